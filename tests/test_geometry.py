"""Geometry kernel: the vectorised crossing test against shapely, and the inflation bracket."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Point, Polygon

from optplan.geometry import (
    batch_crossings,
    circumscribed_radius,
    inflate,
    path_lengths,
    point_clearance,
)
from optplan.problem import CIRCLE_QUAD_SEGS, Obstacle

# ------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------


def rect(x0: float, y0: float, x1: float, y1: float, name: str = "") -> Obstacle:
    return Obstacle("rectangle", shapely.box(x0, y0, x1, y1), name=name)


def poly(verts, name: str = "") -> Obstacle:
    return Obstacle("polygon", Polygon(verts), name=name)


def circle(cx: float, cy: float, r: float, name: str = "") -> Obstacle:
    c = np.array([cx, cy], dtype=float)
    return Obstacle("circle", Point(c).buffer(r, quad_segs=CIRCLE_QUAD_SEGS), name=name,
                    center=c, radius=float(r))


def shapely_inside_lengths(a, b, imap) -> np.ndarray:
    """Length of segment ab inside the *interior* of every part, decided by shapely.

    The segment is cut at every point where it meets the part's boundary; each piece is inside
    when its midpoint is in the part and not on its boundary (a piece running along an edge is
    on the boundary).  Robust where "intersection minus boundary overlap" is not: after a union,
    vertices created at edge crossings lie only within round-off of the edges they came from.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    out = np.zeros(imap.n)
    d = b - a
    length = float(np.hypot(*d))
    if length == 0.0:
        return out
    seg = LineString([a, b])
    scale = max(1.0, float(np.abs(imap.bbox).max()))
    for k, part in enumerate(imap.parts):
        # cut points: where shapely sees the boundary meet the segment, plus boundary vertices
        # within round-off of it (shapely decides those exactly, i.e. by the rounding error)
        verts = shapely.get_coordinates(part.boundary)
        near = verts[shapely.distance(seg, shapely.points(verts)) <= 1e-9 * scale]
        coords = np.vstack([shapely.get_coordinates(seg.intersection(part.boundary)), near])
        ts = np.clip(((coords - a) @ d) / length**2, 0.0, 1.0) if len(coords) else np.zeros(0)
        ts = np.unique(np.r_[0.0, ts, 1.0])
        mids = a + np.outer((ts[:-1] + ts[1:]) / 2, d)
        pts = shapely.points(mids)
        inside = shapely.contains(part, pts) & (shapely.distance(part.boundary, pts) > 1e-9 * scale)
        out[k] = float(np.sum(np.diff(ts)[inside])) * length
    return out


# integer coordinates make touching, grazing and collinear cases common, which is the point
coord = st.integers(-2, 22)
pt = st.tuples(coord, coord)


@st.composite
def obstacle(draw) -> Obstacle:
    kind = draw(st.sampled_from(["rect", "tri", "quad", "circle"]))
    if kind == "rect":
        x0, y0 = draw(st.integers(0, 17)), draw(st.integers(0, 17))
        w, h = draw(st.integers(1, 6)), draw(st.integers(1, 6))
        return rect(x0, y0, x0 + w, y0 + h)
    if kind == "circle":
        return circle(draw(st.integers(2, 18)), draw(st.integers(2, 18)), draw(st.integers(1, 4)))
    n = 3 if kind == "tri" else 4
    verts = draw(st.lists(st.tuples(st.integers(0, 20), st.integers(0, 20)), min_size=n,
                          max_size=n, unique=True))
    p = Polygon(verts)
    if not p.is_valid or p.area < 0.5:
        # a simple fallback keeps the strategy total (no filtering / health-check failures)
        x, y = verts[0]
        return poly([(x, y), (x + 3, y), (x, y + 2)])
    return Obstacle("polygon", p)


maps = st.lists(obstacle(), min_size=1, max_size=5)

