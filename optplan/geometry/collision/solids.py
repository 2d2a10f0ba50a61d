r"""The obstacle region as a union of solids: touching and overlapping obstacles are one.

Obstacles are closed sets and the obstacle region is their *union*.  Two rectangles that share
an edge are one wall: the seam between them lies inside the region, and a path may run along
the union's outer boundary but never along or across a seam.  The collision engine
(:mod:`optplan.geometry.collision.obstacles`) erodes the boundary of each solid by ``eps`` to decide
point robots (a segment that runs along a boundary is not inside), so it must see the solids,
not the pieces as drawn: otherwise a seam would be a boundary of both pieces, eroded on both
sides, and a point robot would slide through it.

:func:`merge_solids` groups the polygon obstacles into *solids*, the connected components of the
relation "closer than ``eps``" (so touching, overlapping and contained pieces, and pieces whose
shared edge is off by round-off, are grouped), and replaces each group by its exact union
(GEOS overlay, ``shapely.unary_union``).  Before the union, each piece is snapped to the
pieces already merged with tolerance ``eps`` (``shapely.snap``: vertices within ``eps`` of a
vertex or an edge of the others move onto it), so that a shared edge that round-off has split
by less than ``eps`` closes instead of leaving a sliver of free space.  Every vertex moves by at
most ``eps``, the tolerance of every clearance decision.

Circle obstacles stay true circles (never polygonised): where a circle overlaps a polygon or
another circle, every point of their common boundary except isolated contact points lies in
the interior of one of them, so the engine's per-item tests already see no seam there.

Pinch points
    Pieces that touch at a single point only (two squares sharing a corner) form a solid whose
    interior does not contain that point.  A point robot (``r <= eps``) may pass through it,
    exactly as the shapely oracle ("the segment does not meet the interior of the union")
    says; any robot with ``r > eps`` may not.

    Where the touching pieces are also joined elsewhere (both touch the bounds wall, or a
    chain of pieces closes a pocket), the union is one polygon whose rings meet at the pinch:
    two holes, or a hole and the exterior, touching at a vertex.  Read ring by ring, that
    vertex is *reflex* in each ring (the ring's turn there spans the other ring's wedge too),
    although the solid has two *convex* corners there, one per piece, and a shortest path
    through the pinch turns on one of them.  :func:`corner_partners` pairs the edges at such a
    vertex by the solid wedge they bound, so that the corners read off the rings are the
    solid's own, however GEOS lays out the rings.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon

__all__ = ["merge_solids", "corner_partners", "solid_rings", "solid_edges"]


def _valid_polygonal(g) -> object | None:
    """``g`` as a valid Polygon or MultiPolygon of its areal parts, or None when empty."""
    if not g.is_valid:
        g = shapely.make_valid(g)
    elif isinstance(g, Polygon):  # already what is asked for, when it has an area
        return g if g.area > 0 else None
    polys = [q for q in shapely.get_parts(g) if isinstance(q, Polygon) and q.area > 0]
    if not polys:
        return None
    return polys[0] if len(polys) == 1 else MultiPolygon(polys)


def _union(geoms: list, before: list[list[int]], eps: float) -> object | None:
    """Exact union of ``geoms`` after snapping each onto its (already snapped) neighbours
    that come before it (``before[k]``: indices ``< k`` within ``eps`` of ``geoms[k]``).

    Snapping in one order, each piece onto pieces that no longer move, makes two near-equal
    vertices meet instead of trading places; the work per piece grows with its neighbours,
    not with the size of the solid.
    """
    snapped: list = []
    for k, g in enumerate(geoms):
        if before[k]:
            near = [snapped[j] for j in before[k]]
            ref = near[0] if len(near) == 1 else shapely.union_all(near)
            s = _valid_polygonal(shapely.snap(g, ref, eps))
            g = g if s is None else s
        snapped.append(g)
    try:
        merged = shapely.union_all(snapped)
    except shapely.errors.GEOSException:  # snapping made the overlay fail: plain union
        merged = shapely.union_all(geoms)
    return _valid_polygonal(merged)


def merge_solids(shapes: list[tuple[int, object]], eps: float
                 ) -> tuple[list[tuple[int, object]], dict[int, tuple[int, ...]]]:
    """Replace touching polygon obstacles by their union (module docstring).

    Parameters
    ----------
    shapes : list of ``(index, shape)``
        As returned by :func:`optplan.geometry.collision.obstacles.clip_obstacles`: a valid,
        non-empty shapely Polygon or MultiPolygon, or a ``(cx, cy, R)`` tuple for a circle (kept as
        is).
    eps : float
        The geometric tolerance of the frame.

    Returns
    -------
    solids : list of ``(index, shape)``
        One entry per solid, in the order of the first obstacle of each; ``index`` is the
        smallest obstacle index in the solid (its *representative*).
    members : dict
        For every solid of two or more obstacles, representative -> obstacle indices (sorted).
    """
    polys = [(i, g) for i, g in shapes if not isinstance(g, tuple)]
    circles = [(i, g) for i, g in shapes if isinstance(g, tuple)]
    if not polys:
        return list(shapes), {}
    # the shapes of clip_obstacles are valid, non-empty polygonal geometries
    idx = [i for i, _ in polys]
    geoms = [g for _, g in polys]
    groups, nbrs = _groups(geoms, idx, eps)
    out: dict[int, object] = {}
    members: dict[int, tuple[int, ...]] = {}
    for ks in groups:
        if len(ks) == 1:
            out[idx[ks[0]]] = geoms[ks[0]]
            continue
        group = sorted(ks.tolist(), key=lambda k: idx[k])
        u = _merge_group(group, geoms, nbrs, eps)
        if u is not None:
            out[idx[group[0]]] = u
            members[idx[group[0]]] = tuple(idx[k] for k in group)
    solids = sorted([*out.items(), *circles], key=lambda t: t[0])
    return solids, members


def _merge_group(group: list[int], geoms: list, nbrs: dict[int, list[int]], eps: float):
    """The union of the pieces at positions ``group`` (in obstacle-index order)."""
    pos = {k: q for q, k in enumerate(group)}
    return _union([geoms[k] for k in group], [[pos[v] for v in nbrs.get(k, ())]
                                              for k in group], eps)


def _groups(geoms: list, idx: list[int], eps: float
            ) -> tuple[list[np.ndarray], dict[int, list[int]]]:
    """The connected components of "closer than ``eps``" (arrays of positions in ``geoms``)
    and, per position, its neighbours of smaller obstacle index (the pieces it is snapped
    onto)."""
    n = len(geoms)
    a, b = shapely.STRtree(geoms).query(geoms, predicate="dwithin", distance=eps)
    off = a != b
    n_comp, label = _components(n, a[off], b[off])
    order = np.argsort(label, kind="stable")
    groups = np.split(order, np.cumsum(np.bincount(label, minlength=n_comp))[:-1])
    rank = np.argsort(np.argsort(np.asarray(idx), kind="stable"), kind="stable")
    earlier = off & (rank[b] < rank[a])
    nbrs: dict[int, list[int]] = {}
    for u, v in zip(a[earlier].tolist(), b[earlier].tolist()):
        nbrs.setdefault(u, []).append(v)
    return groups, nbrs


def _components(n: int, a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    """The connected components of the graph on ``n`` nodes with the edges ``a[k] - b[k]``
    (listed both ways): their number and each node's label, the components numbered in the
    order of their smallest node.  Every node points to a node of its component; each round
    points every root at its smallest neighbouring label and jumps the pointers to the
    roots, until no edge joins two labels: then each component's label is its smallest node
    (it points to a node of the component, no smaller than itself).

    Why by hand: scipy's ``connected_components`` (the oracle of
    ``tests/geometry/test_components.py``; the sight lines' triangulation is labelled with it)
    sets up a sparse matrix per call, which was most of the grouping's time on maps of a few
    obstacles (a cold ``visgraph`` query: ``benchmarks/bench_visgraph.py --against``)."""
    lab = np.arange(n)
    while True:
        new = lab.copy()
        np.minimum.at(new, lab[a], lab[b])
        while True:
            jump = new[new]
            if np.array_equal(jump, new):
                break
            new = jump
        if np.array_equal(new, lab):
            break
        lab = new
    roots, label = np.unique(lab, return_inverse=True)
    return len(roots), label.ravel()


def corner_partners(v: np.ndarray, prv: np.ndarray, nxt: np.ndarray) -> np.ndarray:
    """The incoming edge of each vertex's *solid wedge* (module docstring, pinch points).

    ``v`` ``(n, 2)``: the vertices of closed rings with the solid on their left (all rings of
    all solids concatenated), ``prv`` / ``nxt``: the index of each vertex's ring neighbours.
    A vertex that the rings pass once bounds one solid wedge, between its incoming and its
    outgoing edge: its entry is ``prv`` unchanged.  Where the rings pass a point ``k > 1``
    times (a pinch), the ``2k`` edges there alternate around it between solid and free
    wedges; the solid wedge left of an outgoing edge ends at the first edge counter-clockwise
    from it, which is an incoming edge travelled backwards.  Returns ``prv`` with, at those
    points, the start of that incoming edge: ``v[k] - v[out[k]]`` and ``v[nxt[k]] - v[k]``
    are the two edges of one solid wedge, convex or not by the usual turn test.

    Points are matched exactly (the merge snaps touching vertices onto each other); edges of
    zero length keep their ring neighbour.
    """
    prv = np.asarray(prv)
    out = prv.copy()
    if len(v) < 2:
        return out
    s = v[np.lexsort((v[:, 1], v[:, 0]))]
    if not np.any((s[1:, 0] == s[:-1, 0]) & (s[1:, 1] == s[:-1, 1])):
        return out  # no point that the rings pass twice
    z = v[:, 0] + 1j * v[:, 1]
    _, inv, cnt = np.unique(z, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    d_out = v[nxt] - v
    d_back = v[prv] - v
    ok = (cnt[inv] > 1) & np.any(d_out != 0, axis=1) & np.any(d_back != 0, axis=1)
    rep = np.flatnonzero(ok)
    if not len(rep):
        return out
    rep = rep[np.argsort(inv[rep], kind="stable")]
    a_out = np.arctan2(d_out[rep, 1], d_out[rep, 0])
    a_back = np.arctan2(d_back[rep, 1], d_back[rep, 0])
    grp = inv[rep]
    cut = np.flatnonzero(np.r_[True, grp[1:] != grp[:-1], True])
    for s, e in zip(cut[:-1], cut[1:]):
        if e - s < 2:
            continue
        ccw = np.mod(a_back[None, s:e] - a_out[s:e, None], 2.0 * np.pi)
        ccw[ccw <= 0.0] = np.inf  # an edge back along an outgoing one: no wedge
        out[rep[s:e]] = prv[rep[s:e][np.argmin(ccw, axis=1)]]
    return out


def solid_rings(oset) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rings of the polygon solids of the obstacle set ``oset`` (local frame), read once
    and kept with the set: every ring's points ``(m, 2)`` (its closing repeat included) and
    each point's ring, then per ring whether it is an exterior (else a hole) and whether it
    runs counter-clockwise.  The rings come in the order of the solids, of their polygons
    and, per polygon, the exterior first (``shapely.get_rings``)."""
    got = oset._cache.get("rings")
    if got is None:
        polys = [g for _, g in oset.shapes if not isinstance(g, tuple)]
        rings, part = shapely.get_rings(shapely.get_parts(np.array(polys, dtype=object)),
                                        return_index=True)
        xy, ring = shapely.get_coordinates(rings, return_index=True)
        exterior = np.ones(len(rings), bool)
        exterior[1:] = part[1:] != part[:-1]
        got = oset._cache["rings"] = (xy, ring, exterior, shapely.is_ccw(rings))
    return got


def solid_edges(oset) -> np.ndarray:
    """The boundary edges of the polygon solids of ``oset`` (local frame), ``(m, 4)``: ``x1,
    y1, x2, y2``, every edge of every ring (exterior and holes) of the solids' polygons once,
    so the rings close (the constrained edges of :mod:`~optplan.geometry.tangent.sightlines`)."""
    xy, ring = solid_rings(oset)[:2]
    same = np.flatnonzero(ring[1:] == ring[:-1])  # consecutive points of one ring
    seg = np.concatenate([xy[same], xy[same + 1]], axis=1).reshape(-1, 4)
    return np.ascontiguousarray(seg[(seg[:, 0] != seg[:, 2]) | (seg[:, 1] != seg[:, 3])])
