"""``optplan.geometry.collision.solids._components`` (the solids' grouping: hooking and
pointer jumping in numpy) against scipy's ``connected_components`` (the oracle): the same
partition and numbering (components in the order of their smallest node) on random graphs,
paths whose labels run against the hooking, stars and graphs without edges."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from optplan.geometry.collision.solids import _components


def _oracle(n: int, a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    m, lab = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)),
                                  directed=False)
    first = np.full(m, n)
    np.minimum.at(first, lab, np.arange(n))  # number the components by their smallest node
    rank = np.argsort(np.argsort(first))
    return m, rank[lab]


def _both_ways(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.r_[a, b], np.r_[b, a]


@pytest.mark.parametrize("seed", range(40))
def test_random_graphs_match_scipy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 300))
    m = int(rng.integers(0, 2 * n))
    a, b = _both_ways(rng.integers(0, n, m), rng.integers(0, n, m))
    got = _components(n, a, b)
    want = _oracle(n, a, b)
    assert got[0] == want[0]
    np.testing.assert_array_equal(got[1], want[1])


@pytest.mark.parametrize("shape", ["path-up", "path-down", "path-shuffled", "star", "empty"])
def test_adversarial_shapes_match_scipy(shape: str) -> None:
    n = 3000
    order = {"path-up": np.arange(n), "path-down": np.arange(n)[::-1],
             "path-shuffled": np.random.default_rng(1).permutation(n)}.get(shape)
    if order is not None:
        a, b = _both_ways(order[:-1], order[1:])
    elif shape == "star":
        a, b = _both_ways(np.full(n - 1, n // 2), np.delete(np.arange(n), n // 2))
    else:
        a = b = np.zeros(0, np.int64)
    got = _components(n, a, b)
    want = _oracle(n, a, b)
    assert got[0] == want[0]
    np.testing.assert_array_equal(got[1], want[1])
