"""The hybrid planner's local and formation drive (paper §V steps 2 and 5): the simulator policy.

Every step, each driving robot (the leader; several robots without a formation) is commanded
by its local controller toward its current sub-goal (capped at ``v_factor * max_speed`` with
followers, its heading optionally rate-limited), and the followers by the formation stage's
controller around the leader; the run is ``done`` when every driver completed its sub-goals
and the followers settled (or ``settle_steps`` passed).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from optplan.hybrid.tracker import Driver, SubgoalTracker
from optplan.interfaces import FollowerController
from optplan.potential.backend import RobotsAsObstacles
from optplan.potential.swept import StepGuard
from optplan.problem import Problem, Robot
from optplan.sim import SimState

if TYPE_CHECKING:
    from optplan.hybrid.steps import RunOptions

__all__ = ["Team", "HybridPolicy"]


@dataclass
class Team:
    """Who drives itself (with a goal) and who follows, in simulation order."""

    drivers: list[Robot]
    follower_ids: list[str]
    ids: list[str]
    use_formation: bool


class HybridPolicy:
    """The simulator's policy, ``done`` test and progress cost of one hybrid run."""

    def __init__(self, opts: RunOptions, problem: Problem, team: Team, drivers: list[Driver],
                 tracker: SubgoalTracker, fctrl: FollowerController | None):
        self.o, self.problem, self.team, self.drivers = opts, problem, team, drivers
        # a follower controller only with a formation (Hybrid.solve)
        self.tracker, self.fctrl, self.form = tracker, fctrl, problem.formation
        lid = problem.leader.id
        self.lead = next((d for d in drivers if d.robot.id == lid), drivers[0])
        self.f_idx = [team.ids.index(f) for f in team.follower_ids] if fctrl else []
        self.L = (np.array([f.L for f in self.form.followers]) if fctrl and self.form
                  else np.zeros(0))
        self.k_arrived: int | None = None
        self.gave_up: list[str] = []
        # several drivers (no formation between them): each one's local planner senses the
        # other drivers as discs where they are now, as run_local_planner does (sense_robots)
        planner = opts.stages["local_solver"]
        self.sense_others = len(drivers) > 1 and bool(getattr(planner, "sense_robots", True))
        self._d_idx = np.array([d.index for d in drivers], dtype=int)
        self._d_rad = np.array([d.robot.radius for d in drivers], dtype=float)
        # every robot's straight step is tested exactly before it is taken (the simulator
        # tests end points only): a step through a thin obstacle ends the run as a collision
        self.guard = StepGuard(problem, [problem.robot(i) for i in team.ids])

    def __call__(self, state: SimState) -> np.ndarray | None:
        u = np.zeros((len(self.team.ids), 2))
        for d in self.drivers:
            if d.done:
                continue
            v = self._drive(d, state)
            if v is None:
                return None
            u[d.index] = v
        if self.fctrl is not None and not self._followers(self.fctrl, u, state):
            return None
        if self.o.stop_on_collision and self.guard.check(state.positions, u, state.dt,
                                                         state.t):
            return None  # a step would cross a static obstacle: stop before it
        return u

    def _drive(self, d: Driver, state: SimState) -> np.ndarray | None:
        """Driver ``d``'s command (capped, heading updated), or None when it gave up."""
        if self.sense_others:
            o = self._d_idx != d.index
            state = dataclasses.replace(state, field=RobotsAsObstacles(
                state.field, state.positions[self._d_idx[o]], self._d_rad[o]))
        v = d.controller.velocity(state, d.index)
        while v is None and not d.final:
            d.advance(state.k, state.t, "gave_up")
            v = d.controller.velocity(state, d.index)
        if v is None:
            d.gave_up = True
            self.gave_up.append(f"{d.robot.id}: local planner gave up at t={state.t:.2f}")
            return None
        v = np.asarray(v, dtype=float).reshape(2)
        if not np.all(np.isfinite(v)):
            d.gave_up = True
            self.gave_up.append(f"{d.robot.id}: local planner returned {v} at t={state.t:.2f}")
            return None
        sp = math.hypot(*v)
        cap = self.o.v_factor * d.robot.max_speed
        if self.fctrl is not None and sp > cap:
            v = v * (cap / sp)
        if sp * state.dt > 1e-9 * self.problem.length_scale:
            want = float(math.atan2(v[1], v[0]))
            if self.o.heading_rate > 0:
                dth = (want - d.heading + math.pi) % (2 * math.pi) - math.pi
                lim = self.o.heading_rate * state.dt
                want = d.heading + max(-lim, min(lim, dth))
            d.heading = want
        return v

    def _followers(self, fctrl: FollowerController, u: np.ndarray, state: SimState) -> bool:
        """The followers' commands (by ``fctrl``) into ``u``; False on non-finite output."""
        li = self.lead.index
        state.leader_velocity = u[li].copy()
        uf = fctrl.velocities(state, li, self.f_idx, self.lead.heading)
        uf = np.asarray(uf, dtype=float).reshape(len(self.f_idx), 2)
        if not np.all(np.isfinite(uf)):
            self.gave_up.append(f"formation controller returned non-finite velocities at "
                                f"t={state.t:.2f}")
            return False
        u[self.f_idx] = uf
        return True

    def followers_settled(self, positions: np.ndarray) -> bool:
        if self.fctrl is None or self.form is None:
            return True
        slots = positions[self.lead.index] + self.form.slot_offsets(self.lead.heading)
        err = np.hypot(*(positions[self.f_idx] - slots).T)
        return bool(np.all(err <= self.o.settle_tol * self.L))

    def done(self, state: SimState) -> bool:
        self.tracker.update(state)
        if not self.tracker.all_done:
            return False
        if self.k_arrived is None:
            self.k_arrived = state.k
        return (self.followers_settled(state.positions)
                or state.k - self.k_arrived >= self.o.settle_steps)

    def progress_cost(self, state: SimState) -> float:
        return float(math.hypot(*(state.positions[self.lead.index] - self.lead.robot.goal)))
