"""The exact collision engine against an independent oracle (shapely distances, analytic
circles) and metamorphic tests (translate, scale, far obstacle)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.polygon import orient

from optplan.geometry import (
    Frame,
    convex_decompose,
    convex_pieces,
    obstacle_set,
    path_lengths,
)
from optplan.problem import Obstacle

SIDE = 100.0
BOUNDS = (0.0, 0.0, SIDE, SIDE)


def circle(cx: float, cy: float, r: float, name: str = "c") -> Obstacle:
    return Obstacle("circle", None, name=name, center=np.array([cx, cy], float), radius=float(r))


def polygon(geom, name: str = "p") -> Obstacle:
    return Obstacle("polygon", orient(geom, 1.0), name=name)


def random_map(rng: np.random.Generator, k: int) -> list[Obstacle]:
    """``k`` random obstacles: circles, star-shaped (often non-convex) polygons, holed rings."""
    out = []
    for i in range(k):
        c = rng.uniform(10, 90, 2)
        t = rng.integers(4)
        if t == 0:
            out.append(circle(*c, rng.uniform(0.5, 10), f"c{i}"))
        elif t in (1, 2):
            n = int(rng.integers(3, 9))
            ang = np.sort(rng.uniform(0, 2 * np.pi, n))
            rad = rng.uniform(2, 12, n)
            p = Polygon(c + np.c_[rad * np.cos(ang), rad * np.sin(ang)])
            if not p.is_valid or p.area < 1:
                p = p.convex_hull
            out.append(polygon(p, f"p{i}"))
        else:
            s = rng.uniform(5, 12)
            outer = shapely.box(*(c - s), *(c + s))
            hole = shapely.box(*(c - s / 2), *(c + s / 2))
            out.append(polygon(outer.difference(hole), f"h{i}"))
    return out


def oracle_distance(seg: LineString, o: Obstacle) -> float:
    """Exact distance from a segment to an obstacle (shapely for polygons, analytic circles)."""
    if o.is_circle:
        return max(seg.distance(Point(o.center)) - o.radius, 0.0)
    return seg.distance(o.geometry)


def oracle_inside(seg: LineString, o: Obstacle) -> float:
    """Length of the segment inside the obstacle (shapely; analytic chord for circles)."""
    if o.is_circle:
        a, b = np.asarray(seg.coords)
        d = b - a
        L = float(np.hypot(*d))
        if L == 0:
            return 0.0
        u = d / L
        w = o.center - a
        t = float(w @ u)
        h2 = o.radius**2 - float(np.hypot(*(w - t * u))) ** 2
        if h2 <= 0:
            return 0.0
        h = math.sqrt(h2)
        return max(0.0, min(t + h, L) - max(t - h, 0.0))
    return seg.intersection(o.geometry).length


def test_validator_agrees_with_an_independent_oracle_on_1000_random_maps() -> None:
    """Accepted segments keep distance >= r - tol, rejected ones come closer than r - tol;
    radii from 0 to 20 % of the map; polygons (convex, non-convex, with holes) and circles."""
    rng = np.random.default_rng(20261201)
    frame = Frame.from_bounds(BOUNDS)
    tol = frame.eps
    band = 1e-7 * SIDE  # oracle round-off band (far wider than either side's round-off)
    n_acc = n_rej = 0
    for trial in range(1000):
        obs = random_map(rng, int(rng.integers(1, 5)))
        r = 0.0 if trial % 4 == 0 else float(rng.uniform(0.0, 0.2 * SIDE))
        oset = obstacle_set(obs, r, frame, grid=bool(trial % 2), walls=False)
        segs = rng.uniform(0, SIDE, (6, 2, 2))
        if trial % 5 == 0:  # short segments: more near misses
            segs[:, 1] = segs[:, 0] + rng.normal(0, 3, (6, 2))
        cr = oset.crossings(segs, details=True)
        for k, (a, b) in enumerate(segs):
            seg = LineString([a, b])
            rejected = bool(cr.seg_count[k].sum())
            if r > tol:
                d = min(oracle_distance(seg, o) for o in obs)
                if rejected:
                    assert d < r - tol + band, (trial, k, r, d)
                else:
                    assert d >= r - tol - band, (trial, k, r, d)
            else:  # point robot: rejected iff it runs inside an obstacle
                inside = max(oracle_inside(seg, o) for o in obs)
                if rejected:
                    assert inside > tol - band, (trial, k, inside)
                else:
                    assert inside <= 2 * tol + band, (trial, k, inside)
            n_rej += rejected
            n_acc += not rejected
    assert n_acc > 1000 and n_rej > 1000  # both sides well exercised


def test_clearance_and_nearest_match_the_oracle() -> None:
    rng = np.random.default_rng(7)
    frame = Frame.from_bounds(BOUNDS)
    for _trial in range(60):
        obs = random_map(rng, 4)
        r = float(rng.uniform(0, 5))
        oset = obstacle_set(obs, r, frame, walls=False)
        path = rng.uniform(0, SIDE, (5, 2))
        line = LineString(path)
        d_or = min(oracle_distance(line, o) for o in obs)
        got = float(oset.clearance(path[None])[0])
        if d_or > 0:
            assert got == pytest.approx(d_or - r, abs=1e-9 * SIDE)
        else:
            assert got <= -r + 1e-9 * SIDE
        pts = rng.uniform(0, SIDE, (20, 2))
        near, dist = oset.nearest(pts)
        # touching polygons are one solid, reported under its first member
        solid_of = {j: k for k, ms in oset.members.items() for j in ms}
        for j, o in enumerate(obs):
            if solid_of.get(j, j) != j:
                assert np.all(np.isinf(dist[:, j]))
                continue
            g = Point(o.center).buffer(o.radius, 1024) if o.is_circle else shapely.unary_union(
                [obs[m].geometry for m in oset.members.get(j, (j,))])
            want = shapely.distance(shapely.points(pts), g)
            if o.is_circle:
                want = np.maximum(np.hypot(*(pts - o.center).T) - o.radius, 0.0)
            assert np.allclose(dist[:, j], want, atol=1e-9 * SIDE)
            outside = want > 0
            # the nearest point lies on the boundary at the reported distance
            assert np.allclose(np.hypot(*(near[outside, j] - pts[outside]).T),
                               want[outside], atol=1e-9 * SIDE)


def test_touching_is_allowed_and_contact_is_exact() -> None:
    frame = Frame.from_bounds(BOUNDS)
    wall = polygon(shapely.box(40, 20, 60, 80))
    disc = circle(20, 50, 5)
    eps = frame.eps
    for r in (0.0, 1.0):
        oset = obstacle_set([wall, disc], r, frame)
        # along the wall's edge at exactly distance r; tangent to the disc at distance r
        along = np.array([[40 - r, 10.0], [40 - r, 90.0]])
        tangent = np.array([[10.0, 55 + r], [30.0, 55 + r]])
        assert oset.segment_free(along[:1], along[1:])[0]
        assert oset.segment_free(tangent[:1], tangent[1:])[0]
        if r > 0:  # 2 eps closer: a collision
            assert not oset.segment_free(along[:1] + [2 * eps, 0], along[1:] + [2 * eps, 0])[0]
            assert not oset.segment_free(tangent[:1] - [0, 2 * eps],
                                         tangent[1:] - [0, 2 * eps])[0]
    # a point robot through a vertex, grazing it, is free; one cutting the corner is not
    oset = obstacle_set([wall], 0.0, frame)
    assert oset.segment_free([[30.0, 10.0]], [[50.0, 30.0]])[0] is np.False_
    assert oset.segment_free([[30.0, 30.0]], [[50.0, 10.0]])[0]  # touches (40, 20) only


def test_point_robot_along_an_internal_diagonal_collides() -> None:
    """An L-shaped polygon is tiled by pieces; a segment running exactly along an internal
    diagonal of the tiling is inside the polygon (boundary erosion only on true edges)."""
    frame = Frame.from_bounds(BOUNDS)
    L = Polygon([(10, 10), (60, 10), (60, 30), (30, 30), (30, 60), (10, 60)])
    oset = obstacle_set([polygon(L)], 0.0, frame)
    pieces = convex_pieces(orient(L, 1.0), 4)
    diag = [(v[i], v[(i + 1) % len(v)]) for v, fl in pieces for i in range(len(v)) if not fl[i]]
    assert diag, "the L shape has internal diagonals"
    for a, b in diag:
        assert not oset.segment_free([a], [b])[0], (a, b)


def test_convex_pieces_tile_the_polygon_and_flag_the_boundary() -> None:
    rng = np.random.default_rng(3)
    for _k in range(30):
        obs = [o for o in random_map(rng, 3) if not o.is_circle]
        for o in obs:
            pieces = convex_pieces(o.geometry, 4)
            area = sum(Polygon(v).area for v, _ in pieces)
            assert area == pytest.approx(o.geometry.area, rel=1e-9)
            for v, fl in pieces:
                assert 3 <= len(v) <= 4 and Polygon(v).exterior.is_ccw
                mid = 0.5 * (v + np.roll(v, -1, axis=0))
                on = shapely.distance(shapely.points(mid), o.geometry.boundary) <= 1e-9 * SIDE
                assert np.array_equal(on, fl)
            big = convex_decompose(o.geometry)
            assert sum(Polygon(v).area for v in big) == pytest.approx(o.geometry.area,
                                                                       rel=1e-9)


def grid_polygons(rng: np.random.Generator) -> list[Polygon]:
    """Rectilinear polygons from random unions of grid cells, holes included: many collinear
    vertices, walls ending in line with the decomposition's diagonals (occupancy maps)."""
    cells = rng.random((10, 10)) < 0.55
    boxes = [shapely.box(10 * i, 10 * j, 10 * i + 10, 10 * j + 10)
             for i in range(10) for j in range(10) if cells[i, j]]
    u = shapely.unary_union(boxes)
    return [g for g in getattr(u, "geoms", [u]) if g.area > 0]


