r"""Candidate sight lines: the circles a point may see, found without testing every pair.

The tangent graph (:mod:`optplan.geometry.tangent.tangent_graph`) joins its circles by common
tangents; testing the tangents from one circle to all ``n`` others costs ``O(n)`` per circle
and ``O(n^2)`` for the graph, although on a map of many obstacles a circle sees only a few
others.  This module lists, per *source* point and angular *window*, a superset of the circle
centres visible from it, in time that grows with the visible region rather than with the map.

Mathematics
-----------
*Triangulation.*  The solids' boundary edges, the centres and the corners of a box around
them are triangulated with those edges as constraints (a constrained Delaunay triangulation,
Shewchuk's Triangle through the ``triangle`` package: no vertex added when no two edges
cross).  A triangle is free space or inside a solid: crossing a constrained edge changes
which, and the triangles at the box are free, so one breadth-first pass over the triangles'
components labels them all.

*Triangular expansion* (Bungiu, Hemmer, Hershberger, Huang and Kröller, "Efficient
computation of visibility polygons", 2014).  From a source ``s`` the visible region is
followed triangle by triangle: a *view* is a triangle entered through an edge with the
interval ``[L, R]`` of the directions of the rays from ``s`` that cross it.  With ``c`` the
triangle's third vertex at direction ``theta_c``, ``c`` is seen when ``theta_c`` is in
``[L, R]``, and the rays go on through the two other edges, ``[L, min(R, theta_c)]`` and
``[max(L, theta_c), R]``; a constrained edge stops them.  The first views are the triangles
at the source (the free triangles at its vertex when it is one, else the triangle holding
it, found by a walk), intersected with the window.  The work per source grows with the
triangles its visible region crosses, not with the map.

*Tolerances.*  A segment that passes within a few ``eps`` of a convex corner (grazing it,
running along a wall) may be free for the exact predicate although it crosses a boundary edge
near its end: where an interval is cut at a convex corner whose other edge in the triangle is
constrained, the cut is moved outwards by ``asin(kappa eps / |c - s|)`` (``kappa = 4``), and
every cut by ``1e-9`` rad; the seen test has the same slack.  A ray through a *pinch* (a
vertex where solids touch at a point: four or more constrained edges) goes on into the free
triangles at that vertex whose corner holds its direction: a point robot may pass there.

The candidates are a *superset*: each is still tested with the exact predicates of
:class:`~optplan.geometry.collision.obstacles.ObstacleSet` by its user.  Circle obstacles cast no
shadow here (their tangents are never filtered: :mod:`~optplan.geometry.tangent.tangent_graph`).

Why by hand: neither shapely nor scipy offers visibility from a point; the triangulation is
Triangle's (its ``p`` switch: the constrained triangulation of the edges, ``c``: of their
convex hull), the expansion is compiled with numba
(:mod:`optplan.geometry.tangent.triangular_expansion`) and tested against the all-pairs exact
segment tests in ``tests/geometry/test_sightlines.py``.
"""

from __future__ import annotations

import numpy as np
import triangle
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components

from optplan.geometry.tangent.triangular_expansion import expand_views, locate, pack_triangles

__all__ = ["OverBudget", "Sightlines"]


class OverBudget(RuntimeError):
    """The triangular expansion ran past its budget of views."""


def _complex(xy: np.ndarray) -> np.ndarray:
    """The points ``(n, 2)`` as complex numbers, exactly (no matrix product: numpy's BLAS
    threads would spin beside the expansion's two threads)."""
    return np.ascontiguousarray(xy, float).reshape(-1, 2).view(complex).ravel()


