"""Backend ``orca`` (ORCA through pyrvo): behaviour on analytic scenes, the validator's word on
every ``solved``, the RVO2 world (circumscribed circles, movers), bad options."""

from __future__ import annotations

import builtins
import math
from typing import Any

import numpy as np
import pytest

import optplan as op
from optplan.formation.orca_world import (
    LocalFrame,
    Movers,
    circle_polygon,
    obstacle_polygons,
    require_pyrvo,
)
from optplan.problem import parse_problem

try:
    import pyrvo  # noqa: F401
except ImportError as e:  # the optional extra [orca] is not installed
    pytest.skip(f"pyrvo (RVO2's Python bindings, extra [orca]) cannot be imported: {e}",
                allow_module_level=True)


def _scene(name: str, robots: list[dict[str, Any]], **more: Any) -> op.Problem:
    data = {"name": name, "bounds": [0.0, 0.0, 100.0, 100.0], "length_scale": 1.0,
            "robots": robots, **more}
    return parse_problem(data, f"<{name}>")


def _accepted(problem: op.Problem, res: op.Result) -> None:
    """A ``solved`` result is feasible and reaches in the validator's own run."""
    if res.status is op.Status.solved:
        m = op.evaluate(problem, res.paths, res.times)
        assert m["feasible"] and m["reached"], res.message


def test_empty_map_straight_line_at_max_speed() -> None:
    prob = op.load_problem("open-field")
    r = op.solve(prob, "orca", rng=0)
    assert r.status is op.Status.solved, r.message
    robot = prob.robots[0]
    p = r.paths[robot.id]
    d = robot.goal - robot.start
    # every point on the start-goal segment
    cross = (p[:, 0] - robot.start[0]) * d[1] - (p[:, 1] - robot.start[1]) * d[0]
    assert np.max(np.abs(cross)) / np.hypot(*d) < 1e-4
    # full speed on every step but the last (which lands on the goal)
    speed = np.hypot(*np.diff(p, axis=0).T) / np.diff(r.times)
    np.testing.assert_allclose(speed[:-1], robot.max_speed, rtol=1e-5)
    # the run stops when the robot is within its goal tolerance (the simulator's convention)
    tol = prob.goal_tol(robot)
    steps = math.ceil((np.hypot(*d) - tol) / (robot.max_speed * 0.2))
    assert r.extras["time_to_goal"] == pytest.approx(steps * 0.2)
    assert r.metrics["length"] == pytest.approx(steps * 0.2 * robot.max_speed, rel=1e-6)
    _accepted(prob, r)


@pytest.mark.parametrize("offset", [0.0, 1.0])
def test_two_robots_swapping_places_pass_without_collision(offset: float) -> None:
    prob = _scene("swap", [
        {"id": "a", "start": [20.0, 50.0], "goal": [80.0, 50.0 + offset], "radius": 3.0,
         "max_speed": 4.0},
        {"id": "b", "start": [80.0, 50.0 + offset], "goal": [20.0, 50.0], "radius": 3.0,
         "max_speed": 4.0}])
    r = op.solve(prob, "orca", rng=0)
    assert r.status is op.Status.solved, r.message
    assert r.metrics["separation_violations"] == 0 and r.metrics["collisions"] == 0
    assert r.metrics["min_separation"] >= 6.0  # the two radii: ORCA's reciprocal guarantee
    # they did have to avoid each other: they left the line between the ends
    lateral = max(float(np.max(np.abs(p[:, 1] - 50.0 - offset * (p[:, 0] - 20.0) / 60.0)))
                  for p in r.paths.values())
    assert lateral > 1.0
    _accepted(prob, r)


def test_four_robots_crossing_the_centre_never_collide() -> None:
    """Exactly symmetric: ORCA may turn in a slow roundabout that the stall test stops (an
    honest 'approximate'); whatever happens, no two robots touch, and the seed decides."""
    ends = [((15.0, 50.0), (85.0, 50.0)), ((85.0, 50.0), (15.0, 50.0)),
            ((50.0, 15.0), (50.0, 85.0)), ((50.0, 85.0), (50.0, 15.0))]
    prob = _scene("cross4", [{"id": f"r{i}", "start": list(s), "goal": list(g), "radius": 2.5,
                              "max_speed": 3.0} for i, (s, g) in enumerate(ends)])
    for seed in range(3):
        r = op.solve(prob, "orca", rng=seed)
        assert r.status in (op.Status.solved, op.Status.approximate), r.message
        assert r.metrics["collisions"] == 0, r.message
        _accepted(prob, r)
    again = op.solve(prob, "orca", rng=2)
    np.testing.assert_array_equal(again.paths["r0"], r.paths["r0"])


def test_obstacle_between_start_and_goal_reached_with_subgoals() -> None:
    """A U open toward the robot: plain ORCA stalls in it (a deadlock, said in the message);
    with the visgraph sub-goals the robot goes round it."""
    prob = op.load_problem("trap-u")
    plain = op.solve(prob, "orca", rng=0)
    assert plain.status is op.Status.approximate
    assert "stalled" in plain.message and plain.metrics["collisions"] == 0
    guided = op.solve(prob, "orca", rng=0, subgoals="visgraph")
    assert guided.status is op.Status.solved, guided.message
    assert "sub-goals by visgraph" in guided.message
    assert guided.extras["subgoals"][prob.robots[0].id][-1] == pytest.approx(
        prob.robots[0].goal.tolist())
    _accepted(prob, guided)


