r"""The one convex decomposition of optplan: polygons (holes allowed) into convex pieces.

:func:`convex_decompose` gives few, large convex pieces (the NLP's separating-hyperplane
constraints use them); :func:`convex_pieces` fan-splits those into pieces of at most
``max_edges`` vertices with boundary flags (the collision engine's fixed-width edge tables).

Decomposition
    A convex polygon without holes is one piece.  Otherwise the polygon is triangulated by
    ``shapely.constrained_delaunay_triangles`` and triangles are merged greedily across shared
    edges while the merged ring stays convex (Hertel & Mehlhorn 1983: at most 4x the minimum
    number of convex pieces).  Every convexity and collinearity test is relative
    (``|sin angle| <= 1e-12``), never in absolute coordinates.  :func:`convex_decompose` then
    drops the collinear vertices of each piece.

Why the triangulation decides the boundary flags exactly
    GEOS triangulates the polygon by ear clipping (an ear is accepted only when its corner
    turns strictly and no other vertex lies inside or on it) and then flips diagonals of
    strictly convex quadrilaterals.  So its triangles use the polygon's own vertices (the same
    doubles), have disjoint interiors, tile the polygon and have *no vertex in the relative
    interior of an edge*: where a hole vertex touches a shell edge, that edge is split at the
    vertex.  Orient every triangle counter-clockwise and look at a directed edge ``(u, w)``
    of one:

    * if another triangle has the reversed edge ``(w, u)`` (a *twin*), the two triangles
      cover both sides of the segment, which is interior to the polygon;
    * if none does, the other side is outside near every point of the segment: a triangle
      covering it would have an edge along the segment, and with no vertex inside an edge
      that edge would be ``(w, u)``.  The segment lies on the boundary.

    Merging two pieces removes a twin pair and keeps every other edge, so an edge of a merged
    piece is an edge of a triangle and its flag is "no twin", exactly, without a tolerance
    and without coordinates.  The collinear vertices of a merged piece are kept (every vertex
    is a polygon vertex, so each edge between two of them is wholly boundary or wholly
    interior); a piece with such a straight vertex is split around its vertex centroid
    (:func:`_centre_fan`), a fan from a vertex would give pieces without area.

Orientation and zero-area triangles
    A triangle's orientation is the sign of its orientation determinant, computed in floating
    point and, where Shewchuk's error bound cannot vouch for the sign, exactly in rationals
    (:func:`_orientation`), so a triangle has area exactly when the sign is not 0.  GEOS does
    not produce zero-area ("flat") triangles (the ear clipper rejects flat corners, the flips
    need strictly convex quadrilaterals); should one come, it covers nothing but glues the
    triangles on either side of its segment: its long edge is the union of its short edges.
    Flat triangles sharing an edge lie on one line; per such cluster, every edge of a
    triangle with area that is an edge of the cluster is split at the cluster's vertices
    strictly inside it (ordered along the line lexicographically, exact for collinear
    points), then the flat triangles are dropped (:func:`_refine`).  Both sides of a
    cluster's segment are then cut at the same points, so the twin rule holds again: an
    edge with a twin is interior, one without lies on the boundary (the flat triangle's long
    edge without a neighbour leaves its short edges' neighbours without twins: boundary).

Pieces of at most ``max_edges`` vertices
    A merged piece without straight vertices is fan-split from its first vertex
    (:func:`_fan`; one of more than :data:`RIM_FROM` vertices is first peeled round its rim,
    :func:`_rim`), one with straight vertices around its centroid, starting from the first
    vertex :func:`clean_ring` keeps.  A merged piece all of whose vertices are straight (a
    sliver within the tolerance of a segment, e.g. between a shell edge and a hole vertex
    ``1e-13`` of the size away from it) is kept whole when it has at most ``max_edges``
    vertices (its triangles have area, so it tiles exactly) and centre-split otherwise.
"""

from __future__ import annotations

