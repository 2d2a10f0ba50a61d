r"""Basic artificial potential field (paper §II.E, eqs 3-13) and the shared local-planner core.

Mathematics
-----------
Attraction (eqs 3-4), with :math:`\rho_g = \lVert X - X_g \rVert`:

.. math::  U_{att} = \tfrac12 k \rho_g^2, \qquad F_{att} = -\nabla U_{att} = k (X_g - X).

(The paper prints :math:`k(X - X_g)` for eq 4; the negative gradient points *to* the goal, and
that is what the paper's Fig. 3 and eq 9 use.)

Repulsion of one obstacle (eqs 5-6 for the basic method, eq 34 for the improved one), with
:math:`\rho` the clearance between the robot disc and the obstacle's nearest boundary point:

.. math::  U_{rep} = \tfrac12 \eta \Big(\frac1\rho - \frac1{\rho_0}\Big)^2 \rho_g^{\,n},
           \qquad \rho \le \rho_0,

and zero beyond :math:`\rho_0`.  :math:`n = 0` is eq 5; :math:`n > 0` is eq 34.  Its negative
gradient is (eqs 35-37; eq 6 when :math:`n = 0`)

.. math::  F_{rep} = \eta\Big(\frac1\rho-\frac1{\rho_0}\Big)\frac{\rho_g^{\,n}}{\rho^2}\,\hat n_{OR}
           + \frac n2 \eta \Big(\frac1\rho-\frac1{\rho_0}\Big)^2 \rho_g^{\,n-1}\,\hat n_{RG},

:math:`\hat n_{OR}` the unit vector obstacle -> robot, :math:`\hat n_{RG}` robot -> goal.  The
clearance is clamped, :math:`\rho \ge \rho_{min}`, so forces stay finite.

Motion (eqs 12-13): heading :math:`\gamma = \operatorname{atan2}(F_y, F_x)` of the total force
and a step of length :math:`l`, i.e. the *direction* :math:`F/\lVert F\rVert` with a bounded
step (with map-scale distances the force magnitudes span many decades, the
direction does not).  The last step is shortened to land on the goal.

Units of :math:`\eta` (a choice, documented in ``docs/solvers/apf.md``).  In eq 34
:math:`\eta` multiplies :math:`\rho_g^n`, so :math:`\eta_{(34)}` and :math:`\eta_{(5)}` cannot
both be 3.7 in the same length unit.  On the paper's map scale (hundreds of units,
:math:`\rho_0 = 20`) the literal eq 6 with :math:`\eta = 3.7, k = 15` balances attraction only
at a clearance of ~0.1 map units: the basic robot drives into obstacles.  The basic planner
therefore uses :math:`\eta_{eff} = \eta \cdot (D/\lambda)^{m}` with :math:`D` the start-goal
distance and ``eta_match_n`` :math:`= m` (3, the improved method's exponent, in the ``apf-paper``
preset):
both planners then have the same repulsion at the start, and they differ only near the goal,
which is exactly the paper's comparison.  ``eta_match_n = 0`` gives the literal eq 6.

Length unit.  Every length above is measured in the problem's length unit
:math:`\lambda` = :attr:`optplan.problem.Problem.length_scale` (1 on the paper's scenes): the
field is evaluated on :math:`\tilde x = x/\lambda` and distances divided by :math:`\lambda`
(:func:`evaluate_field`), the length options (``rho_0``, ``rho_min``, ``l``, ``sense_range``,
and SA-APF's ``sa_step``, ``rollout``) are multiples of :math:`\lambda`, so a scene drawn
:math:`s` times larger gives the same trajectory times :math:`s` (docs/solvers/apf.md).

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
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.canonical import format_point
from optplan.interfaces import LocalPlanner
from optplan.options import option
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status
from optplan.sim import ObstacleField, SimState, simulate
from optplan.solver import Backend, make_rng

__all__ = [
    "APF",
    "PotentialFieldBackend",
    "run_local_planner",
    "APFController",
    "FieldParams",
    "attractive_potential",
    "attractive_force",
    "repulsive_potential",
    "repulsive_force",
    "evaluate_field",
    "oscillation_index",
]


# --------------------------------------------------------------------------------------
# pure force / potential functions (vectorised; shared with sa_apf)
# --------------------------------------------------------------------------------------


def attractive_potential(x: np.ndarray, goal: np.ndarray, k: float) -> np.ndarray:
    """Eq 3: :math:`U_{att} = \\tfrac12 k \\lVert X - X_g\\rVert^2`; ``x`` is ``(..., 2)``."""
    d = np.asarray(x, dtype=float) - np.asarray(goal, dtype=float)
    return 0.5 * k * np.sum(d * d, axis=-1)


def attractive_force(x: np.ndarray, goal: np.ndarray, k: float) -> np.ndarray:
    """Eq 4: :math:`F_{att} = -\\nabla U_{att} = k (X_g - X)`, shape ``(..., 2)``."""
    return k * (np.asarray(goal, dtype=float) - np.asarray(x, dtype=float))


def repulsive_potential(rho: np.ndarray, rho_g: np.ndarray, eta: float, rho_0: float,
                        n: float = 0.0) -> np.ndarray:
    """Eq 5 (``n = 0``) / eq 34: repulsive potential of each obstacle.

    Parameters
    ----------
    rho : array
        Clearance robot-obstacle (already clamped to ``rho_min`` by the caller; ``inf`` = unseen).
    rho_g : array
        Distance robot-goal (broadcast against ``rho``).
    eta, rho_0, n : float
        Gain (eq 5), influence distance (map units), goal-distance exponent (eq 34).
    """
    rho = np.asarray(rho, dtype=float)
    inside = rho <= rho_0
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(inside, 1.0 / rho - 1.0 / rho_0, 0.0)
    gn = np.power(np.asarray(rho_g, dtype=float), n) if n != 0 else 1.0
    return np.where(inside, 0.5 * eta * a * a * gn, 0.0)


def repulsive_force(x: np.ndarray, near: np.ndarray, rho: np.ndarray, goal: np.ndarray,
                    eta: float, rho_0: float, n: float = 0.0) -> np.ndarray:
    """Eq 6 (``n = 0``) / eqs 35-37: repulsive force of each obstacle, shape ``(..., 2)``.

    ``F_rep1`` (eq 36) points from the obstacle's nearest point to the robot; ``F_rep2``
    (eq 37) points from the robot to the goal and vanishes for ``n = 0``.

    Parameters
    ----------
    x : array ``(..., 2)``
        Robot position(s).
    near : array ``(..., 2)``
        Nearest obstacle boundary point for each obstacle (``nan`` where unseen).
    rho : array ``(...)``
        Clamped clearance (``> 0``); obstacles with ``rho > rho_0`` contribute nothing.
    goal : array ``(2,)``
    """
    x = np.asarray(x, dtype=float)
    rho = np.asarray(rho, dtype=float)
    inside = rho <= rho_0
    v = x - near
    nv = np.hypot(v[..., 0], v[..., 1])
    ok = inside & (nv > 1e-12)
    with np.errstate(divide="ignore", invalid="ignore"):
        n_or = np.where(ok[..., None], v / np.where(ok, nv, 1.0)[..., None], 0.0)
        a = np.where(inside, 1.0 / rho - 1.0 / rho_0, 0.0)
        g = np.asarray(goal, dtype=float) - x
        rg = np.hypot(g[..., 0], g[..., 1])
        f1 = np.where(inside, eta * a / np.where(inside, rho, 1.0) ** 2, 0.0)
        if n != 0:
            f1 = f1 * rg ** n
    F = f1[..., None] * n_or
    if n != 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            n_rg = np.where((rg > 1e-12)[..., None], g / np.where(rg > 1e-12, rg, 1.0)[..., None],
                            0.0)
            f2 = np.where(inside & (rg > 1e-12), 0.5 * n * eta * a * a
                          * np.power(np.where(rg > 1e-12, rg, 1.0), n - 1.0), 0.0)
        F = F + f2[..., None] * n_rg
    return F


@dataclass(frozen=True)
class FieldParams:
    """Everything the potential needs: gains, exponent, clamp, robot radius, sensing range.

    ``rho_0``, ``rho_min``, ``radius`` and ``sense_range`` are map lengths; ``unit`` is the
    problem's length unit (:attr:`optplan.problem.Problem.length_scale`): the potential is
    evaluated on positions and distances divided by it, so ``k`` and ``eta`` are per length
    unit and the field of a scene drawn ``s`` times larger is the same field.
    """

    k: float
    eta: float
    rho_0: float
    n: float
    rho_min: float
    radius: float
    sense_range: float
    unit: float = 1.0


def evaluate_field(points: np.ndarray, goal: np.ndarray, fld: ObstacleField, t: float,
                   p: FieldParams) -> dict[str, np.ndarray]:
    """Total potential and force at ``points`` ``(P, 2)`` for obstacles sensed from each point.

    Only (point, obstacle) pairs inside the sensing range are evaluated (the geometry core's
    bounding-circle screen behind :meth:`ObstacleField.nearest` discards the rest), so the cost
    barely grows with obstacles out of range.  Positions and distances are divided by
    ``p.unit`` before eqs 3-6 / 34-37 are applied: ``U`` is dimensionless and ``F`` is
    :math:`-\\nabla_{\\tilde x} U` with :math:`\\tilde x = x / \\text{unit}` (its direction is
    that of :math:`-\\nabla_x U`).  Returns a dict with ``U``, ``U_att``, ``U_rep`` ``(P,)``,
    ``F`` ``(P, 2)`` and ``clearance`` ``(P,)`` (min raw clearance robot disc - obstacle in
    map units, unclamped; ``inf`` if none is sensed), plus the sensor readings ``near``
    ``(P, n, 2)`` and ``dist`` ``(P, n)`` (map units).
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    P = len(pts)
    goal = np.asarray(goal, dtype=float)
    near, dist = fld.nearest(pts, t, max_range=p.sense_range)
    u = float(p.unit)
    g = (goal - pts) / u
    rho_g = np.hypot(g[:, 0], g[:, 1])
    u_att = 0.5 * p.k * rho_g * rho_g
    F = p.k * g
    u_rep = np.zeros(P)
    cmin = np.full(P, np.inf)
    r_idx, o_idx = np.nonzero(dist <= p.rho_0 + p.radius)  # pairs inside the influence range
    if len(r_idx):
        clear = dist[r_idx, o_idx] - p.radius
        np.minimum.at(cmin, r_idx, clear)
        rho = np.maximum(clear, p.rho_min) / u
        rho_0 = p.rho_0 / u
        x = pts[r_idx] / u
        rg = rho_g[r_idx]
        ur = repulsive_potential(rho, rg, p.eta, rho_0, p.n)
        f = repulsive_force(x, near[r_idx, o_idx] / u, rho, goal / u, p.eta, rho_0, p.n)
        u_rep = np.bincount(r_idx, weights=ur, minlength=P)
        F = F + np.stack([np.bincount(r_idx, weights=f[:, 0], minlength=P),
                          np.bincount(r_idx, weights=f[:, 1], minlength=P)], axis=1)
    return {"U": u_att + u_rep, "U_att": u_att, "U_rep": u_rep, "F": F, "clearance": cmin,
            "near": near, "dist": dist}


