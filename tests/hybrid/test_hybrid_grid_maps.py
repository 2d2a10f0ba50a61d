"""The hybrid planner on grid-derived (MovingAI-type) maps (docs/solvers/hybrid.md, "Grid
maps"): its steps are tested exactly, and ``hybrid-guided`` reaches the goal."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen


def test_a_leader_step_through_a_thin_wall_ends_the_run_as_a_collision():
    """Before the step guard the simulator's end-point test missed a point robot stepping
    over a wall thinner than its step, and the hybrid completed its sub-goals through it."""
    prob = _thin_wall()[0]
    local = op.get_solver("sa-apf-paper", eta=0.0)
    res = op.solve(prob, "hybrid-paper", rng=0, local_solver=local,
                   init={"r": np.array([[2.0, 5.0], [8.0, 5.0]])})
    assert res.message.startswith("collision: r's step from"), res.message
    assert "crosses 'wall'" in res.message
    assert res.metrics["static_collisions"] == 0
    assert res.status is not op.Status.solved


@pytest.mark.parametrize("kind,size,kw", [("random", 24, {"density": 0.3}), ("maze", 16, {}),
                                          ("room", 32, {})])
def test_hybrid_guided_reaches_the_goal_validator_accepted(kind, size, kw, tmp_path):
    g = movingai_benchmark(kind, size, tmp_path, rng=np.random.default_rng(5), queries=2,
                           **kw)
    for k, q in enumerate(read_scen(str(g.map_path) + ".scen")):
        res = op.solve(q, "hybrid-guided", rng=k)
        assert res.status in (op.Status.solved, op.Status.optimal), (q.name, res.message)
        assert res.metrics["static_collisions"] == 0


# --------------------------------------------------------------------------------------
# issue 42 items 7 and 8: the default budget, the long-path note, the leader's safe steps
# --------------------------------------------------------------------------------------

#: A map seed the repository's other tests do not use (benchmarks/bench_hybrid_grid.py).
_FRESH = 1001


def _fresh_queries(tmp_path, seed=_FRESH, n=10):
    g = movingai_benchmark("random", 32, tmp_path, rng=np.random.default_rng(seed), queries=n)
    return read_scen(str(g.map_path) + ".scen")


def _thin_wall():
    prob = op.parse_problem({
        "name": "thin-wall", "bounds": [0, 0, 10, 10],
        "robots": [{"id": "r", "start": [2, 5], "goal": [8, 5], "radius": 0.0,
                    "max_speed": 2}],
        "obstacles": [{"type": "rectangle", "name": "wall", "min": [4.97, 3],
                       "max": [5.03, 7]}],
    })
    return prob, {"r": np.array([[2.0, 5.0], [2.0, 9.0], [8.0, 9.0], [8.0, 5.0]])}


@pytest.mark.parametrize("name", ["hybrid-paper", "hybrid-qp", "hybrid-guided"])
def test_every_hybrid_preset_has_a_time_limit_of_60_s(name):
    assert op.get_solver(name).time_limit == 60.0
    assert op.get_solver(name, time_limit=None).time_limit is None


class _Clock:
    """A clock that advances one second per reading: the limit counts reports, not load."""

    def __init__(self):
        self.t = 0.0

    def __call__(self):
        self.t += 1.0
        return self.t


def test_the_time_limit_stops_the_simulation_stage_load_independently(monkeypatch):
    from optplan import solver

    prob, init = _thin_wall()
    monkeypatch.setattr(solver, "clock", _Clock())
    res = op.get_solver("hybrid-paper", time_limit=5.0).solve(
        prob, rng=np.random.default_rng(0), init=init)
    assert res.stop_reason == "time_limit"
    assert res.message.startswith("time limit (5 s) reached after "), res.message
    # the deadline is 6 clock readings away (one at the start): the 5th step's report stops
    assert res.n_iter == 5
    assert res.status is op.Status.approximate  # not at the goal: the honest status


def test_the_time_limit_stops_the_global_stage(monkeypatch):
    from optplan import solver

    monkeypatch.setattr(solver, "clock", _Clock())
    res = op.get_solver("hybrid-paper", time_limit=3.0).solve(
        op.load_problem("paper-hybrid"), rng=np.random.default_rng(0))
    assert res.stop_reason == "time_limit"
    assert res.message == "time limit (3 s) reached during the global stage"
    assert res.status is op.Status.approximate


def test_op_solve_keeps_the_hybrid_stop_reason_and_its_limit_replaces_the_preset(monkeypatch):
    from optplan import solver

    prob, init = _thin_wall()
    monkeypatch.setattr(solver, "clock", _Clock())
    res = op.solve(prob, "hybrid-qp", rng=0, init=init)  # the preset's 60 s
    assert res.stop_reason == "time_limit" and res.options["time_limit"] == 60
    assert res.message.startswith("time limit (60 s) reached after "), res.message
    monkeypatch.setattr(solver, "clock", _Clock())
    res = op.solve(prob, "hybrid-qp", rng=0, init=init, time_limit=7)  # replaces the 60 s
    assert res.stop_reason == "time_limit" and res.options["time_limit"] is None
    assert res.message.startswith("stopped by the time limit after "), res.message
    assert res.n_iter <= 7


def test_a_path_far_longer_than_the_optimum_says_so(tmp_path):
    """Map 1001, line 3: the IPSO path is the optimum, the SA-APF leader's detours between the
    sub-goals make the driven path 3.9 times as long; the status stays ``solved``."""
    q = _fresh_queries(tmp_path)[3]
    res = op.solve(q, "hybrid-qp", rng=3, reference=True)
    assert res.status is op.Status.solved
    ratio = res.metrics["ratio_to_optimum"]
    assert ratio > 3
    assert (f"path {ratio:.1f}x the certified optimum {res.metrics['optimum']:.4g} "
            "(global path 1.00x; the rest is the local planner's detours between sub-goals)"
            ) in res.message


def test_the_leader_stepping_off_the_map_is_a_collision_only_for_the_paper(tmp_path):
    """Map 1001, line 9: eq 34's field has no wall at the map's edge and pushes the leader
    over it at t = 1.2 s; the paper's method ends the run there (the step guard, an honest
    collision), ``hybrid-qp`` slides the step along the edge (``leader_safe_step``) and
    drives on (here for 200 steps)."""
    q = _fresh_queries(tmp_path)[9]
    paper = op.solve(q, "hybrid-paper", rng=9)
    assert paper.message.startswith("collision: r1's step from (28.00, 31.93) to (27.94, 32.01)")
    assert paper.status is op.Status.approximate
    qp = op.solve(q, "hybrid-qp", rng=9, max_steps=200)
    assert qp.message.startswith("step budget (200) exhausted"), qp.message
    assert qp.metrics["static_collisions"] == 0 and qp.metrics["in_bounds"]


def test_hybrid_qp_is_collision_free_on_a_fresh_map(tmp_path):
    """Map 1001 (lines 0-3 and 8, the quick ones): no contact, no step stopped by the guard,
    and every status is what the validator says (benchmarks/bench_hybrid_grid.py runs all)."""
    qs = _fresh_queries(tmp_path)
    for k in (0, 1, 2, 3, 8):
        res = op.solve(qs[k], "hybrid-qp", rng=k, reference=True)
        assert not res.message.startswith("collision"), (k, res.message)
        long = res.success and res.metrics["ratio_to_optimum"] > 3
        assert ("x the certified optimum" in res.message) == long, (k, res.message)
        assert res.metrics["collisions"] == 0 and res.metrics["static_collisions"] == 0
        assert res.success == bool(res.metrics["feasible"] and res.metrics["reached"])
