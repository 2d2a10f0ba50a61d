r"""The potential-field controller of one robot: the APF step and local-minimum detection.

Motion (eqs 12-13): heading :math:`\gamma = \operatorname{atan2}(F_y, F_x)` of the total force
(:func:`optplan.potential.field.evaluate_field`) and a step of length :math:`l`, i.e. the
*direction* :math:`F/\lVert F\rVert` with a bounded step (with map-scale distances the force
magnitudes span many decades, the direction does not).  The last step is shortened to land on
the goal.

Local-minimum detection (§IV.B.2), evaluated every step (which test fired is counted in the
result's ``extras["detections"]``):

* eq 38 on the reachable region :math:`R(p)`: :math:`U_{att}(p) \ne 0`, :math:`U_{rep}(p) \ne 0`
  and :math:`U(p) \le \min U(p^*)` over ``n_probe`` points on each of the circles of radius
  :math:`l` and :math:`l/2` around :math:`p` (the positions reachable in one step); the probe
  ring is evaluated only when the last step turned by more than 90 degrees or the goal
  distance has not decreased over 3 steps (a robot moving steadily downhill is not at a
  minimum);
* stall: the net displacement over the last ``window`` steps is below
  ``stall_ratio * window * l``;
* oscillation: at least ``window / 4`` heading reversals (consecutive steps with
  :math:`\cos\angle < -0.5`) in the last ``window`` steps.

The basic planner only counts detections; it gives up when it is still within
``2 l + radius`` of a detected minimum ``patience`` steps later (status ``approximate``).

:class:`APFController` is the basic planner's controller and the base of SA-APF's
(:mod:`optplan.potential.sa_apf`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from optplan.canonical import format_point
from optplan.potential.field import FieldParams, evaluate_field
from optplan.potential.guide import Guide
from optplan.potential.swept import free_steps
from optplan.problem import Problem, Robot
from optplan.sim import ObstacleField, SimState
from optplan.units import Each, Record, Unit

__all__ = ["APFController", "Trace", "STATS_UNITS", "ControllerOptions"]


class ControllerOptions(Protocol):
    """The options an :class:`APFController` reads: those of
    :class:`~optplan.potential.backend.PotentialFieldBackend` (their meaning is there)."""

    @property
    def l(self) -> float | None: ...  # noqa: E743 - the paper's name of the step length
    @property
    def window(self) -> int: ...
    @property
    def n_probe(self) -> int: ...
    @property
    def evade_factor(self) -> float: ...
    @property
    def stall_ratio(self) -> float: ...
    @property
    def detect_eq38(self) -> bool: ...
    @property
    def safe_step(self) -> bool: ...
    @property
    def guide(self) -> str: ...


#: The units of :attr:`APFController.stats` (and SA-APF's): counters, and the reason it gave up.
STATS_UNITS = Record({
    "local_minima_detected": Unit.DIMENSIONLESS, "distinct_minima": Unit.DIMENSIONLESS,
    "escapes": Unit.DIMENSIONLESS, "sa_steps": Unit.DIMENSIONLESS, "steps": Unit.DIMENSIONLESS,
    "evasions": Unit.DIMENSIONLESS, "detections": Each(Unit.DIMENSIONLESS),
    "guide_replans": Unit.DIMENSIONLESS,
    "gave_up": Unit.TEXT})


@dataclass
class Trace:
    """Per-step record of a controller: force magnitude, potential, temperature, mode."""

    force: list = field(default_factory=list)
    potential: list = field(default_factory=list)
    temperature: list = field(default_factory=list)
    mode: list = field(default_factory=list)

    def drop_last(self) -> None:
        """Forget the last row (a step recorded twice: once per mode)."""
        for col in (self.force, self.potential, self.temperature, self.mode):
            col.pop()


class APFController:
    """Potential-field controller for one robot: APF step + local-minimum detection.

    Implements :class:`optplan.interfaces.LocalController`: ``stats``, ``reset(goal)``,
    ``velocity(state, index)`` (the step length uses the simulator's ``state.dt``).  The basic
    planner never escapes; it gives up (returns ``None``) when it stays trapped ``patience``
    steps after a detection (the option of :class:`~optplan.potential.apf.APF`; SA-APF escapes
    instead, its ``patience`` is infinite).
    """

    def __init__(self, backend: ControllerOptions, problem: Problem, robot: Robot,
                 rng: np.random.Generator, params: FieldParams, patience: float = math.inf):
        self.b, self.patience = backend, patience
        self.problem = problem
        self.robot = robot
        self.rng = rng
        self.params = params
        self.goal = np.asarray(robot.goal if robot.goal is not None else robot.start, float)
        self.final_goal = self.goal.copy()  # the field's goal is a sub-goal when guided
        self.guide: Guide | None = None
        self._known: np.ndarray | None = None  # static obstacles on the known map (guide)
        self.mode = "apf"
        x0, y0, x1, y1 = problem.bounds
        inset = robot.radius + 16 * problem.frame.eps
        self._box = (np.array([x0 + inset, y0 + inset]), np.array([x1 - inset, y1 - inset]))
        self.stats: dict[str, Any] = {  # units: STATS_UNITS
            "local_minima_detected": 0, "distinct_minima": 0, "escapes": 0, "sa_steps": 0,
            "steps": 0,
            "detections": {"eq38": 0, "stall": 0, "oscillation": 0}, "gave_up": "",
        }
        self.trace = Trace()
        self.minima: list[np.ndarray] = []
        self._hist: list[np.ndarray] = []
        self._trap_since: int | None = None
        self._trap_at: np.ndarray | None = None
        self.gave_up = False
        ang = 2 * np.pi * np.arange(backend.n_probe) / backend.n_probe
        self._ring = np.stack([np.cos(ang), np.sin(ang)], axis=1)

    # -- protocol ---------------------------------------------------------------------
    def reset(self, goal: np.ndarray) -> None:
        """Set a new (sub-)goal; clears the trap memory (positions, minima, SA state)."""
        self.goal = np.asarray(goal, dtype=float).reshape(2)
        self.final_goal = self.goal.copy()
        self.guide = None
        self._hist.clear()
        self.minima.clear()
        self._trap_since = None
        self._trap_at = None
        self.gave_up = False

    def step_length(self, dt: float) -> float:
        """Eq 13's step ``l``: the option times the length unit, else ``max_speed * dt``."""
        if self.b.l is not None:
            return float(self.b.l) * self.params.unit
        return float(self.robot.max_speed * dt)

    def velocity(self, state: SimState, index: int) -> np.ndarray | None:
        dt = float(state.dt)
        x = np.asarray(state.positions[index], dtype=float)
        l_step = self.step_length(dt)
        self.stats["steps"] += 1
        if self.gave_up:
            return None
        if self.b.guide == "visgraph" and self.mode == "apf":
            if self.guide is None:
                self.guide = Guide(self.problem, self.robot, x, self.final_goal)
            self.goal = self.guide.subgoal(x, l_step)
            self.stats["guide_replans"] = self.guide.replans
        step = self._step(state, x, l_step, dt)
        if step is None:
            self.gave_up = True
            return None
        return step / dt

    # -- internals --------------------------------------------------------------------
    def _apf_step(self, x: np.ndarray, t: float, fld: ObstacleField, l_step: float,
                  ev: dict | None = None) -> tuple[np.ndarray, dict]:
        if ev is None:
            ev = evaluate_field(x[None], self.goal, fld, t, self.params)
        F = ev["F"][0]
        dg = float(np.hypot(*(self.goal - x)))
        if self.guide is not None and self.guide.visible and not self._unknown_near(fld, ev):
            F = self.goal - x  # guided: the segment to the sub-goal is free on the known map
        nf = float(np.hypot(*F))
        if nf < 1e-300 or not math.isfinite(nf):
            return np.zeros(2), ev
        step = F / nf * min(l_step, dg)
        if self.b.safe_step:
            step = self.free_step(x, step, fld, ev)
        return step, ev

    def _unknown_near(self, fld: ObstacleField, ev: dict) -> bool:
        """A sensed obstacle the known map does not have (temporary, moving, another robot)
        is within the influence distance."""
        known = self._known_mask(fld)
        d = ev["dist"][0]
        near = d <= self.params.rho_0 + self.robot.radius
        return bool(np.any(near[len(known):]) or np.any(near[:len(known)] & ~known))

    def _known_mask(self, fld: ObstacleField) -> np.ndarray:
        if self._known is None or len(self._known) != fld.n_static:
            self._known = np.array([o.known for o in fld.static], bool)
        return self._known

    def free_step(self, x: np.ndarray, step: np.ndarray, fld: ObstacleField, ev: dict
                  ) -> np.ndarray:
        """Option ``safe_step``: the step, or the first free one of its variants.

        Variants, in this order, each at lengths ``|step| * 2^-k`` (k = 0..4): the step; the
        step slid along the nearest sensed static obstacle (its component toward the obstacle
        removed, rescaled to ``|step|``); the step clipped to the bounds.  Each is decided by
        the exact segment test (:func:`~optplan.potential.swept.free_steps`); none free: no
        move (the stall test then sees it).
        """
        L = float(np.hypot(*step))
        if L <= 0 or free_steps(self.problem, self.robot, x, (x + step)[None])[0]:
            return step
        cands = [step]
        d = ev["dist"][0, :fld.n_static]
        if len(d) and np.isfinite(d).any():
            v = x - ev["near"][0, int(np.argmin(d))]
            nv = float(np.hypot(*v))
            if nv > 0:
                nh = v / nv
                slide = step - min(0.0, float(step @ nh)) * nh
                ls = float(np.hypot(*slide))
                if ls > 1e-9 * L:
                    cands.append(slide * (L / ls))
        cands.append(np.clip(x + step, *self._box) - x)
        C = np.array([c * 0.5 ** k for k in range(5) for c in cands])
        ok = np.flatnonzero(free_steps(self.problem, self.robot, x, x + C))
        return C[ok[0]] if len(ok) else np.zeros(2)

    def evade(self, x: np.ndarray, ev: dict, fld: ObstacleField, l_step: float
              ) -> np.ndarray | None:
        """Moving-obstacle safety step: when a dynamic obstacle's clearance is below
        ``evade_factor * l``, step (length ``l``) straight away from its nearest point.

        Needed because the improved repulsion (eq 34) vanishes near the goal by design and SA
        moves ignore the field; without it a moving obstacle can run into a robot that waits
        at its goal or anneals.  ``evade_factor = 0`` disables it.  ``ev`` is the
        :func:`evaluate_field` output at ``x`` (its sensor readings are reused).
        """
        f = self.b.evade_factor
        if f <= 0 or fld.n == fld.n_static:
            return None
        dd = ev["dist"][0, fld.n_static:] - self.robot.radius
        j = int(np.argmin(dd))
        if not dd[j] < f * l_step:
            return None
        v = x - ev["near"][0, fld.n_static + j]
        nv = float(np.hypot(*v))
        if nv < 1e-12:
            return None
        self.stats["evasions"] = self.stats.get("evasions", 0) + 1
        return v / nv * l_step

    def _record(self, ev: dict, temperature: float, mode: str) -> None:
        self.trace.force.append(float(np.hypot(*ev["F"][0])))
        self.trace.potential.append(float(ev["U"][0]))
        self.trace.temperature.append(temperature)
        self.trace.mode.append(mode)

    def detect(self, x: np.ndarray, t: float, fld: ObstacleField, l_step: float,
               ev: dict) -> str:
        """Local-minimum tests (eq 38, stall, oscillation); returns the reason or ``""``."""
        b = self.b
        dg = float(np.hypot(*(self.goal - x)))
        if dg <= self.problem.goal_tol(self.robot):
            return ""  # the global minimum (Fig. 12, step 5)
        self._hist.append(x.copy())
        if len(self._hist) > b.window + 1:
            del self._hist[0]
        if b.detect_eq38 and ev["U_rep"][0] > 0 and ev["U_att"][0] > 0 and self._suspect():
            probes = np.vstack([x + l_step * self._ring, x + 0.5 * l_step * self._ring])
            U = evaluate_field(probes, self.goal, fld, t, self.params)["U"]
            if ev["U"][0] <= U.min():
                return "eq38"
        if len(self._hist) > b.window:
            H = np.asarray(self._hist)
            net = float(np.hypot(*(H[-1] - H[0])))
            if net < b.stall_ratio * b.window * l_step:
                return "stall"
            d = np.diff(H, axis=0)
            s = np.hypot(d[:, 0], d[:, 1])
            ok = (s[1:] > 1e-12) & (s[:-1] > 1e-12)
            c = np.sum(d[1:] * d[:-1], axis=1) / np.where(ok, s[1:] * s[:-1], 1.0)
            if int(np.sum(ok & (c < -0.5))) >= max(2, b.window // 4):
                return "oscillation"
        return ""

    def _suspect(self) -> bool:
        """Cheap pre-filter for eq 38: the last step turned by more than 90 degrees, or the goal
        distance did not decrease over the last 3 steps.  A robot moving steadily downhill is
        not at a minimum, so the probe ring is only evaluated when this holds."""
        H = self._hist
        if len(H) < 3:
            return False
        d1, d2 = H[-1] - H[-2], H[-2] - H[-3]
        if float(d1 @ d2) < 0:
            return True
        if len(H) >= 4:
            g = self.goal
            eps = 1e-9 * self.params.unit
            return bool(np.hypot(*(H[-1] - g)) >= np.hypot(*(H[-4] - g)) - eps)
        return False

    def _centroid(self, x: np.ndarray) -> np.ndarray:
        """Estimated minimum: the centroid of the recent positions."""
        H = np.asarray(self._hist) if self._hist else x[None]
        return H[-min(len(H), max(4, self.b.window // 2)):].mean(axis=0)

    def _note_minimum(self, xm: np.ndarray, reason: str, l_step: float) -> None:
        """Count a detection event at ``xm``; remember ``xm`` (distinct places counted too)."""
        r_same = 2 * l_step + self.robot.radius
        self.stats["local_minima_detected"] += 1
        self.stats["detections"][reason] += 1
        if not any(np.hypot(*(xm - m)) <= r_same for m in self.minima):
            self.stats["distinct_minima"] += 1
        self.minima.append(xm)

    def _step(self, state: SimState, x: np.ndarray, l_step: float, dt: float
              ) -> np.ndarray | None:
        ev = evaluate_field(x[None], self.goal, state.field, state.t, self.params)
        ev_step = self.evade(x, ev, state.field, l_step)
        if ev_step is not None:
            self._record(ev, float("nan"), "evade")
            return ev_step
        step, ev = self._apf_step(x, state.t, state.field, l_step, ev)
        self._record(ev, float("nan"), "apf")
        reason = self.detect(x, state.t, state.field, l_step, ev)
        r_same = 2 * l_step + self.robot.radius
        if reason:
            xm = self._centroid(x)
            if self._trap_at is None or np.hypot(*(xm - self._trap_at)) > r_same:
                self._note_minimum(xm, reason, l_step)
                self._trap_at, self._trap_since = xm, self.stats["steps"]
        if self._trap_at is not None:
            if np.hypot(*(x - self._trap_at)) > r_same + l_step:
                self._trap_at, self._trap_since = None, None
            elif self.stats["steps"] - self._trap_since >= self.patience:
                dg = float(np.hypot(*(self.goal - x)))
                kind = ("oscillating near the goal (GNRON)" if dg <= self.params.rho_0 +
                        self.robot.radius else "trapped in a local minimum")
                self.stats["gave_up"] = (f"{kind} at {format_point(self.problem, x)}, "
                                         f"{dg * self.problem.world_unit:.2f} from the goal")
                return None
        return step

