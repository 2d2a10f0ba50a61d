"""The compiled roadmap graph utilities (optplan.swarm.roadmap_graph) and the corner pairs'
detour test return exactly what their numpy formulations return."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra as scipy_dijkstra

from optplan.swarm import roadmap as rm
from optplan.swarm.roadmap_graph import dijkstra, edge_csr, unique_pairs


def _unique_oracle(n, i, j):
    """np.unique of the keys min * n + max of the pairs kept (i != j, j >= 0)."""
    keep = (i != j) & (j >= 0)
    key = np.unique(np.minimum(i, j)[keep] * n + np.maximum(i, j)[keep])
    return key // max(n, 1), key % max(n, 1)


def _csr_oracle(nodes, i, j):
    """Stable argsort by source of concat(i, j); lengths by np.hypot."""
    n = len(nodes)
    src = np.concatenate((i, j))
    order = np.argsort(src, kind="stable")
    indptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
    w = np.hypot(nodes[i, 0] - nodes[j, 0], nodes[i, 1] - nodes[j, 1])
    pos = np.empty(len(src), np.int64)
    pos[order] = np.arange(len(src))
    return indptr, np.concatenate((j, i))[order], np.concatenate((w, w))[order], pos


#: (n, m) of the random pair lists: empty, one node, few and many repeats
CASES = ((0, 0), (1, 0), (1, 5), (2, 1), (5, 40), (50, 30), (300, 5000), (1000, 20000))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_unique_pairs_match_np_unique(seed):
    rng = np.random.default_rng(seed)
    for n, m in CASES:
        i = rng.integers(0, max(n, 1), m)
        j = rng.integers(-1, max(n, 1), m)  # -1: a missing neighbour
        if m:
            j[: m // 4] = i[: m // 4][::-1]  # repeats in both orientations
        lo, hi = unique_pairs(n, i, j)
        elo, ehi = _unique_oracle(n, i, j)
        assert lo.dtype == hi.dtype == np.int64
        np.testing.assert_array_equal(lo, elo)
        np.testing.assert_array_equal(hi, ehi)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_edge_csr_matches_a_stable_argsort(seed):
    rng = np.random.default_rng(seed)
    for n, m in CASES:
        nodes = rng.normal(size=(n, 2)) * rng.choice([1e-3, 1.0, 700.0])
        i = rng.integers(0, max(n, 1), m) if n else np.zeros(0, np.int64)
        j = rng.integers(0, max(n, 1), m) if n else np.zeros(0, np.int64)
        got = edge_csr(nodes, i, j)
        for g, e in zip(got, _csr_oracle(nodes, i, j)):
            assert g.dtype == e.dtype
            np.testing.assert_array_equal(g.view(np.int64) if g.dtype == float else g,
                                          e.view(np.int64) if e.dtype == float else e)


def test_dijkstra_matches_scipy():
    rng = np.random.default_rng(4)
    nodes = rng.uniform(0, 100, (200, 2))
    i, j = unique_pairs(200, rng.integers(0, 200, 600), rng.integers(0, 200, 600))
    indptr, target, weight, _ = edge_csr(nodes, i, j)
    m = csr_matrix((weight, target, indptr), shape=(200, 200))
    for src in (0, 1, 57):
        np.testing.assert_array_equal(dijkstra(indptr, target, weight, src),
                                      scipy_dijkstra(m, directed=True, indices=src))
    one = edge_csr(np.zeros((1, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64))
    np.testing.assert_array_equal(dijkstra(one[0], one[1], one[2], 0), [0.0])


def test_detour_test_decides_as_hypot():
    rng = np.random.default_rng(5)
    for scale in (1e-160, 1e-3, 1.0, 700.0, 1e6):
        d = rng.normal(size=(4000, 2)) * scale
        m = rng.uniform(0, 3, 4000) * scale
        h = np.hypot(d[:, 0], d[:, 1])
        h_c = np.hypot
        bound = h + m
        # on the bound, one ulp either side, far either side, no bound
        for b in (bound, np.nextafter(bound, 0), np.nextafter(bound, np.inf), bound * 0.5,
                  bound * 2.0, np.full(4000, np.inf)):
            for (dx, dy), mm, bb in zip(d, m, b):
                d2 = dx * dx + dy * dy
                # (np.hypot: the C library's hypot, as numba's math.hypot; CPython's
                # math.hypot is its own and may differ in the last bit)
                assert rm._detour_within(dx, dy, d2, mm, bb) == (h_c(dx, dy) + mm <= bb)
