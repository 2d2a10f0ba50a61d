r"""SA-APF: improved repulsion (eqs 34-37) + local-minimum detection (eq 38) + simulated
annealing escape (paper §IV.A-B, eqs 14-16, flow of Fig. 12).

Mathematics
-----------
Potential: :math:`U = U_{att} + \sum_i U_{rep,i}` with the improved repulsion of eq 34,

.. math:: U_{rep} = \tfrac12\eta\Big(\frac1\rho-\frac1{\rho_0}\Big)^2\rho_g^{\,n},

whose negative gradient is :math:`F_{rep1}` (eq 36, away from the obstacle) plus
:math:`F_{rep2}` (eq 37, toward the goal); both vanish at the goal for :math:`n > 1`, so the goal
is the global minimum (GNRON fixed).  The forces are in :mod:`optplan.backends.apf`.

Flow (Fig. 12): APF step (eqs 12-13) -> local-minimum test (eq 38, stall, oscillation; see
:mod:`optplan.backends.apf`) -> at the goal: done; elsewhere: simulated annealing escape
(§IV.B.3), then back to APF.

Simulated annealing escape (§IV.B.3 steps 1-4):

1. :math:`T \leftarrow T_0`, :math:`X` = the detected minimum :math:`X_{lm}`.
2. Random perturbation (eq 14): :math:`X' = X + r \odot v \cdot T_0/T`, :math:`r \sim U[-1,1]^2`,
   :math:`v = (s, s)` with :math:`s` = ``sa_step`` (perturbations widen as the system cools, as
   eq 14 prescribes; capped at the sensing range).  Candidates outside the bounds, or whose
   straight segment from :math:`X` passes within ``margin`` of a sensed obstacle, are rejected
   (a robot cannot teleport through walls).
3. Metropolis (eq 15, §IV.B.3 step 3): accept when :math:`\Delta U = U(X') - U(X) < 0`, else with
   probability :math:`\exp(-\Delta U / (k_B T))`.  **k_B = 1 (dimensionless).**  The paper
   writes :math:`k_B = 1.380649\times10^{-23}` J/K; with potentials of order :math:`10^3` and any
   sane :math:`T`, :math:`\Delta U/(k_B T) \sim 10^{26}`, so the acceptance probability of every
   uphill move is exactly 0 in floating point and SA degenerates into greedy descent, which
   cannot leave a local minimum.  ``T`` is measured in units of potential: :math:`T_0 =
   \tau_0\,U_{att}(X_{lm})` (``tau_0`` dimensionless), which makes the acceptance scale-free.
4. Cooling (eq 16) :math:`T \leftarrow \theta T` after every proposal.  An accepted candidate
   becomes a waypoint the robot drives to (at most :math:`l` per time step, every step checked
   against sensed obstacles).  On arrival the *escape test* runs: a greedy APF roll-out of
   ``rollout`` map units from the new position (obstacles as sensed along it, frozen at the
   current time) must not come back within :math:`2l + r` of any detected minimum; then the
   robot has left the minimum's basin, SA stops and APF resumes.  Otherwise SA continues from
   the new position.  When :math:`T < 10^{-3} T_0` the system is re-heated (up to
   ``sa_restarts`` times); after that, or ``sa_budget`` proposals, the planner gives up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.backends.apf import (
    APFController,
    FieldParams,
    PotentialFieldBackend,
    evaluate_field,
)
from optplan.interfaces import LocalPlanner
from optplan.problem import Problem, Robot
from optplan.sim import ObstacleField, SimState
from optplan.solver import check_int, check_range

__all__ = ["SAAPF", "SAAPFController", "K_B"]

#: Boltzmann constant used in the Metropolis test (dimensionless; see the module docstring).
K_B = 1.0


class SAAPFController(APFController):
    """APF with the improved potential, eq 38 detection and the SA escape (Fig. 12)."""

    escapes_enabled: ClassVar[bool] = True

    def __init__(self, backend: SAAPF, problem: Problem, robot: Robot,
                 rng: np.random.Generator, params: FieldParams):
        super().__init__(backend, problem, robot, rng, params)
        self.sb = backend
        self._sa_reset()
        x0, y0, x1, y1 = problem.bounds
        r = robot.radius
        self._lo = np.array([x0 + r, y0 + r])
        self._hi = np.array([x1 - r, y1 - r])
        self.margin = 0.25 * robot.radius

    def _sa_reset(self) -> None:
        self.mode = "apf"
        self.T = float("nan")
        self.T0 = float("nan")
        self.target: np.ndarray | None = None
        self.x_lm: np.ndarray | None = None
        self.escape_steps = 0
        self.restarts = 0

    def reset(self, goal: np.ndarray) -> None:
        super().reset(goal)
        self._sa_reset()

    # -- SA pieces ------------------------------------------------------------------------
    def _start_sa(self, xm: np.ndarray, x: np.ndarray, t: float, fld: ObstacleField) -> None:
        self.mode = "sa"
        self.x_lm = xm
        u_att = 0.5 * self.params.k * float(np.sum((x - self.goal) ** 2))
        self.T0 = self.sb.tau_0 * max(u_att, 1e-12)
        self.T = self.T0
        self.target = None
        self.escape_steps = 0
        self.restarts = 0

    def _segments_clear(self, x: np.ndarray, cands: np.ndarray, t: float,
                        fld: ObstacleField) -> np.ndarray:
        """Straight segments ``x -> cand`` keep ``margin`` clearance from sensed obstacles."""
        d = cands - x
        L = np.hypot(d[:, 0], d[:, 1])
        h = max(0.5 * self.robot.radius, 1e-3)
        S = int(min(max(np.ceil(L.max() / h), 1), 400)) if len(L) else 1
        s = np.linspace(0.0, 1.0, S + 1)[1:]
        pts = x + s[None, :, None] * d[:, None, :]  # (m, S, 2)
        _, dist = fld.nearest(pts.reshape(-1, 2), t, max_range=self.params.sense_range)
        cl = (dist.min(axis=1) if dist.shape[1] else np.full(len(pts.reshape(-1, 2)), np.inf))
        cl = cl.reshape(len(cands), S) - self.robot.radius
        return cl.min(axis=1) >= self.margin

    def escaped(self, x: np.ndarray, t: float, fld: ObstacleField, l_step: float) -> bool:
        """Escape test: a greedy APF roll-out from ``x`` stays away from every known minimum."""
        r_same = 2 * l_step + self.robot.radius
        M = max(1, int(math.ceil(self.sb.rollout / l_step)))
        p = x.copy()
        mins = np.asarray(self.minima) if self.minima else np.zeros((0, 2))
        tol = self.problem.goal_tol(self.robot)
        for _ in range(M):
            if len(mins) and np.min(np.hypot(*(mins - p).T)) <= r_same:
                return False
            g = float(np.hypot(*(self.goal - p)))
            if g <= tol:
                return True
            F = evaluate_field(p[None], self.goal, fld, t, self.params)["F"][0]
            nf = float(np.hypot(*F))
            if nf < 1e-300 or not math.isfinite(nf):
                break
            p = p + F / nf * min(l_step, g)
        return not (len(mins) and np.min(np.hypot(*(mins - p).T)) <= r_same)

    def _propose(self, x: np.ndarray, t: float, fld: ObstacleField) -> np.ndarray | None:
        """Run up to ``sa_batch`` SA proposals (eqs 14-16); return the accepted candidate."""
        sb = self.sb
        m = sb.sa_batch
        # eq 14: scale of the perturbation for each of the next m proposals
        Ts = self.T * sb.theta ** np.arange(m)
        scale = np.minimum(sb.sa_step * self.T0 / Ts, self.params.sense_range)
        dX = self.rng.uniform(-1.0, 1.0, size=(m, 2)) * scale[:, None]
        cand = x + dX
        u_rand = self.rng.random(m)
        inb = np.all((cand >= self._lo) & (cand <= self._hi), axis=1)
        ok = inb.copy()
        if ok.any():
            ok[ok] = self._segments_clear(x, cand[ok], t, fld)
        ev = evaluate_field(np.vstack([x[None], cand]), self.goal, fld, t, self.params)
        dU = ev["U"][1:] - ev["U"][0]
        for j in range(m):
            self.stats["sa_steps"] += 1
            self.escape_steps += 1
            T = self.T
            self.T *= sb.theta  # eq 16
            if not ok[j]:
                continue
            if dU[j] < 0 or u_rand[j] < math.exp(-dU[j] / (K_B * T)):  # eq 15 / step 3
                return cand[j]
        return None

    def _sa_step(self, state: SimState, x: np.ndarray, l_step: float, ev: dict | None = None
                 ) -> np.ndarray | None:
        fld, t = state.field, state.t
        if ev is None:
            ev = evaluate_field(x[None], self.goal, fld, t, self.params)
        self._record(ev, self.T, "sa")
        if self.target is not None:
            d = self.target - x
            dist = float(np.hypot(*d))
            if dist <= 1e-9:
                self.target = None
                if self.escaped(x, t, fld, l_step):
                    self.stats["escapes"] += 1
                    self.mode = "apf"
                    self._hist.clear()
                    self._trap_at = None
                    step, _ = self._apf_step(x, t, fld, l_step, ev)
                    return step
            else:
                step = d / dist * min(l_step, dist)
                cl = evaluate_field((x + step)[None], self.goal, fld, t + 0.0, self.params)
                if cl["clearance"][0] >= self.margin:
                    return step
                self.target = None  # something (a moving obstacle) is in the way
        if self.escape_steps >= self.sb.sa_budget:
            self.stats["gave_up"] = (f"SA budget ({self.sb.sa_budget} proposals) exhausted near "
                                     f"({x[0]:.2f}, {x[1]:.2f})")
            return None
        if self.T < 1e-3 * self.T0:
            self.restarts += 1
            if self.restarts > self.sb.sa_restarts:
                self.stats["gave_up"] = (f"no escape after {self.sb.sa_restarts} re-heats near "
                                         f"({x[0]:.2f}, {x[1]:.2f})")
                return None
            self.T = self.T0
        acc = self._propose(x, t, fld)
        if acc is not None:
            self.target = acc
            d = acc - x
            dist = float(np.hypot(*d))
            return d / dist * min(l_step, dist) if dist > 0 else np.zeros(2)
        return np.zeros(2)

    def _step(self, state: SimState, x: np.ndarray, l_step: float, dt: float
              ) -> np.ndarray | None:
        ev = evaluate_field(x[None], self.goal, state.field, state.t, self.params)
        ev_step = self.evade(x, ev, state.field, l_step)
        if ev_step is not None:
            self.target = None
            self._record(ev, self.T, "evade")
            return ev_step
        if self.mode == "sa":
            return self._sa_step(state, x, l_step, ev)
        step, ev = self._apf_step(x, state.t, state.field, l_step, ev)
        self._record(ev, float("nan"), "apf")
        reason = self.detect(x, state.t, state.field, l_step, ev)
        if not reason:
            return step
        xm = self._centroid(x)
        self._note_minimum(xm, reason, l_step)
        self._start_sa(xm, x, state.t, state.field)
        return self._sa_step(state, x, l_step, ev)


@dataclass(frozen=True, kw_only=True)
class SAAPF(PotentialFieldBackend, LocalPlanner):
    """Improved APF with simulated-annealing escape (paper §IV.A-B, eqs 14-16, 34-38).

    Parameters
    ----------
    k : float
        Attraction gain (eq 4).  Paper: 15.
    eta : float
        Repulsion gain of the improved potential (eq 34).  Paper: 3.7.
    rho_0 : float
        Obstacle influence distance (eq 34), map units (clearance from the robot disc).
        Paper: 20.
    n : float
        Goal-distance exponent of eq 34 (Table 1; ``n > 1`` makes the goal the global
        minimum).  Paper: 3.  ``n = 0`` gives the basic repulsion of eq 5.
    theta : float
        Cooling factor of eq 16, ``T <- theta T`` after every SA proposal.  Paper: [0.95, 0.99].
    tau_0 : float
        Initial temperature ``T_0 = tau_0 * U_att(X_lm)`` (dimensionless; k_B = 1).
    sa_step : float
        Base perturbation half-width ``s`` of eq 14 (map units); widens as ``T_0 / T``.
    sa_batch : int
        SA proposals evaluated per time step (thinking time; the robot moves at most ``l``).
    sa_budget : int
        Maximum SA proposals per escape before giving up.
    sa_restarts : int
        Re-heats (``T <- T_0``) allowed per escape when ``T < 1e-3 T_0``.
    rollout : float
        Length (map units) of the greedy roll-out in the escape test.
    evade_factor : float
        Moving-obstacle safety step when a dynamic obstacle is closer than ``evade_factor * l``
        (``0`` disables; see :meth:`~optplan.backends.apf.APFController.evade`).
    l, dt, max_steps, rho_min, sense_range, window, stall_ratio, n_probe, detect_eq38, \
