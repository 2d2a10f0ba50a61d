"""The MovingAI benchmark generator (optplan.maps.movingai_gen, ``optplan gen-map``).

* the ``.scen`` optimal lengths agree with independent checks: scipy's Dijkstra on the same
  8-connected grid without corner cutting, and all-pairs Floyd-Warshall on tiny maps;
* the files round-trip through optplan's own MovingAI readers (``read_grid``, ``read_scen``),
  whose any-angle optimum lies between the straight line and the octile length;
* random maps have the density asked for, room and maze maps are connected, every query joins
  two free cells of one component, buckets are ``floor(length / 4)``;
* the same seed writes the same bytes, another seed other maps; bad arguments are errors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

import optplan as op
from optplan import generators
from optplan.maps import read_grid, read_scen, read_scen_entries, scen_octile_length
from optplan.maps.movingai_gen import (
    KINDS,
    benchmark_terrain,
    default_name,
    generate_benchmark,
    octile_length,
    scen_queries,
)


def grid_graph(blocked: np.ndarray):
    """The MovingAI move graph as a sparse matrix: 8 neighbours, diagonals only between two
    free side cells; node ``y * W + x``."""
    h, w = blocked.shape
    free = ~blocked
    rows, cols, vals = [], [], []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dx == dy == 0:
                continue
            y, x = np.mgrid[0:h, 0:w]
            ny, nx = y + dy, x + dx
            ok = (ny >= 0) & (ny < h) & (nx >= 0) & (nx < w)
            ok &= free
            ok[ok] &= free[ny[ok], nx[ok]]
            if dx and dy:
                ok[ok] &= free[y[ok], nx[ok]] & free[ny[ok], x[ok]]
            rows.append((y * w + x)[ok])
            cols.append((ny * w + nx)[ok])
            vals.append(np.full(ok.sum(), math.sqrt(2) if dx and dy else 1.0))
    n = h * w
    return coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, n)).tocsr()


@pytest.mark.parametrize("kind, size", [(k, 32) for k in KINDS] + [("street", 64), ("maze", 64),
                                                                   ("random", 48)])
def test_scen_lengths_agree_with_scipy_dijkstra(tmp_path, kind, size):
    gen = generate_benchmark(kind, size, tmp_path, rng=np.random.default_rng(11), queries=25)
    blocked = read_grid(gen.map_path).cells != 0
    graph = grid_graph(blocked)
    entries = read_scen_entries(gen.scen_path)
    assert len(entries) == gen.queries == 25
    w = blocked.shape[1]
    starts = sorted({e.start[1] * w + e.start[0] for e in entries})
    dist = dijkstra(graph, indices=starts)
    row = {s: k for k, s in enumerate(starts)}
    for e in entries:
        ref = dist[row[e.start[1] * w + e.start[0]], e.goal[1] * w + e.goal[0]]
        assert math.isfinite(ref) and e.optimal_length == pytest.approx(ref, abs=1e-8)
        assert e.bucket == int(e.optimal_length // 4)
        assert not blocked[e.start[1], e.start[0]] and not blocked[e.goal[1], e.goal[0]]
        assert e.start != e.goal
    assert [e.bucket for e in entries] == sorted(e.bucket for e in entries)


def test_octile_length_against_floyd_warshall_on_tiny_maps():
    rng = np.random.default_rng(5)
    for _ in range(20):
        h, w = rng.integers(3, 8, size=2)
        blocked = rng.random((h, w)) < 0.3
        n = h * w
        d = np.full((n, n), np.inf)
        np.fill_diagonal(d, 0.0)
        for y in range(h):
            for x in range(w):
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        ny, nx = y + dy, x + dx
                        if (dx, dy) == (0, 0) or not (0 <= ny < h and 0 <= nx < w):
                            continue
                        if blocked[y, x] or blocked[ny, nx]:
                            continue
                        if dx and dy and (blocked[y, nx] or blocked[ny, x]):
                            continue
                        d[y * w + x, ny * w + nx] = math.sqrt(2) if dx and dy else 1.0
        for k in range(n):
            d = np.minimum(d, d[:, k:k + 1] + d[k:k + 1, :])
        for a in range(n):
            for b in range(n):
                if blocked.flat[a] or blocked.flat[b]:
                    assert octile_length(blocked, (a % w, a // w), (b % w, b // w)) == math.inf
                    continue
                got = octile_length(blocked, (a % w, a // w), (b % w, b // w))
                assert got == pytest.approx(d[a, b], abs=1e-12) or got == d[a, b] == math.inf


@pytest.mark.parametrize("kind", KINDS)
def test_files_round_trip_through_the_movingai_importer(tmp_path, kind):
    gen = generate_benchmark(kind, 32, tmp_path, rng=np.random.default_rng(2), queries=6)
    assert gen.map_path.name == f"{default_name(kind, 32)}.map"
    terrain = benchmark_terrain(kind, 32, np.random.default_rng(2))
    grid = read_grid(gen.map_path)
    assert np.array_equal(grid.cells != 0, terrain != ".")
    assert set(np.unique(terrain)) <= {".", "@", "T"}
    probs = read_scen(gen.scen_path)
    assert [q.name for q in probs] == [f"{gen.map_path.stem}-{k + 2}" for k in range(6)]
    for q, e in zip(probs, read_scen_entries(gen.scen_path)):
        assert scen_octile_length(q) == pytest.approx(e.optimal_length)
    for q in probs[:3]:
        res = op.solve(q, "visgraph")
        assert res.status.value == "optimal", (q.name, res.message)
        s, g = q.robots[0].start, q.robots[0].goal
        straight = float(np.hypot(*(g - s)))
        assert straight - 1e-9 <= res.metrics["length_exact"] <= scen_octile_length(q) + 1e-9


@pytest.mark.parametrize("density", [0.1, 0.2, 0.3])
@pytest.mark.parametrize("size", [32, 100])
def test_random_density(density, size):
    t = benchmark_terrain("random", size, np.random.default_rng(0), density=density)
    assert t.shape == (size, size)
    assert abs(np.mean(t != ".") - density) <= 0.5 / size ** 2


@pytest.mark.parametrize("kind", ["room", "maze"])
@pytest.mark.parametrize("size", [32, 128])
def test_rooms_and_mazes_are_connected(kind, size):
    from scipy import ndimage

    t = benchmark_terrain(kind, size, np.random.default_rng(size))
    _, n = ndimage.label(t == ".")
    assert n == 1
    assert 0.05 < np.mean(t != ".") < 0.6


def test_street_maps_have_blocks_streets_and_trees():
    t = benchmark_terrain("street", 256, np.random.default_rng(4))
    share = np.mean(t != ".")
    assert 0.2 < share < 0.7 and (t == "T").any()
    from scipy import ndimage

    labels, n = ndimage.label(t == ".")
    assert np.bincount(labels.ravel())[1:].max() > 0.8 * np.sum(t == ".")  # one street net
    assert n >= 1


def test_seeds_are_reproducible(tmp_path):
    a = generate_benchmark("street", 64, tmp_path / "a", rng=np.random.default_rng(9), queries=8)
    b = generate_benchmark("street", 64, tmp_path / "b", rng=np.random.default_rng(9), queries=8)
    c = generate_benchmark("street", 64, tmp_path / "c", rng=np.random.default_rng(10),
                           queries=8)
    assert a.map_path.read_bytes() == b.map_path.read_bytes()
    assert a.scen_path.read_bytes() == b.scen_path.read_bytes()
    assert a.map_path.read_bytes() != c.map_path.read_bytes()
    for kind in KINDS:
        x = benchmark_terrain(kind, 40, np.random.default_rng(1))
        assert np.array_equal(x, benchmark_terrain(kind, 40, np.random.default_rng(1)))
        assert not np.array_equal(x, benchmark_terrain(kind, 40, np.random.default_rng(2)))
    blocked = x != "."
    assert scen_queries(blocked, 5, np.random.default_rng(3)) == \
        scen_queries(blocked, 5, np.random.default_rng(3))
    # also reachable as optplan.generators
    d = generators.movingai_benchmark("street", 64, tmp_path / "d", rng=np.random.default_rng(9),
                                      queries=8)
    assert d.scen_path.read_bytes() == a.scen_path.read_bytes()


def test_bad_arguments():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="unknown map kind 'city'"):
        benchmark_terrain("city", 32, rng)
    for size in (4, 4096, 32.0, True):
        with pytest.raises(ValueError, match="size: expected an integer in 8..2048"):
            benchmark_terrain("random", size, rng)
    with pytest.raises(ValueError, match=r"density: expected a number in 0..0.4"):
        benchmark_terrain("random", 32, rng, density=0.5)
    with pytest.raises(ValueError, match="no two mutually reachable free cells"):
        scen_queries(np.ones((4, 4), dtype=bool), 1, rng)
    with pytest.raises(ValueError, match="queries: expected an integer >= 0"):
        generate_benchmark("random", 32, "unused", rng=rng, queries=-1)


def test_cli_gen_map(tmp_path, capsys):
    from optplan.cli import main

    assert main(["gen-map", "maze", "32", "--seed", "3", "--out", str(tmp_path),
                 "--queries", "7"]) == 0
    out = capsys.readouterr().out
    m = tmp_path / "maze-32-32-seed3.map"
    assert out.startswith(f"wrote {m} (32 x 32 cells, ") and "(7 queries, buckets " in out
    ref = generate_benchmark("maze", 32, tmp_path / "ref", rng=np.random.default_rng(3),
                             queries=7, name="maze-32-32-seed3")
    assert m.read_bytes() == ref.map_path.read_bytes()
    assert (tmp_path / "maze-32-32-seed3.map.scen").read_bytes() == ref.scen_path.read_bytes()
    assert main(["gen-map", "random", "32", "--density", "0.5", "--out", str(tmp_path)]) == 2
    assert "density: expected a number in 0..0.4" in capsys.readouterr().err
