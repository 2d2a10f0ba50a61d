r"""Leader-follower formation control with the paper's L-phi potentials (paper §II.G, §IV.C).

Geometry (the L-phi convention, fixed in :class:`optplan.problem.Follower`)
--------------------------------------------------------------------------
The leader is at :math:`p_L` with heading :math:`\theta_L`.  A follower's slot is

.. math::  s = p_L + L\,R(\theta_L)\,[-\cos\varphi,\ \sin\varphi]^T,

i.e. :math:`\varphi` is measured from the leader's *backward* heading, positive to the leader's
left; :math:`\varphi = 0` is directly behind.  The actual polar coordinates of a follower at
:math:`p_F` are :math:`r = \|p_F - p_L\|` and
:math:`\varphi = \mathrm{wrap}(\theta_L + \pi - \operatorname{atan2}(p_F - p_L))`.
With the paper-formation start (leader (60, 60) heading :math:`\pi/4`, :math:`L = 60`),
:math:`\varphi = +\pi/4` puts f1 at (0, 60) and :math:`\varphi = -\pi/4` puts f2 at (60, 0),
as in the paper's Figs. 13 and 31.

Pilot (leader), eqs 39-45
-------------------------
Attraction :math:`F_{att} = k\,(X_g - X)` (eq 40, :math:`k = 15`) toward the current reference
point :math:`X_g`; for every sensed obstacle within :math:`\rho_0` the improved repulsion
:math:`F_{rep1} = \eta(1/\rho - 1/\rho_0)\,\rho_g^n/\rho^2` away from the obstacle (eq 44) and
:math:`F_{rep2} = \tfrac n2\eta(1/\rho - 1/\rho_0)^2\rho_g^{n-1}` toward the reference point
(eq 45); :math:`\rho` is the clearance (distance to the obstacle minus the robot radius, clamped at
``rho_min``), :math:`\rho_g = \|X - X_g\|`.  The pilot moves along :math:`F/\|F\|` at its cruise
speed (``pilot = "builtin"``, the default).  ``pilot`` may instead name any
:class:`~optplan.interfaces.LocalPlanner` (e.g. ``"sa-apf"``, paper §IV.B): its controller then
drives the leader toward the same reference points.

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
``leader-follower-paper`` preset)
-----------------------------------------------------------------------------------------
The eq 6-style repulsions act only within a few units, less than one control step of motion,
so they cannot stop two followers that the rotating formation frame drives together (on
``paper-warehouse``, L = 21, f1 and f2 touch at t = 28.5 s).  With ``safety`` every follower
command is replaced by the closest velocity (exact 2-D projection,
:func:`project_halfplanes`) meeting discrete-time barrier half-planes: for a neighbour robot at
centre distance :math:`d` along unit vector :math:`n` (from it to the follower)
:math:`n^T(u_i - u_j) \ge -\gamma_s(d - D)/\tau` with :math:`D = D_s +` ``sep_margin`` (split
half and half between two followers; the leader's command is known), for every sensed obstacle
:math:`n^T u_i \ge n^T v_o - \gamma_s(\rho - m)/\tau` from its nearest boundary point, the
arena walls, and an inscribed polygon of the speed disc.  Because
:math:`\|x + \tau w\| \ge n^T(x + \tau w)`, a met row keeps the gap :math:`\ge D` (clearance
:math:`\ge m` for a convex obstacle) after the step, whatever the step length, for
:math:`\gamma_s \le 1`.  Safety has priority over formation keeping.

The potential is even in :math:`\varphi`, its barrier keeps a follower on the side of the
leader's wake it is on, and its pull decays like :math:`1/r` far out, so a follower swept to
the wrong side or left behind an obstacle settles in the mirrored slot or jams.  With
``recovery`` such a *lost* follower pursues its slot directly when it can see it, else follows
the pilot's recorded path (the paper: "the follower robot will follow the path of the pilot
robot") until it is back within ``L / 2`` of its slot on its own side
(:meth:`LPhiFollowers.recovery`).

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
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.interfaces import (
    LOCAL_PLANNER,
    PATH_SOLVER,
    FormationBackend,
    LocalController,
    resolve_stage,
)
from optplan.potential.apf import attractive_force, repulsive_force
from optplan.problem import Problem
from optplan.result import History, Progress, Result, Status
from optplan.sim import ObstacleField, SimState, simulate
from optplan.solver import Backend, get_solver, make_rng, option

__all__ = [
    "PilotedFormation",
    "LeaderFollower",
    "LPhiFollowers",
    "PilotAPF",
    "ReferenceTracker",
    "lphi_potential",
    "lphi_gradient",
    "adapted_angle",
    "relative_polar",
    "slot_positions",
    "pilot_force",
    "run_formation",
]

#: robot clearance floor used in 1/rho terms (map units)
RHO_MIN = 1e-3


# --------------------------------------------------------------------------------------
# pure maths
# --------------------------------------------------------------------------------------


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles to ``[-pi, pi)``."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def relative_polar(p_lead: np.ndarray, theta: float, p_f: np.ndarray) -> tuple[np.ndarray,
                                                                               np.ndarray]:
    """Actual ``(r, phi)`` of followers ``p_f`` (``(F, 2)``) in the L-phi convention."""
    rel = np.atleast_2d(p_f) - np.asarray(p_lead)[None, :]
    r = np.hypot(rel[:, 0], rel[:, 1])
    phi = wrap(theta + np.pi - np.arctan2(rel[:, 1], rel[:, 0]))
    return r, np.asarray(phi)


def slot_positions(p_lead: np.ndarray, theta: float, L: np.ndarray,
                   phi: np.ndarray) -> np.ndarray:
    """Slots ``p_L + L R(theta) [-cos phi, sin phi]``, shape ``(F, 2)``."""
    ang = theta + np.pi - np.asarray(phi, dtype=float)
    L = np.asarray(L, dtype=float)
    return np.asarray(p_lead)[None, :] + np.stack([L * np.cos(ang), L * np.sin(ang)], axis=-1)


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


def pilot_force(x: np.ndarray, goal: np.ndarray, near: np.ndarray, clear: np.ndarray,
                k: float, eta: float, rho_0: float, n: float) -> np.ndarray:
    """Total pilot force, eqs 40 + 44 + 45, summed over obstacles.

    The same improved field as SA-APF (eqs 34-37, :mod:`optplan.potential.apf`) with the
    pilot's gains.

    Parameters
    ----------
    x, goal : (2,)
    near : (m, 2)
        Nearest obstacle points.
    clear : (m,)
        Clearances ``rho`` (clamped by the caller); obstacles with ``rho > rho_0`` are ignored.
    """
    F = attractive_force(x, goal, k)
    if len(clear):
        F = F + np.sum(repulsive_force(x[None, :], near, clear, goal, eta, rho_0, n), axis=0)
    return F


def project_halfplanes(u0: np.ndarray, A: np.ndarray, b: np.ndarray,
                       hard: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""Exact 2-D projection :math:`\arg\min_u \|u-u_0\|^2` s.t. :math:`A_k u \ge b_k`, batched.

    In the plane the minimiser of a distance over a polygon is ``u0`` itself, its projection
    on one constraint line, or the intersection of two constraint lines; every candidate is
    enumerated (vectorised) and the closest feasible one kept.  If the rows have no common
    point, the candidate (among those meeting the ``hard`` rows, e.g. the speed polygon, and
    ``u = 0``) with the smallest worst violation of the other rows is returned and flagged.

    Parameters
    ----------
    u0 : (F, 2)
        Nominal velocities.
    A : (F, K, 2)
        Row normals (unit length; an all-zero row with ``b = -inf`` is inactive padding).
    b : (F, K)
        Right-hand sides.
    hard : (K,) bool, optional
        Rows never traded off in the infeasible case (default: none).

    Returns
    -------
    u : (F, 2)
        Projected velocities.
    infeasible : (F,) bool
        True where the rows had no common point (best compromise returned).
    """
    u0 = np.asarray(u0, float)
    F, K = b.shape
    hard = np.zeros(K, bool) if hard is None else np.asarray(hard, bool)
    an2 = np.sum(A * A, axis=-1)  # (F, K)
    live = an2 > 1e-18
    # candidates: u0, line projections, pairwise line intersections, the origin
    viol0 = b - np.einsum("fkd,fd->fk", A, u0)
    proj = u0[:, None, :] + np.where(live, viol0 / np.where(live, an2, 1.0), 0.0)[..., None] * A
    i, j = np.triu_indices(K, 1)
    a1, a2 = A[:, i], A[:, j]  # (F, P, 2)
    det = a1[..., 0] * a2[..., 1] - a1[..., 1] * a2[..., 0]
    ok = np.abs(det) > 1e-12
    sd = np.where(ok, det, 1.0)
    b1, b2 = b[:, i], b[:, j]
    b1 = np.where(np.isfinite(b1), b1, 0.0)
    b2 = np.where(np.isfinite(b2), b2, 0.0)
    x = (b1 * a2[..., 1] - b2 * a1[..., 1]) / sd
    y = (a1[..., 0] * b2 - a2[..., 0] * b1) / sd
    inter = np.stack([x, y], -1)
    inter = np.where(ok[..., None], inter, u0[:, None, :])
    cand = np.concatenate([u0[:, None, :], proj, inter, np.zeros((F, 1, 2))], axis=1)
    slack = np.einsum("fkd,fcd->fck", A, cand) - b[:, None, :]  # (F, C, K), >= 0 feasible
    scale = 1e-9 * (1.0 + np.max(np.abs(np.where(np.isfinite(b), b, 0.0)), axis=1))
    worst = np.max(-slack, axis=2)  # worst violation per candidate
    dist = np.sum((cand - u0[:, None, :]) ** 2, axis=2)
    feas = worst <= scale[:, None]
    infeasible = ~feas.any(axis=1)
    score = np.where(feas, dist, np.inf)
    if infeasible.any():
        hard_ok = np.all(slack[..., hard] >= -scale[:, None, None], axis=2) if hard.any() \
            else np.ones(feas.shape, bool)
        soft = np.max(np.where(hard[None, None, :], -np.inf, -slack), axis=2)
        alt = np.where(hard_ok, soft + 1e-9 * dist, np.inf)
        score = np.where(infeasible[:, None], alt, score)
    best = np.argmin(score, axis=1)
    return cand[np.arange(F), best], infeasible


