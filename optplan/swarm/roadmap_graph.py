"""Compiled graph utilities of the sparse roadmap (:mod:`optplan.swarm.roadmap`): the
distinct node pairs of a list of candidate pairs, the CSR form of undirected edges with their
lengths, and Dijkstra's shortest distances over it.

The first two are counting sorts by node index, in time and memory linear in the pairs and
nodes (no ``n x n`` mask: a roadmap of any size in the options' ranges fits), and return
exactly what the numpy formulations in their docstrings return (the tests compare them).
"""

from __future__ import annotations

import math

import numpy as np

from optplan.geometry.compiled import F1, F2, I1, compiled, heap_pop, heap_push, i8, leaf

__all__ = ["unique_pairs", "edge_csr", "dijkstra"]


@leaf(I1)
def _cumulate(a):
    """``a[:] = np.cumsum(a)``, in place: counts into running sums."""
    for v in range(a.shape[0] - 1):
        a[v + 1] += a[v]


@compiled(i8, I1, I1)
def unique_pairs(n, i, j):
    """The distinct pairs ``min(i, j) < max(i, j)`` of nodes ``0 .. n - 1``, in lexicographic
    order.

    Parameters
    ----------
    n : int
        The node count (every ``i``, ``j`` is below it).
    i, j : ndarray of int64, shape (m,)
        The candidate pairs, either orientation, repeats allowed; pairs with ``i == j`` or
        ``j < 0`` (a missing neighbour) are dropped.

    Returns
    -------
    lo, hi : ndarray of int64, shape (p,)
        The distinct pairs ``lo < hi``, sorted by ``lo`` then ``hi`` (what ``np.unique`` of
        the keys ``lo * n + hi`` gives).

    Notes
    -----
    Two counting sorts: the pairs by ``hi``, then stably by ``lo`` into one bucket per ``lo``,
    in which a pair is dropped when it equals the bucket's last pair (the pairs arrive in
    ``hi`` order, so repeats are adjacent); the buckets are then closed up.  Time and memory
    ``O(m + n)``.
    """
    m = i.shape[0]
    start = np.zeros(n + 1, np.int64)  # per hi, then per lo: the first slot of its bucket
    for e in range(m):
        if i[e] != j[e] and j[e] >= 0:
            start[max(i[e], j[e]) + 1] += 1
    _cumulate(start)
    p = start[n]
    by_hi = np.empty(p, np.int64)  # the kept pairs by hi
    for e in range(m):
        if i[e] != j[e] and j[e] >= 0:
            b = max(i[e], j[e])
            by_hi[start[b]] = e
            start[b] += 1
    start[:] = 0
    for q in range(p):
        e = by_hi[q]
        start[min(i[e], j[e]) + 1] += 1
    _cumulate(start)
    fill = start[:n].copy()
    hi = np.empty(p, np.int64)  # the buckets of lo in order, each in ascending hi
    for q in range(p):
        e = by_hi[q]
        a = min(i[e], j[e])
        b = max(i[e], j[e])
        if fill[a] == start[a] or hi[fill[a] - 1] != b:  # not a repeat
            hi[fill[a]] = b
            fill[a] += 1
    count = 0
    for a in range(n):
        count += fill[a] - start[a]
    lo = np.empty(count, np.int64)
    q = 0
    for a in range(n):  # close up the buckets (in place: q <= start[a])
        for s in range(start[a], fill[a]):
            lo[q] = a
            hi[q] = hi[s]
            q += 1
    return lo, hi[:count]


@compiled(F2, I1, I1)
def edge_csr(nodes, i, j):
    """Both directions of the undirected edges ``(i, j)`` in CSR form, with their lengths.

    Parameters
    ----------
    nodes : ndarray of float64, shape (n, 2)
        The node points.
    i, j : ndarray of int64, shape (m,)
        The edges.

    Returns
    -------
    indptr : ndarray of int64, shape (n + 1,)
        The directed edges of node ``v`` are the slots ``indptr[v] .. indptr[v + 1] - 1``, in
        the order of ``concat(i, j)`` (a stable sort by source: what
        ``np.argsort(concat(i, j), kind="stable")`` orders).
    target : ndarray of int64, shape (2 m,)
        The other end of each directed edge.
    weight : ndarray of float64, shape (2 m,)
        Its length, ``math.hypot`` of the coordinate differences ``nodes[i] - nodes[j]``
        (the same bits as ``np.hypot``: both are the C library's ``hypot``).
    pos : ndarray of int64, shape (2 m,)
        The slot of each directed edge of ``concat(i, j)``.
    """
    n = nodes.shape[0]
    m = i.shape[0]
    indptr = np.zeros(n + 1, np.int64)
    for e in range(m):
        indptr[i[e] + 1] += 1
        indptr[j[e] + 1] += 1
    _cumulate(indptr)
    fill = indptr[:n].copy()
    target = np.empty(2 * m, np.int64)
    weight = np.empty(2 * m)
    pos = np.empty(2 * m, np.int64)
    for e in range(m):
        a = i[e]
        b = j[e]
        w = math.hypot(nodes[a, 0] - nodes[b, 0], nodes[a, 1] - nodes[b, 1])
        q = fill[a]
        fill[a] += 1
        target[q] = b
        weight[q] = w
        pos[e] = q
    for e in range(m):
        a = i[e]
        b = j[e]
        q = fill[b]
        fill[b] += 1
        target[q] = a
        weight[q] = weight[pos[e]]
        pos[m + e] = q
    return indptr, target, weight, pos


@compiled(I1, I1, F1, i8)
def dijkstra(indptr, target, weight, src):
    """Shortest distances from ``src`` over a CSR graph.

    Parameters
    ----------
    indptr, target, weight : ndarray
        The graph (:func:`edge_csr`).
    src : int
        The source node.

    Returns
    -------
    ndarray of float64, shape (n,)
        The distance of every node from ``src`` (``inf``: not reached).
    """
    n = indptr.shape[0] - 1
    dist = np.full(n, np.inf)
    done = np.zeros(n, np.bool_)
    cap = target.shape[0] + 1
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    dist[src] = 0.0
    size = heap_push(hk, hv, 0, 0.0, src)
    while size > 0:
        d, v, size = heap_pop(hk, hv, size)
        if done[v]:
            continue
        done[v] = True
        for e in range(indptr[v], indptr[v + 1]):
            u = target[e]
            nd = d + weight[e]
            if nd < dist[u]:
                dist[u] = nd
                size = heap_push(hk, hv, size, nd, u)
    return dist
