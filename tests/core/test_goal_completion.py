"""A run accepted inside the goal tolerance is graded on its shortest continuation to the goal
point (optplan.goal_completion): no valid run has a length or arrival ratio below 1."""

from __future__ import annotations

import math

import numpy as np
import pytest

from optplan.geometry.timing import PlanStatus, TimedPlan
from optplan.goal_completion import completion_length
from optplan.problem import parse_problem
from optplan.solver import time_reference
from optplan.time_grading import grade_robot
from tests.geometry.time_scenes import time_scene

#: a mover far from everything: the grading in time runs, nothing is in the way
FAR = {"type": "circle", "radius": 0.1, "waypoints": [[1, 9], [2, 9]], "times": [0, 1]}
#: the robot (radius 0.2, goal tolerance 0.2) stops 0.2 short of its goal (9, 5)
SHORT = np.array([[1.0, 5.0], [8.8, 5.0]])


def _fixed(arrival: float):
    """A reference planner that answers ``arrival`` whatever the problem."""
    return lambda problem, rid: TimedPlan(PlanStatus.arrived, arrival, None, None, "fixed")


def test_a_run_that_stops_short_is_graded_at_the_goal_point():
    p = time_scene([FAR])
    g = grade_robot(p, "r", SHORT, reference=time_reference)
    assert g["arrival_time"] == pytest.approx(7.8, rel=1e-12)  # accepted inside the tolerance
    assert g["arrival_completion"] == pytest.approx(0.2, rel=1e-12)
    assert g["arrival_at_goal"] == pytest.approx(8.0, rel=1e-12)
    assert g["arrival_completion_status"] == "completed"
    # the references are for the goal point: the straight line at full speed is optimal
    assert g["time_lower_bound"] == pytest.approx(8.0, rel=1e-12)
    assert g["arrival_ratio_to_lower"] == pytest.approx(1.0, abs=1e-9)
    assert g["arrival_ratio_to_reference"] >= 1.0 - 1e-9
    assert completion_length(p, "r", SHORT) == pytest.approx(0.2, rel=1e-12)


def test_a_run_on_the_goal_point_is_graded_as_it_is():
    p = time_scene([FAR])
    g = grade_robot(p, "r", np.array([[1.0, 5.0], [9.0, 5.0]]))
    assert g["arrival_completion"] == 0.0 and g["arrival_completion_status"] == "at goal"
    assert g["arrival_at_goal"] == g["arrival_time"] == pytest.approx(8.0, rel=1e-12)


def test_an_unreached_run_is_not_completed():
    p = time_scene([FAR])
    assert completion_length(p, "r", np.array([[1.0, 5.0], [5.0, 5.0]])) is None
    g = grade_robot(p, "r", np.array([[1.0, 5.0], [5.0, 5.0]]))
    assert g["arrival_time"] is None and "arrival_at_goal" not in g


def test_a_wall_inside_the_tolerance_is_walked_around():
    """A goal tolerance of 2 around (9, 5) with a wall between the run's end (7.2, 5) and the
    goal: the continuation is the exact shortest path around the wall, longer than the gap."""
    p = parse_problem({
        "name": "wall", "bounds": [0, 0, 10, 10], "goal_tolerance": 2.0,
        "robots": [{"id": "r", "start": [1, 5], "goal": [9, 5], "radius": 0.2}],
        "obstacles": [{"type": "polygon", "vertices": [[7.8, 3], [8.2, 3], [8.2, 7], [7.8, 7]]}]})
    path = np.array([[1.0, 5.0], [7.2, 5.0]])
    done = completion_length(p, "r", path)
    assert done is not None and done > 1.8 + 0.5
    optimum = completion_length(p, "r", np.array([[1.0, 5.0]] * 2))  # None: not inside
    assert optimum is None
    from optplan.solver import reference_optimum

    opt = reference_optimum(p)["optimum"]
    assert 6.2 + done >= opt - 1e-9


