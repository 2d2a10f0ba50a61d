"""The hybrid planner's per-robot sub-goal tracking (paper §V step 6).

A :class:`Driver` is a robot with its own goal and sub-goal sequence, driven by a local
controller; the :class:`SubgoalTracker` moves every driver on to its next sub-goal when the
current one is reached, sensed inside a temporary obstacle, or not approached for
``stall_steps`` steps (the choices where the paper is silent: :mod:`optplan.hybrid.planner`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optplan.interfaces import LocalController
from optplan.problem import Robot
from optplan.sim import SimState

__all__ = ["Driver", "SubgoalTracker"]


@dataclass
class Driver:
    """A robot with its own goal, driven through its sub-goals by a local controller."""

    index: int
    robot: Robot
    goals: np.ndarray  # (k, 2), last = final goal
    controller: LocalController
    reach_tol: float
    goal_tol: float
    j: int = 0
    best: float = math.inf
    k_best: int = 0
    done: bool = False
    gave_up: bool = False
    heading: float = 0.0
    reached_at: list = field(default_factory=list)  # (sub-goal index, time, how)
    t_goal: float = math.nan

    @property
    def final(self) -> bool:
        return self.j == len(self.goals) - 1

    def advance(self, k: int, t: float, how: str) -> None:
        self.reached_at.append((self.j, float(t), how))
        self.j += 1
        self.best, self.k_best = math.inf, k
        self.controller.reset(self.goals[self.j].copy())


class SubgoalTracker:
    """Step 6: moves every driving robot on to its next sub-goal.

    An intermediate sub-goal is left when it is reached (within ``reach_tol``; with
    ``reach_visible`` only once the next sub-goal is in sight, :meth:`next_visible`), sensed
    inside a temporary obstacle (``skip_blocked``) or not approached for ``stall_steps`` steps;
    the final goal is reached within the goal tolerance.  :meth:`update` is idempotent within a
    step.
    """

    def __init__(self, drivers: list[Driver], *, skip_blocked: bool, stall_steps: int,
                 sensing: float | None, reach_visible: bool = False, unit: float = 1.0):
        self.drivers = drivers
        self.skip_blocked, self.stall_steps, self.sensing = skip_blocked, stall_steps, sensing
        self.reach_visible, self.unit = reach_visible, unit
        self._temp_mask: dict[int, np.ndarray] = {}

    @property
    def all_done(self) -> bool:
        return all(d.done for d in self.drivers)

    def update(self, state: SimState) -> None:
        for d in self.drivers:
            while not d.done and self._step(d, state):
                pass

    def _step(self, d: Driver, state: SimState) -> bool:
        """One decision for driver ``d``; True when it moved on to another sub-goal."""
        dist = math.hypot(*(d.goals[d.j] - state.positions[d.index]))
        if d.final:
            if dist <= d.goal_tol:
                d.done, d.t_goal = True, float(state.t)
                d.reached_at.append((d.j, float(state.t), "reached"))
            return False
        how = ""
        if dist <= d.reach_tol and (not self.reach_visible or self.next_visible(d, state)):
            how = "reached"
        elif self.blocked(d, state):
            how = "blocked"
        elif dist < d.best - 0.1 * d.robot.radius:
            d.best, d.k_best = dist, state.k
        elif self.stall_steps and state.k - d.k_best > self.stall_steps:
            how = "stalled"
        if how:
            d.advance(state.k, state.t, how)
        return bool(how)

    def next_visible(self, d: Driver, state: SimState) -> bool:
        """The straight segment from the robot to its next sub-goal keeps the robot disc clear
        of the known static obstacles (samples every half radius, at most 2000)."""
        if d.j + 1 >= len(d.goals):
            return True
        fld = state.field
        temp = self._temp(fld)
        known = ~temp[:fld.n_static]
        if not known.any():
            return True
        x = np.asarray(state.positions[d.index], dtype=float)
        g = d.goals[d.j + 1]
        r = d.robot.radius
        h = max(0.5 * r, 1e-3 * self.unit)
        n = int(min(2000, max(2, math.ceil(math.hypot(*(g - x)) / h) + 1)))
        pts = x + np.linspace(0.0, 1.0, n)[:, None] * (g - x)
        _, dist = fld.nearest(pts, state.t, max_range=r + h)
        return not bool(np.any(dist[:, :fld.n_static][:, known] < r))

    def _temp(self, fld: Any) -> np.ndarray:
        """Per obstacle of ``fld``: is it a temporary (``known = false``) static obstacle."""
        temp = self._temp_mask.get(id(fld))
        if temp is None:
            temp = np.array([not o.known for o in fld.static] + [False] * (fld.n - fld.n_static),
                            dtype=bool)
            self._temp_mask[id(fld)] = temp
        return temp

    def blocked(self, d: Driver, state: SimState) -> bool:
        """The current sub-goal lies inside a sensed temporary obstacle."""
        fld = state.field
        if not self.skip_blocked or fld.n_static == 0:
            return False
        temp = self._temp(fld)
        if not temp.any():
            return False
        g = d.goals[d.j]
        if self.sensing is not None and math.hypot(*(g - state.positions[d.index])) > \
                self.sensing:
            return False
        _, dist = fld.nearest(g, state.t, max_range=d.robot.radius)
        return bool(np.any(dist[0][temp] < d.robot.radius))
