"""The circles of the tangent graph and the exact test of an arc along one.

A shortest path of a disc robot of radius ``r`` touches the grown obstacles only on circles:
radius ``r`` around every *convex* vertex of a polygon ring (holes included), with its *normal
cone* (the directions between the outward normals of the two edges), and radius ``R + r``
around every circle obstacle (all directions).  :func:`circles_of` lists them;
:class:`ArcChecker` decides exactly whether an arc along one keeps ``r`` from the items near
its circle (arc-to-segment and arc-to-circle distances in closed form).  The search that uses
them is :mod:`optplan.geometry.tangent.tangent_graph`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely

from optplan.geometry.collision import ObstacleSet, corner_partners, solid_edges, solid_rings

__all__ = ["TWO_PI", "ANGLE_TOL", "Circles", "circles_of", "ArcChecker"]

TWO_PI = 2.0 * math.pi
#: Angular slack (rad) of the normal-cone tests (tangents along an offset edge sit on the
#: cone's boundary up to round-off).
ANGLE_TOL = 1e-9


@dataclass(frozen=True)
class Circles:
    """The circles of the tangent graph (local frame).

    Attributes
    ----------
    center : complex array ``(n,)``
    rho : array ``(n,)``
        Radius (``r`` at polygon vertices, ``R + r`` for circle obstacles).
    lo, width : arrays ``(n,)``
        Normal cone: directions ``lo .. lo + width`` (rad, counter-clockwise);
        ``width = 2 pi`` for circle obstacles.
    full : bool array ``(n,)``
        Circle obstacle (every direction allowed, arcs may wrap).
    """

    center: np.ndarray
    rho: np.ndarray
    lo: np.ndarray
    width: np.ndarray
    full: np.ndarray

    @property
    def n(self) -> int:
        return len(self.center)


def _convex_vertices(v: np.ndarray, prv: np.ndarray, nxt: np.ndarray):
    """Convex vertices of rings whose solid lies on their left (all rings concatenated in
    ``v``, with the index of each vertex's ring neighbours): (vertices, cone lo, cone width)."""
    e2 = v[nxt] - v
    e1 = v - v[prv]
    l1, l2 = np.hypot(*e1.T), np.hypot(*e2.T)
    cr = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    convex = (l1 > 0) & (l2 > 0) & (cr > 1e-12 * l1 * l2)
    n1 = np.arctan2(-e1[:, 0], e1[:, 1])  # outward normal rot(-90) of the incoming edge
    n2 = np.arctan2(-e2[:, 0], e2[:, 1])
    width = np.mod(n2 - n1, TWO_PI)
    return v[convex], n1[convex], width[convex]


def _reaches_bounds(oset: ObstacleSet, centers: np.ndarray, rho) -> np.ndarray:
    """Per circle (local centres ``(n, 2)``, radii ``rho``): it comes within ``eps`` of the
    bounds, so a path inside them may touch it."""
    x0, y0, x1, y1 = oset.frame.local_bounds
    dx = np.maximum(np.maximum(x0 - centers[:, 0], centers[:, 0] - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - centers[:, 1], centers[:, 1] - y1), 0.0)
    return np.hypot(dx, dy) <= rho + 2.0 * oset.frame.eps


def circles_of(oset: ObstacleSet) -> Circles:
    """Circles of the tangent graph for the obstacles of ``oset`` (radius ``oset.radius``)."""
    r = oset.radius
    circ = [g for _, g in oset.shapes if isinstance(g, tuple)]
    xy, ring, exterior, ccw = solid_rings(oset)
    pt = np.flatnonzero(np.r_[ring[1:] == ring[:-1], False])  # not a ring's closing repeat
    ring = ring[pt]
    sizes = np.bincount(ring, minlength=len(exterior))
    first = np.cumsum(sizes) - sizes
    pos = np.arange(len(pt)) - first[ring]
    # the solid on the left: an exterior counter-clockwise, a hole clockwise
    turn = (exterior != ccw)[ring]
    keep = sizes[ring] >= 3
    allv = xy[pt[first[ring] + np.where(turn, sizes[ring] - 1 - pos, pos)][keep]]
    if len(allv):
        sizes = sizes[sizes >= 3]
        start = np.repeat(np.cumsum(sizes) - sizes, sizes)
        pos = np.arange(int(sizes.sum())) - start
        size = np.repeat(sizes, sizes)
        nxt = start + (pos + 1) % size
        # at a pinch the rings meet: pair the edges by the solid wedge they bound
        v, lo, wd = _convex_vertices(allv, corner_partners(allv, start + (pos - 1) % size, nxt),
                                     nxt)
    else:
        v, lo, wd = np.zeros((0, 2)), np.zeros(0), np.zeros(0)
    cc = np.array(circ, dtype=float).reshape(-1, 3)
    # walled: a circle farther outside the bounds than its radius is never touched by a path
    # inside them (the wall's outer corners, vertices of obstacles clipped beyond the edge)
    if oset.walled:
        keep = _reaches_bounds(oset, v, r)
        v, lo, wd = v[keep], lo[keep], wd[keep]
        cc = cc[_reaches_bounds(oset, cc[:, :2], cc[:, 2] + r)]
    return Circles(np.concatenate([v[:, 0] + 1j * v[:, 1], cc[:, 0] + 1j * cc[:, 1]]),
                   np.concatenate([np.full(len(v), r), cc[:, 2] + r]),
                   np.concatenate([lo, np.zeros(len(cc))]),
                   np.concatenate([wd, np.full(len(cc), TWO_PI)]),
                   np.concatenate([np.zeros(len(v), bool), np.ones(len(cc), bool)]))


# --------------------------------------------------------------------------------------
# exact arc tests
# --------------------------------------------------------------------------------------


def _in_arc(phi, start, sweep):
    """Angle ``phi`` within the CCW arc ``start .. start + sweep``."""
    return np.mod(phi - start, TWO_PI) <= sweep + ANGLE_TOL


def _point_arc_dist(q, c, rho, start, sweep):
    """Distance from points ``q`` to CCW arcs (broadcasting complex arrays)."""
    v = q - c
    inarc = _in_arc(np.angle(v), start, sweep)
    p0 = c + rho * np.exp(1j * start)
    p1 = c + rho * np.exp(1j * (start + sweep))
    return np.where(inarc, np.abs(np.abs(v) - rho), np.minimum(np.abs(q - p0), np.abs(q - p1)))


def _point_seg_dist(q, P, E):
    """Distance from ``q`` to segments ``P -> P + E``."""
    ee = (E * E.conj()).real
    t = np.clip(((q - P) * E.conj()).real / np.maximum(ee, 1e-300), 0.0, 1.0)
    return np.abs(q - (P + t * E))


def _arc_seg_dist(c, rho, start, sweep, P, E):
    """Exact distance between CCW arcs and segments ``P -> P + E`` (broadcast).

    The minimum is attained at an arc end, a segment end, an intersection, or the arc point
    whose radius is normal to the segment (foot inside the segment).
    """
    p0 = c + rho * np.exp(1j * start)
    p1 = c + rho * np.exp(1j * (start + sweep))
    d = np.minimum(_point_seg_dist(p0, P, E), _point_seg_dist(p1, P, E))
    d = np.minimum(d, _point_arc_dist(P, c, rho, start, sweep))
    d = np.minimum(d, _point_arc_dist(P + E, c, rho, start, sweep))
    L = np.abs(E)
    u = E / np.maximum(L, 1e-300)
    # arc points with radius normal to the segment: c +- rho * i u
    for sgn in (1.0, -1.0):
        x = c + sgn * rho * 1j * u
        t = ((x - P) * u.conj()).real
        ok = (t >= 0) & (t <= L) & _in_arc(np.angle(sgn * 1j * u), start, sweep)
        d = np.where(ok, np.minimum(d, np.abs(((x - P) * u.conj()).imag)), d)
    # intersections of the circle with the segment's line
    w = P - c
    b = (w * u.conj()).real
    h2 = b * b - (np.abs(w) ** 2 - rho * rho)
    sq = np.sqrt(np.maximum(h2, 0.0))
    for t in (-b - sq, -b + sq):
        x = P + t * u
        ok = (h2 >= 0) & (t >= 0) & (t <= L) & _in_arc(np.angle(x - c), start, sweep)
        d = np.where(ok, 0.0, d)
    return d


#: Arcs :meth:`ArcChecker.free_many` tests in one batch (bounds its temporary memory).
ARC_BATCH = 1 << 15


@dataclass
class ArcChecker:
    """Exact arc-free tests: does an arc along a circle keep ``r`` from every obstacle?

    Every arc the searches test starts at a free point (the end of a free tangent, or a
    query's start), so it comes within ``r`` of a solid only where it comes within ``r`` of
    the solid's *boundary* (to get inside, it crosses it): an arc is tested against the
    boundary edges of the polygon solids (:func:`~optplan.geometry.collision.solid_edges`,
    the internal diagonals of the convex tiling left out) and the circle obstacles, in
    closed form (:func:`_arc_seg_dist`, :func:`_point_arc_dist`).  Only those that may come
    near the arc are tested: the arc lies within ``b = 2 rho sin(sweep / 4)`` of its
    midpoint ``m``, so an edge (circle) farther than ``b + r`` from ``m`` cannot block it.
    The candidates come from one R-tree (``shapely.STRtree``, made once per obstacle set on
    the first test) over the edges and the circles' bounding boxes: the edges within ``b + r``
    of ``m`` (GEOS's segment distance; ``b + r`` carries a few ``eps`` of slack) and the
    circles whose box is, kept when their exact distance from ``m`` is within ``b + r``.  The
    cost per arc is that of the items near the arc, not of those near its circle: on a
    polygon of 20,000 vertices round a circle, a few tens, not thousands (the chains phase of
    ``benchmarks/bench_crowded.py``, where the arcs are tested).  Tested against every piece
    edge and circle in ``tests/geometry/test_arc_checker.py``.
    """

    oset: ObstacleSet
    circles: Circles
    cache: dict = field(default_factory=dict)

    def _index(self) -> dict:
        """One R-tree (``shapely.STRtree``) over the boundary edges, then the circle
        obstacles' bounding boxes (grown by ``eps``: each holds its disc), with their
        arrays."""
        ix = self.cache.get("index")
        if ix is None:
            S = self.oset
            seg = solid_edges(S)
            cc, cr = S.item_center[S.n_pieces:], S.circle_radius
            h = cr + S.eps
            items = np.concatenate([shapely.linestrings(seg.reshape(-1, 2, 2)) if len(seg) else
                                    np.zeros(0, object),
                                    shapely.box(cc.real - h, cc.imag - h, cc.real + h,
                                                cc.imag + h)])
            ix = {"P": seg[:, 0] + 1j * seg[:, 1],
                  "E": (seg[:, 2] - seg[:, 0]) + 1j * (seg[:, 3] - seg[:, 1]),
                  "n_edges": len(seg), "cc": cc, "cr": cr,
                  "tree": shapely.STRtree(items) if len(items) else None}
            self.cache["index"] = ix
        return ix

    def free(self, i: int, theta0: np.ndarray, sweep: np.ndarray, sense: int) -> np.ndarray:
        """Arcs on circle ``i`` from angles ``theta0`` over ``sweep >= 0`` in ``sense``: free."""
        theta0 = np.atleast_1d(np.asarray(theta0, float))
        n = len(theta0)
        return self.free_many(np.full(n, int(i)), theta0, np.broadcast_to(sweep, n),
                              np.full(n, int(sense)))

    def free_many(self, idx: np.ndarray, theta0: np.ndarray, sweep: np.ndarray,
                  sense: np.ndarray) -> np.ndarray:
        """Arcs on circles ``idx`` from angles ``theta0`` over ``sweep >= 0`` in ``sense``
        (``+1`` CCW, ``-1`` CW), per arc: free.  Arcs on circles of radius 0 are free."""
        idx = np.atleast_1d(np.asarray(idx, np.int64))
        out = np.ones(len(idx), bool)
        sweep = np.atleast_1d(np.asarray(sweep, float))
        theta0 = np.atleast_1d(np.asarray(theta0, float))
        sense = np.atleast_1d(np.asarray(sense))
        todo = np.flatnonzero(self.circles.rho[idx] > 0)
        for q in range(0, len(todo), ARC_BATCH):
            k = todo[q:q + ARC_BATCH]
            start = np.where(sense[k] > 0, theta0[k], theta0[k] - sweep[k])
            out[k] = ~self._blocked(self.circles.center[idx[k]], self.circles.rho[idx[k]],
                                    start, sweep[k])
        return out

    def _blocked(self, c: np.ndarray, rho: np.ndarray, start: np.ndarray,
                 sweep: np.ndarray) -> np.ndarray:
        """CCW arcs (centres ``c``, radii ``rho``, from ``start`` over ``sweep``) that come
        closer than ``r - eps`` to a boundary edge or a circle obstacle."""
        S, ix = self.oset, self._index()
        lim = S.radius - S.eps
        m = c + rho * np.exp(1j * (start + 0.5 * sweep))
        reach = 2.0 * rho * np.sin(0.25 * np.minimum(sweep, TWO_PI)) + lim + 4.0 * S.eps
        out = np.zeros(len(c), bool)
        if ix["tree"] is None:
            return out
        a, e = ix["tree"].query(shapely.points(m.real, m.imag), predicate="dwithin",
                                distance=reach)
        edge = e < ix["n_edges"]
        ae, ee = a[edge], e[edge]
        d = _arc_seg_dist(c[ae], rho[ae], start[ae], sweep[ae], ix["P"][ee], ix["E"][ee])
        out[ae[d < lim]] = True
        if not edge.all():  # circles whose box comes within reach: their exact distance
            ac, b = a[~edge], e[~edge] - ix["n_edges"]
            cc, cr = ix["cc"][b], ix["cr"][b]
            near = np.abs(m[ac] - cc) - cr <= reach[ac]
            ac, cc, cr = ac[near], cc[near], cr[near]
            d = _point_arc_dist(cc, c[ac], rho[ac], start[ac], sweep[ac]) - cr
            out[ac[d < lim]] = True
        return out

