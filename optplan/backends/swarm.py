"""Shared machinery of the swarm path planners ``pso``, ``mpso`` and ``ipso`` (paper §III).

Encoding
    A particle is the ``D = 2 n`` coordinates of ``n`` intermediate waypoints, interleaved
    ``[x_1, y_1, x_2, y_2, ..., x_n, y_n]``; the path is ``start -> p_1 -> ... -> p_n -> goal``
    (domain-notes §1.2, Cartesian encoding).  ``n`` is the option ``n_waypoints``.

Fitness (eqs 31-33)
    ``fit = f_1 + f_2`` with ``f_1`` the polyline length (eq 31) and
    ``f_2 = penalty_weight * sum_i alpha_i`` (eq 32), ``alpha_i`` the number of obstacles
    the robot's disc hits along segment ``i`` (touching is not a collision).  Beyond the
    paper, ``penetration_weight * penetration`` can be added (how deep the path goes into
    obstacles, see below): it gives the swarm a gradient out of obstacles (the count alone is
    a flat landscape).

    **Default penalty weight** ``(n + 1) * diag`` (``diag`` = diagonal of the map bounds).
    Every waypoint stays inside the bounds (bounds handling below), so each of the ``n + 1``
    segments is at most ``diag`` long and any collision-free particle costs at most
    ``(n + 1) * diag``; a colliding one costs at least ``|goal - start| + penalty_weight``
    ``> (n + 1) * diag``.  Hence every collision-free path beats every colliding path: the
    fitness is lexicographic (feasibility first, then length) and gbest can never be a
    colliding shortcut while a feasible particle exists.

    The whole swarm is scored with one call of the collision test per evaluation,
    :meth:`optplan.geometry.ObstacleSet.crossings`: the exact disc-robot test against the raw
    obstacles (``alpha_i`` = number of obstacles closer than the robot radius to segment
    ``i``; penetration = ``r - distance`` or ``r + inside length`` per colliding convex
    piece).  It is the validator's own test (on the known obstacles), so a fitness-feasible
    path is validator-feasible as far as the known obstacles go.

Bounds handling (option ``bounds_mode``)
    ``"reflect"`` (default): a coordinate beyond a bound is mirrored back into the map and the
    velocity component is reversed; ``"clip"``: put on the bound, velocity component zeroed;
    ``"random"``: the coordinate is re-drawn uniformly in the bounds, velocity zeroed.
    (pyswarms' stuck-particle reports, domain-notes §1.2.)

Initialisation (option ``init_mode``)
    ``"uniform"``: waypoints uniform in the map; ``"sorted"`` (default): uniform, then ordered
    along the start->goal direction (no initial back-tracking zig-zags); ``"line"``: on the
    straight line plus Gaussian noise of ``0.1 * diag``; ``"roadmap"`` (beyond the paper):
    ``"sorted"`` plus ``n_particles // 10`` particles, spread evenly over the swarm, seeded
    with collision-free paths from small random roadmaps (:func:`roadmap_paths`).  An ``init``
    path (from an earlier stage) seeds particle 0 (:func:`resample_path`: exact when it has at
    most ``n`` bends).

Local refinement (beyond the paper)
    :func:`tighten`: deterministic corner cutting and string pulling of a collision-free path
    with the fitness kernel only (used by ``ipso``'s ``tighten_rounds``).  Backends add such
    post-iteration steps through :meth:`SwarmBackend._finish` (one history row each, not
    counted as iterations).

Convergence bookkeeping
    The "optimal number of iterations" of the paper's Tables 2-3 is defined here as the first
    iteration whose best fitness is within 0.1 % of the final best of the swarm iterations
    (:func:`converged_iteration`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
from shapely.geometry.polygon import orient

from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status, notify
from optplan.solver import Backend, check_choice, check_int, check_range, make_rng

if TYPE_CHECKING:
    from optplan.geometry import ObstacleSet
    from optplan.problem import Obstacle

__all__ = [
    "SwarmSpace",
    "SwarmEval",
    "SwarmState",
    "SwarmBackend",
    "make_space",
    "default_penalty",
    "decode",
    "evaluate_swarm",
    "evaluate_paths",
    "PathBuffer",
    "bound_positions",
    "bounce_velocity",
    "handle_bounds",
    "clamp_velocity",
    "initial_swarm",
    "resample_path",
    "converged_iteration",
    "densify",
    "tighten",
]

BOUNDS_MODES = ("reflect", "clip", "random")
INIT_MODES = ("sorted", "uniform", "line", "roadmap")
#: Relative tolerance of the "improved by" tests on fitness values.
_EPS = 1e-12


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
    """The search space of one robot: endpoints, box bounds per dimension, the fitness map.

    ``obstacles`` is the fitness kernel (None: no obstacles, every path is collision-free).
    ``static`` (the known static obstacles) and ``radius`` (the robot's) are read only for
    the obstacle corners of ``ipso``'s ``snap`` option (:func:`snap_targets`).
    """

    start: np.ndarray
    goal: np.ndarray
    n_waypoints: int
    lo: np.ndarray
    hi: np.ndarray
    obstacles: ObstacleSet | None
    penalty_weight: float
    penetration_weight: float = 0.0
    static: tuple[Obstacle, ...] = ()
    radius: float = 0.0

    @property
    def dim(self) -> int:
        return 2 * self.n_waypoints

    @cached_property
    def span(self) -> np.ndarray:
        """``hi - lo`` per dimension (computed once; read-only)."""
        out = self.hi - self.lo
        out.flags.writeable = False
        return out

    @cached_property
    def diag(self) -> float:
        """Diagonal of the map bounds (computed once)."""
        return float(math.hypot(*(self.hi[:2] - self.lo[:2])))

    @cached_property
    def _seg_ones(self) -> np.ndarray:
        """Ones over the ``n + 1`` segments (row sums by a matrix-vector product)."""
        return np.ones(self.n_waypoints + 1)


def make_space(problem: Problem, robot: Robot, n_waypoints: int, *,
               penalty_weight: float | None = None,
               penetration_weight: float = 0.0) -> SwarmSpace:
    """Build the :class:`SwarmSpace` of ``robot`` on the map ``problem`` (pass a known view).

    The fitness scores with :meth:`optplan.problem.Problem.obstacle_set` of the known static
    obstacles for the robot's radius (the exact disc-robot test, built once per problem and
    radius, cached).
    """
    x0, y0, x1, y1 = problem.bounds
    lo = np.tile([x0, y0], n_waypoints).astype(float)
    hi = np.tile([x1, y1], n_waypoints).astype(float)
    obs = problem.obstacle_set(robot.radius, known_only=True)
    pw = default_penalty(problem.bounds, n_waypoints) if penalty_weight is None else penalty_weight
    return SwarmSpace(np.asarray(robot.start, float), np.asarray(robot.goal, float),
                      n_waypoints, lo, hi, obs, float(pw), float(penetration_weight),
                      problem.static_obstacles(known_only=True), float(robot.radius))


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
    """Eqs 31-33 for a whole batch: one collision-test call for all particles."""
    return evaluate_paths(decode(X, space), space)


def evaluate_paths(paths: np.ndarray, space: SwarmSpace) -> SwarmEval:
    """Eqs 31-33 for already decoded polylines ``(P, n + 2, 2)`` (see :class:`PathBuffer`)."""
    z = paths.view(np.complex128)[..., 0]  # points as complex numbers
    length = np.abs(z[:, 1:] - z[:, :-1]) @ space._seg_ones
    if space.obstacles is None:  # no obstacles: nothing to cross
        count, pen = np.zeros(len(paths), np.int64), np.zeros(len(paths))
    else:
        cr = space.obstacles.crossings(paths, penetration=space.penetration_weight > 0)
        count, pen = cr.count, cr.penetration
    cost = length + space.penalty_weight * count
    if space.penetration_weight:
        cost += space.penetration_weight * pen
    return SwarmEval(cost, length, count, pen)


class PathBuffer:
    """Two preallocated batches of polylines ``(rows, n + 2, 2)`` with start and goal filled in.

    ``X(i)`` is the ``(rows, 2n)`` particle view of batch ``i % 2`` (it shares memory with
    ``paths(i)``): an iteration writes its particles straight into the polylines that the
    fitness kernel reads, with no decode or concatenation.  Two batches alternate so that the
    swarm of iteration ``k`` (a view into one) is intact while iteration ``k + 1`` writes the
    other.
    """

    def __init__(self, space: SwarmSpace, rows: int) -> None:
        self._paths = []
        self._X = []
        for _ in range(2):
            p = np.empty((rows, space.n_waypoints + 2, 2))
            p[:, 0] = space.start
            p[:, -1] = space.goal
            self._paths.append(p)
            X = p[:, 1:-1].reshape(rows, space.dim)  # a view: each row's inner block
            if not np.shares_memory(X, p):  # pragma: no cover - numpy guarantees the view
                raise RuntimeError("PathBuffer: the particle view of the paths is a copy")
            self._X.append(X)

    def paths(self, i: int) -> np.ndarray:
        return self._paths[i % 2]

    def X(self, i: int) -> np.ndarray:
        return self._X[i % 2]


# --------------------------------------------------------------------------------------
# particle operations
# --------------------------------------------------------------------------------------


def bound_positions(X: np.ndarray, lo: np.ndarray, hi: np.ndarray, mode: str,
                    rng: np.random.Generator) -> np.ndarray | None:
    """Bring positions back into ``[lo, hi]`` per dimension, **in place**.

    Returns the mask of the coordinates that were out (None when none was).  Coordinates
    inside the bounds are never changed, not even in the last bit: the mirror of ``reflect``
    is computed as ``2 clip(x) - x``, which is exactly ``x`` inside (``2x`` is exact and
    ``2x - x`` is exact by Sterbenz's lemma).  Modes: module docstring.
    """
    # (ufuncs rather than np.clip / ndarray.any: same result, less per-call overhead on the
    # small arrays of a swarm)
    C = np.maximum(X, lo)
    np.minimum(C, hi, out=C)
    out = C != X
    if not np.count_nonzero(out):
        return None
    if mode == "reflect":
        C *= 2.0
        np.subtract(C, X, out=X)  # mirror at the crossed bound
        np.maximum(X, lo, out=C)
        np.minimum(C, hi, out=C)
        far = C != X
        if np.count_nonzero(far):
            # far out (beyond a whole span): mirror repeatedly, triangle wave of period 2 span
            span = hi - lo
            u = np.mod(X - lo, 2 * span)
            np.copyto(X, lo + np.where(u > span, 2 * span - u, u), where=far)
    elif mode == "clip":
        X[...] = C
    else:  # random
        fresh = lo + (hi - lo) * rng.random(X.shape)
        np.copyto(X, fresh, where=out)
    return out


def handle_bounds(X: np.ndarray, V: np.ndarray, lo: np.ndarray, hi: np.ndarray, mode: str,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Bring positions back into ``[lo, hi]`` per dimension and adapt the velocities.

    Returns new ``(X, V)`` (the inputs are not modified): ``reflect`` reverses the velocity
    component of a reflected coordinate, ``clip`` and ``random`` zero it
    (:func:`bound_positions`).
    """
    Xn = np.array(X, dtype=float)
    out = bound_positions(Xn, lo, hi, mode, rng)
    if out is None:
        return Xn, V
    return Xn, bounce_velocity(V, out, mode)


def bounce_velocity(V: np.ndarray, out: np.ndarray, mode: str) -> np.ndarray:
    """Velocities after bounds handling: reversed (``reflect``) or zeroed where ``out``."""
    return np.where(out, -V, V) if mode == "reflect" else np.where(out, 0.0, V)


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
    if space.obstacles is None:  # no obstacles: every segment is free
        return np.ones(len(segs), dtype=bool)
    return space.obstacles.crossings(segs, penetration=False).count == 0


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


def densify(path: np.ndarray, spacing: float) -> np.ndarray:
    """The same polyline with extra points every ~``spacing`` along each segment (vertices
    kept, so the geometric path is unchanged)."""
    p = np.asarray(path, dtype=float)
    seg = np.hypot(*np.diff(p, axis=0).T)
    k = np.maximum(1, np.ceil(seg / spacing).astype(int))
    t = np.concatenate([np.arange(m) / m for m in k])
    i = np.repeat(np.arange(len(seg)), k)
    return np.vstack([p[i] + t[:, None] * (p[i + 1] - p[i]), p[-1:]])


#: Corner-cut fractions of :func:`tighten` (how far along each adjacent segment).
CUT_FRACTIONS = 0.5 ** np.arange(1, 11)


def tighten(path: np.ndarray, space: SwarmSpace, rounds: int = 30,
            rel_tol: float = 1e-7, min_gain: float = 1e-5) -> tuple[np.ndarray, int]:
    """Deterministic corner cutting and string pulling of a collision-free polyline (beyond
    the paper).

    Each round, for every interior vertex ``v`` with neighbours ``a``, ``b``, the cuts
    ``p = v + s (a - v)``, ``q = v + t (b - v)`` for ``s, t`` in :data:`CUT_FRACTIONS` are
    tested (one batch of segments ``p -> q``); each vertex takes its collision-free cut with the
    largest length gain.  Fractions are at most 1/2, so the cuts of neighbouring vertices do
    not overlap and ``a -> p``, ``q -> b`` are sub-segments of collision-free segments.  Then a
    greedy :func:`shortcut` drops the vertices that are no longer needed.  The path stays
    collision-free for the fitness (hence for the validator), never gets longer, and contracts
    onto the obstacle corners it wraps (the locally shortest path of its homotopy class).
    A cut must gain more than ``min_gain`` x the path length (this bounds the number of
    vertices spent on approximating the rounded corners of the disc robot's free space).
    Stops after ``rounds`` rounds or when a round gains less than ``rel_tol`` of the length.
    Returns ``(path, number of segments tested)``.
    """
    p = shortcut(np.asarray(path, dtype=float), space)
    length = float(np.hypot(*np.diff(p, axis=0).T).sum())
    f = CUT_FRACTIONS
    F = len(f)
    n_eval = 0
    for _ in range(rounds):
        if len(p) <= 2:
            break
        v, a, b = p[1:-1], p[:-2], p[2:]
        P = v[:, None, :] + f[None, :, None] * (a - v)[:, None, :]  # (V, F, 2)
        Q = v[:, None, :] + f[None, :, None] * (b - v)[:, None, :]
        Pp = np.broadcast_to(P[:, :, None, :], (len(v), F, F, 2))
        Qq = np.broadcast_to(Q[:, None, :, :], (len(v), F, F, 2))
        ok = segment_free(Pp.reshape(-1, 2), Qq.reshape(-1, 2), space).reshape(len(v), F, F)
        n_eval += ok.size
        gain = (np.hypot(*(Pp - v[:, None, None, :]).transpose(3, 0, 1, 2))
                + np.hypot(*(Qq - v[:, None, None, :]).transpose(3, 0, 1, 2))
                - np.hypot(*(Qq - Pp).transpose(3, 0, 1, 2)))
        gain = np.where(ok, gain, -1.0).reshape(len(v), -1)
        j = np.argmax(gain, axis=1)
        g = gain[np.arange(len(v)), j]
        cut = g > min_gain * length
        if not cut.any():
            break
        pts = [p[:1]]
        for i in range(len(v)):
            if cut[i]:
                pts.append(np.stack([P[i, j[i] // F], Q[i, j[i] % F]]))
            else:
                pts.append(v[i:i + 1])
        pts.append(p[-1:])
        q = shortcut(np.concatenate(pts), space)
        new = float(np.hypot(*np.diff(q, axis=0).T).sum())
        if new >= length:
            break
        done = new > length * (1.0 - rel_tol)
        p, length = q, new
        if done:
            break
    return p, n_eval


def snap_targets(space: SwarmSpace, push: float) -> np.ndarray:
    """Convex corners of the known polygonal obstacles, moved out along their bisector to
    ``radius + push`` from the corner (the middle of the arc the disc robot's free space has
    there), keeping those the fitness finds collision-free.

    Shortest paths among polygons bend only at convex obstacle corners (de Berg et al.,
    Lemma 15.1), for a disc robot on the arcs of radius ``r`` around them; a waypoint snapped
    to a slightly pushed-out target makes the path hug that corner without touching it
    (touching paths are fragile for floating-point tests).  Circles have no corners and give
    no target.  Hole rings count with the solid on the other side.
    """
    out = []
    for ob in space.static:
        if ob.is_circle or ob.geometry is None:
            continue
        for poly in getattr(ob.geometry, "geoms", [ob.geometry]):
            poly = orient(poly, 1.0)  # CCW exterior, CW holes: the solid is on the left
            for ring in (poly.exterior, *poly.interiors):
                c = shapely.get_coordinates(ring)[:-1]
                if len(c) < 3:
                    continue
                prev, nxt = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
                a, b = c - prev, nxt - c
                cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
                la, lb = np.hypot(*a.T), np.hypot(*b.T)
                keep = cross > 1e-12 * la * lb  # left turn: a convex corner of the solid
                na = np.stack([a[:, 1], -a[:, 0]], 1) / np.maximum(la, 1e-300)[:, None]
                nb = np.stack([b[:, 1], -b[:, 0]], 1) / np.maximum(lb, 1e-300)[:, None]
                bis = na + nb  # outward (away from the solid)
                bis /= np.maximum(np.hypot(*bis.T), 1e-300)[:, None]
                out.append((c + (space.radius + push) * bis)[keep])
    t = np.concatenate(out) if out else np.zeros((0, 2))
    if len(t) and space.obstacles is not None:  # drop corners inside another obstacle
        t = t[space.obstacles.crossings(np.stack([t, t], axis=1), penetration=False).count == 0]
    return t


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
        self.offer_gbest(X, ev)
        self.offer_feasible(X, ev)

    def offer_gbest(self, X: np.ndarray, ev: SwarmEval, n: int | None = None) -> None:
        """Replace gbest by the best candidate (of the first ``n``) if it has a lower fitness."""
        j = int(np.argmin(ev.cost if n is None else ev.cost[:n]))
        if ev.cost[j] < self.gbest_f:
            self.gbest = X[j].copy()
            self.gbest_f = float(ev.cost[j])
            self.gbest_len = float(ev.length[j])
            self.gbest_count = int(ev.count[j])

    def offer_feasible(self, X: np.ndarray, ev: SwarmEval) -> None:
        """Replace the best collision-free position by a shorter collision-free candidate."""
        feas = ev.count == 0
        if np.count_nonzero(feas):
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
    roadmap_samples : int
        Random samples per roadmap for ``init_mode = "roadmap"`` (beyond the paper).
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
        check_int(self, "roadmap_samples", 2, 100_000)

    # -- hooks for subclasses ------------------------------------------------------
    def _start(self, space: SwarmSpace, state: SwarmState, rng: np.random.Generator) -> None:
        """Called once after the initial evaluation (set up algorithm-specific state)."""

    def _iterate(self, space: SwarmSpace, state: SwarmState, k: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        """One iteration ``k`` (1-based); returns extra history columns."""
        raise NotImplementedError

    def _finish(self, space: SwarmSpace, state: SwarmState, rng: np.random.Generator):
        """Optional steps after the ``k_max`` iterations (a generator of history columns).

        Each yielded dict adds one history row (numbered on from ``k_max``); these rows are not
        counted in ``Result.n_iter``.
        """
        return iter(())

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
                           penetration_weight=self.penetration_weight)
        X = initial_swarm(space, self.n_particles,
                          "sorted" if self.init_mode == "roadmap" else self.init_mode, rng)
        if self.init_mode == "roadmap":
            seeds = roadmap_paths(space, max(1, self.n_particles // 10), rng,
                                  n_samples=self.roadmap_samples)
            for i, pth in enumerate(seeds):  # spread over the swarm (one per island)
                X[i * self.n_particles // len(seeds)] = np.clip(
                    resample_path(pth, self.n_waypoints).reshape(-1), space.lo, space.hi)
        if init_path is not None and len(init_path) >= 2:
            X[0] = np.clip(resample_path(init_path, self.n_waypoints).reshape(-1),
                           space.lo, space.hi)
        V = np.zeros_like(X)
        ev = evaluate_swarm(X, space)
        state = new_state(X, V, ev)
        self._start(space, state, rng)
        rows: list[dict[str, Any]] = []

        def record(k: int, extra: dict[str, Any]) -> bool:
            # F.sum() / n is what np.mean computes (same pairwise sum), without its wrapper
            row = {"iteration": k, "best_cost": state.gbest_f,
                   "feasible_best_length": state.feas_len if state.feas_x is not None
                   else math.nan,
                   "n_eval": state.n_eval, "time": time.perf_counter() - t0,
                   "mean_cost": float(state.F.sum() / len(state.F)), **extra}
            rows.append(row)
            if callback is None:
                return False
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
        state.stats["_iterations"] = k
        if not stopped:
            for extra in self._finish(space, state, rng):
                k += 1
                if record(k, extra):
                    stopped = True
                    break
        return space, state, rows, stopped

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None):
        t0 = time.perf_counter()
        rng = make_rng(rng)[0]
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
            n_iter += st.stats["_iterations"]
            stopped_any |= stopped
            # the answer: the best collision-free particle ever seen, else gbest
            x = st.feas_x if st.feas_x is not None else st.gbest
            ok = st.feas_x is not None
            all_ok &= ok
            final = st.stats.get("_final_path") if ok else None
            paths[robot.id] = final if final is not None else decode(x[None], space)[0]
            # over the swarm iterations (a final tightening row is not an iteration)
            best = np.array([r["best_cost"] for r in rows[:st.stats["_iterations"] + 1]])
            conv = converged_iteration(best)
            cost += st.feas_len if ok else st.gbest_f
            per_robot[robot.id] = {
                "converged_iteration": conv,
                "final_best_cost": st.gbest_f,
                "feasible_best_length": st.feas_len if ok else None,
                "crossings": st.gbest_count,
                "penalty_weight": space.penalty_weight,
                **{k: v for k, v in st.stats.items() if not k.startswith("_")},
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
    if len(all_rows) == 1:  # columns in first-seen order, nan where a row lacks one
        rows = all_rows[0]
        keys = list(dict.fromkeys(k for r in rows for k in r))
        return History({k: [r.get(k, np.nan) for r in rows] for k in keys})
    n = max(len(r) for r in all_rows)
    for i in range(n):
        rows = [r[min(i, len(r) - 1)] for r in all_rows]
        hist.append(iteration=i, best_cost=sum(r["best_cost"] for r in rows),
                    feasible_best_length=sum(r["feasible_best_length"] for r in rows),
                    n_eval=sum(r["n_eval"] for r in rows), time=rows[-1]["time"],
                    mean_cost=sum(r["mean_cost"] for r in rows))
    return hist
