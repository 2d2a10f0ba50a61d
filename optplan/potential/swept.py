r"""Exact tests of a time step's straight motion against the static obstacles.

A time-stepping planner moves each robot along the straight segment :math:`x \to x + u\,dt`.
Testing the end point only (what :func:`optplan.sim.simulate` does) misses a step that
crosses a thin obstacle or the corner of one with both ends free, and a point robot
(``radius = 0``) whose end point lies *inside* an obstacle (its distance there is 0, which is
not below ``radius - eps``).  On grid-derived maps (cells of a few steps) both happen, and the
run then "reaches the goal" along a path the validator rejects (docs/solvers/apf.md,
"Grid maps").  These helpers decide the whole segment exactly, with the predicate the
validator uses (:meth:`optplan.geometry.ObstacleSet.segment_free` of the robot's radius, the
bounds as a wall): a segment is free when it keeps the robot disc at distance
``>= radius - eps`` from every static obstacle and inside the bounds.

Dynamic obstacles are not tested here (the simulator's end-point test covers them).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from optplan.canonical import format_point
from optplan.problem import Problem, Robot

__all__ = ["StepGuard", "free_steps", "clamp_speed"]


def clamp_speed(v: np.ndarray, vmax: float) -> np.ndarray:
    """``v`` scaled down to speed ``vmax`` when faster (the simulator's speed limit)."""
    s = float(math.hypot(*v))
    return v * (vmax / s) if s > vmax > 0 else v


def free_steps(problem: Problem, robot: Robot, x: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Per end point ``ends[k]`` ``(K, 2)``: whether the segment ``x -> ends[k]`` is free
    (exact; the robot's radius, every static obstacle, the bounds as a wall)."""
    ends = np.asarray(ends, dtype=float).reshape(-1, 2)
    oset = problem.obstacle_set(robot.radius)
    return oset.segment_free(np.broadcast_to(np.asarray(x, float), ends.shape), ends)


class StepGuard:
    """Checks every robot's straight step of a simulator step before it is taken.

    ``check(state_positions, velocities, dt, t)`` returns ``""`` when every step is free,
    else a description of the first step that meets a static obstacle or the bounds (the
    description is also kept in :attr:`collision`).  The policies of
    :func:`~optplan.potential.backend.run_local_planner` and of the hybrid planner call it and
    stop the run (status ``failed``, "collision: ...") instead of stepping through.
    """

    def __init__(self, problem: Problem, robots: list[Robot]):
        self.problem = problem
        self.robots = robots
        self.collision = ""

    def check(self, positions: np.ndarray, velocities: np.ndarray, dt: float, t: float,
              active: Any = None) -> str:
        """The first step ``positions[i] -> positions[i] + dt * velocities[i]`` (speed
        clamped to the robot's ``max_speed``) that is not free, described; ``""`` if none.
        ``active`` (bool array) limits the test to those robots."""
        for i, r in enumerate(self.robots):
            if active is not None and not active[i]:
                continue
            x = np.asarray(positions[i], dtype=float)
            y = x + dt * clamp_speed(np.asarray(velocities[i], dtype=float), r.max_speed)
            if np.array_equal(x, y) or free_steps(self.problem, r, x, y[None])[0]:
                continue
            self.collision = (f"{r.id}'s step from {format_point(self.problem, x)} to "
                              f"{format_point(self.problem, y)} at t={t + dt:.2f} s "
                              f"{self._what(r, x, y)}")
            return self.collision
        return ""

    def _what(self, r: Robot, x: np.ndarray, y: np.ndarray) -> str:
        """What the step ``x -> y`` meets: the obstacle's name or the bounds."""
        oset = self.problem.obstacle_set(r.radius)
        hits = oset.crossings(np.stack([x, y])[None], details=True, penetration=False).pairs
        if hits is None or len(hits[2]) == 0:
            return "is not free"
        return f"crosses {oset.solid_name(int(hits[2][0]))!r}"
