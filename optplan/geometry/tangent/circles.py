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

from optplan.geometry.collision import ObstacleSet, corner_partners

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
    rings, circ = [], []
    for _, g in oset.shapes:
        if isinstance(g, tuple):
            circ.append(g)
            continue
        for p in getattr(g, "geoms", [g]):
            ext = np.asarray(p.exterior.coords)[:-1]
            rings.append(ext if p.exterior.is_ccw else ext[::-1])  # solid on the left
            for h in p.interiors:
                c = np.asarray(h.coords)[:-1]
                rings.append(c[::-1] if h.is_ccw else c)
    rings = [q for q in rings if len(q) >= 3]
    if rings:
        sizes = np.array([len(q) for q in rings])
        start = np.repeat(np.cumsum(sizes) - sizes, sizes)
        idx = np.arange(int(sizes.sum()))
        pos = idx - start
        size = np.repeat(sizes, sizes)
        allv, nxt = np.concatenate(rings), start + (pos + 1) % size
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


@dataclass
class ArcChecker:
    """Exact arc-free tests against the items near each circle (cached per circle)."""

    oset: ObstacleSet
    circles: Circles
    cache: dict = field(default_factory=dict)

    def _near(self, i: int):
        if i not in self.cache:
            S, C = self.oset, self.circles
            reach = C.rho[i] + S.radius + 4 * S.eps
            it = np.flatnonzero(np.abs(S.item_center - C.center[i]) - S.item_reach
                                <= C.rho[i] + reach)
            pk = it[it < S.n_pieces]
            ck = it[it >= S.n_pieces]
            P = S.table[0][:, pk].ravel()
            E = S.table[1][:, pk].ravel()
            # only the edges within the same reach: an item's reach is that of its farthest
            # edge (the bounds' wall reaches every circle; few of its edges come near)
            near = _point_seg_dist(C.center[i], P, E) <= C.rho[i] + reach
            self.cache[i] = (P[near], E[near], S.item_center[ck],
                             S.circle_radius[ck - S.n_pieces])
        return self.cache[i]

    def free(self, i: int, theta0: np.ndarray, sweep: np.ndarray, sense: int) -> np.ndarray:
        """Arcs on circle ``i`` from angles ``theta0`` over ``sweep >= 0`` in ``sense``: free."""
        theta0 = np.atleast_1d(np.asarray(theta0, float))
        sweep = np.atleast_1d(np.asarray(sweep, float))
        out = np.ones(len(theta0), bool)
        rho = float(self.circles.rho[i])
        if rho == 0.0 or len(theta0) == 0:
            return out
        S = self.oset
        start = theta0 if sense > 0 else theta0 - sweep
        c = self.circles.center[i]
        P, E, cc, cr = self._near(i)
        lim = S.radius - S.eps
        if len(P):
            d = _arc_seg_dist(c, rho, start[:, None], sweep[:, None], P[None, :], E[None, :])
            out &= ~(d < lim).any(axis=1)
        if len(cc):
            d = _point_arc_dist(cc[None, :], c, rho, start[:, None], sweep[:, None]) - cr[None, :]
            out &= ~(d < lim).any(axis=1)
        return out
