"""One obstacle set and tangent graph per static map and process (``optplan.problem.shared``).

Problems loaded apart (a ``.scen``'s lines written as scenario files and read back one by one,
as ``optplan bench`` runs them) share the map's obstacle set and graph; answers of
``op.solve(p, "visgraph")`` are identical whether the cache is cold or warm and in whatever
order the problems are solved (metamorphic: a problem solved first, after all others, after
others in reverse order, and on a graph built by another problem), for each ``graph``
option; the digest tells maps apart to the last bit; the cache keeps at most ``MAX_SETS`` sets.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely

import optplan as op
from optplan.catalog import load_problem
from optplan.maps import read_scen, write_batch
from optplan.maps.movingai_gen import generate_benchmark
from optplan.problem import Obstacle, shared


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Eight lines of a 64 x 64 street map (378 circles) as scenario files."""
    out = tmp_path_factory.mktemp("street")
    gen = generate_benchmark("street", 64, out, rng=np.random.default_rng(5), queries=8)
    return [str(f) for f in write_batch(read_scen(gen.scen_path), out / "batch")]


def _answer(res) -> tuple:
    return (res.status, res.metrics["lengths_exact"],
            {k: v.tobytes() for k, v in res.paths.items()})


def _fresh(path: str):
    """The problem of ``path`` as a copy with no cache (``optplan bench``'s cold copy)."""
    return load_problem(path).replaced(keep=("frame",))


@pytest.fixture
def large(monkeypatch):
    """The map counts as large (``auto`` builds it) from 100 circles."""
    from optplan.geometry.tangent import tangent_graph

    monkeypatch.setattr(tangent_graph, "SIGHTLINES_MIN", 100)


@pytest.mark.parametrize("graph", ["auto", "built", "lazy", "auto-large"])
def test_answers_do_not_depend_on_the_cache_or_the_order(files, graph, request):
    if graph == "auto-large":
        request.getfixturevalue("large")
        graph = "auto"
    cold = {}
    for f in files:  # each one solved first, on a cold cache
        shared.clear()
        cold[f] = _answer(op.solve(_fresh(f), "visgraph", graph=graph))
    shared.clear()
    for order in (files, files[::-1], files[1::2] + files[::2]):
        for f in order:  # warm: after the others
            assert _answer(op.solve(_fresh(f), "visgraph", graph=graph)) == cold[f]
    assert shared.stats()["sets"] >= 1


def test_lazy_auto_and_built_agree_and_auto_builds_large_maps(files, large):
    shared.clear()
    p = _fresh(files[0])
    oset = p.obstacle_set(0.0, known_only=True)
    from optplan.geometry.tangent.tangent_graph import SIGHTLINES_MIN, tangent_graph

    graph = tangent_graph(oset)
    assert graph.circles.n >= SIGHTLINES_MIN and graph.chains is None and graph.use_sightlines
    auto = [_answer(op.solve(_fresh(f), "visgraph", graph="auto")) for f in files]
    assert graph.chains is not None  # built by the first query, shared by the others
    assert _fresh(files[-1]).obstacle_set(0.0, known_only=True) is oset
    lazy = [_answer(op.solve(_fresh(f), "visgraph", graph="lazy")) for f in files]
    assert auto == lazy


def test_the_digest_tells_maps_apart():
    sq = Obstacle("polygon", shapely.box(2.0, 2.0, 4.0, 4.0), name="a")
    moved = Obstacle("polygon", shapely.box(2.0, 2.0, 4.0, np.nextafter(4.0, 5.0)), name="a")
    b = (0.0, 0.0, 10.0, 10.0)
    d = shared.map_digest([sq], b)
    assert d == shared.map_digest([Obstacle("polygon", shapely.box(2.0, 2.0, 4.0, 4.0),
                                            name="a")], b)
    assert d != shared.map_digest([moved], b)
    assert d != shared.map_digest([sq], (0.0, 0.0, 10.0, 11.0))
    assert d != shared.map_digest([Obstacle("polygon", sq.geometry, name="b")], b)
    assert d != shared.map_digest([Obstacle("polygon", sq.geometry, known=False, name="a")], b)
    c = Obstacle("circle", None, name="c", center=np.array([5.0, 5.0]), radius=1.0)
    c2 = Obstacle("circle", None, name="c", center=np.array([5.0, 5.0]), radius=1.5)
    assert shared.map_digest([c], b) != shared.map_digest([c2], b)


def test_the_cache_is_bounded(monkeypatch):
    shared.clear()
    monkeypatch.setattr(shared, "MAX_SETS", 2)
    p = op.load_problem("paper-env1").replaced()
    sets = [p.replaced().obstacle_set(r) for r in (0.5, 1.0, 1.5)]
    assert shared.stats()["sets"] == 2
    assert p.replaced().obstacle_set(1.5) is sets[2]  # kept: the most recent
    assert p.replaced().obstacle_set(0.5) is not sets[0]  # dropped, made again
    monkeypatch.setattr(shared, "MAX_GRAPH_BYTES", 0)
    op.solve(p.replaced(), "visgraph", graph="built")
    r = p.robots[0].radius
    assert p.replaced().obstacle_set(r, known_only=True) is not None  # a lookup trims
    assert shared.stats()["sets"] == 1  # over the graphs' bytes: only the most recent stays