# --------------------------------------------------------------------------------------
# controllers
# --------------------------------------------------------------------------------------


class PilotAPF:
    """The pilot's improved APF (eqs 39-45) as a :class:`~optplan.interfaces.LocalController`.

    Moves along ``F / |F|`` at ``speed``; never overshoots the goal.  The force is computed
    in units of ``scale`` (the problem's :attr:`~optplan.problem.Problem.length_scale`):
    positions and clearances are divided by it, ``rho_0`` and ``rho_min`` are multiples of it,
    so the direction of motion does not depend on the unit the scene is drawn in.
    """

    def __init__(self, problem: Problem, robot_id: str, *, k: float, eta: float, rho_0: float,
                 n: float, speed: float, rho_min: float = 0.5, scale: float = 1.0):
        self.robot = problem.robot(robot_id)
        self.k, self.eta, self.rho_0, self.n = k, eta, rho_0, n
        self.speed, self.rho_min, self.scale = speed, rho_min, float(scale)
        self.goal = np.array(self.robot.goal if self.robot.goal is not None
                             else self.robot.start, float)
        self.stats: dict[str, Any] = {"steps": 0}

    def reset(self, goal: np.ndarray) -> None:
        self.goal = np.asarray(goal, float).copy()

    def velocity(self, state: SimState, index: int) -> np.ndarray | None:
        x = state.positions[index]
        s = self.scale
        near, dist = state.field.nearest(x, state.t,
                                         max_range=self.rho_0 * s + self.robot.radius)
        clear = np.maximum((dist[0] - self.robot.radius) / s, self.rho_min)
        clear = np.where(np.isfinite(dist[0]), clear, np.inf)
        F = pilot_force(x / s, self.goal / s, near[0] / s, clear, self.k, self.eta, self.rho_0,
                        self.n)
        nf = float(np.hypot(*F))
        self.stats["steps"] += 1
        if nf < 1e-12:
            return np.zeros(2)
        dt = float(state.dt)
        dist_g = float(np.hypot(*(self.goal - x)))
        return F / nf * min(self.speed, dist_g / dt)


