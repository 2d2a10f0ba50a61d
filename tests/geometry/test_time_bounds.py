"""Certified arrival lower bounds (optplan.geometry.timing.time_bounds): analytic, metamorphic
cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from optplan.geometry.timing.motion import mover_pieces
from optplan.geometry.timing.time_bounds import arrival_lower_bound, parked_contact_times
from optplan.problem import parse_problem
from tests.geometry.time_scenes import SQUARE
from tests.geometry.time_scenes import time_scene as _problem


def test_static_bound_is_the_optimum_over_speed():
    b = arrival_lower_bound(_problem([], speed=2.0))
    assert b.value == pytest.approx(4.0, rel=1e-12) and b.static_bound == b.value
    # a disc obstacle on the line: the certified detour, not the straight line
    b = arrival_lower_bound(_problem([], obstacles=[((5, 5), 1.0)]))
    assert b.value > 8.0 + 0.1


def test_mover_parked_on_the_goal_for_a_while():
    # parked on the goal until t = 20, then up at 4 units/s: contact ends when the centres are
    # 0.5 + 0.2 apart, at 20 + 0.7 / 4
    b = arrival_lower_bound(_problem([{"type": "circle", "radius": 0.5,
                                       "waypoints": [[9, 5], [9, 9]], "times": [20, 21]}]))
    assert b.value == pytest.approx(20.175, rel=1e-12) and b.static_bound == 8.0


def test_goal_occupied_for_ever():
    b = arrival_lower_bound(_problem([{"type": "circle", "radius": 0.5, "waypoints": [[9, 5]],
                                       "times": [0]}]))
    assert b.value == math.inf and "for ever" in b.reason


@pytest.mark.parametrize("after, busy", [
    ("loop", [(3.8, 6.2), (13.8, 16.2), (23.8, 26.2)]),     # period 10, passes y = 5 at 5 + 10k
    ("bounce", [(3.8, 6.2), (13.8, 16.2), (23.8, 26.2)]),   # period 20, forth at 5, back at 15
])
def test_repeating_square_over_the_goal(after, busy):
    # a 2 x 2 square moving up x = 9 at 1 unit/s: contact with the parked disc while
    # |y - 5| < 1 + 0.2
    p = _problem([{"type": "polygon", "vertices": SQUARE, "waypoints": [[9, 0], [9, 10]],
                   "times": [0, 10], "after": after}])
    got = parked_contact_times(p.dynamic_obstacles, [9, 5], 0.2, 0.0, 30.0)
    assert np.allclose(got[:3], busy, rtol=0, atol=1e-12)
    assert arrival_lower_bound(p).value == 8.0  # the goal is free at 8


def test_loop_jump_is_not_a_piece():
    p = _problem([{"type": "circle", "radius": 0.5, "waypoints": [[5, 0], [5, 10]],
                   "times": [1, 3], "after": "loop"}])
    ta, tb, b, w = mover_pieces(p.dynamic_obstacles[0], 0.0, 6.0)
    assert ta.tolist() == [0, 1, 3, 5] and tb.tolist() == [1, 3, 5, 7]
    assert np.all(b[1:, 1] == 0) and np.all(w[1:, 1] == 5)  # each period starts at (5, 0)
    v = _problem([{"type": "circle", "radius": 0.5, "waypoints": [[5, 0]],
                   "velocity": [1, 0]}]).dynamic_obstacles[0]
    assert mover_pieces(v, 0.0, 6.0)[1].tolist() == [math.inf]


@pytest.mark.parametrize("scale, shift", [(1.0, (1e3, -2e3)), (1e-3, (0.0, 0.0)),
                                          (1e4, (5e4, 5e4))])
def test_translate_and_scale_space_and_time(scale, shift):
    movers = [{"type": "circle", "radius": 0.5, "waypoints": [[9, 5], [9, 9]],
               "times": [20, 21]}]
    ref = arrival_lower_bound(_problem(movers)).value
    got = arrival_lower_bound(_problem(movers, scale=scale, shift=shift)).value
    assert got == pytest.approx(ref * scale, rel=1e-9)


def test_a_far_mover_changes_nothing():
    movers = [{"type": "circle", "radius": 0.5, "waypoints": [[9, 5], [9, 9]],
               "times": [20, 21]}]
    far = {"type": "circle", "radius": 0.3, "waypoints": [[0.5, 0.5], [0.5, 2.0]],
           "times": [0, 5], "after": "bounce"}
    assert (arrival_lower_bound(_problem(movers + [far])).value
            == arrival_lower_bound(_problem(movers)).value)


def test_a_follower_has_no_goal_bound():
    p = parse_problem({
        "name": "f", "bounds": [0, 0, 20, 20],
        "robots": [{"id": "L", "start": [5, 10], "goal": [15, 10], "radius": 0.2},
                   {"id": "F", "start": [3, 10], "radius": 0.2}],
        "formation": {"leader": "L", "safety_distance": 0.5,
                      "followers": [{"id": "F", "L": 2.0, "phi": 0.0}]}})
    with pytest.raises(ValueError, match="no goal"):
        arrival_lower_bound(p, "F")
    assert arrival_lower_bound(p).value == pytest.approx(10.0)


def test_reference_grades_the_plan_in_time():
    import optplan as op

    movers = [{"type": "circle", "radius": 0.5, "waypoints": [[5, 9.5], [5, 9.0]],
               "times": [0, 1]}]
    p = _problem(movers, speed=2.0)
    res = op.solve(p, "visgraph", reference=True)
    m = res.metrics
    assert m["arrival_time"] == pytest.approx(m["length"] / 2.0, rel=1e-12)
    assert m["time_lower_bound"] == pytest.approx(4.0, rel=1e-12)
    assert m["arrival_ratio_to_lower"] == pytest.approx(m["arrival_time"] / 4.0)
    assert res.status.value == "optimal" and m["arrival_ratio_to_lower"] >= 1 - 1e-12
    static = op.solve(_problem([]), "visgraph", reference=True).metrics
    assert "arrival_time" not in static and "time_lower_bound" not in static


def test_arrival_time_of_a_timed_plan():
    from optplan.geometry.timing.time_bounds import arrival_time

    p = _problem([])
    path = np.array([[1, 5], [5, 5], [9, 5], [9, 5]], float)
    assert arrival_time(p, "r", path, np.array([0.0, 10.0, 20.0, 30.0])) == 20.0
    assert arrival_time(p, "r", path) == pytest.approx(8.0)
    assert arrival_time(p, "r", path[:2]) is None
