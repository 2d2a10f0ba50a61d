"""The convex pieces and their boundary flags against an independent oracle (shapely).

:func:`~optplan.geometry.collision.pieces.convex_pieces` flags an edge as boundary when no
triangle of the triangulation has its twin (no distances).  The oracle checks, with shapely
only: the pieces tile the polygon (their areas add up to its area, their union is it), each is
convex and counter-clockwise with 3 to ``max_edges`` vertices, each flagged edge's midpoint
lies on the boundary, each unflagged one's in the interior (away from the boundary), and the
flagged edges add up to the boundary's length (every boundary point is covered once).  The
inputs: random unions of boxes and triangles, grid unions (holes, pinch points, long collinear
walls), the solids of random maps, and adversarial polygons (holes touching the shell at a
vertex and inside an edge, pinch points, collinear and near-collinear vertices), plus
triangulations with zero-area triangles injected in place of GEOS's.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import shapely
from shapely.geometry import MultiPolygon, Polygon

from optplan.generators import random_obstacles
from optplan.geometry import Frame
from optplan.geometry.collision import pieces as pieces_mod
from optplan.geometry.collision.obstacles import PIECE_EDGES, _solids
from optplan.geometry.collision.pieces import convex_pieces, convex_pieces_many


def violations(g, pieces, max_edges: int = 4) -> list[str]:
    """What is wrong with ``pieces`` (``(vertices, flags)``) of the polygon ``g``: empty when
    the oracle accepts them."""
    out = []
    x0, y0, x1, y1 = g.bounds
    tol = 1e-9 * max(x1 - x0, y1 - y0)
    boundary = g.boundary
    area = flagged = 0.0
    shapes = []
    for n, (v, fl) in enumerate(pieces):
        if not (3 <= len(v) <= max_edges and len(fl) == len(v)):
            out.append(f"piece {n}: {len(v)} vertices, {len(fl)} flags")
            continue
        w = np.roll(v, -1, axis=0)
        e = w - v
        a = np.roll(e, 1, axis=0)
        cr = a[:, 0] * e[:, 1] - a[:, 1] * e[:, 0]
        if np.any(cr < -1e-12 * np.hypot(*a.T) * np.hypot(*e.T)):
            out.append(f"piece {n}: not convex")
        p = Polygon(v)
        if not (p.area > 0 and p.exterior.is_ccw):
            out.append(f"piece {n}: not counter-clockwise with area")
        shapes.append(p)
        area += p.area
        mid = shapely.points(0.5 * (v + w))
        d = shapely.distance(mid, boundary)
        if np.any(d[fl] > tol):
            out.append(f"piece {n}: a flagged edge off the boundary")
        if np.any(d[~fl] <= 0) or not np.all(shapely.covers(g, mid[~fl])):
            out.append(f"piece {n}: an unflagged edge not interior")
        flagged += float(np.hypot(*e[fl].T).sum())
    if abs(area - g.area) > 1e-12 * g.area:
        out.append(f"areas add up to {area!r}, not {g.area!r}")
    union = shapely.unary_union(shapes) if shapes else Polygon()
    if shapely.symmetric_difference(union, g).area > 1e-12 * g.area:
        out.append("the union of the pieces is not the polygon")
    if abs(flagged - boundary.length) > 1e-12 * boundary.length:
        out.append(f"flagged edges add up to {flagged!r}, the boundary to {boundary.length!r}")
    return out


def random_unions(rng: np.random.Generator, k: int = 8, side: int = 40) -> list[Polygon]:
    """The parts of a union of ``k`` boxes and triangles with integer coordinates."""
    geoms = []
    for _ in range(k):
        x, y = rng.integers(0, side, 2)
        if rng.random() < 0.5:
            w, h = rng.integers(1, 12, 2)
            geoms.append(shapely.box(x, y, x + w, y + h))
        else:
            t = Polygon(rng.integers(-8, 9, (3, 2)) + [x, y])
            if t.area > 0:
                geoms.append(t)
    u = shapely.unary_union(geoms)
    return [g for g in getattr(u, "geoms", [u]) if g.area > 0]


def grid_union(rng: np.random.Generator, n: int = 10) -> list[Polygon]:
    """The parts of a union of random cells of an ``n x n`` grid (holes, pinch points)."""
    cells = rng.random((n, n)) < 0.55
    u = shapely.unary_union([shapely.box(10 * i, 10 * j, 10 * i + 10, 10 * j + 10)
                             for i in range(n) for j in range(n) if cells[i, j]])
    return [g for g in getattr(u, "geoms", [u]) if g.area > 0]


def map_solids(n: int, seed: int) -> list:
    """The polygon solids of a random map, as the obstacle set builds them (the bounds wall
    included)."""
    obs = random_obstacles(n, seed=seed, keep_free=((10, 10), (490, 490)))
    frame = Frame.from_bounds((0.0, 0.0, 500.0, 500.0))
    shapes, _, _ = _solids(obs, frame, 1.0 + frame.length, True, True)
    return [g for _, g in shapes if not isinstance(g, tuple)]


SQUARE = [(0, 0), (4, 0), (4, 4), (0, 4)]
BIG = [(0, 0), (10, 0), (10, 10), (0, 10)]


def adversarial() -> list[Polygon]:
    """Holes touching the shell, pinch points, collinear and near-collinear vertices."""
    e = 1e-13  # relative to the polygons' size (about 10)
    star = np.linspace(0, 2 * np.pi, 17)[:-1]
    rad = np.where(np.arange(16) % 2, 3.0, 7.0)
    return [
        Polygon(SQUARE, [[(2, 0), (3, 1), (1, 1)]]),  # a hole vertex inside a shell edge
        Polygon(SQUARE, [[(0, 0), (2, 1), (1, 2)]]),  # ... at a shell vertex
        Polygon(BIG, [[(5, 0), (7, 2), (3, 2)], [(10, 10), (8, 6), (6, 8)]]),  # two holes
        Polygon(BIG, [[(2, 2), (5, 5), (2, 5)], [(5, 5), (8, 8), (8, 5)]]),  # holes pinched
        Polygon(BIG, [[(1, 1), (3, 1), (3, 3), (1, 3)], [(3, 3), (5, 3), (5, 5), (3, 5)],
                      [(5, 5), (7, 5), (7, 7), (5, 7)]]),  # a chain of pinched holes
        # collinear vertices on the shell and on a hole
        Polygon([(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (2, 2), (2, 1), (1, 1), (1, 2),
                 (0, 2), (0, 1)]),
        Polygon([(0, 0), (2, 0), (4, 0), (6, 0), (6, 6), (0, 6)],
                [[(1, 1), (2, 1), (3, 1), (3, 2), (3, 3), (2, 3), (1, 3), (1, 2)]]),
        # T-junctions: walls ending in line with each other
        Polygon([(0, 0), (6, 0), (6, 1), (4, 1), (4, 3), (6, 3), (6, 4), (0, 4), (0, 3), (2, 3),
                 (2, 1), (0, 1)]),
        Polygon([(10, 10), (60, 10), (60, 30), (30, 30), (30, 60), (10, 60)]),
        Polygon(np.c_[rad * np.cos(star), rad * np.sin(star)]),
        # the bounds wall: a frame around a hole
        Polygon([(-10, -10), (110, -10), (110, 110), (-10, 110)],
                [[(0, 0), (0, 100), (100, 100), (100, 0)]]),
        # near-collinear vertices (1e-13 relative), reflex and convex, on the shell and a hole
        Polygon([(0, 0), (5, 10 * e), (10, 0), (10, 10), (5, 3), (0, 10)]),
        Polygon([(0, 0), (5, -10 * e), (10, 0), (10, 10), (0, 10)]),
        Polygon([(0, 0), (3, 0), (6, 10 * e), (9, 0), (9, 9), (0, 9)],
                [[(2, 2), (4, 2), (6, 2 + 10 * e), (6, 5), (2, 5)]]),
        # a hole 1e-13 (relative) from the shell, and a wall 1e-13 out of line
        Polygon(BIG, [[(5, 10 * e), (7, 2), (3, 2)]]),
        Polygon([(0, 0), (6, 0), (6, 1), (4, 1 + 10 * e), (4, 3), (6, 3), (6, 4), (0, 4), (0, 3),
                 (2, 3), (2, 1), (0, 1 - 10 * e)]),
    ]


def check_all(polys: list, max_edges: int = 4) -> int:
    """Run the oracle on ``convex_pieces_many`` of ``polys``; the polygons checked."""
    for g, got in zip(polys, convex_pieces_many(polys, max_edges)):
        assert g.is_valid
        bad = violations(g, got, max_edges)
        assert not bad, (g.wkt, bad[:3])
    return len(polys)


@pytest.mark.parametrize("max_edges", [3, 4, 5])
def test_adversarial_polygons_pass_the_oracle(max_edges: int) -> None:
    polys = adversarial()
    assert check_all(polys, max_edges) == len(polys)
    # the pieces of one polygon do not depend on its neighbours in the batch
    for g in polys:
        assert not violations(g, convex_pieces(g, max_edges), max_edges)


def test_random_unions_pass_the_oracle() -> None:
    rng = np.random.default_rng(12)
    n = sum(check_all(random_unions(rng)) for _ in range(60))
    assert n > 200


def test_grid_unions_with_holes_and_pinch_points_pass_the_oracle() -> None:
    rng = np.random.default_rng(13)
    polys = [g for _ in range(25) for g in grid_union(rng)]
    assert sum(len(g.interiors) for g in polys) > 10
    check_all(polys)
    check_all(polys[:40], 3)


def test_map_solids_pass_the_oracle() -> None:
    """The solids of random maps (merged touching obstacles, the bounds wall), and one
    MultiPolygon of several of them."""
    for n, seed in ((10, 0), (10, 1), (30, 2), (100, 3)):
        polys = map_solids(n, seed)
        check_all([p for g in polys for p in getattr(g, "geoms", [g])], PIECE_EDGES)
    parts = [p for g in map_solids(30, 4) for p in getattr(g, "geoms", [g])]
    multi = MultiPolygon(parts[:6])
    assert multi.is_valid
    assert not violations(multi, convex_pieces(multi))


@pytest.mark.parametrize("max_edges", [3, 4, 5])
def test_convex_polygons_of_many_vertices_are_peeled_round_the_rim(max_edges: int) -> None:
    """A convex ring of more than ``RIM_FROM`` vertices (a disc drawn as a polygon; random
    convex hulls; a non-convex polygon whose triangulation merges into a large convex part)
    passes the oracle, and its pieces are local: most lie within a few edge lengths of the
    boundary, not across the polygon as a fan from one vertex would."""
    rng = np.random.default_rng(21)
    n_rim = pieces_mod.RIM_FROM
    discs = [Polygon([(50 + 6 * np.cos(t), 30 + 6 * np.sin(t))
                      for t in 2 * np.pi * np.arange(n) / n]) for n in (n_rim + 1, 200, 2000)]
    hulls = []  # random points of random ellipses: every point a hull vertex
    for _ in range(5):
        t = rng.uniform(0, 2 * np.pi, 300)
        a, b = rng.uniform(1, 20, 2)
        hulls.append(shapely.convex_hull(shapely.multipoints(np.c_[a * np.cos(t),
                                                                  b * np.sin(t)])))
    bite = [shapely.difference(discs[1], shapely.box(50, 30, 60, 40))]
    polys = discs + hulls + bite
    assert all(len(g.exterior.coords) - 1 > n_rim for g in discs + hulls)
    for g in discs[1:]:  # (first: the oracle's union of a fan's thin pieces is costly)
        got = convex_pieces(g, max_edges)
        size = np.array([np.ptp(v, axis=0).max() for v, _ in got])
        assert np.median(size) < 0.1 * 12  # a fan's pieces span about the diameter (12)
        assert np.sum(size > 3) <= n_rim  # only the inner ring's fan is large
    check_all(polys, max_edges)


def test_the_oracle_notices_a_wrong_flag_or_a_missing_piece() -> None:
    """Mutation check: every single flipped flag, and every dropped piece, is caught."""
    rng = np.random.default_rng(14)
    polys = adversarial()[:8] + random_unions(rng)[:4]
    flips = 0
    for g in polys:
        got = convex_pieces(g)
        assert not violations(g, got)
        for n, (v, _) in enumerate(got):
            for i in range(len(v)):
                bad = [(w, f.copy()) for w, f in got]
                bad[n][1][i] = ~bad[n][1][i]
                assert violations(g, bad), (g.wkt, n, i)
                flips += 1
        if len(got) > 1:
            assert violations(g, got[1:])
    assert flips > 100


def fake_triangulation(monkeypatch, triangles: list) -> None:
    """Make ``shapely.constrained_delaunay_triangles`` (as the pieces module calls it) return
    ``triangles`` (vertex lists, any orientation, zero-area ones allowed)."""
    tris = shapely.GeometryCollection([Polygon(t) for t in triangles])

    def fake(g):
        return tris if np.ndim(g) == 0 else np.array([tris] * len(g), dtype=object)

    monkeypatch.setattr(pieces_mod.shapely, "constrained_delaunay_triangles", fake)


def halves(*polys: Polygon) -> list:
    """GEOS's triangles of polygons that meet along segments, as vertex lists."""
    return [list(t.exterior.coords)[:3] for h in polys
            for t in shapely.get_parts(shapely.constrained_delaunay_triangles(h))]


