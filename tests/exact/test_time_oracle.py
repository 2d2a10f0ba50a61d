"""Self-tests of the brute-force time oracle (tests/exact/time_oracle.py) on hand-derived cases.

Every expected arrival is derived in a comment.  Conventions: the robot (radius ``r``) drives
along the straight line ``y = 5`` from ``x = 1`` to ``x = 9`` (``S = 8``) at speed ``<= 1``
unless stated otherwise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from optplan.problem import parse_problem
from tests.exact.time_oracle import (
    check_trajectory,
    clearance,
    grid_earliest_arrival,
    grid_schedule,
    mover_breakpoints,
    mover_max_speed,
    mover_position,
    polygon_distance,
)

START, GOAL = [1.0, 5.0], [9.0, 5.0]
LINE = np.array([START, GOAL])


def scene(*movers: dict, radius: float = 0.2, max_speed: float = 1.0):
    return parse_problem({
        "name": "oracle",
        "bounds": [0, 0, 10, 10],
        "robots": [{"id": "r", "start": START, "goal": GOAL, "radius": radius,
                    "max_speed": max_speed}],
        "dynamic_obstacles": list(movers),
    })


# ----------------------------------------------------------------------------------------------
# (d) motion model: hold, loop (jump, right-continuous), bounce, velocity, parked
# ----------------------------------------------------------------------------------------------
TRACK = {"type": "circle", "radius": 0.5, "waypoints": [[0, 0], [2, 0], [2, 2]],
         "times": [1, 2, 4]}  # t0 = 1, P = 3


def one(after: str):
    return scene({**TRACK, "after": after}).dynamic_obstacles[0]


@pytest.mark.parametrize(("after", "cases"), [
    # before t0 and on [t0, t_n] the three agree; after t_n:
    ("hold", [(-3, (0, 0)), (1, (0, 0)), (1.5, (1, 0)), (2, (2, 0)), (3, (2, 1)), (4, (2, 2)),
              (4.5, (2, 2)), (100, (2, 2))]),
    # loop: period 3, at t0 + kP = 4, 7, ... the first waypoint (right-continuous jump);
    # t = 4.5 is t - P = 1.5 -> (1, 0); t = 6.5 is t - P = 3.5 -> (2, 1.5); t = 7 jump again
    ("loop", [(-3, (0, 0)), (1.5, (1, 0)), (3, (2, 1)), (4, (0, 0)), (4.5, (1, 0)),
              (5, (2, 0)), (6.5, (2, 1.5)), (7, (0, 0)), (7 + 3e3, (0, 0)), (8.5, (2, 0.5))]),
    # bounce: period 6; on [4, 7] backwards: tau = 8 - t; on [7, 10] forwards: tau = t - 6
    ("bounce", [(-3, (0, 0)), (3, (2, 1)), (4, (2, 2)), (5, (2, 1)), (6, (2, 0)),
                (6.5, (1, 0)), (7, (0, 0)), (7.5, (1, 0)), (9, (2, 1)), (10, (2, 2)),
                (11, (2, 1)), (13, (0, 0))]),
])
def test_positions(after, cases):
    dyn = one(after)
    for t, expected in cases:
        np.testing.assert_allclose(mover_position(dyn, float(t)), expected, atol=1e-12,
                                   err_msg=f"{after} at t={t}")
    ts = np.array([c[0] for c in cases], dtype=float)
    np.testing.assert_allclose(mover_position(dyn, ts), [c[1] for c in cases], atol=1e-12)


def test_loop_jump_left_limit():
    dyn = one("loop")
    # just before the jump at t = 4 it is (nearly) at the last waypoint, at 4 the first
    np.testing.assert_allclose(mover_position(dyn, 4 - 1e-9), (2, 2), atol=1e-8)
    np.testing.assert_allclose(mover_position(dyn, 4.0), (0, 0), atol=0)
    np.testing.assert_allclose(mover_position(dyn, 7 - 1e-9), (2, 2), atol=1e-8)
    # jump times among the breakpoints: waypoint times repeated with period 3
    np.testing.assert_allclose(mover_breakpoints(dyn, 0, 8), [1, 2, 4, 5, 7, 8])
    np.testing.assert_allclose(mover_breakpoints(one("bounce"), 0, 13),
                               [1, 2, 4, 6, 7, 8, 10, 12, 13])
    np.testing.assert_allclose(mover_breakpoints(one("hold"), 1.5, 100), [2, 4])


def test_velocity_and_parked():
    p = scene({"type": "circle", "radius": 0.5, "waypoints": [[1, 2]], "velocity": [0.5, -1],
               "times": [2]},
              {"type": "circle", "radius": 0.5, "waypoints": [[3, 3]], "velocity": [1, 0]},
              {"type": "circle", "radius": 0.5, "waypoints": [[4, 4]], "times": [7]})
    vel, vel0, parked = p.dynamic_obstacles
    # (1, 2) + (t - 2) (0.5, -1), also before times[0]
    np.testing.assert_allclose(mover_position(vel, 0.0), (0, 4))
    np.testing.assert_allclose(mover_position(vel, 4.0), (2, 0))
    np.testing.assert_allclose(mover_position(vel0, np.array([-1.0, 2.0])), [(2, 3), (5, 3)])
    np.testing.assert_allclose(mover_position(parked, np.array([-5.0, 7.0, 1e6])), [(4, 4)] * 3)
    assert mover_max_speed(vel) == pytest.approx(math.hypot(0.5, 1))
    assert mover_max_speed(parked) == 0.0
    assert mover_max_speed(one("loop")) == pytest.approx(2.0)  # 2 units in 1 s, jump ignored


def test_matches_optplan_motion_model():
    """Cross-reading: the oracle's own motion model agrees with DynamicObstacle.position (the
    test may import it, the oracle never does)."""
    rng = np.random.default_rng(3)
    ts = np.concatenate([rng.uniform(-5, 30, 400), [1, 2, 4, 7, 10, 13, 16]])
    for after in ("hold", "loop", "bounce"):
        dyn = one(after)
        np.testing.assert_allclose(mover_position(dyn, ts), dyn.position(ts), atol=1e-9)


def test_clearance_disc_and_polygon():
    p = scene({"type": "circle", "radius": 0.5, "waypoints": [[0, 0], [4, 0]], "times": [0, 4]},
              {"type": "polygon", "vertices": [[-1, -1], [1, -1], [1, 1], [-1, 1]],
               "waypoints": [[5, 5]], "times": [0]})
    disc, square = p.dynamic_obstacles
    # exact disc (not its polygon): at t = 1 the centre is (1, 0); (4, 4) is 5 away -> 4.5
    assert clearance(disc, [4, 4], 1.0) == pytest.approx(4.5, abs=1e-12)
    assert clearance(disc, [1.2, 0], 1.0) == 0.0  # inside
    np.testing.assert_allclose(clearance(disc, np.array([[4, 4], [5, 3]]), np.array([1.0, 2.0])),
                               [4.5, math.hypot(3, 3) - 0.5])
    # square [4, 6]^2: (8, 5) -> 2, (7, 7) -> sqrt 2 (corner), (5, 5) inside
    np.testing.assert_allclose(clearance(square, np.array([[8, 5], [7, 7], [5, 5]]), 3.0),
                               [2, math.sqrt(2), 0], atol=1e-12)


def test_polygon_distance_matches_shapely():
    # non-convex, with a hole, and a multipolygon: plain numpy against shapely
    rng = np.random.default_rng(7)
    pts = np.concatenate([rng.uniform(-4, 4, (3000, 2)), [[0, 0], [1, 0], [3, 3]]])
    ell = Polygon([(0, 0), (3, 0), (3, 1), (1, 1), (1, 3), (0, 3)])
    holed = Polygon([(-3, -3), (3, -3), (3, 3), (-3, 3)], [[(-1, -1), (1, -1), (1, 1), (-1, 1)]])
    multi = shapely.MultiPolygon([ell, Polygon([(-3, -3), (-2, -3), (-2, -2)])])
    for g in (ell, holed, multi):
        np.testing.assert_allclose(polygon_distance(g, pts, chunk_cells=997),
                                   shapely.distance(shapely.points(pts), g), atol=1e-12)


# ----------------------------------------------------------------------------------------------
# (a) empty scene: arrival S / v
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("path", "v", "ds", "dt", "expected"), [
    (LINE, 1.0, 0.04, 0.04, 8.0),                       # S = 8, v = 1: 200 steps of 0.04
    (LINE, 2.0, 0.04, 0.02, 4.0),                       # S / v = 4
    (np.array([[0, 0], [3, 0], [3, 4]]), 1.0, 0.05, 0.05, 7.0),   # corner, S = 3 + 4
    (LINE, 1.0, 0.02, 0.04, 8.0),                       # two cells per step: still exact
])
def test_empty_scene(path, v, ds, dt, expected):
    p = scene()
    got = grid_earliest_arrival(p, path, 0.2, v, ds, dt, horizon=12.0, margin=0.05)
    assert got == pytest.approx(expected, abs=1e-9)


def test_empty_scene_resolution_rounds_up():
    # max_speed dt / ds = 1.5 -> one cell per step (grid speed 0.04 / 0.04 = 1 <= 1.5):
    # arrival 8 >= S / v = 5.33 (conservative, documented)
    got = grid_earliest_arrival(scene(), LINE, 0.2, 1.5, 0.04, 0.04, horizon=12.0, margin=0.05)
    assert got == pytest.approx(8.0)
    assert grid_earliest_arrival(scene(), LINE, 0.2, 1.0, 0.04, 0.04, horizon=7.0,
                                 margin=0.05) is None          # 8 s needed, 7 s horizon


# ----------------------------------------------------------------------------------------------
# (b) a disc mover crossing the line once, perpendicular
# ----------------------------------------------------------------------------------------------
# Mover: radius R = 1 centred (5, t) for t in [0, 10] (upwards at speed 1, then held at (5, 10)).
# Robot r = 0.2 at (x(t), 5).  Contact iff (x - 5)^2 + (t - 5)^2 < rho^2, rho = R + r = 1.2:
# in the (x, t) plane the forbidden set is the disc of radius rho around (5, 5).  A schedule is
# a curve t(x) with slope dt/dx >= 1 from (1, 0).  Passing before the disc: the earliest
# curve is t = x - 1, at distance |5 - 5 - 1| / sqrt 2 = 0.707 < rho from (5, 5): impossible.
# So it passes after: at the column x_Q = 5 - rho / sqrt 2 (where the disc's tangent has slope
# 1) it must be above the disc's top t_Q = 5 + rho / sqrt 2, then needs >= 9 - x_Q more seconds:
# T >= t_Q + 9 - x_Q = 9 + rho sqrt 2, reached by waiting w = 1 + rho sqrt 2 at the start and
# then driving at full speed (the line t = x - 1 + w is tangent to the disc).  After t = 10 the
# mover is parked at (5, 10), 5 away from the line: harmless.
RHO = 1.2
CROSS = {"type": "circle", "radius": 1.0, "waypoints": [[5, 0], [5, 10]], "times": [0, 10]}
T_CROSS = 9 + RHO * math.sqrt(2)                       # 10.697


def test_crossing_mover_grid():
    p = scene(CROSS)
    ds = dt = 0.04
    margin = 0.02
    got = grid_earliest_arrival(p, LINE, 0.2, 1.0, ds, dt, horizon=16.0, margin=margin)
    # conservative: >= T* (grid schedules are truly feasible); upper: the inflated problem's
    # optimum 9 + (rho + margin) sqrt 2 plus a few grid steps
    inflated = 9 + (RHO + margin) * math.sqrt(2)
    assert got is not None
    assert T_CROSS - 1e-9 <= got <= inflated + 3 * dt
    # finer grid, two cells per step: closer
    fine = grid_earliest_arrival(p, LINE, 0.2, 1.0, 0.02, 0.04, horizon=16.0, margin=0.01)
    assert fine is not None
    assert T_CROSS - 1e-9 <= fine <= 9 + (RHO + 0.01) * math.sqrt(2) + 3 * 0.04


def test_crossing_mover_grid_schedule_is_feasible():
    """The grid schedule passes the independent continuous check (>= 0: the margin covers the
    sampling gaps) and its last time is the grid arrival."""
    p = scene(CROSS)
    sched = grid_schedule(p, LINE, 0.2, 1.0, 0.04, 0.04, horizon=16.0, margin=0.02)
    assert sched is not None
    times, s, pts = sched
    assert times[-1] == pytest.approx(
        grid_earliest_arrival(p, LINE, 0.2, 1.0, 0.04, 0.04, horizon=16.0, margin=0.02))
    assert s[0] == 0 and s[-1] == pytest.approx(8.0)
    assert np.all(np.diff(s) >= 0) and np.all(np.diff(s) <= 1.0 * 0.04 + 1e-12)
    np.testing.assert_allclose(pts[-1], GOAL)
    assert check_trajectory(p, times, pts, 0.2) >= 0.0


def test_crossing_mover_no_margin_still_brackets():
    # margin 0: no guarantee in the docs, but on this case it stays within a step of T*
    got = grid_earliest_arrival(scene(CROSS), LINE, 0.2, 1.0, 0.04, 0.04, horizon=16.0, margin=0.0)
    assert got is not None and T_CROSS - 0.04 <= got <= T_CROSS + 3 * 0.04


# ----------------------------------------------------------------------------------------------
# (c) a mover parked on the goal until t0, then leaving upwards at speed D
# ----------------------------------------------------------------------------------------------
# Disc R = 0.5 centred (9, 5) until t0 = 10, then (9, 5 + D u), u = t - t0 in [0, 1], D = 3;
# rho = R + r = 0.7.  The distance from (x, 5) to the mover decreases as x -> 9, and any
# schedule arriving at T has x(t) >= 9 - (T - t); so a schedule arriving at T exists iff the
# full-speed approach x(t) = 9 - (T - t) is free (it starts at x = 1 no later than t = T - 8 =
# 2.7 > 0).  With a = T - t0: (a - u)^2 + D^2 u^2 >= rho^2 for u in [0, 1] and (a - u)^2 >= rho^2
# for u < 0.  The first minimum is a^2 D^2 / (1 + D^2) at u = a / (1 + D^2) in [0, 1], so
# a >= rho sqrt(1 + D^2) / D (= 0.7379 > rho: the second constraint is weaker).
# T* = t0 + rho sqrt(1 + D^2) / D = 10.7379.
D_UP, T0 = 3.0, 10.0
PARKED = {"type": "circle", "radius": 0.5, "waypoints": [GOAL, [9.0, 5.0 + D_UP]],
          "times": [T0, T0 + 1]}


def test_parked_on_goal_disc():
    p = scene(PARKED)
    dt, margin = 0.04, 0.05
    exact = T0 + 0.7 * math.sqrt(1 + D_UP**2) / D_UP
    inflated = T0 + (0.7 + margin) * math.sqrt(1 + D_UP**2) / D_UP
    got = grid_earliest_arrival(p, LINE, 0.2, 1.0, 0.04, dt, horizon=14.0, margin=margin)
    assert got is not None
    assert got >= T0 + 0.7                               # the trivial bound t0 + rho / v
    assert exact - 1e-9 <= got <= inflated + 3 * dt
    # staying at the goal afterwards is also possible (the mover has left for good)
    assert grid_earliest_arrival(p, LINE, 0.2, 1.0, 0.04, dt, horizon=14.0, margin=margin,
                                 stay=True) == pytest.approx(got)


# Same with a square of half-side h = 0.5 (polygon mover), r = 0.2.  At the goal the robot
# needs D u - h >= r.  Before that, while x <= 9 - h and the square's bottom is above the line
# (D u > h), the nearest feature is the corner (9 - h, 5 + D u - h): with c = a - h,
# (c - u)^2 + (D u - h)^2 >= r^2, minimum (D c - h)^2 / (1 + D^2) at u = (c + h D) / (1 + D^2)
# (= 0.188: D u = 0.563 > h and c - u = 0.19 >= 0, so the minimiser is in that branch):
# c >= (h + r sqrt(1 + D^2)) / D = 0.3775.  The other branches (face: a - u - h >= r while
# D u <= h, i.e. c >= r + h / D = 0.367; top: D (a - h) - h >= r, i.e. c >= 0.233) are weaker.
# T* = t0 + h + (h + r sqrt(1 + D^2)) / D = 10.8775.
def test_parked_on_goal_square():
    sq = {"type": "polygon", "vertices": [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]],
          "waypoints": [GOAL, [9.0, 5.0 + D_UP]], "times": [T0, T0 + 1]}
    p = scene(sq)
    h, r, dt, margin = 0.5, 0.2, 0.04, 0.05
    exact = T0 + h + (h + r * math.sqrt(1 + D_UP**2)) / D_UP
    inflated = T0 + h + (h + (r + margin) * math.sqrt(1 + D_UP**2)) / D_UP
    got = grid_earliest_arrival(p, LINE, r, 1.0, 0.04, dt, horizon=12.0, margin=margin)
    assert got is not None
    assert exact - 1e-9 <= got <= inflated + 3 * dt


# ----------------------------------------------------------------------------------------------
# (e) check_trajectory
# ----------------------------------------------------------------------------------------------
def test_check_flags_driving_through():
    # straight at full speed through the crossing mover of (b): centre distance
    # sqrt((t - 4)^2 + (5 - t)^2), minimum sqrt(0.5) = 0.707 < R = 1 at t = 4.5: the centre
    # enters the disc, clearance 0 -> exactly -r (a sample hits the inside)
    p = scene(CROSS)
    assert check_trajectory(p, [0, 8], [START, GOAL], 0.2) == pytest.approx(-0.2, abs=1e-12)
    # partial overlap: wait w = 1 + 1.1 sqrt 2, then full speed: the (x, t) line is 1.1 from
    # (5, 5) -> centre distance 1.1 -> 1.1 - 1 - 0.2 = -0.1; the sampled value is >= the true
    # minimum and at most step / 2 = 0.005 above it
    w = 1 + 1.1 * math.sqrt(2)
    got = check_trajectory(p, [0, w, w + 8], [START, START, GOAL], 0.2)
    assert -0.1 - 1e-9 <= got <= -0.1 + 0.2 / 40


@pytest.mark.parametrize(("extra", "expected"), [
    # wait w = 1 + rho sqrt 2 + e then full speed: the (x, t) line is (w - 1) / sqrt 2 =
    # rho + e / sqrt 2 from (5, 5) -> value e / sqrt 2 (the tangent point is on the schedule)
    (0.05, 0.05 / math.sqrt(2)),
    # waiting until t = 12 at (1, 5): the mover passes (5, 5) at t = 5, 4 away -> 4 - 1.2;
    # afterwards it is parked at (5, 10), >= 5 away
    (12 - 1 - RHO * math.sqrt(2), 4 - RHO),
])
def test_check_accepts_waiting(extra, expected):
    p = scene(CROSS)
    w = 1 + RHO * math.sqrt(2) + extra
    got = check_trajectory(p, [0, w, w + 8], [START, START, GOAL], 0.2)
    assert expected - 1e-9 <= got <= expected + 0.2 / 40   # [m*, m* + step / 2]


def test_check_loop_jump_both_sides_and_hold():
    # Robot parked at (2, 0) during [0, 3]; disc R = 0.5 loops from (-5, 0) to (1.5, 0) in 1 s
    # (speed 6.5) and jumps back at t = 1, 2, 3.  Left limit at the jump: centre (1.5, 0), 0.5
    # away -> clearance 0 -> 0 - 0.2 exactly (a sampled end of each piece); right after the
    # jump it is 7 away.  Sampling only right-continuous values would miss the worst contact
    # only by the step; the left limit gives it exactly.
    p = parse_problem({
        "name": "jump", "bounds": [-10, -10, 10, 10],
        "robots": [{"id": "r", "start": [2, 0], "goal": [2, 0], "radius": 0.2, "max_speed": 1}],
        "dynamic_obstacles": [{"type": "circle", "radius": 0.5, "waypoints": [[-5, 0], [1.5, 0]],
                               "times": [0, 1], "after": "loop"}]})
    assert check_trajectory(p, [0, 3], [[2, 0], [2, 0]], 0.2) == pytest.approx(-0.2, abs=1e-12)
    # held at the last point up to the horizon: a single stamp at t = 0, checked up to 2.5
    assert check_trajectory(p, [0], [[2, 0]], 0.2, horizon=2.5) == pytest.approx(-0.2, abs=1e-12)
    # only [0, 0.5]: the mover reaches x = -5 + 3.25 = -1.75, 3.75 away -> 3.75 - 0.5 - 0.2
    assert check_trajectory(p, [0, 0.5], [[2, 0], [2, 0]], 0.2) == pytest.approx(3.05, abs=1e-9)


def test_check_without_movers_and_bad_input():
    assert check_trajectory(scene(), [0, 8], [START, GOAL], 0.2) == math.inf
    with pytest.raises(ValueError):
        check_trajectory(scene(CROSS), [0, 0], [START, GOAL], 0.2)    # teleport
    with pytest.raises(ValueError):
        check_trajectory(scene(CROSS), [1, 0], [START, GOAL], 0.2)    # time goes back
    # a repeated stamp with the same point is harmless
    assert check_trajectory(scene(CROSS), [0, 0, 8], [START, START, GOAL], 0.2) == -0.2
