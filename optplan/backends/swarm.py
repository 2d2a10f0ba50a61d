"""Shared machinery of the swarm path planners ``pso``, ``mpso`` and ``ipso`` (paper §III).

Encoding
    A particle is the ``D = 2 n`` coordinates of ``n`` intermediate waypoints, interleaved
    ``[x_1, y_1, x_2, y_2, ..., x_n, y_n]``; the path is ``start -> p_1 -> ... -> p_n -> goal``
    (domain-notes §1.2, Cartesian encoding).  ``n`` is the option ``n_waypoints``.

Fitness (eqs 31-33)
    ``fit = f_1 + f_2`` with ``f_1`` the polyline length (eq 31) and
    ``f_2 = penalty_weight * sum_i alpha_i`` (eq 32), ``alpha_i`` the number of inflated
    obstacles whose *interior* segment ``i`` enters (touching is not a collision).  Beyond the
    paper, ``penetration_weight * (length of path inside obstacles)`` can be added: it gives
    the swarm a gradient out of obstacles (the count alone is a flat landscape).

    **Default penalty weight** ``(n + 1) * diag`` (``diag`` = diagonal of the map bounds).
    Every waypoint stays inside the bounds (bounds handling below), so each of the ``n + 1``
    segments is at most ``diag`` long and any collision-free particle costs at most
    ``(n + 1) * diag``; a colliding one costs at least ``|goal - start| + penalty_weight``
    ``> (n + 1) * diag``.  Hence every collision-free path beats every colliding path: the
    fitness is lexicographic (feasibility first, then length) and gbest can never be a
    colliding shortcut while a feasible particle exists.

    The whole swarm is scored with one call of the crossing test per evaluation:
    ``kernel = "geometry"`` calls :func:`optplan.geometry.batch_crossings`; ``kernel = "fast"``
    (default) calls :func:`fast_crossings`, a private re-formulation of the same test (same
    counts and penetration lengths; twin-tested) that is ~10x faster on small swarms, see its
    docstring.

Bounds handling (option ``bounds_mode``)
    ``"reflect"`` (default): a coordinate beyond a bound is mirrored back into the map and the
    velocity component is reversed; ``"clip"``: put on the bound, velocity component zeroed;
    ``"random"``: the coordinate is re-drawn uniformly in the bounds, velocity zeroed.
    (pyswarms' stuck-particle reports, domain-notes §1.2.)

Initialisation (option ``init_mode``)
    ``"uniform"``: waypoints uniform in the map; ``"sorted"`` (default): uniform, then ordered
    along the start->goal direction (no initial back-tracking zig-zags); ``"line"``: on the
    straight line plus Gaussian noise of ``0.1 * diag``; ``"roadmap"`` (beyond the paper):
    ``"sorted"`` plus a few particles seeded with collision-free paths from small random
    roadmaps (:func:`roadmap_paths`).  An ``init`` path (from an earlier
    stage) seeds particle 0 (:func:`resample_path`: exact when it has at most ``n`` bends).

Convergence bookkeeping
    The "optimal number of iterations" of the paper's Tables 2-3 is defined here as the first
    iteration whose best fitness is within 0.1 % of the final best (:func:`converged_iteration`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.geometry import InflatedMap, batch_crossings, inflate
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status, notify
from optplan.solver import Backend, check_choice, check_int, check_range

__all__ = [
    "CrossingKernel",
    "SwarmSpace",
    "SwarmEval",
    "SwarmState",
    "SwarmBackend",
    "make_kernel",
    "fast_crossings",
    "make_space",
    "default_penalty",
    "decode",
    "evaluate_swarm",
    "handle_bounds",
    "clamp_velocity",
    "initial_swarm",
    "resample_path",
    "converged_iteration",
]

BOUNDS_MODES = ("reflect", "clip", "random")
INIT_MODES = ("sorted", "uniform", "line", "roadmap")
KERNELS = ("fast", "geometry")
#: Relative tolerance of the "improved by" tests on fitness values.
_EPS = 1e-12


# --------------------------------------------------------------------------------------
# fast crossing kernel
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CrossingKernel:
    """Edge arrays of an :class:`~optplan.geometry.InflatedMap` laid out for :func:`fast_crossings`.

    ``vp``/``vq``: ``(3, Ne)`` rows ``(y, x, 1)`` of every boundary edge's start/end point, so
    that the side of all edges' endpoints w.r.t. all segment lines is one matrix product.
    ``px, py, qx, qy``: ``(Np, Emax)`` padded per-part copies (padding = degenerate edges that
    never straddle) for the bounding-box path used with many obstacles.
    """

    imap: InflatedMap
    vp: np.ndarray
    vq: np.ndarray
    part: np.ndarray
    offset: np.ndarray
    pad: np.ndarray
    bbox: np.ndarray
    scale: float
    _scratch: dict = field(default_factory=dict, repr=False)

    def buffer(self, name: str, shape: tuple[int, ...], dtype: Any = float) -> np.ndarray:
        """A reusable scratch array (large temporaries are otherwise re-mapped by the OS
        allocator on every call, which costs more than the arithmetic)."""
        buf = self._scratch.get(name)
        size = int(np.prod(shape))
        if buf is None or buf.size < size or buf.dtype != np.dtype(dtype):
            buf = np.empty(max(size, 1), dtype=dtype)
            self._scratch[name] = buf
        return buf[:size].reshape(shape)

    @property
    def n_parts(self) -> int:
        return self.imap.n

    @property
    def n_edges(self) -> int:
        return self.vp.shape[1]


def make_kernel(imap: InflatedMap) -> CrossingKernel:
    """Precompute the edge layout of ``imap`` for :func:`fast_crossings`."""
    e = imap.edges[imap.edge_mask]  # (Ne, 4) in part order
    counts = imap.edge_mask.sum(axis=1)
    part = np.repeat(np.arange(imap.n), counts)
    ones = np.ones(len(e))
    vp = np.stack([e[:, 1], e[:, 0], ones]) if len(e) else np.zeros((3, 0))
    vq = np.stack([e[:, 3], e[:, 2], ones]) if len(e) else np.zeros((3, 0))
    pad = imap.edges.copy()
    if imap.n:
        first = imap.edges[:, 0, :2]
        fill = np.concatenate([first, first], axis=1)[:, None, :]
        pad = np.where(imap.edge_mask[..., None], pad, fill)
    offset = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    bb = imap.bbox
    scale = max(1.0, float(np.max(np.abs(bb)))) if bb.size else 1.0
    return CrossingKernel(imap, np.ascontiguousarray(vp), np.ascontiguousarray(vq), part,
                          offset, pad, bb, scale)


def _straddles(sp: np.ndarray, sq: np.ndarray, kern: CrossingKernel,
               shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Edges straddling the line with an on-line vertex counted as '+' (ge) or '-' (gt)."""
    b1 = np.greater_equal(sp, 0.0, out=kern.buffer("b1", shape, bool))
    b2 = np.greater_equal(sq, 0.0, out=kern.buffer("b2", shape, bool))
    ge = np.not_equal(b1, b2, out=kern.buffer("ge", shape, bool))
    np.greater(sp, 0.0, out=b1)
    np.greater(sq, 0.0, out=b2)
    gt = np.not_equal(b1, b2, out=kern.buffer("gt", shape, bool))
    return ge, gt