def test_moving_obstacle_as_an_agent() -> None:
    """A disc and a square crossing the robot's line: each is an agent moving along its track
    (the velocity of its piece at that time), avoided by the robot."""
    mover = {"name": "m", "waypoints": [[50.0, 10.0], [50.0, 90.0]], "times": [0.0, 40.0]}
    robot = [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 2.0,
              "max_speed": 4.0}]
    for shape in ({"type": "circle", "radius": 4.0},
                  {"type": "polygon", "vertices": [[-4, -4], [4, -4], [4, 4], [-4, 4]]}):
        prob = _scene("crossing", robot, dynamic_obstacles=[{**mover, **shape}])
        mv = Movers(prob)
        pos, vel = mv.at(10.0, 0.2)
        np.testing.assert_allclose(pos[0], [50.0, 30.0], atol=1e-9)
        np.testing.assert_allclose(vel[0], [0.0, 2.0], atol=1e-9)
        assert mv.radius[0] >= 4.0 * (math.sqrt(2.0) if shape["type"] == "polygon" else 1.0) - 1e-9
        r = op.solve(prob, "orca", rng=0)
        assert r.extras["mover_agents"] == 1
        assert r.metrics["dynamic_contacts"] == 0, r.message
        _accepted(prob, r)


def test_circles_are_circumscribed_and_rings_oriented() -> None:
    poly = circle_polygon(np.array([3.0, -2.0]), 5.0, 7)
    a, b = poly, np.roll(poly, -1, axis=0)
    e = b - a
    # every edge is tangent to the circle: the centre is at distance 5 from its line
    dist = np.abs(e[:, 0] * (a[:, 1] + 2.0) - e[:, 1] * (a[:, 0] - 3.0)) / np.hypot(*e.T)
    np.testing.assert_allclose(dist, 5.0)
    area = 0.5 * np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1])
    assert area > 0  # counter-clockwise
    prob = _scene("holes", [{"id": "r", "start": [5.0, 5.0], "goal": [95.0, 95.0],
                             "radius": 1.0, "max_speed": 2.0}], obstacles=[
        {"type": "polygon", "name": "ring", "vertices": [[20, 20], [20, 80], [80, 80], [80, 20]],
         "holes": [[[40, 40], [60, 40], [60, 60], [40, 60]]]}])
    rings = obstacle_polygons(prob, LocalFrame.of(prob), 16)

    def signed(r: np.ndarray) -> float:
        s = np.roll(r, -1, axis=0)
        return float(0.5 * np.sum(r[:, 0] * s[:, 1] - s[:, 0] * r[:, 1]))

    assert [np.sign(signed(r)) for r in rings] == [1.0, -1.0, -1.0]  # shape, hole, bounds


def test_team_preset_keeps_formation_on_the_open_field() -> None:
    prob = op.load_problem("formation-open-field")
    r = op.solve(prob, "orca-team", rng=0)
    assert r.status is op.Status.solved, r.message
    assert set(r.paths) == {"leader", "f1", "f2"}
    assert r.metrics["formation_final_error"] <= 0.25 * 30.0
    _accepted(prob, r)


@pytest.mark.parametrize("scene", ["paper-warehouse", "warehouse-team", "paper-formation"])
@pytest.mark.parametrize("solver", ["orca", "orca-team"])
def test_every_solved_is_accepted_by_the_validator(scene: str, solver: str) -> None:
    prob = op.load_problem(scene)
    r = op.solve(prob, solver, rng=0)
    assert r.times is not None and len(r.times) == len(r.paths[prob.leader.id])
    _accepted(prob, r)


@pytest.mark.parametrize(("overrides", "match"), [
    ({"time_horizon": 0.1}, "option 'time_horizon' of backend 'orca' must be at least dt"),
    ({"time_horizon_obst": 0.5, "dt": 1.0}, "'time_horizon_obst'.*at least dt"),
    ({"subgoals": "astar"}, "subgoals"),
    ({"circle_sides": 2}, "circle_sides"),
    ({"neighbor_dist": 0.0}, "neighbor_dist"),
    ({"speed_factor": 1.5}, "speed_factor"),
    ({"perturb": -0.1}, "perturb"),
])
def test_bad_options_are_clear_errors(overrides: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        op.get_solver("orca", **overrides)


def test_team_without_a_formation_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match=r"no \[formation\].*team = true"):
        op.solve("open-field", "orca-team", rng=0)


def test_missing_pyrvo_names_the_package(monkeypatch: pytest.MonkeyPatch) -> None:
    real = builtins.__import__

    def no_pyrvo(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "pyrvo":
            raise ImportError("No module named 'pyrvo'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyrvo)
    monkeypatch.delitem(__import__("sys").modules, "pyrvo", raising=False)
    with pytest.raises(ImportError, match=r"needs the package 'pyrvo'.*optplan\[orca\]"):
        require_pyrvo()
