r"""Leader-follower formation control with the paper's L-phi potentials (paper §II.G, §IV.C).

The formation frame (slots, polar coordinates) is :mod:`optplan.formation.slots`; the pilot, the
reference and the simulation loop shared with the formation QP are
:mod:`optplan.formation.pilot`; the safety layer is :mod:`optplan.formation.safety`.

Followers, eqs 46-52
--------------------
Each follower descends the total L-phi potential (eq 50)

.. math:: U = A\Big(\frac{L_d^2}{r^2} + \ln r^2\Big) + B\Big(\frac{\varphi_d^2}{\varphi^2}
          + \ln\varphi^2\Big),

whose minimum is at :math:`r = L_d`, :math:`|\varphi| = |\varphi_d|`.  The radial and angular
derivatives are :math:`\partial U/\partial r = A(-2L_d^2/r^3 + 2/r)` (eq 47; the paper prints
:math:`L_d` instead of :math:`L_d^2`, a typo: only :math:`L_d^2` makes :math:`r = L_d` the
stationary point) and :math:`\partial U/\partial\varphi = B(-2\varphi_d^2/\varphi^3 + 2/\varphi)`
(eq 49, same typo).  The angular term is a barrier at :math:`\varphi = 0`: a follower never
crosses the line directly behind the leader, so the two sides of the formation stay apart.

The paper gives forces but no motion law; optplan's choice (documented, measured in the docs):
the follower's velocity is the leader's velocity (feed-forward, "the follower robot will follow
the path of the pilot robot") plus a gradient step on :math:`U` in Cartesian coordinates,

.. math:: u_F = v_L - \kappa\,\Big(\frac{\partial U}{\partial r}\hat e_r
          + \frac1r\frac{\partial U}{\partial\varphi}\hat e_\varphi\Big),
          \qquad \kappa = k_f\,\frac{L_d^2}{4\max(A,\ B/\Phi_d^2)},

where :math:`\hat e_\varphi` is the direction of increasing :math:`\varphi` and ``k_f`` (1/s) is
the faster of the two linearised convergence rates (:math:`\partial^2U/\partial r^2 = 4A/L_d^2`
radially and :math:`4B/(\Phi_d^2L_d^2)` tangentially at the slot), so ``k_f * dt <= 1`` keeps
the discrete step stable for any :math:`\Phi_d`.  Near obstacles the desired angle shrinks by eq 52,

.. math:: \varphi_d = \Phi_d\,\frac{\ln(c\rho)}{\ln(c\rho_0)}\ (\rho < \rho_0),
          \quad \rho \ge 1/c,\ c = 20,

(clamped so the log never flips the formation side).  The paper says the
followers also avoid each other and obstacles (§IV.C.3) without giving the law; optplan adds an
APF repulsion of the eq 6 form between robots (``eta_r``, influence ``d_0``) and from obstacles
(``eta_f``, influence ``rho_f``).  The simulator clamps every speed to ``max_speed``.

Safety layer (options ``safety`` and ``recovery``; beyond the paper's equations, on in the
``leader-follower-paper`` preset): the barrier filter and its guarantee are documented in
:mod:`optplan.formation.safety`.

The recovery of a *lost* follower (option ``recovery``) is described in
:mod:`optplan.formation.safety`.

Units
-----
Every distance-like option is a multiple of the scene's
:attr:`~optplan.problem.Problem.length_scale` (1 on the paper's scenes): the pilot's force is
computed in units of it, eq 52 uses ``rho_0_f * length_scale`` and ``c_phi / length_scale``, the
followers' repulsions act on clearances in units of it and add velocities times it, and the
safety filter's margins and the recovery's visibility tests are multiples of it.  The L-phi law
itself is scale-free (``kappa`` grows with :math:`L^2`, the gradient falls with :math:`1/L`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.formation.pilot import (
    PilotedFormation,
    run_formation,
)
from optplan.formation.safety import FollowerStates, LeaderFrame, SafetyLayer
from optplan.formation.slots import relative_polar
from optplan.interfaces import FormationBackend
from optplan.problem import Problem
from optplan.sim import SimState
from optplan.solver import make_rng, option
from optplan.units import Record, Unit

__all__ = [
    "STATS_UNITS",
    "LeaderFollower",
    "LPhiFollowers",
    "lphi_potential",
    "lphi_gradient",
    "adapted_angle",
]

#: robot clearance floor used in 1/rho terms (map units)
RHO_MIN = 1e-3

#: The units of :attr:`LPhiFollowers.stats`: the smallest angle ratio of eq 52 and counters.
STATS_UNITS = Record({
    "min_phi_ratio": Unit.DIMENSIONLESS, "steps": Unit.DIMENSIONLESS,
    "filtered": Unit.DIMENSIONLESS, "infeasible": Unit.DIMENSIONLESS,
    "lost": Unit.DIMENSIONLESS, "recovery_steps": Unit.DIMENSIONLESS})


# --------------------------------------------------------------------------------------
# the L-phi potentials, eqs 46-52
# --------------------------------------------------------------------------------------


def lphi_potential(r, phi, L, Phi, A: float = 0.5, B: float = 0.5):
    """Total L-phi potential, eq 50 (eqs 46 + 48)."""
    r, phi = np.asarray(r, float), np.asarray(phi, float)
    return A * (L**2 / r**2 + np.log(r**2)) + B * (np.asarray(Phi) ** 2 / phi**2
                                                    + np.log(phi**2))


def lphi_gradient(r, phi, L, Phi, A: float = 0.5, B: float = 0.5):
    """``(dU/dr, dU/dphi)``: eqs 47 and 49 with the squared desired values (see module doc)."""
    r, phi = np.asarray(r, float), np.asarray(phi, float)
    dr = A * (-2 * np.asarray(L) ** 2 / r**3 + 2 / r)
    dphi = B * (-2 * np.asarray(Phi) ** 2 / phi**3 + 2 / phi)
    return dr, dphi


def adapted_angle(Phi, rho, rho_0: float, c: float = 20.0):
    """Desired angle near obstacles, eq 52, with ``rho`` clamped at ``1/c``."""
    rho = np.minimum(np.maximum(np.asarray(rho, float), 1.0 / c), rho_0)
    ratio = np.log(c * rho) / math.log(c * rho_0)
    return np.asarray(Phi) * ratio


# --------------------------------------------------------------------------------------
# the follower law
# --------------------------------------------------------------------------------------


class LPhiFollowers(SafetyLayer):
    """The paper's follower law (eqs 46-52) for a set of followers
    (a :class:`~optplan.interfaces.FollowerController`)."""

    def __init__(self, problem: Problem, opts: LeaderFollower):
        if problem.formation is None:
            raise ValueError(f"problem {problem.name!r} has no [formation]")
        self.problem = problem
        self.form = problem.formation
        self.spec = {f.id: f for f in self.form.followers}
        self.o = opts
        #: the problem's length unit: the distance-like options are multiples of it
        self.ell = float(problem.length_scale)
        self.stats: dict[str, Any] = {"min_phi_ratio": 1.0, "steps": 0, "filtered": 0,
                                      "infeasible": 0, "lost": 0,
                                      "recovery_steps": 0}  # units: STATS_UNITS
        self._trail = np.zeros((0, 2))  # the pilot's path so far (option trail)
        self._lost = np.zeros(len(self.form.followers), bool)
        m = max(int(opts.speed_sides), 3)
        ang = 2 * np.pi * np.arange(m) / m
        # inscribed speed polygon: -[cos, sin] . u >= -vmax cos(pi/m)
        self._speed_rows = -np.stack([np.cos(ang), np.sin(ang)], 1)
        self._speed_rhs = math.cos(math.pi / m)

    def velocities(self, state: SimState, leader_index: int, follower_indices: list[int],
                   leader_heading: float) -> np.ndarray:
        o = self.o
        P = state.positions
        xl = P[leader_index]
        dt = float(state.dt)
        ids = [state.ids[i] for i in follower_indices]
        L = np.array([self.spec[i].L for i in ids])
        Phi = np.array([self.spec[i].phi for i in ids])
        radii = np.array([self.problem.robot(i).radius for i in ids])
        xf = P[follower_indices]
        vl = state.leader_command(leader_index)
        ell = self.ell
        rho_min = RHO_MIN * ell
        # obstacle sensing for every follower at once
        rng_s = max(o.rho_0_f, o.rho_f) * ell
        near, dist = state.field.nearest(xf, state.t, max_range=rng_s + radii.max())
        clear = dist - radii[:, None]
        rho = np.min(clear, axis=1) if clear.shape[1] else np.full(len(ids), np.inf)
        phi_d = (adapted_angle(Phi, rho / ell, o.rho_0_f, o.c_phi) if o.adapt_phi else Phi)
        self.stats["min_phi_ratio"] = float(min(self.stats["min_phi_ratio"],
                                                np.min(np.abs(phi_d / Phi))))
        r, phi = relative_polar(xl, leader_heading, xf)
        r = np.maximum(r, rho_min)
        phi = np.where(np.abs(phi) < 1e-6, np.copysign(1e-6, Phi), phi)
        dUr, dUphi = lphi_gradient(r, phi, L, phi_d, o.A, o.B)
        rel = xf - xl[None, :]
        e_r = rel / r[:, None]
        # phi grows clockwise (toward the leader's left from behind): e_phi = -perp(e_r)
        e_phi = np.stack([e_r[:, 1], -e_r[:, 0]], axis=1)
        kappa = o.k_f * L**2 / (4 * np.maximum(o.A, o.B / Phi**2))
        grad = dUr[:, None] * e_r + (dUphi / r)[:, None] * e_phi
        u = (vl[None, :] if o.feedforward else 0.0) - kappa[:, None] * grad
        # inter-robot repulsion (every robot in the simulation, eq 6 form), on clearances in
        # units of length_scale and returned as a velocity in map units (x length_scale)
        tiny = 1e-9 * ell
        if o.eta_r > 0 and len(P) > 1:
            allr = np.array([self.problem.robot(i).radius for i in state.ids])
            diff = xf[:, None, :] - P[None, :, :]
            dd = np.hypot(diff[..., 0], diff[..., 1])
            gap = np.maximum(dd - radii[:, None] - allr[None, :], rho_min) / ell
            act = (gap < o.d_0) & (dd > tiny)
            mag = np.where(act, ell * o.eta_r * (1 / gap - 1 / o.d_0) / gap**2, 0.0)
            u = u + np.sum(mag[..., None] * diff / np.where(dd > tiny, dd, 1)[..., None], 1)
        if o.eta_f > 0 and clear.shape[1]:
            g = np.maximum(clear, rho_min) / ell
            act = np.isfinite(g) & (g < o.rho_f)
            v = xf[:, None, :] - near
            nv = np.hypot(v[..., 0], v[..., 1])
            nrm = np.where(act[..., None], v / np.where(nv > tiny, nv, 1)[..., None], 0.0)
            mag = np.where(act, ell * o.eta_f * (1 / g - 1 / o.rho_f) / g**2, 0.0)
            u = u + np.sum(mag[..., None] * np.nan_to_num(nrm), axis=1)
        if o.recovery:
            u = self.recovery(state, u, LeaderFrame(xl, leader_heading, vl),
                              FollowerStates(ids, xf, radii, L, Phi, phi_d, phi))
        if o.safety:
            u = self.safety_filter(state, leader_index, follower_indices, u, vl, near, dist,
                                   radii, dt)
        self.stats["steps"] += 1
        return u


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class LeaderFollower(PilotedFormation, FormationBackend):
    """Paper leader-follower formation: pilot APF (eqs 39-45) + L-phi followers (eqs 46-52).

    Parameters
    ----------
    A, B : float
        Gains of the distance and angle potentials (eqs 46, 48); paper 0.5 each.
    k_f : float
        Follower convergence rate (1/s): scale of the gradient step, see module doc;
        ``k_f * dt <= 1``.
    feedforward : bool
        Add the leader's velocity to every follower command.
    eta_r : float
        Inter-robot repulsion gain, eq 6 form on the clearance in units of ``length_scale``
        (paper §IV.C.3 asks for inter-robot avoidance without giving a law; 0 disables it).
    d_0 : float
        Influence clearance of the inter-robot repulsion (x length_scale).
    eta_f : float
        Follower obstacle repulsion gain, eq 6 form as ``eta_r`` (0 disables it).
    rho_f : float
        Influence clearance of the follower obstacle repulsion (x length_scale).
    safety : bool
        Beyond the paper (its §IV.C.3 asks for inter-robot avoidance without a law): pass every
        follower command through a discrete-time barrier filter, the closest velocity (exact
        2-D projection) meeting one half-plane per neighbour robot, sensed obstacle and arena
        wall plus the speed limit, so that no gap can shrink below ``D_s + sep_margin``
        (robots) or ``clear_margin`` (obstacles) in one step.  Safety takes priority over
        formation keeping; with no common point the least-violating command is used (counted
        in ``stats["infeasible"]``).
    gamma_s : float
        Barrier rate in ``(0, 1]``: a row lets a gap close by at most ``gamma_s`` times its
        excess per step.
    sep_margin : float
        Extra separation above the formation's ``safety_distance`` kept by the filter
        (x length_scale).
    clear_margin : float
        Clearance from obstacles kept by the filter and by the recovery's visibility tests
        (x length_scale).
    max_rows : int
        Most critical filter rows kept per follower (besides the speed polygon).
    speed_sides : int
        Sides of the polygon inscribed in the speed disc used by the filter.
    recovery : bool
        Beyond the paper's equations: a follower on the wrong side of the leader's wake, with
        its slot hidden behind a static obstacle, or far away pursues its slot directly or,
        hidden, follows the pilot's recorded path ("the follower robot will follow the path
        of the pilot robot") until it is back near its slot (see
        :meth:`LPhiFollowers.recovery`).
    trail_far : float
        Slot distance (x L) beyond which a follower counts as lost even with its slot in
        sight.
    trail_reach : float
        How far (x L) a lost follower looks along the pilot's path for a visible target.
    k, eta, rho_0, n, adapt_phi, rho_0_f, c_phi, pilot, path_solver, v_factor, ref_spacing,
    lookahead, tau_h, dt, max_steps, settle_tol
        See :class:`PilotedFormation` (the leader's pilot and run settings).
    """

    name: ClassVar[str] = "leader-follower"
    stats_units: ClassVar[Record] = STATS_UNITS
    A: float = option(0.5, lo=0.0, lo_open=True)
    B: float = option(0.5, lo=0.0, lo_open=True)
    k_f: float = option(1.0, lo=0.0, lo_open=True)
    feedforward: bool = option(True)
    eta_r: float = option(200.0, lo=0.0)
    d_0: float = option(10.0, lo=0.0, lo_open=True, scale=True)
    eta_f: float = option(200.0, lo=0.0)
    rho_f: float = option(10.0, lo=0.0, lo_open=True, scale=True)
    safety: bool = option(False)
    gamma_s: float = option(0.5, lo=0.0, hi=1.0, lo_open=True)
    sep_margin: float = option(0.5, lo=0.0, scale=True)
    clear_margin: float = option(0.5, lo=0.0, scale=True)
    max_rows: int = option(12, lo=1, hi=1000)
    speed_sides: int = option(16, lo=6, hi=256)
    recovery: bool = option(False)
    trail_far: float = option(2.0, lo=0.5)
    trail_reach: float = option(3.0, lo=0.0, lo_open=True)

    def check(self) -> None:
        """``k_f * dt <= 1`` (stable follower step), then the shared stage resolution."""
        if self.k_f * self.dt > 1 + 1e-12:
            raise ValueError(f"options 'k_f' * 'dt' of backend {self.name!r} must be <= 1 "
                             f"(stable follower step), got {self.k_f} * {self.dt}")
        super().check()

    def followers_controller(self, problem: Problem, rng: np.random.Generator) -> LPhiFollowers:
        """The L-phi follower law as a :class:`~optplan.interfaces.FollowerController`
        (:class:`~optplan.interfaces.FormationBackend`)."""
        return LPhiFollowers(problem, self)

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        rng = make_rng(rng)[0]
        return run_formation(self, problem, self.followers_controller(problem, rng), rng=rng,
                             init=init, callback=callback)
