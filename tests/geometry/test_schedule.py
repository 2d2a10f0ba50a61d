"""The fastest schedule along a path (optplan.geometry.timing.schedule): hand-derived arrivals, an
independent brute-force oracle, metamorphic cases and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from optplan.geometry.timing.schedule import fastest_schedule
from optplan.metrics import time_checks
from optplan.problem import parse_problem
from tests.exact import time_oracle as oracle
from tests.geometry.time_scenes import time_scene

LINE = np.array([[1.0, 5.0], [9.0, 5.0]])
RHO = 0.5  # mover radius 0.3 + robot radius 0.2


def _crosser(c: float, speed: float, after: str = "hold") -> dict:
    """A disc of radius 0.3 crossing y = 5 upwards at x = 5 at time ``c`` at ``speed``,
    between y = 2 and y = 8."""
    t0 = c - 3.0 / speed
    return {"type": "circle", "radius": 0.3, "waypoints": [[5, 2], [5, 8]],
            "times": [t0, t0 + 6.0 / speed], "after": after}


def _checked(p, path=LINE):
    """The schedule, after checking it with the exact validator and the oracle's dense check."""
    s = fastest_schedule(p, path)
    if s.status == "scheduled":
        r = p.leader.radius
        tc = time_checks(p, {p.leader.id: s.path}, {p.leader.id: s.times})
        assert tc["dynamic_contacts"] == 0
        assert oracle.check_trajectory(p, s.times, s.path, r) >= -1e-9 * p.extent
        assert np.all(np.diff(s.times) >= 0)
        steps = np.hypot(*np.diff(s.path, axis=0).T)
        dt = np.diff(s.times)
        assert np.all(steps <= p.leader.max_speed * dt * (1 + 1e-9) + 1e-12)
        assert s.times[-1] == pytest.approx(s.arrival, rel=1e-12)
        assert np.allclose(s.path[[0, -1]], path[[0, -1]])
    return s


def test_no_mover_full_speed():
    s = _checked(time_scene([], speed=2.0))
    assert s.status == "scheduled" and s.arrival == pytest.approx(4.0, rel=1e-12)
    assert len(s.path) == 2


def test_a_door_that_closes_and_reopens():
    # a 1 x 1 square slides onto the line at x = 5 by t = 1, stays until t = 6, and slides
    # up at 4 units/s.  The robot waits at x = 4.3 and leaves at t0 when its disc, running at
    # speed 1, just clears the door's rounded lower-left corner:
    # 4 (t0 - 6) - 0.5 = max_d sqrt(0.04 - (0.2 - d)^2) - 4 d = 3.4 / sqrt(17) - 0.8.
    door = {"type": "polygon", "vertices": [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]],
            "waypoints": [[5, 9], [5, 5], [5, 5], [5, 9]], "times": [0, 1, 6, 7]}
    s = _checked(time_scene([door]))
    t0 = 6 + (3.4 / math.sqrt(17) - 0.3) / 4
    assert s.status == "scheduled" and s.arrival == pytest.approx(t0 + 4.7, rel=1e-9)


def test_a_mover_crossing_the_line():
    # a mover crossing at x = 5 at t = 4 (when the robot would be there): in the mover's frame
    # the robot runs on the line x + y = 1 - tau, at distance |1 - tau| / sqrt(2) ... shifted:
    # the forbidden delays are |c - 4 - tau| < sqrt(2) rho, so tau* = sqrt(2) rho.
    s = _checked(time_scene([_crosser(4.0, 1.0)]))
    assert s.arrival == pytest.approx(8 + math.sqrt(2) * RHO, rel=1e-9)


@pytest.mark.parametrize("after", ["loop", "bounce"])
def test_repeating_movers(after):
    # crossings at t = 4, 10, 16, ... (loop: always upwards; bounce: alternately): the same
    # forbidden delays around each crossing; the first window is the binding one
    s = _checked(time_scene([_crosser(4.0, 1.0, after)]))
    assert s.arrival == pytest.approx(8 + math.sqrt(2) * RHO, rel=1e-9)
    # a crossing every 2 s with half-width sqrt(2) rho = 0.707: the gap after the first window
    fast = {"type": "circle", "radius": 0.3, "waypoints": [[5, 4], [5, 6]], "times": [3, 5],
            "after": after}
    s = _checked(time_scene([fast]))
    assert s.status == "scheduled" and s.arrival >= 8.0


def test_a_mover_parked_on_the_goal_for_a_while():
    # parked on the goal until t = 20, then up at 4 units/s; the robot drives in behind it:
    # (a - u)^2 + 16 u^2 >= 0.7^2 for all u <= a (a = arrival - 20) gives a = 0.7 sqrt(17) / 4
    park = {"type": "circle", "radius": 0.5, "waypoints": [[9, 5], [9, 9]], "times": [20, 21]}
    s = _checked(time_scene([park]))
    assert s.arrival == pytest.approx(20 + 0.7 * math.sqrt(17) / 4, rel=1e-9)


