"""Candidate sight lines (``optplan.geometry.tangent.sightlines``) never lose a free tangent.

The triangular expansion lists, per source, a superset of the circles it sees; the tangent
graph keeps only the tangents to those.  Oracle: the same tangents computed towards *every*
circle and tested with the exact segment predicate (``ObstacleSet.segment_free``): the free
ones must be the same sets, edge for edge, on grid maps (touching cells, pinch points, long
walls of many pieces, staircases), maps with circle obstacles, for a point and a disc robot.
From points: every centre a free straight segment reaches is a candidate; a point sees through
a pinch and along a wall.  The triangles' free/solid labels agree with shapely.  Metamorphic:
translating and scaling the map changes no candidate set.  ``TangentGraph.build`` stores
exactly the free tangents and answers queries like the lazy graph.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry.polygon import orient

from optplan.geometry import Frame, obstacle_set
from optplan.geometry.tangent.sightlines import Sightlines
from optplan.geometry.tangent.tangent_edges import edges_of_one
from optplan.geometry.tangent.tangent_graph import TangentGraph
from optplan.maps import read_scen
from optplan.maps.movingai_gen import generate_benchmark
from optplan.problem import Obstacle

BOUNDS = (0.0, 0.0, 100.0, 100.0)


def _poly(g) -> Obstacle:
    return Obstacle("polygon", orient(g, 1.0), name="p")


def _disc(x: float, y: float, r: float) -> Obstacle:
    return Obstacle("circle", None, name="c", center=np.array([x, y]), radius=r)


def _cells(rng: np.random.Generator, n: int = 10) -> list[Obstacle]:
    """One square per occupied cell of a random ``n x n`` grid over [5, 95]^2: shared edges,
    pinch points, walls of many pieces, staircases."""
    occ = rng.random((n, n)) < rng.uniform(0.2, 0.45)
    h = 90.0 / n
    return [_poly(shapely.box(5 + h * i, 5 + h * j, 5 + h * (i + 1), 5 + h * (j + 1)))
            for i, j in zip(*np.nonzero(occ))]


def _mixed(rng: np.random.Generator) -> list[Obstacle]:
    """Cells, rotated rectangles and circle obstacles."""
    obs = _cells(rng, 6)
    for _ in range(3):
        c = rng.uniform(15, 85, 2)
        box = shapely.affinity.rotate(shapely.box(*(c - [6, 1.5]), *(c + [6, 1.5])),
                                      float(rng.uniform(0, 180)))
        obs.append(_poly(box))
    for _ in range(3):
        obs.append(_disc(*rng.uniform(15, 85, 2), float(rng.uniform(1, 4))))
    return obs


def _free_tangents(graph: TangentGraph, every: bool) -> set:
    """The free tangents of every circle and sense: towards the candidates, or
    (``every``) towards every circle."""
    C, oset = graph.circles, graph.oset
    keys, a, b = [], [], []
    for i in range(C.n):
        vis = np.arange(C.n) if every else graph.visible(i)
        for si in (1, -1):
            e = edges_of_one(C, i, si, vis, oset.eps)
            keys += [(i, si, int(j), int(s)) for j, s in zip(e.j, e.sj)]
            a.append(e.pi if e.pi is not None else np.full(len(e.j), C.center[i]))
            b.append(e.pj)
    za, zb = np.concatenate(a), np.concatenate(b)
    fr = oset.frame
    free = oset.segment_free(fr.world(np.stack([za.real, za.imag], 1)),
                             fr.world(np.stack([zb.real, zb.imag], 1)))
    return {k for k, f in zip(keys, free) if f}


MAPS = [("cells", s) for s in range(4)] + [("mixed", s) for s in range(3)]


@pytest.mark.parametrize("kind,seed", MAPS)
@pytest.mark.parametrize("radius", [0.0, 1e-6, 0.6])
def test_no_free_tangent_is_lost(kind, seed, radius):
    rng = np.random.default_rng(seed)
    obs = _cells(rng) if kind == "cells" else _mixed(rng)
    oset = obstacle_set(obs, radius, Frame.from_bounds(BOUNDS))
    g = TangentGraph(oset, sightlines=True)
    ours = _free_tangents(g, every=False)
    assert ours == _free_tangents(g, every=True)
    assert ours  # the maps have free tangents
    if kind == "cells":  # and the sight lines do filter on the maps of many cells
        n_cand = sum(len(g.visible(i)) for i in range(g.circles.n))
        assert n_cand < 0.8 * g.circles.n ** 2


@pytest.mark.parametrize("family", ["random", "maze", "room", "street"])
def test_no_free_tangent_is_lost_on_generated_maps(family, tmp_path):
    gen = generate_benchmark(family, 32, tmp_path, rng=np.random.default_rng(3), queries=2)
    p = read_scen(gen.scen_path)[0]
    for radius in (0.0, 0.3):
        g = TangentGraph(obstacle_set(p.obstacles, radius, p.frame), sightlines=True)
        assert _free_tangents(g, every=False) == _free_tangents(g, every=True)


def _point_oracle(oset, pts: np.ndarray, centres: np.ndarray) -> list[set]:
    """Per point, the centres reached by a free straight segment (exact predicate)."""
    out = []
    for q in pts:
        free = oset.pairs_free(np.vstack([q[None], centres]), np.zeros(len(centres), int),
                               np.arange(1, len(centres) + 1))
        out.append(set(np.flatnonzero(free).tolist()))
    return out


@pytest.mark.parametrize("seed", range(4))
def test_every_centre_a_free_segment_reaches_is_a_candidate(seed):
    rng = np.random.default_rng(seed)
    frame = Frame.from_bounds(BOUNDS)
    oset = obstacle_set(_cells(rng, 12), 0.0, frame)
    g = TangentGraph(oset, sightlines=True)
    C = g.circles
    pts = rng.uniform(1, 99, (60, 2))
    pts = pts[oset.point_distances(pts) > 0.05][:25]
    centres = frame.world(np.stack([C.center.real, C.center.imag], 1))
    for q, seen in zip(pts, _point_oracle(oset, pts, centres)):
        z = frame.local(q)
        cand = set(g.visible_from(complex(z[0], z[1])).tolist())
        assert seen <= cand
        assert len(cand) < C.n  # something is hidden on these maps


def test_translation_and_scale_change_no_candidate_set():
    rng = np.random.default_rng(11)
    obs = _cells(rng, 12)
    sets = []
    for shift, scale in [((0.0, 0.0), 1.0), ((1e6, -3e5), 1.0), ((0.0, 0.0), 1e-3),
                         ((-2.5e4, 7e4), 40.0)]:
        moved = [_poly(shapely.affinity.translate(
            shapely.affinity.scale(o.geometry, scale, scale, origin=(0, 0)), *shift))
            for o in obs]
        b = (shift[0], shift[1], shift[0] + 100 * scale, shift[1] + 100 * scale)
        g = TangentGraph(obstacle_set(moved, 0.0, Frame.from_bounds(b)), sightlines=True)
        order = np.lexsort((g.circles.center.imag, g.circles.center.real))
        rank = np.argsort(order)
        sets.append([sorted(rank[g.visible(int(i))].tolist()) for i in order])
    assert all(s == sets[0] for s in sets[1:])


def test_a_square_hides_what_is_behind_it():
    # a point left of a square sees its two left corners, not its two right ones; a corner
    # of a second square straight behind is hidden, one off to the side is seen
    oset = obstacle_set([_poly(shapely.box(40, 40, 60, 60)), _poly(shapely.box(80, 45, 90, 55)),
                         _poly(shapely.box(80, 80, 90, 90))], 0.0, Frame.from_bounds(BOUNDS))
    g = TangentGraph(oset, sightlines=True)
    fr = oset.frame
    z = fr.local(np.array([10.0, 50.0]))
    cand = g.visible_from(complex(z[0], z[1]))
    C = fr.world(np.stack([g.circles.center.real, g.circles.center.imag], 1))
    seen = {tuple(np.round(C[k], 6)) for k in cand}
    assert {(40.0, 40.0), (40.0, 60.0)} <= seen
    assert not {(60.0, 40.0), (60.0, 60.0), (80.0, 45.0), (80.0, 55.0)} & seen
    assert (80.0, 80.0) in seen


def test_a_point_sees_through_a_pinch_and_along_a_wall():
    # squares touching at (50, 50): the line from (40, 60) through the pinch reaches the
    # corner (70, 30) of a third square (a point robot passes a pinch); the line along the
    # top of the wall y = 20 reaches its far corner (60, 20) from (10, 20)
    sq = [shapely.box(40, 40, 50, 50), shapely.box(50, 50, 60, 60), shapely.box(70, 20, 80, 30),
          shapely.box(20, 10, 60, 20)]
    oset = obstacle_set([_poly(g) for g in sq], 0.0, Frame.from_bounds(BOUNDS))
    g = TangentGraph(oset, sightlines=True)
    fr = oset.frame
    C = fr.world(np.stack([g.circles.center.real, g.circles.center.imag], 1))
    for src, dst in [((40.0, 60.0), (70.0, 30.0)), ((10.0, 20.0), (60.0, 20.0))]:
        z = fr.local(np.array(src))
        seen = {tuple(np.round(C[k], 6)) for k in g.visible_from(complex(z[0], z[1]))}
        assert dst in seen
        assert oset.segment_free(np.array([src]), np.array([dst]))[0]
    # a point beside the pinch, off its diagonal, does not see the hidden corner
    z = fr.local(np.array([40.0, 62.0]))
    seen = {tuple(np.round(C[k], 6)) for k in g.visible_from(complex(z[0], z[1]))}
    assert (70.0, 30.0) not in seen


@pytest.mark.parametrize("seed", range(3))
def test_triangles_are_free_exactly_outside_the_solids(seed):
    # oracle: shapely, each triangle's centroid inside a polygon solid (the bounds wall
    # included) or not
    rng = np.random.default_rng(seed)
    oset = obstacle_set(_mixed(rng), 0.0, Frame.from_bounds(BOUNDS))
    sl = TangentGraph(oset, sightlines=True).sightlines
    assert len(sl.VX) == len(sl._keys)  # no vertex added: no two edges cross
    cen = sl.VX[sl.T].mean(axis=1)
    solids = shapely.union_all([g for _, g in oset.shapes if not isinstance(g, tuple)])
    inside = shapely.contains_xy(solids, cen[:, 0], cen[:, 1])
    assert inside.any() and not inside.all()
    assert (sl.FREE == ~inside).all()
    # counter-clockwise triangles, neighbours across the edge opposite each corner
    a, b, c = (sl.VX[sl.T[:, k]] for k in range(3))
    assert ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0] > 0).all()
    t, k = np.nonzero(sl.NB >= 0)
    nb, nk = sl.NB[t, k], sl.NK[t, k]
    assert (sl.NB[nb, nk] == t).all() and (sl.CON[nb, nk] == sl.CON[t, k]).all()


def test_sightlines_of_nothing():
    s = Sightlines(np.zeros((0, 4)), np.zeros((0, 2)), np.zeros((0, 2)), 1e-9,
                   (0.0, 0.0, 1.0, 1.0))
    assert s.candidates([[0.5, 0.5]], 0.0, 7.0)[0].size == 0
    s = Sightlines(np.zeros((0, 4)), np.array([[0.2, 0.2], [0.9, 0.1]]), np.zeros((0, 2)),
                   1e-9, (0.0, 0.0, 1.0, 1.0))
    assert s.candidates([[0.5, 0.5]], 0.0, 7.0)[0].tolist() == [0, 1]
    assert s.candidates([], 0.0, 7.0) == []


@pytest.mark.parametrize("kind,seed", [("cells", 0), ("mixed", 1)])
@pytest.mark.parametrize("radius", [0.0, 1e-6, 0.6])
def test_build_stores_every_free_tangent_of_points_discs_and_circles(kind, seed, radius):
    """The build tries only the sense pairs of the windows that see across a pair (one for
    two points): it stores exactly the free tangents of every circle, sense and other circle
    (points, discs of radius r at corners, circle obstacles)."""
    rng = np.random.default_rng(seed)
    obs = _cells(rng) if kind == "cells" else _mixed(rng)
    oset = obstacle_set(obs, radius, Frame.from_bounds(BOUNDS))
    ch = TangentGraph(oset, sightlines=True).build().chains
    stored = set(zip(ch.circle.tolist(), ch.sense.tolist(), ch.a_circle.tolist(),
                     ch.a_sense.tolist()))
    free = _free_tangents(TangentGraph(oset, sightlines=False), every=True)
    assert stored == free and ch.n_edges == len(free)


@pytest.mark.parametrize("radius", [0.0, 0.2])
def test_build_stores_the_free_tangents_and_answers_like_the_lazy_graph(radius, tmp_path):
    gen = generate_benchmark("street", 32, tmp_path, rng=np.random.default_rng(5), queries=8)
    probs = read_scen(gen.scen_path, radius=radius)
    oset = probs[0].obstacle_set(radius)
    built = TangentGraph(oset, sightlines=True).build()
    free = _free_tangents(TangentGraph(oset, sightlines=False), every=True)
    ch = built.chains
    stored = set(zip(ch.circle.tolist(), ch.sense.tolist(), ch.a_circle.tolist(),
                     ch.a_sense.tolist()))
    assert stored == free and ch.n_edges == len(free)
    for p in probs:
        r = p.robots[0]
        a = built.shortest_path(r.start, r.goal)
        b = TangentGraph(oset, sightlines=False).shortest_path(r.start, r.goal)
        assert a.length == pytest.approx(b.length, rel=1e-12, abs=0.0)
