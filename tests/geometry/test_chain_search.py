"""The compiled search over a built tangent graph (``optplan.geometry.tangent.chain_search``).

Oracle: the lazy A* of ``optplan.geometry.tangent.tangent_search`` on the same map, an independent
search over a different graph (arrival states expanded into sorted successor streams,
dominance by arcs, no chains): every length must agree, and both must find no path together.
Maps: random cell maps (shared edges, pinch points, staircases), maps with rotated rectangles
and circle obstacles (arcs that go round), generated MovingAI maps; a point robot and disc
robots.  Also: a graph queried lazily before it is built, the ``stop`` callback between two
chunks of the compiled loop, an enclosed goal, and translation of the whole map.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from optplan.geometry import Frame, obstacle_set
from optplan.geometry.tangent import chain_search as cs
from optplan.geometry.tangent.tangent_graph import TangentGraph
from optplan.maps import read_scen
from optplan.maps.movingai_gen import generate_benchmark
from optplan.problem import Obstacle
from tests.geometry.test_sightlines import _cells, _mixed, _poly

BOUNDS = (0.0, 0.0, 100.0, 100.0)


def _map(kind: str, rng: np.random.Generator) -> list[Obstacle]:
    """Cells of a random grid (shared edges, pinch points, staircases); with ``mixed``
    fewer cells, rotated rectangles and circle obstacles (the sight-line tests' maps)."""
    return _cells(rng) if kind == "cells" else _mixed(rng)


def _queries(oset, rng: np.random.Generator, n: int) -> np.ndarray:
    x0, y0, x1, y1 = oset.frame.bounds
    pts = rng.uniform([x0, y0], [x1, y1], (8 * n, 2))
    pts = pts[oset.point_distances(pts) > oset.radius + 0.05]
    return pts[: 2 * (len(pts) // 2)][: 2 * n].reshape(-1, 2, 2)


def _circles(res) -> list:
    """The circles (centre, sense) a path follows."""
    return [(complex(w[0]), w[4]) for w in res.waypoints]


def _agree(oset, queries, built: TangentGraph | None = None) -> int:
    """Every query: the built graph's length and polyline are the lazy search's, bit for bit;
    returns the paths found."""
    built = TangentGraph(oset).build() if built is None else built
    assert built.chains is not None
    lazy = TangentGraph(oset)
    found = 0
    for s, g in queries:
        a, b = built.shortest_path(s, g), lazy.shortest_path(s, g)
        assert math.isfinite(a.length) == math.isfinite(b.length)
        if math.isfinite(b.length):
            found += 1
            if _circles(a) == _circles(b):  # the same path: made one way, the same bits
                assert a.length == b.length
                np.testing.assert_array_equal(a.polyline, b.polyline)
            else:  # a tie (equal lengths, e.g. a staircase on a grid): either path
                assert a.length == pytest.approx(b.length, rel=1e-12)
            assert np.allclose(a.polyline[[0, -1]], [s, g])
            seg = np.hypot(*np.diff(a.polyline, axis=0).T).sum()
            assert seg >= a.length * (1 - 1e-12)
            if not built.circles.rho.any():  # no arcs: the polyline is the path
                assert seg == pytest.approx(a.length, rel=1e-12)
                assert oset.crossings(a.polyline[None]).count[0] == 0
    return found


@pytest.mark.parametrize("kind,seed", [("cells", s) for s in range(3)]
                         + [("mixed", s) for s in range(3)])
@pytest.mark.parametrize("radius", [0.0, 0.6])
def test_built_graph_answers_like_the_lazy_search(kind, seed, radius):
    rng = np.random.default_rng(seed)
    oset = obstacle_set(_map(kind, rng), radius, Frame.from_bounds(BOUNDS))
    assert _agree(oset, _queries(oset, rng, 25)) >= 10


@pytest.mark.parametrize("family", ["random", "maze", "room", "street"])
@pytest.mark.parametrize("radius", [0.0, 0.25])
def test_generated_maps(family, radius, tmp_path):
    gen = generate_benchmark(family, 32, tmp_path, rng=np.random.default_rng(4), queries=20)
    probs = read_scen(gen.scen_path, radius=radius)
    oset = probs[0].obstacle_set(radius)
    qs = np.array([[p.robots[0].start, p.robots[0].goal] for p in probs])
    assert _agree(oset, qs) == len(qs)


def test_a_graph_queried_before_it_is_built(tmp_path):
    """Successors made (and segments found blocked) by lazy searches are kept, the rest
    made: the built graph's tangents are the free ones, whatever was there before."""
    rng = np.random.default_rng(2)
    oset = obstacle_set(_map("mixed", rng), 0.3, Frame.from_bounds(BOUNDS))
    qs = _queries(oset, rng, 20)
    g = TangentGraph(oset)
    for s, t in qs[:5]:
        g.shortest_path(s, t)
    assert g._edges and any((e.ok != 1).any() for e in g._edges.values())
    g.build()
    fresh = TangentGraph(oset).build()

    def tangents(ch):
        return sorted(zip(ch.circle, ch.sense, ch.a_circle, ch.a_sense))

    assert tangents(g.chains) == tangents(fresh.chains)
    _agree(oset, qs, built=g)


def test_stop_between_chunks(monkeypatch):
    rng = np.random.default_rng(0)
    oset = obstacle_set(_map("cells", rng), 0.0, Frame.from_bounds(BOUNDS))
    g = TangentGraph(oset).build()
    s, t = (1.0, 1.0), (99.0, 99.0)
    want = g.shortest_path(s, t).length
    monkeypatch.setattr(cs, "CHUNK", 1)
    calls = []
    res = g.shortest_path(s, t, stop=lambda: calls.append(1) or True)
    assert res.info["stopped"] and res.length == math.inf and len(calls) == 1
    assert g.shortest_path(s, t, stop=lambda: False).length == want


def test_an_enclosed_goal_is_unreachable():
    ring = shapely.box(40, 40, 60, 60).difference(shapely.box(45, 45, 55, 55))
    oset = obstacle_set([_poly(ring)], 0.0, Frame.from_bounds(BOUNDS))
    g = TangentGraph(oset).build()
    res = g.shortest_path((10.0, 10.0), (50.0, 50.0))
    assert res.length == math.inf and "not reachable" in res.info["reason"]
    assert g.shortest_path((10.0, 10.0), (90.0, 20.0)).length == pytest.approx(math.hypot(80, 10))


def test_translation_changes_no_length():
    rng = np.random.default_rng(7)
    obs = _map("mixed", rng)
    shift = np.array([1e4, -3e3])
    moved = [Obstacle("polygon", shapely.affinity.translate(o.geometry, *shift), name="p")
             if o.kind == "polygon" else
             Obstacle("circle", None, name="c", center=o.center + shift, radius=o.radius)
             for o in obs]
    a = obstacle_set(obs, 0.4, Frame.from_bounds(BOUNDS))
    b = obstacle_set(moved, 0.4, Frame.from_bounds((1e4, -3e3, 1e4 + 100.0, -2.9e3)))
    ga, gb = TangentGraph(a).build(), TangentGraph(b).build()
    for s, t in _queries(a, rng, 15):
        la, lb = ga.shortest_path(s, t).length, gb.shortest_path(s + shift, t + shift).length
        assert la == pytest.approx(lb, rel=1e-9) or la == lb == math.inf


@pytest.mark.parametrize("radius", [0.0, 0.5])
def test_ends_on_vertices_and_on_the_walls(radius):
    """Starts and goals at obstacle corners (a point robot may touch them), on a disc
    robot's offset of a corner, and against the bounds: the lengths agree."""
    rng = np.random.default_rng(3)
    obs = _map("cells", rng)
    oset = obstacle_set(obs, radius, Frame.from_bounds(BOUNDS))
    corners = np.array([c for o in obs for c in o.geometry.exterior.coords[:-1]])
    if radius > 0:  # a corner's offset along its diagonal, just clear of the obstacle
        corners = corners + radius * 1.0001 * np.sign(corners - 50.0)
    ends = np.vstack([corners[rng.choice(len(corners), 12, replace=False)],
                      [[radius, 50.0], [100.0 - radius, 37.0], [20.0, radius]]])
    ends = ends[oset.point_distances(ends) >= radius - 1e-9]
    qs = np.array([[a, b] for a, b in zip(ends[:-1], ends[1:])])
    assert _agree(oset, qs) >= 5


@pytest.mark.parametrize("seed", range(2))
def test_the_paths_are_the_lazy_search_paths(seed):
    """Where the shortest path is unique (real-valued maps with circle obstacles, a disc
    robot) the built graph returns the lazy search's path: the same waypoints (circles,
    arrival angles, sweeps, senses), length and polyline, bit for bit (both made from the
    path's circles by ``arc_lines.exact_path``)."""
    rng = np.random.default_rng(seed)
    oset = obstacle_set(_map("mixed", rng), 0.6, Frame.from_bounds(BOUNDS))
    built, lazy = TangentGraph(oset).build(), TangentGraph(oset)
    n = 0
    for s, g in _queries(oset, rng, 20):
        a, b = built.shortest_path(s, g), lazy.shortest_path(s, g)
        if b.polyline is None:
            continue
        n += 1
        assert a.waypoints == b.waypoints and a.length == b.length
        np.testing.assert_array_equal(a.polyline, b.polyline)
    assert n >= 10


def test_a_map_without_obstacles():
    """No circles, no tangents: the straight line, or the reason an end is not allowed."""
    oset = obstacle_set([], 0.5, Frame.from_bounds((0.0, 0.0, 10.0, 10.0)))
    g = TangentGraph(oset).build()
    assert g.circles.n == 0 and g.chains.n_edges == 0
    assert g.shortest_path((1.0, 1.0), (9.0, 9.0)).length == pytest.approx(8 * math.sqrt(2))
    res = g.shortest_path((0.2, 1.0), (9.0, 9.0))
    assert res.length == math.inf and "within 0.5" in res.info["reason"]


def test_stable_argsort_is_numpys_stable_sort():
    from optplan.geometry.tangent.tangent_chains import stable_argsort

    rng = np.random.default_rng(0)
    for k in (rng.integers(0, 5, 1000), rng.integers(0, 10**6, 5000), np.zeros(0, np.int64),
              np.array([2**61, 3, 2**61, 0])):  # the last one: too large, numpy's own sort
        assert np.array_equal(stable_argsort(k), np.argsort(k, kind="stable"))


def test_the_departures_order_is_lexsorts():
    """chains_of orders the departures by chain, then position, ties by index: lexsort's."""
    from optplan.geometry.tangent.tangent_chains import dense_rank, stable_argsort

    rng = np.random.default_rng(1)
    E = 4000
    u = rng.integers(0, 50, E)
    key = rng.choice(np.r_[0.0, 1.0, rng.random(20)], E)  # many exact ties
    assert np.array_equal(dense_rank(key), np.searchsorted(np.unique(key), key))
    assert len(dense_rank(np.zeros(0))) == 0
    order = stable_argsort(u * E + dense_rank(key))
    assert np.array_equal(order, np.lexsort((key, u)))
