r"""SA-APF: improved repulsion (eqs 34-37) + local-minimum detection (eq 38) + simulated
annealing escape (paper §IV.A-B, eqs 14-16, flow of Fig. 12).

Mathematics
-----------
Potential: :math:`U = U_{att} + \sum_i U_{rep,i}` with the improved repulsion of eq 34,

.. math:: U_{rep} = \tfrac12\eta\Big(\frac1\rho-\frac1{\rho_0}\Big)^2\rho_g^{\,n},

whose negative gradient is :math:`F_{rep1}` (eq 36, away from the obstacle) plus
:math:`F_{rep2}` (eq 37, toward the goal); both vanish at the goal for :math:`n > 1`, so the goal
is the global minimum (GNRON fixed).  The forces are in :mod:`optplan.potential.apf`.

Flow (Fig. 12): APF step (eqs 12-13) -> local-minimum test (eq 38, stall, oscillation; see
:mod:`optplan.potential.apf`) -> at the goal: done; elsewhere: simulated annealing escape
(§IV.B.3), then back to APF.

Simulated annealing escape (§IV.B.3 steps 1-4):

1. :math:`T \leftarrow T_0`, :math:`X` = the detected minimum :math:`X_{lm}`.
2. Random perturbation (eq 14): :math:`X' = X + r \odot v \cdot T_0/T`,
   :math:`r \sim U[-1,1]^2`, :math:`v = (s, s)` with :math:`s` = ``sa_step``
   :math:`\times\lambda` (perturbations widen as the system cools, as eq 14 prescribes; capped
   at the sensing range).  Candidates outside the bounds, or whose straight segment from
   :math:`X` passes within ``margin`` of a sensed obstacle, are rejected (a robot cannot
   teleport through walls).
3. Metropolis (eq 15, §IV.B.3 step 3): accept when :math:`\Delta U = U(X') - U(X) < 0`, else
   with probability :math:`\exp(-\Delta U / (k_B T))`.  **k_B = 1 (dimensionless; option
   ``k_B``).**  The paper writes :math:`k_B = 1.380649\times10^{-23}` J/K; with potentials of
   order :math:`10^3` and any sane :math:`T`, :math:`\Delta U/(k_B T) \sim 10^{26}`, so the
   acceptance probability of every uphill move is exactly 0 in floating point and SA
   degenerates into greedy descent, which cannot leave a local minimum.  ``T`` is measured in
   units of potential: :math:`T_0 = \tau_0\,U_{att}(X_{lm})` (``tau_0`` dimensionless), which
   makes the acceptance scale-free.
4. Cooling (eq 16) :math:`T \leftarrow \theta T` after every proposal.  An accepted candidate
   becomes a waypoint the robot drives to (at most :math:`l` per time step, every step checked
   against sensed obstacles).  On arrival the *escape test* runs: a greedy APF roll-out of
   ``rollout`` :math:`\times\lambda` from the new position (obstacles as sensed along it, frozen
   at the current time) must not come back within :math:`2l + r` of any detected minimum; then the
   robot has left the minimum's basin, SA stops and APF resumes.  Otherwise SA continues from
   the new position.  When :math:`T < 10^{-3} T_0` the system is re-heated (up to
   ``sa_restarts`` times); after that, or ``sa_budget`` proposals, the planner gives up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.canonical import format_point
from optplan.interfaces import LocalPlanner
from optplan.options import option
from optplan.potential.backend import PotentialFieldBackend
from optplan.potential.controller import APFController
from optplan.potential.field import FieldParams, evaluate_field
from optplan.potential.swept import free_steps
from optplan.problem import Problem, Robot
from optplan.sim import ObstacleField, SimState

__all__ = ["SAAPF", "SAAPFController", "K_B", "K_B_PAPER"]

#: Default Boltzmann constant of the Metropolis test (dimensionless; module docstring).
K_B = 1.0
#: The paper's value (J/K): makes every uphill acceptance exactly 0 (option ``k_B``).
K_B_PAPER = 1.380649e-23


class SAAPFController(APFController):
    """APF with the improved potential, eq 38 detection and the SA escape (Fig. 12)."""

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
        self.escape_steps = 0
        self.restarts = 0

    def reset(self, goal: np.ndarray) -> None:
        super().reset(goal)
        self._sa_reset()

    # -- SA pieces ------------------------------------------------------------------------
    def _start_sa(self, x: np.ndarray) -> None:
        """Step 1: enter SA at a detected minimum (robot at ``x``), ``T = T_0``."""
        self.mode = "sa"
        g = (x - self.goal) / self.params.unit  # U_att in length units, as in the field
        u_att = 0.5 * self.params.k * float(np.sum(g * g))
        self.T0 = self.sb.tau_0 * max(u_att, 1e-12)
        self.T = self.T0
        self.target = None
        self.escape_steps = 0
        self.restarts = 0

    def _segments_clear(self, x: np.ndarray, cands: np.ndarray, t: float,
                        fld: ObstacleField) -> np.ndarray:
        """Straight segments ``x -> cand`` keep ``margin`` clearance from sensed obstacles."""
        # the exact test decides the static obstacles: a segment crossing a corner between two
        # samples, or a point robot inside an obstacle (distance 0 >= margin 0), is not clear
        ok = free_steps(self.problem, self.robot, x, cands)
        if self.robot.radius + self.margin <= 0.0 or not ok.any():
            return ok  # a distance is never negative: for a point robot the samples all pass
        d = cands - x
        L = np.hypot(d[:, 0], d[:, 1])
        h = max(0.5 * self.robot.radius, 1e-3 * self.params.unit)
        S = int(min(max(np.ceil(L.max() / h), 1), 400))  # from every candidate, as always
        s = np.linspace(0.0, 1.0, S + 1)[1:]
        pts = (x + s[None, :, None] * d[ok][:, None, :]).reshape(-1, 2)  # the free ones' samples
        _, dist = fld.nearest(pts, t, max_range=self.params.sense_range)
        cl = dist.min(axis=1) if dist.shape[1] else np.full(len(pts), np.inf)
        # the samples keep the margin from sensed (also moving) obstacles
        ok[ok] = (cl.reshape(-1, S) - self.robot.radius).min(axis=1) >= self.margin
        return ok

    def escaped(self, x: np.ndarray, t: float, fld: ObstacleField, l_step: float) -> bool:
        """Escape test: a greedy APF roll-out from ``x`` stays away from every known minimum."""
        r_same = 2 * l_step + self.robot.radius
        M = max(1, int(math.ceil(self.sb.rollout * self.params.unit / l_step)))
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
        scale = np.minimum(sb.sa_step * self.params.unit * self.T0 / Ts,
                           self.params.sense_range)
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
            if dU[j] < 0 or u_rand[j] < _boltzmann(dU[j], sb.k_B * T):  # eq 15 / step 3
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
            if dist <= 1e-9 * self.params.unit:
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
                cl = evaluate_field((x + step)[None], self.goal, fld, t, self.params)
                if (cl["clearance"][0] >= self.margin
                        and free_steps(self.problem, self.robot, x, (x + step)[None])[0]):
                    return step
                self.target = None  # something (a moving obstacle) is in the way
        if self.escape_steps >= self.sb.sa_budget:
            self.stats["gave_up"] = (f"SA budget ({self.sb.sa_budget} proposals) exhausted near "
                                     f"{format_point(self.problem, x)}")
            return None
        if self.T < 1e-3 * self.T0:
            self.restarts += 1
            if self.restarts > self.sb.sa_restarts:
                self.stats["gave_up"] = (f"no escape after {self.sb.sa_restarts} re-heats near "
                                         f"{format_point(self.problem, x)}")
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
        self._start_sa(x)
        self.trace.drop_last()  # this step is an SA step: _sa_step records it (one row a step)
        return self._sa_step(state, x, l_step, ev)


def _boltzmann(dU: float, kT: float) -> float:
    """Metropolis acceptance ``exp(-dU / kT)`` of an uphill move (0 when it underflows)."""
    z = dU / kT
    return 0.0 if z > 745.0 else math.exp(-z)


@dataclass(frozen=True, kw_only=True)
class SAAPF(PotentialFieldBackend, LocalPlanner):
    """Improved APF with simulated-annealing escape (paper §IV.A-B, eqs 14-16, 34-38).

    Parameters
    ----------
    n : float
        Goal-distance exponent of eq 34 (Table 1; ``n > 1`` makes the goal the global
        minimum).  Paper: 3.  ``n = 0`` gives the basic repulsion of eq 5.
    theta : float
        Cooling factor of eq 16, ``T <- theta T`` after every SA proposal.  Paper: [0.95, 0.99].
    tau_0 : float
        Initial temperature ``T_0 = tau_0 * U_att(X_lm)`` (dimensionless, potential measured
        in length units).
    k_B : float
        Boltzmann constant of the Metropolis test (eq 15), in units of potential per unit of
        ``T``.  Default 1 (dimensionless); the paper's 1.380649e-23 J/K makes every uphill
        acceptance exactly 0, so SA becomes greedy descent (docs/solvers/apf.md).
    sa_step : float
        Base perturbation half-width ``s`` of eq 14 (x length_scale); widens as ``T_0 / T``.
    sa_batch : int
        SA proposals evaluated per time step (thinking time; the robot moves at most ``l``).
    sa_budget : int
        Maximum SA proposals per escape before giving up.
    sa_restarts : int
        Re-heats (``T <- T_0``) allowed per escape when ``T < 1e-3 T_0``.
    rollout : float
        Length of the greedy roll-out in the escape test (x length_scale), at most 1e4
        (about 14 diagonals of a map at its default ``length_scale``; each escape test takes
        up to ``rollout / l`` field evaluations, so a longer one only costs time).
    evade_factor : float
        Moving-obstacle safety step when a dynamic obstacle is closer than ``evade_factor * l``
        (``0`` disables; see :meth:`~optplan.potential.controller.APFController.evade`).  Default 2.
    k, eta, rho_0, l, dt, max_steps, rho_min, sense_range, window, stall_ratio, n_probe, \
