"""Shared machinery of the swarm path planners ``pso``, ``mpso`` and ``ipso`` (paper §III).

Encoding
    A particle is the ``D = 2 n`` coordinates of ``n`` intermediate waypoints, interleaved
    ``[x_1, y_1, x_2, y_2, ..., x_n, y_n]``; the path is ``start -> p_1 -> ... -> p_n -> goal``
    (Cartesian encoding).  ``n`` is the option ``n_waypoints``.

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

Velocity update (eq 1, and eq 22 of IPSO)
    :func:`velocity_update` is the one PSO velocity update of the package (``pso``, ``mpso``
    and ``ipso`` call it), compiled with numba; the random factors are drawn by the caller
    from the run's ``rng``.

Bounds handling (option ``bounds_mode``)
    ``"reflect"`` (default): a coordinate beyond a bound is mirrored back into the map and the
    velocity component is reversed; ``"clip"``: put on the bound, velocity component zeroed;
    ``"random"``: the coordinate is re-drawn uniformly in the bounds, velocity zeroed.

Initialisation (option ``init_mode``)
    ``"uniform"``: waypoints uniform in the map; ``"sorted"`` (default): uniform, then ordered
    along the start->goal direction (no initial back-tracking zig-zags); ``"line"``: on the
    straight line plus Gaussian noise of ``0.1 * diag``; ``"roadmap"`` (beyond the paper):
    ``"sorted"``, then particles seeded with the ``corridors`` shortest start-goal paths of
    distinct homotopy classes of one sparse random roadmap (:func:`roadmap_corridors`), one
    per block of consecutive particles (one per island of ``ipso``).  An ``init`` path (from
    an earlier stage) seeds particle 0 (:func:`optplan.geometry.polyline.resample_path`: exact
    when it has at most ``n`` bends).

Sparse roadmap (beyond the paper; a probabilistic roadmap, no exact planner)
    Nodes (:func:`roadmap_nodes`): uniform samples, obstacle-based samples beside the boundary
    edges and around the corners of the kernel's convex pieces (:func:`boundary_samples`) and
    medial-axis retractions, which land in narrow passages (:func:`medial_samples`).  Edges
    (:func:`build_roadmap`): k nearest neighbours, the nearest node in each octant (a Yao
    graph, which bridges dense clusters and sparse regions) and every pair of corner / medial
    nodes within ``CORNER_REACH`` x diag (taut paths run between corners), kept when free with
    a margin of ``CLEAR_MARGIN`` x diag; corner pairs that no walk within the search bound can
    use (outside the start-goal ellipse of the bound) are skipped untested.  Corridors
    (:func:`roadmap_corridors`): the k shortest walks of distinct homotopy signatures (label
    setting, A* with the exact roadmap distance to the goal, at most 1.1 x the shortest walk),
    string-pulled.

Homotopy classes (beyond the paper)
    A path's class is summarised by an integer *signature*: for every item of the fitness
    kernel (convex piece or circle) a reference point inside it and the upward vertical ray from
    it; each segment crossing a ray adds ``+1`` (left to right) or ``-1`` to that item's count,
    and the signature hashes the count vector (:func:`signature_hashes`).  Two paths with
    common endpoints have the same signature iff their loop winds zero times around every
    item (see :mod:`optplan.geometry.homotopy`); the counts add over concatenated segments, so
    a roadmap search can carry them along its edges.

Local refinement (beyond the paper)
    :func:`tighten`: deterministic corner cutting and string pulling of collision-free paths
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

import numba
import numpy as np

from optplan.geometry.homotopy import obstacle_points
from optplan.geometry.polyline import resample_path
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status, notify
from optplan.solver import Backend, make_rng, option

if TYPE_CHECKING:
    from optplan.geometry import ObstacleSet

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
    "velocity_update",
    "bound_rows",
    "bound_positions",
    "bounce_velocity",
    "handle_bounds",
    "initial_swarm",
    "as_particle",
    "segment_free",
    "pairs_free",
    "shortcut",
    "tighten",
    "signature_hashes",
    "signature_hashes_list",
    "Roadmap",
    "build_roadmap",
    "roadmap_corridors",
    "converged_iteration",
]

BOUNDS_MODES = ("reflect", "clip", "random")
INIT_MODES = ("sorted", "uniform", "line", "roadmap")

#: Clearance kept by roadmap edges and tightened paths, as a fraction of the map diagonal
#: (1000 x the geometric tolerance ``eps``; see :class:`SwarmSpace`).
CLEAR_MARGIN = 1e-6

#: Compiled helpers (numba; cached on disk after the first run, see docs/solvers/pso.md).
_jit = numba.njit(cache=True, nogil=True)


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
    ``clear`` is the same test for a disc :data:`CLEAR_MARGIN` x the map diagonal larger: the
    roadmap and the tightening use it, so that the paths they make keep that margin from the
    obstacles instead of touching them within the validator's tolerance (default: ``obstacles``).
    """

    start: np.ndarray
    goal: np.ndarray
    n_waypoints: int
    lo: np.ndarray
    hi: np.ndarray
    obstacles: ObstacleSet | None
    penalty_weight: float
    penetration_weight: float = 0.0
    clear: ObstacleSet | None = None

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

    @cached_property
    def signature_points(self) -> np.ndarray:
        """One reference point per kernel item (world coordinates), shape ``(K, 2)``."""
        if self.obstacles is None or self.obstacles.n_items == 0:
            return np.zeros((0, 2))
        return np.ascontiguousarray(obstacle_points(self.obstacles) + self.obstacles.frame.origin)

    @cached_property
    def signature_keys(self) -> np.ndarray:
        """Per reference point a 64-bit key (splitmix64 of its index) hashed into signatures."""
        return _splitmix_keys(len(self.signature_points))


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
    # the bounds are the search box (bounds handling keeps every waypoint inside them), not
    # a wall of the fitness: the swarm's encoding is the paper's; the validator holds the
    # robot's disc inside the bounds (docs/geometry.md, "The bounds are a wall")
    obs = problem.obstacle_set(robot.radius, known_only=True, walls=False)
    clear = problem.obstacle_set(robot.radius + CLEAR_MARGIN * math.hypot(x1 - x0, y1 - y0),
                                 known_only=True, walls=False)
    pw = default_penalty(problem.bounds, n_waypoints) if penalty_weight is None else penalty_weight
    return SwarmSpace(np.asarray(robot.start, float), np.asarray(robot.goal, float),
                      n_waypoints, lo, hi, obs, float(pw), float(penetration_weight), clear)


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


@_jit
def velocity_update(V, X, pbest, guides, leader, w, c1, c2, eps, eta, vmax, out):
    """Eq 1 (PSO) and eq 22 (IPSO) for the whole swarm, written into ``out`` (returned)::

        v_id <- w v_id + c1 eps_id (p_id - x_id) + c2 eta_id (g_d - x_id)      (1), (22)

    then clamped to ``[-vmax_d, vmax_d]`` (``inf``: no clamp).  ``g`` is particle ``i``'s
    guide ``guides[leader[i]]``: the global best (one guide, every leader 0) or its island's
    best.  ``eps``, ``eta`` ~ U(0, 1) per particle and coordinate are drawn by the caller from
    the run's generator.  ``out`` may be ``V``.
    """
    P, D = X.shape
    for i in range(P):
        g = leader[i]
        for d in range(D):
            x = X[i, d]
            v = (w * V[i, d] + (c1 * eps[i, d]) * (pbest[i, d] - x)
                 + (c2 * eta[i, d]) * (guides[g, d] - x))
            v = min(v, vmax[d])
            out[i, d] = max(v, -vmax[d])
    return out


