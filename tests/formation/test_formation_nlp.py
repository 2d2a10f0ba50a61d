"""The team trajectory NLP (preset formation-nlp): analytic cases, a squeeze, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.formation.slots import slot_positions
from optplan.problem import parse_problem

L, PHI = 10.0, math.pi / 4
HEADING = 0.0


def _team(obstacles=(), movers=(), safety=3.0, followers=None, start=(20.0, 50.0),
          goal=(80.0, 50.0)) -> op.Problem:
    """A leader from ``start`` to ``goal`` (east), two followers at their slots at the start."""
    slots = slot_positions(np.array(start), HEADING, np.array([L, L]), np.array([PHI, -PHI]))
    fol = followers if followers is not None else [
        {"id": "f1", "L": L, "phi": PHI}, {"id": "f2", "L": L, "phi": -PHI}]
    return parse_problem({
        "name": "nlp-team", "bounds": [0, 0, 100, 100],
        "robots": [{"id": "leader", "start": list(start), "goal": list(goal), "radius": 1.0,
                    "max_speed": 2.0},
                   {"id": "f1", "start": slots[0].tolist(), "radius": 1.0, "max_speed": 2.0},
                   {"id": "f2", "start": slots[1].tolist(), "radius": 1.0, "max_speed": 2.0}],
        "formation": {"leader": "leader", "safety_distance": safety, "followers": fol},
        "obstacles": list(obstacles), "dynamic_obstacles": list(movers)})


def _straight(p: op.Problem) -> dict[str, np.ndarray]:
    """Every robot on the straight translation of the leader's line."""
    d = p.leader.goal - p.leader.start
    return {r.id: np.stack([r.start, r.start + d]) for r in p.robots}


def test_empty_map_straight_formation_at_full_speed():
    p = _team()
    res = op.solve(p, "formation-nlp", init=_straight(p), n_steps=20)
    assert res.status.value == "solved" and "locally optimal" in res.message
    assert res.cost == pytest.approx(60.0 / 2.0, rel=1e-5)
    assert not res.extras.get("kept_warm_start")
    assert res.metrics["formation_rmse"] <= 1e-3 * L  # the documented tolerance
    assert res.metrics["collisions"] == 0 and res.metrics["reached"]
    for rid, path in res.paths.items():  # straight lines
        d = path - path[0]
        assert np.max(np.abs(d[:, 1])) < 1e-4, rid


def test_a_formation_squeezes_through_a_gap_narrower_than_itself():
    # two walls leave a gap of 8 at x = 50 (the formation is 2 L sin(pi/4) = 14 wide)
    walls = [{"type": "rectangle", "min": [48, 0], "max": [52, 46]},
             {"type": "rectangle", "min": [48, 54], "max": [52, 100]}]
    p = _team(obstacles=walls)
    # 30 steps: the same squeeze through the gap as 40, in a fraction of the time
    res = op.solve(p, "formation-nlp", init=_straight(p), n_steps=30)
    m = res.metrics
    assert res.status.value == "solved" and "locally optimal" in res.message, res.message
    assert m["collisions"] == 0 and m["feasible"] and m["reached"]
    assert m["formation_rmse"] > 0.1  # it had to leave the slots to get through
    assert m["min_separation"] >= 3.0 - 1e-6


def test_a_moving_obstacle_is_avoided_in_continuous_time():
    mover = {"type": "circle", "radius": 2.0, "waypoints": [[50, 90], [50, 10]],
             "times": [0, 25], "after": "bounce"}
    p = _team(movers=[mover])
    res = op.solve(p, "formation-nlp", init=_straight(p), n_steps=40)
    assert res.metrics["dynamic_contacts"] == 0
    assert res.status.value == "solved"


