r"""Convex obstacle pieces of the waypoint NLP and its pair geometry (local frame).

The model side of :mod:`optplan.exact.nlp` that needs no CasADi: every obstacle cut into convex
pieces with a clearance (:func:`obstacle_pieces`: polygons by
:func:`optplan.geometry.convex_decompose`, circles as one vertex with clearance ``R + r``, plus
``margin`` and the numerical safety ``SAFETY_REL`` x map diagonal), the exact (segment, piece)
distances of the collision engine (:func:`piece_distances`, :func:`pair_distances`), pair
pruning (:func:`select_pairs`), the separating hyperplanes' warm start
(:func:`init_hyperplanes`) and the start / goal check (:func:`blocked_end`).  The maths is in
the :mod:`optplan.exact.nlp` module docstring.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from optplan.geometry import Frame, ObstacleSet, convex_decompose, obstacle_set
from optplan.problem import Obstacle, Problem, Robot

__all__ = [
    "SAFETY_REL",
    "Pieces",
    "obstacle_pieces",
    "piece_distances",
    "pair_distances",
    "select_pairs",
    "init_hyperplanes",
    "blocked_end",
]

#: numerical safety added to every clearance, as a fraction of the map diagonal.
SAFETY_REL = 1e-6


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



def blocked_end(problem: Problem, robot: Robot, known_only: bool, margin: float) -> str:
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
