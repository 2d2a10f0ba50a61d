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