def test_warm_start_is_never_beaten_by_a_worse_plan():
    # from hybrid-qp (the default warm start): the NLP's plan or the warm start, never worse
    p = _team()
    warm = op.solve(p, "hybrid-qp", rng=0)
    res = op.solve(p, "formation-nlp", rng=0, n_steps=20)
    assert res.status.value == "solved"
    assert res.cost <= res.extras["warm_arrival"] * (1 + 1e-9)
    assert res.metrics["formation_rmse"] <= warm.metrics["formation_rmse"] + 1e-3 * L


def test_bad_inputs_give_a_clear_status():
    solo = parse_problem({"name": "solo", "bounds": [0, 0, 10, 10],
                          "robots": [{"id": "r", "start": [1, 1], "goal": [9, 9], "radius": 0.1}]})
    res = op.solve(solo, "formation-nlp")
    assert res.status.value == "failed" and "no formation" in res.message
    # a safety distance the slots cannot keep (L = 10, the followers 14 apart, 40 required)
    p = _team(safety=40.0)
    res = op.solve(p, "formation-nlp", init=_straight(p), n_steps=10)
    assert res.status.value != "solved" or "kept the warm start" in res.message
    # a follower slot inside an obstacle along the whole way: the followers cannot keep it
    wall = [{"type": "rectangle", "min": [30, 58], "max": [90, 62]}]
    p = _team(obstacles=wall)
    res = op.solve(p, "formation-nlp", init=_straight(p), n_steps=10)
    assert res.metrics["static_collisions"] == 0 or res.status.value != "solved"
    with pytest.raises(ValueError, match="n_steps"):
        op.get_solver("formation-nlp", n_steps=1)
    with pytest.raises(ValueError, match="warm_start = 'no-such-planner': not a solver"):
        op.get_solver("formation-nlp", warm_start="no-such-planner")
    with pytest.raises(ValueError, match="cannot start from itself"):
        op.get_solver("formation-nlp", warm_start="formation-nlp")


def test_callback_stops_ipopt_and_keeps_a_valid_plan():
    """A callback that asks to stop ends IPOPT at once (it used to run to convergence past
    ``time_limit``); the judged result stays a valid team plan."""
    seen = []

    def stop_after_three(p):
        if "objective" in p.info:
            seen.append(p.iteration)
            if p.iteration >= 3:
                raise StopIteration

    res = op.solve("formation-open-field", "formation-nlp", rng=0, callback=stop_after_three)
    assert seen == [1, 2, 3]
    assert res.stop_reason == "callback"
    assert "User_Requested_Stop" in res.message
    assert res.status is op.Status.solved and res.metrics["feasible"]


def test_an_exception_of_the_callback_inside_ipopt_propagates():
    def boom(p):
        if "objective" in p.info:
            raise KeyError("boom")

    with pytest.raises(KeyError, match="boom"):
        op.solve("formation-open-field", "formation-nlp", rng=0, callback=boom)


@pytest.mark.parametrize("limit", [None, 600.0])
def test_the_runs_limit_bounds_the_warm_start_not_its_preset(monkeypatch, limit):
    """The warm start (hybrid-qp, whose preset stops at 60 s) runs without its own limit: the
    run's ``time_limit`` bounds it (a run of 600 s is never cut at 60 s by the warm start),
    also when ``op.solve(time_limit=...)`` replaces the preset's; none means none."""
    from optplan.formation import formation_nlp

    seen = []
    real = formation_nlp.without_own_limit

    def spy(backend, own):
        out = real(backend, own)
        seen.append((backend.time_limit, out.time_limit))
        return out

    def stop(p):  # at the warm start's first report: only the set-up is looked at
        raise StopIteration

    monkeypatch.setattr(formation_nlp, "without_own_limit", spy)
    kw = {} if limit is None else {"time_limit": limit}
    op.solve("formation-open-field", "formation-nlp", rng=0, callback=stop, **kw)
    op.solve("formation-open-field", op.get_solver("formation-nlp", time_limit=limit), rng=0,
             callback=stop)
    assert seen == [(60.0, None), (60.0, None)]
