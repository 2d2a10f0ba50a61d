"""The compiled helpers of :mod:`optplan.swarm.refine` against plain Python / numpy oracles:
the index pairs and the greedy string pulling of :func:`~optplan.swarm.refine._pull`, the
dirty rows and the cut application of :func:`~optplan.swarm.refine.tighten`."""

from __future__ import annotations

import numpy as np
import pytest

from optplan.swarm import refine as rf

LENGTHS = [1, 2, 5, 9, 3, 12]


def _offsets(lengths):
    off = np.zeros(len(lengths) + 1, np.int64)
    off[1:] = np.cumsum(lengths)
    return off


@pytest.mark.parametrize("window", [0, 1, 3, 6, 20])
def test_pairs_are_every_close_pair_of_a_path_in_order(window):
    off = _offsets(LENGTHS)
    want = [(i, j) for p in range(len(LENGTHS)) for i in range(off[p], off[p + 1])
            for j in range(i + 1, off[p + 1]) if window == 0 or j - i <= window]
    I, J = rf._pairs(off, window)
    assert list(zip(I.tolist(), J.tolist(), strict=True)) == want


@pytest.mark.parametrize("seed", range(4))
def test_pulled_is_the_greedy_jump_to_the_farthest_visible_vertex(seed):
    rng = np.random.default_rng(seed)
    off = _offsets(LENGTHS)
    pts = rng.normal(size=(off[-1], 2))
    ids = rng.permutation(100)[:off[-1]].astype(np.int64)
    I, J = rf._pairs(off, 4)
    free = rng.random(len(I)) < 0.5
    visible = set(zip(I[free].tolist(), J[free].tolist(), strict=True))
    kept = []
    for p in range(len(LENGTHS)):
        v, last = int(off[p]), int(off[p + 1]) - 1
        path = [v]
        while v < last:
            later = [j for j in range(v + 2, last + 1) if (v, j) in visible]
            v = max(later) if later else v + 1
            path.append(v)
        kept.append(path)
    new_pts, new_off, new_ids = rf._pulled(pts, off, ids, I, J, free)
    flat = [v for path in kept for v in path]
    np.testing.assert_array_equal(new_off, _offsets([len(k) for k in kept]))
    np.testing.assert_array_equal(new_pts, pts[flat])
    np.testing.assert_array_equal(new_ids, ids[flat])


def test_dirty_rows_skip_settled_vertices_and_inactive_paths():
    rng = np.random.default_rng(3)
    off = _offsets(LENGTHS)
    ids = rng.permutation(200)[:off[-1]].astype(np.int64)
    settled = rng.integers(-1, 3, (2, 200))
    prev, nxt = settled  # views
    for v in range(1, off[-1] - 1):  # about half of the vertices settled
        if rng.random() < 0.5:
            prev[ids[v]], nxt[ids[v]] = ids[v - 1], ids[v + 1]
    active = np.array([True, True, False, True, True, True])
    length = rng.random(len(LENGTHS)) * 100
    rows, thr = rf._dirty_rows(off, ids, settled, active, length, 1e-5)
    want = [v for p in range(len(LENGTHS)) if active[p] for v in range(off[p] + 1, off[p + 1] - 1)
            if prev[ids[v]] != ids[v - 1] or nxt[ids[v]] != ids[v + 1]]
    assert rows.tolist() == want
    owner = np.searchsorted(off, rows, side="right") - 1
    np.testing.assert_array_equal(thr, 1e-5 * length[owner])


def _numpy_apply_cuts(pts, off, ids, rows, cut, P, Q, j, next_id, prev, nxt):
    """The earlier numpy version of the cut application."""
    F = P.shape[1]
    r = np.arange(len(rows))
    P, Q = P[r, j // F][cut], Q[r, j % F][cut]
    v = rows[~cut]
    prev[ids[v]] = ids[v - 1]
    nxt[ids[v]] = ids[v + 1]
    cv = rows[cut]
    rep = np.ones(len(pts), np.int64)
    rep[cv] = 2
    start = np.zeros(len(pts) + 1, np.int64)
    start[1:] = np.cumsum(rep)
    new_pts = np.repeat(pts, rep, axis=0)
    new_ids = np.repeat(ids, rep)
    s = start[cv]
    new_pts[s], new_pts[s + 1] = P, Q
    new_ids[s] = next_id + 2 * np.arange(len(cv), dtype=np.int64)
    new_ids[s + 1] = new_ids[s] + 1
    return new_pts, start[off], new_ids, next_id + 2 * len(cv)


def test_apply_cuts_replaces_each_cut_vertex_by_its_two_cut_points():
    rng = np.random.default_rng(5)
    off = _offsets(LENGTHS)
    pts = rng.normal(size=(off[-1], 2))
    ids = np.arange(off[-1], dtype=np.int64)
    rows = np.array([v for p in range(len(LENGTHS)) for v in range(off[p] + 1, off[p + 1] - 1)
                     if rng.random() < 0.7], np.int64)
    F = 4
    P = rng.normal(size=(len(rows), F, 2))
    Q = rng.normal(size=(len(rows), F, 2))
    j = rng.integers(0, F * F, len(rows))
    cut = rng.random(len(rows)) < 0.6
    settled = np.full((2, 100), -1, np.int64)
    prev0, nxt0 = np.full(100, -1, np.int64), np.full(100, -1, np.int64)
    got = rf._apply_cuts(pts, off, ids, rows, cut, P, Q, j, off[-1], settled)
    want = _numpy_apply_cuts(pts, off, ids, rows, cut, P, Q, j, off[-1], prev0, nxt0)
    for a, b in zip(got, want, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(settled, [prev0, nxt0])
