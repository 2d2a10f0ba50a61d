"""The compiled roadmap edges and the staged corner-cut tests give the same results as the
straightforward numpy / scipy versions they replaced (pure speed changes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from optplan.generators import corridor_scene
from optplan.swarm import core as sw
from optplan.swarm import refine as rf
from optplan.swarm import roadmap as rm
from optplan.swarm import samples as smp


def _octant(dx, dy):
    """The octants of the earlier nested-``if`` version."""
    if dy >= 0:
        if dx > 0:
            return 0 if dy < dx else 1
        return 2 if dy > -dx else 3
    if dx < 0:
        return 4 if -dy < -dx else 5
    return 6 if -dy > dx else 7


def _reference_base_pairs(nodes, k):
    """The earlier neighbour and Yao pairs: cKDTree neighbours, O(n^2) octant scan."""
    n = len(nodes)
    tree = cKDTree(nodes)
    nb = tree.query(nodes, k=k + 1)[1][:, 1:]
    nb2 = tree.query(nodes[:2], k=min(2 * k, n - 1) + 1)[1][:, 1:]
    pairs = set()
    for i in range(n):
        for j in nb[i]:
            if i != j:
                pairs.add((min(i, j), max(i, j)))
    for i in range(2):
        for j in nb2[i]:
            if i != j:
                pairs.add((min(i, j), max(i, j)))
    for i in range(n):
        best = [math.inf] * 8
        arg = [-1] * 8
        for j in range(n):
            if j == i:
                continue
            dx, dy = nodes[j] - nodes[i]
            d = dx * dx + dy * dy
            s = _octant(dx, dy)
            if d < best[s]:
                best[s], arg[s] = d, j
        for j in arg:
            if j >= 0:
                pairs.add((min(i, j), max(i, j)))
    return pairs


def _reference_edges(space, nodes, corner, k, slack):
    """The earlier build_roadmap edge selection: the base pairs, then the corner pairs within
    the ellipse bound from scipy's Dijkstra; tested with the same kernel."""
    n = len(nodes)
    pairs = _reference_base_pairs(nodes, k)
    base = sorted(pairs)
    bi, bj = np.array(base).T
    okb = sw.segment_free(nodes[bi], nodes[bj], space)
    w = np.hypot(*(nodes[bi[okb]] - nodes[bj[okb]]).T)
    m = csr_matrix((np.r_[w, w], (np.r_[bi[okb], bj[okb]], np.r_[bj[okb], bi[okb]])),
                   shape=(n, n))
    U = dijkstra(m, directed=True, indices=0)[1]
    reach2 = (rm.CORNER_REACH * space.diag) ** 2
    ds = np.hypot(*(nodes - nodes[0]).T)
    dg = np.hypot(*(nodes - nodes[1]).T)
    cidx = np.flatnonzero(corner)
    extra = []
    for x in range(len(cidx)):
        for y in range(x + 1, len(cidx)):
            a, b = cidx[x], cidx[y]
            if (a, b) in pairs:
                continue
            d = nodes[a] - nodes[b]
            if d @ d > reach2:
                continue
            via = np.hypot(*d) + min(ds[a] + dg[b], ds[b] + dg[a])
            if via <= slack * U * (1.0 + 1e-9):
                extra.append((a, b))
    ei, ej = np.array(extra).T
    oke = sw.segment_free(nodes[ei], nodes[ej], space)
    free = sorted([(a, b) for (a, b), o in zip(base, okb) if o]
                  + [(a, b) for (a, b), o in zip(extra, oke) if o])
    return free


def test_sector_matches_the_nested_octant_test():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(2000, 2))
    d[:200] = np.round(d[:200])  # axis directions and diagonals, zeros
    d[200:300, 1] = d[200:300, 0]
    d[300:400, 1] = -d[300:400, 0]
    for dx, dy in d:
        assert rm._sector(dx, dy, 8) == _octant(dx, dy)
        assert rm._sector(dx, dy, 4) == _octant(dx, dy) * 4 // 8