def _csr(keys: np.ndarray, items: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of ``items`` by ``keys`` in ``0 .. n - 1`` (stable)."""
    order = np.argsort(keys, kind="stable")
    start = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(keys, minlength=n), out=start[1:])
    return start, np.ascontiguousarray(items[order], dtype=np.int64)


def _free_triangles(T: np.ndarray, NB: np.ndarray, CON: np.ndarray, seed: int) -> np.ndarray:
    """Free space or solid per triangle: components joined by unconstrained edges, labelled
    by the parity of their breadth-first depth from the component of triangle ``seed``
    (crossing a constrained edge changes free to solid and back)."""
    nt = len(T)
    t = np.repeat(np.arange(nt), 3)
    nb, con = NB.ravel(), CON.ravel()
    ok = nb >= 0
    same = coo_matrix((np.ones(int((ok & ~con).sum())), (t[ok & ~con], nb[ok & ~con])),
                      shape=(nt, nt))
    ncomp, comp = connected_components(same, directed=False)
    cross = ok & con
    pairs = coo_matrix((np.ones(int(cross.sum())), (comp[t[cross]], comp[nb[cross]])),
                       shape=(ncomp, ncomp))
    order, pred = breadth_first_order(pairs, comp[seed], directed=False)
    depth = np.zeros(ncomp, np.int64)
    for c in order[1:]:
        depth[c] = depth[pred[c]] + 1
    return depth[comp] % 2 == 0


class Sightlines:
    """The constrained triangulation of one obstacle set's boundary edges and a set of
    centres, and the candidate query of
    :func:`~optplan.geometry.tangent.triangular_expansion.expand_views` over it.

    Parameters
    ----------
    edges : (m, 4) array
        Boundary edges ``x1, y1, x2, y2`` of the solids (local frame); two edges meet at
        most at their ends (the solids are disjoint but for pinch points).
    centres : (n, 2) array
        The points to find (local frame).
    corners : (c, 2) array
        The convex vertices of the solids (local frame): a cut is widened at a vertex only
        there (a segment can pass a convex corner, but not a reflex or straight vertex of a
        solid without entering it).
    eps : float
        The obstacle set's tolerance.
    extent : tuple
        ``(x0, y0, x1, y1)`` that the sources lie in (the local bounds).
    """

    def __init__(self, edges: np.ndarray, centres: np.ndarray, corners: np.ndarray,
                 eps: float, extent: tuple[float, float, float, float]):
        e4 = np.asarray(edges, float).reshape(-1, 4)
        self.centres = np.ascontiguousarray(np.asarray(centres, float).reshape(-1, 2))
        self.eps = float(eps)
        self.views = 0  # views run by the expansions so far (the work)
        n_c, m = len(self.centres), len(e4)
        pts = np.concatenate([self.centres, e4[:, :2], e4[:, 2:],
                              np.asarray(extent, float).reshape(2, 2)])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-12))
        box = np.array([[lo[0] - pad, lo[1] - pad], [hi[0] + pad, lo[1] - pad],
                        [hi[0] + pad, hi[1] + pad], [lo[0] - pad, hi[1] + pad]])
        z = _complex(np.concatenate([pts[:n_c + 2 * m], box]))
        self._keys, inv = np.unique(z, return_inverse=True)
        bv = inv[-4:]
        segs = np.concatenate([np.stack([inv[n_c:n_c + m], inv[n_c + m:n_c + 2 * m]], 1),
                               np.stack([bv, np.roll(bv, -1)], 1)])
        out = triangle.triangulate({"vertices": np.stack([self._keys.real, self._keys.imag], 1),
                                    "segments": segs}, "pcnQ")
        self.VX = np.ascontiguousarray(out["vertices"], float)
        self.T = np.ascontiguousarray(out["triangles"], np.int64)
        self.NB = np.ascontiguousarray(out["neighbors"], np.int64)
        nv, nt = len(self.VX), len(self.T)
        # the edge opposite corner k is (T[k+1], T[k+2]); its index in the neighbour
        back = np.where(self.NB[:, :, None] >= 0, self.NB[np.maximum(self.NB, 0)], -2)
        self.NK = np.ascontiguousarray(
            np.argmax(back == np.arange(nt)[:, None, None], axis=2), np.int64)
        a, b = self.T[:, [1, 2, 0]], self.T[:, [2, 0, 1]]
        s = np.asarray(out["segments"], np.int64)
        con_keys = np.minimum(s[:, 0], s[:, 1]) * nv + np.maximum(s[:, 0], s[:, 1])
        self.CON = np.ascontiguousarray(np.isin(np.minimum(a, b) * nv + np.maximum(a, b),
                                                con_keys))
        seed = int(np.flatnonzero((self.T == bv[0]).any(axis=1))[0])
        self.FREE = np.ascontiguousarray(_free_triangles(self.T, self.NB, self.CON, seed))
        self.CONV = np.zeros(nv, bool)
        self.CONV[self._vertex_ids(np.asarray(corners, float).reshape(-1, 2))[0]] = True
        inner = s[~np.isin(s, bv).any(axis=1)]  # not the box's edges
        self.PINCH = np.bincount(inner.ravel(), minlength=nv) >= 4
        self.vstart, self.vtri = _csr(self.T.ravel(), np.arange(3 * nt), nv)
        self.TR = pack_triangles(self.T, self.NB, self.NK, self.CON, self.FREE)
        self.cstart, self.citems = _csr(inv[:n_c], np.arange(n_c), nv)

    def _vertex_ids(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The vertices at the points ``xy`` (exactly), and which points are vertices."""
        z = _complex(xy)
        k = np.minimum(np.searchsorted(self._keys, z), max(len(self._keys) - 1, 0))
        hit = self._keys[k] == z
        return k[hit], hit

    def candidates(self, sources, lo, width) -> list[np.ndarray]:
        """Per source (local ``(k, 2)``), the indices of the centres it may see in the window
        ``lo .. lo + width`` (rad, counter-clockwise; ``width >= 2 pi``: all directions)."""
        counts, flat = self.candidates_flat(sources, lo, width)
        return np.split(flat, np.cumsum(counts)[:-1]) if len(counts) else []

    def candidates_flat(self, sources, lo, width, group=None,
                        budget: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`candidates` as ``(counts, flat)``: how many per source, and those of
        source 0, then of source 1, ...; consecutive sources of one ``group`` (ints, default
        each its own) list a centre once between them.  ``budget``: the views (triangles
        entered) the expansion may run; past it :class:`OverBudget` is raised (the
        expansion stops after the source that crossed it)."""
        S = np.ascontiguousarray(np.asarray(sources, float).reshape(-1, 2))
        k = len(S)
        G = np.arange(k) if group is None else np.ascontiguousarray(group, np.int64)
        LO, W = np.empty(k), np.empty(k)  # one per source (a scalar broadcast)
        LO[:], W[:] = np.asarray(lo, float), np.asarray(width, float)
        if k == 0 or len(self.centres) == 0:
            return np.zeros(k, np.int64), np.zeros(0, np.int64)
        SV = np.full(k, -1, np.int64)
        ids, hit = self._vertex_ids(S)
        SV[hit] = ids
        ST = np.full(k, -1, np.int64)
        for q in np.flatnonzero(~hit):
            ST[q] = locate(self.VX, self.TR, S[q, 0], S[q, 1], 0, 4 * len(self.T) + 8)
        mesh = (self.VX, self.TR, self.CONV, self.PINCH, self.vstart, self.vtri, self.cstart,
                self.citems)
        lim = -1 if budget is None else int(budget)
        counts, flat, views = expand_views((S, SV, ST, LO, W, G), mesh, self.eps, lim)
        self.views += int(views)
        if 0 <= lim < views:
            raise OverBudget(f"the sight lines ran more than {lim} views")
        return counts, flat