detect_eq38, sense_robots
        Shared options, see :class:`~optplan.potential.backend.PotentialFieldBackend`.
    """

    name: ClassVar[str] = "sa-apf"
    n: float = option(3.0, lo=0.0, hi=10.0)
    theta: float = option(0.95, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    tau_0: float = option(5.0, lo=0.0, lo_open=True)
    k_B: float = option(K_B, lo=0.0, lo_open=True)
    sa_step: float = option(10.0, lo=0.0, lo_open=True, scale=True)
    sa_batch: int = option(8, lo=1, hi=1000)
    sa_budget: int = option(4000, lo=1, hi=10_000_000)
    sa_restarts: int = option(10, lo=0, hi=10_000)
    rollout: float = option(60.0, lo=0.0, hi=1e4, scale=True)
    evade_factor: float = option(2.0, lo=0.0, hi=100.0)

    def field_params(self, problem: Problem, robot: Robot) -> FieldParams:
        """The improved potential's parameters for ``robot`` (eq 34 with exponent ``n``)."""
        return self._params(problem, robot, self.eta, float(self.n))

    def controller(self, problem: Problem, robot_id: str, rng: np.random.Generator
                   ) -> SAAPFController:
        """A :class:`~optplan.interfaces.LocalController` for ``robot_id``
        (:class:`~optplan.interfaces.LocalPlanner`)."""
        robot = problem.robot(robot_id)
        return SAAPFController(self, problem, robot, rng, self.field_params(problem, robot))
