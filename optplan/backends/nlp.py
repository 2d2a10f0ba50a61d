r"""Exact waypoint NLP (CasADi + IPOPT): a local optimum of path length with whole-segment
collision constraints (domain-notes §2.3).

Mathematics
-----------
Decision variables are the interior waypoints :math:`p_1, \dots, p_{N-1}` of a polyline with
:math:`N` segments; :math:`p_0` = start and :math:`p_N` = goal are fixed, every waypoint lies in
the map bounds.  The objective is the smoothed length plus a tiny spacing regulariser

.. math::

    f(p) = \sum_{i=0}^{N-1} \sqrt{\lVert \Delta_i \rVert^2 + \varepsilon^2}
           + w N \sum_{i=1}^{N-1} \lVert \Delta_i - \Delta_{i-1} \rVert^2 ,
    \qquad \Delta_i = p_{i+1} - p_i ,

(coordinates normalised by the map diagonal, so :math:`\varepsilon` and :math:`w` are
dimensionless); the *reported* length is the plain polyline length.

Collision avoidance is imposed on whole segments.  Every obstacle is cut into convex pieces
:math:`O_j = \mathrm{conv}\{v_{j1}, \dots, v_{jm}\}` with a clearance :math:`d_j`; for every
kept (segment :math:`i`, piece :math:`j`) pair there is a separating hyperplane
:math:`(a_{ij}, c_{ij})`:

.. math::

    a_{ij}^\top v_{jk} \le c_{ij} \;\; \forall k, \qquad
    a_{ij}^\top p_i \ge c_{ij} + d_j, \qquad a_{ij}^\top p_{i+1} \ge c_{ij} + d_j, \qquad
    \lVert a_{ij} \rVert^2 \le 1 .

Because :math:`a^\top y - c` is affine and :math:`\lVert a \rVert \le 1`, it is a lower bound
of :math:`\mathrm{dist}(y, O_j)`; holding at both endpoints it holds on the whole segment.
Conversely two convex sets at distance :math:`\ge d` admit such a hyperplane, so the
constraint is *exact* for convex pieces (domain-notes §2.3 (b)-(c), OBCA duality).  A disc
(centre :math:`o`, radius :math:`R`) is the one-vertex piece :math:`\{o\}` with clearance
:math:`R + d`: :math:`a^\top (p - o) \ge R + d`.

Clearance modes
    ``"exact"`` (default) uses the raw obstacles with clearance = robot radius (discs natively):
    the true disc-robot problem, with 3-5 vertices per piece, well conditioned and fast.  Its
    paths are always accepted by the validator, whose inflated polygons are inscribed in the true
    Minkowski sum; its optimum is slightly longer than the ``visgraph`` optimum on those polygons
    (measured 0.009-0.012 % on the paper maps).  ``"inscribed"`` uses the validator's own map: the
    robot-radius round buffer (shapely, ``quad_segs = 8``, merged where obstacles overlap,
    :meth:`Problem.inflated`) cut into convex pieces, with zero extra clearance; it compares
    like with like with ``visgraph`` but has ~36 vertices per piece (3-10x slower).  Both add
    ``margin`` and a numerical safety of ``1e-6`` x map diagonal.

Convex decomposition
    Non-convex polygons (and merged inflated unions, holes included) are triangulated with
    :func:`shapely.constrained_delaunay_triangles` and the triangles greedily merged across
    shared edges while the union stays convex (Hertel-Mehlhorn style).

Pair pruning
    Only pairs whose piece lies within ``prune_distance`` (fraction of the map diagonal) of the
    *initial* segment, beyond the piece's clearance, are constrained.  After each solve every
    (segment, piece) distance is checked exactly (shapely); a violated pruned pair is added (with
    the pairs near the new segments) and the NLP re-solved, up to ``max_rounds`` solves; the
    last one constrains every pair.  A re-solve starts from the previous round's solution
    (``resolve_from = "last"``, default: it already satisfies the kept pairs, so IPOPT only
    clears the added ones; from overlapping heuristic guesses this halves the iterations and
    more often keeps the optimal homotopy class) or from the initial guess again (``"init"``).
    If the shared validator still objects, all pairs are added.

Structure re-use
    The NLP is built once per structure ``(N, slots per segment, vertices per slot, IPOPT
    options)`` with ``casadi.nlpsol`` on SX symbols (``expand = True``); the piece vertices are
    *parameters*, the clearances and the on/off state of each slot and vertex row are constraint
    *bounds*.  Different maps, seeds and warm starts therefore re-use one compiled solver.

Warm start
    ``init`` (any path, e.g. an IPSO or visgraph result) keeps all its vertices and gains
    collinear points on its longest segments, proportionally to arc length, until it has ``N``
    segments (``N = max(n_segments, len(init) - 1)``).  Hyperplanes start at the unit normal of
    the nearest points (:func:`shapely.shortest_line`) with ``c`` = the piece's support value.
    Without ``init`` the start is the ``visgraph`` path (``init_from = "visgraph"``) or the
    straight line (``"straight"``).  IPOPT is local: the homotopy class is the initial guess's.

Statuses
    IPOPT ``Solve_Succeeded`` and validator pass -> ``optimal`` (a KKT point: locally optimal in
    the initial guess's homotopy class); acceptable level / iteration or time limit / user stop
    with a feasible path -> ``solved``; IPOPT infeasibility or failure -> ``approximate`` with the
    IPOPT message; start or goal inside an obstacle, or no path at all (visgraph) ->
    ``infeasible``.  Guard: with a caller's ``init``, if IPOPT returns a path that the validator
    rejects or that is longer, the (validator-feasible) initial guess is returned instead, as
    ``solved`` with a message; the NLP's own length stays in ``extras``.  (The backend's own
    visgraph start is not guarded: its result is the NLP optimum, reported as is.)
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from optplan.metrics import evaluate
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Result, Status, notify
from optplan.solver import Backend, check_choice, check_int, check_range

__all__ = [
    "WaypointNLP",
    "Pieces",
    "convex_decompose",
    "obstacle_pieces",
    "resample_path",
    "select_pairs",
    "init_hyperplanes",
    "objective_function",
    "solve_waypoint_nlp",
    "NLPOutcome",
]

#: numerical safety added to every clearance, as a fraction of the map diagonal.
SAFETY_REL = 1e-6
#: hard cap on the number of segments (longer initial guesses are resampled by arc length).
MAX_SEGMENTS = 400

_SUCCESS = {"Solve_Succeeded"}
_SOLVED = {
    "Solved_To_Acceptable_Level",
    "Maximum_Iterations_Exceeded",
    "Maximum_CpuTime_Exceeded",
    "Maximum_WallTime_Exceeded",
    "User_Requested_Stop",
    "Search_Direction_Becomes_Too_Small",
    "Feasible_Point_Found",
}


# --------------------------------------------------------------------------------------
# geometry: convex pieces
# --------------------------------------------------------------------------------------


def _ring(poly: Polygon) -> np.ndarray:
    """CCW exterior vertices without the closing repeat."""
    return np.asarray(orient(poly, 1.0).exterior.coords)[:-1]


def _is_convex(ring: np.ndarray, rel_tol: float = 1e-12) -> bool:
    """True when a CCW ring has no right turn (collinear vertices allowed)."""
    a = ring - np.roll(ring, 1, axis=0)
    b = np.roll(ring, -1, axis=0) - ring
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    scale = np.hypot(a[:, 0], a[:, 1]) * np.hypot(b[:, 0], b[:, 1])
    return bool(np.all(cross >= -rel_tol * np.maximum(scale, 1e-300)))


def _drop_collinear(ring: np.ndarray, rel_tol: float = 1e-12) -> np.ndarray:
    a = ring - np.roll(ring, 1, axis=0)
    b = np.roll(ring, -1, axis=0) - ring
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    scale = np.hypot(a[:, 0], a[:, 1]) * np.hypot(b[:, 0], b[:, 1])
    keep = np.abs(cross) > rel_tol * np.maximum(scale, 1e-300)
    return ring[keep] if keep.sum() >= 3 else ring


def convex_decompose(poly: Polygon) -> list[np.ndarray]:
    """Cut a polygon (holes allowed) into convex pieces; CCW vertex arrays ``(m, 2)``.

    A convex polygon without holes is returned as one piece.  Otherwise the polygon is
    triangulated (:func:`shapely.constrained_delaunay_triangles`, whose triangles use the
    polygon's own vertices) and triangles are merged greedily across shared edges while the
    merged ring stays convex (Hertel-Mehlhorn style: at most 4x the minimum piece count).
    """
    poly = orient(poly, 1.0)
    ring = _ring(poly)
    if not poly.interiors and _is_convex(ring):
        return [_drop_collinear(ring)]
    tris = shapely.constrained_delaunay_triangles(poly)
    rings: dict[int, list[tuple[float, float]]] = {}
    for k, t in enumerate(getattr(tris, "geoms", [])):
        if t.area <= 0:
            continue
        rings[k] = [tuple(map(float, v)) for v in _ring(t)]
    owner: dict[tuple, int] = {}
    for k, r in rings.items():
        for u, v in zip(r, r[1:] + r[:1]):
            owner[(u, v)] = k
    changed = True
    while changed:
        changed = False
        for k in sorted(rings, key=lambda q: -len(rings[q])):
            if k not in rings:
                continue
            r = rings[k]
            for u, v in zip(r, r[1:] + r[:1]):
                q = owner.get((v, u))
                if q is None or q == k:
                    continue
                rq = rings[q]
                ia = r.index(v)
                a_part = r[ia:] + r[:ia]           # v ... u
                ib = rq.index(u)
                b_part = rq[ib:] + rq[:ib]         # u ... v
                merged = a_part + b_part[1:-1]
                arr = np.asarray(merged)
                if not _is_convex(arr):
                    continue
                for x, y in zip(r, r[1:] + r[:1]):
                    owner.pop((x, y), None)
                for x, y in zip(rq, rq[1:] + rq[:1]):
                    owner.pop((x, y), None)
                del rings[q]
                rings[k] = merged
                for x, y in zip(merged, merged[1:] + merged[:1]):
                    owner[(x, y)] = k
                changed = True
                break
    return [_drop_collinear(np.asarray(r)) for r in rings.values()]


@dataclass(frozen=True, eq=False)
class Pieces:
    """Convex obstacle pieces for the NLP.

    Attributes
    ----------
    verts : list of (m_j, 2) arrays
        Vertices of each convex piece (a disc is its single centre vertex).
    clear : (J,) array
        Required distance from each piece (robot radius, disc radius, margin, safety).
    geoms : (J,) array of shapely geometries
        The piece as a Polygon (or a Point for a disc), for exact distance checks.
    names : list of str
        Obstacle name(s) each piece comes from.
    """

    verts: list[np.ndarray]
    clear: np.ndarray
    geoms: np.ndarray
    names: list[str]

    @property
    def n(self) -> int:
        return len(self.verts)

    @property
    def max_verts(self) -> int:
        return max((len(v) for v in self.verts), default=1)


def obstacle_pieces(problem: Problem, robot: Robot, *, mode: str = "inscribed",
                    known_only: bool = True, margin: float = 0.0) -> Pieces:
    """Convex pieces and clearances for ``robot`` (cached on the problem).

    ``mode = "inscribed"``: pieces of the validator's inflated map with zero clearance;
    ``"exact"``: raw obstacles with clearance = robot radius (discs natively).  Both add
    ``margin`` and ``SAFETY_REL * problem.extent``.
    """
    key = ("nlp_pieces", mode, round(float(robot.radius), 12), known_only, float(margin))
    if key in problem._cache:
        return problem._cache[key]
    safety = SAFETY_REL * problem.extent
    verts, clear, geoms, names = [], [], [], []
    if mode == "inscribed":
        imap = problem.inflated(robot.radius, known_only=known_only)
        for part, nm in zip(imap.parts, imap.names):
            for v in convex_decompose(part):
                verts.append(v)
                clear.append(margin + safety)
                geoms.append(Polygon(v))
                names.append("+".join(nm))
    elif mode == "exact":
        for o in problem.static_obstacles(known_only):
            if o.is_circle:
                verts.append(np.asarray(o.center, float)[None, :])
                clear.append(float(o.radius) + robot.radius + margin + safety)
                geoms.append(shapely.Point(o.center))
                names.append(o.name)
            else:
                for v in convex_decompose(o.geometry):
                    verts.append(v)
                    clear.append(robot.radius + margin + safety)
                    geoms.append(Polygon(v))
                    names.append(o.name)
    else:
        raise ValueError(f"clearance mode must be 'inscribed' or 'exact', got {mode!r}")
    out = Pieces(verts, np.asarray(clear, float), np.asarray(geoms, dtype=object), names)
    problem._cache[key] = out
    return out


# --------------------------------------------------------------------------------------
# paths, pairs, hyperplane warm start
# --------------------------------------------------------------------------------------


def resample_path(path: np.ndarray, n_segments: int) -> np.ndarray:
    """Polyline with exactly ``n_segments`` segments through every vertex of ``path``.

    Consecutive duplicates are dropped; each original segment is split into ``m_s >= 1`` equal
    parts with ``m_s`` proportional to its length (largest remainder).  If the path has more
    segments than ``n_segments`` it is resampled uniformly by arc length instead.
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) > 1:
        d = np.hypot(*np.diff(p, axis=0).T)
        p = np.vstack([p[0], p[1:][d > 0]]) if np.any(d > 0) else p[:1]
    if len(p) == 1:
        p = np.vstack([p, p])
    seg = np.hypot(*np.diff(p, axis=0).T)
    S = len(seg)
    if S > n_segments:
        s = np.r_[0.0, np.cumsum(seg)]
        t = np.linspace(0.0, s[-1], n_segments + 1)
        return np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], axis=1)
    extra = n_segments - S
    tot = seg.sum()
    share = extra * seg / tot if tot > 0 else np.full(S, extra / S)
    m = 1 + np.floor(share).astype(int)
    rem = n_segments - m.sum()
    if rem > 0:
        order = np.argsort(-(share - np.floor(share)), kind="stable")
        m[order[:rem]] += 1
    out = [p[0]]
    for k in range(S):
        f = np.arange(1, m[k] + 1)[:, None] / m[k]
        out.extend(p[k] + f * (p[k + 1] - p[k]))
    return np.asarray(out)