class ReferenceTracker:
    """Drives the leader along a reference polyline with a
    :class:`~optplan.interfaces.LocalController`.

    The reference is resampled every ``spacing``; the current target is the first sample more
    than ``lookahead`` ahead of the leader's progress index (monotone).  The controller is
    ``reset`` only when the target changes.  Reference points closer than ``clearance`` to a
    sensed obstacle (one the global planner did not know) are skipped.  At the last point the
    speed is capped so the leader stops on the goal.
    """

    def __init__(self, ref: np.ndarray, controller: Any, *, spacing: float, lookahead: float,
                 speed: float, goal_tol: float, clearance: float = 0.0):
        ref = np.asarray(ref, float)
        seg = np.hypot(*np.diff(ref, axis=0).T) if len(ref) > 1 else np.zeros(0)
        s = np.r_[0.0, np.cumsum(seg)]
        # at most 100,000 samples: a tiny spacing cannot exhaust memory
        n = max(2, min(100_000, int(math.ceil(s[-1] / spacing)) + 1)) if s[-1] > 0 else 1
        ss = np.linspace(0, s[-1], n)
        self.points = np.stack([np.interp(ss, s, ref[:, 0]), np.interp(ss, s, ref[:, 1])], 1)
        self.goal = ref[-1].copy()
        self.ctrl, self.lookahead, self.speed, self.goal_tol = controller, lookahead, speed, \
            goal_tol
        self.clearance = clearance
        self.idx = -1
        self.progress = 0
        self.gave_up = 0

    def velocity(self, state: SimState, index: int) -> np.ndarray:
        x = state.positions[index]
        dt = float(state.dt)
        dgoal = float(np.hypot(*(self.goal - x)))
        if dgoal <= 0.5 * self.goal_tol:
            return np.zeros(2)
        # progress: nearest sample within a window ahead
        win = self.points[self.progress: self.progress + 20]
        j = int(np.argmin(np.hypot(*(win - x).T)))
        self.progress += j
        d = np.hypot(*(self.points[self.progress:] - x).T)
        far = np.nonzero(d > self.lookahead)[0]
        tgt = self.progress + int(far[0]) if len(far) else len(self.points) - 1
        # skip reference points blocked by sensed (temporary / moving) obstacles
        if tgt < len(self.points) - 1 and self.clearance > 0:
            cand = self.points[tgt: tgt + 60]
            _, dist = state.field.nearest(cand, state.t, max_range=self.clearance)
            free = np.nonzero(np.min(dist, axis=1, initial=np.inf) >= self.clearance)[0]
            if len(free):
                tgt += int(free[0])
        if tgt != self.idx:
            self.idx = tgt
            self.ctrl.reset(self.points[tgt])
        u = self.ctrl.velocity(state, index)
        if u is None:
            self.gave_up += 1
            u = np.zeros(2)
        u = np.asarray(u, float)
        sp = float(np.hypot(*u))
        cap = self.speed if self.idx < len(self.points) - 1 else min(self.speed, dgoal / dt)
        if sp > cap:
            u = u * (cap / sp)
        return u