radii = st.sampled_from([0.0, 0.0, 0.5, 1.0, 1.7])
paths = st.lists(pt, min_size=2, max_size=6)


# ------------------------------------------------------------------------------------
# batch_crossings agrees with shapely
# ------------------------------------------------------------------------------------


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(obstacles=maps, radius=radii, data=st.data())
def test_batch_crossings_agree_with_shapely(obstacles, radius, data) -> None:
    imap = inflate(obstacles, radius)
    # path points: grid points and obstacle vertices (so segments run along edges, through
    # corners and across diagonals, the cases where a crossing test goes wrong)
    verts = [tuple(v) for part in imap.parts for v in np.asarray(part.exterior.coords)[:-1]]
    point = st.one_of(pt, st.sampled_from(verts)) if verts else pt
    batch = data.draw(st.lists(st.lists(point, min_size=2, max_size=6), min_size=1, max_size=4))
    m = max(len(p) for p in batch)
    # pad shorter paths by repeating their last point (zero-length segments: no crossings)
    arr = np.array([list(p) + [p[-1]] * (m - len(p)) for p in batch], dtype=float)
    res = batch_crossings(arr, imap)
    scale = max(1.0, float(np.abs(imap.bbox).max())) if imap.n else 1.0
    hi, lo = 1e-6 * scale, 1e-12 * scale
    assert res.count.shape == (len(batch),) and res.seg_count.shape == (len(batch), m - 1)
    for i in range(len(batch)):
        total = 0.0
        for s in range(m - 1):
            inside = shapely_inside_lengths(arr[i, s], arr[i, s + 1], imap)
            total += inside[inside > lo].sum()
            sure = int(np.sum(inside > hi))
            maybe = int(np.sum(inside > lo))
            assert sure <= res.seg_count[i, s] <= maybe, (arr[i, s], arr[i, s + 1], inside)
        assert res.penetration[i] == pytest.approx(total, abs=1e-6 * scale * m)
        assert res.count[i] == res.seg_count[i].sum()


@settings(max_examples=60, deadline=None)
@given(obstacles=maps, radius=radii, path=paths)
def test_two_dim_input_and_lengths(obstacles, radius, path) -> None:
    imap = inflate(obstacles, radius)
    arr = np.array(path, dtype=float)
    one = batch_crossings(arr, imap)
    many = batch_crossings(arr[None], imap)
    np.testing.assert_array_equal(one.count, many.count)
    assert path_lengths(arr) == pytest.approx(LineString(arr).length if len(
        set(map(tuple, path))) > 1 else 0.0)


def test_touching_is_not_a_collision() -> None:
    imap = inflate([rect(0, 0, 10, 10)], 0.0)
    cases = {
        "through a corner": [(-5, 5), (5, -5)],
        "along an edge": [(-3, 0), (13, 0)],
        "along an edge, partly": [(2, 10), (8, 10)],
        "ends on the boundary": [(-5, 5), (0, 5)],
        "starts on a corner, leaves": [(10, 10), (20, 15)],
        "corner to corner outside": [(10, 0), (20, -10)],
        "degenerate": [(3, 3), (3, 3)],
    }
    for why, seg in cases.items():
        arr = np.array(seg, dtype=float)
        if why == "degenerate":
            res = batch_crossings(arr, imap)
            assert res.count[0] == 0, why
            continue
        res = batch_crossings(arr, imap)
        assert res.count[0] == 0 and res.penetration[0] == 0.0, why


def test_crossings_counted_per_obstacle_with_penetration() -> None:
    imap = inflate([rect(0, 0, 10, 10), rect(20, 0, 30, 10), circle(50, 5, 3)], 0.0)
    res = batch_crossings(np.array([[-5.0, 5.0], [60.0, 5.0]]), imap)
    assert res.count[0] == 3
    chord = imap.parts[2].intersection(LineString([(40, 5), (60, 5)])).length
    assert res.penetration[0] == pytest.approx(10 + 10 + chord, rel=1e-12)
    # first segment ends inside the square, second leaves it, third runs free
    res2 = batch_crossings(np.array([[[-5.0, 5.0], [5.0, 5.0], [15.0, 5.0], [15.0, 20.0]]]),
                           imap)
    assert res2.seg_count.tolist() == [[1, 1, 0]]
    assert res2.penetration[0] == pytest.approx(10.0)


