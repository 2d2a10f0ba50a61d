r"""The one exact collision and clearance engine: true polygons and true circles.

Model
    A robot is a disc of radius ``r >= 0`` (``r = 0``: a point robot).  A straight segment ``s``
    is free of an obstacle ``O`` when the exact Euclidean distance ``dist(s, O) >= r - eps``
    (touching allowed; ``eps`` from :class:`~optplan.geometry.collision.frame.Frame`).  Nothing is
    buffered or polygonised: polygons (with holes) are split into convex pieces that tile them,
    circles are kept as centre and radius.

Per (segment, item) pair, where an item is a convex piece or a circle, the engine computes

* ``dist``: the exact distance between the segment and the closed item (0 when they meet):
  Cyrus-Beck clipping against the piece's half-planes decides "meets"; otherwise the distance
  is the smallest of the vertex-to-segment and endpoint-to-edge distances (the closed form of
  segment-polygon distance for disjoint convex sets).  Circle: centre-to-segment distance minus
  the radius.
* ``inside``: the length of the segment inside the item *eroded by eps along the obstacle's
  boundary* (internal diagonals of the tiling are not eroded, so a segment along a diagonal is
  inside).  This decides point robots: a segment that runs along an edge or grazes a vertex is
  not inside, one that crosses the interior is.

A (segment, obstacle) pair **collides** when ``dist < r - eps`` for one of its items, or the
summed ``inside`` exceeds ``eps``.  For ``r > eps`` the first test decides (a segment that
meets the obstacle has ``dist = 0``); for a point robot the second does.  The continuous
penetration measure of the swarm fitness (paper eq 32) is ``r - dist + inside`` summed over
colliding (segment, item) pairs: zero at the threshold, growing as the segment moves in.

Working region and frame
    Coordinates are taken relative to the frame origin once, at build time.  Obstacles are
    clipped to the working region (the bounds grown by ``r + L``); obstacles entirely outside
    it are dropped.  Inside the bounds every distance below ``r + L`` is exact.

Solids
    The obstacle region is the union of the obstacles (closed sets).  Polygons that touch or
    overlap are merged into one solid before the decomposition
    (:mod:`optplan.geometry.collision.solids`), so a seam between two pieces is an internal
    diagonal, never an eroded boundary: no robot, not even a point, runs along or through it.

Candidate pairs and the compiled loops
    Each item has a bounding box and a bounding circle.  With few items (< 48) every item's
    box, grown by ``r + 2 eps``, is compared with the segment's box in one branch-free pass,
    and the bounding circles of the items that pass are tested against the segment; with
    many, a uniform grid lists items by the cells their bounding square covers and each
    segment visits the cells it crosses (column by column), so
    the work per segment grows with the obstacles near it.  The screens keep a margin of
    ``2 eps`` beyond the collision threshold.  The loops are compiled with numba
    (:mod:`optplan.geometry.collision.kernel`, the only implementation; shapely is the oracle of the
    tests).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Polygon

from optplan.geometry.collision import kernel
from optplan.geometry.collision.frame import Frame
from optplan.geometry.collision.grid import item_grid
from optplan.geometry.collision.pieces import convex_pieces, convex_pieces_many
from optplan.geometry.collision.solids import merge_solids

__all__ = ["PIECE_EDGES", "BOUNDS_NAME", "DiscCrossings", "ObstacleSet", "obstacle_set",
           "clip_obstacles", "bounds_wall"]

#: Edges per convex piece (larger convex polygons are fan-split; triangles repeat an edge).
PIECE_EDGES = 4

#: Name of the bounds wall in results (``ObstacleSet.names[-1]`` of a walled set).
BOUNDS_NAME = "bounds"


@dataclass(frozen=True)
class DiscCrossings:
    """Output of :meth:`ObstacleSet.crossings` for paths of shape ``(P, M, 2)``.

    Attributes
    ----------
    count : (P,) int
        Colliding (segment, obstacle) pairs per path (an obstacle of several pieces counts
        once per segment).
    penetration : (P,) float
        Sum over colliding (segment, item) pairs of ``r - dist + inside`` (map units).
    seg_count : (P, M-1) int or None
        Per segment, the number of obstacles it collides with (``details=True``).
    pairs : tuple of arrays or None
        Colliding ``(path, segment, obstacle)`` index triples (``details=True``); obstacle
        indices refer to the obstacle list the set was built from.
    """

    count: np.ndarray
    penetration: np.ndarray
    seg_count: np.ndarray | None = None
    pairs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None


# --------------------------------------------------------------------------------------
# the obstacle set
# --------------------------------------------------------------------------------------


def clip_obstacles(obstacles: Sequence, frame: Frame, margin: float) -> list[tuple[int, object]]:
    """Obstacles in the local frame, clipped to the bounds grown by ``margin``.

    Returns ``(index, shape)`` pairs for the obstacles that reach into that region: ``shape`` is
    a shapely ``Polygon``/``MultiPolygon`` (local coordinates) or a ``(cx, cy, R)`` tuple for a
    circle.  Obstacles entirely outside the region are dropped.

    Raises
    ------
    ValueError
        An obstacle reaching into the region has coordinates beyond what double precision
        resolves (:meth:`Frame.check_extent`).
    """
    x0, y0, x1, y1 = frame.local_bounds
    lo = np.array([x0 - margin, y0 - margin])
    hi = np.array([x1 + margin, y1 + margin])
    # the polygons at once: their boxes (local), the ones that reach the region, moved to
    # the local frame in one call, and clipped where they cross its border
    pk = [i for i, o in enumerate(obstacles) if not o.is_circle]
    polys: dict[int, object] = {}
    if pk:
        geoms = np.array([obstacles[i].geometry for i in pk], dtype=object)
        box = frame.local(shapely.bounds(geoms).reshape(-1, 2, 2))  # (min, max) corners
        reach = ~(np.any(box[:, 1] < lo, axis=1) | np.any(box[:, 0] > hi, axis=1))
        whole = ~(np.any(box[:, 0] < lo, axis=1) | np.any(box[:, 1] > hi, axis=1))
        ks = np.flatnonzero(reach)
        moved = shapely.transform(geoms[ks], lambda xy: xy - frame.origin)
        for k, g in zip(ks.tolist(), moved):
            polys[pk[k]] = g if whole[k] else _clip_polygon(g, frame, lo, hi,
                                                            _label(pk[k], obstacles[pk[k]]))
    out: list[tuple[int, object]] = []
    for i, o in enumerate(obstacles):
        shape = (_clip_circle(o, frame, lo, hi, _label(i, o)) if o.is_circle else
                 polys.get(i))
        if shape is not None:
            out.append((i, shape))
    return out


def _label(i: int, o) -> str:
    """Obstacle ``i`` as error messages name it."""
    return f"obstacle {i} ({o.name!r})" if getattr(o, "name", "") else f"obstacle {i}"


def _clip_circle(o, frame: Frame, lo: np.ndarray, hi: np.ndarray, label: str):
    """A circle obstacle as ``(cx, cy, R)`` (local), None when it lies outside the region."""
    c = frame.local(o.center)
    R = float(o.radius)
    if np.any(c + R < lo) or np.any(c - R > hi):
        return None  # entirely outside the region (exact box test)
    frame.check_extent(float(np.max(np.abs(c))) + R, label)
    return (float(c[0]), float(c[1]), R)


def _clip_polygon(g, frame: Frame, lo: np.ndarray, hi: np.ndarray, label: str):
    """A polygon obstacle ``g`` (local frame) that crosses the border of the region, clipped
    to it; None when nothing of it with area is left."""
    _check_far_edges(g, frame, lo, hi, label)
    g = shapely.clip_by_rect(g, lo[0], lo[1], hi[0], hi[1])
    g = shapely.make_valid(g) if not g.is_valid else g
    polys = [q for q in getattr(g, "geoms", [g]) if isinstance(q, Polygon)
             and not q.is_empty and q.area > 0]
    if not polys:
        return None
    return shapely.MultiPolygon(polys) if len(polys) > 1 else polys[0]


def _check_far_edges(g, frame: Frame, lo: np.ndarray, hi: np.ndarray, label: str) -> None:
    """Reject an oblique edge that reaches into the region from beyond ``1e6 L``.

    Clipping such an edge at the region's border would place the new vertex with an error of
    about ``1e-16 x`` the far coordinate, above the tolerance.  Axis-parallel edges clip
    exactly (a wall reaching to ``y = -1e10`` is fine).
    """
    lim = 1e6 * frame.length
    for poly in getattr(g, "geoms", [g]):
        for ring in (poly.exterior, *poly.interiors):
            c = np.asarray(ring.coords)
            a, b = c[:-1], c[1:]
            far = (np.abs(a).max(axis=1) > lim) | (np.abs(b).max(axis=1) > lim)
            if not far.any():
                continue
            oblique = (a[:, 0] != b[:, 0]) & (a[:, 1] != b[:, 1])
            emin, emax = np.minimum(a, b), np.maximum(a, b)
            meets = np.all(emin <= hi, axis=1) & np.all(emax >= lo, axis=1)
            if np.any(far & oblique & meets):
                k = int(np.flatnonzero(far & oblique & meets)[0])
                frame.check_extent(float(max(np.abs(a[k]).max(), np.abs(b[k]).max())),
                                   f"{label}, an oblique edge reaching into the map")


def bounds_wall(frame: Frame, margin: float) -> Polygon:
    """The bounds as a wall (local frame): the closed complement of the open bounds within the
    bounds grown by ``margin``, a rectangular frame whose hole is the bounds."""
    return _wall(*frame.local_bounds, margin)


@functools.lru_cache(maxsize=64)
def _wall(x0: float, y0: float, x1: float, y1: float, margin: float) -> Polygon:
    """:func:`bounds_wall` by its size (a shapely geometry is immutable: one per size)."""
    outer = [(x0 - margin, y0 - margin), (x1 + margin, y0 - margin),
             (x1 + margin, y1 + margin), (x0 - margin, y1 + margin)]
    return Polygon(outer, [[(x0, y0), (x0, y1), (x1, y1), (x1, y0)]])


@functools.lru_cache(maxsize=64)
def _wall_pieces(x0: float, y0: float, x1: float, y1: float, margin: float) -> tuple:
    """:func:`convex_pieces` of the bounds wall alone, cached by its size (every obstacle set
    of a map, and of every map of the same size, has the same one)."""
    frame = Frame.from_bounds((x0, y0, x1, y1))
    out = convex_pieces(bounds_wall(frame, margin), PIECE_EDGES)
    for v, fl in out:
        v.setflags(write=False)
        fl.setflags(write=False)
    return tuple(out)


@dataclass(frozen=True, eq=False)
class ObstacleSet:
    """Static obstacles of a map laid out for exact disc-robot queries (module docstring).

    Build with :func:`obstacle_set` or :meth:`optplan.problem.Problem.obstacle_set`.  Inputs and
    outputs of every method are in world coordinates; the arrays below are local.

    Attributes
    ----------
    frame : Frame
        Local frame and tolerance (``frame.eps``).
    radius : float
        Robot radius ``r``.
    names : tuple of str
        Names of *all* obstacles given (indices in results refer to this list), then
        :data:`BOUNDS_NAME` when the set is walled.
    shapes : tuple
        ``(obstacle index, local shape)`` of the solids kept: the obstacles clipped by
        :func:`clip_obstacles`, touching polygons merged into one solid under the smallest
        index of its members (:func:`optplan.geometry.collision.solids.merge_solids`).
    n_pieces : int
        Convex pieces; items ``0 .. n_pieces - 1`` are pieces, the rest circles.
    item_obstacle, item_center, item_reach : arrays
        Per item: obstacle index, bounding-circle centre (complex, local) and radius.
    circle_radius : array
        Radii of the circle items.
    table : complex array ``(6, 4, n_pieces)``
        Per piece edge: start ``p``, edge vector ``e``, outward unit normal ``n``,
        ``-conj(e) / |e|^2``, ``n . p`` and the eroded offset ``n . p - eps`` (boundary edges)
        or ``n . p`` (internal diagonals), both in the real part.
    boundary : bool array ``(4, n_pieces)``
        Edge on the obstacle's boundary.
    grid : dict or None
        Uniform grid of items (CSR lists), or None (all-pairs screen).
    members : dict
        Solid representative -> the indices of the obstacles merged into it (solids of two or
        more obstacles only).  Results that name an obstacle index name the representative;
        :meth:`solid_name` names the members too.
    """

    frame: Frame
    radius: float
    names: tuple
    shapes: tuple
    n_pieces: int
    item_obstacle: np.ndarray
    item_center: np.ndarray
    item_reach: np.ndarray
    circle_radius: np.ndarray
    table: np.ndarray
    boundary: np.ndarray
    grid: dict | None
    members: dict = field(default_factory=dict)
    walled: bool = False
    _cache: dict = field(default_factory=dict, repr=False)

    def solid_name(self, k: int) -> str:
        """Name of obstacle ``k`` as results report it: with the obstacles merged into its
        solid, e.g. ``"wall-a (one solid with 'wall-b', 'wall-c')"``."""
        name = self.names[k] or f"obstacle {k}"
        others = [self.names[j] or f"obstacle {j}" for j in self.members.get(k, ()) if j != k]
        if not others:
            return name
        shown = ", ".join(repr(o) for o in others[:3])
        more = f" and {len(others) - 3} more" if len(others) > 3 else ""
        return f"{name} (one solid with {shown}{more})"

    @property
    def n_obstacles(self) -> int:
        """Obstacles an index may refer to (the bounds wall included when walled)."""
        return len(self.names)

    @property
    def n_items(self) -> int:
        return len(self.item_obstacle)

    @property
    def eps(self) -> float:
        return self.frame.eps

    @property
    def arrays(self) -> tuple:
        """Real arrays of the compiled kernel ``(K, P, E, N, C, CE, B, IC, IR, CR, OWN)``: its
        ``items`` argument, one tuple (:mod:`optplan.geometry.collision.kernel`)."""
        if "arrays" not in self._cache:
            t = self.table
            K = self.n_pieces

            def xy(z):  # (4, K) complex -> (K, 4, 2) real: (re, im) pairs, as stored
                return np.ascontiguousarray(z.T).view(float).reshape(K, 4, 2)

            self._cache["arrays"] = (
                K, xy(t[0]), xy(t[1]), xy(t[2]), np.ascontiguousarray(t[4].real.T),
                np.ascontiguousarray(t[5].real.T), np.ascontiguousarray(self.boundary.T),
                np.ascontiguousarray(np.stack([self.item_center.real,
                                               self.item_center.imag], axis=1)),
                np.ascontiguousarray(self.item_reach, dtype=float),
                np.ascontiguousarray(self.circle_radius, dtype=float),
                np.ascontiguousarray(self.item_obstacle, dtype=np.int64))
        return self._cache["arrays"]

    def _grid_args(self) -> tuple[bool, float, float, float, int, int, np.ndarray, np.ndarray,
                                  np.ndarray]:
        g = self.grid
        if g is None:
            z = np.zeros(1, np.int64)
            return False, 1.0, 0.0, 0.0, 1, 1, z, z, z
        return (True, float(g["h"]), float(g["x0"]), float(g["y0"]), int(g["nx"]),
                int(g["ny"]), g["start"], g["count"], g["items"])

    def pair_geometry(self, si: np.ndarray, it: np.ndarray, a: np.ndarray,
                      d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact ``dist`` and eroded ``inside`` length of (segment ``si``, item ``it``) pairs.

        ``a``, ``d``: local complex segment starts and vectors.  See the module docstring.
        """
        A = np.ascontiguousarray(np.stack([np.real(a), np.imag(a)], axis=1), dtype=float)
        D = np.ascontiguousarray(np.stack([np.real(d), np.imag(d)], axis=1), dtype=float)
        from optplan.geometry.collision import pairs_kernel  # compiled on first use (its docstring)

        return pairs_kernel.pairs(np.ascontiguousarray(si, np.int64),
                                  np.ascontiguousarray(it, np.int64), A, D, self.arrays,
                                  self.eps)

    def _segments(self, paths) -> tuple[np.ndarray, np.ndarray, int, int]:
        """Local segment starts and vectors ``(n, 2)`` of a batch of polylines."""
        pts = np.asarray(paths, dtype=float)
        if pts.ndim == 2:
            pts = pts[None]
        if pts.ndim != 3 or pts.shape[-1] != 2:
            raise ValueError(f"paths must have shape (P, M, 2) or (M, 2), got {pts.shape}")
        P, M, _ = pts.shape
        loc = self.frame.local(pts)
        A = np.ascontiguousarray(loc[:, :-1].reshape(-1, 2))
        D = np.ascontiguousarray(loc[:, 1:].reshape(-1, 2)) - A
        return A, D, P, M - 1

    # -- public queries ---------------------------------------------------------------------
    def crossings(self, paths, details: bool = False, penetration: bool = True
                  ) -> DiscCrossings:
        """Exact collision count and penetration for a batch of polylines.

        Parameters
        ----------
        paths : array ``(P, M, 2)`` or ``(M, 2)``, world coordinates
        details : bool
            Also return per-segment counts and the colliding (path, segment, obstacle) pairs.
        penetration : bool
            Compute the penetration measure (else zeros).
        """
        A, D, P, S = self._segments(paths)
        if self.n_items == 0 or S <= 0:
            return DiscCrossings(np.zeros(P, np.int64), np.zeros(P),
                                 np.zeros((P, max(S, 0)), np.int64) if details else None,
                                 (np.zeros(0, np.int64),) * 3 if details else None)
        cap = 4 * len(A) + 16 if details else 0
        while True:
            hits = np.empty((cap, 2), np.int64)
            count, pen, n_hits = kernel.crossings(
                A, D, S, self.arrays, self.n_obstacles, self._grid_args(), self.radius,
                self.eps, bool(penetration), hits)
            if not details or n_hits <= cap:
                break
            cap = int(n_hits)
        if not penetration:
            pen = np.zeros(P)
        if not details:
            return DiscCrossings(count, pen)
        hits = hits[:n_hits]
        seg = hits[:, 0]
        seg_count = np.bincount(seg, minlength=P * S).reshape(P, S).astype(np.int64)
        return DiscCrossings(count, pen, seg_count, (seg // S, seg % S, hits[:, 1].copy()))

    def segment_free(self, a, b=None) -> np.ndarray:
        """Per segment ``a[k] -> b[k]`` (world, ``(K, 2)`` each), or per segment ``a[k]``
        (``(K, 2, 2)``, its two ends) when ``b`` is None: collision-free."""
        seg = (np.asarray(a, dtype=float) if b is None else np.stack(
            [np.asarray(a, dtype=float).reshape(-1, 2), np.asarray(b, dtype=float).reshape(-1, 2)],
            axis=1)).reshape(-1, 2, 2)
        if len(seg) == 0:
            return np.zeros(0, bool)
        return self.crossings(seg, penetration=False).count == 0

    def pairs_free(self, points, i, j) -> np.ndarray:
        """Per index pair ``(i[k], j[k])`` into ``points`` (world, ``(n, 2)``): whether the
        segment ``points[i[k]] -> points[j[k]]`` is collision-free.

        The decision of :meth:`segment_free`, with an early exit per segment (the item that
        blocked the previous segment is tried first); the segments are given by point indices,
        so a roadmap tests its vertex pairs without gathering their end points.
        """
        i = np.ascontiguousarray(i, np.int64)
        j = np.ascontiguousarray(j, np.int64)
        if len(i) == 0:
            return np.zeros(0, dtype=bool)
        if self.n_items == 0:
            return np.ones(len(i), dtype=bool)
        L = np.ascontiguousarray(self.frame.local(points))
        from optplan.geometry.collision import pairs_kernel  # compiled on first use (its docstring)

        return pairs_kernel.free_pairs(L, i, j, self.arrays, self.n_obstacles,
                                       self._grid_args(), self.radius, self.eps)

    def clearance(self, paths, max_dist: float = math.inf) -> np.ndarray:
        """Per path, the exact minimum distance to any obstacle minus the radius ``r``.

        Negative when the path comes closer than ``r`` (``-r`` when it meets an obstacle,
        ``-r - inside / 2`` when it runs inside one: a point robot's depth bound).  ``inf`` with
        no obstacle within ``max_dist``.
        """
        A, D, P, S = self._segments(paths)
        out = np.full(P, math.inf)
        if self.n_items == 0 or S <= 0:
            return out
        best = kernel.clearance(A, D, self.arrays, self.eps, float(max_dist))
        return best.reshape(P, S).min(axis=1) - self.radius

    def point_distances(self, points) -> np.ndarray:
        """Exact distance from each point to the nearest obstacle (0 inside); ``inf`` if none."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(pts) == 0:
            return np.zeros(0)
        c = self.clearance(np.stack([pts, pts], axis=1)) + self.radius
        return np.maximum(c, 0.0)

    def ends_problem(self, start, goal) -> str | None:
        """Why ``start`` or ``goal`` (world) cannot be the centre of the robot's disc (closer
        than the radius to an obstacle), or None."""
        r = self.radius
        ends = np.array([np.asarray(start, float), np.asarray(goal, float)])
        for key, p, c in zip(("start", "goal"), (start, goal), self.point_distances(ends)):
            if c < r - self.eps:
                return (f"{key} {np.asarray(p).tolist()} lies within {r:g} of an "
                        f"obstacle (distance {c:.6g})")
        return None

    def nearest(self, points, max_range: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
        """Nearest boundary point and distance for every (point, obstacle) pair.

        Parameters
        ----------
        points : array ``(R, 2)`` or ``(2,)``, world coordinates
        max_range : float
            Obstacles farther than this are skipped (distance ``inf``, point ``nan``); a point
            inside an obstacle gets distance 0 at any range.

        Returns
        -------
        nearest : ``(R, n_obstacles, 2)`` world coordinates of the nearest boundary point
        dist : ``(R, n_obstacles)`` exact distance to the obstacle, 0 inside
        """
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        R, n = len(pts), self.n_obstacles
        if self.n_items == 0 or R == 0:
            return np.full((R, n, 2), np.nan), np.full((R, n), math.inf)
        from optplan.geometry.collision import (
            nearest_kernel,  # compiled on first use (its docstring)
        )

        near, dist = nearest_kernel.nearest(np.ascontiguousarray(self.frame.local(pts)),
                                            self.arrays, n, float(max_range))
        m = n - 1 if self.walled else n  # the wall alone is not an obstacle of the map
        return near[:, :m] + self.frame.origin, dist[:, :m]


def obstacle_set(obstacles: Iterable, radius: float, frame: Frame,
                 grid: bool | None = None, solids: bool = True,
                 walls: bool = True) -> ObstacleSet:
    """Build the :class:`ObstacleSet` of static ``obstacles`` for a disc of ``radius``.

    Parameters
    ----------
    obstacles : iterable of :class:`optplan.problem.Obstacle`
    radius : float
        Robot radius (map units), >= 0.
    frame : Frame
        The map's local frame (:attr:`optplan.problem.Problem.frame`).
    grid : bool or None
        Use the uniform-grid screen; ``None`` decides by the number of items.
    solids : bool
        Merge touching polygons into solids (the obstacle region, module docstring).  False
        keeps every obstacle apart: only for distances to each of a decomposition's pieces
        (the NLP's convex pieces), never for a collision decision.
    walls : bool
        The bounds are a wall (:func:`bounds_wall`, named :data:`BOUNDS_NAME`): the robot's
        disc stays inside them like outside any obstacle, obstacles touching the bounds are one
        solid with it.  False only for a sensor that sees obstacles, not the map's edge (the
        simulator's sensing), or for a set that is not a map (a decomposition's pieces, one
        moving shape).
    """
    if not (radius >= 0 and math.isfinite(radius)):
        raise ValueError(f"radius must be finite and >= 0, got {radius}")
    obstacles = list(obstacles)
    eps = frame.eps
    margin = radius + frame.length
    shapes, names, members = _solids(obstacles, frame, margin, solids, walls)
    n_obs = len(obstacles)
    pieces, bflags, owner, circles, c_owner = [], [], [], [], []
    polys = [g for i, g in shapes if not isinstance(g, tuple) and not (walls and i == n_obs)]
    made = iter(convex_pieces_many(polys, PIECE_EDGES))  # every solid's queries at once
    for i, g in shapes:
        if isinstance(g, tuple):
            circles.append(g)
            c_owner.append(i)
            continue
        alone = walls and i == n_obs  # the wall, touched by no obstacle
        for v, fl in (_wall_pieces(*frame.local_bounds, margin) if alone else next(made)):
            pieces.append(v)
            bflags.append(fl)
            owner.append(i)
    K = len(pieces)
    V, table, boundary, pc, reach = _edge_table(pieces, bflags, eps)
    circ = np.array(circles, dtype=float).reshape(-1, 3)
    centers = np.vstack([pc, circ[:, :2]])
    reach = np.concatenate([reach, circ[:, 2]])
    item_obstacle = np.array(owner + c_owner, dtype=np.int64)
    # items of the solid that holds the bounds wall (module docstring of grid)
    wall_ids = ({n_obs} | {k for k, ms in members.items() if n_obs in ms}) if walls else set()
    in_wall = np.isin(item_obstacle, sorted(wall_ids))
    gd = item_grid(centers, reach, V, in_wall, radius, eps, grid)
    return ObstacleSet(frame, float(radius), names,
                       tuple(shapes), K, item_obstacle, centers[:, 0] + 1j * centers[:, 1],
                       reach, circ[:, 2], table, boundary, gd, members, bool(walls))


def _solids(obstacles: list, frame: Frame, margin: float, solids: bool, walls: bool
            ) -> tuple[list, tuple, dict]:
    """The clipped shapes (the bounds wall appended when walled), merged into solids when
    asked; their names (``"bounds"`` last when walled) and the solids' members."""
    shapes = clip_obstacles(obstacles, frame, margin)
    names = tuple(getattr(o, "name", "") for o in obstacles)
    if walls:
        shapes.append((len(obstacles), bounds_wall(frame, margin)))
        names += (BOUNDS_NAME,)
    members: dict = {}
    if solids:
        shapes, members = merge_solids(shapes, frame.eps)
    return shapes, names, members


def _edge_table(pieces: list, bflags: list, eps: float) -> tuple:
    """Padded vertices ``(K, 4, 2)``, the edge table, boundary flags, bounding-circle centres
    and radii of the convex pieces (:class:`ObstacleSet` attributes)."""
    K = len(pieces)
    # padded vertex / flag arrays (K, 4): a triangle repeats its last vertex (a zero-length
    # edge would have no normal, so the last *edge* is repeated instead); Q: each edge's end
    m = np.array([len(v) for v in pieces], dtype=np.int64)
    at = (np.cumsum(m) - m)[:, None]  # each piece's first row in the concatenation
    j, last = np.arange(PIECE_EDGES), m[:, None] - 1
    if K:
        xy, fb = np.concatenate(pieces).astype(float), np.concatenate(bflags).astype(bool)
        V, FB = xy[at + np.minimum(j, last)], fb[at + np.minimum(j, last)]
        Q = xy[at + np.where(j < last, j + 1, 0)]
    else:
        V, Q, FB = np.zeros((0, PIECE_EDGES, 2)), np.zeros((0, PIECE_EDGES, 2)), np.zeros(
            (0, PIECE_EDGES), bool)
    p = (V[..., 0] + 1j * V[..., 1]).T  # (4, K)
    ev = (Q[..., 0] + 1j * Q[..., 1]).T - p
    nrm = -1j * ev / np.abs(ev)  # outward normal of a CCW piece
    c = (nrm.conj() * p).real
    table = np.stack([p, ev, nrm, -ev.conj() / np.abs(ev) ** 2, c + 0j, c - eps * FB.T + 0j])
    boundary = FB.T.copy()
    nv = np.array([len(v) for v in pieces], dtype=float)
    if not K:
        return V, table, boundary, np.zeros((0, 2)), np.zeros(0)
    pc = np.stack([(V[..., 0] * (np.arange(PIECE_EDGES) < nv[:, None])).sum(1) / nv,
                   (V[..., 1] * (np.arange(PIECE_EDGES) < nv[:, None])).sum(1) / nv], axis=1)
    reach = np.max(np.hypot(V[..., 0] - pc[:, :1], V[..., 1] - pc[:, 1:]), axis=1)
    return V, table, boundary, pc, reach