@pytest.mark.parametrize("kind, seed", [("shelves", 1), ("doors", 0)])
def test_compiled_roadmap_edges_match_the_reference(kind, seed):
    prob = corridor_scene(kind, seed)
    space = sw.make_space(prob, prob.planned_robots[0], 8)
    nodes, corner = smp.roadmap_nodes(space, 40, np.random.default_rng(3), 360, 200)
    i, j, ok = rm._tested_edges(space, nodes, corner, 25, 1.1)
    assert list(zip(i[ok].tolist(), j[ok].tolist())) == [
        (int(a), int(b)) for a, b in _reference_edges(space, nodes, corner, 25, 1.1)]


def test_roadmap_csr_and_heuristic_match_scipy():
    prob = corridor_scene("shelves", 0)
    space = sw.make_space(prob, prob.planned_robots[0], 8)
    g = rm.build_roadmap(space, np.random.default_rng(5), 40, 25, 360, 200, 1.1)
    n = len(g.nodes)
    src = np.repeat(np.arange(n), np.diff(g.indptr))
    # every directed edge has its reverse, with the same length and the negated hash
    fwd = {(a, b): (w, h) for a, b, w, h in zip(src, g.target, g.weight, g.ehash)}
    for (a, b), (w, h) in fwd.items():
        assert fwd[(b, a)] == (w, -h)
        assert w == np.hypot(*(g.nodes[a] - g.nodes[b]))
    m = csr_matrix((g.weight, g.target, g.indptr), shape=(n, n))
    np.testing.assert_array_equal(g.to_goal(), dijkstra(m, directed=True, indices=1))


def _reference_cuts(pts, rows, f, thr, space):
    """The earlier tighten step: every cut tested, argmax of the free gains."""
    F = len(f)
    v, a, b = pts[rows], pts[rows - 1], pts[rows + 1]
    P = v[:, None, :] + f[None, :, None] * (a - v)[:, None, :]
    Q = v[:, None, :] + f[None, :, None] * (b - v)[:, None, :]
    Pp = np.broadcast_to(P[:, :, None, :], (len(v), F, F, 2))
    Qq = np.broadcast_to(Q[:, None, :, :], (len(v), F, F, 2))
    ok = sw.segment_free(Pp.reshape(-1, 2), Qq.reshape(-1, 2), space).reshape(len(v), F * F)
    dp = np.hypot(*(P - v[:, None, :]).transpose(2, 0, 1))
    dq = np.hypot(*(Q - v[:, None, :]).transpose(2, 0, 1))
    gain = (dp[:, :, None] + dq[:, None, :]
            - np.hypot(*(Qq - Pp).transpose(3, 0, 1, 2))).reshape(len(v), F * F)
    gain = np.where(ok, gain, -1.0)
    j = np.argmax(gain, axis=1)
    cut = gain[np.arange(len(v)), j] > thr
    return P, Q, j, cut, ok.size


def test_staged_cuts_choose_what_testing_every_cut_chooses():
    prob = corridor_scene("shelves", 1)
    space = sw.make_space(prob, prob.planned_robots[0], 8)
    paths = rm.roadmap_corridors(space, 10, np.random.default_rng(2), 40, 25, 360, 200)
    assert paths
    pts, off = rf._flat(paths)
    rows = np.concatenate([np.arange(off[p] + 1, off[p + 1] - 1) for p in range(len(paths))])
    thr = np.full(len(rows), 1e-5 * 700.0)
    thr[::3] = 0.0  # vertices whose every cut counts
    for f in (rf.CUT_FRACTIONS, rf.CUT_FRACTIONS[:4]):
        P, Q, j, cut, n = rf._best_cuts(pts, rows, f, thr, space)
        P0, Q0, j0, cut0, n0 = _reference_cuts(pts, rows, f, thr, space)
        np.testing.assert_array_equal(P, P0)
        np.testing.assert_array_equal(Q, Q0)
        np.testing.assert_array_equal(cut, cut0)
        np.testing.assert_array_equal(j[cut], j0[cut0])
        assert n <= n0