def test_union_vertices_within_roundoff_of_the_line() -> None:
    tri = poly([(0, 0), (0, 5), (3, 0)])
    # a square poking out of the triangle's hypotenuse: the chord between the two crossing
    # points of the union runs through the interior (square above, triangle below) ...
    chord = batch_crossings(np.array([[2.0, 5.0 / 3.0], [1.8, 2.0]]),
                            inflate([rect(0, 0, 2, 2), tri], 0.0))
    assert chord.count[0] == 1
    assert chord.penetration[0] == pytest.approx(math.hypot(0.2, 1.0 / 3.0))
    # ... and a segment along the whole hypotenuse is inside only where the square covers it
    along = batch_crossings(np.array([[0.0, 5.0], [3.0, 0.0]]),
                            inflate([rect(1, 2, 2, 4), tri], 0.0))
    assert along.penetration[0] == pytest.approx(math.hypot(0.8, 4.0 / 3.0))


def test_non_convex_and_holes() -> None:
    # a square ring (union of four walls) has a hole: crossing the hole is free
    walls = [rect(0, 0, 10, 1), rect(0, 9, 10, 10), rect(0, 0, 1, 10), rect(9, 0, 10, 10)]
    imap = inflate(walls, 0.0)
    assert imap.n == 1 and len(imap.parts[0].interiors) == 1
    across = batch_crossings(np.array([[-1.0, 5.0], [11.0, 5.0]]), imap)
    assert across.count[0] == 1  # one (segment, part) pair ...
    assert across.penetration[0] == pytest.approx(2.0)  # ... through two walls
    inside = batch_crossings(np.array([[2.0, 2.0], [8.0, 8.0]]), imap)
    assert inside.count[0] == 0
    u = inflate([poly([(0, 0), (10, 0), (10, 10), (7, 10), (7, 3), (3, 3), (3, 10), (0, 10)])],
                0.0)
    mouth = batch_crossings(np.array([[5.0, 12.0], [5.0, 3.0]]), u)  # into the U, to its floor
    assert mouth.count[0] == 0
    floor = batch_crossings(np.array([[5.0, 12.0], [5.0, 2.0]]), u)
    assert floor.count[0] == 1 and floor.penetration[0] == pytest.approx(1.0)


def test_large_coordinates() -> None:
    off = 1e6
    imap = inflate([rect(off, off, off + 10, off + 10)], 1.0)
    hit = batch_crossings(np.array([[off - 5, off + 5], [off + 15, off + 5]]), imap)
    graze = batch_crossings(np.array([[off - 5, off - 1], [off + 15, off - 1]]), imap)
    assert hit.count[0] == 1 and hit.penetration[0] == pytest.approx(12.0, rel=1e-9)
    assert graze.count[0] == 0


# ------------------------------------------------------------------------------------
# inflation bracket
# ------------------------------------------------------------------------------------


def _exact_sum(obstacles, radius):
    """The exact Minkowski sum, approximated from inside by a very fine buffer."""
    fine = []
    for o in obstacles:
        if o.is_circle:
            fine.append(Point(o.center).buffer(o.radius + radius, quad_segs=256))
        else:
            fine.append(o.geometry.buffer(radius, quad_segs=256))
    return shapely.unary_union(fine)


@settings(max_examples=40, deadline=None)
@given(obstacles=maps, radius=st.floats(0.1, 3.0))
def test_circumscribed_covers_exact_disc(obstacles, radius) -> None:
    cir = inflate(obstacles, radius, mode="circumscribed")
    exact = _exact_sum(obstacles, radius)
    assert cir.union.buffer(1e-9 * max(1.0, exact.length)).covers(exact)