patience, sense_robots
        As for :class:`~optplan.backends.apf.APF` (``patience`` is unused: SA-APF escapes).
    """

    name: ClassVar[str] = "sa-apf"
    contract_problem: ClassVar[str] = "trap-saddle"
    contract_overrides: ClassVar[dict] = {"max_steps": 600}
    n: float = 3.0
    theta: float = 0.95
    tau_0: float = 5.0
    sa_step: float = 10.0
    sa_batch: int = 8
    sa_budget: int = 4000
    sa_restarts: int = 10
    rollout: float = 60.0
    evade_factor: float = 2.0

    def __post_init__(self) -> None:
        self._check_common()
        check_range(self, "n", 0.0, 10.0)
        check_range(self, "theta", 0.0, 1.0, lo_open=True, hi_open=True)
        check_range(self, "tau_0", 0.0, lo_open=True)
        check_range(self, "sa_step", 0.0, lo_open=True)
        check_int(self, "sa_batch", 1, 1000)
        check_int(self, "sa_budget", 1, 10_000_000)
        check_int(self, "sa_restarts", 0, 10_000)
        check_range(self, "rollout", 0.0)

    def field_params(self, problem: Problem, robot: Robot) -> FieldParams:
        """The improved potential's parameters for ``robot`` (eq 34 with exponent ``n``)."""
        return FieldParams(self.k, self.eta, self.rho_0, float(self.n), self.rho_min,
                           robot.radius, self.sensing(problem, robot))

    def controller(self, problem: Problem, robot_id: str, rng: np.random.Generator
                   ) -> SAAPFController:
        """A :class:`~optplan.interfaces.LocalController` for ``robot_id``
        (:class:`~optplan.interfaces.LocalPlanner`)."""
        robot = problem.robot(robot_id)
        return SAAPFController(self, problem, robot, rng, self.field_params(problem, robot))
