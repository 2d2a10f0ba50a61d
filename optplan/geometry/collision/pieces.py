"""The one convex decomposition of optplan: polygons (holes allowed) into convex pieces.

:func:`convex_decompose` gives few, large convex pieces (the NLP's separating-hyperplane
constraints use them); :func:`convex_pieces` fan-splits those into pieces of at most
``max_edges`` vertices with boundary flags (the collision engine's fixed-width edge tables).

Decomposition: a convex polygon without holes is one piece.  Otherwise the polygon is
triangulated by ``shapely.constrained_delaunay_triangles`` (its triangles use the polygon's own
vertices) and triangles are merged greedily across shared edges while the merged ring stays
convex (Hertel & Mehlhorn 1983: at most 4x the minimum number of convex pieces).  Every
convexity and collinearity test is relative (``|sin angle| <= 1e-12``), never in absolute
coordinates.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry.polygon import orient

__all__ = ["convex_decompose", "convex_pieces", "convex_pieces_many", "clean_ring", "is_convex"]

#: Relative tolerance of the collinearity / convexity tests (sine of the turning angle).
SIN_TOL = 1e-12


def _turns(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cross products of consecutive edges at each vertex of a ring ``(k, 2)`` (or of each
    ring of ``(m, k, 2)``), and the products of their lengths."""
    k = v.shape[-2]
    nxt, prv = (np.arange(k) + 1) % k, (np.arange(k) - 1) % k
    e = v[..., nxt, :] - v  # edge i: v[i] -> v[i+1]
    a = e[..., prv, :]  # incoming edge at vertex i
    cr = a[..., 0] * e[..., 1] - a[..., 1] * e[..., 0]
    ln = np.hypot(e[..., 0], e[..., 1])
    return cr, ln[..., prv] * ln


def _convex_rows(q: np.ndarray) -> np.ndarray:
    """:func:`is_convex` of each ring ``q[k]`` (``(m, k, 2)``, rings of one length)."""
    cr, sc = _turns(q)
    return np.all(cr >= -SIN_TOL * sc, axis=-1)


def clean_ring(v: np.ndarray) -> np.ndarray:
    """Drop repeated and collinear vertices of a ring (no closing repeat)."""
    return _clean(v)[0]


def _clean(v: np.ndarray) -> tuple[np.ndarray, bool | None]:
    """:func:`clean_ring` of ``v`` and, from the turns it computed last, :func:`is_convex` of
    the result (None when it has fewer than 3 vertices or no pass found it clean)."""
    v = np.asarray(v, dtype=float)
    for _ in range(len(v)):
        if len(v) < 3:
            return v, None
        cr, sc = _turns(v)
        keep = np.abs(cr) > SIN_TOL * sc
        if keep.all():
            return v, bool(np.all(cr >= -SIN_TOL * sc))
        v = v[keep]
    return v, None


def is_convex(v: np.ndarray) -> bool:
    """A CCW ring without right turns (collinear vertices allowed)."""
    cr, sc = _turns(np.asarray(v, dtype=float))
    return bool(np.all(cr >= -SIN_TOL * sc))


def _turn_ok(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float]) -> bool:
    """No right turn at ``b`` on the way ``a -> b -> c`` (:func:`is_convex`'s test at one
    vertex, in plain Python)."""
    ux, uy, vx, vy = b[0] - a[0], b[1] - a[1], c[0] - b[0], c[1] - b[1]
    return ux * vy - uy * vx >= -SIN_TOL * math.hypot(ux, uy) * math.hypot(vx, vy)


def _convex_list(r: list[tuple[float, float]]) -> bool:
    """:func:`is_convex` for a short ring given as a list (plain Python: the merge loop tests
    many rings of 3-8 vertices, where array overhead would dominate)."""
    n = len(r)
    return all(_turn_ok(r[i - 1], r[i], r[(i + 1) % n]) for i in range(n))