U_TOP = [(4, 2), (3, 2), (3, 1), (1, 1), (1, 2), (0, 2)]  # the top of a U over x in [0, 4]
LOW = [(0, -1), (4, -1), (4, 0), (0, 0)]  # a box under it

FLAT_CASES = {
    # the flat triangle's long edge is interior (the box's top), its short edges the U's
    # bottom split at a point the box's triangles do not have
    "long edge interior": (
        Polygon(LOW[:3] + U_TOP + LOW[3:]),
        halves(Polygon([(0, 0), (2, 0), (4, 0), *U_TOP]), Polygon(LOW))
        + [[(0, 0), (2, 0), (4, 0)]]),
    # the flat triangle's long edge is the boundary, its short edges are interior
    "long edge on the boundary": (
        Polygon([(0, 0), (2, 0), (4, 0), *U_TOP]),
        halves(Polygon([(0, 0), (2, 0), (4, 0), *U_TOP])) + [[(4, 0), (2, 0), (0, 0)]]),
    # two flat triangles, one's short edge the other's long edge
    "chain": (
        Polygon(LOW[:3] + U_TOP + LOW[3:]),
        halves(Polygon([(0, 0), (1, 0), (2, 0), (4, 0), *U_TOP]), Polygon(LOW))
        + [[(0, 0), (2, 0), (4, 0)], [(2, 0), (1, 0), (0, 0)]]),
    # two flat triangles on one long edge, between halves cut at different points (the
    # vertices of two holes)
    "lens": (
        Polygon([(0, -2), (4, -2), (4, 0), (4, 2), (0, 2), (0, 0)],
                [[(1, 0), (2, 1), (0.5, 1)], [(3, 0), (3.5, -1), (2, -1)]]),
        halves(Polygon([(0, 0), (4, 0), (4, 2), (0, 2)], [[(1, 0), (2, 1), (0.5, 1)]]),
               Polygon([(0, -2), (4, -2), (4, 0), (0, 0)], [[(3, 0), (3.5, -1), (2, -1)]]))
        + [[(0, 0), (1, 0), (4, 0)], [(4, 0), (3, 0), (0, 0)]]),
}