@_jit
def bound_rows(X, lo, hi, code):
    """Bounds handling of the rows of ``X`` into ``[lo, hi]``, in place: ``code`` 1 =
    ``reflect``, 2 = ``clip``, 0 = ``random`` (nothing moves here: the caller re-draws the
    coordinates of the returned mask, :func:`redraw_out`).  Returns the out-of-bounds mask and
    whether any coordinate was out.  Coordinates inside are never changed, not even in the
    last bit (the mirror is ``2 clip(x) - x``)."""
    P, D = X.shape
    out = np.zeros((P, D), np.bool_)
    anyout = False
    for i in range(P):
        for d in range(D):
            x = X[i, d]
            c = min(max(x, lo[d]), hi[d])
            if c == x:
                continue
            out[i, d] = True
            anyout = True
            if code == 2:
                X[i, d] = c
            elif code == 1:
                y = 2.0 * c - x  # mirror at the crossed bound
                if min(max(y, lo[d]), hi[d]) != y:
                    # far out (beyond a whole span): mirror repeatedly, triangle wave of
                    # period 2 span
                    span = hi[d] - lo[d]
                    u = np.mod(y - lo[d], 2.0 * span)
                    y = lo[d] + (2.0 * span - u if u > span else u)
                X[i, d] = y
    return out, anyout


BOUND_CODES = {"random": 0, "reflect": 1, "clip": 2}


def redraw_out(X: np.ndarray, out: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               rng: np.random.Generator) -> None:
    """``random`` bounds mode: re-draw the coordinates of the mask ``out`` uniformly in the
    bounds (one ``rng.random(X.shape)`` draw), in place."""
    fresh = lo + (hi - lo) * rng.random(X.shape)
    np.copyto(X, fresh, where=out)


def bound_positions(X: np.ndarray, lo: np.ndarray, hi: np.ndarray, mode: str,
                    rng: np.random.Generator) -> np.ndarray | None:
    """Bring positions back into ``[lo, hi]`` per dimension, **in place**.

    Returns the mask of the coordinates that were out (None when none was).  Modes: module
    docstring (:func:`bound_rows`, :func:`redraw_out`).
    """
    out, anyout = bound_rows(X, lo, hi, BOUND_CODES[mode])
    if not anyout:
        return None
    if mode == "random":
        redraw_out(X, out, lo, hi, rng)
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


def initial_swarm(space: SwarmSpace, n_particles: int, mode: str,
                  rng: np.random.Generator) -> np.ndarray:
    """Initial positions ``(n_particles, 2n)`` (modes: module docstring; ``roadmap`` starts
    from ``sorted``, its seeds are placed by the driver)."""
    n, D = space.n_waypoints, space.dim
    if mode == "line":
        frac = np.arange(1, n + 1) / (n + 1)
        base = (space.start[None, :] + frac[:, None] * (space.goal - space.start)[None, :])
        X = base.reshape(-1)[None, :] + 0.1 * space.diag * rng.standard_normal((n_particles, D))
        X = np.clip(X, space.lo, space.hi)
    else:
        X = space.lo + space.span * rng.random((n_particles, D))
        if mode in ("sorted", "roadmap") and n > 1:
            W = X.reshape(n_particles, n, 2)
            axis = space.goal - space.start
            proj = (W - space.start) @ axis
            order = np.argsort(proj, axis=1, kind="stable")
            X = np.take_along_axis(W, order[..., None], axis=1).reshape(n_particles, D)
    return X


# --------------------------------------------------------------------------------------
# polylines: resampling, visibility, string pulling, tightening
# --------------------------------------------------------------------------------------