import functools
import math
from fractions import Fraction

import numpy as np
import shapely
from shapely.geometry.polygon import orient

__all__ = ["convex_decompose", "convex_pieces", "convex_pieces_many", "clean_ring", "is_convex"]

#: Relative tolerance of the collinearity / convexity tests (sine of the turning angle).
SIN_TOL = 1e-12
#: Vertices of a convex ring beyond which its pieces are peeled round the rim (:func:`_rim`),
#: not fanned from one vertex.
RIM_FROM = 64

Ring = list[tuple[float, float]]


@functools.lru_cache(maxsize=64)
def _ring_index(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The next and previous vertex indices of a ring of ``k`` vertices."""
    return (np.arange(k) + 1) % k, (np.arange(k) - 1) % k


def _turns(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cross products of consecutive edges at each vertex of a ring ``(k, 2)`` (or of each
    ring of ``(m, k, 2)``), and the products of their lengths."""
    nxt, prv = _ring_index(v.shape[-2])
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
    v = np.asarray(v, dtype=float)
    return v[_kept(v)[0]]


def _kept(v: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, bool | None]:
    """The indices of the vertices of the ring ``v`` that :func:`clean_ring` keeps (it drops
    the collinear ones and repeats until none is left) and, from the turns it computed last,
    :func:`is_convex` of the result (None when it has fewer than 3 vertices or no pass found
    it clean).  ``idx``: the vertices a first pass kept, when it was made already."""
    idx = np.arange(len(v)) if idx is None else idx
    for _ in range(len(v)):
        if len(idx) < 3:
            return idx, None
        cr, sc = _turns(v[idx])
        keep = np.abs(cr) > SIN_TOL * sc
        if keep.all():
            return idx, bool(np.all(cr >= -SIN_TOL * sc))
        idx = idx[keep]
    return idx, None


def is_convex(v: np.ndarray) -> bool:
    """A CCW ring without right turns (collinear vertices allowed)."""
    cr, sc = _turns(np.asarray(v, dtype=float))
    return bool(np.all(cr >= -SIN_TOL * sc))


def _turn_ok(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float]) -> bool:
    """No right turn at ``b`` on the way ``a -> b -> c`` (:func:`is_convex`'s test at one
    vertex, in plain Python)."""
    ux, uy, vx, vy = b[0] - a[0], b[1] - a[1], c[0] - b[0], c[1] - b[1]
    return ux * vy - uy * vx >= -SIN_TOL * math.hypot(ux, uy) * math.hypot(vx, vy)


def _convex_list(r: Ring) -> bool:
    """:func:`is_convex` for a short ring given as a list (plain Python: the merge loop tests
    many rings of 3-8 vertices, where array overhead would dominate)."""
    n = len(r)
    return all(_turn_ok(r[i - 1], r[i], r[(i + 1) % n]) for i in range(n))


def _clean_list(r: Ring) -> bool:
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


def _orientation(xy: np.ndarray) -> np.ndarray:
    """The exact sign (1 counter-clockwise, -1 clockwise, 0 collinear) of each triangle
    ``xy[k]`` (``(m, 3, 2)``): the floating-point determinant where its magnitude beats the
    error bound (Shewchuk 1997: ``3.3e-16`` times the sum of the products' magnitudes; here
    ``1e-15``), else the determinant of the doubles in rationals."""
    d = xy[:, :2] - xy[:, 2:]  # a - c, b - c
    left, right = d[:, 0, 0] * d[:, 1, 1], d[:, 0, 1] * d[:, 1, 0]
    det = left - right
    sign = np.sign(det)
    for k in np.flatnonzero(np.abs(det) <= 1e-15 * (np.abs(left) + np.abs(right))).tolist():
        (ax, ay), (bx, by), (cx, cy) = (tuple(map(Fraction, p)) for p in xy[k].tolist())
        e = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
        sign[k] = (e > 0) - (e < 0)
    return sign