def fast_crossings(paths: np.ndarray, kern: CrossingKernel,
                   tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Interior-crossing count and penetration length, as :func:`optplan.geometry.batch_crossings`.

    Same maths (signed crossing sum along each segment's line; see ``optplan.geometry``), with
    the work arranged for small swarms:

    1. The side ``s = cross(D, v - A)`` of every edge endpoint ``v`` w.r.t. every segment line
       is an affine function of ``v``, so all of them are two matrix products
       ``(S, 3) @ (3, Ne)``.  With many obstacles (``S * Ne`` large) the candidate
       (segment, part) pairs are first pre-filtered by bounding boxes instead.
    2. Only the straddling (segment, edge) pairs (``np.nonzero``; typically ~2 per segment and
       obstacle whose *line* crosses it) get the crossing parameter ``t`` and the sign, and the
       per-(segment, part) inside fraction is a ``bincount``.

    Parameters
    ----------
    paths : array ``(P, M, 2)``
    kern : CrossingKernel
    tol : float
        As in ``batch_crossings``: a pair collides when its inside length exceeds
        ``tol * max(1, map scale)``.

    Returns
    -------
    count : (P,) int
        Number of (segment, part) pairs entering a part's interior.
    penetration : (P,) float
        Total length inside interiors.
    """
    pts = np.asarray(paths, dtype=float)
    P, M, _ = pts.shape
    S = M - 1
    Np = kern.n_parts
    if Np == 0 or S <= 0:
        return np.zeros(P, dtype=np.int64), np.zeros(P)
    a = pts[:, :-1, :].reshape(-1, 2)
    d = (pts[:, 1:, :] - pts[:, :-1, :]).reshape(-1, 2)
    n_seg = a.shape[0]
    c = d[:, 0] * a[:, 1] - d[:, 1] * a[:, 0]
    if n_seg * kern.n_edges <= 200_000:
        lin = np.stack([d[:, 0], -d[:, 1], -c], axis=1)
        shape = (n_seg, kern.n_edges)
        sp_all = np.matmul(lin, kern.vp, out=kern.buffer("sp", shape))
        sq_all = np.matmul(lin, kern.vq, out=kern.buffer("sq", shape))
        ge, gt = _straddles(sp_all, sq_all, kern, shape)
        flat = np.flatnonzero(np.logical_or(ge, gt, out=kern.buffer("any", shape, bool)))
        si, ei = np.divmod(flat, kern.n_edges)
        use_ge, use_gt = ge.reshape(-1)[flat], gt.reshape(-1)[flat]
        sp = sp_all.reshape(-1)[flat]
        sq = sq_all.reshape(-1)[flat]
        e_p = kern.vp[:2, ei]  # rows (y, x)
        e_q = kern.vq[:2, ei]
        part = kern.part[ei]
    else:
        b = a + d
        lo = np.minimum(a, b)
        hi = np.maximum(a, b)
        bb = kern.bbox
        pi, oi = np.nonzero(
            (lo[:, None, 0] <= bb[None, :, 2]) & (hi[:, None, 0] >= bb[None, :, 0])
            & (lo[:, None, 1] <= bb[None, :, 3]) & (hi[:, None, 1] >= bb[None, :, 1]))
        if pi.size == 0:
            return np.zeros(P, dtype=np.int64), np.zeros(P)
        E = kern.pad[oi]  # (K, Emax, 4) as (px, py, qx, qy)
        dx, dy, cc = d[pi, 0:1], d[pi, 1:2], c[pi, None]
        sp_all = dx * E[..., 1] - dy * E[..., 0] - cc
        sq_all = dx * E[..., 3] - dy * E[..., 2] - cc
        ge = (sp_all >= 0) != (sq_all >= 0)
        gt = (sp_all > 0) != (sq_all > 0)
        flat = np.flatnonzero(ge | gt)
        use_ge, use_gt = ge.reshape(-1)[flat], gt.reshape(-1)[flat]
        ki, li = np.divmod(flat, E.shape[1])
        sp = sp_all.reshape(-1)[flat]
        sq = sq_all.reshape(-1)[flat]
        ee = E.reshape(-1, 4)[flat]
        e_p = np.stack([ee[:, 1], ee[:, 0]])
        e_q = np.stack([ee[:, 3], ee[:, 2]])
        si = pi[ki]
        part = oi[ki]
    if si.size == 0:
        return np.zeros(P, dtype=np.int64), np.zeros(P)
    lam = sp / (sp - sq)
    xy = e_p + lam * (e_q - e_p)  # rows (y, x) of the crossing point
    ds = d[si]
    dd = ds[:, 0] * ds[:, 0] + ds[:, 1] * ds[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((xy[1] - a[si, 0]) * ds[:, 0] + (xy[0] - a[si, 1]) * ds[:, 1]) / dd
    t = np.where(dd > 0, t, 1.0)
    # entering (sign +1) when cross(D, edge) = sq - sp < 0
    contrib = np.where(sq < sp, 1.0, -1.0) * np.clip(1.0 - t, 0.0, 1.0)
    # a vertex exactly on the line is put on one side or the other (>= / > tests); as in
    # batch_crossings keep the smaller inside length of the two infinitesimal shifts, so a
    # segment running along or grazing a boundary is not a collision
    key = si * Np + part
    f_ge = np.bincount(key, weights=np.where(use_ge, contrib, 0.0), minlength=n_seg * Np)
    f_gt = np.bincount(key, weights=np.where(use_gt, contrib, 0.0), minlength=n_seg * Np)
    frac = np.minimum(f_ge, f_gt)
    seglen = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])
    inside = np.clip(frac.reshape(n_seg, Np), 0.0, 1.0) * seglen[:, None]
    hit = inside > tol * kern.scale
    count = hit.reshape(P, -1).sum(axis=1)
    pen = np.where(hit, inside, 0.0).reshape(P, -1).sum(axis=1)
    return count, pen


# --------------------------------------------------------------------------------------
# search space, fitness
# --------------------------------------------------------------------------------------


def default_penalty(bounds: tuple[float, float, float, float], n_waypoints: int) -> float:
    """``(n + 1) * diag``: makes every collision-free path beat every colliding one.

    With all waypoints inside the bounds a feasible path is at most ``(n + 1) * diag`` long,
    while a colliding one costs at least ``|goal - start| + penalty``.
    """
    x0, y0, x1, y1 = bounds
    return float((n_waypoints + 1) * math.hypot(x1 - x0, y1 - y0))


@dataclass(frozen=True, eq=False)
class SwarmSpace:
    """The search space of one robot: endpoints, box bounds per dimension, the fitness map."""

    start: np.ndarray
    goal: np.ndarray
    n_waypoints: int
    lo: np.ndarray
    hi: np.ndarray
    imap: InflatedMap
    kernel: CrossingKernel | None
    penalty_weight: float
    penetration_weight: float = 0.0

    @property
    def dim(self) -> int:
        return 2 * self.n_waypoints

    @property
    def span(self) -> np.ndarray:
        return self.hi - self.lo

    @property
    def diag(self) -> float:
        return float(math.hypot(*(self.hi[:2] - self.lo[:2])))


def make_space(problem: Problem, robot: Robot, n_waypoints: int, *,
               penalty_weight: float | None = None, penetration_weight: float = 0.0,
               kernel: str = "fast", map_quad_segs: int | None = None) -> SwarmSpace:
    """Build the :class:`SwarmSpace` of ``robot`` on the map ``problem`` (pass a known view).

    ``map_quad_segs = None`` plans on exactly the validator's map (inscribed round buffer);
    an integer plans on a coarser *circumscribed* buffer with that many segments per quarter
    circle, which contains the validator's map (so anything collision-free for the planner is
    collision-free for the validator) at the price of up to ``r (1/cos(pi/(4 q)) - 1)`` extra
    clearance at corners.
    """
    if map_quad_segs is None:
        imap = problem.inflated(robot.radius, known_only=True)
    else:
        key = ("swarm-coarse-map", round(float(robot.radius), 12), int(map_quad_segs))
        if key not in problem._cache:
            problem._cache[key] = inflate(problem.static_obstacles(known_only=True),
                                          robot.radius, mode="circumscribed",
                                          quad_segs=int(map_quad_segs))
        imap = problem._cache[key]
    x0, y0, x1, y1 = problem.bounds
    lo = np.tile([x0, y0], n_waypoints).astype(float)
    hi = np.tile([x1, y1], n_waypoints).astype(float)
    kern = None
    if kernel == "fast":
        key = ("swarm-kernel", id(imap))
        if key not in problem._cache:
            problem._cache[key] = (imap, make_kernel(imap))
        kern = problem._cache[key][1]
    pw = default_penalty(problem.bounds, n_waypoints) if penalty_weight is None else penalty_weight
    return SwarmSpace(np.asarray(robot.start, float), np.asarray(robot.goal, float),
                      n_waypoints, lo, hi, imap, kern, float(pw), float(penetration_weight))


def decode(X: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Particles ``(P, 2n)`` -> polylines ``(P, n + 2, 2)`` (start, waypoints, goal)."""
    P = X.shape[0]
    out = np.empty((P, space.n_waypoints + 2, 2))
    out[:, 0] = space.start
    out[:, 1:-1] = X.reshape(P, space.n_waypoints, 2)
    out[:, -1] = space.goal
    return out


@dataclass(frozen=True)
class SwarmEval:
    """Fitness of a batch of particles: ``cost = length + penalty*count + pen_w*penetration``."""

    cost: np.ndarray
    length: np.ndarray
    count: np.ndarray
    penetration: np.ndarray

    def take(self, idx: Any) -> SwarmEval:
        """The rows ``idx`` (slice, index array or mask)."""
        return SwarmEval(self.cost[idx], self.length[idx], self.count[idx],
                         self.penetration[idx])


def evaluate_swarm(X: np.ndarray, space: SwarmSpace) -> SwarmEval:
    """Eqs 31-33 for a whole batch: one crossing-test call for all particles."""
    paths = decode(X, space)
    d = np.diff(paths, axis=1)
    length = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2).sum(axis=1)
    if space.kernel is not None:
        count, pen = fast_crossings(paths, space.kernel)
    else:
        cr = batch_crossings(paths, space.imap)
        count, pen = cr.count, cr.penetration
    cost = length + space.penalty_weight * count
    if space.penetration_weight:
        cost = cost + space.penetration_weight * pen
    return SwarmEval(cost, length, count, pen)