class LPhiFollowers:
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
                                      "infeasible": 0, "lost": 0, "recovery_steps": 0}
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
            u = self.recovery(state, ids, xl, xf, u, vl, L, Phi, phi, radii, leader_heading,
                              phi_d)
        if o.safety:
            u = self.safety_filter(state, leader_index, follower_indices, u, vl, near, dist,
                                   radii, dt)
        self.stats["steps"] += 1
        return u

    def _clear_segments(self, fld: ObstacleField, t: float, p: np.ndarray, C: np.ndarray,
                        clear: float) -> np.ndarray:
        """Which segments ``p -> C[k]`` keep ``clear`` from every static obstacle."""
        if len(C) == 0 or fld.n_static == 0:
            return np.ones(len(C), bool)
        seg = np.hypot(*(C - p).T)
        S = max(2, int(math.ceil(float(seg.max()) / max(0.5 * clear, self.ell))) + 1)
        s = np.linspace(0.0, 1.0, S)
        pts = p[None, None, :] + s[None, :, None] * (C - p)[:, None, :]  # (N, S, 2)
        _, d = fld.nearest(pts.reshape(-1, 2), t, max_range=clear)
        d = d[:, : fld.n_static].min(axis=1, initial=np.inf).reshape(len(C), S)
        return np.all(d >= clear, axis=1)

    def recovery(self, state: SimState, ids: list[str], xl: np.ndarray, xf: np.ndarray,
                 u: np.ndarray, vl: np.ndarray, L: np.ndarray, Phi: np.ndarray,
                 phi: np.ndarray, radii: np.ndarray, theta: float,
                 phi_d: np.ndarray) -> np.ndarray:
        """Option ``recovery``: a follower that lost its slot goes back to it first.

        The L-phi potential is even in phi and its barrier at phi = 0 keeps a follower on the
        side it is on, and its pull decays like 1/r far from the leader; so a follower that
        was swept to the wrong side (the pilot swerved), left behind an obstacle or far away
        would settle in the mirrored slot, jam against its neighbour, or crawl.  Such a
        follower is *lost* when it is farther than ``L / 2`` from its slot and the slot is on
        the other side of the leader's wake (sign of phi), hidden behind a static obstacle
        (the segment to it lacks the robot's radius plus ``clear_margin`` of clearance) or
        farther than ``trail_far * L``.  A lost follower with its slot in sight pursues it,
        ``u = v_L + k_f (s - x)`` (capped at its max speed), else heads at full speed for the
        farthest point of the pilot's recorded path it can see within ``trail_reach * L``
        (the pilot's path is clear of static obstacles: "the follower robot will follow the
        path of the pilot robot").  It returns to the L-phi law once its slot is in sight,
        within ``L / 2`` and on its side.
        """
        o = self.o
        fld = state.field
        dt = float(state.dt)
        if len(self._trail) == 0 or np.hypot(*(xl - self._trail[-1])) >= self.ell:
            self._trail = np.vstack([self._trail, xl[None, :]])
        slots = slot_positions(xl, theta, L, phi_d)
        err = np.hypot(*(xf - slots).T)
        wrong = (np.sign(phi) != np.sign(Phi)) & (Phi != 0)
        u = u.copy()
        vmax = np.array([self.problem.robot(k).max_speed for k in ids])
        if len(self._lost) != len(xf):
            self._lost = np.zeros(len(xf), bool)
        for i in range(len(xf)):
            if err[i] <= 0.5 * L[i] and not self._lost[i]:
                continue
            clear = radii[i] + o.clear_margin * self.ell
            seen = bool(self._clear_segments(fld, state.t, xf[i], slots[i:i + 1], clear)[0])
            if self._lost[i]:
                if seen and err[i] <= 0.5 * L[i] and not wrong[i]:
                    self._lost[i] = False
            elif wrong[i] or not seen or err[i] > o.trail_far * L[i]:
                self._lost[i] = True
                self.stats["lost"] += 1
            if not self._lost[i]:
                continue
            self.stats["recovery_steps"] += 1
            if seen:
                w = vl + o.k_f * (slots[i] - xf[i])
            else:
                T = self._trail
                dd = np.hypot(*(T - xf[i]).T)
                cand = np.nonzero(dd <= o.trail_reach * L[i])[0]
                if len(cand) == 0:
                    cand = np.array([int(np.argmin(dd))])
                cand = cand[::-1][:80]  # farthest along the pilot's path first
                vis = self._clear_segments(fld, state.t, xf[i], T[cand], clear)
                j = int(cand[int(np.argmax(vis))]) if vis.any() else int(cand[-1])
                d = T[j] - xf[i]
                nd = float(np.hypot(*d))
                w = (d / nd * min(float(vmax[i]), nd / dt) if nd > 1e-9 * self.ell
                     else np.zeros(2))
            sp = float(np.hypot(*w))
            u[i] = w * min(1.0, float(vmax[i]) / sp) if sp > 0 else w
        return u

    def safety_filter(self, state: SimState, leader_index: int, follower_indices: list[int],
                      u: np.ndarray, vl: np.ndarray, near: np.ndarray, dist: np.ndarray,
                      radii: np.ndarray, dt: float) -> np.ndarray:
        r"""Closest velocities to ``u`` that keep every gap after the step (option ``safety``).

        Discrete-time barrier rows, one half-plane per follower and neighbour (see the module
        doc): with :math:`n` the unit vector from the neighbour to the follower, :math:`d` the
        centre distance and :math:`D = D_s +` ``sep_margin``,

        * another follower:  :math:`n^T u_i \ge -\gamma (d - D)/(2\tau)` (each of the pair takes
          half, so together :math:`n^T(u_i-u_j) \ge -\gamma(d-D)/\tau`);
        * the leader or any robot not controlled here (known velocity :math:`v_j`):
          :math:`n^T u_i \ge n^T v_j - \gamma (d - D)/\tau`;
        * every sensed obstacle (nearest boundary point, velocity :math:`v_o`):
          :math:`n^T u_i \ge n^T v_o - \gamma(\rho - m)/\tau`, :math:`\rho` = clearance;
        * the arena bounds, and an inscribed polygon of the speed disc (hard rows).

        Since :math:`\|x + \tau w\| \ge n^T(x + \tau w)`, a row kept with
        :math:`\gamma \le 1` keeps the gap :math:`\ge D` (or the clearance :math:`\ge m`
        for a convex obstacle) after the step, and the whole step segment clear.  Rows that
        cannot bind (:math:`b \le -v_{max}`) are dropped and at most ``max_rows`` kept.
        """
        o = self.o
        P = state.positions
        Fn = len(follower_indices)
        xf = P[follower_indices]
        vmax = np.array([self.problem.robot(state.ids[i]).max_speed for i in follower_indices])
        g = o.gamma_s / dt
        rows_a: list[np.ndarray] = []
        rows_b: list[np.ndarray] = []
        # --- robots ---
        R = len(P)
        if R > 1:
            allr = np.array([self.problem.robot(i).radius for i in state.ids])
            Ds = self.form.safety_distance
            diff = xf[:, None, :] - P[None, :, :]  # (F, R, 2)
            dd = np.hypot(diff[..., 0], diff[..., 1])
            D = np.maximum(Ds, radii[:, None] + allr[None, :]) + o.sep_margin * self.ell
            tiny = 1e-9 * self.ell
            nrm = diff / np.where(dd > tiny, dd, 1.0)[..., None]
            ctrl = np.zeros(R, bool)
            ctrl[follower_indices] = True
            vel = np.asarray(state.velocities, float).copy()
            lr = self.problem.robot(state.ids[leader_index])
            sp = float(np.hypot(*vl))
            vel[leader_index] = vl * (min(1.0, lr.max_speed / sp) if sp > 0 else 1.0)
            h = dd - D
            bb = np.where(ctrl[None, :], -0.5 * g * h,
                          np.einsum("frd,rd->fr", nrm, vel) - g * h)
            self_pair = np.asarray(follower_indices)[:, None] == np.arange(R)[None, :]
            use = ~self_pair & (dd > tiny)
            rows_a.append(np.where(use[..., None], nrm, 0.0))
            rows_b.append(np.where(use, bb, -np.inf))
        # --- obstacles (nearest boundary points from the sensing above) ---
        if dist.shape[1]:
            fld = state.field
            vo = (fld.offsets(state.t + dt) - fld.offsets(state.t)) / dt  # (n_obs, 2)
            v = xf[:, None, :] - near
            nv = np.hypot(v[..., 0], v[..., 1])
            use = np.isfinite(dist) & (nv > 1e-9 * self.ell)
            nrm = np.where(use[..., None], v / np.where(use, nv, 1.0)[..., None], 0.0)
            rho = dist - radii[:, None]
            bb = np.einsum("fkd,kd->fk", nrm, vo) - g * (np.where(use, rho, 0.0)
                                                         - o.clear_margin * self.ell)
            rows_a.append(nrm)
            rows_b.append(np.where(use, bb, -np.inf))
        # --- arena bounds ---
        x0, y0, x1, y1 = self.problem.bounds
        lo = np.stack([xf[:, 0] - x0, xf[:, 1] - y0], 1) - radii[:, None]
        hi = np.stack([x1 - xf[:, 0], y1 - xf[:, 1]], 1) - radii[:, None]
        eye = np.eye(2)
        rows_a.append(np.broadcast_to(np.concatenate([eye, -eye])[None], (Fn, 4, 2)))
        rows_b.append(np.concatenate([-g * lo, -g * hi], 1))
        A = np.concatenate(rows_a, axis=1)
        b = np.concatenate(rows_b, axis=1)
        # keep the rows that can bind (b > -vmax), most critical first, at most max_rows
        b = np.where(b > -vmax[:, None], b, -np.inf)
        k = min(o.max_rows, b.shape[1])
        order = np.argsort(-b, axis=1)[:, :k]
        A = np.take_along_axis(A, order[..., None], axis=1)
        b = np.take_along_axis(b, order, axis=1)
        A = np.where(np.isfinite(b)[..., None], A, 0.0)
        m = len(self._speed_rows)
        A = np.concatenate([A, np.broadcast_to(self._speed_rows[None], (Fn, m, 2))], 1)
        b = np.concatenate([b, -vmax[:, None] * self._speed_rhs * np.ones((1, m))], 1)
        hard = np.r_[np.zeros(k, bool), np.ones(m, bool)]
        # the nominal command, clamped to the speed disc as the simulator would
        sp = np.hypot(u[:, 0], u[:, 1])
        u_nom = u * np.minimum(1.0, vmax / np.where(sp > 0, sp, 1.0))[:, None]
        active = np.isfinite(b[:, :k]).any(axis=1)
        out = u_nom.copy()
        if active.any():
            uf, bad = project_halfplanes(u_nom[active], A[active], b[active], hard)
            out[active] = uf
            self.stats["infeasible"] += int(bad.sum())
            self.stats["filtered"] += int(np.sum(np.hypot(*(uf - u_nom[active]).T)
                                                 > 1e-9 * self.ell))
        return out