def as_particle(path: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """A path as a particle: its ``n_waypoints`` interior points, clipped into the bounds."""
    w = resample_path(path, space.n_waypoints + 1)[1:-1].reshape(-1)
    return np.clip(w, space.lo, space.hi)


def segment_free(a: np.ndarray, b: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Collision-free flags of segments ``a[i] -> b[i]`` with the margin of ``space.clear``
    (:func:`pairs_free` of the stacked end points)."""
    n = len(a)
    idx = np.arange(n, dtype=np.int64)
    return pairs_free(np.concatenate([np.asarray(a, float).reshape(-1, 2),
                                      np.asarray(b, float).reshape(-1, 2)]), idx, idx + n,
                      space)


def pairs_free(points: np.ndarray, i: np.ndarray, j: np.ndarray,
               space: SwarmSpace) -> np.ndarray:
    """Collision-free flags of the segments ``points[i[q]] -> points[j[q]]`` with the margin
    of ``space.clear`` (no obstacles: all free).

    One call of :meth:`optplan.geometry.ObstacleSet.pairs_free` (the compiled
    :func:`optplan.geometry.kernel.free_pairs`): the decision of
    :meth:`optplan.geometry.ObstacleSet.segment_free` (``crossings(...).count == 0``) with an
    early exit per segment; the segments are given by point indices, so a roadmap or a
    string pulling tests its vertex pairs without gathering their end points."""
    test = space.clear if space.clear is not None else space.obstacles
    if test is None:  # no obstacles: every segment is free
        return np.ones(len(i), dtype=bool)
    return test.pairs_free(points, i, j)


def shortcut(path: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Greedy string pulling: from each kept vertex jump to the farthest visible later vertex."""
    return _shortcut_many([np.asarray(path, dtype=float)], space)[0]


def _shortcut_many(paths: list[np.ndarray], space: SwarmSpace) -> list[np.ndarray]:
    """:func:`shortcut` of several paths with one visibility test for all vertex pairs."""
    if not paths:
        return []
    pts, off = _flat(paths)
    pts, off = _pull(pts, off, space, 0)[:2]
    return [pts[off[i]:off[i + 1]] for i in range(len(paths))]


def _flat(paths: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Paths as one point array and the start offsets ``(n_paths + 1,)``."""
    off = np.zeros(len(paths) + 1, np.int64)
    off[1:] = np.cumsum([len(p) for p in paths])
    return np.ascontiguousarray(np.concatenate([np.asarray(p, float) for p in paths])), off


@_jit
def _pairs(off, window):
    """Global index pairs ``(i, j)``, ``i < j`` in the same path and at most ``window`` apart
    (0: every pair)."""
    n = 0
    for p in range(off.shape[0] - 1):
        m = off[p + 1] - off[p]
        for i in range(m):
            n += min(m - 1 - i, window) if window > 0 else m - 1 - i
    I = np.empty(n, np.int64)
    J = np.empty(n, np.int64)
    q = 0
    for p in range(off.shape[0] - 1):
        o, m = off[p], off[p + 1] - off[p]
        for i in range(m):
            top = m if window <= 0 else min(m, i + window + 1)
            for j in range(i + 1, top):
                I[q] = o + i
                J[q] = o + j
                q += 1
    return I, J


@_jit
def _greedy_keep(off, I, J, free):
    """Greedy string pulling from the visibility of the pairs ``(I, J)`` (sorted by ``I``
    then ``J``, as :func:`_pairs` makes them): from each kept vertex the farthest visible
    later vertex (the next vertex when none is).  Returns the keep mask."""
    N = off[-1]
    far = np.arange(N) + 1  # farthest visible later vertex per vertex
    for q in range(I.shape[0]):
        if free[q] and J[q] > far[I[q]]:
            far[I[q]] = J[q]
    keep = np.zeros(N, np.bool_)
    for p in range(off.shape[0] - 1):
        v = off[p]
        last = off[p + 1] - 1
        keep[v] = True
        while v < last:
            v = min(far[v], last)
            keep[v] = True
    return keep


def _pull(pts: np.ndarray, off: np.ndarray, space: SwarmSpace, window: int,
          ids: np.ndarray | None = None):
    """String pulling of flat paths (pairs at most ``window`` apart, 0: all): the kept
    points, offsets, ids and the number of segments tested."""
    I, J = _pairs(off, window)
    keep = _greedy_keep(off, I, J, pairs_free(pts, I, J, space))
    cnt = np.add.reduceat(keep, off[:-1]) if len(pts) else np.zeros(0, np.int64)
    new_off = np.zeros_like(off)
    new_off[1:] = np.cumsum(cnt)
    return pts[keep], new_off, (ids[keep] if ids is not None else None), len(I)


@_jit
def _dirty_rows(off, ids, settled_prev, settled_next, active):
    """Interior vertices of the active paths not known to admit no cut with their current
    neighbours (global indices)."""
    out = np.empty(off[-1], np.int64)
    n = 0
    for p in range(off.shape[0] - 1):
        if not active[p]:
            continue
        for v in range(off[p] + 1, off[p + 1] - 1):
            x = ids[v]
            if settled_prev[x] != ids[v - 1] or settled_next[x] != ids[v + 1]:
                out[n] = v
                n += 1
    return out[:n]


@_jit
def _apply_cuts(pts, off, ids, rows, cut, P, Q, next_id, settled_prev, settled_next):
    """Replace every cut vertex ``rows[r]`` by its two cut points ``P[r], Q[r]`` (new ids from
    ``next_id``); a tested vertex without a cut is recorded as settled with its neighbours.
    Returns the new points, offsets, ids and the next free id."""
    n_cut = 0
    for r in range(rows.shape[0]):
        if cut[r]:
            n_cut += 1
        else:
            v = rows[r]
            settled_prev[ids[v]] = ids[v - 1]
            settled_next[ids[v]] = ids[v + 1]
    N = pts.shape[0]
    new_pts = np.empty((N + n_cut, 2))
    new_ids = np.empty(N + n_cut, np.int64)
    new_off = np.zeros_like(off)
    which = np.full(N, -1, np.int64)
    for r in range(rows.shape[0]):
        if cut[r]:
            which[rows[r]] = r
    q = 0
    for p in range(off.shape[0] - 1):
        new_off[p] = q
        for v in range(off[p], off[p + 1]):
            r = which[v]
            if r < 0:
                new_pts[q] = pts[v]
                new_ids[q] = ids[v]
                q += 1
            else:
                new_pts[q] = P[r]
                new_pts[q + 1] = Q[r]
                new_ids[q] = next_id
                new_ids[q + 1] = next_id + 1
                next_id += 2
                q += 2
    new_off[-1] = q
    return new_pts, new_off, new_ids, next_id


@_jit
def _lengths(pts, off):
    """Length of each flat path."""
    out = np.zeros(off.shape[0] - 1)
    for p in range(off.shape[0] - 1):
        for v in range(off[p], off[p + 1] - 1):
            out[p] += math.hypot(pts[v + 1, 0] - pts[v, 0], pts[v + 1, 1] - pts[v, 1])
    return out


#: Corner-cut fractions of :func:`tighten` (how far along each adjacent segment).
CUT_FRACTIONS = 0.5 ** np.arange(1, 11)


#: Rank boundaries of the staged cut tests of :func:`tighten` (by decreasing gain).
CUT_STAGES = (8, 24)


@_jit
def _cut_table(pts, rows, f, thr):
    """The corner cuts of :func:`tighten` for the vertices ``rows``: the cut points
    ``P[r, s] = v + f[s] (a - v)``, ``Q[r, t] = v + f[t] (b - v)``, the length gain of each
    cut ``(s, t)`` (flat index ``s F + t``), the cuts in order of decreasing gain (ties: the
    lower index first) and per vertex how many gain more than ``thr[r]``."""
    R = rows.shape[0]
    F = f.shape[0]
    P = np.empty((R, F, 2))
    Q = np.empty((R, F, 2))
    gain = np.empty((R, F * F))
    order = np.empty((R, F * F), np.int64)
    n_above = np.zeros(R, np.int64)
    dp = np.empty(F)
    dq = np.empty(F)
    for r in range(R):
        v = rows[r]
        vx, vy = pts[v, 0], pts[v, 1]
        ax, ay = pts[v - 1, 0] - vx, pts[v - 1, 1] - vy
        bx, by = pts[v + 1, 0] - vx, pts[v + 1, 1] - vy
        for s in range(F):
            P[r, s, 0] = vx + f[s] * ax
            P[r, s, 1] = vy + f[s] * ay
            Q[r, s, 0] = vx + f[s] * bx
            Q[r, s, 1] = vy + f[s] * by
            dp[s] = math.hypot(P[r, s, 0] - vx, P[r, s, 1] - vy)
            dq[s] = math.hypot(Q[r, s, 0] - vx, Q[r, s, 1] - vy)
        for s in range(F):
            for t in range(F):
                g = (dp[s] + dq[t]) - math.hypot(Q[r, t, 0] - P[r, s, 0],
                                                 Q[r, t, 1] - P[r, s, 1])
                gain[r, s * F + t] = g
                if g > thr[r]:
                    n_above[r] += 1
        order[r] = np.argsort(-gain[r], kind="mergesort")
    return P, Q, gain, order, n_above


@_jit
def _stage_segments(P, Q, order, n_above, found, lo, hi):
    """The cuts of ranks ``lo .. hi - 1`` (among those above the threshold) of the vertices
    without a free cut yet: their segments ``p -> q``, vertex and rank."""
    R = order.shape[0]
    F = P.shape[1]
    n = 0
    for r in range(R):
        if not found[r]:
            n += max(0, min(hi, n_above[r]) - lo)
    A = np.empty((n, 2))
    B = np.empty((n, 2))
    who = np.empty(n, np.int64)
    rank = np.empty(n, np.int64)
    q = 0
    for r in range(R):
        if found[r]:
            continue
        for k in range(lo, min(hi, n_above[r])):
            c = order[r, k]
            A[q, 0] = P[r, c // F, 0]
            A[q, 1] = P[r, c // F, 1]
            B[q, 0] = Q[r, c % F, 0]
            B[q, 1] = Q[r, c % F, 1]
            who[q] = r
            rank[q] = k
            q += 1
    return A, B, who, rank


@_jit
def _stage_pick(order, who, rank, free, found, choice):
    """Per vertex the first free cut of the stage (in rank order: the largest gain)."""
    for q in range(who.shape[0]):
        r = who[q]
        if free[q] and not found[r]:
            found[r] = True
            choice[r] = order[r, rank[q]]


def _best_cuts(pts: np.ndarray, rows: np.ndarray, f: np.ndarray, thr: np.ndarray,
               space: SwarmSpace):
    """Per vertex ``rows[r]`` its collision-free corner cut with the largest gain, if that
    gain is above ``thr[r]``: the cut points ``P, Q`` (``(R, F, 2)``), the chosen flat index
    ``j`` and the mask ``cut``, and the number of segments tested.

    The same choice as testing all ``F x F`` cuts and taking the argmax of the gains of the
    free ones (the first on ties), with fewer tests: the cuts that gain at most ``thr[r]``
    cannot be taken and are not tested, and the others are tested in stages of decreasing
    gain (ranks below :data:`CUT_STAGES`, then the rest), each vertex only until it has a
    free cut."""
    P, Q, gain, order, n_above = _cut_table(pts, rows, f, thr)
    R = len(rows)
    found = np.zeros(R, bool)
    choice = np.zeros(R, np.int64)
    n_eval = 0
    lo = 0
    for hi in (*CUT_STAGES, order.shape[1]):
        A, B, who, rank = _stage_segments(P, Q, order, n_above, found, lo, hi)
        if len(A):
            _stage_pick(order, who, rank, segment_free(A, B, space), found, choice)
            n_eval += len(A)
        lo = hi
        if lo >= order.shape[1]:
            break
    return P, Q, choice, found, n_eval


def tighten(paths: list[np.ndarray], space: SwarmSpace, rounds: int = 30,
            rel_tol: float = 1e-7, min_gain: float = 1e-5,
            fractions: np.ndarray = CUT_FRACTIONS) -> tuple[list[np.ndarray], int]:
    """Deterministic corner cutting and string pulling of collision-free polylines (beyond
    the paper), all paths together (two visibility tests per round for all of them).

    First a greedy :func:`shortcut` of each path.  Then each round, for every interior vertex
    ``v`` with neighbours ``a``, ``b`` (skipping vertices that admitted no cut with the same
    neighbours in an earlier round), the cuts ``p = v + s (a - v)``, ``q = v + t (b - v)`` for
    ``s, t`` in ``fractions`` (default :data:`CUT_FRACTIONS`, 1/2 to 1/1024) are tested (one
    batch of segments ``p -> q``); each vertex takes its collision-free cut with the largest
    length gain.  Fractions are at most 1/2, so the cuts of neighbouring vertices do not
    overlap and ``a -> p``, ``q -> b`` are sub-segments of collision-free segments.  Then a
    greedy string pulling over vertices at most 6 apart drops the vertices that are no longer
    needed.  Visibility is tested with the margin of ``space.clear``.  A path stays
    collision-free for the fitness (hence for the validator), never gets longer, and contracts
    onto the obstacle corners it wraps (the locally shortest path of its homotopy class).  A
    cut must gain more than ``min_gain`` x the path length (this bounds the number of vertices
    spent on approximating the rounded corners of the disc robot's free space).  A path stops
    after ``rounds`` rounds, when a round gains less than ``rel_tol`` of its length or when no
    vertex admits a cut.  Returns ``(paths, number of segments tested)``.
    """
    if not paths:
        return [], 0
    pts, off = _flat(paths)
    pts, off, _, n_eval = _pull(pts, off, space, 0)
    ids = np.arange(len(pts), dtype=np.int64)
    next_id = len(pts)
    cap = max(4 * len(pts), 64)
    s_prev = np.full(cap, -1, np.int64)
    s_next = np.full(cap, -1, np.int64)
    length = _lengths(pts, off)
    active = np.diff(off) > 2
    f = np.asarray(fractions, dtype=float)
    F = len(f)
    for _ in range(rounds):
        rows = _dirty_rows(off, ids, s_prev, s_next, active)
        if not len(rows):
            break
        owner = np.searchsorted(off, rows, side="right") - 1
        P, Q, j, cut, n = _best_cuts(pts, rows, f, min_gain * length[owner], space)
        n_eval += n
        if next_id + 2 * int(cut.sum()) > cap:  # room for the new ids
            cap = 2 * (next_id + 2 * int(cut.sum()))
            s_prev = np.concatenate([s_prev, np.full(cap - len(s_prev), -1, np.int64)])
            s_next = np.concatenate([s_next, np.full(cap - len(s_next), -1, np.int64)])
        r = np.arange(len(rows))
        pts, off, ids, next_id = _apply_cuts(pts, off, ids, rows, cut, P[r, j // F],
                                             Q[r, j % F], next_id, s_prev, s_next)
        pts, off, ids, n = _pull(pts, off, space, 6, ids)
        n_eval += n
        new = _lengths(pts, off)
        active &= (new < length * (1.0 - rel_tol)) & (np.diff(off) > 2)
        length = new
    return [pts[off[i]:off[i + 1]] for i in range(len(paths))], int(n_eval)


# --------------------------------------------------------------------------------------
# homotopy classes and the sparse roadmap (beyond the paper)
# --------------------------------------------------------------------------------------


def _splitmix_keys(n: int) -> np.ndarray:
    """``n`` 64-bit keys (splitmix64 of 1..n as signed int64): hashing, not randomness."""
    mask = (1 << 64) - 1
    out = np.empty(n, np.int64)
    for i in range(n):
        z = ((i + 1) * 0x9E3779B97F4A7C15) & mask
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        z ^= z >> 31
        out[i] = z - (1 << 64) if z >= 1 << 63 else z
    return out


@_jit
def _segment_hashes(A, B, Z, keys):
    """Per segment ``A[s] -> B[s]`` the sum of ``keys[o]`` times its signed crossing of the
    upward ray from ``Z[o]`` (wrapping int64 arithmetic)."""
    n = A.shape[0]
    out = np.zeros(n, np.int64)
    for s in range(n):
        ax, ay, bx, by = A[s, 0], A[s, 1], B[s, 0], B[s, 1]
        h = np.int64(0)
        for o in range(Z.shape[0]):
            zx = Z[o, 0]
            ra = ax > zx
            rb = bx > zx
            if ra == rb:
                continue
            y = ay + (zx - ax) * (by - ay) / (bx - ax)
            if y > Z[o, 1]:
                if rb:
                    h += keys[o]
                else:
                    h -= keys[o]
        out[s] = h
    return out


def signature_hashes(paths: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Homotopy signature (an int64 hash, module docstring) of each polyline ``(P, M, 2)``;
    equal for two paths with common endpoints iff they wind alike around every item."""
    p = np.asarray(paths, dtype=float)
    if p.ndim == 2:
        p = p[None]
    P, M, _ = p.shape
    if M < 2:
        return np.zeros(P, np.int64)
    A = np.ascontiguousarray(p[:, :-1].reshape(-1, 2))
    B = np.ascontiguousarray(p[:, 1:].reshape(-1, 2))
    h = _segment_hashes(A, B, space.signature_points, space.signature_keys)
    return h.reshape(P, M - 1).sum(axis=1)


@_jit
def _heap_push(hk, hv, size, key, val):
    """Push ``(key, val)`` onto the binary min-heap ``hk, hv`` of ``size`` items."""
    i = size
    hk[i] = key
    hv[i] = val
    while i > 0:
        up = (i - 1) >> 1
        if hk[up] <= hk[i]:
            break
        hk[up], hk[i] = hk[i], hk[up]
        hv[up], hv[i] = hv[i], hv[up]
        i = up
    return size + 1


@_jit
def _heap_pop(hk, hv, size):
    """Pop the smallest ``(key, val)``; returns it and the new size."""
    key, val = hk[0], hv[0]
    size -= 1
    hk[0], hv[0] = hk[size], hv[size]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and hk[c + 1] < hk[c]:
            c += 1
        if hk[i] <= hk[c]:
            break
        hk[c], hk[i] = hk[i], hk[c]
        hv[c], hv[i] = hv[i], hv[c]
        i = c
    return key, val, size


@_jit
def _k_classes(indptr, nbr, weight, ehash, heur, src, dst, k_goal, k_node, slack=np.inf):
    """Label-setting search for the ``k_goal`` shortest ``src -> dst`` walks of distinct
    homotopy signatures (each node settles at most ``k_node`` signatures, shortest first),
    A*-ordered by ``g + heur[node]`` (``heur``: a consistent lower bound of the distance to
    ``dst``, e.g. the exact roadmap distance, so each node still settles its labels shortest
    first; ``inf`` marks nodes that do not reach ``dst``).  The search stops at the
    first label longer than ``slack`` x the first walk found (the walks it could still find
    are at least that long).

    Returns the goal labels (shortest first), each label's node and parent label.
    """
    n = indptr.shape[0] - 1
    cap = k_node * nbr.shape[0] + 1  # every settled label pushes one label per edge
    lab_node = np.empty(cap, np.int64)
    lab_hash = np.empty(cap, np.int64)
    lab_par = np.empty(cap, np.int64)
    lab_g = np.empty(cap)
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    lab_node[0] = src
    lab_hash[0] = 0
    lab_par[0] = -1
    lab_g[0] = 0.0
    n_lab = 1
    settled = np.zeros(n, np.int64)
    shash = np.empty((n, k_node), np.int64)
    goals = np.empty(k_goal, np.int64)
    n_goal = 0
    size = _heap_push(hk, hv, 0, heur[src], 0)
    bound = np.inf
    while size > 0 and n_goal < k_goal:
        f, lab, size = _heap_pop(hk, hv, size)
        if f > bound:
            break
        v = lab_node[lab]
        d = lab_g[lab]
        h = lab_hash[lab]
        if settled[v] >= k_node:
            continue
        dup = False
        for q in range(settled[v]):
            if shash[v, q] == h:
                dup = True
                break
        if dup:
            continue
        shash[v, settled[v]] = h
        settled[v] += 1
        if v == dst:
            goals[n_goal] = lab
            if n_goal == 0:
                bound = slack * d
            n_goal += 1
            continue
        for e in range(indptr[v], indptr[v + 1]):
            u = nbr[e]
            if settled[u] >= k_node:
                continue
            g = d + weight[e]
            if not g + heur[u] <= bound:  # beyond the bound, or u does not reach dst
                continue
            hu = h + ehash[e]
            known = False
            for q in range(settled[u]):  # that class of u is settled already (shorter)
                if shash[u, q] == hu:
                    known = True
                    break
            if known:
                continue
            lab_node[n_lab] = u
            lab_hash[n_lab] = hu
            lab_par[n_lab] = lab
            lab_g[n_lab] = g
            size = _heap_push(hk, hv, size, g + heur[u], n_lab)
            n_lab += 1
    return goals[:n_goal], lab_node[:n_lab], lab_par[:n_lab]


def boundary_samples(space: SwarmSpace, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` random points beside the obstacles (world coordinates), moved out from the
    obstacle by the robot radius plus an exponential margin (mean ``0.5 r + diag / 200``):
    half of them from a point drawn uniformly by length over the kernel's boundary edges and
    circle perimeters (along the outward normal), half around a random corner of a convex
    piece (in a random direction between the normals of its two edges).  Obstacle-based
    sampling (a PRM technique): it puts roadmap nodes in narrow passages and around the
    corners that shortest paths wrap."""
    os_ = space.obstacles
    if os_ is None or os_.n_items == 0 or n <= 0:
        return np.zeros((0, 2))
    K = os_.n_pieces
    p, e, nrm = os_.table[0], os_.table[1], os_.table[2]  # (4, K) complex, local frame
    w_edge = np.where(os_.boundary, np.abs(e), 0.0).T.reshape(-1)  # (K * 4,)
    cen = os_.item_center[K:]
    rad = os_.circle_radius
    w = np.concatenate([w_edge, 2 * np.pi * rad])
    if w.sum() <= 0:
        return np.zeros((0, 2))
    off = os_.radius + rng.exponential(0.5 * os_.radius + space.diag / 200.0, n)
    n_corner = n // 2 if K else 0
    z = np.empty(n, complex)
    # along edges and circles
    m = n - n_corner
    pick = rng.choice(len(w), size=m, p=w / w.sum())
    u = rng.random(m)
    edge = pick < len(w_edge)
    k, j = pick[edge] // 4, pick[edge] % 4
    ze = np.empty(m, complex)
    ze[edge] = p[j, k] + u[edge] * e[j, k] + off[:m][edge] * nrm[j, k]
    c = pick[~edge] - len(w_edge)
    ze[~edge] = cen[c] + (rad[c] + off[:m][~edge]) * np.exp(2j * np.pi * u[~edge])
    z[:m] = ze
    # around piece corners: vertex j of piece k lies between edges j - 1 and j
    if n_corner:
        # corners without replacement (every corner once before any twice)
        order = np.concatenate([rng.permutation(4 * K) for _ in range(-(-n_corner // (4 * K)))])
        k, j = order[:n_corner] // 4, order[:n_corner] % 4
        a0 = np.angle(nrm[(j - 1) % 4, k])
        sweep = np.mod(np.angle(nrm[j, k]) - a0, 2 * np.pi)
        sweep = np.where(sweep > np.pi, 0.0, sweep)  # a reflex join: along the first normal
        z[m:] = p[j, k] + off[m:] * np.exp(1j * (a0 + rng.random(n_corner) * sweep))
    return np.stack([z.real, z.imag], axis=1) + os_.frame.origin


def medial_samples(space: SwarmSpace, n: int, rng: np.random.Generator) -> np.ndarray:
    """Samples retracted toward the medial axis (a PRM technique for narrow passages): for
    each of ``n`` points (half uniform in the bounds, half :func:`boundary_samples`, which
    start beside an obstacle and so find the obstacles close to it), the midpoint of its
    nearest boundary points on its two nearest obstacles (searched within ``diag / 4``), kept
    when free.  In a passage between two obstacles the midpoint lies on its centre line,
    however narrow it is."""
    os_ = space.obstacles
    if os_ is None or os_.n_obstacles < 2 or n <= 0:
        return np.zeros((0, 2))
    lo, hi = space.lo[:2], space.hi[:2]
    x = np.vstack([lo + (hi - lo) * rng.random((n - n // 2, 2)),
                   boundary_samples(space, n // 2, rng)])
    n = len(x)
    near, dist = os_.nearest(x, max_range=space.diag / 4.0)
    two = np.argsort(dist, axis=1)[:, :2]
    r = np.arange(n)
    ok = np.isfinite(dist[r, two[:, 1]])
    m = 0.5 * (near[r, two[:, 0]] + near[r, two[:, 1]])[ok]
    m = m[np.all((m >= lo) & (m <= hi), axis=1)]
    return m[segment_free(m, m, space)]


def roadmap_nodes(space: SwarmSpace, n_samples: int, rng: np.random.Generator,
                  boundary: int | None = None, medial: int | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Start, goal and the collision-free ones among ``n_samples`` uniform draws in the bounds
    and ``boundary`` (default ``n_samples``) :func:`boundary_samples`, plus the
    :func:`medial_samples` of ``medial`` (default ``n_samples``) points.  Returns the nodes and a
    mask of the *corner* nodes (the corner samples, start and goal)."""
    lo, hi = space.lo[:2], space.hi[:2]
    nb = n_samples if boundary is None else boundary
    pts = np.vstack([lo + (hi - lo) * rng.random((n_samples, 2)),
                     boundary_samples(space, nb, rng)])
    corner = np.zeros(len(pts), bool)
    corner[n_samples + nb - (nb // 2 if space.obstacles is not None
                              and space.obstacles.n_pieces else 0):] = True
    keep = np.all((pts >= lo) & (pts <= hi), axis=1)
    pts, corner = pts[keep], corner[keep]
    free = segment_free(pts, pts, space)
    mids = medial_samples(space, n_samples if medial is None else medial, rng)
    return (np.vstack([space.start, space.goal, pts[free], mids]),
            np.concatenate([[True, True], corner[free], np.ones(len(mids), bool)]))


@dataclass(frozen=True, eq=False)
class Roadmap:
    """A sparse roadmap in CSR form (both directions of every edge): ``nodes`` (0 = start,
    1 = goal), per directed edge its target, length and signature hash."""

    nodes: np.ndarray
    indptr: np.ndarray
    target: np.ndarray
    weight: np.ndarray
    ehash: np.ndarray

    def to_goal(self) -> np.ndarray:
        """Roadmap distance of every node to the goal (``inf``: not connected), the exact
        A* heuristic of the class search (the edges go both ways: Dijkstra from the goal)."""
        return _dijkstra(self.indptr, self.target, self.weight, 1)

    def walk(self, lab: int, lab_node: np.ndarray, lab_par: np.ndarray) -> np.ndarray:
        """The points of the walk ending in label ``lab``."""
        seq = []
        while lab >= 0:
            seq.append(int(lab_node[lab]))
            lab = int(lab_par[lab])
        return self.nodes[seq[::-1]]


def build_roadmap(space: SwarmSpace, rng: np.random.Generator, n_samples: int = 40,
                  k_neighbours: int = 25, boundary: int | None = None,
                  medial: int | None = None, slack: float | None = None) -> Roadmap | None:
    """The sparse random roadmap (beyond the paper; no exact planner).  Nodes:
    :func:`roadmap_nodes`.  Edges: each node to its ``k_neighbours`` nearest nodes (start and
    goal to twice as many) and to its nearest node in each of :data:`YAO_SECTORS` angular
    sectors, and every pair of corner nodes (taut paths run between corners; 0 neighbours:
    every pair of nodes), kept when collision-free with the margin of ``space.clear``.  None
    when no edge is free.

    ``slack`` (the search bound of :func:`roadmap_corridors`): the neighbour and Yao edges are
    tested first; with ``U`` the shortest start-goal walk over them, a corner pair ``(a, b)``
    with ``|s - a| + |a - b| + |b - g| > slack U`` (either orientation) is not tested and not
    kept.  No walk through it can be within ``slack`` x the shortest walk ``L <= U`` of the
    whole roadmap, nor on a shortest path to the goal from a node such a walk reaches, so the
    class search returns the same walks; it only skips the collision tests of long corner pairs
    far from the start-goal line.

    The candidate edges come from compiled loops (:func:`_base_edges`, :func:`_corner_edges`),
    and each group is tested in one call of the collision kernel (two calls in all)."""
    nodes, corner = roadmap_nodes(space, n_samples, rng, boundary, medial)
    n = len(nodes)
    if k_neighbours <= 0 or k_neighbours >= n - 1:  # every pair
        i, j = np.triu_indices(n, 1)
        ok = pairs_free(nodes, i, j, space)
    else:
        i, j, ok = _tested_edges(space, nodes, corner, k_neighbours, slack)
    i, j = i[ok], j[ok]
    if len(i) == 0:
        return None
    return Roadmap(nodes, *_roadmap_csr(nodes, i, j, space.signature_points,
                                        space.signature_keys))


def _tested_edges(space: SwarmSpace, nodes: np.ndarray, corner: np.ndarray, k: int,
                  slack: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The candidate edges ``i < j`` of :func:`build_roadmap` (lexicographic order) and their
    collision-free flags: the neighbour and Yao edges, tested first, then the corner pairs
    within :data:`CORNER_REACH` x diag and inside the ellipse of ``slack`` x the shortest
    walk over the free first edges (untested pairs outside it are returned as not free)."""
    from scipy.spatial import cKDTree

    n = len(nodes)
    tree = cKDTree(nodes)
    nb = tree.query(nodes, k=k + 1)[1][:, 1:]
    nb2 = tree.query(nodes[:2], k=min(2 * k, n - 1) + 1)[1][:, 1:]
    bi, bj = _base_edges(nodes, nb.astype(np.int64), nb2.astype(np.int64), YAO_SECTORS)
    okb = pairs_free(nodes, bi, bj, space)
    bound = math.inf
    if slack is not None and math.isfinite(slack):
        U = _walk_length(nodes, bi[okb], bj[okb])
        if math.isfinite(U):
            bound = slack * U * (1.0 + 1e-9)
    i, j, ok, todo = _corner_edges(nodes, bi, bj, corner, okb, CORNER_REACH * space.diag,
                                   bound)
    ok[todo] = pairs_free(nodes, i[todo], j[todo], space)
    return i, j, ok


def _walk_length(nodes: np.ndarray, i: np.ndarray, j: np.ndarray) -> float:
    """Shortest walk from node 0 to node 1 over the undirected edges ``(i, j)`` (inf: none)."""
    if len(i) == 0:
        return math.inf
    indptr, target, weight, _ = _csr(len(nodes), i, j, _edge_lengths(nodes, i, j))
    return float(_dijkstra(indptr, target, weight, 0)[1])


#: Corner nodes farther apart than this fraction of the map diagonal are not paired directly.
CORNER_REACH = 0.3

#: Angular sectors of the Yao edges of :func:`build_roadmap` (a divisor of 8: octants).
YAO_SECTORS = 8


@_jit
def _sector(dx, dy, sectors):
    """The Yao sector of the direction ``(dx, dy)``: octant 0-7 counter-clockwise from +x (a
    half-open 45 degree cone each), times ``sectors / 8``.  Written with selects instead of
    branches (the same octants as nested ``if``s; it runs once per pair of roadmap nodes)."""
    neg = dy < 0.0  # the lower half is the upper half turned by 180 degrees
    u = -dx if neg else dx
    v = -dy if neg else dy
    o = (np.int64(2) + np.int64(v <= -u)) if u <= 0.0 else np.int64(v >= u)
    return (o + np.int64(4) * np.int64(neg)) * sectors // 8


@_jit
def _base_edges(nodes, nb, nb2, sectors):
    """The neighbour and Yao edges of :func:`build_roadmap`: each node to its nearest nodes
    ``nb`` (a row per node; ``nb2``: more for nodes 0 and 1, start and goal) and to its
    nearest node in each of ``sectors`` equal angular sectors (a Yao graph: connected, and it
    bridges a dense cluster and a sparse region, which the k nearest neighbours of the
    cluster's nodes do not).  Returns those pairs ``i < j`` in lexicographic order."""
    n = nodes.shape[0]
    M = np.zeros((n, n), np.bool_)
    _mark_rows(M, nb)
    _mark_rows(M, nb2)
    X = nodes[:, 0].copy()
    Y = nodes[:, 1].copy()
    d2 = np.empty(n)
    sec = np.empty(n, np.int64)
    best = np.empty(sectors)
    arg = np.empty(sectors, np.int64)
    for i in range(n):
        xi = X[i]
        yi = Y[i]
        for j in range(n):
            dx = X[j] - xi
            dy = Y[j] - yi
            d2[j] = dx * dx + dy * dy
            sec[j] = _sector(dx, dy, sectors)
        best[:] = np.inf
        arg[:] = -1
        for j in range(n):
            if j != i and d2[j] < best[sec[j]]:
                best[sec[j]] = d2[j]
                arg[sec[j]] = j
        for s in range(sectors):
            if arg[s] >= 0:
                M[min(i, arg[s]), max(i, arg[s])] = True
    return _mask_pairs(M)


@_jit
def _mark_rows(M, nb):
    """Mark the pairs (node ``i``, ``nb[i, q]``) in the upper triangle of ``M`` (not ``i``
    itself)."""
    for i in range(nb.shape[0]):
        for q in range(nb.shape[1]):
            j = nb[i, q]
            if j != i:
                M[min(i, j), max(i, j)] = True


@_jit
def _mask_pairs(M):
    """The marked pairs ``a < b`` of ``M`` in lexicographic order."""
    n = M.shape[0]
    cnt = 0
    for a in range(n):
        for b in range(a + 1, n):
            cnt += M[a, b]
    bi = np.empty(cnt, np.int64)
    bj = np.empty(cnt, np.int64)
    q = 0
    for a in range(n):
        for b in range(a + 1, n):
            if M[a, b]:
                bi[q] = a
                bj[q] = b
                q += 1
    return bi, bj


@_jit
def _corner_edges(nodes, bi, bj, corner, okb, reach, bound):
    """All candidate pairs ``a < b`` in lexicographic order: the base edges ``(bi, bj)``
    (lexicographic, collision-free flags ``okb``) and the pairs of ``corner`` nodes at most
    ``reach`` apart whose start-goal detour ``|s - a| + |a - b| + |b - g|`` (the shorter
    orientation) is at most ``bound``, merged row by row (a pair that is both is a base edge).
    Returns the pairs, their flags (the base flags, False for a corner pair) and the mask of
    the corner pairs (to be tested)."""
    n = nodes.shape[0]
    ds = np.empty(n)
    dg = np.empty(n)
    for v in range(n):
        ds[v] = math.hypot(nodes[v, 0] - nodes[0, 0], nodes[v, 1] - nodes[0, 1])
        dg[v] = math.hypot(nodes[v, 0] - nodes[1, 0], nodes[v, 1] - nodes[1, 1])
    r2 = reach * reach
    cidx = np.flatnonzero(corner)
    nc = cidx.shape[0]
    nbase = bi.shape[0]
    cap = nbase + nc * (nc - 1) // 2
    I = np.empty(cap, np.int64)
    J = np.empty(cap, np.int64)
    ok = np.zeros(cap, np.bool_)
    todo = np.zeros(cap, np.bool_)
    q = 0
    e = 0  # next base edge
    c0 = 0  # first corner node after a
    for a in range(n):
        while c0 < nc and cidx[c0] <= a:
            c0 += 1
        c = c0 if corner[a] else nc
        while True:
            b_base = bj[e] if e < nbase and bi[e] == a else n
            b_corn = cidx[c] if c < nc else n
            if b_base == n and b_corn == n:
                break
            if b_base <= b_corn:
                I[q] = a
                J[q] = b_base
                ok[q] = okb[e]
                e += 1
                q += 1
                if b_corn == b_base:
                    c += 1
                continue
            c += 1
            b = b_corn
            dx = nodes[a, 0] - nodes[b, 0]
            dy = nodes[a, 1] - nodes[b, 1]
            if dx * dx + dy * dy > r2:
                continue
            via = math.hypot(dx, dy) + min(ds[a] + dg[b], ds[b] + dg[a])
            if via <= bound:
                I[q] = a
                J[q] = b
                todo[q] = True
                q += 1
    return I[:q], J[:q], ok[:q], todo[:q]


@_jit
def _edge_lengths(nodes, i, j):
    """Length of each edge ``nodes[i[e]] -> nodes[j[e]]``."""
    out = np.empty(i.shape[0])
    for e in range(i.shape[0]):
        out[e] = math.hypot(nodes[i[e], 0] - nodes[j[e], 0], nodes[i[e], 1] - nodes[j[e], 1])
    return out


@_jit
def _csr(n, i, j, w):
    """Both directions of the undirected edges ``(i, j)`` (lengths ``w``) in CSR form, the
    edges of a node in the order of ``concat(i, j)`` (a stable sort by source)."""
    m = i.shape[0]
    indptr = np.zeros(n + 1, np.int64)
    for e in range(m):
        indptr[i[e] + 1] += 1
        indptr[j[e] + 1] += 1
    for v in range(n):
        indptr[v + 1] += indptr[v]
    fill = indptr[:-1].copy()
    target = np.empty(2 * m, np.int64)
    weight = np.empty(2 * m)
    pos = np.empty(2 * m, np.int64)  # the slot of each directed edge of concat(i, j)
    for e in range(m):
        q = fill[i[e]]
        fill[i[e]] += 1
        target[q] = j[e]
        weight[q] = w[e]
        pos[e] = q
    for e in range(m):
        q = fill[j[e]]
        fill[j[e]] += 1
        target[q] = i[e]
        weight[q] = w[e]
        pos[m + e] = q
    return indptr, target, weight, pos


def _roadmap_csr(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, Z: np.ndarray,
                 keys: np.ndarray) -> tuple[np.ndarray, ...]:
    """CSR arrays of :class:`Roadmap` (indptr, target, length, signature hash) of the free
    edges ``(i, j)``."""
    w = _edge_lengths(nodes, i, j)
    indptr, target, weight, pos = _csr(len(nodes), i, j, w)
    eh = _segment_hashes(nodes[i], nodes[j], Z, keys)
    ehash = np.empty(2 * len(i), np.int64)
    ehash[pos[:len(i)]] = eh
    ehash[pos[len(i):]] = -eh
    return indptr, target, weight, ehash


@_jit
def _dijkstra(indptr, target, weight, src):
    """Shortest distances from ``src`` over a CSR graph (``inf``: not reached)."""
    n = indptr.shape[0] - 1
    dist = np.full(n, np.inf)
    done = np.zeros(n, np.bool_)
    cap = target.shape[0] + 1
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    dist[src] = 0.0
    size = _heap_push(hk, hv, 0, 0.0, src)
    while size > 0:
        d, v, size = _heap_pop(hk, hv, size)
        if done[v]:
            continue
        done[v] = True
        for e in range(indptr[v], indptr[v + 1]):
            u = target[e]
            nd = d + weight[e]
            if nd < dist[u]:
                dist[u] = nd
                size = _heap_push(hk, hv, size, nd, u)
    return dist


def roadmap_corridors(space: SwarmSpace, n_paths: int, rng: np.random.Generator,
                      n_samples: int = 40, k_neighbours: int = 25,
                      boundary: int | None = None, medial: int | None = None,
                      slack: float = 1.1, node_classes: int = 20) -> list[np.ndarray]:
    """Collision-free start-goal paths of distinct homotopy classes from one sparse random
    roadmap (:func:`build_roadmap`; beyond the paper, no exact planner).

    * the ``n_paths`` shortest roadmap walks of distinct homotopy signatures
      (:func:`signature_hashes`; label setting, A*-ordered, at most ``node_classes``
      signatures per node), shortest first, none longer than ``slack`` x the shortest;

    Each walk is string-pulled (greedy, over nodes at most 8 apart; it can only shorten the
    walk).  A roadmap that does not connect start and goal gives no path.
    """
    g = build_roadmap(space, rng, n_samples, k_neighbours, boundary, medial, slack)
    if g is None or n_paths < 1:
        return []
    heur = g.to_goal()
    if not np.isfinite(heur[0]):  # start and goal are not connected
        return []
    goals, lab_node, lab_par = _k_classes(g.indptr, g.target, g.weight, g.ehash, heur, 0, 1,
                                          int(n_paths), int(min(n_paths, node_classes)),
                                          float(slack))
    walks = [g.walk(int(lab), lab_node, lab_par) for lab in goals]
    if not walks:
        return []
    pts, off = _flat(walks)
    pts, off = _pull(pts, off, space, 8)[:2]
    return [pts[off[i]:off[i + 1]] for i in range(len(walks))]


def signature_hashes_list(paths: list[np.ndarray], space: SwarmSpace) -> np.ndarray:
    """:func:`signature_hashes` of polylines of different lengths."""
    if not paths:
        return np.zeros(0, np.int64)
    M = max(len(p) for p in paths)
    return signature_hashes(np.array([np.vstack([p, np.repeat(p[-1:], M - len(p), axis=0)])
                                      for p in paths]), space)


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
    """Mutable state of one swarm run (positions, velocities, memories, bookkeeping).

    ``stats`` holds the backend's public counters (reported in ``extras["per_robot"]``);
    ``final_path`` is an answer that is not a particle (e.g. a tightened path with more
    vertices than ``n_waypoints``), set by a backend's :meth:`SwarmBackend._finish`.
    """

    X: np.ndarray
    V: np.ndarray
    F: np.ndarray
    pbest: np.ndarray
    pbest_f: np.ndarray
    gbest: np.ndarray
    gbest_f: float
    gbest_count: int
    feas_len: float = math.inf
    feas_x: np.ndarray | None = None
    n_eval: int = 0
    final_path: np.ndarray | None = None
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
                    gbest_count=int(ev.count[j]), n_eval=len(X))
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
        disables the clamp.  Not in the paper.
    bounds_mode : {"reflect", "clip", "random"}
        Handling of coordinates that leave the map (see module docstring).
    init_mode : {"sorted", "uniform", "line", "roadmap"}
        Initial swarm (see module docstring).
    penalty_weight : float or None
        ``delta`` of eq 32 per crossing, in units of the problem's ``length_scale`` (map units
        on the paper's maps, where it is 1); ``None`` = ``(n_waypoints + 1) * diag``, the
        smallest round value making every collision-free path beat every colliding one.
    penetration_weight : float
        Weight of the inside-obstacle length added to the fitness (beyond the paper; 0 in the
        ``-paper`` presets).
    roadmap_samples, roadmap_boundary, roadmap_medial : int
        Beyond the paper, the roadmap of ``init_mode = "roadmap"`` (:func:`build_roadmap`):
        uniform samples, obstacle-based samples (half along the boundary edges, half around
        the corners, :func:`boundary_samples`) and medial-axis retractions
        (:func:`medial_samples`).
    roadmap_neighbours : int
        Nearest neighbours each roadmap node is connected to (besides its Yao edges and the
        pairs of corner nodes); 0 connects every pair of nodes.
    corridors : int
        Homotopy classes taken from the roadmap (beyond the paper): its ``corridors`` shortest
        walks of distinct classes (:func:`roadmap_corridors`); the shortest seed the particles
        (one per island of ``ipso``), ``ipso``'s end-game compares all of them.
    """

    name: ClassVar[str] = "swarm"

    n_particles: int = option(50, lo=2, hi=100_000)
    k_max: int = option(200, lo=0, hi=1_000_000)
    c1: float = option(1.5, lo=0.0, hi=10.0)
    c2: float = option(1.5, lo=0.0, hi=10.0)
    n_waypoints: int = option(4, lo=1, hi=200)
    v_max: float = option(0.2, lo=0.0, lo_open=True, inf_ok=True)
    bounds_mode: str = option("reflect", choices=BOUNDS_MODES)
    init_mode: str = option("sorted", choices=INIT_MODES)
    penalty_weight: float | None = option(None, lo=0.0, scale=True)
    penetration_weight: float = option(0.0, lo=0.0)
    roadmap_samples: int = option(40, lo=0, hi=100_000)
    roadmap_boundary: int = option(360, lo=0, hi=100_000)
    roadmap_medial: int = option(200, lo=0, hi=100_000)
    roadmap_neighbours: int = option(25, lo=0, hi=100_000)
    corridors: int = option(30, lo=1, hi=1000)

    # -- hooks for subclasses ------------------------------------------------------
    def _start(self, space: SwarmSpace, state: SwarmState, seeds: list[np.ndarray],
               rng: np.random.Generator) -> Any:
        """Called once after the initial evaluation; returns the backend's per-run object
        (constants and algorithm state), passed to :meth:`_iterate` and :meth:`_finish`.
        ``seeds`` are the roadmap corridors (``init_mode = "roadmap"``, else empty)."""
        return None

    def _iterate(self, space: SwarmSpace, state: SwarmState, run: Any, k: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        """One iteration ``k`` (1-based); returns extra history columns."""
        raise NotImplementedError

    def _finish(self, space: SwarmSpace, state: SwarmState, run: Any,
                rng: np.random.Generator):
        """Optional steps after the ``k_max`` iterations (a generator of history columns).

        Each yielded dict adds one history row (numbered on from ``k_max``); these rows are not
        counted in ``Result.n_iter``.
        """
        return iter(())

    def _stats(self, run: Any) -> dict[str, Any]:
        """The backend's public per-robot counters of a run (``extras["per_robot"]``)."""
        return {}

    # -- shared helpers --------------------------------------------------------------
    def _vmax(self, space: SwarmSpace) -> np.ndarray:
        """Velocity clamp per coordinate (``inf`` everywhere when there is none)."""
        if math.isinf(self.v_max):
            return np.full(space.dim, math.inf)
        return self.v_max * space.span

    def _initial(self, space: SwarmSpace, init_path: np.ndarray | None,
                 rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
        """Initial positions and the roadmap corridors that seeded some of them."""
        X = initial_swarm(space, self.n_particles, self.init_mode, rng)
        seeds: list[np.ndarray] = []
        if self.init_mode == "roadmap":
            seeds = roadmap_corridors(space, self.corridors, rng, n_samples=self.roadmap_samples,
                                      k_neighbours=self.roadmap_neighbours,
                                      boundary=self.roadmap_boundary,
                                      medial=self.roadmap_medial)
            blocks = self._seed_blocks(len(seeds))
            for i, pth in enumerate(seeds[:blocks]):  # one per block of particles
                X[i * self.n_particles // blocks] = as_particle(pth, space)
        if init_path is not None and len(init_path) >= 2:
            X[0] = as_particle(init_path, space)
        return X, seeds

    def _seed_blocks(self, n_seeds: int) -> int:
        """How many roadmap corridors the initial swarm holds (one per block of consecutive
        particles): all of them, at most one per particle."""
        return min(n_seeds, self.n_particles)

    # -- the driver --------------------------------------------------------------------
    def _run_robot(self, problem: Problem, robot: Robot, rng: np.random.Generator,
                   init_path: np.ndarray | None, callback, t0: float, it_offset: int):
        pw = self.penalty_weight
        space = make_space(problem, robot, self.n_waypoints,
                           penalty_weight=None if pw is None else pw * problem.length_scale,
                           penetration_weight=self.penetration_weight)
        X, seeds = self._initial(space, init_path, rng)
        V = np.zeros_like(X)
        ev = evaluate_swarm(X, space)
        state = new_state(X, V, ev)
        run = self._start(space, state, seeds, rng)
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
            extra = self._iterate(space, state, run, k, rng)
            stopped = record(k, extra)
        iterations = k
        state.stats.update(self._stats(run))
        if not stopped:
            for extra in self._finish(space, state, run, rng):
                k += 1
                if record(k, extra):
                    stopped = True
                    break
        return space, state, rows, stopped, iterations

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
            space, st, rows, stopped, iters = self._run_robot(view, robot, rng, ip, callback,
                                                              t0, n_iter)
            all_rows.append(rows)
            n_eval += st.n_eval
            n_iter += iters
            stopped_any |= stopped
            # the answer: a final path (end-game), else the best collision-free particle ever
            # seen, else gbest
            ok = st.final_path is not None or st.feas_x is not None
            all_ok &= ok
            if st.final_path is not None:
                paths[robot.id] = st.final_path
            else:
                x = st.feas_x if st.feas_x is not None else st.gbest
                paths[robot.id] = decode(x[None], space)[0]
            # over the swarm iterations (a final tightening row is not an iteration)
            best = np.array([r["best_cost"] for r in rows[:iters + 1]])
            cost += st.feas_len if ok else st.gbest_f
            per_robot[robot.id] = {
                "converged_iteration": converged_iteration(best),
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