def _triangles(polys) -> list[dict[int, Ring]]:
    """Per polygon of ``polys``: its constrained Delaunay triangles with area,
    counter-clockwise, as vertex lists keyed by their index; zero-area triangles refined away
    (:func:`_refine`).  One GEOS call and one pass of the array work for all of them."""
    out: list[dict[int, Ring]] = [{} for _ in polys]
    tris, which = shapely.get_parts(shapely.constrained_delaunay_triangles(polys),
                                    return_index=True)
    if len(tris) == 0:
        return out
    xy = shapely.get_coordinates(tris).reshape(len(tris), 4, 2)[:, :3]
    sign = _orientation(xy)
    cw = sign < 0
    xy[cw] = xy[cw][:, [0, 2, 1]]  # the ring reversed
    flats: dict[int, list[Ring]] = {}
    for k, (t, sk, p) in enumerate(zip(xy.tolist(), sign.tolist(), which.tolist())):
        if sk:
            out[p][k] = [tuple(q) for q in t]
        else:
            flats.setdefault(p, []).append([tuple(q) for q in t])
    for p, f in flats.items():
        _refine(out[p], f)
    return out


def _refine(rings: dict[int, Ring], flats: list[Ring]) -> None:
    """Split the edges of ``rings`` (triangles with area) that are edges of the zero-area
    triangles ``flats`` at the vertices of the flats' line inside them (module docstring)."""
    parent = list(range(len(flats)))

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    seen: dict[tuple, int] = {}
    for i, f in enumerate(flats):  # clusters: flats joined by an edge
        for u, w in zip(f, f[1:] + f[:1]):
            key = (min(u, w), max(u, w))
            if key in seen:
                parent[root(i)] = root(seen[key])
            seen.setdefault(key, i)
    owner = {(u, w): k for k, r in rings.items() for u, w in zip(r, r[1:] + r[:1])}
    line: dict[int, set] = {}
    for i, f in enumerate(flats):
        line.setdefault(root(i), set()).update(f)
    pts = {c: sorted(p) for c, p in line.items()}  # lexicographic: the order along the line
    for (u, w), i in seen.items():  # u < w
        inner = [p for p in pts[root(i)] if u < p < w]
        for a, b, seq in ((u, w, inner), (w, u, inner[::-1])):
            k = owner.pop((a, b), None) if inner else None
            if k is None:
                continue
            r = rings[k]
            j = r.index(a) + 1
            r[j:j] = seq
            for x, y in zip([a, *seq], [*seq, b]):
                owner[(x, y)] = k


def _merge(rings: dict[int, Ring]) -> dict[tuple, int]:
    """Hertel-Mehlhorn: one pass over the internal edges of a triangulation, removing an edge
    when the union of its two pieces stays convex (near-linear in the number of triangles).
    Merges ``rings`` in place; returns the owner of each directed edge left, whose twin
    ``(w, u)`` is there exactly when ``(u, w)`` is interior (module docstring).

    Merging two rings across their shared edge ``(u, w)`` changes the neighbours of ``u`` and
    ``w`` only, so the merged ring passes :func:`_convex_list` exactly when both rings did
    and the turns at ``u`` and ``w`` pass: only those two are tested."""
    owner: dict[tuple, int] = {}
    for k, r in rings.items():
        for u, w in zip(r, r[1:] + r[:1]):
            owner[(u, w)] = k
    # a triangle with area passes :func:`_convex_list` (its cross products are at least its
    # doubled area minus a few ulps of ``|u| |v|``, far above ``-SIN_TOL |u| |v|``); only a
    # ring refined by :func:`_refine` is tested
    ok = {k: len(r) == 3 or _convex_list(r) for k, r in rings.items()}
    diagonals = [(u, w) for (u, w) in owner if (w, u) in owner and u < w]
    for u, w in diagonals:
        _merge_across(rings, owner, ok, u, w)
    return owner