def test_boundary_flags_cover_the_boundary_exactly_on_grid_polygons() -> None:
    """Every edge of a piece is either boundary or interior: the flagged edges add up to the
    polygon's boundary length (a part edge running on from a wall into the interior is split
    where it leaves the wall)."""
    rng = np.random.default_rng(5)
    n_holes = 0
    for _k in range(25):
        for g in grid_polygons(rng):
            n_holes += len(g.interiors)
            pieces = convex_pieces(g, 4)
            assert sum(Polygon(v).area for v, _ in pieces) == pytest.approx(g.area, rel=1e-9)
            flagged = sum(np.hypot(*(np.roll(v, -1, axis=0) - v)[fl].T).sum()
                          for v, fl in pieces)
            assert flagged == pytest.approx(g.length, rel=1e-9)
            assert all(Polygon(v).area > 0 and 3 <= len(v) <= 4 for v, _ in pieces)
    assert n_holes > 0


def test_nearest_matches_the_oracle_on_grid_polygons() -> None:
    """Distances and nearest boundary points, outside and inside, against shapely."""
    rng = np.random.default_rng(8)
    frame = Frame.from_bounds(BOUNDS)
    for _k in range(10):
        polys = grid_polygons(rng)
        # parts of a grid union may touch at a corner: solids=False keeps one per part
        oset = obstacle_set([polygon(g, f"g{i}") for i, g in enumerate(polys)], 0.0, frame,
                            solids=False)
        pts = rng.uniform(0, SIDE, (300, 2))
        near, dist = oset.nearest(pts)
        for j, g in enumerate(polys):
            to_boundary = shapely.distance(shapely.points(pts), g.boundary)
            want = np.where(shapely.covers(g, shapely.points(pts)), 0.0, to_boundary)
            assert np.allclose(dist[:, j], want, atol=1e-9 * SIDE)
            assert np.allclose(np.hypot(*(near[:, j] - pts).T), to_boundary,
                               atol=1e-9 * SIDE)