def oscillation_index(path: np.ndarray, unit: float = 1.0) -> float:
    """Sum of absolute heading changes (rad) per ``unit`` of length of a trajectory (the
    local planners pass the problem's ``length_scale``, so the index is scale-free)."""
    p = np.asarray(path, dtype=float)
    d = np.diff(p, axis=0)
    s = np.hypot(d[:, 0], d[:, 1])
    d = d[s > 1e-9]
    L = float(s.sum()) / float(unit)
    if len(d) < 2 or L <= 0:
        return 0.0
    th = np.arctan2(d[:, 1], d[:, 0])
    dth = np.abs((np.diff(th) + np.pi) % (2 * np.pi) - np.pi)
    return float(dth.sum() / L)


# --------------------------------------------------------------------------------------
# the controller (optplan.interfaces.LocalController)
# --------------------------------------------------------------------------------------


@dataclass
class _Trace:
    force: list = field(default_factory=list)
    potential: list = field(default_factory=list)
    temperature: list = field(default_factory=list)
    mode: list = field(default_factory=list)


class APFController:
    """Potential-field controller for one robot: APF step + local-minimum detection.

    Implements :class:`optplan.interfaces.LocalController`: ``stats``, ``reset(goal)``,
    ``velocity(state, index)`` (the step length uses the simulator's ``state.dt``).  The basic
    planner never escapes; it gives up (returns ``None``) when it stays trapped ``patience``
    steps after a detection.
    """

    def __init__(self, backend: PotentialFieldBackend, problem: Problem, robot: Robot,
                 rng: np.random.Generator, params: FieldParams):
        self.b = backend
        self.problem = problem
        self.robot = robot
        self.rng = rng
        self.params = params
        self.goal = np.asarray(robot.goal if robot.goal is not None else robot.start, float)
        self.stats: dict[str, Any] = {
            "local_minima_detected": 0, "distinct_minima": 0, "escapes": 0, "sa_steps": 0,
            "steps": 0,
            "detections": {"eq38": 0, "stall": 0, "oscillation": 0}, "gave_up": "",
        }
        self.trace = _Trace()
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
        nf = float(np.hypot(*F))
        dg = float(np.hypot(*(self.goal - x)))
        if nf < 1e-300 or not math.isfinite(nf):
            return np.zeros(2), ev
        return F / nf * min(l_step, dg), ev

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
            elif self.stats["steps"] - self._trap_since >= self.b.patience:
                dg = float(np.hypot(*(self.goal - x)))
                kind = ("oscillating near the goal (GNRON)" if dg <= self.params.rho_0 +
                        self.robot.radius else "trapped in a local minimum")
                self.stats["gave_up"] = (f"{kind} at {format_point(self.problem, x)}, "
                                         f"{dg * self.problem.world_unit:.2f} from the goal")
                return None
        return step


