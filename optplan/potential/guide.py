r"""Guidance of a potential-field controller by the exact tangent-graph path (option ``guide``).

Beyond the paper.  The potential field of eqs 3-6 / 34 knows obstacles within ``rho_0`` only;
on grid-derived maps (hundreds of small squares, walls of many pieces, one-cell passages) its
local minima are everywhere and the SA escape of §IV.B wanders.  With ``guide = "visgraph"``
the controller plans once the arc-exact shortest path of the robot disc on the *known* map
(:func:`optplan.geometry.tangent.tangent_graph.tangent_graph`, the ``visgraph`` solver's graph) from
where it is to its goal, and uses its vertices as a moving sub-goal:

.. math::  g(x) = P_{j(x)}, \qquad j(x) = \max\{\, j \le i + m : [x, P_j] \text{ free}\,\},

with :math:`P_0 \dots P_N` the path, :math:`i` the current index (never decreasing) and
:math:`m` = :data:`LOOKAHEAD`; "free" is the exact segment test of the robot disc on the known
map (:func:`optplan.potential.swept.free_steps`).  When no vertex ahead is visible (the robot
was pushed round a corner) the path is planned again from :math:`x`.

While :math:`g(x)` is visible and no obstacle off the known map (temporary, moving, another
robot) is within :math:`\rho_0`, the step is taken straight toward it: the segment is certified
free, and the repulsion of the known obstacles, which on grid maps overwhelms the attraction
far from the goal (:math:`\rho_g^n` in eq 34) and makes a sub-goal on an obstacle's boundary
unreachable, is not applied.  Otherwise the field of eqs 3-4 and 34-37 (toward :math:`g(x)`)
moves the robot, and the SA escape runs when the tests of eq 38 fire.  On a map whose
obstacles are all known the guided planner is therefore a follower of the certified
shortest path (docs/solvers/apf.md, "Grid maps").
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.collision import farthest_clear
from optplan.geometry.tangent.tangent_graph import tangent_graph
from optplan.problem import Problem, Robot

__all__ = ["Guide", "LOOKAHEAD", "REPLAN_EVERY", "GUIDE_MARGIN"]

#: Vertices ahead of the current one tested for visibility each step.
LOOKAHEAD = 24
#: Clearance (x length_scale) the guide path keeps beyond the robot radius when the start
#: and goal allow it (else it is planned for the radius itself).
GUIDE_MARGIN = 1e-4
#: Fewest calls between two plans of the path (a lost robot re-plans from where it is).
REPLAN_EVERY = 10


class Guide:
    """The moving sub-goal of a guided controller, from ``x`` to ``goal``.

    ``path`` is ``None`` when the known map has no path (the start or goal too close to an
    obstacle, or no connection): :meth:`subgoal` then returns the goal.
    """

    def __init__(self, problem: Problem, robot: Robot, x: np.ndarray, goal: np.ndarray):
        self.goal = np.asarray(goal, dtype=float)
        self.visible = False
        # the path keeps a margin from the obstacles where it can (the exact tests decide
        # with a tolerance; a path that grazes them may not survive a change of frame)
        margin = GUIDE_MARGIN * problem.length_scale
        self.oset = problem.obstacle_set(robot.radius + margin, known_only=True)
        if tangent_graph(self.oset).shortest_path(x, self.goal).polyline is None:
            self.oset = problem.obstacle_set(robot.radius, known_only=True)
        self.path: np.ndarray | None = None
        self.i = 1
        self.replans = -1
        self._calls = self._last_plan = 0
        self._plan(np.asarray(x, dtype=float))

    def _plan(self, x: np.ndarray) -> None:
        """The shortest path from ``x`` (kept when there is none from here)."""
        res = tangent_graph(self.oset).shortest_path(x, self.goal)
        self.replans += 1
        self._last_plan = self._calls
        if res.polyline is not None or self.path is None:
            self.path, self.i = res.polyline, 1

    def subgoal(self, x: np.ndarray, step: float) -> np.ndarray:
        """The farthest visible vertex within :data:`LOOKAHEAD` of the current one; when
        none is visible (the field pushed the robot round a corner) the path is planned again
        from ``x``, at most every :data:`REPLAN_EVERY` calls.  A vertex is visible when the
        segment to it is free and so is the first ``step`` of it (the exact test is decided
        with a tolerance: a free segment may have a prefix that grazes an obstacle by more
        than it, and the robot moves along prefixes)."""
        self._calls += 1
        seen = self._farthest_seen(x, step)
        if seen is None and self._calls - self._last_plan >= REPLAN_EVERY:
            self._plan(x)
            seen = self._farthest_seen(x, step)
        self.visible = seen is not None
        if self.path is None:
            return self.goal
        if seen is not None:
            self.i = seen
        return self.path[self.i].copy()

    def _farthest_seen(self, x: np.ndarray, step: float) -> int | None:
        """The farthest vertex visible from ``x`` up to :data:`LOOKAHEAD` ahead, or ``None``."""
        P = self.path
        if P is None:
            return None
        return farthest_clear(x, P, lambda p, ahead: self._visible(p, ahead, step),
                              range(self.i, min(len(P), self.i + LOOKAHEAD + 1)))

    def _visible(self, x: np.ndarray, ahead: np.ndarray, step: float) -> np.ndarray:
        """Per point of ``ahead``: the segment from ``x`` to it and its first ``step`` are free."""
        d = ahead - x
        L = np.hypot(d[:, 0], d[:, 1])
        first = x + d * np.minimum(1.0, step / np.maximum(L, 1e-300))[:, None]
        ends = np.vstack([ahead, first])
        ok = self.oset.segment_free(np.broadcast_to(x, ends.shape), ends)
        return ok[:len(ahead)] & ok[len(ahead):]