def _transform(o: Obstacle, s: float, shift: np.ndarray) -> Obstacle:
    if o.is_circle:
        return circle(*(o.center * s + shift), o.radius * s, o.name)
    g = shapely.affinity.scale(o.geometry, s, s, origin=(0, 0))
    return polygon(shapely.affinity.translate(g, *shift), o.name)


@pytest.mark.parametrize("s, shift", [(1.0, (5e5, 5e6)), (1e-3, (0.0, 0.0)),
                                      (1e3, (0.0, 0.0)), (1e3, (-3e7, 2e8))])
def test_metamorphic_translate_scale_and_far_obstacle(s: float, shift) -> None:
    """Translating, scaling and adding an obstacle far outside the bounds leave every
    collision decision and (scaled) clearance unchanged."""
    rng = np.random.default_rng(11)
    shift = np.asarray(shift, float)
    base = Frame.from_bounds(BOUNDS)
    moved = Frame.from_bounds((shift[0], shift[1], shift[0] + SIDE * s, shift[1] + SIDE * s))
    for trial in range(40):
        obs = random_map(rng, 4)
        r = float(rng.uniform(0, 8)) if trial % 3 else 0.0
        paths = rng.uniform(0, SIDE, (8, 4, 2))
        a = obstacle_set(obs, r, base)
        far = [circle(1e11, 1e11, 1.0, "far")]
        b = obstacle_set([_transform(o, s, shift) for o in obs] + far, r * s, moved)
        ca, cb = a.crossings(paths), b.crossings(paths * s + shift)
        assert np.array_equal(ca.count, cb.count)
        assert np.allclose(cb.penetration, ca.penetration * s, rtol=1e-7, atol=1e-9 * SIDE * s)
        ka, kb = a.clearance(paths), b.clearance(paths * s + shift)
        assert np.allclose(kb, ka * s, rtol=1e-7, atol=1e-8 * SIDE * s)


