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
speed.  If the SA-APF backend (paper §IV.B) is installed and ``pilot = "sa-apf"`` its controller
drives the leader instead (same reference points).

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

(clamped so the log never flips the formation side, domain-notes §3.3).  The paper says the
followers also avoid each other and obstacles (§IV.C.3) without giving the law; optplan adds an
APF repulsion of the eq 6 form between robots (``eta_r``, influence ``d_0``) and from obstacles
(``eta_f``, influence ``rho_f``).  The simulator clamps every speed to ``max_speed``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.problem import Problem
from optplan.result import History, Progress, Status
from optplan.sim import ObstacleField, SimState, simulate
from optplan.solver import Backend, check_int, check_range, get_solver

__all__ = [
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

    Parameters
    ----------
    x, goal : (2,)
    near : (m, 2)
        Nearest obstacle points.
    clear : (m,)
        Clearances ``rho`` (clamped by the caller); obstacles with ``rho > rho_0`` are ignored.
    """
    d_g = goal - x
    rho_g = float(np.hypot(*d_g))
    F = k * d_g
    use = np.isfinite(clear) & (clear <= rho_0)
    if use.any() and rho_g > 0:
        rho = clear[use]
        v = x[None, :] - near[use]
        nv = np.hypot(v[:, 0], v[:, 1])
        n_or = v / np.where(nv > 1e-12, nv, 1.0)[:, None]
        diff = 1.0 / rho - 1.0 / rho_0
        f1 = eta * diff * rho_g**n / rho**2
        f2 = 0.5 * n * eta * diff**2 * rho_g ** (n - 1)
        F = F + np.sum(f1[:, None] * n_or, axis=0) + np.sum(f2) * d_g / rho_g
    return F


# --------------------------------------------------------------------------------------
# controllers
# --------------------------------------------------------------------------------------


class PilotAPF:
    """The pilot's improved APF (eqs 39-45) as a LocalController (interfaces.md).

    Moves along ``F / |F|`` at ``speed``; never overshoots the goal.
    """

    def __init__(self, problem: Problem, robot_id: str, *, k: float, eta: float, rho_0: float,
                 n: float, speed: float, rho_min: float = 0.5):
        self.robot = problem.robot(robot_id)
        self.k, self.eta, self.rho_0, self.n = k, eta, rho_0, n
        self.speed, self.rho_min = speed, rho_min
        self.goal = np.array(self.robot.goal if self.robot.goal is not None
                             else self.robot.start, float)
        self.stats: dict[str, Any] = {"steps": 0}

    def reset(self, goal: np.ndarray) -> None:
        self.goal = np.asarray(goal, float).copy()

    def velocity(self, state: SimState, index: int) -> np.ndarray | None:
        x = state.positions[index]
        near, dist = state.field.nearest(x, state.t, max_range=self.rho_0 + self.robot.radius)
        clear = np.maximum(dist[0] - self.robot.radius, self.rho_min)
        clear = np.where(np.isfinite(dist[0]), clear, np.inf)
        F = pilot_force(x, self.goal, near[0], clear, self.k, self.eta, self.rho_0, self.n)
        nf = float(np.hypot(*F))
        self.stats["steps"] += 1
        if nf < 1e-12:
            return np.zeros(2)
        dt = float(state.memory.get("dt", 1.0))
        dist_g = float(np.hypot(*(self.goal - x)))
        return F / nf * min(self.speed, dist_g / dt)


class ReferenceTracker:
    """Drives the leader along a reference polyline with a LocalController.

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
        n = max(2, int(math.ceil(s[-1] / spacing)) + 1) if s[-1] > 0 else 1
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
        dt = float(state.memory.get("dt", 1.0))
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
    """The paper's follower law (eqs 46-52) for a set of followers (FollowerController)."""

    def __init__(self, problem: Problem, opts: LeaderFollower):
        if problem.formation is None:
            raise ValueError(f"problem {problem.name!r} has no [formation]")
        self.problem = problem
        self.form = problem.formation
        self.spec = {f.id: f for f in self.form.followers}
        self.o = opts
        self.stats: dict[str, Any] = {"min_phi_ratio": 1.0, "steps": 0}

    def velocities(self, state: SimState, leader_index: int, follower_indices: list[int],
                   leader_heading: float) -> np.ndarray:
        o = self.o
        P = state.positions
        xl = P[leader_index]
        ids = [state.ids[i] for i in follower_indices]
        L = np.array([self.spec[i].L for i in ids])
        Phi = np.array([self.spec[i].phi for i in ids])
        radii = np.array([self.problem.robot(i).radius for i in ids])
        xf = P[follower_indices]
        vl = np.asarray(state.memory.get("leader_velocity", state.velocities[leader_index]),
                        float)
        # obstacle sensing for every follower at once
        rng_s = max(o.rho_0_f, o.rho_f)
        near, dist = state.field.nearest(xf, state.t, max_range=rng_s + radii.max())
        clear = dist - radii[:, None]
        rho = np.min(clear, axis=1) if clear.shape[1] else np.full(len(ids), np.inf)
        phi_d = adapted_angle(Phi, rho, o.rho_0_f, o.c_phi) if o.adapt_phi else Phi
        self.stats["min_phi_ratio"] = float(min(self.stats["min_phi_ratio"],
                                                np.min(np.abs(phi_d / Phi))))
        r, phi = relative_polar(xl, leader_heading, xf)
        r = np.maximum(r, RHO_MIN)
        phi = np.where(np.abs(phi) < 1e-6, np.copysign(1e-6, Phi), phi)
        dUr, dUphi = lphi_gradient(r, phi, L, phi_d, o.A, o.B)
        rel = xf - xl[None, :]
        e_r = rel / r[:, None]
        # phi grows clockwise (toward the leader's left from behind): e_phi = -perp(e_r)
        e_phi = np.stack([e_r[:, 1], -e_r[:, 0]], axis=1)
        kappa = o.k_f * L**2 / (4 * np.maximum(o.A, o.B / Phi**2))
        grad = dUr[:, None] * e_r + (dUphi / r)[:, None] * e_phi
        u = (vl[None, :] if o.feedforward else 0.0) - kappa[:, None] * grad
        # inter-robot repulsion (every robot in the simulation, eq 6 form)
        if o.eta_r > 0 and len(P) > 1:
            allr = np.array([self.problem.robot(i).radius for i in state.ids])
            diff = xf[:, None, :] - P[None, :, :]
            dd = np.hypot(diff[..., 0], diff[..., 1])
            gap = np.maximum(dd - radii[:, None] - allr[None, :], RHO_MIN)
            act = (gap < o.d_0) & (dd > 1e-9)
            mag = np.where(act, o.eta_r * (1 / gap - 1 / o.d_0) / gap**2, 0.0)
            u = u + np.sum(mag[..., None] * diff / np.where(dd > 1e-9, dd, 1)[..., None], 1)
        if o.eta_f > 0 and clear.shape[1]:
            g = np.maximum(clear, RHO_MIN)
            act = np.isfinite(g) & (g < o.rho_f)
            v = xf[:, None, :] - near
            nv = np.hypot(v[..., 0], v[..., 1])
            nrm = np.where(act[..., None], v / np.where(nv > 1e-12, nv, 1)[..., None], 0.0)
            mag = np.where(act, o.eta_f * (1 / g - 1 / o.rho_f) / g**2, 0.0)
            u = u + np.sum(mag[..., None] * np.nan_to_num(nrm), axis=1)
        self.stats["steps"] += 1
        return u


# --------------------------------------------------------------------------------------
# shared driver (also used by formation_qp)
# --------------------------------------------------------------------------------------


def reference_path(problem: Problem, path_solver: str, rng: np.random.Generator,
                   init: dict[str, np.ndarray] | None) -> tuple[np.ndarray, str]:
    """The leader's reference: ``init[leader]``, else planned on ``problem.known_view()``."""
    lead = problem.leader
    if init and lead.id in init:
        return np.asarray(init[lead.id], float), "reference from init"
    try:
        res = get_solver(path_solver).solve(problem.known_view(), rng=rng)
        path = res.paths.get(lead.id)
        if path is not None and len(path) >= 2 and res.status.value in ("optimal", "solved",
                                                                         "approximate"):
            return np.asarray(path, float), f"reference by {path_solver} ({res.status.value})"
        msg = f"{path_solver} returned {res.status.value}"
    except Exception as e:  # noqa: BLE001 - an unavailable planner must not abort the run
        msg = f"{path_solver} unavailable ({e})"
    return np.vstack([lead.start, lead.goal]), msg + "; straight-line reference used"


def make_pilot(problem: Problem, opts: Any, rng: np.random.Generator, speed: float):
    """The leader's LocalController: own eqs 39-45 pilot, or the SA-APF backend's controller."""
    lead = problem.leader
    if opts.pilot != "apf-paper":
        try:
            try:  # the pilot's paper values (eqs 39-45) on the named local planner
                loc = get_solver(opts.pilot, k=opts.k, eta=opts.eta, rho_0=opts.rho_0, n=opts.n)
            except ValueError:
                loc = get_solver(opts.pilot)
            return loc.controller(problem, lead.id, rng), opts.pilot
        except Exception as e:  # noqa: BLE001 - fall back to the built-in pilot
            note = f"pilot {opts.pilot!r} unavailable ({type(e).__name__}); built-in used"
            return PilotAPF(problem, lead.id, k=opts.k, eta=opts.eta, rho_0=opts.rho_0,
                            n=opts.n, speed=speed), note
    return PilotAPF(problem, lead.id, k=opts.k, eta=opts.eta, rho_0=opts.rho_0, n=opts.n,
                    speed=speed), "apf-paper"


def run_formation(backend: Backend, problem: Problem, fctrl: Any, *, rng: np.random.Generator,
                  init: dict[str, np.ndarray] | None,
                  callback: Callable[[Progress], Any] | None,
                  joint: Callable[..., np.ndarray] | None = None):
    """One simulation: leader tracks the reference, followers by ``fctrl``.

    ``joint(state, u_lead, heading) -> (R, 2)`` replaces the follower call when the backend
    also filters the leader (formation-qp with the leader in the QP).
    """
    o = backend  # options live on the backend
    t_start = time.perf_counter()
    if problem.formation is None:
        raise ValueError(f"{backend.name}: problem {problem.name!r} has no [formation]")
    form = problem.formation
    lead = problem.leader
    ids = [lead.id] + [f.id for f in form.followers]
    fidx = list(range(1, len(ids)))
    ref, ref_msg = reference_path(problem, o.path_solver, rng, init)
    speed = o.v_factor * lead.max_speed
    pilot, pilot_name = make_pilot(problem, o, rng, speed)
    tracker = ReferenceTracker(ref, pilot, spacing=o.ref_spacing, lookahead=o.lookahead,
                               speed=speed, goal_tol=problem.goal_tol(lead),
                               clearance=2 * lead.radius + o.lookahead / 2)
    fld = ObstacleField(problem)
    hist = History()
    g0 = lead.goal - lead.start
    h0 = (float(np.arctan2(ref[1, 1] - ref[0, 1], ref[1, 0] - ref[0, 0])) if len(ref) > 1
          else float(np.arctan2(g0[1], g0[0])))
    heading = [h0, h0]  # [formation-frame heading, last raw heading]
    L = np.array([f.L for f in form.followers])
    tol = problem.goal_tol(lead)

    def slot_err(state: SimState) -> np.ndarray:
        P = state.positions
        slots = slot_positions(P[0], heading[0], L, [f.phi for f in form.followers])
        return np.hypot(*(P[1:] - slots).T)

    def policy(state: SimState):
        t0 = time.perf_counter()
        ul = tracker.velocity(state, 0)
        if np.hypot(*ul) > 1e-9:
            heading[1] = float(np.arctan2(ul[1], ul[0]))
        # formation frame: the leader's heading low-passed with time constant tau_h (it keeps
        # converging to the last heading after the leader stops)
        a = min(1.0, o.dt / o.tau_h) if o.tau_h > 0 else 1.0
        heading[0] = float(wrap(heading[0] + a * wrap(heading[1] - heading[0])))
        state.memory["leader_velocity"] = ul
        if joint is not None:
            U = joint(state, ul, heading[0])
        else:
            U = np.zeros((len(ids), 2))
            U[0] = ul
            U[1:] = fctrl.velocities(state, 0, fidx, heading[0])
        err = slot_err(state)
        row = dict(iteration=state.k, best_cost=float(np.hypot(*(lead.goal - state.positions[0]))),
                   n_eval=state.k + 1, time=time.perf_counter() - t_start,
                   formation_error=float(err.max()), step_time=time.perf_counter() - t0)
        row.update(state.memory.pop("qp_row", {}))
        hist.append(**row)
        return U

    def done(state: SimState) -> bool:
        P = state.positions
        if np.hypot(*(P[0] - lead.goal)) > tol:
            return False
        if state.k == 0:
            return False
        vmax = np.array([problem.robot(i).max_speed for i in ids[1:]])
        sp = np.hypot(*state.velocities[1:].T) / vmax
        if np.all(sp < 1e-3):  # settled where the law holds them (e.g. eq 52 near a wall)
            return True
        return bool(np.all(slot_err(state) <= o.settle_tol * L) and np.all(sp < 1e-2))

    out = simulate(problem, policy, ids=ids, dt=o.dt, max_steps=o.max_steps, done=done,
                   field_=fld, callback=callback, memory={"dt": o.dt})
    paths = out.paths()
    claim = {"done": Status.solved, "budget": Status.approximate,
             "callback": Status.approximate}.get(out.reason, Status.failed)
    msg = f"{out.reason}" + (f" ({out.collision})" if out.collision else "")
    msg += f"; {ref_msg}; pilot {pilot_name}"
    extras = {"reference": ref, "stop_reason": out.reason, "pilot": pilot_name,
              "pilot_stats": dict(getattr(pilot, "stats", {})),
              "follower_stats": dict(getattr(fctrl, "stats", {})),
              "contacts": out.memory.get("contacts", [])}
    res = backend.finish(problem, paths, claim=claim, times=out.times,
                         cost=float(out.times[-1]), message=msg, n_iter=out.steps,
                         n_eval=out.steps, history=hist, extras=extras,
                         metrics_extra={"time_to_goal": float(out.times[-1])},
                         wall_time=time.perf_counter() - t_start)
    return res


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class LeaderFollower(Backend):
    """Paper leader-follower formation: pilot APF (eqs 39-45) + L-phi followers (eqs 46-52).

    Parameters
    ----------
    k : float
        Pilot attraction gain (eqs 39-40); paper 15.
    eta : float
        Pilot repulsion gain (eqs 41, 44-45); paper 3.7.
    rho_0 : float
        Pilot obstacle influence distance (map units, eq 41); paper 100.
    n : float
        Goal-distance exponent of the improved repulsion (eq 41); paper 3.
    A, B : float
        Gains of the distance and angle potentials (eqs 46, 48); paper 0.5 each.
    k_f : float
        Follower convergence rate (1/s): scale of the gradient step, see module doc.
    adapt_phi : bool
        Shrink the desired angle near obstacles by eq 52.
    rho_0_f : float
        Obstacle distance (map units) below which eq 52 acts; paper uses the same
        :math:`\\rho_0 = 100`.
    c_phi : float
        The factor 20 inside the logarithms of eq 52 (1/map unit); rho is clamped at 1/c_phi.
    feedforward : bool
        Add the leader's velocity to every follower command.
    eta_r, d_0 : float
        Inter-robot repulsion gain and influence clearance (map units), eq 6 form (paper
        §IV.C.3 asks for inter-robot avoidance without giving a law).
    eta_f, rho_f : float
        Follower obstacle repulsion gain and influence clearance (0 disables it).
    pilot : str
        ``"apf-paper"`` (built-in eqs 39-45) or a local solver name whose backend exposes
        ``controller()`` (e.g. ``"sa-apf"``); falls back to the built-in one if unavailable.
    path_solver : str
        Solver planning the leader's reference on ``problem.known_view()`` when ``init`` has
        none.
    v_factor : float
        Leader cruise speed as a fraction of its ``max_speed`` (headroom for followers).
    ref_spacing, lookahead : float
        Reference resampling step and target look-ahead (map units).
    tau_h : float
        Time constant (s) of the low-pass filter on the leader heading that orients the
        formation frame (0: raw heading of the leader's command).
    dt : float
        Control period (s).
    max_steps : int
        Simulation budget.
    settle_tol : float
        The run ends when the leader is at its goal and every follower is within
        ``settle_tol * L`` of its slot and (nearly) still, or every follower has stopped.
    """

    name: ClassVar[str] = "leader-follower"
    contract_problem: ClassVar[str] = "formation-open-field"
    contract_overrides: ClassVar[dict] = {"path_solver": "visgraph", "max_steps": 150,
                                          "dt": 1.0}
    k: float = 15.0
    eta: float = 3.7
    rho_0: float = 100.0
    n: float = 3.0
    A: float = 0.5
    B: float = 0.5
    k_f: float = 1.0
    adapt_phi: bool = True
    rho_0_f: float = 100.0
    c_phi: float = 20.0
    feedforward: bool = True
    eta_r: float = 200.0
    d_0: float = 10.0
    eta_f: float = 200.0
    rho_f: float = 10.0
    pilot: str = "apf-paper"
    path_solver: str = "ipso-paper"
    v_factor: float = 0.75
    ref_spacing: float = 5.0
    lookahead: float = 15.0
    tau_h: float = 5.0
    dt: float = 0.5
    max_steps: int = 4000
    settle_tol: float = 0.005

    def __post_init__(self) -> None:
        check_range(self, "k", 0, lo_open=True)
        check_range(self, "eta", 0)
        check_range(self, "rho_0", 0, lo_open=True)
        check_range(self, "n", 0)
        check_range(self, "A", 0, lo_open=True)
        check_range(self, "B", 0, lo_open=True)
        check_range(self, "k_f", 0, lo_open=True)
        check_range(self, "rho_0_f", 0, lo_open=True)
        check_range(self, "c_phi", 0, lo_open=True)
        check_range(self, "eta_r", 0)
        check_range(self, "d_0", 0, lo_open=True)
        check_range(self, "eta_f", 0)
        check_range(self, "rho_f", 0, lo_open=True)
        check_range(self, "v_factor", 0, 1, lo_open=True)
        check_range(self, "ref_spacing", 0, lo_open=True)
        check_range(self, "lookahead", 0)
        check_range(self, "dt", 0, lo_open=True)
        check_range(self, "tau_h", 0)
        if self.k_f * self.dt > 1 + 1e-12:
            raise ValueError(f"options 'k_f' * 'dt' of backend {self.name!r} must be <= 1 "
                             f"(stable follower step), got {self.k_f} * {self.dt}")
        check_int(self, "max_steps", 1, 10_000_000)
        check_range(self, "settle_tol", 0, lo_open=True)
        for b in ("adapt_phi", "feedforward"):
            if not isinstance(getattr(self, b), bool):
                raise ValueError(f"option {b!r} of backend {self.name!r} must be true or false")
        for s in ("pilot", "path_solver"):
            if not isinstance(getattr(self, s), str) or not getattr(self, s):
                raise ValueError(f"option {s!r} of backend {self.name!r} must be a solver name")

    def followers_controller(self, problem: Problem, rng: np.random.Generator) -> LPhiFollowers:
        """The L-phi follower law as a FollowerController (interfaces.md)."""
        return LPhiFollowers(problem, self)

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        rng = rng if rng is not None else np.random.default_rng(0)
        return run_formation(self, problem, self.followers_controller(problem, rng), rng=rng,
                             init=init, callback=callback)