def test_circumscribed_covers_at_awkward_corner() -> None:
    # a corner turning by 1.49 nominal arc steps: GEOS uses one fillet segment there
    th = 1.49 * math.pi / 16
    p = poly([(0, 0), (10, 0), (10 + 10 * math.cos(th), 10 * math.sin(th)), (0, 10)])
    cir = inflate([p], 1.0, mode="circumscribed")
    ring = cir.parts[0].exterior
    pts = shapely.points([ring.interpolate(t, normalized=True).coords[0]
                          for t in np.linspace(0, 1, 4001)])
    gap = 1.0 - float(shapely.distance(pts, p.geometry).min())
    assert gap <= 1e-9


@settings(max_examples=40, deadline=None)
@given(obstacles=maps, radius=st.floats(0.1, 3.0))
def test_inflation_bracket(obstacles, radius) -> None:
    ins = inflate(obstacles, radius, mode="inscribed")
    cir = inflate(obstacles, radius, mode="circumscribed")
    assert ins.mode == "inscribed" and cir.mode == "circumscribed"
    assert ins.union.area < cir.union.area
    exact = _exact_sum(obstacles, radius)
    # circumscribed: covers the exact sum (up to round-off)
    slack = 1e-9 * max(1.0, exact.length)
    assert cir.union.buffer(slack).covers(exact)
    # the inscribed polygon lies inside the exact sum: its vertices are within r of the obstacle
    verts = np.concatenate([np.asarray(p.exterior.coords) for p in ins.parts])
    raw = point_clearance(verts, obstacles)
    assert np.all(raw <= radius * (1 + 1e-9))
    assert ins.union.area <= exact.area * (1 + 1e-9) + 1e-9


def test_circumscribed_radius_formula() -> None:
    r, q = 2.0, 8
    R = circumscribed_radius(r, q)
    # at least the radius whose regular polygon (q segments per quarter) has inradius r ...
    assert R * math.cos(math.pi / (4 * q)) >= r * (1 - 1e-12)
    disc = Point(0, 0).buffer(R, quad_segs=q)
    assert disc.exterior.distance(Point(0, 0)) >= r * (1 - 1e-9)
    # ... and not looser than needed for GEOS's widest fillet step (1.5 nominal steps)
    assert R <= r / math.cos(3 * math.pi / (8 * q)) * (1 + 1e-12)


def test_inflate_merges_overlaps_and_names_parts() -> None:
    imap = inflate([rect(0, 0, 10, 10, "a"), rect(11, 0, 20, 10, "b"), rect(50, 50, 60, 60, "c")],
                   1.0)
    assert imap.n == 2
    assert sorted(imap.names) == [("a", "b"), ("c",)]
    assert imap.edges.shape[0] == 2 and imap.edge_mask.shape == imap.edges.shape[:2]
    assert imap.containing(np.array([10.5, 5.0])) == "a+b"
    assert imap.containing(np.array([30.0, 30.0])) is None
    empty = inflate([], 1.0)
    assert empty.n == 0
    assert batch_crossings(np.array([[0.0, 0.0], [1.0, 1.0]]), empty).count[0] == 0


def test_inflate_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="mode"):
        inflate([rect(0, 0, 1, 1)], 1.0, mode="outer")
    with pytest.raises(ValueError, match="radius"):
        inflate([rect(0, 0, 1, 1)], -1.0)


def test_point_clearance() -> None:
    obs = [rect(0, 0, 10, 10), circle(30, 5, 2)]
    d = point_clearance(np.array([[5.0, 5.0], [15.0, 5.0], [30.0, 10.0], [-3.0, -4.0]]), obs)
    np.testing.assert_allclose(d, [0.0, 5.0, 3.0, 5.0])
    assert np.isinf(point_clearance(np.array([[0.0, 0.0]]), [])).all()