# --------------------------------------------------------------------------------------
# shared driver (also used by formation_qp)
# --------------------------------------------------------------------------------------


def reference_path(problem: Problem, path_solver: Backend, rng: np.random.Generator,
                   init: dict[str, np.ndarray] | None) -> tuple[np.ndarray, str]:
    """The leader's reference: ``init[leader]``, else planned on ``problem.known_view()``.

    A path solver that returns no usable path (status ``infeasible`` / ``failed``, or fewer
    than two points) gives the straight start-goal line, said in the message.
    """
    lead = problem.leader
    if init and lead.id in init:
        return np.asarray(init[lead.id], float), "reference from init"
    name = path_solver.preset or path_solver.name
    res = path_solver.solve(problem.known_view(), rng=rng)
    path = res.paths.get(lead.id)
    if path is not None and len(path) >= 2 and res.status.value in ("optimal", "solved",
                                                                     "approximate"):
        return np.asarray(path, float), f"reference by {name} ({res.status.value})"
    return (np.vstack([lead.start, lead.goal]),
            f"{name} returned {res.status.value}; straight-line reference used")


#: ``pilot`` value selecting the built-in eqs 39-45 pilot (:class:`PilotAPF`).
BUILTIN_PILOT = "builtin"

#: The pilot's gains passed on to a local planner used as the pilot (those it has).
PILOT_GAINS = ("k", "eta", "rho_0", "n")


