"""Fixed-step time simulation shared by local planners and formation controllers.

Robots are discs moving as single integrators, ``x_{k+1} = x_k + dt * u_k`` with
``|u_k| <= max_speed``.  A *policy* maps the current :class:`SimState` to desired velocities;
the simulator clamps them, moves the robots, advances dynamic obstacles and checks contacts
every step.  Termination: every robot done (goal reached, or the policy says so), a collision,
the policy returning ``None`` (it gave up), a ``StopIteration`` from the callback, or the step
budget.

Sensing.  :class:`ObstacleField` answers, for a position and time, the nearest boundary point
and distance of every obstacle (static polygons, circles, and dynamic obstacles at time t)
within a range.  Distances are to the raw obstacle (not inflated); inside an obstacle the
distance is 0.  A bounding-box pre-filter discards obstacles farther than the range before any
edge-level work, so obstacles outside the sensing range cost one vectorised comparison.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optplan.problem import Problem
from optplan.result import Progress, notify

__all__ = ["ObstacleField", "SimState", "SimOutcome", "simulate"]


def _edges_of(poly) -> np.ndarray:
    rings = [poly.exterior, *poly.interiors]
    out = []
    for r in rings:
        c = np.asarray(r.coords)
        out.append(np.hstack([c[:-1], c[1:]]))
    return np.vstack(out)


class ObstacleField:
    """Nearest-point queries against a problem's static and dynamic obstacles.

    Parameters
    ----------
    problem : Problem
    include_temporary : bool
        Include temporary (``known = false``) static obstacles (local planners see them).
    include_dynamic : bool
        Include dynamic obstacles.

    Obstacle indices: ``0 .. n_static-1`` static (problem order, filtered), then dynamic.
    """

    def __init__(self, problem: Problem, include_temporary: bool = True,
                 include_dynamic: bool = True):
        self.problem = problem
        self.static = [o for o in problem.obstacles if o.known or include_temporary]
        self.dynamic = list(problem.dynamic_obstacles) if include_dynamic else []
        self.names = [o.name for o in self.static] + [d.name for d in self.dynamic]
        self.n_static = len(self.static)
        self.n = len(self.names)
        # each obstacle as: circle (centre, radius) or padded polygon edges, in its own frame
        kinds, centers, radii, edge_list = [], [], [], []
        for o in self.static:
            if o.is_circle:
                kinds.append(0)
                centers.append(o.center)
                radii.append(o.radius)
                edge_list.append(np.zeros((0, 4)))
            else:
                kinds.append(1)
                centers.append(np.zeros(2))
                radii.append(0.0)
                edge_list.append(_edges_of(o.geometry))
        for d in self.dynamic:
            if d.kind == "circle":
                kinds.append(0)
                centers.append(np.zeros(2))
                radii.append(d.radius)
                edge_list.append(np.zeros((0, 4)))
            else:
                kinds.append(1)
                centers.append(np.zeros(2))
                radii.append(0.0)
                edge_list.append(_edges_of(d.local_geometry))
        self.is_circle = np.array(kinds, dtype=int) == 0
        self.center0 = np.array(centers, dtype=float).reshape(-1, 2)
        self.radius = np.array(radii, dtype=float)
        e_max = max([len(e) for e in edge_list] + [1])
        self.edges = np.zeros((self.n, e_max, 4))
        self.edge_mask = np.zeros((self.n, e_max), bool)
        for i, e in enumerate(edge_list):
            self.edges[i, : len(e)] = e
            self.edge_mask[i, : len(e)] = True
        # local-frame bounding boxes
        bb = np.zeros((self.n, 4))
        for i in range(self.n):
            if self.is_circle[i]:
                c, r = self.center0[i], self.radius[i]
                bb[i] = [c[0] - r, c[1] - r, c[0] + r, c[1] + r]
            else:
                e = edge_list[i]
                bb[i] = [e[:, [0, 2]].min(), e[:, [1, 3]].min(), e[:, [0, 2]].max(),
                         e[:, [1, 3]].max()]
        self.bbox0 = bb
        self._off_t: float | None = None
        self._off = np.zeros((self.n, 2))

    def offsets(self, t: float) -> np.ndarray:
        """Translation of every obstacle at time ``t``, shape ``(n, 2)`` (zero for static).

        The last query is cached: controllers and the simulator ask several times per step.
        """
        t = float(t)
        if self._off_t == t:
            return self._off
        off = np.zeros((self.n, 2))
        for k, d in enumerate(self.dynamic):
            off[self.n_static + k] = d.position(t)
        off.setflags(write=False)
        self._off_t, self._off = t, off
        return off

    def nearest(self, points: np.ndarray, t: float = 0.0,
                max_range: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """Nearest boundary points and distances for every (point, obstacle) pair.

        Parameters
        ----------
        points : array, shape ``(R, 2)`` or ``(2,)``
        t : float
            Time (positions of dynamic obstacles).
        max_range : float
            Obstacles whose bounding box is farther than this are skipped (distance ``inf``).

        Returns
        -------
        nearest : array ``(R, n, 2)``
            Nearest boundary point (``nan`` where skipped).
        dist : array ``(R, n)``
            Distance to the obstacle (0 inside, ``inf`` where skipped).
        """
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        R = len(pts)
        near = np.full((R, self.n, 2), np.nan)
        dist = np.full((R, self.n), np.inf)
        if self.n == 0:
            return near, dist
        off = self.offsets(t)
        rel = pts[:, None, :] - off[None, :, :]  # point in each obstacle's frame, (R, n, 2)
        bb = self.bbox0
        dx = np.maximum(np.maximum(bb[None, :, 0] - rel[..., 0], rel[..., 0] - bb[None, :, 2]), 0)
        dy = np.maximum(np.maximum(bb[None, :, 1] - rel[..., 1], rel[..., 1] - bb[None, :, 3]), 0)
        cand = np.hypot(dx, dy) <= max_range
        # circles
        ci = cand & self.is_circle[None, :]
        if ci.any():
            r_idx, o_idx = np.nonzero(ci)
            v = rel[r_idx, o_idx] - self.center0[o_idx]
            nv = np.hypot(v[:, 0], v[:, 1])
            safe = np.where(nv > 1e-12, nv, 1.0)
            u = np.where(nv[:, None] > 1e-12, v / safe[:, None], np.array([1.0, 0.0]))
            near[r_idx, o_idx] = self.center0[o_idx] + u * self.radius[o_idx, None] + off[o_idx]
            dist[r_idx, o_idx] = np.maximum(nv - self.radius[o_idx], 0.0)
        # polygons: project onto every edge, keep the closest; inside -> distance 0
        pi_ = cand & ~self.is_circle[None, :]
        if pi_.any():
            r_idx, o_idx = np.nonzero(pi_)
            q = rel[r_idx, o_idx][:, None, :]  # (K, 1, 2)
            E = self.edges[o_idx]  # (K, E, 4)
            a, b = E[..., 0:2], E[..., 2:4]
            ab = b - a
            L2 = np.sum(ab * ab, axis=-1)
            s = np.clip(np.sum((q - a) * ab, axis=-1) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
            proj = a + s[..., None] * ab
            d2 = np.sum((q - proj) ** 2, axis=-1)
            d2 = np.where(self.edge_mask[o_idx], d2, np.inf)
            k = np.argmin(d2, axis=1)
            best = proj[np.arange(len(k)), k]
            dd = np.sqrt(d2[np.arange(len(k)), k])
            # inside test (crossing number with a +x ray)
            y = q[..., 1]
            straddle = ((a[..., 1] > y) != (b[..., 1] > y)) & self.edge_mask[o_idx]
            with np.errstate(divide="ignore", invalid="ignore"):
                xc = a[..., 0] + (y - a[..., 1]) * ab[..., 0] / np.where(ab[..., 1] == 0, 1,
                                                                         ab[..., 1])
            inside = (np.sum(straddle & (xc > q[..., 0]), axis=1) % 2) == 1
            near[r_idx, o_idx] = best + off[o_idx]
            dist[r_idx, o_idx] = np.where(inside, 0.0, dd)
        return near, dist


@dataclass
class SimState:
    """What a policy sees at step ``k`` (time ``t``)."""

    k: int
    t: float
    ids: list[str]
    positions: np.ndarray  # (R, 2)
    velocities: np.ndarray  # (R, 2) commanded at the previous step
    field: ObstacleField
    memory: dict[str, Any] = field(default_factory=dict)


@dataclass
class SimOutcome:
    """Trajectories and why the run stopped."""

    times: np.ndarray  # (T,)
    positions: np.ndarray  # (T, R, 2)
    ids: list[str]
    reason: str  # 'done', 'collision', 'budget', 'gave_up', 'callback'
    collision: str = ""
    steps: int = 0
    memory: dict[str, Any] = field(default_factory=dict)

    def paths(self) -> dict[str, np.ndarray]:
        return {rid: self.positions[:, i, :].copy() for i, rid in enumerate(self.ids)}


def simulate(
    problem: Problem,
    policy: Callable[[SimState], np.ndarray | None],
    *,
    ids: list[str],
    dt: float,
    max_steps: int,
    done: Callable[[SimState], bool],
    field_: ObstacleField | None = None,
    start: np.ndarray | None = None,
    t0: float = 0.0,
    stop_on_collision: bool = True,
    callback: Callable[[Progress], Any] | None = None,
    progress_cost: Callable[[SimState], float] | None = None,
    memory: dict[str, Any] | None = None,
) -> SimOutcome:
    """Run ``policy`` from the robots' starts until ``done``, a collision, or the budget.

    Parameters
    ----------
    problem : Problem
    policy : callable
        ``policy(state) -> (R, 2)`` desired velocities, or ``None`` to give up.
    ids : list of str
        Robots simulated (in this order).
    dt : float
        Time step (s).
    max_steps : int
        Step budget.
    done : callable
        ``done(state) -> bool``; checked before every step.
    field_ : ObstacleField, optional
        Obstacles used for contact checks (default: everything, temporary and dynamic).
    start : array, optional
        Initial positions ``(R, 2)`` (default: the robots' starts).
    stop_on_collision : bool
        Stop at the first contact (robot disc overlapping an obstacle or another robot).
    callback : callable, optional
        Receives a :class:`~optplan.result.Progress` each step; ``StopIteration`` stops.
    progress_cost : callable, optional
        Scalar reported as ``best_cost`` to the callback (e.g. distance to goal).
    """
    fld = field_ or ObstacleField(problem)
    robots = [problem.robot(i) for i in ids]
    radii = np.array([r.radius for r in robots])
    vmax = np.array([r.max_speed for r in robots])
    pos = np.array([r.start for r in robots], dtype=float) if start is None else np.array(
        start, dtype=float)
    state = SimState(0, t0, list(ids), pos.copy(), np.zeros_like(pos), fld, memory or {})
    times = [t0]
    traj = [pos.copy()]
    reason, coll = "budget", ""
    tol = 1e-9 * max(1.0, problem.extent)
    for k in range(max_steps):
        state.k, state.t = k, t0 + k * dt
        if done(state):
            reason = "done"
            break
        u = policy(state)
        if u is None:
            reason = "gave_up"
            break
        u = np.asarray(u, dtype=float).reshape(pos.shape)
        sp = np.hypot(u[:, 0], u[:, 1])
        scale = np.where(sp > vmax, vmax / np.where(sp > 0, sp, 1.0), 1.0)
        u = u * scale[:, None]
        pos = pos + dt * u
        state.positions, state.velocities = pos.copy(), u
        t_new = t0 + (k + 1) * dt
        times.append(t_new)
        traj.append(pos.copy())
        _, d = fld.nearest(pos, t_new, max_range=float(radii.max()) + 1.0)
        hit = d < radii[:, None] - tol
        if len(ids) > 1:
            diff = pos[:, None, :] - pos[None, :, :]
            dd = np.hypot(diff[..., 0], diff[..., 1])
            np.fill_diagonal(dd, np.inf)
            rr = radii[:, None] + radii[None, :]
            pair_hit = dd < rr - tol
        else:
            pair_hit = np.zeros((1, 1), bool)
        if hit.any() or pair_hit.any():
            if hit.any():
                ri, oi = np.argwhere(hit)[0]
                coll = f"{ids[ri]} touched {fld.names[oi]} at t={t_new:.2f}"
            else:
                ri, rj = np.argwhere(pair_hit)[0]
                coll = f"{ids[ri]} touched {ids[rj]} at t={t_new:.2f}"
            state.memory.setdefault("contacts", []).append(coll)
            if stop_on_collision:
                reason = "collision"
                break
        cost = progress_cost(state) if progress_cost else float("nan")
        if notify(callback, Progress(k, cost, k + 1, t_new - t0, {})):
            reason = "callback"
            break
    else:
        state.t = t0 + max_steps * dt
        if done(state):
            reason = "done"
    return SimOutcome(np.array(times), np.array(traj), list(ids), reason, coll,
                      len(times) - 1, state.memory)