def _merge_across(rings: dict[int, Ring], owner: dict[tuple, int], ok: dict[int, bool],
                  u: tuple[float, float], w: tuple[float, float]) -> None:
    """Merge the two rings on either side of the edge ``(u, w)`` when the union is convex
    (:func:`_merge`), updating ``rings`` and the edges' ``owner``."""
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
        rings = _triangles(np.array([poly]))[0]
        _merge(rings)
        out.extend(np.asarray(r) if _clean_list(r) else clean_ring(np.asarray(r))
                   for r in rings.values())
    return [v for v in out if len(v) >= 3]


def _rim(v: np.ndarray, flags: np.ndarray, max_edges: int
         ) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray, np.ndarray]:
    """Peel a convex ring of more than :data:`RIM_FROM` vertices: runs of ``max_edges``
    consecutive vertices cut off round the rim (each run's closing chord an internal edge), the
    ring of the runs' ends peeled again, until at most ``RIM_FROM`` vertices are left.
    Returns the pieces and the inner ring (vertices, flags).

    A fan from one vertex would give thin pieces that all reach across the polygon (every
    piece near every point of it, for the collision screens); a run of consecutive vertices
    stays where its vertices are, and each level keeps a ``1 / (max_edges - 1)`` share of the
    ring.  The ring is strictly convex (a clean ring), so every run and every inner ring is.
    """
    out: list[tuple[np.ndarray, np.ndarray]] = []
    run = max_edges - 1  # edges of the ring per piece
    while len(v) > RIM_FROM:
        n = len(v)
        starts = np.arange(0, n - run, run)  # runs s .. s + run, all within 0 .. n - 1
        for s in starts.tolist():
            fl = np.zeros(max_edges, bool)
            fl[:-1] = flags[s:s + run]
            out.append((np.array(v[s:s + run + 1], dtype=float), fl))
        keep = np.ones(n, bool)
        for d in range(1, run):
            keep[starts + d] = False
        inner = np.array(flags, dtype=bool)
        inner[starts] = False  # the chords
        v, flags = v[keep], inner[keep]
    return out, v, flags


