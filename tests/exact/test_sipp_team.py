"""Prioritised ``sipp`` with several robots: every robot holds its goal until the team ends."""

from __future__ import annotations

import pytest

import optplan as op
from optplan.exact.sipp import earliest_arrival
from optplan.problem import parse_problem


def _team(mover: dict) -> op.Problem:
    """Robot ``a`` reaches its goal (5, 2) in about 4 s, robot ``b`` its goal (19, 8) in about
    18 s; ``mover`` is the one moving obstacle."""
    return parse_problem({
        "name": "hold", "bounds": [0, 0, 20, 10],
        "robots": [{"id": "a", "start": [1, 2], "goal": [5, 2], "radius": 0.3},
                   {"id": "b", "start": [1, 8], "goal": [19, 8], "radius": 0.3}],
        "dynamic_obstacles": [mover]})


#: a disc coming down x = 5 after a's arrival: over a's goal at about t = 11
CROSSER = {"type": "circle", "radius": 0.5, "waypoints": [[5, 9.5], [5, 0.5]],
           "times": [6, 12]}


def test_a_robot_that_arrives_first_holds_its_goal_until_the_team_ends():
    p = _team(CROSSER)
    alone = earliest_arrival(p, "a")
    assert alone.arrival == pytest.approx(4.0, rel=1e-9)  # alone it need only arrive
    res = op.solve(p, "sipp")
    m = res.metrics
    assert res.status is op.Status.solved and m["collisions"] == 0, res.message
    arr = {rid: e["arrival"] for rid, e in res.extras["sipp"].items()}
    # a arrives after the crosser has passed its goal (the disc is clear of it after
    # t = 6 + 6 (9.5 - 2 + 0.8) / 9 = 11.53), and holds it while b is on its way
    assert arr["a"] >= 11.53 - 1e-6 and arr["b"] > arr["a"]
    assert "holding its goal until the team ends" in res.message


def test_arriving_only_would_collide():
    """Without the hold (each robot planned to arrive only) the crosser runs over a at its
    goal: what the hold prevents (the validator's contact, from the same plans)."""
    p = _team(CROSSER)
    a = earliest_arrival(p, "a")
    m = op.evaluate(p, {"a": a.path}, a.times)
    assert m["collisions"] == 0  # a alone stops at t = 4: the contact comes while it holds
    held = op.evaluate(p, {"a": a.path[[0, -1, -1]]}, [0.0, a.arrival, 18.0])
    assert held["dynamic_contacts"] == 1


def test_a_robot_that_cannot_hold_its_goal_says_so():
    """A disc parks on a's goal for ever from t = 10, before b arrives: a cannot hold it."""
    parker = {"type": "circle", "radius": 0.5, "waypoints": [[10, 2], [5, 2]], "times": [5, 10]}
    res = op.solve(_team(parker), "sipp")
    assert res.status is op.Status.failed
    assert "a: no arrival that holds the goal until" in res.message


def test_one_robot_need_only_arrive():
    p = parse_problem({
        "name": "one", "bounds": [0, 0, 20, 10],
        "robots": [{"id": "a", "start": [1, 2], "goal": [5, 2], "radius": 0.3}],
        "dynamic_obstacles": [CROSSER]})
    res = op.solve(p, "sipp")
    assert res.status is op.Status.optimal and res.metrics["arrival_time"] == pytest.approx(4.0)
