r"""Exact waypoint NLP (CasADi + IPOPT): a local optimum of path length with whole-segment
collision constraints (docs/solvers/nlp.md).

Mathematics
-----------
Decision variables are the interior waypoints :math:`p_1, \dots, p_{N-1}` of a polyline with
:math:`N` segments; :math:`p_0` = start and :math:`p_N` = goal are fixed, every waypoint lies in
the map bounds.  The objective is the smoothed length plus a tiny spacing regulariser

.. math::

    f(p) = \sum_{i=0}^{N-1} \sqrt{\lVert \Delta_i \rVert^2 + \varepsilon^2}
           + w N \sum_{i=1}^{N-1} \lVert \Delta_i - \Delta_{i-1} \rVert^2 ,
    \qquad \Delta_i = p_{i+1} - p_i ,

(coordinates in the map's local frame divided by the map diagonal, so :math:`\varepsilon` and
:math:`w` are dimensionless); the *reported* length is the plain polyline length.

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
constraint is *exact* for convex pieces (the separating-hyperplane form of OBCA duality:
Zhang, Liniger & Borrelli 2021).  A disc (centre :math:`o`, radius :math:`R`) is the
one-vertex piece :math:`\{o\}` with clearance :math:`R + d`: :math:`a^\top (p - o) \ge R + d`.

Clearance
    The true disc-robot problem: the raw polygons with clearance = robot radius, circles natively
    (:math:`\lVert x - c \rVert \ge R + r`), plus ``margin`` and a numerical safety of
    ``SAFETY_REL`` x map diagonal (``1e-6 L``, far above the validator's tolerance
    ``eps = 1e-9 L``, so an IPOPT point that meets its constraints to IPOPT's tolerance is
    accepted by the validator).  The geometry is the exact engine's
    (:meth:`Problem.obstacle_set`): its local, clipped shapes are the input of the pieces.

Local frame
    Everything is computed in the map's local frame (:attr:`Problem.frame`: coordinates
    relative to the centre of the bounds), subtracted once when the pieces and the initial path
    are built and added back to the returned waypoints.  The NLP variables are local
    coordinates divided by the map diagonal ``L``, so a map at UTM coordinates solves like the
    same map at the origin (IPOPT's tolerances are absolute in its variables).

Convex decomposition
    :func:`optplan.geometry.convex_decompose` (the one decomposition of optplan: convex
    polygons are one piece, others the Hertel-Mehlhorn merge of a constrained Delaunay
    triangulation, holes included).

Pair pruning
    Only pairs whose piece lies within ``prune_distance`` (fraction of the map diagonal) of the
    *initial* segment, beyond the piece's clearance, are constrained.  After each solve every
    (segment, piece) distance is computed exactly by the collision engine
    (:meth:`ObstacleSet.pair_geometry` on an :class:`~optplan.geometry.ObstacleSet` whose
    obstacles are the NLP's convex pieces: the engine fan-splits a piece into items of at most
    four vertices, and the distance to the piece is the smallest over its items); a violated
    pruned pair is added (with the pairs near the new segments) and the NLP re-solved, up to
    ``max_rounds`` solves; the last one constrains every pair.  A re-solve starts from the
    previous round's solution (``resolve_from = "last"``, default: it already satisfies the kept
    pairs, so IPOPT only clears the added ones; from overlapping heuristic guesses this halves
    the iterations and more often keeps the optimal homotopy class) or from the initial guess
    again (``"init"``).  If the shared validator still objects, all pairs are added.

Structure re-use
    The NLP is built once per structure ``(N, the kept pairs' segments, vertex rows per pair,
    IPOPT options)`` with ``casadi.nlpsol`` on SX symbols (``expand = True``); the constraint
    vector is flat, indexed by the kept (segment, piece) pairs, each segment with as many pairs
    as it has (no empty slots padded to the busiest segment's count: they stayed in IPOPT's
    KKT system as free rows and made every iteration slower).  The piece vertices are
    *parameters* and the clearances *bounds*, so seeds and warm starts with the same pairs
    re-use one compiled solver; any other set of pairs is a new (vectorised) build.

Warm start
    ``init`` (any path, e.g. an IPSO or visgraph result) keeps all its vertices and gains
    collinear points on its longest segments, proportionally to arc length, until it has ``N``
    segments (``N = max(n_segments, len(init) - 1)``, rounded up to a multiple of 8 when the
    ``init`` is longer).  Each hyperplane starts at the best of
    the candidate normals that contain the optimal separating direction of a segment and a
    convex piece (the piece's edge normals, the segment's normals, the directions from the
    piece's vertices to the segment's endpoints), with ``c`` in the middle of the gap.
    Without ``init`` the start is the arc-exact tangent-graph path
    (:func:`optplan.geometry.tangent_graph.problem_shortest_path`, ``init_from = "visgraph"``)
    or the straight line (``"straight"``).  IPOPT is local: the homotopy class is the initial
    guess's.

Statuses
    IPOPT ``Solve_Succeeded`` is a KKT point: locally optimal in the initial guess's homotopy
    class.  It is claimed ``optimal`` only when it lies in the homotopy class of the certified
    optimum of the same map (:mod:`optplan.geometry.homotopy`) *and* that optimum confirms its
    length within :data:`optplan.result.OPTIMAL_REL_TOL` (1e-9); otherwise ``solved``, with
    "locally optimal (KKT)", the gap (also ``extras["ipopt"][robot]["optimum_gap"]``) and the
    reason in the message: chords around the optimum's arcs, or the safety clearance at a
    corner, keep a KKT point 1e-6 to 1e-4 above the optimum (docs/solvers/nlp.md).  Acceptable
    level / iteration or time limit / user stop -> claim ``solved``; IPOPT infeasibility or
    failure -> ``approximate`` with the IPOPT message; start or goal within ``r`` of an
    obstacle, or no path at all (tangent graph) -> ``infeasible``.
    The backend never decides feasibility: the shared validator grades every claim
    (:meth:`Backend.finish`).  Guard: with a caller's ``init``, if IPOPT returns a path that the
    validator rejects or that is longer, the (validator-feasible) initial guess is returned
    instead, as ``solved`` with a message; the NLP's own length stays in ``extras``.  (The
    backend's own visgraph start is not guarded: its result is the NLP optimum, reported as is.)
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from shapely.geometry import Polygon

from optplan.geometry import Frame, ObstacleSet, convex_decompose, obstacle_set
from optplan.geometry.homotopy import same_homotopy
from optplan.geometry.polyline import path_lengths, resample_path
from optplan.geometry.tangent_graph import problem_shortest_path
from optplan.metrics import evaluate
from optplan.problem import Obstacle, Problem, Robot
from optplan.result import History, Progress, Result, Status, confirms_optimum, notify, optimum_gap
from optplan.solver import Backend, option

__all__ = [
    "WaypointNLP",
    "Pieces",
    "obstacle_pieces",
    "resample_path",
    "piece_distances",
    "pair_distances",
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

#: A caller's ``init`` with more than ``n_segments`` segments gets a multiple of this many
#: (one compiled NLP per structure: the warm starts of one map then share one or two builds).
SEGMENT_BUCKET = 8

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
# geometry: convex pieces (local frame)
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Pieces:
    """Convex obstacle pieces for the NLP, in the map's local frame.

    Attributes
    ----------
    frame : Frame
        The map's frame; ``verts`` are ``frame.local`` coordinates.
    verts : list of (m_j, 2) arrays
        Vertices of each convex piece, CCW (a circle is its single centre vertex).
    clear : (J,) array
        Required distance from ``conv(verts[j])``: robot radius (plus the circle radius for a
        circle), ``margin`` and the safety ``SAFETY_REL * L``.
    need : (J,) array
        The clearance the validator requires (robot radius, plus the circle radius): ``clear``
        without margin and safety.
    radius : (J,) array
        Circle radius (0 for polygon pieces): the engine measures the distance to the disc,
        the NLP to its centre.
    obstacle : (J,) int array
        Index of the source obstacle in ``problem.static_obstacles(known_only)``.
    names : list of str
        Name of each piece's obstacle.
    engine : ObstacleSet
        The exact collision engine over the pieces themselves (obstacle ``j`` = piece ``j``,
        frame origin 0: local coordinates in and out), for the exact pair distances.
    """

    frame: Frame
    verts: list[np.ndarray]
    clear: np.ndarray
    need: np.ndarray
    radius: np.ndarray
    obstacle: np.ndarray
    names: list[str]
    engine: ObstacleSet

    @property
    def n(self) -> int:
        return len(self.verts)

    @property
    def max_verts(self) -> int:
        return max((len(v) for v in self.verts), default=1)


def obstacle_pieces(problem: Problem, robot: Robot, *, known_only: bool = True,
                    margin: float = 0.0) -> Pieces:
    """Convex pieces and clearances for ``robot`` (cached on the problem).

    The input is the exact engine's view of the map (:meth:`Problem.obstacle_set`: local
    coordinates, obstacles clipped to the working region): each polygon is cut by
    :func:`optplan.geometry.convex_decompose` with clearance ``r``; each circle is one
    vertex with clearance ``R + r``.  Both add ``margin`` and ``SAFETY_REL * L``.
    """
    return problem.memo(("nlp_pieces", float(robot.radius), bool(known_only), float(margin)),
                        lambda: _build_pieces(problem, robot, known_only, margin))


def _build_pieces(problem: Problem, robot: Robot, known_only: bool, margin: float) -> Pieces:
    """:func:`obstacle_pieces` without the cache."""
    frame = problem.frame
    safety = SAFETY_REL * frame.length
    r = float(robot.radius)
    oset = problem.obstacle_set(r, known_only=known_only)
    verts, need, rad, owner, names, objs = [], [], [], [], [], []
    for i, g in oset.shapes:
        nm = oset.names[i]
        if isinstance(g, tuple):  # circle (cx, cy, R), local
            cx, cy, R = g
            verts.append(np.array([[cx, cy]]))
            need.append(R + r)
            rad.append(R)
            owner.append(i)
            names.append(nm)
            objs.append(Obstacle(kind="circle", geometry=None, name=nm,
                                 center=np.array([cx, cy]), radius=R))
            continue
        for v in convex_decompose(g):
            verts.append(v)
            need.append(r)
            rad.append(0.0)
            owner.append(i)
            names.append(nm)
            objs.append(Obstacle(kind="polygon", geometry=Polygon(v), name=nm))
    need_a = np.asarray(need, float)
    # the pieces' own engine: local coordinates (origin 0), the map's length scale and bounds
    local = Frame(frame.local_bounds, np.zeros(2), frame.length)
    out = Pieces(frame, verts, need_a + margin + safety, need_a, np.asarray(rad, float),
                 np.asarray(owner, np.int64), names,
                 obstacle_set(objs, r, local, solids=False, walls=False))
    return out


# --------------------------------------------------------------------------------------
# paths, pairs, hyperplane warm start (local frame)
# --------------------------------------------------------------------------------------


def piece_distances(path: np.ndarray, pieces: Pieces) -> np.ndarray:
    """``(N, J)`` exact distance from each segment of ``path`` (local, ``(N + 1, 2)``) to each
    piece's vertex hull; for a circle piece, to its centre (``max(dist to the disc, 0) + R``,
    so ``R`` for a segment that meets the disc).

    Computed by the collision engine (:meth:`ObstacleSet.pair_geometry`) over every (segment,
    item) pair of the pieces' own engine, reduced to the piece by the smallest item distance
    (0 where the segment meets the piece).  Pieces the engine dropped (beyond the working
    region) get ``inf``.
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    N = len(p) - 1
    out = np.full((N, pieces.n), np.inf)
    eng = pieces.engine
    if pieces.n == 0 or N <= 0 or eng.n_items == 0:
        return out
    z = p[:, 0] + 1j * p[:, 1]
    a, d = z[:-1], np.diff(z)
    K = eng.n_items
    block = max(1, 1_000_000 // K)
    for s0 in range(0, N, block):
        s1 = min(N, s0 + block)
        si = np.repeat(np.arange(s0, s1), K)
        it = np.tile(np.arange(K), s1 - s0)
        dist, _ = eng.pair_geometry(si, it, a, d)
        np.minimum.at(out, (si, eng.item_obstacle[it]), dist)
    return out + pieces.radius[None, :]


def pair_distances(path: np.ndarray, pieces: Pieces) -> np.ndarray:
    """``(N, J)`` slack: exact distance from each segment (local path) to each piece minus
    the piece's clearance ``pieces.clear``."""
    return piece_distances(path, pieces) - pieces.clear[None, :]


def select_pairs(path: np.ndarray, pieces: Pieces, prune: float) -> np.ndarray:
    """Boolean ``(N, J)`` mask of pairs whose slack ``dist - clearance`` is ``<= prune``."""
    return pair_distances(path, pieces) <= prune


def init_hyperplanes(path: np.ndarray, pieces: Pieces, seg: np.ndarray,
                     piece: np.ndarray, clear: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Initial ``(a, c)`` for the pairs ``(seg[k], piece[k])`` (local path and pieces).

    For a segment disjoint from the piece, ``a`` maximises the separation
    ``h(a) = min(a . p_i, a . p_{i+1}) - max_k a . v_k`` over the unit candidates: the piece's
    outward edge normals, the segment's two normals and the directions from each vertex to
    each endpoint.  These contain the direction of the nearest points of a segment and a
    disjoint convex piece (vertex-segment, endpoint-edge or endpoint-vertex), where ``h`` is
    the distance.  For a segment that meets the piece (``h <= 0`` for every candidate) ``a``
    is the unit vector from the piece's centroid to the segment's midpoint: the side the
    segment mostly lies on (the least-penetration candidate instead sends IPOPT to a worse
    homotopy class more often from overlapping heuristic guesses).  ``c`` = max over the
    piece's vertices of ``a . v`` (the support value); with ``clear`` (per-piece clearances)
    ``c`` is moved to the middle of the slack between the support value and the segment's
    nearer endpoint, when there is any.
    """
    K = len(seg)
    if K == 0:
        return np.zeros((0, 2)), np.zeros(0)
    path = np.asarray(path, dtype=float)
    P0, P1 = path[seg], path[seg + 1]
    nv = np.array([len(pieces.verts[j]) for j in piece])
    M = int(nv.max())
    V = np.zeros((K, M, 2))
    for k, j in enumerate(piece):
        v = pieces.verts[j]
        V[k, : len(v)] = v
        V[k, len(v):] = v[-1]  # padding repeats a vertex: the support value is unchanged
    idx = np.arange(M)[None, :]
    valid_v = idx < nv[:, None]
    nxt = np.where(idx + 1 < nv[:, None], idx + 1, 0)
    E = np.take_along_axis(V, nxt[..., None], axis=1) - V  # edge v_k -> v_{k+1}
    cands = [np.stack([E[..., 1], -E[..., 0]], axis=-1)]  # outward normals (CCW pieces)
    okc = [valid_v & (nv[:, None] >= 3)]
    t = P1 - P0
    nrm = np.stack([-t[:, 1], t[:, 0]], axis=-1)[:, None, :]
    cands += [nrm, -nrm, P0[:, None, :] - V, P1[:, None, :] - V]
    okc += [np.ones((K, 1), bool)] * 2 + [valid_v] * 2
    A = np.concatenate(cands, axis=1)
    ok = np.concatenate(okc, axis=1)
    ln = np.hypot(A[..., 0], A[..., 1])
    ok &= ln > 0
    A = A / np.where(ln > 0, ln, 1.0)[..., None]
    sup = np.einsum("kcd,kmd->kcm", A, V).max(axis=2)
    near = np.minimum(np.einsum("kcd,kd->kc", A, P0), np.einsum("kcd,kd->kc", A, P1))
    h = np.where(ok, near - sup, -np.inf)
    best = np.argmax(h, axis=1)
    rows = np.arange(K)
    a = A[rows, best]
    meets = ~(h[rows, best] > 0)
    if meets.any():
        # area centroid of the piece (shoelace; a circle piece: its centre)
        W = V[meets]
        Wn = np.take_along_axis(W, nxt[meets][..., None], axis=1)
        cr = np.where(valid_v[meets], W[..., 0] * Wn[..., 1] - Wn[..., 0] * W[..., 1], 0.0)
        ar = cr.sum(axis=1)
        cen = np.einsum("km,kmd->kd", cr, W + Wn) / np.where(ar != 0, 3.0 * ar, 1.0)[:, None]
        flat = ~(np.abs(ar) > 0)
        cen[flat] = (W[flat] * valid_v[meets][flat][..., None]).sum(axis=1) / nv[meets][flat,
                                                                                  None]
        dv = 0.5 * (P0[meets] + P1[meets]) - cen
        nd = np.hypot(dv[:, 0], dv[:, 1])
        dv = np.where(nd[:, None] > 0, dv / np.where(nd > 0, nd, 1.0)[:, None], [1.0, 0.0])
        a[meets] = dv
    support = np.einsum("kmd,kd->km", V, a).max(axis=1)
    if clear is None:
        return a, support
    # put the hyperplane in the middle of the gap, so that neither side starts at zero slack
    near = np.minimum(np.sum(a * P0, axis=1), np.sum(a * P1, axis=1))
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
    n_pairs: int
    n_rows: int
    nx: int
    ng: int
    callback: Any = None


def _pair_rows(rows: np.ndarray) -> list[int]:
    """Order of the constraint rows: pair by pair, its ``rows[k]`` vertex rows, then its two
    endpoint rows and its norm row (the built expression lists all vertex rows, then all
    first-endpoint, second-endpoint and norm rows)."""
    K = len(rows)
    nvt = int(rows.sum())
    off = np.r_[0, np.cumsum(rows)[:-1]]
    out: list[int] = []
    for k in range(K):
        out += range(int(off[k]), int(off[k] + rows[k]))
        out += [nvt + k, nvt + K + k, nvt + 2 * K + k]
    return out


@functools.lru_cache(maxsize=32)
def _build(n_seg: int, seg: tuple, rows: tuple, ipopt_opts: tuple,
           with_callback: bool) -> _Built:
    """Build the waypoint NLP for a structure: ``n_seg`` segments and the kept pairs, pair
    ``k`` on segment ``seg[k]`` (non-decreasing) with ``rows[k]`` vertex rows.

    Variables ``x = [interior waypoints (N-1)x2 row-major, a (2 per pair), c (1 per pair)]``;
    parameters ``[start, goal, eps, w, vertex rows (sum(rows) x 2)]``; constraint rows per
    pair: ``rows[k]`` vertex rows ``a.v - c`` (upper bound 0; the rows beyond the piece's
    vertex count repeat its last vertex and get an infinite bound), two endpoint rows
    ``a.p - c`` (lower bound = clearance), one ``|a|^2`` row (upper bound 1).  No slot of a
    segment is padded to the busiest segment's count (issue 18: such empty slots stayed in
    IPOPT's KKT system as free rows and made every iteration slower).  The
    expression is built with vectorised SX indexing (one operation per row type).
    """
    import casadi as ca

    N, K = n_seg, len(seg)
    nW = max(N - 1, 0)
    W = ca.SX.sym("W", nW * 2)
    A = ca.SX.sym("A", K * 2)
    C = ca.SX.sym("C", K)
    start = ca.SX.sym("start", 2)
    goal = ca.SX.sym("goal", 2)
    eps = ca.SX.sym("eps")
    w = ca.SX.sym("w")
    nvt = int(sum(rows))
    Vp = ca.SX.sym("V", nvt * 2)
    P = ca.vertcat(start.T, ca.reshape(W, 2, nW).T, goal.T)
    L, R = _length_terms(P, eps, w, N)
    if K:
        ax, ay = A[0::2], A[1::2]
        own = np.repeat(np.arange(K), rows).tolist()
        s0 = [int(i) for i in seg]
        s1 = [i + 1 for i in s0]
        def per_row(e):  # e[own] as a column: with K = 1, e is 1 x 1 and e[list] is a row
            return ca.reshape(e[own], len(own), 1)

        gv = per_row(ax) * Vp[0::2] + per_row(ay) * Vp[1::2] - per_row(C)
        Px, Py = P[:, 0], P[:, 1]
        e0 = ax * Px[s0] + ay * Py[s0] - C
        e1 = ax * Px[s1] + ay * Py[s1] - C
        gexpr = ca.vertcat(gv, e0, e1, ax * ax + ay * ay)[_pair_rows(np.asarray(rows))]
    else:
        gexpr = ca.SX(0, 1)
    x = ca.vertcat(W, A, C)
    p = ca.vertcat(start, goal, eps, w, Vp)
    nlp = {"x": x, "p": p, "f": L + R, "g": gexpr}
    ip = dict(ipopt_opts)
    opts: dict[str, Any] = {"expand": True, "print_time": False, "error_on_fail": False,
                            "ipopt": ip}
    cb = None
    if with_callback:
        cb = _IterCallback.make(x.numel(), gexpr.numel(), p.numel())
        opts["iteration_callback"] = cb
    solver = ca.nlpsol("waypoint_nlp", "ipopt", nlp, opts)
    return _Built(solver, N, K, nvt, int(x.numel()), int(gexpr.numel()), cb)


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


def _solve_once(path0: np.ndarray, pieces: Pieces, mask: np.ndarray, *, scale: float,
                bounds, eps: float, w: float, ipopt_opts: tuple,
                on_iter: Callable[[float], bool] | None) -> tuple[np.ndarray, dict, float]:
    """One IPOPT solve from ``path0`` with the pairs in ``mask``; returns (path, stats, build).

    ``path0``, the pieces and ``bounds`` are local-frame coordinates; the NLP runs on them
    divided by ``scale`` (the map diagonal).  The returned path is local.
    """
    N = len(path0) - 1
    seg, piece = np.nonzero(mask)  # row-major: ordered by segment
    K = len(seg)
    nv = np.array([len(pieces.verts[j]) for j in piece], dtype=np.int64)
    # vertex rows per pair: the piece's vertex count rounded up to a multiple of 4 (the
    # extra rows are free); without them IPOPT's iterates change (2 of the 390 tails polishes
    # ended at another KKT point, 1e-5 in length), with them the paths are those of the
    # padded NLP before issue 18 (to 5e-12 relative)
    rows = np.maximum(4, -(-nv // 4) * 4) if K else nv
    tb = time.perf_counter()
    built = _build(N, tuple(seg.tolist()), tuple(rows.tolist()), ipopt_opts, on_iter is not None)
    build_time = time.perf_counter() - tb
    u = path0 / scale
    a0, c0 = init_hyperplanes(path0, pieces, seg, piece, pieces.clear)
    nvt = int(rows.sum())
    Vt = np.zeros((nvt, 2))
    vub = np.full(nvt, np.inf)
    o = 0
    for k, j in enumerate(piece):
        vj = pieces.verts[j] / scale
        Vt[o: o + len(vj)] = vj
        Vt[o + len(vj): o + rows[k]] = vj[-1]
        vub[o: o + len(vj)] = 0.0
        o += rows[k]
    clear = pieces.clear[piece] / scale
    # bounds on x
    x0b, y0b, x1b, y1b = bounds
    lo = np.array([x0b, y0b]) / scale
    hi = np.array([x1b, y1b]) / scale
    nW = max(N - 1, 0)
    lbx = np.r_[np.tile(lo, nW), np.full(K * 2, -1.0), np.full(K, -np.inf)]
    ubx = np.r_[np.tile(hi, nW), np.full(K * 2, 1.0), np.full(K, np.inf)]
    x0 = np.r_[np.clip(u[1:-1], lo, hi).ravel(), a0.ravel(), c0 / scale]
    # constraint bounds in the built order: vertex rows, first and second endpoint rows,
    # norm rows, then permuted pair by pair
    lbg = np.r_[np.full(nvt, -np.inf), clear, clear, np.full(K, -np.inf)]
    ubg = np.r_[vub, np.full(2 * K, np.inf), np.ones(K)]
    perm = _pair_rows(rows) if K else []
    lbg, ubg = lbg[perm], ubg[perm]
    par = np.r_[u[0], u[-1], eps, w, Vt.ravel()]
    if built.callback is not None:
        built.callback.target = on_iter
    sol = built.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=par)
    if built.callback is not None:
        built.callback.target = None
    st = dict(built.solver.stats())
    xs = np.asarray(sol["x"]).ravel()
    if not np.all(np.isfinite(xs)):
        xs = x0
        st["return_status"] = st.get("return_status", "") + " (non-finite iterate)"
        st["success"] = False
    Wsol = xs[: 2 * nW].reshape(nW, 2)
    out = np.vstack([path0[0], Wsol * scale, path0[-1]])
    info = {k: st.get(k) for k in ("return_status", "success", "iter_count")}
    info.update(t_wall=sum(float(v) for k, v in st.items() if k.startswith("t_wall_")),
                n_pairs=int(K), vertex_rows=nvt, n_seg=N, build_time=build_time)
    return out, info, build_time


def solve_waypoint_nlp(
    problem: Problem,
    robot: Robot,
    init_path: np.ndarray,
    *,
    n_segments: int = 20,
    known_only: bool = True,
    margin: float = 0.0,
    prune_distance: float = 0.05,
    max_rounds: int = 4,
    eps: float = 1e-4,
    spacing_weight: float = 1e-4,
    resolve_from: str = "last",
    segment_bucket: int = 1,
    ipopt_options: dict | None = None,
    on_iter: Callable[[float], bool] | None = None,
) -> NLPOutcome:
    """Solve the waypoint NLP for ``robot`` from ``init_path`` (world coordinates in and out).

    The initial path is taken to the map's local frame once; the NLP, the pair checks and the
    hyperplanes work there, and the solution is taken back to world coordinates at the end
    (start and goal are the robot's, bit for bit).  Multi-round: solve with the pruned pairs,
    check every (segment, piece) distance exactly, add the violated pairs (and those near the
    new segments) and re-solve (at most ``max_rounds`` solves), from the previous round's
    solution (``resolve_from = "last"``) or from the initial guess (``"init"``).
    ``on_iter(f)`` is called every IPOPT iteration; returning True stops IPOPT.  An initial
    path with more than ``n_segments`` segments keeps every vertex, its segment count rounded
    up to a multiple of ``segment_bucket``.
    """
    pieces = obstacle_pieces(problem, robot, known_only=known_only, margin=margin)
    frame = problem.frame
    scale = frame.length
    start = frame.local(robot.start)
    goal = None if robot.goal is None else frame.local(robot.goal)
    p = frame.local(np.asarray(init_path, float).reshape(-1, 2))
    if np.hypot(*(p[0] - start)) > frame.eps:
        p = np.vstack([start, p])
    if goal is not None and np.hypot(*(p[-1] - goal)) > frame.eps:
        p = np.vstack([p, goal])
    # a longer initial path keeps every vertex; its segment count is rounded up to a multiple
    # of segment_bucket (warm starts of similar length then share one compiled structure)
    n_eff = n_segments if len(p) - 1 <= n_segments else _bucket(len(p) - 1, segment_bucket)
    n_eff = min(n_eff, MAX_SEGMENTS)
    path = resample_path(p, n_eff)
    path[0] = start
    if goal is not None:
        path[-1] = goal
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
    view = problem.known_view() if known_only else problem

    def world(q: np.ndarray) -> np.ndarray:
        out = frame.world(q)
        out[0] = robot.start
        if robot.goal is not None:
            out[-1] = robot.goal
        return out

    while rounds < max_rounds:
        rounds += 1
        t0 = time.perf_counter()
        new, info, bt = _solve_once(start_path, pieces, mask, scale=scale,
                                    bounds=frame.local_bounds, eps=eps, w=spacing_weight,
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
            m = evaluate(view, {robot.id: world(path)})
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
    length = float(path_lengths(path))
    return NLPOutcome(path=world(path), length=length, return_status=status, success=success,
                      iterations=iters, rounds=rounds, n_pairs=int(mask.sum()),
                      pruned=int(mask.size - mask.sum()), solve_time=solve_t,
                      build_time=build, stats=stats, stopped=stopped, violation=viol)


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class WaypointNLP(Backend):
    r"""Waypoint NLP with separating-hyperplane segment constraints, solved by IPOPT.

    Locally optimal path length in the homotopy class of the initial guess
    (see the module docstring for the maths).

    Parameters
    ----------
    n_segments : int
        :math:`N`, number of path segments (waypoints between start and goal: :math:`N-1`).
        An initial guess with more segments raises :math:`N` to keep all its vertices (for a
        caller's ``init``, to the next multiple of ``SEGMENT_BUCKET``, 8, so that similar warm
        starts share one build).
    margin : float
        Extra clearance on top of the robot radius, in units of the problem's
        ``length_scale`` (map units on the paper's maps): the NLP avoids the true polygons and
        circles by ``r + margin * length_scale``, plus a safety of ``SAFETY_REL`` x the map
        diagonal.
    init_from : {"visgraph", "straight"}
        Initial guess when no ``init`` is given: the arc-exact tangent-graph path (the
        ``visgraph`` polyline) or the straight start-goal line.
    prune_distance : float
        Pair pruning radius as a fraction of the map diagonal: a (segment, piece) pair is
        constrained when its initial slack ``dist - clearance`` is at most this; ``inf``
        constrains every pair (no pruning).
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
    n_segments: int = option(20, lo=1, hi=MAX_SEGMENTS)
    margin: float = option(0.0, lo=0.0, scale=True)
    init_from: str = option("visgraph", choices=("visgraph", "straight"))
    prune_distance: float = option(0.05, lo=0.0, inf_ok=True)
    max_rounds: int = option(4, lo=1, hi=50)
    resolve_from: str = option("last", choices=("init", "last"))
    eps: float = option(1e-4, lo=0.0, hi=1e-2)
    spacing_weight: float = option(1e-4, lo=0.0, hi=1.0)
    see_temporary: bool = option(False)
    guard: bool = option(True)
    max_iter: int = option(500, lo=1, hi=100_000)
    tol: float = option(1e-8, lo=0.0, hi=1.0, lo_open=True)
    acceptable_tol: float = option(1e-6, lo=0.0, hi=1.0, lo_open=True)
    mu_strategy: str = option("monotone", choices=("adaptive", "monotone"))
    mu_init: float = option(1e-7, lo=0.0, hi=1e3, lo_open=True)
    bound_push: float = option(1e-6, lo=0.0, hi=0.5, lo_open=True)
    print_level: int = option(0, lo=0, hi=12)

    def ipopt_options(self) -> dict:
        """The IPOPT options passed to ``nlpsol`` (plugin level ``expand``/``print_time`` too)."""
        return {"print_level": self.print_level, "sb": "yes", "max_iter": self.max_iter,
                "tol": self.tol, "acceptable_tol": self.acceptable_tol,
                "mu_strategy": self.mu_strategy, "mu_init": self.mu_init,
                "bound_push": self.bound_push, "bound_frac": self.bound_push,
                "slack_bound_push": self.bound_push, "slack_bound_frac": self.bound_push}

    def _initial(self, problem: Problem, robot: Robot, init
                 ) -> tuple[np.ndarray | None, str, Status]:
        """(initial path, its source, status if there is none)."""
        if init is not None and robot.id in init:
            return np.asarray(init[robot.id], float).reshape(-1, 2), "init", Status.solved
        if self.init_from == "visgraph":
            res = problem_shortest_path(problem, robot, known_only=not self.see_temporary)
            if res.polyline is None:
                # the walled tangent graph is complete: no path is a proof
                return (None, res.info.get("reason", "the tangent graph has no path"),
                        Status.infeasible)
            return res.polyline, "visgraph", Status.solved
        return np.vstack([robot.start, robot.goal]), "straight", Status.solved

    @staticmethod
    def _certify(problem: Problem, robot: Robot, path: np.ndarray,
                 known_only: bool) -> tuple[Status, str, float | None]:
        """``optimal`` when the KKT path is in the certified optimum's homotopy class and the
        optimum confirms its length (:func:`~optplan.result.confirms_optimum`), else ``solved``
        with "locally optimal", the gap and the reason; and the optimum (``None``: none)."""
        ref = problem_shortest_path(problem, robot, known_only)  # cached: the visgraph init
        if ref.polyline is None or not ref.info.get("certified"):
            return Status.solved, "locally optimal (KKT); no certified optimum to compare", None
        length, opt = path_lengths(path), ref.length
        same = same_homotopy(path, ref.polyline, problem.obstacle_set(robot.radius, known_only))
        if same and confirms_optimum(length, opt):
            return Status.optimal, "", opt
        why = ("another homotopy class than the certified optimum" if not same else
               "in the optimum's homotopy class (chords and the safety clearance keep it above)")
        return Status.solved, (f"locally optimal (KKT): {100 * optimum_gap(length, opt):.2g} % "
                               f"above the certified optimum {opt:.6g}, {why}"), opt

    def _outcome(self, problem: Problem, robot: Robot, out, guess: np.ndarray, source: str,
                 known_only: bool, info: dict[str, Any]) -> tuple[np.ndarray, Status, str]:
        """The path, claim and message of one robot's NLP result ``out``: certified against
        the optimum when IPOPT succeeded, and (``guard``, an ``init`` guess) the initial guess
        kept when the NLP path is infeasible or longer.  Notes go into ``info``."""
        view = problem if not known_only else problem.known_view()
        if out.success and out.return_status in _SUCCESS:
            claim, note, opt = self._certify(problem, robot, out.path, known_only)
            if opt is not None:
                info.update(optimum=opt, optimum_gap=optimum_gap(out.length, opt))
            if note:
                info["certificate"] = note
        elif out.return_status in _SOLVED:
            claim = Status.solved
        else:
            claim = Status.approximate
        path = out.path
        msg = f"{robot.id}: IPOPT {out.return_status} after {out.iterations} iterations"
        if out.rounds > 1:
            msg += f" in {out.rounds} rounds"
        if "certificate" in info:
            msg += "; " + info["certificate"]
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
                info["kept_init"] = True
        return path, claim, msg

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t0 = time.perf_counter()
        known_only = not self.see_temporary
        margin = self.margin * problem.length_scale  # the option is in length_scale units
        paths: dict[str, np.ndarray] = {}
        msgs: list[str] = []
        claims: list[Status] = []
        extras: dict[str, Any] = {"ipopt": {}}
        hist = History()
        counter = {"it": 0, "stop": False}
        best = [math.inf]

        raised: list[BaseException] = []

        def on_iter(f: float) -> bool:
            counter["it"] += 1
            try:
                stop = notify(callback, Progress(iteration=counter["it"], best_cost=best[0],
                                                 n_eval=counter["it"],
                                                 elapsed=time.perf_counter() - t0,
                                                 info={"objective": f}))
            except BaseException as e:  # noqa: BLE001 - re-raised after IPOPT returns
                # CasADi would swallow it (and print its internals): stop IPOPT cleanly and
                # let the exception propagate unchanged from solve()
                raised.append(e)
                stop = True
            counter["stop"] = counter["stop"] or stop
            return stop

        for robot in problem.planned_robots:
            if counter["stop"]:
                paths[robot.id] = np.vstack([robot.start, robot.start])
                claims.append(Status.approximate)
                msgs.append(f"{robot.id}: not planned (stopped by callback)")
                continue
            guess, source, why_none = self._initial(problem, robot, init)
            if guess is None:
                paths[robot.id] = np.vstack([robot.start, robot.start])
                claims.append(why_none)
                msgs.append(f"{robot.id}: {source}")
                continue
            which = _blocked_end(problem, robot, known_only, margin)
            if which:
                paths[robot.id] = np.vstack([robot.start, robot.start])
                claims.append(Status.infeasible)
                msgs.append(f"{robot.id}: {which} lies within the robot radius of an obstacle")
                continue
            try:
                out = solve_waypoint_nlp(
                    problem, robot, guess, n_segments=self.n_segments,
                    known_only=known_only, margin=margin,
                    prune_distance=self.prune_distance, max_rounds=self.max_rounds,
                    resolve_from=self.resolve_from,
                    segment_bucket=SEGMENT_BUCKET if source == "init" else 1,
                    eps=self.eps, spacing_weight=self.spacing_weight,
                    ipopt_options=self.ipopt_options(),
                    on_iter=on_iter if callback is not None else None)
                if raised:
                    raise raised[0]
            except RuntimeError as e:  # CasADi / IPOPT numerical failure -> failed status
                if raised:
                    raise

                paths[robot.id] = guess
                claims.append(Status.failed)
                msgs.append(f"{robot.id}: NLP failed ({type(e).__name__}: {e})")
                continue
            extras["ipopt"][robot.id] = {
                "rounds": out.stats, "return_status": out.return_status,
                "iterations": out.iterations, "n_pairs": out.n_pairs, "pruned": out.pruned,
                "solve_time": out.solve_time, "build_time": out.build_time,
                "init_source": source, "init_length": path_lengths(guess),
                "nlp_length": out.length, "max_violation": out.violation,
            }
            path, claim, msg = self._outcome(problem, robot, out, guess, source, known_only,
                                             extras["ipopt"][robot.id])
            paths[robot.id] = path
            claims.append(claim)
            msgs.append(msg)
            if len(problem.planned_robots) == 1:
                best[0] = min(best[0], path_lengths(path))
            hist.append(iteration=counter["it"] or out.iterations, best_cost=path_lengths(path),
                        n_eval=out.iterations, time=time.perf_counter() - t0,
                        robot=robot.id, rounds=out.rounds)
        order = [Status.failed, Status.infeasible, Status.approximate, Status.solved,
                 Status.optimal]
        claim = min(claims, key=order.index) if claims else Status.failed
        if counter["stop"] and claim is Status.optimal:
            claim = Status.solved
        lead = problem.leader.id if problem.leader.id in paths else next(iter(paths))
        opt = extras["ipopt"].get(lead, {}).get("optimum")
        return self.finish(
            problem, paths, claim=claim, cost=path_lengths(paths[lead]), message="; ".join(msgs),
            metrics_extra=None if opt is None else {"optimum": opt},
            n_iter=sum(e["iterations"] for e in extras["ipopt"].values()),
            n_eval=sum(e["iterations"] for e in extras["ipopt"].values()),
            history=hist, extras=extras, wall_time=time.perf_counter() - t0)


def _blocked_end(problem: Problem, robot: Robot, known_only: bool, margin: float) -> str:
    """``"start"`` or ``"goal"`` when it lies within the robot radius of an obstacle (the
    validator's clearance: touching is allowed), else ``""``."""
    pieces = obstacle_pieces(problem, robot, known_only=known_only, margin=margin)
    if not pieces.n or robot.goal is None:
        return ""
    ends = problem.frame.local(np.vstack([robot.start, robot.start, robot.goal,
                                          robot.goal]))  # segments 0, 2: points
    dd = piece_distances(ends, pieces)[[0, 2]] - pieces.need[None, :]
    if dd.min() >= -problem.frame.eps:
        return ""
    return "start" if dd[0].min() < -problem.frame.eps else "goal"
