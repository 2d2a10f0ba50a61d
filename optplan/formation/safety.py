r"""The leader-follower safety layer: the barrier filter and the recovery of lost followers.

Options ``safety`` and ``recovery`` of :class:`~optplan.formation.leader_follower.LeaderFollower`.

Beyond the paper's equations; on in the ``leader-follower-paper`` preset.  The filter and the
recovery are methods of :class:`SafetyLayer`, the base of
:class:`~optplan.formation.leader_follower.LPhiFollowers`; the exact 2-D projection they use is
:func:`project_halfplanes`.

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.formation.slots import slot_positions
from optplan.geometry.collision import farthest_clear
from optplan.problem import Formation, Problem
from optplan.sim import ObstacleField, SimState

__all__ = ["SafetyLayer", "LeaderFrame", "FollowerStates", "project_halfplanes"]


@dataclass(frozen=True)
class LeaderFrame:
    """The formation frame at one control step: where the leader is, its heading and the
    velocity it was commanded.

    Attributes
    ----------
    x : (2,)
        The leader's position (the frame's origin).
    heading : float
        The frame's heading (rad); the slots are placed about it.
    v : (2,)
        The leader's command this step.
    """

    x: np.ndarray
    heading: float
    v: np.ndarray


@dataclass(frozen=True)
class FollowerStates:
    """The followers at one control step as the L-phi law sees them, one entry per follower.

    Attributes
    ----------
    ids : list of str
        The followers' robot ids.
    x : (F, 2)
        Their positions.
    radii : (F,)
        Their radii.
    L, Phi : (F,)
        Their slots' distance and angle (the formation's spec).
    phi_d : (F,)
        The slot angle the law aims at (``Phi`` adapted near obstacles, eq 52).
    phi : (F,)
        Their measured angle in the leader's frame (never 0: nudged to the side of ``Phi``).
    """

    ids: list[str]
    x: np.ndarray
    radii: np.ndarray
    L: np.ndarray
    Phi: np.ndarray
    phi_d: np.ndarray
    phi: np.ndarray


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


class SafetyLayer:
    """The safety filter and the recovery of the L-phi followers.

    Needs, on the instance: ``o`` (the :class:`~optplan.formation.leader_follower.LeaderFollower`
    options), ``problem``, ``form``, ``ell`` (the length unit), ``stats``, ``_trail`` (the
    pilot's path so far), ``_lost`` (per follower) and the speed polygon ``_speed_rows`` /
    ``_speed_rhs``.
    """

    o: Any
    problem: Problem
    form: Formation
    ell: float
    stats: dict[str, Any]
    _trail: np.ndarray
    _lost: np.ndarray
    _speed_rows: np.ndarray
    _speed_rhs: float

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

    def recovery(self, state: SimState, u: np.ndarray, lead: LeaderFrame,
                 fol: FollowerStates) -> np.ndarray:
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
        within ``L / 2`` and on its side.  Returns the followers' commands ``u`` with those of
        the lost followers replaced.
        """
        dt = float(state.dt)
        self._record_trail(lead.x)
        xf, L = fol.x, fol.L
        slots = slot_positions(lead.x, lead.heading, L, fol.phi_d)
        err = np.hypot(*(xf - slots).T)
        wrong = (np.sign(fol.phi) != np.sign(fol.Phi)) & (fol.Phi != 0)
        u = u.copy()
        vmax = np.array([self.problem.robot(k).max_speed for k in fol.ids])
        if len(self._lost) != len(xf):
            self._lost = np.zeros(len(xf), bool)
        for i in range(len(xf)):
            if err[i] <= 0.5 * L[i] and not self._lost[i]:
                continue
            clear = fol.radii[i] + self.o.clear_margin * self.ell
            seen = bool(self._clear_segments(state.field, state.t, xf[i], slots[i:i + 1],
                                             clear)[0])
            if not self._still_lost(i, seen, err[i], L[i], wrong[i]):
                continue
            self.stats["recovery_steps"] += 1
            if seen:
                w = lead.v + self.o.k_f * (slots[i] - xf[i])
            else:
                w = self._along_trail(state, xf[i], L[i], clear, float(vmax[i]), dt)
            sp = float(np.hypot(*w))
            u[i] = w * min(1.0, float(vmax[i]) / sp) if sp > 0 else w
        return u

    def _record_trail(self, xl: np.ndarray) -> None:
        """Append the pilot's position to its recorded path (one point per length unit)."""
        if len(self._trail) == 0 or np.hypot(*(xl - self._trail[-1])) >= self.ell:
            self._trail = np.vstack([self._trail, xl[None, :]])

    def _still_lost(self, i: int, seen: bool, err: float, L: float, wrong: bool) -> bool:
        """Update follower ``i``'s *lost* flag (see :meth:`recovery`) and return it."""
        if self._lost[i]:
            if seen and err <= 0.5 * L and not wrong:
                self._lost[i] = False
        elif wrong or not seen or err > self.o.trail_far * L:
            self._lost[i] = True
            self.stats["lost"] += 1
        return bool(self._lost[i])

    def _along_trail(self, state: SimState, x: np.ndarray, L: float, clear: float,
                     vmax: float, dt: float) -> np.ndarray:
        """Full speed toward the farthest point of the pilot's path in sight within
        ``trail_reach * L`` (the nearest point when none is that close)."""
        T = self._trail
        dd = np.hypot(*(T - x).T)
        cand = np.nonzero(dd <= self.o.trail_reach * L)[0]
        if len(cand) == 0:
            cand = np.array([int(np.argmin(dd))])
        cand = cand[-80:]  # the farthest along the pilot's path
        j = farthest_clear(x, T, lambda p, Q: self._clear_segments(state.field, state.t, p, Q,
                                                                   clear), cand)
        if j is None:
            j = int(cand[0])
        d = T[j] - x
        nd = float(np.hypot(*d))
        return d / nd * min(vmax, nd / dt) if nd > 1e-9 * self.ell else np.zeros(2)

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