def make_pilot(problem: Problem, opts: PilotedFormation, rng: np.random.Generator,
               speed: float) -> tuple[LocalController, str]:
    """The leader's controller and its name: the built-in pilot or the ``pilot`` stage's."""
    lead = problem.leader
    planner = opts.stages["pilot"]
    if planner is None:
        return PilotAPF(problem, lead.id, k=opts.k, eta=opts.eta, rho_0=opts.rho_0, n=opts.n,
                        speed=speed, scale=problem.length_scale), BUILTIN_PILOT
    return planner.controller(problem, lead.id, rng), opts.pilot


class _FormationRun:
    """One leader-follower simulation: the pilot on the reference, the followers by ``fctrl``.

    The policy, ``done`` test and history of :func:`run_formation`; the formation frame's
    heading is the leader's command direction low-passed with time constant ``tau_h``.
    """

    def __init__(self, o: PilotedFormation, problem: Problem, tracker: ReferenceTracker,
                 fctrl: Any, ref: np.ndarray, joint: Callable[..., np.ndarray] | None,
                 step_columns: Callable[[], dict[str, Any]] | None):
        self.o, self.problem, self.tracker, self.fctrl = o, problem, tracker, fctrl
        self.joint, self.step_columns = joint, step_columns
        form = problem.formation
        self.lead = problem.leader
        self.ids = [self.lead.id] + [f.id for f in form.followers]
        self.fidx = list(range(1, len(self.ids)))
        self.L = np.array([f.L for f in form.followers])
        self.phi = np.array([f.phi for f in form.followers])
        self.vmax_f = np.array([problem.robot(i).max_speed for i in self.ids[1:]])
        self.tol = problem.goal_tol(self.lead)
        g0 = self.lead.goal - self.lead.start
        h0 = (float(np.arctan2(ref[1, 1] - ref[0, 1], ref[1, 0] - ref[0, 0])) if len(ref) > 1
              else float(np.arctan2(g0[1], g0[0])))
        self.heading = h0  # the formation frame's heading
        self.raw_heading = h0  # the last heading of a non-zero leader command
        self.hist = History()
        self.t_start = time.perf_counter()

    def slot_err(self, state: SimState) -> np.ndarray:
        P = state.positions
        slots = slot_positions(P[0], self.heading, self.L, self.phi)
        return np.hypot(*(P[1:] - slots).T)

    def _turn(self, ul: np.ndarray) -> None:
        if np.hypot(*ul) > 1e-9 * self.problem.length_scale:
            self.raw_heading = float(np.arctan2(ul[1], ul[0]))
        o = self.o
        a = min(1.0, o.dt / o.tau_h) if o.tau_h > 0 else 1.0
        self.heading = float(wrap(self.heading + a * wrap(self.raw_heading - self.heading)))

    def policy(self, state: SimState) -> np.ndarray:
        t0 = time.perf_counter()
        ul = self.tracker.velocity(state, 0)
        self._turn(ul)
        state.leader_velocity = ul
        if self.joint is not None:
            U = self.joint(state, ul, self.heading)
        else:
            U = np.zeros((len(self.ids), 2))
            U[0] = ul
            U[1:] = self.fctrl.velocities(state, 0, self.fidx, self.heading)
        err = self.slot_err(state)
        row = dict(iteration=state.k,
                   best_cost=float(np.hypot(*(self.lead.goal - state.positions[0]))),
                   n_eval=state.k + 1, time=time.perf_counter() - self.t_start,
                   formation_error=float(err.max()), step_time=time.perf_counter() - t0)
        if self.step_columns is not None:
            row.update(self.step_columns())
        self.hist.append(**row)
        return U

    def done(self, state: SimState) -> bool:
        P = state.positions
        if np.hypot(*(P[0] - self.lead.goal)) > self.tol or state.k == 0:
            return False
        sp = np.hypot(*state.velocities[1:].T) / self.vmax_f
        if np.all(sp < 1e-3):  # settled where the law holds them (e.g. eq 52 near a wall)
            return True
        return bool(np.all(self.slot_err(state) <= self.o.settle_tol * self.L)
                    and np.all(sp < 1e-2))


