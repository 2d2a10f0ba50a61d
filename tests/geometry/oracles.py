"""Independent oracles of the geometry tests: shapely and scipy only, never optplan's geometry.

* :func:`plain_visibility_length`: a point robot's shortest path among polygons (every vertex
  a node, an edge kept when its open segment does not meet the interior of the union).
* :func:`polygonal_bracket`: a disc robot's optimum bracketed by inscribed and circumscribed
  round buffers, each solved by the plain visibility graph.
* :func:`path_is_free`: a polyline's clearance from the union of the raw obstacles.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient


def plain_visibility_length(polys: list[Polygon], start, goal) -> float:
    """Shortest path of a point robot among ``polys`` (their union is the obstacle region);
    ``inf`` when the goal is not reachable."""
    nodes = [tuple(start), tuple(goal)]
    for p in polys:
        for ring in (p.exterior, *p.interiors):
            nodes.extend(tuple(c) for c in np.asarray(ring.coords)[:-1])
    nodes = np.array(nodes)
    n = len(nodes)
    i, j = np.triu_indices(n, 1)
    union = shapely.unary_union(polys)
    shapely.prepare(union)
    # screen before the exact test: a segment with a point (its middle, quarters, eighths) in
    # the interior, farther than 1e-9 x the extent from the boundary (not a rounding artefact
    # of the point), meets the interior: blocked
    x0, y0, x1, y1 = union.bounds
    edge = union.boundary
    shapely.prepare(edge)
    tol = 1e-9 * max(x1 - x0, y1 - y0, 1.0)
    blocked = np.zeros(len(i), bool)
    for f in (0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875):
        k = np.flatnonzero(~blocked)
        pts = shapely.points((1 - f) * nodes[i[k]] + f * nodes[j[k]])
        inside = shapely.contains_properly(union, pts)
        k, pts = k[inside], pts[inside]
        blocked[k[~shapely.dwithin(edge, pts, tol)]] = True
    # the exact test of the others: a segment that meets the union is blocked unless it only
    # touches it (DE-9IM: their interiors do not meet; the same verdicts as relate_pattern
    # "T********", faster on a prepared geometry)
    test = np.flatnonzero(~blocked)
    segs = shapely.linestrings(np.stack([nodes[i[test]], nodes[j[test]]], axis=1))
    meet = shapely.intersects(union, segs)
    blocked[test[meet]] = ~shapely.touches(union, segs[meet])
    d = nodes[j] - nodes[i]
    length = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])
    ok = ~blocked & (length > 0)
    i, j, w = i[ok], j[ok], length[ok]
    g = csr_matrix((np.r_[w, w], (np.r_[i, j], np.r_[j, i])), shape=(n, n))
    return float(dijkstra(g, indices=0)[1])


def polygonal_bracket(polys: list[Polygon], r: float, start, goal) -> tuple[float, float]:
    """Bracket of a disc robot's optimum: shapely round buffers of the polygons by r
    (inscribed, quad_segs 16) and by r / cos(3 pi / 128) (circumscribed: GEOS may round a
    corner's segment count so one chord spans 1.5 nominal steps), each solved by the plain
    visibility graph."""

    def grown(d):
        u = shapely.unary_union([p.buffer(d, quad_segs=16) for p in polys])
        return [orient(g, 1.0) for g in getattr(u, "geoms", [u])]

    return (plain_visibility_length(grown(r), start, goal),
            plain_visibility_length(grown(r / math.cos(3 * math.pi / 128)), start, goal))


def path_is_free(path, polys: list[Polygon], r: float, tol: float) -> bool:
    """Whether ``path`` keeps a disc of radius ``r`` clear of the union of ``polys`` up to
    ``tol``: a point robot (``r <= tol``) runs at most ``tol`` inside the union eroded by
    ``tol`` (it may run along the boundary and pass a pinch point), a disc stays at distance
    ``>= r - tol``."""
    union = shapely.unary_union(polys)
    line = shapely.LineString(np.asarray(path, float))
    if r <= tol:
        core = union.buffer(-tol, join_style="mitre")
        return float(shapely.length(shapely.intersection(line, core))) <= tol
    return float(shapely.distance(line, union)) >= r - tol