def test_a_mover_faster_than_the_robot():
    # crossing at 5 units/s: the forbidden delays are |c - 4 - tau| < rho sqrt(26) / 5
    fast = {"type": "circle", "radius": 0.3, "waypoints": [[5, 5]], "times": [4.0],
            "velocity": [0.0, 5.0]}
    s = _checked(time_scene([fast]))
    assert s.arrival == pytest.approx(8 + RHO * math.sqrt(26) / 5, rel=1e-9)
    # overtaking along the path at 3 units/s: it sweeps every point of the line, no schedule
    chaser = {"type": "circle", "radius": 0.3, "waypoints": [[-5, 5]], "times": [0.0],
              "velocity": [3.0, 0.0]}
    s = _checked(time_scene([chaser]))
    assert s.status == "no_schedule" and s.arrival is None and "no schedule exists" in s.message


def test_goal_occupied_for_ever():
    park = {"type": "circle", "radius": 0.5, "waypoints": [[9, 5]], "times": [0]}
    s = _checked(time_scene([park]))
    assert s.status == "no_schedule" and s.path is None


def test_bad_input_gives_a_status():
    p = time_scene([_crosser(4.0, 1.0)])
    s = fastest_schedule(p, [[2.0, 5.0], [9.0, 5.0]])
    assert s.status == "invalid" and "not at robot 'r'" in s.message
    inside = {"type": "circle", "radius": 0.5, "waypoints": [[1, 5], [1, 9]], "times": [0, 4]}
    s = fastest_schedule(time_scene([inside]), LINE)
    assert s.status == "invalid" and "starts inside the moving obstacle" in s.message
    s = fastest_schedule(time_scene([], obstacles=[((5, 5), 1.0)]), LINE)
    assert s.status == "invalid" and "static obstacle" in s.message
    with pytest.raises(ValueError, match="finite"):
        fastest_schedule(p, [[1.0, 5.0], [np.nan, 5.0]])
    with pytest.raises(ValueError, match=r"\(m, 2\)"):
        fastest_schedule(p, [1.0, 5.0])


def test_a_zero_length_path():
    s = _checked(time_scene([_crosser(4.0, 1.0)]), np.array([[1.0, 5.0], [1.0, 5.0]]))
    assert s.status == "scheduled" and s.arrival == 0.0


@pytest.mark.parametrize("scale, shift", [(1.0, (1e3, -2e3)), (1e-3, (0.0, 0.0)),
                                          (1e4, (5e4, 5e4))])
def test_translate_and_scale_space_and_time(scale, shift):
    movers = [_crosser(4.0, 1.0, "bounce"),
              {"type": "polygon", "vertices": [[-0.4, -0.3], [0.4, -0.3], [0.4, 0.3],
                                               [-0.4, 0.3]],
               "waypoints": [[7, 3], [7, 7]], "times": [5, 8], "after": "loop"}]
    path = np.array([[1.0, 5.0], [4.0, 6.0], [9.0, 5.0]])
    ref = _checked(time_scene(movers), path)
    got = fastest_schedule(time_scene(movers, scale=scale, shift=shift),
                           path * scale + np.asarray(shift))
    assert got.status == ref.status == "scheduled"
    assert got.arrival == pytest.approx(ref.arrival * scale, rel=1e-9)


def test_a_far_mover_changes_nothing():
    movers = [_crosser(4.0, 1.0)]
    far = {"type": "circle", "radius": 0.3, "waypoints": [[0.5, 0.5], [0.5, 2.0]],
           "times": [0, 5], "after": "bounce"}
    a = fastest_schedule(time_scene(movers), LINE)
    b = fastest_schedule(time_scene(movers + [far]), LINE)
    assert b.arrival == pytest.approx(a.arrival, rel=1e-12)


def _random_scene(seed: int):
    rng = np.random.default_rng(seed)
    dyn = []
    for _ in range(4):
        wps = rng.uniform(1, 9, (int(rng.integers(2, 4)), 2)).round(2).tolist()
        m = {"waypoints": wps, "times": np.cumsum(rng.uniform(1, 5, len(wps))).round(2).tolist(),
             "after": str(rng.choice(["hold", "loop", "bounce"]))}
        if rng.random() < 0.5:
            m.update(type="circle", radius=float(rng.uniform(0.2, 0.8)))
        else:
            a, b = rng.uniform(0.2, 0.6, 2)
            m.update(type="polygon", vertices=[[-a, -b], [a, -b], [a, b], [-a, b]])
        dyn.append(m)
    start, mid, goal = rng.uniform(1, 9, (3, 2))
    p = parse_problem({"name": "random", "bounds": [0, 0, 10, 10],
                       "robots": [{"id": "r", "start": start.tolist(), "goal": goal.tolist(),
                                   "radius": 0.2, "max_speed": 1.0}],
                       "dynamic_obstacles": dyn})
    return p, np.array([start, mid, goal])


@pytest.mark.parametrize("seed", [1, 3, 7])
def test_no_grid_schedule_arrives_earlier(seed):
    # the oracle's own motion model and distances, on a conservative (s, t) grid: every grid
    # schedule is collision-free, so none may arrive before the exact earliest arrival
    p, path = _random_scene(seed)
    s = _checked(p, path)
    assert s.status == "scheduled"
    grid = oracle.grid_earliest_arrival(p, path, 0.2, 1.0, 0.04, 0.04, s.arrival + 1.0, 0.02)
    assert grid is not None and grid >= s.arrival - 1e-9
    assert grid - s.arrival < 0.1  # and the exact arrival is not far below the grid's