class RobotsAsObstacles:
    """An obstacle field plus other robots as disc obstacles frozen at their current positions.

    Beyond the paper (which plans one robot, or a formation through its leader): when
    ``run_local_planner`` simulates several independently planned robots, each one senses the
    others through this view of the field (option ``sense_robots``).  The robots come after
    the scene's dynamic obstacles, so they count as moving obstacles (``n_static`` is
    unchanged), also for :meth:`APFController.evade`.  Implements the part of
    :class:`~optplan.sim.ObstacleField` the controllers use: ``nearest``, ``n``, ``n_static``.
    """

    def __init__(self, base: ObstacleField, centers: np.ndarray, radii: np.ndarray):
        self.base = base
        self.centers = np.asarray(centers, dtype=float).reshape(-1, 2)
        self.radii = np.asarray(radii, dtype=float).reshape(-1)
        self.n_static = base.n_static
        self.n = base.n + len(self.radii)

    def nearest(self, points: np.ndarray, t: float = 0.0,
                max_range: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`ObstacleField.nearest` with the robot discs appended (same conventions)."""
        near, dist = self.base.nearest(points, t, max_range)
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        v = pts[:, None, :] - self.centers[None, :, :]  # (R, K, 2)
        nv = np.hypot(v[..., 0], v[..., 1])
        u = np.where(nv[..., None] > 1e-12, v / np.maximum(nv, 1e-12)[..., None],
                     np.array([1.0, 0.0]))
        rn = self.centers[None] + u * self.radii[None, :, None]
        rd = np.maximum(nv - self.radii[None, :], 0.0)
        far = rd > max_range
        rn[far] = np.nan
        rd[far] = np.inf
        return np.concatenate([near, rn], axis=1), np.concatenate([dist, rd], axis=1)


# --------------------------------------------------------------------------------------
# shared solve(): simulate every planned robot with its own controller
# --------------------------------------------------------------------------------------


def run_local_planner(backend: PotentialFieldBackend, problem: Problem, rng: np.random.Generator,
                      callback: Callable[[Progress], Any] | None) -> Any:
    """Simulate ``problem.planned_robots`` with ``backend``'s controllers; build the Result."""
    t_start = time.perf_counter()
    robots = problem.planned_robots
    ids = [r.id for r in robots]
    ctrls = [backend.controller(problem, r.id, rng) for r in robots]
    goals = np.array([r.goal for r in robots], dtype=float)
    tols = np.array([problem.goal_tol(r) for r in robots])
    dt = backend.dt
    fld = ObstacleField(problem)
    stopped = np.zeros(len(ids), bool)

    def at_goal(pos: np.ndarray) -> np.ndarray:
        return np.hypot(*(pos - goals).T) <= tols

    def done(state: SimState) -> bool:
        return bool(np.all(at_goal(state.positions) | stopped))

    radii = np.array([r.radius for r in robots], dtype=float)
    sense_robots = backend.sense_robots and len(robots) > 1

    def policy(state: SimState) -> np.ndarray | None:
        out = np.zeros((len(ids), 2))
        reached = at_goal(state.positions)
        for i, c in enumerate(ctrls):
            if reached[i] or stopped[i]:
                continue
            seen = state
            if sense_robots:  # the other robots as discs where they are now
                o = np.arange(len(ids)) != i
                seen = dataclasses.replace(state, field=RobotsAsObstacles(
                    state.field, state.positions[o], radii[o]))
            v = c.velocity(seen, i)
            if v is None:
                stopped[i] = True
            else:
                out[i] = v
        if np.all(stopped | reached) and np.any(stopped):
            return None
        return out

    def cost(state: SimState) -> float:
        return float(np.max(np.hypot(*(state.positions - goals).T)))

    try:
        out = simulate(problem, policy, ids=ids, dt=dt, max_steps=backend.max_steps, done=done,
                       field_=fld, callback=callback, progress_cost=cost)
    except (FloatingPointError, np.linalg.LinAlgError) as e:  # numerical failure -> failed
        starts = {r.id: np.vstack([r.start, r.start]) for r in robots}
        return backend.finish(problem, starts, claim=Status.failed, times=np.array([0.0, dt]),
                              message=f"numerical failure: {e}",
                              wall_time=time.perf_counter() - t_start)
    paths = out.paths()
    reached = at_goal(out.positions[-1])
    claim, msg = _local_outcome(out, bool(np.all(reached)), ids, ctrls, backend.max_steps)
    lead = problem.leader.id if problem.leader.id in paths else ids[0]
    li = ids.index(lead)
    t_goal = float("nan")
    if reached[li]:
        dg = np.hypot(*(out.positions[:, li, :] - goals[li]).T)
        t_goal = float(out.times[int(np.argmax(dg <= tols[li]))])
    unit = problem.length_scale
    extra = {"time_to_goal": t_goal, "oscillation_index": oscillation_index(paths[lead], unit)}
    detections = {k: int(sum(c.stats["detections"][k] for c in ctrls))
                  for k in ("eq38", "stall", "oscillation")}
    extras = {
        "local_minima_detected": int(sum(c.stats["local_minima_detected"] for c in ctrls)),
        "detections": detections,
        "local_minima_escaped": int(sum(c.stats["escapes"] for c in ctrls)),
        "sa_steps": int(sum(c.stats["sa_steps"] for c in ctrls)),
        "sim_steps": int(out.steps),
        "sim_reason": out.reason,
        "length_scale": unit,
        "controllers": {ids[i]: c.stats for i, c in enumerate(ctrls)},
        "minima": {ids[i]: [m.tolist() for m in c.minima] for i, c in enumerate(ctrls)},
        "collision": out.collision,
    }
    return backend.finish(problem, paths, claim=claim, times=out.times,
                          cost=float(np.sum(np.hypot(*np.diff(paths[lead], axis=0).T))),
                          message=msg, n_iter=int(out.steps), n_eval=int(out.steps),
                          history=_trace_history(ctrls[li].trace, dt), extras=extras,
                          metrics_extra=extra, wall_time=time.perf_counter() - t_start)


def _local_outcome(out: Any, reached: bool, ids: list[str], ctrls: list[APFController],
                   max_steps: int) -> tuple[Status, str]:
    """The claimed status and the message of a finished local-planner simulation."""
    if out.reason == "collision":
        return Status.failed, f"collision: {out.collision}"
    if out.reason == "done" and reached:
        return Status.solved, "goal reached"
    if out.reason == "callback":
        return Status.approximate, "stopped by the callback"
    if out.reason == "budget":
        return Status.approximate, f"step budget ({max_steps}) exhausted"
    why = "; ".join(f"{ids[i]}: {c.stats['gave_up']}" for i, c in enumerate(ctrls)
                    if c.stats["gave_up"])
    return Status.approximate, f"gave up: {why}"


def _trace_history(tr: _Trace, dt: float) -> History:
    """The controller's per-step trace as the result's history."""
    hist = History()
    for k in range(len(tr.force)):
        hist.append(iteration=k, best_cost=tr.potential[k], n_eval=k + 1,
                    time=k * dt, force=tr.force[k], potential=tr.potential[k],
                    temperature=tr.temperature[k], sa=tr.mode[k] != "apf")
    return hist


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class PotentialFieldBackend(Backend):
    """Options shared by ``apf`` and ``sa-apf`` (the time-stepping potential-field planners).

    Lengths marked "(x length_scale)" are multiples of the problem's length unit
    :attr:`optplan.problem.Problem.length_scale` (1 on the paper's maps); the potential is
    evaluated on positions divided by it (:class:`FieldParams`), so a preset behaves the same
    on a scene drawn in centimetres, metres or kilometres.

    Parameters
    ----------
    k : float
        Attraction gain (eq 4), force per length unit of goal distance.  Paper: 15.
    eta : float
        Repulsion gain (eq 5 for ``apf``, eq 34 for ``sa-apf``), per length unit.  Paper: 3.7.
    rho_0 : float
        Obstacle influence distance (eq 5 / 34), measured as clearance from the robot disc
        (x length_scale).  Paper: 20.
    l : float or None
        Step length per time step (eq 13, x length_scale); ``None`` = the robot's
        ``max_speed * dt`` (``dt`` of the simulation that runs the controller).
    dt : float
        Time step of the planner's own simulation, s.
    max_steps : int
        Step budget of the simulation (the run never hangs).
    rho_min : float
        Clamp of the clearance in eqs 5-6 / 34-37 so forces stay finite (x length_scale;
        at most ``rho_0``).
    sense_range : float or None
        Sensing range measured from the robot centre (x length_scale); ``None`` = the
        scenario's ``[sensing]`` range, else ``rho_0 + radius``.
    window : int
        Steps in the stall / oscillation window of the local-minimum detection.
    stall_ratio : float
        Stall when the net displacement over ``window`` steps is below
        ``stall_ratio * window * l`` (dimensionless).
    n_probe : int
        Probe directions on each circle of the reachable region ``R(p)`` (eq 38).
    detect_eq38 : bool
        Use the eq 38 test (the stall and oscillation tests are always on).
    evade_factor : float
        Moving-obstacle safety step when a dynamic obstacle is closer than ``evade_factor * l``
        (:meth:`APFController.evade`); ``0`` disables it (dimensionless).
    sense_robots : bool
        Beyond the paper: with several planned robots (no formation), each senses the others
        as disc obstacles at their current positions (:class:`RobotsAsObstacles`); without
        it they drive through each other.  No effect with one planned robot.
    """

    k: float = option(15.0, lo=0.0, lo_open=True)
    eta: float = option(3.7, lo=0.0)
    rho_0: float = option(20.0, lo=0.0, lo_open=True, scale=True)
    l: float | None = option(None, lo=0.0, lo_open=True, scale=True)
    dt: float = option(0.2, lo=0.0, hi=60.0, lo_open=True)
    max_steps: int = option(3000, lo=1, hi=10_000_000)
    rho_min: float = option(0.05, lo=0.0, lo_open=True, scale=True)
    sense_range: float | None = option(None, lo=0.0, lo_open=True, scale=True)
    window: int = option(16, lo=4, hi=10_000)
    stall_ratio: float = option(0.15, lo=0.0, hi=1.0, lo_open=True)
    n_probe: int = option(16, lo=3, hi=360)
    detect_eq38: bool = option(True)
    evade_factor: float = option(0.0, lo=0.0, hi=100.0)
    sense_robots: bool = option(True)

    def check(self) -> None:
        if self.rho_min > self.rho_0:
            raise ValueError(f"option 'rho_min' of backend {self.name!r} must be <= rho_0 "
                             f"({self.rho_0!r}), got {self.rho_min!r}")

    def sensing(self, problem: Problem, robot: Robot) -> float:
        """Sensing range from the robot centre, map units: the option (x length_scale), the
        scenario's ``[sensing]`` range, else ``rho_0 * length_scale + radius``."""
        s = problem.length_scale
        if self.sense_range is not None:
            return float(self.sense_range * s)
        if problem.sensing_range is not None:
            return float(problem.sensing_range)
        return float(self.rho_0 * s + robot.radius)

    def _params(self, problem: Problem, robot: Robot, eta: float, n: float) -> FieldParams:
        s = problem.length_scale
        return FieldParams(self.k, eta, self.rho_0 * s, n, self.rho_min * s, robot.radius,
                           self.sensing(problem, robot), s)

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None):
        gen = make_rng(rng)[0]
        return run_local_planner(self, problem, gen, callback)


