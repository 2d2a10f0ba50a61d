"""The circles of the tangent graph and the exact test of an arc along one.

A shortest path of a disc robot of radius ``r`` touches the grown obstacles only on circles:
radius ``r`` around every *convex* vertex of a polygon ring (holes included), with its *normal
cone* (the directions between the outward normals of the two edges), and radius ``R + r``
around every circle obstacle (all directions).  :func:`circles_of` lists them;
:class:`ArcChecker` decides exactly whether an arc along one keeps ``r`` from the obstacles (the
compiled test of :mod:`optplan.geometry.collision.arc_kernel`: arc-to-segment and
arc-to-circle distances in closed form).  The search that uses
them is :mod:`optplan.geometry.tangent.tangent_graph`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from optplan.geometry.collision import ObstacleSet, corner_partners, solid_rings
from optplan.geometry.collision.arc_kernel import ANGLE_TOL, TWO_PI, arcs_free

__all__ = ["TWO_PI", "ANGLE_TOL", "Circles", "circles_of", "ArcChecker"]



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

    @cached_property
    def cap(self) -> np.ndarray:
        """Largest cone offset: ``width``, ``inf`` on a circle obstacle (no clamp)."""
        return np.where(self.full, np.inf, self.width)

    @cached_property
    def reach(self) -> np.ndarray:
        """Largest offset still in the cone: ``width + ANGLE_TOL``, ``inf`` on a circle
        obstacle (every direction)."""
        return np.where(self.full, np.inf, self.width + ANGLE_TOL)


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
    pt = np.flatnonzero(np.append(ring[1:] == ring[:-1], False))  # not a ring's closing repeat
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
    cen = np.concatenate([v, cc[:, :2]])
    rho = np.concatenate([np.full(len(v), r), cc[:, 2] + r])
    lo = np.concatenate([lo, np.zeros(len(cc))])
    wd = np.concatenate([wd, np.full(len(cc), TWO_PI)])
    full = np.concatenate([np.zeros(len(v), bool), np.ones(len(cc), bool)])
    # walled: a circle farther outside the bounds than its radius is never touched by a path
    # inside them (the wall's outer corners, vertices of obstacles clipped beyond the edge)
    if oset.walled:
        keep = _reaches_bounds(oset, cen, rho)
        cen, rho, lo, wd, full = cen[keep], rho[keep], lo[keep], wd[keep], full[keep]
    return Circles(cen[:, 0] + 1j * cen[:, 1], rho, lo, wd, full)


@dataclass
class ArcChecker:
    """Exact arc-free tests: does an arc along a circle keep ``r`` from every obstacle?

    The compiled test of the obstacle set
    (:func:`~optplan.geometry.collision.arc_kernel.arcs_free`: exact distances to the solids'
    boundary edges and the circle obstacles near the arc, through the set's own screen), on
    arcs given by their circle, start angle, sweep and sense.  Every arc the searches test
    starts at a free point (the end of a free tangent, or a query's start), as that test
    requires.
    """

    oset: ObstacleSet
    circles: Circles

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
        sweep = np.atleast_1d(np.asarray(sweep, float))
        theta0 = np.atleast_1d(np.asarray(theta0, float))
        start = np.where(np.atleast_1d(np.asarray(sense)) > 0, theta0, theta0 - sweep)
        C = self.circles
        return arcs_free(self.oset, C.center[idx], C.rho[idx], start, sweep)