def _fan(v: np.ndarray, flags: np.ndarray, max_edges: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Fan-split a convex ring from its first vertex into pieces of at most ``max_edges``
    (a ring of more than :data:`RIM_FROM` vertices peeled first: :func:`_rim`)."""
    if 3 <= len(v) <= max_edges:  # the ring itself (what the loop below gives, without its work)
        return [(np.array(v, dtype=float), np.array(flags, dtype=bool))]
    out: list[tuple[np.ndarray, np.ndarray]] = []
    if len(v) > RIM_FROM:
        out, v, flags = _rim(np.asarray(v), np.asarray(flags, bool), max_edges)
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


def _centre_fan(v: np.ndarray, flags: np.ndarray, max_edges: int, start: int = 0
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split a convex ring with collinear vertices into pieces around its vertex centroid
    (the ring taken from its vertex ``start`` on).

    A fan from a ring vertex would give zero-area pieces along a side with several collinear
    vertices; the centroid lies strictly inside, so every piece ``(c, v_i, v_{i+1}[, v_{i+2}])``
    has area.  Two neighbouring triangles form one quad when ``max_edges >= 4`` and the quad is
    convex.
    """
    n = len(v)
    nxt = _ring_index(n)[0]
    if start:
        order = (np.arange(n) + start) % n
        v, flags = v[order], flags[order]
    quads = np.empty((n, 4, 2))
    quads[:, 0] = v.mean(axis=0)
    quads[:, 1], quads[:, 2], quads[:, 3] = v, v[nxt], v[nxt[nxt]]
    convex = _convex_rows(quads).tolist() if max_edges >= 4 else [False] * n
    fq, ft = np.zeros((n, 4), bool), np.zeros((n, 3), bool)  # the flags of quads, triangles
    fq[:, 1], fq[:, 2], ft[:, 1] = flags, flags[nxt], flags
    out = []
    i = 0
    while i < n:
        if i + 2 <= n and convex[i]:
            out.append((quads[i], fq[i]))
            i += 2
            continue
        out.append((quads[i, :3], ft[i]))
        i += 1
    return out


def _flagged_pieces(polys: np.ndarray, max_edges: int
                    ) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """The pieces of each polygon by its triangulation: merged (:func:`_merge`), each edge
    flagged by the twin rule, split by :func:`_fan` or :func:`_centre_fan` (module
    docstring).  Whether :func:`clean_ring` would keep every vertex is decided for every
    merged ring at once (:func:`_straight`, the same arithmetic)."""
    rings, flags, count = _merged_rings(polys)
    if not rings:
        return [[] for _ in polys]
    xy, start, size, kept = _straight(rings)
    clean = np.logical_and.reduceat(kept, start).tolist()
    pieces = [_split(xy[f:f + k].copy(), np.array(fl), ok, kept[f:f + k], max_edges)
              for f, k, fl, ok in zip(start.tolist(), size.tolist(), flags, clean)]
    ends = np.cumsum(count).tolist()
    return [[p for one in pieces[b - n:b] for p in one] for b, n in zip(ends, count)]


def _merged_rings(polys: np.ndarray) -> tuple[list[Ring], list[list[bool]], list[int]]:
    """The merged rings of every polygon's triangulation (:func:`_merge`), per ring its
    edges' flags (no twin: on the boundary) and per polygon its number of rings."""
    rings: list[Ring] = []
    flags: list[list[bool]] = []
    count = []
    for tri in _triangles(polys):
        owner = _merge(tri)
        count.append(len(tri))
        for r in tri.values():
            rings.append(r)
            flags.append([(w, u) not in owner for u, w in zip(r, r[1:] + r[:1])])
    return rings, flags, count


def _straight(rings: list[Ring]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rings' vertices concatenated ``(m, 2)``, each ring's first row and size, and per
    vertex whether :func:`clean_ring` keeps it (its turn beats the collinearity threshold)."""
    size = np.array([len(r) for r in rings])
    xy = np.array([p for r in rings for p in r], dtype=float)
    start = np.cumsum(size) - size
    nxt, prv = np.arange(len(xy)) + 1, np.arange(len(xy)) - 1
    nxt[start + size - 1], prv[start] = start, start + size - 1
    e = xy[nxt] - xy
    a = e[prv]
    cr = a[:, 0] * e[:, 1] - a[:, 1] * e[:, 0]
    ln = np.hypot(e[:, 0], e[:, 1])
    return xy, start, size, np.abs(cr) > SIN_TOL * (ln[prv] * ln)


def _split(v: np.ndarray, fl: np.ndarray, clean: bool, kept: np.ndarray, max_edges: int
           ) -> list[tuple[np.ndarray, np.ndarray]]:
    """The pieces of one merged ring ``v`` (flags ``fl``; ``clean``: every vertex kept,
    ``kept``: per vertex)."""
    k = len(v)
    if clean and k <= max_edges:  # its own piece (what _fan gives)
        return [(v, fl)]
    idx = np.arange(k) if clean else _kept(v, np.flatnonzero(kept))[0]
    if len(idx) == k or (len(idx) < 3 and k <= max_edges):
        return _fan(v, fl, max_edges)
    s = int(idx[0]) if len(idx) >= 3 else 0  # where the cleaned ring starts
    return _centre_fan(v, fl, max_edges, s)


def convex_pieces(geom, max_edges: int = 4) -> list[tuple[np.ndarray, np.ndarray]]:
    """Pieces of the convex decomposition fan-split to at most ``max_edges`` vertices.

    Returns
    -------
    list of (vertices, boundary)
        ``vertices``: CCW ``(k, 2)``, ``3 <= k <= max_edges``; ``boundary``: ``(k,)`` bool, True
        where edge ``v[i] -> v[i+1]`` lies on the polygon's boundary (False for the internal
        diagonals of the decomposition and of the fan).  Every edge is either on the boundary
        or interior (module docstring): the pieces keep the polygon vertices that lie on their
        sides.
    """
    return convex_pieces_many([geom], max_edges)[0]


def convex_pieces_many(geoms: list, max_edges: int = 4
                       ) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """:func:`convex_pieces` of each of ``geoms`` (a map has thousands of solids: the convex
    ones without holes are tested at once, the others triangulated at once)."""
    if max_edges < 3:
        raise ValueError(f"max_edges must be >= 3, got {max_edges}")
    out: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in geoms]
    polys, owner = shapely.get_parts(np.array(geoms, dtype=object), return_index=True)
    keep = ~shapely.is_empty(polys) & (shapely.area(polys) > 0)
    polys, owner = polys[keep], owner[keep]
    plain = shapely.get_num_interior_rings(polys) == 0
    made: list = [None] * len(polys)
    for i, one in zip(np.flatnonzero(plain).tolist(), _convex_fans(polys[plain], max_edges)):
        made[i] = one
    rest = [i for i, one in enumerate(made) if one is None]
    for i, one in zip(rest, _flagged_pieces(polys[rest], max_edges)):
        made[i] = one
    for gi, one in zip(owner.tolist(), made):
        out[gi].extend(one)
    return out


def _convex_fans(polys: np.ndarray, max_edges: int
                 ) -> list[list[tuple[np.ndarray, np.ndarray]] | None]:
    """Per polygon without holes: the fan of its ring (counter-clockwise, cleaned) when it is
    convex (its own single piece), else None.

    The turns of every ring are computed at once, :func:`_turns`'s arithmetic on the
    concatenated coordinates (each ring's closing repeat ends its last edge); a clockwise
    ring's turns are those of the reversed ring negated, exactly.  A ring with a vertex to
    drop goes through :func:`_kept`.
    """
    ext = shapely.get_exterior_ring(polys)
    xy, ring = shapely.get_coordinates(ext, return_index=True)
    out: list[list[tuple[np.ndarray, np.ndarray]] | None] = [None] * len(polys)
    if not len(polys):
        return out
    count = np.bincount(ring, minlength=len(polys))
    size = count - 1  # without the closing repeat
    first = np.cumsum(count) - count
    ccw = shapely.is_ccw(ext)
    e = np.diff(xy, axis=0, append=xy[:1])  # coordinate i -> i + 1
    at = np.flatnonzero(np.diff(ring, append=-1) == 0)  # the vertices (no closing repeat)
    start = np.cumsum(size) - size  # each ring's first vertex in ``at``
    prv = np.arange(len(at)) - 1
    prv[start] = start + size - 1
    a, b = e[at[prv]], e[at]  # incoming and outgoing edge at each vertex
    cr = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    ln = np.hypot(b[:, 0], b[:, 1])
    sc = SIN_TOL * (ln[prv] * ln)
    turns = np.where(np.repeat(ccw, size), cr, -cr) >= -sc
    ok = size >= 3
    clean = (ok & np.logical_and.reduceat(np.abs(cr) > sc, start)).tolist()
    convex = (ok & np.logical_and.reduceat(turns, start)).tolist()
    for row, (f, k, c) in enumerate(zip(first.tolist(), size.tolist(), ccw.tolist())):
        R = xy[f:f + k] if c else xy[f + k - 1:f - 1 if f else None:-1]
        if clean[row]:
            v, cv = R, convex[row]
        else:
            idx, cv = _kept(R)
            v = R[idx]
        if cv is None:
            cv = len(v) >= 3 and is_convex(v)
        if cv:
            out[row] = _fan(v, np.ones(len(v), bool), max_edges)
    return out