@pytest.mark.parametrize("case", sorted(FLAT_CASES))
@pytest.mark.parametrize("max_edges", [3, 4])
def test_zero_area_triangles_are_refined_away(monkeypatch, case: str, max_edges: int) -> None:
    """Triangulations with zero-area triangles (GEOS gives none): the pieces still pass the
    oracle, without a piece of zero area."""
    g, triangles = FLAT_CASES[case]
    assert g.is_valid and not g.convex_hull.equals(g)  # not one convex piece: triangulated
    fake_triangulation(monkeypatch, triangles)
    got = convex_pieces(g, max_edges)
    assert not violations(g, got, max_edges), violations(g, got, max_edges)
    # without the refinement the flags are wrong where a flat triangle glues two sides
    if case != "long edge on the boundary":
        monkeypatch.setattr(pieces_mod, "_refine", lambda rings, flats: None)
        assert violations(g, convex_pieces(g, max_edges), max_edges)


def test_orientation_is_the_exact_sign() -> None:
    """:func:`_orientation` against rational arithmetic on near-collinear and collinear
    triples (the floating-point determinant alone gets some of these wrong)."""
    rng = np.random.default_rng(15)
    a = rng.uniform(-1e3, 1e3, (4000, 2))
    d = rng.uniform(-1, 1, (4000, 2))
    t = rng.uniform(-2, 2, (4000, 2))
    b, c = a + t[:, :1] * d, a + t[:, 1:] * d  # collinear up to the rounding of b and c
    c[::3] += rng.choice([-1, 1], (len(c[::3]), 2)) * 1e-13 * np.abs(c[::3])
    c[1::7] = b[1::7]  # a repeated vertex
    xy = np.stack([a, b, c], axis=1)
    got = pieces_mod._orientation(xy.copy())
    want = []
    for (ax, ay), (bx, by), (cx, cy) in ((tuple(map(Fraction, p)) for p in tri)
                                         for tri in xy.tolist()):
        e = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
        want.append((e > 0) - (e < 0))
    assert np.array_equal(got, want)
    assert np.sum(np.array(want) == 0) > 500
    det = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1]) - (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    assert np.any(np.sign(det) != want)  # the float determinant alone would be wrong
