"""The team reference (optplan.team_grading): a front of known team plans per problem, the rule
that no valid plan scores below 1, the certified lower bound, formation-nlp's time limit.

The candidates here come from a cheap ``formation-nlp`` (few grid steps, few iterations: the
rule holds whatever the front); one test goes through ``op.solve(reference="team")`` and the
preset found by name.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

import optplan as op
import optplan.solver as solver_mod
from optplan.cli import main as cli_main
from optplan.generators import formation_scene
from optplan.team_grading import (
    TeamFront,
    TeamPoint,
    grade_team,
    team_front,
    with_team_reference,
)
from tests.formation.test_formation_nlp import _straight, _team

#: the team heuristics graded (their rng=0 runs are candidates: other seeds are graded too)
HEURISTICS = ("formation-qp", "leader-follower-paper", "hybrid-qp", "orca-team")
DISC = [{"type": "circle", "center": [50, 50], "radius": 4.0}]


def _cheap(problem: op.Problem) -> dict[str, op.Result]:
    """The reference's candidates with a 20-step NLP (deterministic: no time limit)."""
    return op.get_solver("formation-nlp", n_steps=20, time_limit=None).team_candidates(problem)


def _rough(problem: op.Problem) -> dict[str, op.Result]:
    """The candidates with a 10-step NLP stopped after 15 iterations (cheap on big scenes)."""
    return op.get_solver("formation-nlp", n_steps=10, max_iter=15,
                         time_limit=None).team_candidates(problem)


@pytest.fixture(scope="module")
def disc() -> op.Problem:
    """A leader and two followers passing a disc (one problem object: the front is cached)."""
    return _team(obstacles=DISC)


def _graded(problem: op.Problem, res: op.Result, reference=_cheap) -> dict:
    return with_team_reference(res.metrics, problem, res, reference)


def test_the_reference_does_not_change_with_the_plan():
    p = _team(obstacles=DISC)
    a = op.solve(p, "formation-qp", rng=1, reference="team")  # the preset, found by name
    b = op.solve(p, "orca-team", rng=0, reference="team")
    ma, mb = a.metrics, b.metrics
    assert ma["team_reference_status"] == mb["team_reference_status"] == "solved"
    assert ma["team_reference_message"] == mb["team_reference_message"]
    assert mb["reference_time"] < ma["reference_time"]  # built once, cached on the problem
    front = team_front(p, solver_mod.team_reference)
    for m in (ma, mb):
        assert m["team_arrival_reference"] in [f.arrival for f in front.members] + [
            m["team_arrival"]]
        assert m["arrival_ratio_to_team"] >= 1 and m["formation_rmse_ratio_to_team"] >= 1


def test_a_plan_whose_nlp_keeps_it_no_longer_scores_one(disc):
    plan = op.solve(disc, "leader-follower-paper", rng=0)
    # the old reference, the NLP warm-started from the plan itself, keeps it here (IPOPT stopped
    # after 2 iterations): the plan scored 1.0 by construction
    old = op.get_solver("formation-nlp", n_steps=20, max_iter=2).reference(disc, plan)
    assert old.extras.get("kept_warm_start")
    m = _graded(disc, plan)
    assert m["team_plan_valid"]
    assert m["arrival_ratio_to_team"] > 1.1  # the NLP from another warm start is earlier
    assert m["team_arrival_reference_source"].startswith("formation-nlp from ")


@pytest.mark.parametrize("scene", ["paper-formation", "random"])
def test_no_valid_plan_scores_below_one(scene):
    p = (op.load_problem(scene) if scene != "random" else
         formation_scene(3, "wedge", distance=120.0, obstacles=4, seed=3))
    cands = _rough(p)  # the heuristics' rng=0 plans and the NLP from each: graded too
    plans = [*cands.values(), *(op.solve(p, h, rng=1) for h in HEURISTICS)]
    bound = None
    n_valid = 0
    for res in plans:
        m = _graded(p, res, lambda problem: cands)
        bound = m["team_arrival_lower_bound"]
        if not m["team_plan_valid"]:
            continue
        n_valid += 1
        assert m["arrival_ratio_to_team"] >= 1 and m["formation_rmse_ratio_to_team"] >= 1
        assert m["team_arrival"] >= bound and m["arrival_ratio_to_team_lower"] >= 1
    assert n_valid >= 4 and bound is not None and bound > 0


def test_the_lower_bound_is_the_static_optimum_over_max_speed(disc):
    # the leader (radius 1, speed 2) from (20, 50) to (80, 50) round a disc of radius 4: two
    # tangents from 30 away to the inflated circle (radius 5) and the arc between them
    d, r = 30.0, 5.0
    length = 2 * math.sqrt(d * d - r * r) + r * (math.pi - 2 * math.acos(r / d))
    front = team_front(disc, _cheap)
    for source, res in _cheap(disc).items():
        m = grade_team(disc, res, front)
        assert m["team_arrival_lower_bound"] == pytest.approx(length / 2.0, rel=1e-9)
        assert m["team_arrival_lower_bound_reason"] == "static optimum / max_speed"
        if m["team_plan_valid"]:
            assert m["team_arrival"] >= m["team_arrival_lower_bound"], source


