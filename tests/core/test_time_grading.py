"""Grading a plan in time (optplan.time_grading through ``op.solve(..., reference=True)``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.cli.app import main as cli_main
from optplan.problem import parse_problem
from optplan.time_grading import grade_robot
from tests.geometry.time_scenes import time_scene

#: a disc of radius 0.3 crossing y = 5 upwards at x = 5 at t = 4, when a robot driving the
#: straight line at speed 1 would be there: the fastest timing of that line waits
#: sqrt(2) (0.3 + 0.2) s (tests/geometry/test_schedule.py derives it)
CROSSER = {"type": "circle", "radius": 0.3, "waypoints": [[5, 2], [5, 8]], "times": [1, 7]}
WAIT = math.sqrt(2) * 0.5


def test_a_geometric_plan_is_graded_against_every_reference():
    p = time_scene([CROSSER])
    res = op.solve(p, "visgraph", reference=True)
    m = res.metrics
    assert m["arrival_time"] == pytest.approx(8.0, rel=1e-12)  # timed at max_speed
    assert m["collisions"] == 1 and res.status.value == "approximate"
    # the same straight line, timed at best: it waits for the crosser
    assert m["schedule_status"] == "scheduled"
    assert m["schedule_arrival"] == pytest.approx(8.0 + WAIT, rel=1e-9)
    assert m["arrival_ratio_to_schedule"] == pytest.approx(8.0 / (8.0 + WAIT), rel=1e-9)
    # sipp may leave the line; it is never later than this path's best timing, never earlier
    # than the certified bound
    assert m["time_lower_bound"] == pytest.approx(8.0, rel=1e-12)
    assert 8.0 - 1e-9 <= m["time_reference"] <= m["schedule_arrival"] + 1e-9
    assert m["arrival_ratio_to_reference"] == pytest.approx(8.0 / m["time_reference"])
    assert "time_per_robot" not in m


def test_reference_time_counts_the_grading_in_time():
    """The certified optimum is cached per problem (0 s the second time), the grading in time
    is not: ``reference_time`` holds its cost, so ``wall_time + reference_time`` is the call."""
    p = time_scene([CROSSER])
    op.solve(p, "visgraph", reference=True)
    again = op.solve(p, "visgraph", reference=True).metrics
    assert again["reference_time"] > 0.0 and again["schedule_status"] == "scheduled"
    static = time_scene([])
    op.solve(static, "visgraph", reference=True)
    assert op.solve(static, "visgraph", reference=True).metrics["reference_time"] == 0.0


def test_no_moving_obstacle_no_grading_in_time():
    m = op.solve(time_scene([]), "visgraph", reference=True).metrics
    assert not {"arrival_time", "schedule_arrival", "time_reference"} & set(m)


def test_a_path_through_a_static_obstacle_has_no_schedule():
    p = time_scene([CROSSER], obstacles=[((5, 5), 1.0)])
    g = grade_robot(p, "r", np.array([[1.0, 5.0], [9.0, 5.0]]))
    assert g["schedule_arrival"] is None and g["schedule_status"] == "invalid"
    assert "static obstacle" in g["schedule_message"]
    assert g["arrival_ratio_to_schedule"] is None


def test_a_timed_plan_is_scheduled_up_to_its_arrival():
    # a plan that waits 3 s at the start, reaches the goal at t = 11 and stays: its arrival is
    # 11, the fastest timing of its path (the line) waits only as long as the crosser demands
    p = time_scene([CROSSER])
    times = np.array([0.0, 3.0, 11.0, 12.0])
    path = np.array([[1.0, 5.0], [1.0, 5.0], [9.0, 5.0], [9.0, 5.0]])
    g = grade_robot(p, "r", path, times)
    assert g["arrival_time"] == pytest.approx(11.0)
    assert g["schedule_arrival"] == pytest.approx(8.0 + WAIT, rel=1e-9)


def _team() -> op.Problem:
    return parse_problem({
        "name": "team-in-time", "bounds": [0, 0, 40, 20],
        "robots": [{"id": "L", "start": [5, 10], "goal": [30, 10], "radius": 0.3,
                    "max_speed": 2.0},
                   {"id": "F", "start": [3, 10], "radius": 0.3, "max_speed": 2.0}],
        "formation": {"leader": "L", "safety_distance": 1.0,
                      "followers": [{"id": "F", "L": 2.0, "phi": 2.5}]},
        "dynamic_obstacles": [{"type": "circle", "radius": 0.5,
                               "waypoints": [[20, 2], [20, 18]], "times": [0, 16],
                               "after": "bounce"}]})


def test_every_robot_of_a_team_is_graded():
    res = op.solve(_team(), "leader-follower-paper", rng=0, reference=True)
    per = res.metrics["time_per_robot"]
    assert set(per) == {"L", "F"}
    assert per["L"]["arrival_time"] == res.metrics["arrival_time"]
    assert per["L"]["time_reference"] is not None and "time_reference" not in per["F"]
    for g in per.values():
        if g["schedule_arrival"] is not None and g["arrival_time"] is not None:
            # no timing of a path beats its best timing (up to the plan's own stamps)
            assert g["schedule_arrival"] <= g["arrival_time"] + 1e-6


def test_optplan_solve_prints_the_grades_in_time(capsys):
    # paper-warehouse has moving obstacles; visgraph's path is not scheduled (it crosses a
    # temporary obstacle), so the schedule line says why
    assert cli_main(["solve", "paper-warehouse", "visgraph"]) == 0
    out = capsys.readouterr().out
    assert "arrival" in out and "ratio to reference" in out and "ratio to lower bound" in out
    assert "schedule: the path crosses a static obstacle" in out
