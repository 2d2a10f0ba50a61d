"""The farthest vertex of a polyline in clear sight (the step every waypoint follower takes)."""

from __future__ import annotations

import numpy as np
import pytest

from optplan.geometry.collision import farthest_clear

#: a polyline along the x axis, one vertex per unit
LINE = np.stack([np.arange(10.0), np.zeros(10)], axis=1)


def wall_at(x: float, calls: list[np.ndarray] | None = None):
    """A test that sees every vertex before the wall ``x = x`` (and records its calls)."""
    def clear(p: np.ndarray, Q: np.ndarray) -> np.ndarray:
        if calls is not None:
            calls.append(Q.copy())
        return Q[:, 0] < x
    return clear


def test_the_farthest_clear_vertex_and_none() -> None:
    assert farthest_clear(np.zeros(2), LINE, wall_at(6.5)) == 6
    assert farthest_clear(np.zeros(2), LINE, wall_at(100.0)) == 9
    assert farthest_clear(np.zeros(2), LINE, wall_at(-1.0)) is None
    assert farthest_clear(np.zeros(2), LINE[:0], wall_at(5.0)) is None


def test_candidates_bound_the_search() -> None:
    """A tracker whose index never moves back passes its window ahead."""
    assert farthest_clear(np.zeros(2), LINE, wall_at(6.5), range(2, 5)) == 4
    assert farthest_clear(np.zeros(2), LINE, wall_at(6.5), [1, 3, 7, 8]) == 3
    assert farthest_clear(np.zeros(2), LINE, wall_at(1.5), range(2, 5)) is None


def test_one_call_for_a_vectorised_test() -> None:
    calls: list[np.ndarray] = []
    assert farthest_clear(np.zeros(2), LINE, wall_at(4.5, calls), range(1, 8)) == 4
    assert len(calls) == 1 and np.array_equal(calls[0], LINE[1:8])


def test_chunks_go_farthest_first_and_stop_at_a_clear_one() -> None:
    calls: list[np.ndarray] = []
    assert farthest_clear(np.zeros(2), LINE, wall_at(4.5, calls), range(1, 8), chunk=1) == 4
    assert [float(Q[0, 0]) for Q in calls] == [7.0, 6.0, 5.0, 4.0]
    calls.clear()
    assert farthest_clear(np.zeros(2), LINE, wall_at(4.5, calls), range(1, 8), chunk=3) == 4
    assert [Q[:, 0].tolist() for Q in calls] == [[5.0, 6.0, 7.0], [2.0, 3.0, 4.0]]


@pytest.mark.parametrize("chunk", [None, 1, 2, 5, 50])
def test_the_chunk_never_changes_the_answer(chunk: int | None) -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        seen = rng.random(10) < 0.3

        def clear(p: np.ndarray, Q: np.ndarray, seen=seen) -> np.ndarray:
            return seen[Q[:, 0].astype(int)]

        lo, hi = sorted(rng.integers(0, 11, size=2))
        hits = np.flatnonzero(seen[lo:hi])
        want = int(lo + hits[-1]) if len(hits) else None
        assert farthest_clear(np.zeros(2), LINE, clear, range(lo, hi), chunk=chunk) == want