def test_a_valid_plan_better_than_the_front_replaces_it(disc):
    slow = op.solve(disc, "leader-follower-paper", rng=0)
    nlp = op.get_solver("formation-nlp", n_steps=20).reference(disc, slow)
    assert nlp.success and nlp.metrics["feasible"]

    def only_the_heuristic(problem: op.Problem) -> dict[str, op.Result]:
        return {"leader-follower-paper": slow}

    m = _graded(disc, nlp, only_the_heuristic)
    assert m["team_arrival_reference_source"] == "this plan"  # earlier than the front
    assert m["arrival_ratio_to_team"] == 1.0
    # the heuristic itself against the front that holds the NLP's plan only: beaten on arrival
    m = _graded(disc, slow, lambda problem: {"nlp": nlp})
    assert m["arrival_ratio_to_team"] > 1.1
    # a plan the validator rejects does not join the front: straight through the disc, kept
    bad = op.solve(disc, "formation-nlp", init=_straight(disc), n_steps=10, max_iter=1)
    assert bad.metrics["collisions"] > 0
    m = _graded(disc, bad, lambda problem: {"nlp": nlp})
    assert not m["team_plan_valid"] and m["team_arrival"] < nlp.cost  # earlier, not valid
    # no front member arrives as early, or keeps the formation as well: no reference
    assert m["team_reference_source"] is None and m["arrival_ratio_to_team"] is None


def test_the_front_keeps_the_non_dominated_points_and_grades_by_the_rule(disc):
    res = op.solve(disc, "orca-team", rng=0)
    me = grade_team(disc, res, TeamFront((), ()))  # no front: the plan is its own reference
    a, e = me["team_arrival"], res.metrics["formation_rmse"]
    assert me["team_reference_source"] == "this plan"
    assert me["team_reference_status"] == "no valid candidate"
    fast = TeamPoint("fast", 0.5 * a, 2 * e, 1.0, True)
    tidy = TeamPoint("tidy", 2 * a, 0.5 * e, 3.0, True)
    best = TeamPoint("best", 0.9 * a, 0.9 * e, 2.0, True)
    front = TeamFront((fast, best, tidy), ())
    m = grade_team(disc, res, front)
    assert m["team_arrival_reference_source"] == "best"  # fast keeps the formation worse
    assert m["arrival_ratio_to_team"] == pytest.approx(1 / 0.9)
    assert m["formation_rmse_ratio_to_team"] == pytest.approx(1 / 0.9)  # tidy is too late
    assert m["team_min_separation_reference"] == 2.0
    # within the tolerance (0.1 %) a member's RMSE is no worse than the plan's
    near = TeamPoint("near", 0.8 * a, e * (1 + 5e-4), 2.0, True)
    m = grade_team(disc, res, TeamFront((near,), ()))
    assert m["team_arrival_reference_source"] == "near"
    assert m["team_formation_rmse_reference_source"] == "this plan"
    assert m["team_reference_source"] == "arrival: near; formation rmse: this plan"
    # RMSEs below 0.1 % of the mean slot distance are ties: both sides of the ratio floored
    tiny = dataclasses.replace(res, metrics={**res.metrics, "formation_rmse": 1e-6})
    exact = TeamPoint("exact", 0.9 * a, 0.0, 2.0, True)
    m = grade_team(disc, tiny, TeamFront((exact,), ()))
    assert m["team_formation_rmse_reference_source"] == "exact"
    assert m["formation_rmse_ratio_to_team"] == 1.0


def test_the_front_drops_dominated_and_invalid_candidates(disc):
    front = team_front(disc, _cheap)
    pts = [(c.arrival, c.rmse) for c in front.candidates if c.valid]
    for m in front.members:
        assert m.valid
        assert not any(a <= m.arrival and e <= m.rmse and (a, e) != (m.arrival, m.rmse)
                       for a, e in pts)
    assert [m.arrival for m in front.members] == sorted(m.arrival for m in front.members)
    assert len(front.candidates) == 2 * len(HEURISTICS)


class _Ticks:
    """A clock that advances one second at every reading."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        self.t += 1.0
        return self.t


def test_the_time_limit_stops_ipopt_under_a_replaced_clock(disc, monkeypatch):
    monkeypatch.setattr(solver_mod, "clock", _Ticks())
    nlp = op.get_solver("formation-nlp", n_steps=20, time_limit=5.0)
    res = nlp.solve(disc, init=_straight(disc))
    assert res.stop_reason == "time_limit"
    assert res.message.startswith("time limit (5 s) reached")
    # IPOPT stopped at its first iteration past the deadline (the readings: the start, then
    # one per iteration); its iterate still collides, so the warm start is kept
    iterations = re.search(r"User_Requested_Stop, (\d+) iterations", res.message)
    assert iterations is not None and int(iterations.group(1)) <= 5
    assert res.extras.get("kept_warm_start")
    # stopped while the warm-start planner runs: its plan is returned as it is
    res = op.get_solver("formation-nlp", n_steps=20, time_limit=5.0).solve(
        disc, rng=np.random.default_rng(0))
    assert res.stop_reason == "time_limit"
    assert "the warm start (hybrid-qp) was stopped by the time limit (5 s)" in res.message
    # none: no limit (the clock jumps past any deadline)
    res = op.get_solver("formation-nlp", n_steps=20, time_limit=None).solve(
        disc, init=_straight(disc))
    assert res.stop_reason == "" and "locally optimal" in res.message
    # none, and the warm-start planner's own (hybrid-qp: 60 s) is lifted too: it runs to its
    # end, and the run polishes it
    res = op.get_solver("formation-nlp", n_steps=20, time_limit=None).solve(
        disc, rng=np.random.default_rng(0))
    assert res.stop_reason == "" and "stopped" not in res.message
    assert "locally optimal" in res.message


def test_the_time_limit_is_an_option(capsys):
    assert op.get_solver("formation-nlp").time_limit == 60.0  # type: ignore[attr-defined]
    assert cli_main(["show-solver", "formation-nlp"]) == 0
    assert "time_limit" in capsys.readouterr().out
    with pytest.raises(ValueError, match="time_limit"):
        op.get_solver("formation-nlp", time_limit=0.0)