# --------------------------------------------------------------------------------------
# particle operations
# --------------------------------------------------------------------------------------


def handle_bounds(X: np.ndarray, V: np.ndarray, lo: np.ndarray, hi: np.ndarray, mode: str,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Bring positions back into ``[lo, hi]`` per dimension (modes: module docstring)."""
    out = (X < lo) | (X > hi)
    if not out.any():
        return X, V
    span = hi - lo
    if mode == "reflect":
        # mirror at the walls (repeatedly for far-out values): triangle wave of period 2 span
        u = np.mod(X - lo, 2 * span)
        Xn = lo + np.where(u > span, 2 * span - u, u)
        Vn = np.where(out, -V, V)
    elif mode == "clip":
        Xn = np.clip(X, lo, hi)
        Vn = np.where(out, 0.0, V)
    else:  # random
        fresh = lo + span * rng.random(X.shape)
        Xn = np.where(out, fresh, X)
        Vn = np.where(out, 0.0, V)
    return Xn, Vn


def clamp_velocity(V: np.ndarray, vmax: np.ndarray | None) -> np.ndarray:
    """Clip each velocity component to ``[-vmax, vmax]`` (``None``: no clamp)."""
    return V if vmax is None else np.clip(V, -vmax, vmax)


def initial_swarm(space: SwarmSpace, n_particles: int, mode: str,
                  rng: np.random.Generator) -> np.ndarray:
    """Initial positions ``(n_particles, 2n)`` (modes: module docstring)."""
    n, D = space.n_waypoints, space.dim
    if mode == "line":
        frac = np.arange(1, n + 1) / (n + 1)
        base = (space.start[None, :] + frac[:, None] * (space.goal - space.start)[None, :])
        X = base.reshape(-1)[None, :] + 0.1 * space.diag * rng.standard_normal((n_particles, D))
        X = np.clip(X, space.lo, space.hi)
    else:
        X = space.lo + space.span * rng.random((n_particles, D))
        if mode == "sorted" and n > 1:
            W = X.reshape(n_particles, n, 2)
            axis = space.goal - space.start
            proj = (W - space.start) @ axis
            order = np.argsort(proj, axis=1, kind="stable")
            X = np.take_along_axis(W, order[..., None], axis=1).reshape(n_particles, D)
    return X


def resample_path(path: np.ndarray, n: int) -> np.ndarray:
    """``n`` waypoints describing a polyline, shape ``(n, 2)`` (start and goal excluded).

    With at most ``n`` interior vertices the polyline is reproduced exactly: its vertices are
    kept and the longest segments are split at their midpoints until there are ``n``.  With
    more, ``n`` points evenly spaced by arc length approximate it.
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    inner = p[1:-1]
    if len(p) >= 2 and len(inner) <= n:
        pts = list(p)
        while len(pts) - 2 < n:
            q = np.asarray(pts)
            seg = np.hypot(*np.diff(q, axis=0).T)
            j = int(np.argmax(seg))
            pts.insert(j + 1, 0.5 * (q[j] + q[j + 1]))
        return np.asarray(pts[1:-1])
    seg = np.hypot(*np.diff(p, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 0:
        return np.repeat(p[:1], n, axis=0)
    q = s[-1] * np.arange(1, n + 1) / (n + 1)
    return np.stack([np.interp(q, s, p[:, 0]), np.interp(q, s, p[:, 1])], axis=1)


def segment_free(a: np.ndarray, b: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Collision-free flags of segments ``a[i] -> b[i]`` (one crossing-test call)."""
    segs = np.stack([a, b], axis=1)
    if len(segs) == 0:
        return np.zeros(0, dtype=bool)
    if space.kernel is not None:
        count, _ = fast_crossings(segs, space.kernel)
    else:
        count = batch_crossings(segs, space.imap).count
    return count == 0


def shortcut(path: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Greedy string pulling: from each kept vertex jump to the farthest visible later vertex."""
    p = np.asarray(path, dtype=float)
    m = len(p)
    if m <= 2:
        return p
    i, j = np.triu_indices(m, 1)
    free = np.zeros((m, m), dtype=bool)
    free[i, j] = segment_free(p[i], p[j], space)
    out = [0]
    while out[-1] != m - 1:
        cur = out[-1]
        vis = np.flatnonzero(free[cur, cur + 1:]) + cur + 1
        out.append(int(vis.max()) if vis.size else cur + 1)
    return p[out]


def roadmap_paths(space: SwarmSpace, n_paths: int, rng: np.random.Generator,
                  n_samples: int = 60) -> list[np.ndarray]:
    """Collision-free start-goal paths from small random roadmaps (beyond the paper).

    Each roadmap: ``n_samples`` uniform points plus start and goal, every pair connected when
    the segment is collision-free (one crossing-test call for all pairs), Dijkstra, then
    :func:`shortcut`.  Used by ``init_mode = "roadmap"`` to seed particles in (usually) the
    right homotopy class; a roadmap that does not connect gives no path.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    out = []
    for _ in range(n_paths):
        pts = space.lo[:2] + (space.hi[:2] - space.lo[:2]) * rng.random((n_samples, 2))
        nodes = np.vstack([space.start, space.goal, pts])
        i, j = np.triu_indices(len(nodes), 1)
        ok = segment_free(nodes[i], nodes[j], space)
        i, j = i[ok], j[ok]
        w = np.hypot(*(nodes[i] - nodes[j]).T)
        n = len(nodes)
        g = csr_matrix((np.r_[w, w], (np.r_[i, j], np.r_[j, i])), shape=(n, n))
        dist, pred = dijkstra(g, directed=False, indices=0, return_predecessors=True)
        if not np.isfinite(dist[1]):
            continue
        order = [1]
        while order[-1] != 0:
            order.append(int(pred[order[-1]]))
        out.append(shortcut(nodes[order[::-1]], space))
    return out


def snap_targets(imap: InflatedMap, push: float) -> np.ndarray:
    """Convex vertices of the inflated map pushed outward by ``push`` along their bisector.

    Shortest paths among polygons bend only at convex obstacle vertices (de Berg et al.,
    Lemma 15.1); a waypoint snapped to a slightly pushed-out vertex makes the path hug that
    corner without touching it (touching paths are fragile for floating-point tests).
    """
    out = []
    for part in imap.parts:
        for ring in (part.exterior, *part.interiors):
            c = np.asarray(ring.coords)[:-1]
            if len(c) < 3:
                continue
            prev, nxt = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
            a, b = c - prev, nxt - c
            cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
            keep = cross > 1e-12
            na = np.stack([a[:, 1], -a[:, 0]], 1)  # outward normals (solid on the left)
            nb = np.stack([b[:, 1], -b[:, 0]], 1)
            na /= np.maximum(np.hypot(*na.T), 1e-300)[:, None]
            nb /= np.maximum(np.hypot(*nb.T), 1e-300)[:, None]
            bis = na + nb
            bis /= np.maximum(np.hypot(*bis.T), 1e-300)[:, None]
            out.append((c + push * bis)[keep])
    return np.concatenate(out) if out else np.zeros((0, 2))


def converged_iteration(best: np.ndarray, rel: float = 1e-3) -> int:
    """First iteration whose best is within ``rel`` (0.1 %) of the final best.

    ``best`` is the per-iteration best fitness (index = iteration, 0 = initial swarm).
    """
    b = np.asarray(best, dtype=float)
    if b.size == 0:
        return 0
    final = b[-1]
    ok = b <= final + rel * abs(final)
    return int(np.argmax(ok))


# --------------------------------------------------------------------------------------
# state and the shared driver
# --------------------------------------------------------------------------------------


@dataclass(eq=False)
class SwarmState:
    """Mutable state of one swarm run (positions, velocities, memories, bookkeeping)."""

    X: np.ndarray
    V: np.ndarray
    F: np.ndarray
    pbest: np.ndarray
    pbest_f: np.ndarray
    gbest: np.ndarray
    gbest_f: float
    gbest_len: float
    gbest_count: int
    feas_len: float = math.inf
    feas_x: np.ndarray | None = None
    n_eval: int = 0
    stats: dict = field(default_factory=dict)

    def absorb(self, X: np.ndarray, ev: SwarmEval, slots: np.ndarray | None = None) -> None:
        """Take evaluated positions ``X`` (into ``slots``, default all) and update memories."""
        idx = np.arange(len(self.F)) if slots is None else slots
        self.X[idx] = X
        self.F[idx] = ev.cost
        better = ev.cost < self.pbest_f[idx]
        if better.any():
            b = idx[better]
            self.pbest[b] = X[better]
            self.pbest_f[b] = ev.cost[better]
        self.offer(X, ev)

    def offer(self, X: np.ndarray, ev: SwarmEval) -> None:
        """Update gbest and the feasible best with candidate positions (no slot changes)."""
        j = int(np.argmin(ev.cost))
        if ev.cost[j] < self.gbest_f:
            self.gbest = X[j].copy()
            self.gbest_f = float(ev.cost[j])
            self.gbest_len = float(ev.length[j])
            self.gbest_count = int(ev.count[j])
        feas = ev.count == 0
        if feas.any():
            lens = np.where(feas, ev.length, np.inf)
            k = int(np.argmin(lens))
            if lens[k] < self.feas_len:
                self.feas_len = float(lens[k])
                self.feas_x = X[k].copy()


def new_state(X: np.ndarray, V: np.ndarray, ev: SwarmEval) -> SwarmState:
    j = int(np.argmin(ev.cost))
    st = SwarmState(X=X.copy(), V=V.copy(), F=ev.cost.copy(), pbest=X.copy(),
                    pbest_f=ev.cost.copy(), gbest=X[j].copy(), gbest_f=float(ev.cost[j]),
                    gbest_len=float(ev.length[j]), gbest_count=int(ev.count[j]),
                    n_eval=len(X))
    st.offer(X, ev)
    return st


@dataclass(frozen=True, kw_only=True)
class SwarmBackend(Backend):
    """Options shared by ``pso``, ``mpso`` and ``ipso`` (see the subclasses for the rest).

    Parameters
    ----------
    n_particles : int
        Swarm size (paper §VI.A: n = 50).
    k_max : int
        Number of iterations (paper: k_max = 200).
    c1, c2 : float
        Cognitive and social acceleration coefficients of eq 1 / eq 22 (paper: 1.5, 1.5).
    n_waypoints : int
        Intermediate waypoints per path; the particle has 2 n_waypoints coordinates.  Not given
        in the paper; 4 is enough for the paper maps (their optima have <= 4 bends) and keeps
        the swarm fast; an optimum with more bends needs a larger value.
    v_max : float
        Velocity clamp per coordinate as a fraction of the map range (0.2 = 20 %); ``inf``
        disables it.  Not in the paper.
    bounds_mode : {"reflect", "clip", "random"}
        Handling of coordinates that leave the map (see module docstring).
    init_mode : {"sorted", "uniform", "line"}
        Initial swarm (see module docstring).
    penalty_weight : float or None
        ``delta`` of eq 32 (map units per crossing); ``None`` = ``(n_waypoints + 1) * diag``,
        the smallest round value making every collision-free path beat every colliding one.
    penetration_weight : float
        Weight of the inside-obstacle length added to the fitness (beyond the paper; 0 in the
        ``-paper`` presets).
    kernel : {"fast", "geometry"}
        Crossing test: the private fast re-formulation or ``optplan.geometry.batch_crossings``
        (identical counts; the latter is the reference).
    roadmap_samples : int
        Random samples per roadmap for ``init_mode = "roadmap"`` (beyond the paper).
    map_quad_segs : int or None
        ``None``: fitness on exactly the validator's map.  An int ``q``: on a coarser
        circumscribed inflation containing it (faster, up to ``r(1/cos(pi/4q) - 1)`` more
        clearance at corners).
    """

    name: ClassVar[str] = "swarm"
    contract_problem: ClassVar[str] = "open-field"
    contract_overrides: ClassVar[dict] = {"n_particles": 10, "k_max": 10}

    n_particles: int = 50
    k_max: int = 200
    c1: float = 1.5
    c2: float = 1.5
    n_waypoints: int = 4
    v_max: float = 0.2
    bounds_mode: str = "reflect"
    init_mode: str = "sorted"
    penalty_weight: float | None = None
    penetration_weight: float = 0.0
    kernel: str = "fast"
    map_quad_segs: int | None = None
    roadmap_samples: int = 60

    def __post_init__(self) -> None:
        check_int(self, "n_particles", 2, 100_000)
        check_int(self, "k_max", 0, 1_000_000)
        check_range(self, "c1", 0.0, 10.0)
        check_range(self, "c2", 0.0, 10.0)
        check_int(self, "n_waypoints", 1, 200)
        check_range(self, "v_max", 0.0, math.inf, lo_open=True)
        check_choice(self, "bounds_mode", BOUNDS_MODES)
        check_choice(self, "init_mode", INIT_MODES)
        if self.penalty_weight is not None:
            check_range(self, "penalty_weight", 0.0, math.inf)
        check_range(self, "penetration_weight", 0.0, math.inf)
        check_choice(self, "kernel", KERNELS)
        if self.map_quad_segs is not None:
            check_int(self, "map_quad_segs", 1, 64)
        check_int(self, "roadmap_samples", 2, 100_000)

    # -- hooks for subclasses ------------------------------------------------------
    def _start(self, space: SwarmSpace, state: SwarmState, rng: np.random.Generator) -> None:
        """Called once after the initial evaluation (set up algorithm-specific state)."""

    def _iterate(self, space: SwarmSpace, state: SwarmState, k: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        """One iteration ``k`` (1-based); returns extra history columns."""
        raise NotImplementedError

    # -- shared helpers --------------------------------------------------------------
    def _vmax(self, space: SwarmSpace) -> np.ndarray | None:
        return None if math.isinf(self.v_max) else self.v_max * space.span

    def _velocity(self, state: SwarmState, w: float, rng: np.random.Generator,
                  space: SwarmSpace) -> np.ndarray:
        """Eq 1 / eq 22 for the whole swarm (``epsilon``, ``eta`` ~ U(0,1) per coordinate)."""
        P, D = state.X.shape
        eps = rng.random((P, D))
        eta = rng.random((P, D))
        V = (w * state.V + self.c1 * eps * (state.pbest - state.X)
             + self.c2 * eta * (state.gbest[None, :] - state.X))
        return clamp_velocity(V, self._vmax(space))

    # -- the driver --------------------------------------------------------------------
    def _run_robot(self, problem: Problem, robot: Robot, rng: np.random.Generator,
                   init_path: np.ndarray | None, callback, t0: float, it_offset: int):
        space = make_space(problem, robot, self.n_waypoints,
                           penalty_weight=self.penalty_weight,
                           penetration_weight=self.penetration_weight,
                           kernel=self.kernel, map_quad_segs=self.map_quad_segs)
        X = initial_swarm(space, self.n_particles,
                          "sorted" if self.init_mode == "roadmap" else self.init_mode, rng)
        if self.init_mode == "roadmap":
            seeds = roadmap_paths(space, max(1, self.n_particles // 10), rng,
                                  n_samples=self.roadmap_samples)
            for i, pth in enumerate(seeds):
                X[i] = np.clip(resample_path(pth, self.n_waypoints).reshape(-1),
                               space.lo, space.hi)
        if init_path is not None and len(init_path) >= 2:
            X[0] = np.clip(resample_path(init_path, self.n_waypoints).reshape(-1),
                           space.lo, space.hi)
        V = np.zeros_like(X)
        ev = evaluate_swarm(X, space)
        state = new_state(X, V, ev)
        self._start(space, state, rng)
        rows: list[dict[str, Any]] = []

        def record(k: int, extra: dict[str, Any]) -> bool:
            row = {"iteration": k, "best_cost": state.gbest_f,
                   "feasible_best_length": state.feas_len if state.feas_x is not None
                   else math.nan,
                   "n_eval": state.n_eval, "time": time.perf_counter() - t0,
                   "mean_cost": float(np.mean(state.F)), **extra}
            rows.append(row)
            return notify(callback, Progress(iteration=it_offset + k, best_cost=state.gbest_f,
                                             n_eval=state.n_eval,
                                             elapsed=time.perf_counter() - t0,
                                             info={"robot": robot.id,
                                                   "feasible_best_length": row[
                                                       "feasible_best_length"]}))

        stopped = record(0, {})
        k = 0
        while not stopped and k < self.k_max:
            k += 1
            extra = self._iterate(space, state, k, rng)
            stopped = record(k, extra)
        return space, state, rows, stopped

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None):
        t0 = time.perf_counter()
        rng = np.random.default_rng() if rng is None else rng
        view = problem.known_view()
        paths: dict[str, np.ndarray] = {}
        per_robot: dict[str, Any] = {}
        all_rows: list[list[dict[str, Any]]] = []
        n_eval, n_iter, stopped_any, all_ok = 0, 0, False, True
        cost = 0.0
        msgs = []
        for robot in view.planned_robots:
            if robot.goal is None:
                continue
            ip = None if not init else init.get(robot.id)
            space, st, rows, stopped = self._run_robot(view, robot, rng, ip, callback, t0,
                                                       n_iter)
            all_rows.append(rows)
            n_eval += st.n_eval
            n_iter += len(rows) - 1
            stopped_any |= stopped
            # the answer: the best collision-free particle ever seen, else gbest
            x = st.feas_x if st.feas_x is not None else st.gbest
            ok = st.feas_x is not None
            all_ok &= ok
            paths[robot.id] = decode(x[None], space)[0]
            best = np.array([r["best_cost"] for r in rows])
            conv = converged_iteration(best)
            cost += st.feas_len if ok else st.gbest_f
            per_robot[robot.id] = {
                "converged_iteration": conv,
                "final_best_cost": st.gbest_f,
                "feasible_best_length": st.feas_len if ok else None,
                "crossings": st.gbest_count,
                "penalty_weight": space.penalty_weight,
                **st.stats,
            }
            if not ok:
                msgs.append(f"{robot.id}: no collision-free particle found "
                            f"({st.gbest_count} crossing(s) in gbest)")
        hist = _merge_rows(all_rows)
        first = next(iter(per_robot.values()), {})
        extras = {
            "converged_iteration": first.get("converged_iteration", 0),
            "per_robot": per_robot,
            "stopped_early": stopped_any,
        }
        msg = "; ".join(msgs) or (
            f"{self.name}: best collision-free path after {n_iter} iteration(s)"
            + (" (stopped by callback)" if stopped_any else ""))
        return self.finish(problem, paths, claim=Status.solved if all_ok else Status.approximate,
                           cost=cost, message=msg, n_iter=n_iter, n_eval=n_eval,
                           history=hist, extras=extras, wall_time=time.perf_counter() - t0)


def _merge_rows(all_rows: list[list[dict[str, Any]]]) -> History:
    """One history: a single robot's rows, or per-iteration sums over several robots."""
    hist = History()
    if not all_rows:
        return hist
    if len(all_rows) == 1:
        for r in all_rows[0]:
            hist.append(**r)
        return hist
    n = max(len(r) for r in all_rows)
    for i in range(n):
        rows = [r[min(i, len(r) - 1)] for r in all_rows]
        hist.append(iteration=i, best_cost=sum(r["best_cost"] for r in rows),
                    feasible_best_length=sum(r["feasible_best_length"] for r in rows),
                    n_eval=sum(r["n_eval"] for r in rows), time=rows[-1]["time"],
                    mean_cost=sum(r["mean_cost"] for r in rows))
    return hist