def _rings_convex(rings: dict[int, list[tuple[float, float]]]) -> dict[int, bool]:
    """:func:`_convex_list` of each of many small rings: the cross products at once (the
    same arithmetic), :func:`_turn_ok` only where one is negative (``>= 0`` passes whatever
    the lengths)."""
    ok = {}
    by_len: dict[int, list[int]] = {}
    for k, r in rings.items():
        by_len.setdefault(len(r), []).append(k)
    for ks in by_len.values():
        neg = np.any(_turns(np.array([rings[k] for k in ks]))[0] < 0, axis=1)
        for k, bad in zip(ks, np.asarray(neg).tolist()):
            ok[k] = not bad or _convex_list(rings[k])
    return ok


def _merge_convex(rings: dict[int, list[tuple[float, float]]]) -> list[np.ndarray]:
    """Hertel-Mehlhorn: one pass over the internal edges of a triangulation, removing an edge
    when the union of its two pieces stays convex (near-linear in the number of triangles).

    Merging two rings across their shared edge ``(u, w)`` changes the neighbours of ``u`` and
    ``w`` only, so the merged ring passes :func:`_convex_list` exactly when both rings did
    and the turns at ``u`` and ``w`` pass: only those two are tested."""
    owner: dict[tuple, int] = {}
    for k, r in rings.items():
        for u, w in zip(r, r[1:] + r[:1]):
            owner[(u, w)] = k
    ok = _rings_convex(rings)
    diagonals = [(u, w) for (u, w) in owner if (w, u) in owner and u < w]
    for u, w in diagonals:
        _merge_across(rings, owner, ok, u, w)
    return [np.asarray(r) if _clean_list(r) else clean_ring(np.asarray(r))
            for r in rings.values()]


def _clean_list(r: list[tuple[float, float]]) -> bool:
    """:func:`clean_ring` would keep every vertex of the short ring ``r``: each turn's cross
    product (the same arithmetic) beats the collinearity threshold with a margin of ``1e-9``
    relative (``math.hypot`` and numpy's may differ in the last bits)."""
    n = len(r)
    for i in range(n):
        a, b, c = r[i - 1], r[i], r[(i + 1) % n]
        ux, uy, vx, vy = b[0] - a[0], b[1] - a[1], c[0] - b[0], c[1] - b[1]
        lim = SIN_TOL * (1.0 + 1e-9) * math.hypot(ux, uy) * math.hypot(vx, vy)
        if not abs(ux * vy - uy * vx) > lim:
            return False
    return n >= 3


def _merge_across(rings: dict[int, list[tuple[float, float]]], owner: dict[tuple, int],
                  ok: dict[int, bool], u: tuple[float, float], w: tuple[float, float]) -> None:
    """Merge the two rings on either side of the edge ``(u, w)`` when the union is convex
    (:func:`_merge_convex`), updating ``rings`` and the edges' ``owner``."""
    a, b = owner.get((u, w)), owner.get((w, u))
    if a is None or b is None or a == b or not (ok[a] and ok[b]):
        return
    r, rq = rings[a], rings[b]
    ia, ib = r.index(w), rq.index(u)
    ra, rb = r[ia:] + r[:ia], rq[ib:] + rq[:ib]  # w ... u and u ... w
    if not (_turn_ok(ra[-2], u, rb[1]) and _turn_ok(rb[-2], w, ra[1])):
        return
    del owner[(u, w)], owner[(w, u)]
    for x, y in zip(rq, rq[1:] + rq[:1]):
        if (x, y) in owner:
            owner[(x, y)] = a
    del rings[b]
    rings[a] = ra + rb[1:-1]


def _triangles(poly) -> dict[int, list[tuple[float, float]]]:
    """The constrained Delaunay triangles of ``poly`` with area, counter-clockwise, as
    vertex lists keyed by their index (one vectorised pass: the per-triangle shapely calls
    were most of a large map's import)."""
    tris = shapely.get_parts(shapely.constrained_delaunay_triangles(poly))
    if len(tris) == 0:
        return {}
    xy = shapely.get_coordinates(tris).reshape(len(tris), 4, 2)[:, :3]
    cw = ~shapely.is_ccw(shapely.get_exterior_ring(tris))
    xy[cw] = xy[cw][:, [0, 2, 1]]  # orient(t, 1.0): the ring reversed
    keep = np.flatnonzero(shapely.area(tris) > 0)
    return {int(k): [tuple(p) for p in xy[k].tolist()] for k in keep}