def _segments(path: np.ndarray) -> np.ndarray:
    return shapely.linestrings(np.stack([path[:-1], path[1:]], axis=1))


def pair_distances(path: np.ndarray, pieces: Pieces) -> np.ndarray:
    """``(N, J)`` distance from each segment to each piece minus the piece's clearance."""
    if pieces.n == 0:
        return np.zeros((len(path) - 1, 0))
    d = shapely.distance(_segments(path)[:, None], pieces.geoms[None, :])
    return d - pieces.clear[None, :]


def select_pairs(path: np.ndarray, pieces: Pieces, prune: float) -> np.ndarray:
    """Boolean ``(N, J)`` mask of pairs whose slack ``dist - clearance`` is ``<= prune``."""
    return pair_distances(path, pieces) <= prune


def init_hyperplanes(path: np.ndarray, pieces: Pieces, seg: np.ndarray,
                     piece: np.ndarray, clear: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Initial ``(a, c)`` for the pairs ``(seg[k], piece[k])``.

    ``a`` = unit vector from the piece's nearest point to the segment's nearest point
    (:func:`shapely.shortest_line`); if they touch or overlap, from the piece's centroid to the
    segment midpoint.  ``c`` = max over the piece's vertices of ``a . v`` (the support value);
    with ``clear`` (per-piece clearances) ``c`` is moved to the middle of the slack between
    the support value and the segment's nearer endpoint, when there is any.
    """
    K = len(seg)
    if K == 0:
        return np.zeros((0, 2)), np.zeros(0)
    lines = _segments(path)[seg]
    sl = shapely.shortest_line(pieces.geoms[piece], lines)
    c = shapely.get_coordinates(sl).reshape(K, 2, 2)
    a = c[:, 1] - c[:, 0]
    n = np.hypot(a[:, 0], a[:, 1])
    bad = n < 1e-12
    if np.any(bad):
        cen = shapely.get_coordinates(shapely.centroid(pieces.geoms[piece[bad]]))
        mid = 0.5 * (path[seg[bad]] + path[seg[bad] + 1])
        a[bad] = mid - cen
        n[bad] = np.hypot(a[bad, 0], a[bad, 1])
        still = n < 1e-12
        a[still] = [1.0, 0.0]
        n[still] = 1.0
    a = a / n[:, None]
    support = np.array([np.max(pieces.verts[j] @ a[k]) for k, j in enumerate(piece)])
    if clear is None:
        return a, support
    # put the hyperplane in the middle of the gap, so that neither side starts at zero slack
    near = np.minimum(np.sum(a * path[seg], axis=1), np.sum(a * path[seg + 1], axis=1))
    gap = near - clear[piece] - support
    return a, support + 0.5 * np.maximum(gap, 0.0)


# --------------------------------------------------------------------------------------
# CasADi model
# --------------------------------------------------------------------------------------


def _length_terms(P: Any, eps: Any, w: Any, n_seg: int):
    """Smoothed length and spacing regulariser of a casadi ``(n_seg + 1, 2)`` point matrix."""
    import casadi as ca

    D = P[1:, :] - P[:-1, :]
    length = ca.sum1(ca.sqrt(ca.sum2(D * D) + eps**2))
    if n_seg > 1:
        DD = D[1:, :] - D[:-1, :]
        reg = w * n_seg * ca.sum1(ca.sum2(DD * DD))
    else:
        reg = 0
    return length, reg


@functools.lru_cache(maxsize=16)
def objective_function(n_points: int):
    """CasADi function ``(P (n_points, 2), eps, w) -> (smoothed length, regulariser)``.

    The expression the NLP minimises (in normalised units); exported for the twin test.
    """
    import casadi as ca

    P = ca.SX.sym("P", n_points, 2)
    eps = ca.SX.sym("eps")
    w = ca.SX.sym("w")
    L, R = _length_terms(P, eps, w, n_points - 1)
    return ca.Function("waypoint_length", [P, eps, w], [L, R], ["P", "eps", "w"], ["L", "R"])


class _IterCallback:
    """Factory of a casadi iteration callback forwarding to a Python target (set per solve)."""

    @staticmethod
    def make(nx: int, ng: int, np_: int):
        import casadi as ca

        class CB(ca.Callback):
            def __init__(self):
                ca.Callback.__init__(self)
                self.target: Callable[[float], bool] | None = None
                self.construct("optplan_nlp_iter", {})

            def get_n_in(self):
                return ca.nlpsol_n_out()

            def get_n_out(self):
                return 1

            def get_name_in(self, i):
                return ca.nlpsol_out(i)

            def get_name_out(self, i):
                return "ret"

            def get_sparsity_in(self, i):
                name = ca.nlpsol_out(i)
                if name == "f":
                    return ca.Sparsity.scalar()
                if name in ("x", "lam_x"):
                    return ca.Sparsity.dense(nx)
                if name in ("g", "lam_g"):
                    return ca.Sparsity.dense(ng)
                if name == "lam_p":
                    return ca.Sparsity.dense(np_)
                return ca.Sparsity(0, 0)

            def eval(self, arg):
                stop = False
                if self.target is not None:
                    stop = bool(self.target(float(arg[ca.nlpsol_out().index("f")])))
                return [1 if stop else 0]

        return CB()


@dataclass
class _Built:
    solver: Any
    n_seg: int
    n_slots: int
    n_verts: int
    nx: int
    ng: int
    callback: Any = None


@functools.lru_cache(maxsize=24)
def _build(n_seg: int, n_slots: int, n_verts: int, ipopt_opts: tuple,
           with_callback: bool) -> _Built:
    """Build the waypoint NLP for a structure (segments, slots per segment, vertices per slot).

    Variables ``x = [interior waypoints (N-1)x2 row-major, a (N*K*2), c (N*K)]``; parameters
    ``[start, goal, eps, w, vertices (N*K*V*2)]``; constraint rows per slot ``(i, k)``: ``V``
    vertex rows ``a.v - c`` (upper bound 0), two endpoint rows ``a.p - c`` (lower bound =
    clearance), one ``|a|^2`` row (upper bound 1).  Unused slots / padded vertices get infinite
    bounds (and fixed ``a = c = 0``), so one build serves every map with this structure.
    """
    import casadi as ca

    N, K, V = n_seg, n_slots, n_verts
    W = ca.SX.sym("W", max(N - 1, 0) * 2)
    A = ca.SX.sym("A", N * K * 2)
    C = ca.SX.sym("C", N * K)
    start = ca.SX.sym("start", 2)
    goal = ca.SX.sym("goal", 2)
    eps = ca.SX.sym("eps")
    w = ca.SX.sym("w")
    rho = ca.SX.sym("rho")
    Vp = ca.SX.sym("V", N * K * V * 2)
    rows = [start.T]
    for i in range(N - 1):
        rows.append(W[2 * i: 2 * i + 2].T)
    rows.append(goal.T)
    P = ca.vertcat(*rows)
    L, R = _length_terms(P, eps, w, N)
    g = []
    margin_sum = 0
    for i in range(N):
        p0, p1 = P[i, :].T, P[i + 1, :].T
        for k in range(K):
            s = i * K + k
            a = A[2 * s: 2 * s + 2]
            c = C[s]
            vv = ca.reshape(Vp[s * V * 2: (s + 1) * V * 2], 2, V).T  # (V, 2)
            g.append(ca.mtimes(vv, a) - c)
            g.append(ca.dot(a, p0) - c)
            g.append(ca.dot(a, p1) - c)
            g.append(ca.dot(a, a))
            margin_sum += 0.5 * (ca.dot(a, p0 + p1)) - c
    gexpr = ca.vertcat(*g) if g else ca.SX(0, 1)
    x = ca.vertcat(W, A, C)
    p = ca.vertcat(start, goal, eps, w, rho, Vp)
    nlp = {"x": x, "p": p, "f": L + R - rho * margin_sum, "g": gexpr}
    ip = dict(ipopt_opts)
    opts: dict[str, Any] = {"expand": True, "print_time": False, "error_on_fail": False,
                            "ipopt": ip}
    cb = None
    if with_callback:
        cb = _IterCallback.make(x.numel(), gexpr.numel(), p.numel())
        opts["iteration_callback"] = cb
    solver = ca.nlpsol("waypoint_nlp", "ipopt", nlp, opts)
    return _Built(solver, N, K, V, int(x.numel()), int(gexpr.numel()), cb)


def _bucket(n: int, step: int) -> int:
    return max(step, int(math.ceil(n / step)) * step)


# --------------------------------------------------------------------------------------
# one NLP solve (pure function) and the multi-round driver
# --------------------------------------------------------------------------------------


@dataclass
class NLPOutcome:
    """What :func:`solve_waypoint_nlp` returns (map units)."""

    path: np.ndarray
    length: float
    return_status: str
    success: bool
    iterations: int
    rounds: int
    n_pairs: int
    pruned: int
    solve_time: float
    build_time: float
    stats: list[dict]
    stopped: bool = False
    violation: float = 0.0


def _solve_once(path0: np.ndarray, pieces: Pieces, mask: np.ndarray, *, origin: np.ndarray,
                scale: float, bounds, eps: float, w: float, rho: float, ipopt_opts: tuple,
                on_iter: Callable[[float], bool] | None) -> tuple[np.ndarray, dict, float]:
    """One IPOPT solve from ``path0`` with the pairs in ``mask``; returns (path, stats, build)."""
    N = len(path0) - 1
    seg, piece = np.nonzero(mask)
    counts = np.bincount(seg, minlength=N)
    K = _bucket(int(counts.max()) if len(seg) else 0, 2)
    V = _bucket(max((len(pieces.verts[j]) for j in set(piece.tolist())), default=1), 4)
    tb = time.perf_counter()
    built = _build(N, K, V, ipopt_opts, on_iter is not None)
    build_time = time.perf_counter() - tb
    u = (path0 - origin) / scale
    # slot assignment: k-th pair of segment i -> slot (i, k)
    order = np.argsort(seg, kind="stable")
    seg, piece = seg[order], piece[order]
    first = np.r_[0, np.cumsum(counts)[:-1]]
    slot = np.arange(len(seg)) - first[seg]
    sidx = seg * K + slot
    a0, c0 = init_hyperplanes(path0, pieces, seg, piece, pieces.clear)
    c0n = (c0 - a0 @ origin) / scale  # a.x - c in normalised coordinates: c' = (c - a.o)/s
    Vt = np.zeros((N * K, V, 2))
    vmask = np.zeros((N * K, V), bool)
    for s, j in zip(sidx, piece):
        vj = (pieces.verts[j] - origin) / scale
        Vt[s, : len(vj)] = vj
        Vt[s, len(vj):] = vj[-1]
        vmask[s, : len(vj)] = True
    active = np.zeros(N * K, bool)
    active[sidx] = True
    clear = np.zeros(N * K)
    clear[sidx] = pieces.clear[piece] / scale
    # bounds on x
    x0b, y0b, x1b, y1b = bounds
    lo = (np.array([x0b, y0b]) - origin) / scale
    hi = (np.array([x1b, y1b]) - origin) / scale
    nW = max(N - 1, 0)
    lbx = np.r_[np.tile(lo, nW), np.full(N * K * 2, -1.0), np.full(N * K, -np.inf)]
    ubx = np.r_[np.tile(hi, nW), np.full(N * K * 2, 1.0), np.full(N * K, np.inf)]
    off = 2 * nW
    inact = np.flatnonzero(~active)
    for d in (0, 1):
        lbx[off + 2 * inact + d] = 0.0
        ubx[off + 2 * inact + d] = 0.0
    lbx[off + 2 * N * K + inact] = 0.0
    ubx[off + 2 * N * K + inact] = 0.0
    A0 = np.zeros((N * K, 2))
    C0 = np.zeros(N * K)
    A0[sidx] = a0
    C0[sidx] = c0n
    x0 = np.r_[np.clip(u[1:-1], lo, hi).ravel(), A0.ravel(), C0]
    # constraint bounds, rows per slot: V vertex rows, 2 endpoint rows, 1 norm row
    R = V + 3
    lbg = np.full((N * K, R), -np.inf)
    ubg = np.full((N * K, R), np.inf)
    ubg[:, :V] = np.where(vmask, 0.0, np.inf)
    lbg[:, V] = np.where(active, clear, -np.inf)
    lbg[:, V + 1] = np.where(active, clear, -np.inf)
    ubg[:, V + 2] = np.where(active, 1.0, np.inf)
    par = np.r_[u[0], u[-1], eps, w, rho, Vt.reshape(N * K, V * 2).ravel()]
    if built.callback is not None:
        built.callback.target = on_iter
    sol = built.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg.ravel(), ubg=ubg.ravel(), p=par)
    if built.callback is not None:
        built.callback.target = None
    st = dict(built.solver.stats())
    xs = np.asarray(sol["x"]).ravel()
    if not np.all(np.isfinite(xs)):
        xs = x0
        st["return_status"] = st.get("return_status", "") + " (non-finite iterate)"
        st["success"] = False
    Wsol = xs[: 2 * nW].reshape(nW, 2)
    un = np.vstack([u[0], Wsol, u[-1]])
    out = un * scale + origin
    out[0], out[-1] = path0[0], path0[-1]
    info = {k: st.get(k) for k in ("return_status", "success", "iter_count")}
    info.update(t_wall=sum(float(v) for k, v in st.items() if k.startswith("t_wall_")),
                n_pairs=int(len(seg)), slots=K, verts=V, n_seg=N, build_time=build_time)
    return out, info, build_time


def solve_waypoint_nlp(
    problem: Problem,
    robot: Robot,
    init_path: np.ndarray,
    *,
    n_segments: int = 20,
    mode: str = "exact",
    known_only: bool = True,
    margin: float = 0.0,
    prune_distance: float = 0.05,
    max_rounds: int = 4,
    eps: float = 1e-4,
    spacing_weight: float = 1e-4,
    hyperplane_weight: float = 0.0,
    resolve_from: str = "last",
    ipopt_options: dict | None = None,
    on_iter: Callable[[float], bool] | None = None,
) -> NLPOutcome:
    """Solve the waypoint NLP for ``robot`` from ``init_path`` (map units in and out).

    Multi-round: solve with the pruned pairs, check every (segment, piece) distance exactly,
    add the violated pairs (and those near the new segments) and re-solve (at most
    ``max_rounds`` solves), from the previous round's solution (``resolve_from = "last"``) or
    from the initial guess (``"init"``).
    ``on_iter(f)`` is called every IPOPT iteration; returning True stops IPOPT.
    """
    pieces = obstacle_pieces(problem, robot, mode=mode, known_only=known_only, margin=margin)
    x0, y0, _, _ = problem.bounds
    origin = np.array([x0, y0], float)
    scale = problem.extent
    p = np.asarray(init_path, float).reshape(-1, 2)
    if not np.allclose(p[0], robot.start):
        p = np.vstack([robot.start, p])
    if robot.goal is not None and not np.allclose(p[-1], robot.goal):
        p = np.vstack([p, robot.goal])
    n_eff = min(max(n_segments, len(p) - 1), MAX_SEGMENTS)
    path = resample_path(p, n_eff)
    path[0], path[-1] = robot.start, robot.goal
    opts = tuple(sorted((ipopt_options or {}).items()))
    prune_abs = prune_distance * scale if math.isfinite(prune_distance) else np.inf
    mask = select_pairs(path, pieces, prune_abs) if pieces.n else np.zeros((n_eff, 0), bool)
    stats: list[dict] = []
    build = solve_t = 0.0
    iters = 0
    status, success = "not_run", False
    tol_chk = 0.5 * SAFETY_REL * scale
    stopped = False
    viol = 0.0
    rounds = 0
    full = False
    start_path = path
    while rounds < max_rounds:
        rounds += 1
        t0 = time.perf_counter()
        new, info, bt = _solve_once(start_path, pieces, mask, origin=origin, scale=scale,
                                    bounds=problem.bounds, eps=eps, w=spacing_weight,
                                    rho=hyperplane_weight,
                                    ipopt_opts=opts, on_iter=on_iter)
        solve_t += time.perf_counter() - t0 - bt
        build += bt
        stats.append(info)
        iters += int(info.get("iter_count") or 0)
        status, success = str(info["return_status"]), bool(info["success"])
        path = new
        if status == "User_Requested_Stop":
            stopped = True
            break
        if pieces.n == 0:
            viol = 0.0
            break
        slack = pair_distances(path, pieces)
        bad = slack < -tol_chk
        viol = float(max(0.0, -slack.min()))
        missing = bad & ~mask
        if not missing.any():
            if bad.any() or full:
                break
            m = evaluate(problem.known_view() if known_only else problem, {robot.id: path})
            if m["static_collisions"] == 0 or mask.all():
                break
            mask = np.ones_like(mask)  # validator objects: constrain every pair
            full = True
            continue
        mask = mask | missing | (slack <= prune_abs)
        if resolve_from == "last":
            start_path = path
        if rounds == max_rounds - 1:
            mask = np.ones_like(mask)  # the last solve gets every pair
            full = True
    length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
    return NLPOutcome(path=path, length=length, return_status=status, success=success,
                      iterations=iters, rounds=rounds, n_pairs=int(mask.sum()),
                      pruned=int(mask.size - mask.sum()), solve_time=solve_t,
                      build_time=build, stats=stats, stopped=stopped, violation=viol)


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


def _plen(p: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(np.asarray(p, float), axis=0).T)))


@dataclass(frozen=True, kw_only=True)
class WaypointNLP(Backend):
    r"""Waypoint NLP with separating-hyperplane segment constraints, solved by IPOPT.

    Locally optimal path length in the homotopy class of the initial guess
    (domain-notes §2.3; see the module docstring for the maths).

    Parameters
    ----------
    n_segments : int
        :math:`N`, number of path segments (waypoints between start and goal: :math:`N-1`).
        An initial guess with more segments raises :math:`N` to keep all its vertices.
    clearance_mode : {"exact", "inscribed"}
        ``"exact"`` (default): avoid the raw obstacles by the robot radius (the true disc-robot
        problem, discs handled natively, 3-5 vertices per piece); ``"inscribed"``: avoid the
        validator's inflated polygons (the map ``visgraph`` certifies on; ~36 vertices per
        piece, slower).
    margin : float
        Extra clearance (map units) on top of the mode's clearance.
    init_from : {"visgraph", "straight"}
        Initial guess when no ``init`` is given: the certified visgraph path or the straight
        start-goal line.
    prune_distance : float
        Pair pruning radius as a fraction of the map diagonal: a (segment, piece) pair is
        constrained when its initial slack ``dist - clearance`` is at most this
        (``inf`` = every pair).
    max_rounds : int
        Maximum number of solves (re-solves happen when a pruned pair turns out violated).
    resolve_from : {"last", "init"}
        Start of a re-solve: the previous round's solution (default; it already satisfies the
        kept pairs, so IPOPT only has to clear the added ones: ~2x fewer iterations from
        infeasible heuristic guesses) or the initial guess again.
    eps : float
        :math:`\varepsilon`, length smoothing, fraction of the map diagonal.
    spacing_weight : float
        :math:`w`, weight of the spacing regulariser (dimensionless).
    see_temporary : bool
        Also avoid temporary (``known = false``) obstacles (default: the known map, like the
        other global path solvers).
    guard : bool
        Never return a path longer (or less feasible) than the initial guess.
    max_iter : int
        IPOPT ``max_iter``.
    tol : float
        IPOPT ``tol`` (scaled NLP error).
    acceptable_tol : float
        IPOPT ``acceptable_tol``.
    mu_strategy : {"monotone", "adaptive"}
        IPOPT barrier update strategy (``adaptive`` wanders off warm starts here).
    mu_init : float
        IPOPT initial barrier parameter (small: the warm start is near-optimal).
    bound_push : float
        IPOPT ``bound_push`` = ``bound_frac`` = ``slack_bound_push`` = ``slack_bound_frac``:
        how far the warm start is moved into the interior (small keeps it where it is).
    print_level : int
        IPOPT ``print_level`` (0 = silent).
    """

    name: ClassVar[str] = "nlp"
    certifies: ClassVar[bool] = True
    contract_problem: ClassVar[str] = "open-field"
    contract_overrides: ClassVar[dict] = {"n_segments": 8}

    n_segments: int = 20
    clearance_mode: str = "exact"
    margin: float = 0.0
    init_from: str = "visgraph"
    prune_distance: float = 0.05
    max_rounds: int = 4
    resolve_from: str = "last"
    eps: float = 1e-4
    spacing_weight: float = 1e-4
    see_temporary: bool = False
    guard: bool = True
    max_iter: int = 500
    tol: float = 1e-8
    acceptable_tol: float = 1e-6
    mu_strategy: str = "monotone"
    mu_init: float = 1e-7
    bound_push: float = 1e-6
    print_level: int = 0

    def __post_init__(self) -> None:
        check_int(self, "n_segments", 1, MAX_SEGMENTS)
        check_choice(self, "clearance_mode", ("inscribed", "exact"))
        check_range(self, "margin", 0.0)
        check_choice(self, "init_from", ("visgraph", "straight"))
        check_range(self, "prune_distance", 0.0, math.inf)
        check_int(self, "max_rounds", 1, 50)
        check_choice(self, "resolve_from", ("init", "last"))
        check_range(self, "eps", 0.0, 1e-2)
        check_range(self, "spacing_weight", 0.0, 1.0)
        check_int(self, "max_iter", 1, 100_000)
        check_range(self, "tol", 0.0, 1.0, lo_open=True)
        check_range(self, "acceptable_tol", 0.0, 1.0, lo_open=True)
        check_choice(self, "mu_strategy", ("adaptive", "monotone"))
        check_range(self, "mu_init", 0.0, 1e3, lo_open=True)
        check_range(self, "bound_push", 0.0, 0.5, lo_open=True)
        check_int(self, "print_level", 0, 12)
        for k in ("see_temporary", "guard"):
            if not isinstance(getattr(self, k), bool):
                raise ValueError(f"option {k!r} of backend 'nlp' must be true or false, "
                                 f"got {getattr(self, k)!r}")

    def ipopt_options(self) -> dict:
        """The IPOPT options passed to ``nlpsol`` (plugin level ``expand``/``print_time`` too)."""
        return {"print_level": self.print_level, "sb": "yes", "max_iter": self.max_iter,
                "tol": self.tol, "acceptable_tol": self.acceptable_tol,
                "mu_strategy": self.mu_strategy, "mu_init": self.mu_init,
                "bound_push": self.bound_push, "bound_frac": self.bound_push,
                "slack_bound_push": self.bound_push, "slack_bound_frac": self.bound_push}

    def _initial(self, problem: Problem, robot: Robot, init) -> tuple[np.ndarray | None, str]:
        if init is not None and robot.id in init:
            return np.asarray(init[robot.id], float).reshape(-1, 2), "init"
        if self.init_from == "visgraph":
            from optplan.backends.visgraph import shortest_path

            imap = problem.inflated(robot.radius, known_only=not self.see_temporary)
            path, info = shortest_path(imap, robot.start, robot.goal, problem.bounds)
            if path is None:
                return None, info.get("reason", "visgraph found no path")
            return path, "visgraph"
        return np.vstack([robot.start, robot.goal]), "straight"

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t0 = time.perf_counter()
        known_only = not self.see_temporary
        view = problem if self.see_temporary else problem.known_view()
        paths: dict[str, np.ndarray] = {}
        msgs: list[str] = []
        claims: list[Status] = []
        extras: dict[str, Any] = {"ipopt": {}, "clearance_mode": self.clearance_mode}
        hist = History()
        counter = {"it": 0, "stop": False}
        best = [math.inf]

        def on_iter(f: float) -> bool:
            counter["it"] += 1
            stop = notify(callback, Progress(iteration=counter["it"], best_cost=best[0],
                                             n_eval=counter["it"],
                                             elapsed=time.perf_counter() - t0,
                                             info={"objective": f}))
            counter["stop"] = counter["stop"] or stop
            return stop

        for robot in problem.planned_robots:
            if counter["stop"]:
                paths[robot.id] = np.vstack([robot.start, robot.start])
                claims.append(Status.approximate)
                msgs.append(f"{robot.id}: not planned (stopped by callback)")
                continue
            guess, source = self._initial(view, robot, init)
            if guess is None:
                paths[robot.id] = np.vstack([robot.start, robot.start])
                claims.append(Status.infeasible)
                msgs.append(f"{robot.id}: {source}")
                continue
            pieces = obstacle_pieces(view, robot, mode=self.clearance_mode,
                                     known_only=known_only, margin=self.margin)
            if pieces.n:
                ends = shapely.points(np.vstack([robot.start, robot.goal]))
                dd = shapely.distance(ends[:, None], pieces.geoms[None, :]) - pieces.clear
                tol = 10 * SAFETY_REL * problem.extent
                if dd.min() < -tol:
                    which = "start" if dd[0].min() < -tol else "goal"
                    paths[robot.id] = np.vstack([robot.start, robot.start])
                    claims.append(Status.infeasible)
                    msgs.append(f"{robot.id}: {which} lies within the clearance of an obstacle")
                    continue
            try:
                out = solve_waypoint_nlp(
                    view, robot, guess, n_segments=self.n_segments, mode=self.clearance_mode,
                    known_only=known_only, margin=self.margin,
                    prune_distance=self.prune_distance, max_rounds=self.max_rounds,
                    resolve_from=self.resolve_from,
                    eps=self.eps * 1.0, spacing_weight=self.spacing_weight,
                    ipopt_options=self.ipopt_options(),
                    on_iter=on_iter if callback is not None else None)
            except Exception as e:  # noqa: BLE001 - numerical failure -> failed status
                paths[robot.id] = guess
                claims.append(Status.failed)
                msgs.append(f"{robot.id}: NLP failed ({type(e).__name__}: {e})")
                continue
            extras["ipopt"][robot.id] = {
                "rounds": out.stats, "return_status": out.return_status,
                "iterations": out.iterations, "n_pairs": out.n_pairs, "pruned": out.pruned,
                "solve_time": out.solve_time, "build_time": out.build_time,
                "init_source": source, "init_length": _plen(guess),
                "nlp_length": out.length, "max_violation": out.violation,
            }
            if out.success and out.return_status in _SUCCESS:
                claim = Status.optimal
            elif out.return_status in _SOLVED:
                claim = Status.solved
            else:
                claim = Status.approximate
            path = out.path
            msg = f"{robot.id}: IPOPT {out.return_status} after {out.iterations} iterations"
            if out.rounds > 1:
                msg += f" in {out.rounds} rounds"
            if self.guard and source == "init":
                m_new = evaluate(view, {robot.id: path})
                m_old = evaluate(view, {robot.id: guess})
                ok_new = m_new["feasible"] and m_new["reached"]
                ok_old = m_old["feasible"] and m_old["reached"]
                l_new, l_old = m_new["length"], m_old["length"]
                if ok_old and (not ok_new or l_new > l_old * (1 + 1e-12)):
                    path = guess
                    claim = Status.solved
                    why = "infeasible" if not ok_new else f"longer ({l_new:.6f} > {l_old:.6f})"
                    msg += f"; NLP path {why}: kept the initial guess ({source})"
                    extras["ipopt"][robot.id]["kept_init"] = True
            paths[robot.id] = path
            claims.append(claim)
            msgs.append(msg)
            best[0] = min(best[0], _plen(path)) if len(problem.planned_robots) == 1 else best[0]
            hist.append(iteration=counter["it"] or out.iterations, best_cost=_plen(path),
                        n_eval=out.iterations, time=time.perf_counter() - t0,
                        robot=robot.id, rounds=out.rounds)
        order = [Status.failed, Status.infeasible, Status.approximate, Status.solved,
                 Status.optimal]
        claim = min(claims, key=order.index) if claims else Status.failed
        if counter["stop"] and claim is Status.optimal:
            claim = Status.solved
        lead = problem.leader.id if problem.leader.id in paths else next(iter(paths))
        return self.finish(
            problem, paths, claim=claim, cost=_plen(paths[lead]), message="; ".join(msgs),
            n_iter=sum(e["iterations"] for e in extras["ipopt"].values()),
            n_eval=sum(e["iterations"] for e in extras["ipopt"].values()),
            history=hist, extras=extras, wall_time=time.perf_counter() - t0)