@dataclass(frozen=True, kw_only=True)
class APF(PotentialFieldBackend, LocalPlanner):
    """Basic artificial potential field local planner (paper §II.E, eqs 3-13).

    Parameters
    ----------
    eta_match_n : float
        Unit matching of ``eta`` with the improved method (module docstring): the basic
        repulsion uses ``eta * (D / length_scale) ** eta_match_n`` with ``D`` the start-goal
        distance.  ``0`` is the literal eq 6 (on map-scale scenes its repulsion is
        negligible).  Default 3.
    patience : int
        Steps the basic planner waits, still trapped, after a detection before giving up.
    k, eta, rho_0, l, dt, max_steps, rho_min, sense_range, window, stall_ratio, n_probe, \
detect_eq38, evade_factor, sense_robots
        Shared options, see :class:`PotentialFieldBackend`.
    """

    name: ClassVar[str] = "apf"
    eta_match_n: float = option(3.0, lo=0.0, hi=6.0)
    patience: int = option(30, lo=1, hi=10_000_000)

    # -- helpers ------------------------------------------------------------------------
    def field_params(self, problem: Problem, robot: Robot) -> FieldParams:
        """The potential's parameters for ``robot`` (basic method: n = 0, matched eta)."""
        eta = self.eta
        if self.eta_match_n and robot.goal is not None:
            D = max(float(np.hypot(*(robot.goal - robot.start))) / problem.length_scale, 1e-9)
            eta = self.eta * D ** self.eta_match_n
        return self._params(problem, robot, eta, 0.0)

    def controller(self, problem: Problem, robot_id: str, rng: np.random.Generator
                   ) -> APFController:
        """A :class:`~optplan.interfaces.LocalController` for ``robot_id``
        (:class:`~optplan.interfaces.LocalPlanner`)."""
        robot = problem.robot(robot_id)
        return APFController(self, problem, robot, rng, self.field_params(problem, robot))