def run_formation(backend: PilotedFormation, problem: Problem, fctrl: Any, *,
                  rng: np.random.Generator, init: dict[str, np.ndarray] | None,
                  callback: Callable[[Progress], Any] | None,
                  joint: Callable[..., np.ndarray] | None = None,
                  step_columns: Callable[[], dict[str, Any]] | None = None,
                  extras: Callable[[], dict[str, Any]] | None = None) -> Result:
    """One simulation: leader tracks the reference, followers by ``fctrl``.

    Parameters
    ----------
    backend : PilotedFormation
        The options (pilot, reference, run settings).
    fctrl : FollowerController
        The followers' controller.
    joint : callable, optional
        ``joint(state, u_lead, heading) -> (R, 2)`` replaces the follower call when the
        backend also filters the leader (formation-qp with the leader in the QP).
    step_columns : callable, optional
        ``step_columns() -> dict`` of extra history columns for the step just taken (e.g. the
        QP's status and solve time).
    extras : callable, optional
        ``extras() -> dict`` of backend statistics added to ``Result.extras`` at the end.
    """
    t_start = time.perf_counter()
    if problem.formation is None:
        raise ValueError(f"{backend.name}: problem {problem.name!r} has no [formation]")
    lead = problem.leader
    ref, ref_msg = reference_path(problem, backend.stages["path_solver"], rng, init)
    speed = backend.v_factor * lead.max_speed
    pilot, pilot_name = make_pilot(problem, backend, rng, speed)
    ell = problem.length_scale
    tracker = ReferenceTracker(ref, pilot, spacing=backend.ref_spacing * ell,
                               lookahead=backend.lookahead * ell, speed=speed,
                               goal_tol=problem.goal_tol(lead),
                               clearance=2 * lead.radius + backend.lookahead * ell / 2)
    run = _FormationRun(backend, problem, tracker, fctrl, ref, joint, step_columns)
    out = simulate(problem, run.policy, ids=run.ids, dt=backend.dt,
                   max_steps=backend.max_steps, done=run.done, field_=ObstacleField(problem),
                   callback=callback)
    claim = {"done": Status.solved, "budget": Status.approximate,
             "callback": Status.approximate}.get(out.reason, Status.failed)
    msg = f"{out.reason}" + (f" ({out.collision})" if out.collision else "")
    msg += f"; {ref_msg}; pilot {pilot_name}"
    ex = {"reference": ref, "stop_reason": out.reason, "pilot": pilot_name,
          "pilot_stats": dict(getattr(pilot, "stats", {})),
          "follower_stats": dict(getattr(fctrl, "stats", {})),
          "contacts": list(out.contacts)}
    if extras is not None:
        ex.update(extras())
    return backend.finish(problem, out.paths(), claim=claim, times=out.times,
                          cost=float(out.times[-1]), message=msg, n_iter=out.steps,
                          n_eval=out.steps, history=run.hist, extras=ex,
                          metrics_extra={"time_to_goal": float(out.times[-1])},
                          wall_time=time.perf_counter() - t_start)


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class PilotedFormation(Backend):
    r"""Options shared by the formation backends: the leader's pilot and the run.

    Every distance-like option is a multiple of the scene's length unit
    :attr:`optplan.problem.Problem.length_scale` (marked "x length_scale"; 1 on the paper's
    scenes, so the ``-paper`` presets keep the paper's literal values there): the same preset
    behaves the same on a scene drawn in centimetres, metres or kilometres.

    Parameters
    ----------
    k : float
        Pilot attraction gain (eqs 39-40); paper 15.  The pilot moves along the direction of
        the total force, computed in units of ``length_scale``.
    eta : float
        Pilot repulsion gain (eqs 41, 44-45); paper 3.7.
    rho_0 : float
        Pilot obstacle influence distance (eq 41; x length_scale); paper 100.
    n : float
        Goal-distance exponent of the improved repulsion (eq 41); paper 3.
    adapt_phi : bool
        Shrink the desired angle near obstacles by eq 52.
    rho_0_f : float
        Obstacle clearance below which eq 52 acts (x length_scale); the paper uses the same
        :math:`\rho_0 = 100`.
    c_phi : float
        The factor 20 inside the logarithms of eq 52, per length unit (used as
        ``c_phi / length_scale``); rho is clamped at ``length_scale / c_phi``.
    pilot : str or Backend
        ``"builtin"`` (default, the paper): the built-in eqs 39-45 pilot (:class:`PilotAPF`
        with ``k``, ``eta``, ``rho_0``, ``n``).  Otherwise a preset or backend name (or object)
        of a :class:`~optplan.interfaces.LocalPlanner` (e.g. ``"sa-apf"``), whose controller
        drives the leader with this backend's ``k``, ``eta``, ``rho_0`` and ``n`` (those the
        local planner has as options).  Resolved when the backend is built: a misspelled name
        or a backend without ``controller()`` is a ``ValueError``.
    path_solver : str or Backend
        Solver planning the leader's reference on ``problem.known_view()`` when ``init`` has
        none (default ``"ipso"``, the documented IPSO variant, collision-free in every measured
        run; the literal ``"ipso-paper"`` fails on some maps, see the PSO page).  Resolved when
        the backend is built.
    v_factor : float
        Leader cruise speed as a fraction of its ``max_speed`` (headroom for followers).
    ref_spacing : float
        Resampling step of the leader's reference (x length_scale).
    lookahead : float
        Target look-ahead along the reference (x length_scale); reference points closer than
        twice the leader's radius plus half of it to a sensed obstacle are skipped.
    tau_h : float
        Time constant (s) of the low-pass filter on the leader heading that orients the
        formation frame (0: raw heading of the leader's command).
    dt : float
        Control period (s).
    max_steps : int
        Simulation budget (control steps).
    settle_tol : float
        The run ends when the leader is at its goal and every follower is within
        ``settle_tol * L`` of its slot and (nearly) still, or every follower has stopped
        (a fraction of each follower's L, so scale-free).
    """

    k: float = option(15.0, lo=0.0, lo_open=True)
    eta: float = option(3.7, lo=0.0)
    rho_0: float = option(100.0, lo=0.0, lo_open=True, scale=True)
    n: float = option(3.0, lo=0.0)
    adapt_phi: bool = option(True)
    rho_0_f: float = option(100.0, lo=0.0, lo_open=True, scale=True)
    c_phi: float = option(20.0, lo=0.0, lo_open=True)
    pilot: Any = option(BUILTIN_PILOT, kind="any")
    path_solver: Any = option("ipso", kind="any")
    v_factor: float = option(0.75, lo=0.0, hi=1.0, lo_open=True)
    ref_spacing: float = option(5.0, lo=0.0, lo_open=True, scale=True)
    lookahead: float = option(15.0, lo=0.0, scale=True)
    tau_h: float = option(5.0, lo=0.0)
    dt: float = option(0.5, lo=0.0, lo_open=True)
    max_steps: int = option(4000, lo=1, hi=10_000_000)
    settle_tol: float = option(0.005, lo=0.0, lo_open=True)
    _stages: dict[str, Any] = field(init=False, repr=False, compare=False, default=None)

    def check(self) -> None:
        """Resolve the ``pilot`` and ``path_solver`` stages (a ``ValueError`` names the option)."""
        object.__setattr__(self, "_stages", {"pilot": self._resolve_pilot(), "path_solver":
                                            resolve_stage(self.name, "path_solver",
                                                          self.path_solver, PATH_SOLVER)})

    def _resolve_pilot(self) -> Any:
        if self.pilot == BUILTIN_PILOT:
            return None
        planner = resolve_stage(self.name, "pilot", self.pilot, LOCAL_PLANNER)
        gains = {g: getattr(self, g) for g in PILOT_GAINS if g in planner.options()}
        try:
            return get_solver(planner, **gains)
        except ValueError as e:
            raise ValueError(f"option 'pilot' of backend {self.name!r}: the pilot's gains "
                             f"{sorted(gains)} do not suit {self.pilot!r}: {e}") from None

    @property
    def stages(self) -> dict[str, Any]:
        """The resolved stages: ``{"pilot": LocalPlanner or None (the built-in pilot),
        "path_solver": Backend}``, set when the backend is built."""
        return self._stages

    def options(self) -> dict[str, Any]:
        out = super().options()
        for k in ("pilot", "path_solver"):
            if isinstance(out[k], Backend):
                out[k] = out[k].preset or out[k].name
        return out


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
