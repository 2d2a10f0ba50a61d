"""Build once, query many: a map's ``TangentGraph`` answers a batch of queries exactly like one
search per query.

The queries are the lines of a small generated MovingAI map (``optplan.generators``' street and
room maps, 32 x 32) read through ``optplan.maps.read_scen``; every length from the shared graph
must equal the one-off :func:`shortest_path` on the same obstacle set and the ``visgraph``
preset's certified optimum, for a point and for a disc robot, with the same counts in ``info``
(fewer segment checks); the graph must store successors and reuse segment tests across
queries, and a graph that may store nothing (``max_bytes=0``) must give the same answers;
``visgraph`` with ``graph = "built"`` builds the shared graph once and gives the same optima.
"""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.geometry.tangent.tangent_graph import TangentGraph, shortest_path, tangent_graph
from optplan.maps import read_scen
from optplan.maps.movingai_gen import generate_benchmark


@pytest.fixture(scope="module", params=["street", "room"])
def scen(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(request.param)
    gen = generate_benchmark(request.param, 32, out, rng=np.random.default_rng(7), queries=12)
    return gen.scen_path


@pytest.mark.parametrize("radius", [0.0, 0.2])
def test_batch_equals_one_search_per_query(scen, radius):
    probs = read_scen(scen, radius=radius)
    assert len(probs) == 12
    oset = probs[0].obstacle_set(radius)
    graph = TangentGraph(oset)
    checked = 0
    for p in probs:
        r = p.robots[0]
        one = shortest_path(oset, r.start, r.goal)
        many = graph.shortest_path(r.start, r.goal)
        assert many.length == one.length
        # the same search; segments found blocked by earlier queries are not checked again
        assert {k: v for k, v in many.info.items() if k != "n_checked"} == \
            {k: v for k, v in one.info.items() if k != "n_checked"}
        assert many.info["n_checked"] <= one.info["n_checked"]
        np.testing.assert_array_equal(many.polyline, one.polyline)
        checked += one.info["n_checked"]
    assert graph.stats["queries"] == 12
    assert graph.stats["nodes"] > 0 and graph.nbytes > 0
    # segment statuses found by one query are reused by the next ones
    assert graph.stats["segment_tests"] < checked


def test_solve_shares_the_graph_and_gives_the_optimum(scen):
    probs = read_scen(scen)
    oset = probs[0].obstacle_set(0.0)
    assert all(p.obstacle_set(0.0) is oset for p in probs)  # read_scen shares the set
    graph = tangent_graph(oset)
    assert tangent_graph(oset) is graph
    for p in probs:
        res = op.solve(p, "visgraph")
        r = p.robots[0]
        assert res.status == "optimal"
        assert res.metrics["optimum"] == shortest_path(oset, r.start, r.goal).length
    assert graph.stats["queries"] == len(probs)


@pytest.mark.parametrize("radius", [0.0, 0.2])
def test_solve_with_the_built_graph(scen, radius):
    """``visgraph`` with ``graph = "built"``: the map's graph is built by the first solve
    and reused by the others (the problems of a ``.scen`` share it); the optima are the
    lazy search's."""
    probs = read_scen(scen, radius=radius)
    oset = probs[0].obstacle_set(radius)
    graph = tangent_graph(oset)
    assert graph.chains is None
    chains = None
    for p in probs:
        res = op.solve(p, "visgraph", graph="built")
        r = p.robots[0]
        assert res.status == "optimal"
        assert res.metrics["optimum"] == pytest.approx(
            shortest_path(oset, r.start, r.goal).length, rel=1e-12)
        chains = graph.chains if chains is None else chains
        assert graph.chains is chains  # built once
    assert op.get_solver("visgraph", graph="built").options()["graph"] == "built"
    with pytest.raises(ValueError, match="graph"):
        op.get_solver("visgraph", graph="eager")


def test_memory_bound_keeps_the_answers(scen):
    probs = read_scen(scen)
    oset = probs[0].obstacle_set(0.0)
    bounded = TangentGraph(oset, max_bytes=0)
    for p in probs:
        r = p.robots[0]
        assert bounded.shortest_path(r.start, r.goal).length == \
            shortest_path(oset, r.start, r.goal).length
    assert bounded.nbytes == 0 and bounded.stats["nodes"] == 0


def test_eager_build_stores_every_circle():
    prob = op.catalog.load_problem("paper-env1")
    r = prob.robots[0]
    oset = prob.obstacle_set(r.radius)
    graph = TangentGraph(oset).build()
    assert graph.stats["nodes"] == 2 * graph.circles.n
    assert graph.shortest_path(r.start, r.goal).length == \
        shortest_path(oset, r.start, r.goal).length


@pytest.mark.parametrize("name", op.list_problems())
def test_lazy_and_built_give_the_same_bits_on_the_catalogue(name):
    """The lazy search and the built graph's compiled search find the same path on every
    catalogue problem and report it identically (length, polyline and waypoints made from
    the path's circles one way: ``arc_lines.exact_path``), also through ``op.solve``."""
    p = op.load_problem(name)
    for r in p.planned_robots:
        oset = p.obstacle_set(r.radius, known_only=True)
        a = TangentGraph(oset).shortest_path(r.start, r.goal)
        b = TangentGraph(oset).build().shortest_path(r.start, r.goal)
        assert a.length == b.length and a.waypoints == b.waypoints
        np.testing.assert_array_equal(a.polyline, b.polyline)
    lazy = op.solve(op.load_problem(name), "visgraph", graph="lazy")
    built = op.solve(op.load_problem(name), "visgraph", graph="built")
    assert lazy.status == built.status
    assert lazy.metrics["lengths_exact"] == built.metrics["lengths_exact"]
    assert lazy.paths.keys() == built.paths.keys()
    for k in lazy.paths:
        np.testing.assert_array_equal(lazy.paths[k], built.paths[k])
