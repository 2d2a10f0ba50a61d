"""Geometry kernel: inflation, the vectorised batch crossing test, clearance.

Inflation (domain-notes §2.2)
    ``shapely.buffer`` with round joins places vertices *on* the offset arc, so its polygon is
    inscribed in the true Minkowski sum; buffering by ``r / cos(pi / (4 q))`` gives a
    circumscribed polygon.  Shortest paths around the two bracket the true disc-robot optimum:
    ``L*(circumscribed) >= L*(disc) >= L*(inscribed)``.

Batch crossing test
    For a batch of polylines ``paths`` of shape ``(P, M, 2)`` the test measures, for every
    (segment, inflated obstacle) pair, the length of the segment inside the obstacle's interior.
    Along the infinite line through segment ``AB`` every boundary edge ``PQ`` whose endpoints lie
    on opposite sides of the line (a vertex *on* the line counts as the positive side, which
    handles vertex grazing and collinear edges consistently) contributes a crossing at parameter
    ``t`` with sign ``+1`` (entering) or ``-1`` (leaving).  The indicator of the interior along the
    line is the running sum of those signs, hence the inside length over ``t in [0, 1]`` is::

        |AB| * sum_k sign_k * clip(1 - t_k, 0, 1)

    No parity bookkeeping, no per-segment loop: one array expression over (pairs x edges).
    Touching (a vertex or an edge shared with the boundary) gives zero length, so it is not a
    collision.  A pair *collides* when its inside length exceeds ``tol``.  Candidate pairs are
    pre-filtered by axis-aligned bounding boxes so the cost grows with the number of nearby
    obstacles, not all of them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Point, Polygon
from shapely.geometry.polygon import orient

__all__ = [
    "InflatedMap",
    "CrossingResult",
    "inflate",
    "circumscribed_radius",
    "batch_crossings",
    "candidate_pairs",
    "inside_lengths",
    "path_lengths",
    "point_clearance",
    "ObstacleSet",
    "DiscCrossings",
    "obstacle_set",
    "convex_pieces",
    "KERNEL_ENGINES",
    "kernel_engine",
]

#: shapely ``quad_segs`` used for inflation.
QUAD_SEGS = 8


def circumscribed_radius(r: float, quad_segs: int = QUAD_SEGS) -> float:
    """Buffer distance whose polygon circumscribes the disc of radius ``r``."""
    # GEOS rounds the number of fillet segments of a corner arc to the nearest integer, so
    # one segment may span up to 1.5 nominal steps (pi / 2q each): its chord is at
    # R cos(3 pi / 8q) from the corner, which must be >= r.
    return r / math.cos(3 * math.pi / (8 * quad_segs))


@dataclass(frozen=True, eq=False)
class InflatedMap:
    """Static obstacles inflated by a radius and merged where they overlap.

    Attributes
    ----------
    radius : float
        The inflation radius asked for.
    mode : str
        ``"inscribed"`` (shapely round buffer) or ``"circumscribed"``.
    union : shapely geometry
        Union of the inflated obstacles (``Polygon`` / ``MultiPolygon`` / empty).
    parts : tuple of Polygon
        Connected components of ``union``, oriented (exterior CCW, holes CW).
    names : tuple of str
        For each part, the names of the obstacles merged into it.
    edges : numpy.ndarray
        Padded boundary edges, shape ``(n_parts, E_max, 4)`` as ``(px, py, qx, qy)``.
    edge_mask : numpy.ndarray
        ``(n_parts, E_max)`` True for real edges.
    bbox : numpy.ndarray
        ``(n_parts, 4)`` as ``(xmin, ymin, xmax, ymax)``.
    """

    radius: float
    mode: str
    union: object
    parts: tuple
    names: tuple
    edges: np.ndarray
    edge_mask: np.ndarray
    bbox: np.ndarray
    _prepared: dict = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        return len(self.parts)

    @property
    def scale(self) -> float:
        """Coordinate scale used for relative tolerances: ``max(1, max |bbox|)``."""
        return max(1.0, float(np.max(np.abs(self.bbox)))) if self.bbox.size else 1.0

    @property
    def convex(self) -> np.ndarray:
        """Per part: True when the part is a convex polygon without holes."""
        if "convex" not in self._prepared:
            self._prepared["convex"] = np.array([
                len(p.interiors) == 0 and abs(p.convex_hull.area - p.area) <= 1e-9 * p.area
                for p in self.parts], dtype=bool)
        return self._prepared["convex"]

    def containing(self, p: np.ndarray, tol: float = 1e-9) -> str | None:
        """Name(s) of the part whose interior strictly contains point ``p``, else ``None``."""
        pt = Point(float(p[0]), float(p[1]))
        for part, nm in zip(self.parts, self.names):
            if part.contains(pt) and part.exterior.distance(pt) > tol and all(
                h.distance(pt) > tol for h in part.interiors
            ):
                return "+".join(nm)
        return None

    def vertices(self, convex_only: bool = True) -> np.ndarray:
        """Boundary vertices of all parts (convex ones only by default), shape ``(k, 2)``."""
        out = []
        for part in self.parts:
            rings = [(np.asarray(part.exterior.coords)[:-1], True)]
            rings += [(np.asarray(h.coords)[:-1], False) for h in part.interiors]
            for ring, _ in rings:
                if len(ring) < 3:
                    continue
                if not convex_only:
                    out.append(ring)
                    continue
                prev = np.roll(ring, 1, axis=0)
                nxt = np.roll(ring, -1, axis=0)
                a, b = ring - prev, nxt - ring
                cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
                # exterior CCW and holes CW: the solid is on the left, so a left turn
                # (cross > 0) is a convex corner of the free space boundary
                out.append(ring[cross > 1e-12])
        return np.concatenate(out) if out else np.zeros((0, 2))


def inflate(
    obstacles: Iterable,
    radius: float,
    mode: str = "inscribed",
    quad_segs: int = QUAD_SEGS,
    bounds: tuple[float, float, float, float] | None = None,
) -> InflatedMap:
    """Inflate static obstacles by ``radius`` and merge overlaps.

    Parameters
    ----------
    obstacles : iterable of :class:`optplan.problem.Obstacle`
    radius : float
        Robot radius (plus any margin), map units, >= 0.
    mode : {"inscribed", "circumscribed"}
        Polygon inscribed in the true Minkowski sum (shapely's round buffer) or circumscribing it.
    quad_segs : int
        Segments per quarter circle.
    bounds : optional
        Unused for now; kept so callers can pass the map box.
    """
    if mode not in ("inscribed", "circumscribed"):
        raise ValueError(f"mode must be 'inscribed' or 'circumscribed', got {mode!r}")
    if not (radius >= 0 and math.isfinite(radius)):
        raise ValueError(f"radius must be finite and >= 0, got {radius}")
    d = radius if mode == "inscribed" else circumscribed_radius(radius, quad_segs)
    geoms, names = [], []
    for o in obstacles:
        if o.is_circle:
            r_c = float(o.radius) + radius
            if mode == "circumscribed":
                r_c = circumscribed_radius(r_c, quad_segs)
            g = Point(o.center).buffer(r_c, quad_segs=quad_segs)
        else:
            g = o.geometry.buffer(d, quad_segs=quad_segs) if d > 0 else o.geometry
        geoms.append(g)
        names.append(o.name)
    if not geoms:
        return InflatedMap(radius, mode, shapely.GeometryCollection(), (), (),
                           np.zeros((0, 1, 4)), np.zeros((0, 1), bool), np.zeros((0, 4)))
    union = shapely.unary_union(geoms)
    polys = list(union.geoms) if isinstance(union, MultiPolygon) else [union]
    polys = [orient(p, 1.0) for p in polys if isinstance(p, Polygon) and not p.is_empty]
    tree = shapely.STRtree(geoms)
    part_names = []
    for p in polys:
        idx = tree.query(p, predicate="intersects")
        part_names.append(tuple(names[i] for i in sorted(idx)))
    edge_lists = []
    for p in polys:
        rings = [p.exterior, *p.interiors]
        segs = []
        for ring in rings:
            c = np.asarray(ring.coords)
            segs.append(np.hstack([c[:-1], c[1:]]))
        edge_lists.append(np.vstack(segs))
    e_max = max(len(e) for e in edge_lists)
    edges = np.zeros((len(polys), e_max, 4))
    mask = np.zeros((len(polys), e_max), bool)
    for i, e in enumerate(edge_lists):
        edges[i, : len(e)] = e
        mask[i, : len(e)] = True
    bbox = np.array([p.bounds for p in polys]).reshape(-1, 4)
    return InflatedMap(radius, mode, union, tuple(polys), tuple(part_names), edges, mask, bbox)


@dataclass(frozen=True)
class CrossingResult:
    """Output of :func:`batch_crossings` for paths of shape ``(P, M, 2)``.

    Attributes
    ----------
    count : (P,) int
        Number of (segment, obstacle) pairs whose segment enters the obstacle's interior.
    penetration : (P,) float
        Total length of path inside obstacle interiors (map units).
    seg_count : (P, M-1) int
        Per segment, the number of obstacles it enters.
    """

    count: np.ndarray
    penetration: np.ndarray
    seg_count: np.ndarray
    pairs: tuple[np.ndarray, np.ndarray, np.ndarray] = (
        np.zeros(0, int), np.zeros(0, int), np.zeros(0, int))
    """Colliding pairs as ``(path index, segment index, part index)`` arrays."""


def batch_crossings(paths: np.ndarray, imap: InflatedMap, tol: float = 1e-9) -> CrossingResult:
    """Vectorised interior-crossing count and penetration length for a batch of paths.

    Parameters
    ----------
    paths : array, shape ``(P, M, 2)`` or ``(M, 2)``
        Polylines (``M`` points, ``M - 1`` segments).
    imap : InflatedMap
        Inflated obstacles (see :func:`inflate`).
    tol : float
        Relative tolerance: a pair collides when its inside length exceeds
        ``tol * max(1, map scale)``.

    Returns
    -------
    CrossingResult
    """
    pts = np.asarray(paths, dtype=float)
    if pts.ndim == 2:
        pts = pts[None]
    P, M, _ = pts.shape
    S = M - 1
    seg_count = np.zeros((P, S), dtype=np.int64)
    pen = np.zeros(P)
    if imap.n == 0 or S <= 0:
        return CrossingResult(seg_count.sum(1), pen, seg_count)
    a = pts[:, :-1, :].reshape(-1, 2)
    b = pts[:, 1:, :].reshape(-1, 2)
    si, oi = candidate_pairs(a, b, imap)
    if si.size == 0:
        return CrossingResult(seg_count.sum(1), pen, seg_count)
    inside = inside_lengths(a[si], b[si], oi, imap)
    hit = inside > tol * imap.scale
    np.add.at(seg_count.reshape(-1), si, hit.astype(np.int64))
    path_of = si // S
    np.add.at(pen, path_of, np.where(hit, inside, 0.0))
    pairs = (path_of[hit], (si % S)[hit], oi[hit])
    return CrossingResult(seg_count.sum(1), pen, seg_count, pairs)


def candidate_pairs(a: np.ndarray, b: np.ndarray, imap: InflatedMap) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    """(segment, part) index pairs that may intersect; segments ``a[k] -> b[k]``.

    Two cheap filters: the bounding boxes overlap, and the part's bounding box is not entirely
    on one side of the segment's line (its four corners are tested).
    """
    smin = np.minimum(a, b)
    smax = np.maximum(a, b)
    bb = imap.bbox
    ov = (
        (smin[:, None, 0] <= bb[None, :, 2]) & (smax[:, None, 0] >= bb[None, :, 0])
        & (smin[:, None, 1] <= bb[None, :, 3]) & (smax[:, None, 1] >= bb[None, :, 1])
    )
    si, oi = np.nonzero(ov)
    if si.size == 0:
        return si, oi
    d = b[si] - a[si]
    cx = bb[oi][:, [0, 2, 2, 0]] - a[si, 0:1]
    cy = bb[oi][:, [1, 1, 3, 3]] - a[si, 1:2]
    side = d[:, 0:1] * cy - d[:, 1:2] * cx
    slack = 1e-12 * imap.scale * np.hypot(d[:, 0], d[:, 1])
    keep = ~((side > slack[:, None]).all(axis=1) | (side < -slack[:, None]).all(axis=1))
    return si[keep], oi[keep]


def inside_lengths(a: np.ndarray, b: np.ndarray, oi: np.ndarray,
                   imap: InflatedMap) -> np.ndarray:
    """Length of segment ``a[k] -> b[k]`` inside the interior of part ``oi[k]`` (module doc).

    The core of :func:`batch_crossings` for explicit pairs, shape ``(K,)``.
    """
    A = a[:, None, :]  # (K, 1, 2)
    D = (b - a)[:, None, :]
    E = imap.edges[oi]  # (K, E, 4)
    Pp, Qq = E[..., 0:2], E[..., 2:4]
    # side of edge endpoints w.r.t. the line through A with direction D
    sp = D[..., 0] * (Pp[..., 1] - A[..., 1]) - D[..., 1] * (Pp[..., 0] - A[..., 0])
    sq = D[..., 0] * (Qq[..., 1] - A[..., 1]) - D[..., 1] * (Qq[..., 0] - A[..., 0])
    # a vertex within round-off of the line (distance <= 1e-12 x map scale) is ON the line,
    # so the two tie-breaks below decide it, not the sign of the rounding error
    snap = 1e-12 * imap.scale * np.hypot(D[..., 0], D[..., 1])
    sp = np.where(np.abs(sp) <= snap, 0.0, sp)
    sq = np.where(np.abs(sq) <= snap, 0.0, sq)
    valid = imap.edge_mask[oi]
    ev = Qq - Pp
    den = D[..., 0] * ev[..., 1] - D[..., 1] * ev[..., 0]  # cross(D, e)
    num = (Pp[..., 0] - A[..., 0]) * ev[..., 1] - (Pp[..., 1] - A[..., 1]) * ev[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / np.where(den == 0, 1.0, den)
    # entering when the direction points against the outward normal: cross(D, e) < 0
    w = np.where(den < 0, 1.0, -1.0) * np.clip(1.0 - t, 0.0, 1.0)
    # A vertex lying exactly on the line is assigned to one side: that is the inside length of
    # the line shifted infinitesimally to that side.  Evaluate both shifts and keep the smaller:
    # a proper crossing gives the same length either way, while a segment that only runs along
    # or grazes the boundary has length 0 for the shift away from the solid.
    frac_pos = np.sum(np.where(((sp >= 0) != (sq >= 0)) & valid, w, 0.0), axis=1)
    frac_neg = np.sum(np.where(((sp > 0) != (sq > 0)) & valid, w, 0.0), axis=1)
    frac = np.minimum(frac_pos, frac_neg)
    return np.clip(frac, 0.0, 1.0) * np.hypot(D[:, 0, 0], D[:, 0, 1])


def path_lengths(paths: np.ndarray) -> np.ndarray:
    """Polyline lengths; ``(P, M, 2) -> (P,)`` or ``(M, 2) -> float``."""
    pts = np.asarray(paths, dtype=float)
    d = np.diff(pts, axis=-2)
    return np.sum(np.hypot(d[..., 0], d[..., 1]), axis=-1)


def point_clearance(points: np.ndarray, obstacles: Iterable) -> np.ndarray:
    """Distance from each point to the nearest (raw, un-inflated) obstacle; 0 inside.

    Circles are measured exactly; polygons through ``shapely.distance`` (vectorised).
    Returns ``inf`` when there are no obstacles.
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    best = np.full(len(pts), np.inf)
    polys = []
    for o in obstacles:
        if o.is_circle:
            d = np.hypot(pts[:, 0] - o.center[0], pts[:, 1] - o.center[1]) - o.radius
            best = np.minimum(best, np.maximum(d, 0.0))
        else:
            polys.append(o.geometry)
    if polys:
        geom = shapely.unary_union(polys)
        best = np.minimum(best, shapely.distance(shapely.points(pts), geom))
    return best


# --------------------------------------------------------------------------------------
# exact disc-robot kernel for swarms (raw obstacles, convex pieces, spatial grid)
# --------------------------------------------------------------------------------------

#: Edges per convex piece in :class:`ObstacleSet` (larger convex polygons are fan-split).
PIECE_EDGES = 4


@dataclass(frozen=True)
class DiscCrossings:
    """Output of :meth:`ObstacleSet.crossings` for paths of shape ``(P, M, 2)``.

    Attributes
    ----------
    count : (P,) int
        Number of (segment, obstacle) pairs whose segment comes closer than the radius to the
        raw obstacle (an obstacle split into several convex pieces counts once).
    penetration : (P,) float
        Sum over colliding (segment, piece) pairs of ``r - dist`` (segment outside the raw
        piece) or ``r + inside length`` (segment meets the raw piece), map units: continuous,
        zero at the collision threshold, growing as the segment moves in.  Zeros when
        asked with ``penetration=False``.
    seg_count : (P, M-1) int or None
        Per segment, the number of obstacles it collides with (``details=True`` only).
    pairs : tuple of arrays or None
        Colliding ``(path, segment, obstacle)`` index triples (``details=True`` only).
    """

    count: np.ndarray
    penetration: np.ndarray
    seg_count: np.ndarray | None = None
    pairs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None


def convex_pieces(geom, max_edges: int = PIECE_EDGES) -> list[np.ndarray]:
    """Convex pieces of a polygon as CCW vertex arrays ``(k, 2)``, ``3 <= k <= max_edges``.

    A convex polygon without holes is fan-split into quadrilaterals/triangles sharing its first
    vertex (one piece when it has at most ``max_edges`` vertices: rectangles, triangles,
    trapezoids); anything else is split into the triangles of its constrained Delaunay
    triangulation (``shapely.constrained_delaunay_triangles``).  The pieces tile the polygon.
    """
    polys = list(geom.geoms) if hasattr(geom, "geoms") else [geom]
    out = []
    for p in polys:
        if p.is_empty or p.area <= 0:
            continue
        convex = len(p.interiors) == 0 and abs(p.convex_hull.area - p.area) <= 1e-12 * p.area
        if convex:
            cand = [orient(p.convex_hull, 1.0)]
        else:
            cand = [orient(t, 1.0) for t in
                    shapely.constrained_delaunay_triangles(p).geoms if t.area > 0]
        for c in cand:
            v = np.asarray(c.exterior.coords)[:-1]
            # drop repeated and collinear vertices (zero-length / straight-angle edges)
            prev, nxt = np.roll(v, 1, axis=0), np.roll(v, -1, axis=0)
            cr = ((v[:, 0] - prev[:, 0]) * (nxt[:, 1] - v[:, 1])
                  - (v[:, 1] - prev[:, 1]) * (nxt[:, 0] - v[:, 0]))
            scale = max(1.0, float(np.max(np.abs(v))))
            v = v[np.abs(cr) > 1e-14 * scale * scale]
            if len(v) < 3:
                continue
            i = 1
            while i < len(v) - 1:  # fan: (v0, v_i, ..., v_{i + max_edges - 2})
                j = min(i + max_edges - 2, len(v) - 1)
                out.append(np.vstack([v[:1], v[i:j + 1]]))
                i = j
    return out


#: Engines of :meth:`ObstacleSet.crossings` (``"auto"`` resolves to one of the other two).
KERNEL_ENGINES = ("auto", "numpy", "numba")


def kernel_engine(engine: str = "auto") -> str:
    """The engine ``engine`` resolves to for :meth:`ObstacleSet.crossings` (without details).

    ``"numpy"`` is the vectorised kernel below; ``"numba"`` the compiled loops of
    :mod:`optplan.numba_kernel` (optional dependency: ``pip install optplan[fast]``).
    ``"auto"`` is ``"numba"`` when numba is importable, else ``"numpy"``; the environment
    variable ``OPTPLAN_ENGINE`` overrides what ``"auto"`` means (``numpy``: always numpy,
    ``numba``: require numba, ``auto`` or empty: the default).  Both engines decide every pair
    with the same formulas: counts agree except for a segment within round-off (~1e-16
    relative) of the collision threshold, where numpy's vectorised complex products may round
    differently from scalar code; penetration agrees to round-off.

    Raises
    ------
    ValueError
        Unknown engine (argument or environment variable), or ``"numba"`` asked for while
        numba is not installed.
    """
    import os

    from optplan import numba_kernel

    if engine not in KERNEL_ENGINES:
        raise ValueError(f"unknown crossings engine {engine!r}; allowed: "
                         + ", ".join(repr(e) for e in KERNEL_ENGINES))
    if engine == "auto":
        env = os.environ.get("OPTPLAN_ENGINE", "").strip().lower() or "auto"
        if env not in KERNEL_ENGINES:
            raise ValueError(f"environment variable OPTPLAN_ENGINE={env!r} is not one of "
                             + ", ".join(repr(e) for e in KERNEL_ENGINES))
        if env == "auto":
            return "numba" if numba_kernel.AVAILABLE else "numpy"
        engine = env
    if engine == "numba" and not numba_kernel.AVAILABLE:
        raise ValueError("engine 'numba' needs numba, which is not installed: "
                         "pip install optplan[fast] (or use engine='numpy')")
    return engine


@dataclass(frozen=True, eq=False)
class ObstacleSet:
    """Raw static obstacles laid out for the exact disc-robot test of whole swarms.

    Built once per (obstacles, radius) by :func:`obstacle_set`.  Polygons are split into
    convex pieces of at most 4 edges (:func:`convex_pieces`: rectangles, triangles and
    trapezoids are one piece, against ~36 edges for their round buffer; a triangle is stored
    with one edge repeated, which changes neither a maximum nor a minimum below); circles are
    kept exact.  A (segment, obstacle) pair *collides* when the distance between the segment
    and the raw obstacle is below ``radius + 1e-9 x`` map scale: the exact test of a disc robot
    against the obstacle (the segment enters the open Minkowski sum).  Per (segment, piece):
    Cyrus-Beck clipping by the piece's half-planes says whether the segment meets the piece
    (and the inside length); otherwise the distance is the smallest of the piece-vertex to
    segment and segment-endpoint to piece-edge distances.

    Relation to the validator (:func:`optplan.metrics.evaluate`): the validator tests interior
    crossings of the *inscribed* round buffer (:func:`inflate`), which lies inside the exact
    Minkowski sum.  A segment entering the inscribed polygon's interior comes closer than
    ``radius`` to the obstacle, so this test is stricter: a path collision-free here is
    collision-free for the validator (``tests/test_swarm.py`` checks it on random segments
    and on segments grazing rounded corners).  The price is up to the sagitta
    ``r (1 - cos(pi / 16))`` of extra clearance at rounded corners.  Touching a raw obstacle
    counts as a collision even for ``radius = 0``.

    Candidate pairs: every item (piece or circle) has a bounding circle ``(center, reach)``.
    With few items (< 48) all (segment, item) pairs get one matrix product giving each
    center's distance to the segment's line and its coordinate along the segment, and only
    centers in the box around the capsule of radius ``reach + radius`` are kept.  With many
    items a uniform grid (cell ~ 2 x the median item extent) lists the items by the cells their
    bounding square covers; each segment visits the cells it crosses (column by column, exact
    supercover), and the capsule test is applied to the pairs found, so the work per segment
    grows with the obstacles near it, not with all of them.  Points are handled as complex
    numbers (a free view of the ``(..., 2)`` input), which halves the number of array
    operations; the per-(pair, edge) arrays are ``(4, pairs)`` so that reductions over a
    piece's edges run along the first axis (numpy reduces a short last axis slowly).

    Attributes
    ----------
    radius : float
        Robot radius.
    n_obstacles, names
        Raw obstacles (counts are per obstacle, not per piece).
    n_pieces : int
        Convex pieces; items ``0 .. n_pieces - 1`` are pieces, the rest circles.
    item_obstacle, item_center, item_reach
        Per item: owning obstacle, bounding-circle center (complex) and radius.
    circle_radius : array
        Radii of the circle items.
    table : complex array ``(5, 4, n_pieces)``
        Per piece edge: start point, edge vector, outward unit normal, ``-conj(e) / |e|^2``
        and ``n . p`` (real part).
    scale : float
        Coordinate scale for the ``1e-9`` relative tolerance.
    grid : dict or None
        The uniform grid (cell size, origin, shape, CSR item lists), or None (all pairs).
    grid_free : dict
        The matrix of the all-pairs test (``"M"``), the per-item ``reach + radius`` (``"lim"``;
        ``"lim2"``: with the tolerance and a 1e-9 x scale margin, stacked twice for the two row
        blocks of ``M``) and the edge table of the count-only test (``"hit_table"``:
        ``p, e, conj(n), -conj(e)/|e|^2``).
    """

    radius: float
    n_obstacles: int
    names: tuple
    n_pieces: int
    item_obstacle: np.ndarray
    item_center: np.ndarray
    item_reach: np.ndarray
    circle_radius: np.ndarray
    table: np.ndarray
    scale: float
    grid: dict | None
    grid_free: dict

    @property
    def n_items(self) -> int:
        return len(self.item_obstacle)

    def _grid_pairs(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(segment, item) pairs whose segment crosses a grid cell listing the item."""
        g = self.grid
        h, gx0, gy0, nx, ny = g["h"], g["x0"], g["y0"], g["nx"], g["ny"]
        sw = b.real < a.real
        pa = np.where(sw, b, a)
        pb = np.where(sw, a, b)
        xa, ya, xb, yb = pa.real, pa.imag, pb.real, pb.imag
        i0 = np.clip(np.floor((xa - gx0) / h), 0, nx - 1).astype(np.int64)
        i1 = np.clip(np.floor((xb - gx0) / h), 0, nx - 1).astype(np.int64)
        ncol = i1 - i0 + 1
        seg = np.repeat(np.arange(len(xa)), ncol)
        first = np.cumsum(ncol) - ncol
        col = i0[seg] + np.arange(len(seg)) - first[seg]
        # x-interval of the segment inside the column (border columns extend to infinity)
        lo = np.where(col == 0, -np.inf, gx0 + col * h)
        hi = np.where(col == nx - 1, np.inf, gx0 + (col + 1) * h)
        xs, xe, ys, ye = xa[seg], xb[seg], ya[seg], yb[seg]
        xl = np.maximum(xs, lo)
        xr = np.minimum(xe, hi)
        dx = xe - xs
        slope = np.divide(ye - ys, dx, out=np.zeros_like(dx), where=dx > 0)
        flat = ~(dx > 0)
        y1 = np.where(flat, ys, ys + (xl - xs) * slope)
        y2 = np.where(flat, ye, ys + (xr - xs) * slope)
        j0 = np.clip(np.floor((np.minimum(y1, y2) - gy0) / h), 0, ny - 1).astype(np.int64)
        j1 = np.clip(np.floor((np.maximum(y1, y2) - gy0) / h), 0, ny - 1).astype(np.int64)
        nrow = j1 - j0 + 1
        k = np.repeat(np.arange(len(seg)), nrow)
        first = np.cumsum(nrow) - nrow
        cell = col[k] * ny + j0[k] + np.arange(len(k)) - first[k]
        seg = seg[k]
        cs, cc = g["start"][cell], g["count"][cell]
        m = np.repeat(np.arange(len(cell)), cc)
        first = np.cumsum(cc) - cc
        item = g["items"][cs[m] + np.arange(len(m)) - first[m]]
        key = np.unique(seg[m] * self.n_items + item)
        return np.divmod(key, self.n_items)

    def _piece_hits(self, si: np.ndarray, it: np.ndarray, a: np.ndarray, d: np.ndarray,
                    dc: np.ndarray, inv: np.ndarray, r_eff: float) -> np.ndarray:
        """Collision flags of (segment ``si``, piece ``it``) pairs, without penetration.

        Branch-free (every op runs once on ``(4, pairs)`` arrays; few, short numpy calls):
        the segment meets the closed piece unless a separating axis exists among the piece's
        edge normals (both endpoints strictly outside one edge line) and the segment's normal
        (all vertices strictly on one side of its line); otherwise the pair collides when the
        smallest vertex-segment or endpoint-edge distance is below ``r_eff`` (the exact
        segment-polygon distance when they do not meet).
        """
        p, e, nc, ee = self.grid_free["hit_table"].take(it, axis=2)  # (4, pairs) each
        A, D = a[si], d[si]
        w = p - A  # vertex - A
        q = w * dc[si]  # real: (p - A).d, imaginary: d x (p - A)
        cr = q.imag
        sep = cr.min(axis=0) * cr.max(axis=0) > 0  # the segment's line separates
        hA = (w * nc).real  # n . (p - A) < 0: A strictly outside edge j
        w2 = w - D  # vertex - B
        hB = (w2 * nc).real
        sep |= np.maximum(hA, hB).min(axis=0) < 0  # an edge line separates
        t = q.real * inv[si]  # vertex -> segment
        np.maximum(t, 0.0, out=t)
        np.minimum(t, 1.0, out=t)
        dist = np.abs(w - t * D)
        s = (w * ee).real  # A -> edge j
        np.maximum(s, 0.0, out=s)
        np.minimum(s, 1.0, out=s)
        np.minimum(dist, np.abs(w + s * e), out=dist)
        s = (w2 * ee).real  # B -> edge j
        np.maximum(s, 0.0, out=s)
        np.minimum(s, 1.0, out=s)
        np.minimum(dist, np.abs(w2 + s * e), out=dist)
        close = dist.min(axis=0) < r_eff
        np.logical_not(sep, out=sep)
        sep |= close
        return sep

    def crossings(self, paths: np.ndarray, details: bool = False,
                  penetration: bool = True, engine: str = "auto") -> DiscCrossings:
        """Exact disc-robot collision count (and penetration) for a batch of polylines.

        Parameters
        ----------
        paths : array ``(P, M, 2)`` or ``(M, 2)``
        details : bool
            Also return per-segment counts and the colliding (path, segment, obstacle) pairs.
        penetration : bool
            Compute the penetration measure (else zeros; saves a little time).
        engine : {"auto", "numpy", "numba"}
            ``"numpy"``: the vectorised kernel; ``"numba"``: the compiled loops of
            :mod:`optplan.numba_kernel` (optional dependency ``optplan[fast]``; no
            ``details``); ``"auto"`` (default): numba when it is installed and ``details`` is
            False, else numpy.  The environment variable ``OPTPLAN_ENGINE=numpy`` makes
            ``"auto"`` use numpy (see :func:`kernel_engine`).  Both engines give the same
            counts (up to segments within round-off of the threshold) and penetration.

        Raises
        ------
        ValueError
            Unknown ``engine``, ``"numba"`` without numba installed, or ``"numba"`` with
            ``details=True``.
        """
        if engine == "auto" and details:
            engine = "numpy"
        else:
            engine = kernel_engine(engine)
            if engine == "numba" and details:
                raise ValueError("engine 'numba' does not compute details; use "
                                 "engine='numpy' (or 'auto') with details=True")
        pts = np.asarray(paths, dtype=float)
        if pts.ndim == 2:
            pts = pts[None]
        P, M, _ = pts.shape
        S = M - 1

        def zero() -> DiscCrossings:
            return DiscCrossings(np.zeros(P, np.int64), np.zeros(P),
                                 np.zeros((P, max(S, 0)), np.int64) if details else None,
                                 (np.zeros(0, np.int64),) * 3 if details else None)

        if self.n_items == 0 or S <= 0:
            return zero()
        if engine == "numba":
            from optplan import numba_kernel

            count, pen = numba_kernel.crossings(self, pts, penetration)
            return DiscCrossings(count, pen)
        # points as complex numbers (a free view of the interleaved coordinates)
        z = np.ascontiguousarray(pts).view(np.complex128)[..., 0]
        a = z[:, :-1].reshape(-1)
        d = z[:, 1:].reshape(-1) - a
        dc = d.conj()
        dd = (d * dc).real
        inv = 1.0 / np.maximum(dd, 1e-300)  # degenerate segments: t = 0 below
        r_eff = self.radius + 1e-9 * self.scale
        if self.grid is None:
            # all (segment, item) pairs: keep the centers inside the box around the capsule
            # of radius reach + r (perpendicular and along-segment coordinates by one matmul)
            half = np.sqrt(dd)
            il = np.maximum(half, 1e-300)
            np.divide(1.0, il, out=il)
            half *= 0.5
            da = d * a.conj()
            L = np.empty((4, len(a)))
            np.multiply(d.real, il, out=L[0])
            np.multiply(d.imag, il, out=L[1])
            np.multiply(da.imag, il, out=L[2])  # (dy ax - dx ay) / |d|
            np.multiply(da.real, il, out=L[3])
            np.negative(L[3], out=L[3])
            L[3] -= half  # -(d.a) / |d| - |d| / 2
            # rows 0..K-1: |signed distance| of each center to the segment's line; rows
            # K..2K-1: |coordinate along the segment from the midpoint| - |d| / 2
            R = self.grid_free["M"] @ L
            np.abs(R, out=R)
            K = self.n_items
            R[K:] -= half
            near = R < self.grid_free["lim2"]
            near = near[:K] & near[K:]
            it, si = np.divmod(np.flatnonzero(near), len(a))
        else:
            si, it = self._grid_pairs(a, a + d)
            w = self.item_center[it] - a[si]
            t = np.clip((w * dc[si]).real * inv[si], 0.0, 1.0)
            x = w - t * d[si]
            lim = self.item_reach[it] + (r_eff + 1e-9 * self.scale)  # margin: obstacle_set
            keep = np.flatnonzero((x * x.conj()).real < lim * lim)
            si, it = si[keep], it[keep]
        if si.size == 0:
            return zero()
        hs, hi, hp = [], [], []
        if self.n_pieces < self.n_items:  # circles: exact center-segment distance
            ci = np.flatnonzero(it >= self.n_pieces)
            if ci.size:
                s, c = si[ci], it[ci]
                w = self.item_center[c] - a[s]
                tl = (w * dc[s]).real * inv[s]  # foot of the center on the line
                ro = self.circle_radius[c - self.n_pieces]
                gap = np.abs(w - np.clip(tl, 0.0, 1.0) * d[s]) - ro
                h = np.flatnonzero(gap < r_eff)
                hs.append(s[h])
                hi.append(c[h])
                if penetration:
                    s, w, tl, ro, gap = s[h], w[h], tl[h], ro[h], gap[h]
                    half = np.sqrt(np.maximum(ro * ro - np.abs(w - tl * d[s]) ** 2, 0.0)
                                   * inv[s])
                    chord = np.maximum(np.minimum(tl + half, 1.0) - np.maximum(tl - half, 0.0),
                                       0.0) * np.sqrt(dd[s])
                    hp.append(np.where(gap > 0, self.radius - gap, self.radius + chord))
                pk = np.flatnonzero(it < self.n_pieces)
                si, it = si[pk], it[pk]
        if si.size and not penetration:
            hit = np.flatnonzero(self._piece_hits(si, it, a, d, dc, inv, r_eff))
            hs.append(si[hit])
            hi.append(it[hit])
        elif si.size:
            # edge columns of the candidate pieces, shape (4, pairs) each
            p, e, n, ee, cc = self.table.take(it, axis=2)
            cc = cc.real
            Ac, Dc = a.conj()[si], dc[si]
            # separation by an offset edge: both endpoints at least r outside one half-plane
            gA = (n * Ac).real - cc  # n.A - c
            den = (n * Dc).real  # n.D
            gB = gA + den
            apart = (np.minimum(gA, gB) >= r_eff).any(axis=0)
            # Cyrus-Beck: the part of A + tD inside every half-plane n.x <= c
            den[den == 0] = -1e-200  # parallel: outside (gA > 0) -> t = +huge, never meets
            tt = gA / -den
            neg = den < 0
            t_in = np.maximum(np.where(neg, tt, -np.inf).max(axis=0), 0.0)
            t_out = np.minimum(np.where(neg, np.inf, tt).min(axis=0), 1.0)
            meets = t_in <= t_out
            hit = meets.copy()
            dist = np.zeros(len(si))
            # the rest (near but not meeting): exact distance = min of vertex-segment and
            # endpoint-edge distances
            u = np.flatnonzero(~(apart | meets))
            if u.size:
                su = si[u]
                D, pu, eu, eeu = d[su], p[:, u], e[:, u], ee[:, u]
                w = pu - a[su]
                tv = np.clip((w * dc[su]).real * inv[su], 0.0, 1.0)
                x = w - tv * D
                d2 = (x * x.conj()).real
                x = w + np.clip((w * eeu).real, 0.0, 1.0) * eu
                d2 = np.minimum(d2, (x * x.conj()).real)
                w -= D  # now p - b
                x = w + np.clip((w * eeu).real, 0.0, 1.0) * eu
                d2 = np.minimum(d2, (x * x.conj()).real).min(axis=0)
                hit[u] = d2 < r_eff * r_eff
                dist[u] = np.sqrt(d2)
            hit = np.flatnonzero(hit)
            hs.append(si[hit])
            hi.append(it[hit])
            if penetration:
                inside = (t_out[hit] - t_in[hit]) * np.sqrt(dd[si[hit]])
                hp.append(np.where(meets[hit], self.radius + inside, self.radius - dist[hit]))
        hs = np.concatenate(hs) if len(hs) > 1 else hs[0]
        hi = np.concatenate(hi) if len(hi) > 1 else hi[0]
        pen = np.zeros(P)
        if penetration and hs.size:
            hp = np.concatenate(hp) if len(hp) > 1 else hp[0]
            pen = np.bincount(hs // S, weights=hp, minlength=P)
        # one count per (segment, obstacle): an obstacle split into pieces counts once
        if self.n_items == self.n_obstacles and not details:
            return DiscCrossings(np.bincount(hs // S, minlength=P), pen)
        key = np.unique(hs * self.n_obstacles + self.item_obstacle[hi])
        seg_u = key // self.n_obstacles
        count = np.bincount(seg_u // S, minlength=P)
        if not details:
            return DiscCrossings(count, pen)
        seg_count = np.bincount(seg_u, minlength=P * S).reshape(P, S)
        return DiscCrossings(count, pen, seg_count, (seg_u // S, seg_u % S,
                                                     key % self.n_obstacles))


def obstacle_set(obstacles: Iterable, radius: float, grid: bool | None = None) -> ObstacleSet:
    """Build the :class:`ObstacleSet` of raw static ``obstacles`` for a disc of ``radius``.

    Parameters
    ----------
    obstacles : iterable of :class:`optplan.problem.Obstacle`
    radius : float
        Robot radius (map units), >= 0.
    grid : bool or None
        Use the uniform-grid pre-filter; ``None`` (default) decides by the number of items
        (a grid from 48 items on; below that the all-pairs bounding-circle test is cheaper).
    """
    if not (radius >= 0 and math.isfinite(radius)):
        raise ValueError(f"radius must be finite and >= 0, got {radius}")
    obstacles = list(obstacles)
    pieces, owner, circles, c_owner = [], [], [], []
    for i, o in enumerate(obstacles):
        if o.is_circle:
            circles.append((float(o.center[0]), float(o.center[1]), float(o.radius)))
            c_owner.append(i)
        else:
            for v in convex_pieces(o.geometry):
                pieces.append(v)
                owner.append(i)
    K = len(pieces)
    table = np.zeros((5, PIECE_EDGES, K), dtype=complex)  # p, e, n, -conj(e)/|e|^2, c
    pc, reach = np.zeros((K, 2)), np.zeros(K)
    for k, v in enumerate(pieces):
        vv = np.vstack([v, v[-1:].repeat(PIECE_EDGES - len(v), axis=0)])
        nxt = np.roll(v, -1, axis=0)
        qq = np.vstack([nxt, nxt[-1:].repeat(PIECE_EDGES - len(v), axis=0)])
        p = vv[:, 0] + 1j * vv[:, 1]  # triangles: the last edge repeated
        ev = (qq[:, 0] + 1j * qq[:, 1]) - p
        nrm = -1j * ev / np.abs(ev)  # outward normal of a CCW piece (rotate by -90 degrees)
        table[:, :, k] = [p, ev, nrm, -ev.conj() / np.abs(ev) ** 2, (nrm.conj() * p).real]
        pc[k] = v.mean(axis=0)
        reach[k] = np.max(np.hypot(*(v - pc[k]).T))
    circ = np.array(circles, dtype=float).reshape(-1, 3)
    centers = np.vstack([pc, circ[:, :2]])
    reach = np.concatenate([reach, circ[:, 2]])
    item_obstacle = np.array(owner + c_owner, dtype=np.int64)
    n_items = len(item_obstacle)
    scale = max(1.0, float(np.max(np.abs(centers)) + np.max(reach))) if n_items else 1.0
    use_grid = n_items >= 48 if grid is None else bool(grid)
    gd = None
    # pre-filters keep a margin of 1e-9 x scale beyond reach + r_eff: a pair at the collision
    # threshold of the exact test must never be rejected by the round-off of a cheaper one
    margin = 1e-9 * scale
    if use_grid and n_items:
        ext = reach + radius + 2 * margin
        lo = (centers - ext[:, None]).min(axis=0)
        hi = (centers + ext[:, None]).max(axis=0)
        span = float(np.max(hi - lo))
        # cell ~ twice the median item extent, at most ~256 cells per side
        h = max(2.0 * float(np.median(ext)), span / 256.0, 1e-9 * scale)
        nx = int(math.floor((hi[0] - lo[0]) / h)) + 1
        ny = int(math.floor((hi[1] - lo[1]) / h)) + 1
        i0 = np.clip(np.floor((centers[:, 0] - ext - lo[0]) / h), 0, nx - 1).astype(np.int64)
        i1 = np.clip(np.floor((centers[:, 0] + ext - lo[0]) / h), 0, nx - 1).astype(np.int64)
        j0 = np.clip(np.floor((centers[:, 1] - ext - lo[1]) / h), 0, ny - 1).astype(np.int64)
        j1 = np.clip(np.floor((centers[:, 1] + ext - lo[1]) / h), 0, ny - 1).astype(np.int64)
        cells, items = [], []
        for k in range(n_items):
            ii, jj = np.meshgrid(np.arange(i0[k], i1[k] + 1), np.arange(j0[k], j1[k] + 1))
            cells.append((ii * ny + jj).ravel())
            items.append(np.full(ii.size, k, np.int64))
        cells_a, items_a = np.concatenate(cells), np.concatenate(items)
        order = np.argsort(cells_a, kind="stable")
        count = np.bincount(cells_a, minlength=nx * ny)
        gd = {"h": h, "x0": float(lo[0]), "y0": float(lo[1]), "nx": nx, "ny": ny,
              "items": items_a[order], "count": count,
              "start": np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)}
    # rows giving, for a column (dx, dy, dy ax - dx ay, -(dx ax + dy ay)) of a segment, the
    # cross product (first n_items) and the dot product (next n_items) of d and center - a
    M = np.zeros((2 * n_items, 4))
    M[:n_items, 0], M[:n_items, 1], M[:n_items, 2] = centers[:, 1], -centers[:, 0], 1.0
    M[n_items:, 0], M[n_items:, 1], M[n_items:, 3] = centers[:, 0], centers[:, 1], 1.0
    return ObstacleSet(float(radius), len(obstacles), tuple(o.name for o in obstacles), K,
                       item_obstacle, centers[:, 0] + 1j * centers[:, 1], reach, circ[:, 2],
                       table, scale, gd,
                       {"M": M, "lim": (reach + radius)[:, None],
                        "lim2": np.tile(reach + radius + 2 * margin, 2)[:, None],
                        "hit_table": np.stack([table[0], table[1], table[2].conj(),
                                               table[3]])})