def test_far_obstacle_does_not_switch_collision_checking_off() -> None:
    """A unit circle at (1e11, 1e11) beside a 100 x 100 map: a line through a 20-wide wall
    still collides (it used to be accepted)."""
    frame = Frame.from_bounds(BOUNDS)
    wall = polygon(shapely.box(40, 0, 60, 100))
    oset = obstacle_set([wall, circle(1e11, 1e11, 1.0)], 0.5, frame)
    assert oset.crossings(np.array([[10.0, 50.0], [90.0, 50.0]])).count[0] == 1
    # a wall reaching far below the map is clipped, not a precision problem
    tall = polygon(shapely.box(40, -1e10, 60, 40))
    oset = obstacle_set([tall], 0.5, frame)
    assert oset.segment_free([[10.0, 60.0]], [[90.0, 60.0]])[0]
    assert not oset.segment_free([[10.0, 20.0]], [[90.0, 20.0]])[0]


def test_utm_coordinates_keep_walls_exact() -> None:
    """At UTM-like coordinates a 10-unit wall is exact: a path through it collides."""
    y0 = 5_000_000.0
    frame = Frame.from_bounds((300_000.0, y0, 300_300.0, y0 + 300.0))
    wall = polygon(shapely.box(300_100.0, y0 + 100.0, 300_110.0, y0 + 200.0))
    oset = obstacle_set([wall], 0.5, frame)
    a, b = np.array([[300_050.0, y0 + 150.0]]), np.array([[300_150.0, y0 + 150.0]])
    assert not oset.segment_free(a, b)[0]
    assert oset.segment_free(a + [0, 60.0], b + [0, 60.0])[0]
    assert float(oset.clearance(np.vstack([a, b])[None] + [0, 60.0])[0]) == pytest.approx(
        10.0 - 0.5, abs=1e-6)


def test_precision_limits_are_rejected_with_a_clear_error() -> None:
    with pytest.raises(ValueError, match="size"):
        Frame.from_bounds((0.0, 0.0, 1e155, 1e155))
    with pytest.raises(ValueError, match="double precision"):
        Frame.from_bounds((1e15, 1e15, 1e15 + 100.0, 1e15 + 100.0))
    frame = Frame.from_bounds(BOUNDS)
    spike = polygon(Polygon([(10, 10), (1e15, 50), (10, 90)]), "spike")
    with pytest.raises(ValueError, match="spike"):
        obstacle_set([spike], 0.5, frame)


def test_lengths_and_degenerate_input() -> None:
    p = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 4.0], [6.0, 8.0]])
    assert path_lengths(p) == pytest.approx(10.0)
    assert np.allclose(path_lengths(np.stack([p, 2 * p])), [10.0, 20.0])
    frame = Frame.from_bounds(BOUNDS)
    oset = obstacle_set([circle(50, 50, 10)], 1.0, frame)
    # a zero-length segment is a point
    assert oset.crossings(np.array([[50.0, 39.5], [50.0, 39.5]])).count[0] == 1
    assert oset.crossings(np.array([[50.0, 38.5], [50.0, 38.5]])).count[0] == 0
    with pytest.raises(ValueError, match="shape"):
        oset.crossings(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="radius"):
        obstacle_set([], -1.0, frame)


def test_pieces_of_many_polygons_at_once_are_each_ones_pieces() -> None:
    """convex_pieces_many (the polygons of a batch triangulated in one call) gives what
    convex_pieces gives polygon by polygon: neighbours touching each other (touching grid
    polygons) or a far tiny one change nothing."""
    from optplan.geometry.collision.pieces import convex_pieces_many

    rng = np.random.default_rng(7)
    geoms = [g for _ in range(6) for g in grid_polygons(rng)]
    geoms += [shapely.MultiPolygon(grid_polygons(rng)[:2]), shapely.box(0, 0, 1e-3, 1e-3),
              Polygon([(10, 10), (60, 10), (60, 30), (30, 30), (30, 60), (10, 60)])]
    many = convex_pieces_many(geoms, 4)
    assert len(many) == len(geoms)
    for g, got in zip(geoms, many):
        one = convex_pieces(g, 4)
        assert len(got) == len(one)
        for (v, fl), (w, gl) in zip(got, one):
            assert np.array_equal(v, w) and np.array_equal(fl, gl)