def test_a_continuation_that_meets_a_mover_is_not_graded():
    """A small disc crosses y = 5 at x = 9.2 at t = 8: it misses the robot waiting at (8.8, 5)
    and meets it on the continuation (at (9, 5) at t = 8, 0.2 apart, radii 0.2 + 0.05)."""
    crosser = {"type": "circle", "radius": 0.05, "waypoints": [[9.2, 2], [9.2, 8]],
               "times": [5, 11]}
    p = time_scene([crosser])
    g = grade_robot(p, "r", SHORT, reference=_fixed(20.0))
    assert g["arrival_time"] == pytest.approx(7.8, rel=1e-12)
    assert g["arrival_at_goal"] is None
    assert "continuation" in g["arrival_completion_status"] and "meets" in (
        g["arrival_completion_status"])
    assert g["arrival_ratio_to_reference"] is None and g["arrival_ratio_to_lower"] is None
    assert "time_reference_source" not in g  # an unverified arrival replaces nothing


def test_a_valid_plan_earlier_than_the_reference_replaces_it():
    p = time_scene([FAR])
    g = grade_robot(p, "r", SHORT, reference=_fixed(9.5))
    assert g["time_reference"] == pytest.approx(8.0, rel=1e-12)
    assert "this plan" in g["time_reference_source"]
    assert g["arrival_ratio_to_reference"] == 1.0
    # a reference that is earlier (cached per problem: a fresh one)
    later = grade_robot(time_scene([FAR]), "r", SHORT, reference=_fixed(7.9))
    assert later["time_reference"] == 7.9 and "time_reference_source" not in later
    assert later["arrival_ratio_to_reference"] == pytest.approx(8.0 / 7.9)


def test_an_invalid_plan_replaces_nothing():
    crosser = {"type": "circle", "radius": 0.3, "waypoints": [[5, 2], [5, 8]], "times": [1, 7]}
    p = time_scene([crosser])
    g = grade_robot(p, "r", SHORT, reference=_fixed(30.0))
    assert g["time_reference"] == 30.0 and "not valid" in g["arrival_completion_status"]


@pytest.mark.parametrize("scale,shift", [(1.0, (0.0, 0.0)), (1e-3, (5e3, -2e3)),
                                         (1e3, (-1e5, 3e4)), (7.0, (0.5, 0.25))])
def test_completion_is_invariant_under_translation_and_scaling(scale, shift):
    p = time_scene([FAR], scale=scale, shift=shift)
    path = SHORT * scale + np.array(shift)
    g = grade_robot(p, "r", path)
    tol = 1e-9 * 10 * scale  # relative to the map's extent (the input is rounded there)
    assert g["arrival_completion"] == pytest.approx(0.2 * scale, abs=tol)
    assert g["arrival_at_goal"] == pytest.approx(8.0 * scale, abs=tol)
    assert g["arrival_ratio_to_lower"] == pytest.approx(1.0, abs=1e-9)
    assert math.isclose(completion_length(p, "r", path), 0.2 * scale, abs_tol=tol)


def test_the_length_is_graded_to_the_goal_point():
    """``solve(..., reference=True)``: a path that stops 0.2 short of the goal on an empty map
    is graded on ``length + 0.2``: ratio 1, not 7.8 / 8."""
    import optplan as op
    from optplan.solver import reference_optimum, with_reference

    p = time_scene([])
    m = with_reference({"length": 7.8}, p, {"r": SHORT}, reference_optimum(p))
    assert m["goal_completion"] == pytest.approx(0.2, rel=1e-12)
    assert m["length_to_goal"] == pytest.approx(8.0, rel=1e-12)
    assert m["ratio_to_optimum"] == pytest.approx(1.0, abs=1e-12)
    # a run on the goal point: nothing added
    on = op.solve(p, "visgraph", reference=True).metrics
    assert "goal_completion" not in on and on["ratio_to_optimum"] == pytest.approx(1.0)