def convex_decompose(geom) -> list[np.ndarray]:
    """Convex pieces (CCW vertex arrays ``(m, 2)``, collinear vertices removed) tiling ``geom``
    (a shapely Polygon or MultiPolygon, holes allowed); see the module docstring."""
    out: list[np.ndarray] = []
    for poly in getattr(geom, "geoms", [geom]):
        if poly.is_empty or poly.area <= 0:
            continue
        poly = orient(poly, 1.0)
        ring = np.asarray(poly.exterior.coords)[:-1]
        if not poly.interiors and is_convex(ring):
            out.append(clean_ring(ring))
            continue
        out.extend(_merge_convex(_triangles(poly)))
    return [v for v in out if len(v) >= 3]


def _ring_segments(poly) -> np.ndarray:
    """The edges ``(m, 2, 2)`` of the rings of ``poly`` (exterior, then holes)."""
    segs = [np.stack([xy[:-1], xy[1:]], axis=1) for xy in
            (shapely.get_coordinates(r) for r in (poly.exterior, *poly.interiors))]
    return np.concatenate(segs) if segs else np.zeros((0, 2, 2))


def _pairs_within(tree_geoms, tree_owner: np.ndarray, query_geoms, query_owner: np.ndarray,
                  tol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(query, tree) index pairs within ``tol[query]`` of each other and of one polygon (one
    STRtree for every polygon of a batch; each polygon's own tolerance)."""
    q, k = shapely.STRtree(tree_geoms).query(query_geoms, predicate="dwithin", distance=tol)
    same = query_owner[q] == tree_owner[k]
    return q[same], k[same]


def _boundary_flags(batch: list[tuple], mids: list[np.ndarray]) -> list[np.ndarray]:
    """Per polygon of ``batch`` (``(poly, parts, tol)``), per point of its ``mids``: within
    ``tol`` of the polygon's boundary."""
    segs = [_ring_segments(poly) for poly, _, _ in batch]
    sown = np.repeat(np.arange(len(batch)), [len(x) for x in segs])
    mown = np.repeat(np.arange(len(batch)), [len(m) for m in mids])
    tol = np.array([t for _, _, t in batch])[mown]
    allm = np.concatenate(mids)
    q, _ = _pairs_within(shapely.linestrings(np.concatenate(segs)), sown,
                         shapely.points(allm), mown, tol)
    on = np.zeros(len(allm), bool)
    on[q] = True
    return np.split(on, np.cumsum([len(m) for m in mids])[:-1])


def _insert_boundary_vertices(batch: list[tuple]) -> list[tuple[list[np.ndarray], list[bool]]]:
    """Re-insert each polygon's vertices that lie inside an edge of one of its parts
    (``batch``: ``(poly, parts, tol)`` per polygon).

    :func:`convex_decompose` drops collinear vertices, so an edge of a part may run along the
    boundary and then on into the interior (a T-junction where a wall ends in line with a
    diagonal).  Splitting every part edge at the polygon vertices on it makes each sub-edge
    either part of the boundary or interior, so its boundary flag is exact.  Returns, per
    polygon, the parts and, per part, whether a vertex was inserted.
    """
    verts = [np.concatenate([np.asarray(r.coords)[:-1] for r in (poly.exterior, *poly.interiors)])
             for poly, _, _ in batch]
    vown = np.repeat(np.arange(len(batch)), [len(v) for v in verts])
    allv = np.concatenate(verts)
    starts = np.concatenate([v for _, parts, _ in batch for v in parts])
    ends = np.concatenate([np.concatenate((v[1:], v[:1])) for _, parts, _ in batch
                           for v in parts])
    eown = np.repeat(np.arange(len(batch)), [sum(len(v) for v in parts) for _, parts, _ in batch])
    tol = np.array([t for _, _, t in batch])[eown]
    e_idx, v_idx = _pairs_within(shapely.points(allv), vown,
                                 shapely.linestrings(np.stack([starts, ends], axis=1)), eown,
                                 tol)
    d = ends[e_idx] - starts[e_idx]
    t = np.einsum("ij,ij->i", allv[v_idx] - starts[e_idx], d) / np.einsum("ij,ij->i", d, d)
    inner = (t > 1e-9) & (t < 1 - 1e-9)  # not the edge's own end points
    extra: dict[int, list[tuple[float, int]]] = {}
    for e, vi, tt in zip(e_idx[inner], v_idx[inner], t[inner]):
        extra.setdefault(int(e), []).append((float(tt), int(vi)))
    res, base = [], 0
    for _, parts, _ in batch:
        res.append(_with_inserted(parts, extra, base, allv))
        base += sum(len(v) for v in parts)
    return res


def _with_inserted(parts: list[np.ndarray], extra: dict[int, list[tuple[float, int]]],
                   base: int, verts: np.ndarray) -> tuple[list[np.ndarray], list[bool]]:
    """The ``parts`` (their edges numbered from ``base``) with the vertices ``extra`` lists
    for their edges inserted, and per part whether it changed."""
    out, changed = [], []
    for v in parts:
        if not any(base + j in extra for j in range(len(v))):  # no vertex to insert
            base += len(v)
            changed.append(False)
            out.append(v)
            continue
        ring = []
        for j in range(len(v)):
            ring.append(v[j])
            for _, vi in sorted(extra.get(base + j, [])):
                # a pinch vertex is listed once per ring through it: insert it once (a
                # repeated vertex is an edge of length 0, without a normal)
                if verts[vi][0] != ring[-1][0] or verts[vi][1] != ring[-1][1]:
                    ring.append(verts[vi])
        base += len(v)
        changed.append(True)
        out.append(np.asarray(ring))
    return out, changed


def _fan(v: np.ndarray, flags: np.ndarray, max_edges: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Fan-split a convex ring from its first vertex into pieces of at most ``max_edges``."""
    out = []
    i = 1
    while i < len(v) - 1:  # fan: (v0, v_i, ..., v_j)
        j = min(i + max_edges - 2, len(v) - 1)
        piece = np.concatenate((v[:1], v[i:j + 1]))
        fl = np.zeros(len(piece), bool)
        fl[1:-1] = flags[i:j]  # ring edges v_i -> v_{i+1} ... v_{j-1} -> v_j
        fl[0] = flags[0] if i == 1 else False  # v0 -> v1 only in the first fan piece
        fl[-1] = flags[-1] if j == len(v) - 1 else False  # v_last -> v0: last piece
        out.append((piece, fl))
        i = j
    return out


def _centre_fan(v: np.ndarray, flags: np.ndarray, max_edges: int
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split a convex ring with collinear vertices into pieces around its vertex centroid.

    A fan from a ring vertex would give zero-area pieces along a side with several collinear
    vertices; the centroid lies strictly inside, so every piece ``(c, v_i, v_{i+1}[, v_{i+2}])``
    has area.  Two neighbouring triangles form one quad when ``max_edges >= 4`` and the quad is
    convex.
    """
    c = v.mean(axis=0)
    n = len(v)
    k = np.arange(n)
    quads = np.stack([np.broadcast_to(c, (n, 2)), v, v[(k + 1) % n], v[(k + 2) % n]], axis=1)
    convex = _convex_rows(quads) if max_edges >= 4 else np.zeros(n, bool)
    out = []
    i = 0
    while i < n:
        if i + 2 <= n and convex[i]:
            out.append((quads[i], np.array([False, flags[i], flags[i + 1], False])))
            i += 2
            continue
        out.append((quads[i, :3], np.array([False, flags[i], False])))
        i += 1
    return out


def convex_pieces(geom, max_edges: int = 4) -> list[tuple[np.ndarray, np.ndarray]]:
    """Pieces of :func:`convex_decompose` fan-split to at most ``max_edges`` vertices.

    Returns
    -------
    list of (vertices, boundary)
        ``vertices``: CCW ``(k, 2)``, ``3 <= k <= max_edges``; ``boundary``: ``(k,)`` bool, True
        where edge ``v[i] -> v[i+1]`` lies on the polygon's boundary (False for the internal
        diagonals of the decomposition and of the fan).  Every edge is either on the boundary
        or interior: a part edge that runs on from the boundary into the interior is split at
        the polygon vertex where it leaves it.
    """
    return convex_pieces_many([geom], max_edges)[0]


def convex_pieces_many(geoms: list, max_edges: int = 4
                       ) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """:func:`convex_pieces` of each of ``geoms``, the boundary queries of all of them in one
    STRtree each (a map has thousands of solids)."""
    if max_edges < 3:
        raise ValueError(f"max_edges must be >= 3, got {max_edges}")
    chunks: list[list] = [[] for _ in geoms]  # per geom: piece lists or batch indices
    batch: list[tuple] = []  # (poly, parts, tol) of the polygons that need the queries
    polys, owner = shapely.get_parts(np.array(geoms, dtype=object), return_index=True)
    keep = ~shapely.is_empty(polys) & (shapely.area(polys) > 0)
    polys, owner = polys[keep], owner[keep]
    plain = shapely.get_num_interior_rings(polys) == 0
    fans = iter(_convex_fans(polys[plain], max_edges))
    for poly, gi, pl in zip(polys, owner.tolist(), plain.tolist()):
        one = next(fans) if pl else None
        if one is not None:
            chunks[gi].append(one)
            continue
        parts = convex_decompose(poly)
        if parts:
            x0, y0, x1, y1 = poly.bounds
            batch.append((poly, parts, 1e-9 * max(x1 - x0, y1 - y0)))
            chunks[gi].append(len(batch) - 1)
    done = _split_and_flag(batch, max_edges) if batch else []
    return [[p for c in ch for p in (done[c] if isinstance(c, int) else c)] for ch in chunks]


def _convex_fans(polys: np.ndarray, max_edges: int
                 ) -> list[list[tuple[np.ndarray, np.ndarray]] | None]:
    """Per polygon without holes: the fan of its ring (counter-clockwise, cleaned) when it is
    convex (its own single piece), else None.  The rings of one length are turned at once
    (:func:`_turns` on ``(m, k, 2)``, the same arithmetic); a ring with a vertex to drop goes
    through :func:`_clean`."""
    ext = shapely.get_exterior_ring(polys)
    xy, ring = shapely.get_coordinates(ext, return_index=True)
    size = np.bincount(ring, minlength=len(polys)) - 1  # without the closing repeat
    first = np.cumsum(size + 1) - size - 1
    ccw = shapely.is_ccw(ext)
    out: list[list[tuple[np.ndarray, np.ndarray]] | None] = [None] * len(polys)
    for k in np.unique(size).tolist():
        rows = np.flatnonzero(size == k)
        R = xy[first[rows][:, None] + np.arange(k)]
        R[~ccw[rows]] = R[~ccw[rows]][:, ::-1]
        if k >= 3:
            cr, sc = _turns(R)
            clean = np.all(np.abs(cr) > SIN_TOL * sc, axis=1).tolist()
            convex = np.all(cr >= -SIN_TOL * sc, axis=1).tolist()
        else:
            clean = convex = [False] * len(rows)
        for j, row in enumerate(rows.tolist()):
            v, cv = (R[j], convex[j]) if clean[j] else _clean(R[j])
            if cv is None:
                cv = len(v) >= 3 and is_convex(v)
            if cv:
                out[row] = _fan(v, np.ones(len(v), bool), max_edges)
    return out


def _split_and_flag(batch: list[tuple], max_edges: int
                    ) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """The pieces of each ``(poly, parts, tol)``: boundary vertices inserted, edges flagged
    (one vectorised distance query for the edge midpoints of every part), fan-split."""
    split = _insert_boundary_vertices(batch)
    mids = [np.concatenate([0.5 * (v + np.concatenate((v[1:], v[:1]))) for v in parts])
            for parts, _ in split]
    flags = _boundary_flags([(poly, parts, tol) for (poly, _, tol), (parts, _) in
                             zip(batch, split)], mids)
    done = []
    for (parts, changed), on in zip(split, flags):
        fl = np.split(on, np.cumsum([len(v) for v in parts])[:-1])
        done.append([p for v, f, ch in zip(parts, fl, changed)
                     for p in (_centre_fan(v, f, max_edges) if ch else _fan(v, f, max_edges))])
    return done
