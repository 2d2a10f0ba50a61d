"""The sparse roadmap and its corridors: start-goal paths of distinct homotopy classes
(beyond the paper; a probabilistic roadmap, no exact planner).

Sparse roadmap
    Nodes (:func:`optplan.swarm.samples.roadmap_nodes`): uniform samples, obstacle-based
    samples beside the boundary edges and around the corners of the kernel's convex pieces and
    medial-axis retractions, which land in narrow passages.  Edges
    (:func:`build_roadmap`): k nearest neighbours, the nearest node in each octant (a Yao
    graph, which bridges dense clusters and sparse regions) and every pair of corner / medial
    nodes within :data:`CORNER_REACH` x diag (taut paths run between corners), kept when free
    with a margin of :data:`optplan.swarm.core.CLEAR_MARGIN` x diag; corner pairs that no walk
    within the search bound can use (outside the start-goal ellipse of the bound) are skipped
    untested.  Corridors (:func:`roadmap_corridors`): the k shortest walks of distinct homotopy
    signatures (label setting, A* with the exact roadmap distance to the goal, at most 1.1 x
    the shortest walk), string-pulled.  The graph loops are compiled with numba.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import types

from optplan.geometry.compiled import (
    B1,
    F1,
    F2,
    I1,
    I2,
    compiled,
    f8,
    heap_pop,
    heap_push,
    i8,
    inlined,
    leaf,
)
from optplan.swarm.core import SwarmSpace, pairs_free
from optplan.swarm.refine import _flat, _pull
from optplan.swarm.roadmap_graph import dijkstra, edge_csr, unique_pairs
from optplan.swarm.samples import roadmap_nodes
from optplan.swarm.signatures import _segment_hashes

__all__ = ["CORNER_REACH", "CORNER_PARTNERS", "YAO_SECTORS", "ALL_PAIRS_NODES", "PAIRS_PER_POLL",
           "MAX_NEIGHBOURS", "RoadmapStopped", "Roadmap", "build_roadmap", "roadmap_corridors"]

#: Candidate pairs tested (or node pairs scanned by the Yao search, or labels popped by the
#: class search) between two polls of the deadline (``space.poll``): a roadmap of any size in
#: the options' ranges is built in bounded steps.
PAIRS_PER_POLL = 1 << 16

#: ``roadmap_neighbours = 0`` (or >= the node count) connects every pair of at most this many
#: nodes (~524,000 pairs); a larger roadmap gets ``MAX_NEIGHBOURS`` (a dense one does not fit).
ALL_PAIRS_NODES = 1024

#: Labels the class search (:func:`_k_classes`) makes room for first (doubled when full).
FIRST_LABELS = 1 << 16
#: Nearest neighbours of a node at most (the largest ``roadmap_neighbours``).
MAX_NEIGHBOURS = 64


class RoadmapStopped(Exception):
    """The deadline (``space.poll``) stopped the roadmap: :func:`roadmap_corridors` gives none."""


def _poll(stop: Callable[[], bool] | None) -> None:
    """Raise :class:`RoadmapStopped` when the deadline's poll asks to stop."""
    if stop is not None and stop():
        raise RoadmapStopped


@leaf(I2, I1, i8, i8)
def _has_class(shash, settled, v, h):
    """Whether node ``v`` has settled the signature ``h`` already (among its ``settled[v]``
    settled signatures ``shash[v, :settled[v]]``)."""
    for q in range(settled[v]):
        if shash[v, q] == h:
            return True
    return False


#: ``graph`` of :func:`_k_classes`: ``indptr, nbr, weight, ehash`` (CSR)
_GRAPH = types.Tuple((I1, I1, F1, I1))
#: ``labels``: per label its node, signature hash, parent label and ``g``; the heap ``hk, hv``
_LABELS = types.Tuple((I1, I1, I1, F1, F1, I1))


@compiled(_GRAPH, F1, types.Tuple((i8, i8, i8, f8)), I1, F1, _LABELS, I1, I2, I1,
          types.UniTuple(i8, 2))
def _k_classes_run(graph, heur, query, st, bnd, labels, settled, shash, goals, limits):
    """The resumable loop of :func:`_k_classes` (state in ``st``, ``bnd``, ``labels``): 0 when
    the search is over, 1 after ``budget`` units of work, 2 when the label arrays must grow."""
    indptr, nbr, weight, ehash = graph
    dst, k_goal, k_node, slack = query
    lab_node, lab_hash, lab_par, lab_g, hk, hv = labels
    max_deg, budget = limits
    size = st[0]
    n_lab = st[1]
    n_goal = st[2]
    bound = bnd[0]
    cap = lab_node.shape[0]
    code = 0
    pops = 0
    while size > 0 and n_goal < k_goal:
        if pops >= budget:
            code = 1
            break
        if n_lab + max_deg > cap:
            code = 2
            break
        pops += 1
        f, lab, size = heap_pop(hk, hv, size)
        if f > bound:
            size = 0
            break
        v = lab_node[lab]
        d = lab_g[lab]
        h = lab_hash[lab]
        if settled[v] >= k_node or _has_class(shash, settled, v, h):
            continue
        shash[v, settled[v]] = h
        settled[v] += 1
        pops += indptr[v + 1] - indptr[v]  # the edges scanned below
        if v == dst:
            goals[n_goal] = lab
            if n_goal == 0:
                bound = slack * d
            n_goal += 1
            continue
        for e in range(indptr[v], indptr[v + 1]):
            u = nbr[e]
            if settled[u] >= k_node:
                continue
            g = d + weight[e]
            if not g + heur[u] <= bound:  # beyond the bound, or u does not reach dst
                continue
            hu = h + ehash[e]
            if _has_class(shash, settled, u, hu):  # that class of u is settled (shorter)
                continue
            lab_node[n_lab] = u
            lab_hash[n_lab] = hu
            lab_par[n_lab] = lab
            lab_g[n_lab] = g
            size = heap_push(hk, hv, size, g + heur[u], n_lab)
            n_lab += 1
    st[0] = size
    st[1] = n_lab
    st[2] = n_goal
    bnd[0] = bound
    return code


def _k_classes(graph: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
               heur: np.ndarray, src: int, dst: int, k_goal: int, k_node: int, slack: float,
               stop: Callable[[], bool] | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``k_goal`` shortest ``src -> dst`` walks of distinct homotopy signatures over the CSR
    ``graph = (indptr, nbr, weight, ehash)``: label setting, A*-ordered by ``g + heur[node]``
    (``heur`` a consistent lower bound, ``inf`` where ``dst`` is unreachable), each node settling
    at most ``k_node`` signatures, stopping at the first label over ``slack`` x the first walk.
    The compiled loop runs in steps of 16 x :data:`PAIRS_PER_POLL` units of work, polling
    ``stop`` between two (:class:`RoadmapStopped`); its label arrays start at
    :data:`FIRST_LABELS` and double when full.  Returns the goal labels (shortest first), each
    label's node and parent label."""
    indptr, nbr = graph[0], graph[1]
    n = indptr.shape[0] - 1
    full = k_node * nbr.shape[0] + 1  # every settled label pushes one label per edge
    max_deg = int(np.diff(indptr).max()) if n else 0
    cap = min(full, FIRST_LABELS + max_deg)
    lab_node, lab_hash, lab_par, lab_g, hk, hv = (
        np.empty(cap, t) for t in (np.int64, np.int64, np.int64, float, float, np.int64))
    lab_node[0], lab_hash[0], lab_par[0], lab_g[0] = src, 0, -1, 0.0
    hk[0], hv[0] = heur[src], 0  # a heap of one label
    settled = np.zeros(n, np.int64)
    shash = np.empty((n, k_node), np.int64)
    goals = np.empty(k_goal, np.int64)
    st = np.array([1, 1, 0], np.int64)
    bnd = np.array([np.inf])
    budget = PAIRS_PER_POLL << 4 if stop is not None else 1 << 62
    while True:
        code = _k_classes_run(graph, heur, (dst, k_goal, k_node, slack), st, bnd,
                              (lab_node, lab_hash, lab_par, lab_g, hk, hv), settled, shash,
                              goals, (max_deg, budget))
        if code == 0:
            break
        if code == 2:
            m = int(st[1])
            cap = max(min(full, 2 * cap), m + max_deg)
            lab_node, lab_hash, lab_par, lab_g, hk, hv = (  # the first m kept
                np.concatenate((x[:m], np.empty(cap - m, x.dtype)))
                for x in (lab_node, lab_hash, lab_par, lab_g, hk, hv))
        if code == 1 or cap > budget:  # a step done, or a large growth
            _poll(stop)
    n_lab, n_goal = int(st[1]), int(st[2])
    return goals[:n_goal], lab_node[:n_lab], lab_par[:n_lab]


@dataclass(frozen=True, eq=False)
class Roadmap:
    """A sparse roadmap in CSR form (both directions of every edge): ``nodes`` (0 = start,
    1 = goal), per directed edge its target, length and signature hash."""

    nodes: np.ndarray
    indptr: np.ndarray
    target: np.ndarray
    weight: np.ndarray
    ehash: np.ndarray

    def to_goal(self) -> np.ndarray:
        """Roadmap distance of every node to the goal (``inf``: not connected), the exact
        A* heuristic of the class search (the edges go both ways: Dijkstra from the goal)."""
        return dijkstra(self.indptr, self.target, self.weight, 1)

    def walk(self, lab: int, lab_node: np.ndarray, lab_par: np.ndarray) -> np.ndarray:
        """The points of the walk ending in label ``lab``."""
        seq = []
        while lab >= 0:
            seq.append(int(lab_node[lab]))
            lab = int(lab_par[lab])
        return self.nodes[seq[::-1]]


def build_roadmap(space: SwarmSpace, rng: np.random.Generator, n_samples: int = 40,
                  k_neighbours: int = 25, boundary: int | None = None,
                  medial: int | None = None, slack: float | None = None) -> Roadmap | None:
    """The sparse random roadmap (beyond the paper; no exact planner).  Nodes:
    :func:`roadmap_nodes`.  Edges: each node to its ``k_neighbours`` nearest nodes (start and
    goal to twice as many) and to its nearest node in each of :data:`YAO_SECTORS` angular
    sectors, and every pair of corner nodes (taut paths run between corners; at most
    :data:`CORNER_PARTNERS` per corner node) within :data:`CORNER_REACH` x diag, kept when
    collision-free with the margin of ``space.clear``; 0 neighbours: every pair of nodes (up to
    :data:`ALL_PAIRS_NODES` nodes, else :data:`MAX_NEIGHBOURS` neighbours).  None when no edge
    is free.

    ``slack`` (the search bound of :func:`roadmap_corridors`): the neighbour and Yao edges are
    tested first; with ``U`` the shortest start-goal walk over them, a corner pair ``(a, b)``
    with ``|s - a| + |a - b| + |b - g| > slack U`` (either orientation) is not tested and not
    kept.  No walk through it can be within ``slack`` x the shortest walk ``L <= U`` of the
    whole roadmap, nor on a shortest path to the goal from a node such a walk reaches, so the
    class search returns the same walks; it only skips the collision tests of long corner pairs
    far from the start-goal line.

    The candidate edges come from :func:`_base_edges` and :func:`_corner_edges` (sparse), each
    group tested in passes of :data:`PAIRS_PER_POLL` pairs; ``space.poll`` (the deadline) is
    polled between two passes and, past :data:`ALL_PAIRS_NODES` nodes, between the phases."""
    nodes, corner = roadmap_nodes(space, n_samples, rng, boundary, medial)
    n = len(nodes)
    _poll(space.poll if n > ALL_PAIRS_NODES else None)
    if (k_neighbours <= 0 or k_neighbours >= n - 1) and n <= ALL_PAIRS_NODES:  # every pair
        i, j = np.triu_indices(n, 1)
        ok = _free(nodes, i, j, space)
    else:  # (0 on a large roadmap: the most neighbours)
        k_neighbours = MAX_NEIGHBOURS if k_neighbours <= 0 else k_neighbours
        i, j, ok = _tested_edges(space, nodes, corner, min(k_neighbours, MAX_NEIGHBOURS), slack)
    i, j = i[ok], j[ok]
    if len(i) == 0:
        return None
    return Roadmap(nodes, *_roadmap_csr(nodes, i, j, space.signature_points,
                                        space.signature_keys, space.poll))


def _free(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """:func:`pairs_free` in passes of :data:`PAIRS_PER_POLL` pairs, polling the deadline
    between two (the same flags: each pair is decided on its own)."""
    if len(i) <= PAIRS_PER_POLL:
        return pairs_free(nodes, i, j, space)
    ok = np.empty(len(i), bool)
    for a in range(0, len(i), PAIRS_PER_POLL):
        _poll(space.poll if a else None)
        b = a + PAIRS_PER_POLL
        ok[a:b] = pairs_free(nodes, i[a:b], j[a:b], space)
    return ok


def _tested_edges(space: SwarmSpace, nodes: np.ndarray, corner: np.ndarray, k: int,
                  slack: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The candidate edges ``i < j`` of :func:`build_roadmap` (lexicographic order) and their
    collision-free flags: the neighbour and Yao edges, tested first, then the corner pairs
    within :data:`CORNER_REACH` x diag and inside the ellipse of ``slack`` x the shortest
    walk over the free first edges (untested pairs outside it are returned as not free)."""
    from scipy.spatial import cKDTree

    n = len(nodes)
    tree = cKDTree(nodes)
    k = min(k, n - 1)
    nb = tree.query(nodes, k=k + 1)[1][:, 1:]
    nb2 = tree.query(nodes[:2], k=min(2 * k, n - 1) + 1)[1][:, 1:]
    _poll(space.poll if n > ALL_PAIRS_NODES else None)
    bi, bj = _base_edges(nodes, nb.astype(np.int64), nb2.astype(np.int64),
                         _yao(nodes, YAO_SECTORS, space.poll))
    okb = _free(nodes, bi, bj, space)
    bound = math.inf
    if slack is not None and math.isfinite(slack):
        U = _walk_length(nodes, bi[okb], bj[okb])
        if math.isfinite(U):
            bound = slack * U * (1.0 + 1e-9)
    reach = CORNER_REACH * space.diag
    ends = _endpoint_distances(nodes)
    crange, cadj = _corner_partners(nodes, corner, reach, bound, ends, space.poll)
    _poll(space.poll if n > ALL_PAIRS_NODES else None)
    i, j, ok, todo = _corner_edges(nodes, bi, bj, crange, cadj, okb, reach * reach, bound,
                                   *ends)
    ok[todo] = _free(nodes, i[todo], j[todo], space)
    return i, j, ok


def _walk_length(nodes: np.ndarray, i: np.ndarray, j: np.ndarray) -> float:
    """Shortest walk from node 0 to node 1 over the undirected edges ``(i, j)`` (inf: none)."""
    if len(i) == 0:
        return math.inf
    indptr, target, weight, _ = edge_csr(nodes, i, j)
    return float(dijkstra(indptr, target, weight, 0)[1])


#: Corner nodes farther apart than this fraction of the map diagonal are not paired directly.
CORNER_REACH = 0.3

#: Corner nodes a corner node is paired with at most: all of them while there are at most
#: this many others, else its nearest this many (within :data:`CORNER_REACH`; a pair is kept
#: when either end chose the other).  Bounds the corner pairs of a large roadmap to this many
#: per corner node instead of the square of their count.
CORNER_PARTNERS = 512

#: Angular sectors of the Yao edges of :func:`build_roadmap` (a divisor of 8: octants).
YAO_SECTORS = 8


@inlined  # one call site (_yao_nearest)
def _sector(dx, dy, sectors):
    """The Yao sector of the direction ``(dx, dy)``: octant 0-7 counter-clockwise from +x (a
    half-open 45 degree cone each), times ``sectors / 8``.  Written with selects instead of
    branches (the same octants as nested ``if``s; it runs once per pair of roadmap nodes)."""
    neg = dy < 0.0  # the lower half is the upper half turned by 180 degrees
    u = -dx if neg else dx
    v = -dy if neg else dy
    o = (np.int64(2) + np.int64(v <= -u)) if u <= 0.0 else np.int64(v >= u)
    return (o + np.int64(4) * np.int64(neg)) * sectors // 8


@compiled(F2, i8, i8, i8)
def _yao_nearest(nodes, sectors, i0, i1):
    """Per node ``i0 <= i < i1`` its nearest other node in each of ``sectors`` equal angular
    sectors (:func:`_sector`; the lowest index on ties), ``-1`` for an empty sector:
    ``(i1 - i0, sectors)``."""
    n = nodes.shape[0]
    X = nodes[:, 0].copy()
    Y = nodes[:, 1].copy()
    d2 = np.empty(n)
    sec = np.empty(n, np.int64)
    best = np.empty(sectors)
    arg = np.empty((i1 - i0, sectors), np.int64)
    for i in range(i0, i1):
        xi = X[i]
        yi = Y[i]
        for j in range(n):
            dx = X[j] - xi
            dy = Y[j] - yi
            d2[j] = dx * dx + dy * dy
            sec[j] = _sector(dx, dy, sectors)
        best[:] = np.inf
        arg[i - i0, :] = -1
        for j in range(n):
            if j != i and d2[j] < best[sec[j]]:
                best[sec[j]] = d2[j]
                arg[i - i0, sec[j]] = j
    return arg


def _yao(nodes: np.ndarray, sectors: int, stop: Callable[[], bool] | None) -> np.ndarray:
    """:func:`_yao_nearest` of every node, in passes of about ``64`` x :data:`PAIRS_PER_POLL`
    node pairs with the deadline's poll ``stop`` between two."""
    n = len(nodes)
    rows = max(1, (PAIRS_PER_POLL << 6) // max(n, 1))
    parts = []
    for a in range(0, n, rows):
        _poll(stop if a else None)
        parts.append(_yao_nearest(nodes, sectors, a, min(a + rows, n)))
    return np.concatenate(parts) if len(parts) != 1 else parts[0]


def _base_edges(nodes: np.ndarray, nb: np.ndarray, nb2: np.ndarray,
                yao: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The neighbour and Yao edges of :func:`build_roadmap`: each node to its nearest nodes
    ``nb`` (a row per node; ``nb2``: more for nodes 0 and 1, start and goal) and to its
    nearest node in each angular sector ``yao`` (:func:`_yao_nearest`; a Yao graph:
    connected, and it bridges a dense cluster and a sparse region, which the k nearest
    neighbours of the cluster's nodes do not).  Returns those pairs ``i < j`` in
    lexicographic order."""
    rows = [np.repeat(np.arange(len(r), dtype=np.int64), r.shape[1]) for r in (nb, nb2, yao)]
    return unique_pairs(len(nodes), np.concatenate(rows),
                        np.concatenate([r.ravel() for r in (nb, nb2, yao)]).astype(np.int64))


def _corner_partners(nodes: np.ndarray, corner: np.ndarray, reach: float, bound: float,
                     ends: tuple[np.ndarray, np.ndarray], stop: Callable[[], bool] | None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Per node ``a`` the corner nodes ``b > a`` a corner node ``a`` is paired with,
    ``cadj[crange[a, 0]:crange[a, 1]]`` (ascending): every later corner node while there are
    at most :data:`CORNER_PARTNERS` + 1 (``cadj``: the corner nodes, shared by the ranges),
    else the pairs of a corner node and one of its :data:`CORNER_PARTNERS` nearest within
    ``reach`` (either way; in passes, polling ``stop``), those beyond the detour ``bound``
    (:func:`_corner_edges`; ``ends``: :func:`_endpoint_distances`) dropped with a margin."""
    n = len(nodes)
    cidx = np.flatnonzero(corner).astype(np.int64)
    nc = len(cidx)
    crange = np.zeros((n, 2), np.int64)
    if nc <= CORNER_PARTNERS + 1:
        crange[cidx, 0] = np.arange(1, nc + 1)
        crange[cidx, 1] = nc
        return crange, cidx
    from scipy.spatial import cKDTree

    pts = nodes[cidx]
    tree = cKDTree(pts)
    step = max(1, PAIRS_PER_POLL // CORNER_PARTNERS)
    ds, dg = ends
    pa, pb = [], []
    for a in range(0, nc, step):  # in passes, polling the deadline between two
        _poll(stop if a else None)
        d, nbr = tree.query(pts[a:a + step], k=CORNER_PARTNERS + 1,
                            distance_upper_bound=reach * (1.0 + 1e-9))
        keep = nbr < nc  # missing neighbours are nc
        u = cidx[np.repeat(np.arange(a, a + len(nbr)), nbr.shape[1])[keep.ravel()]]
        v, d = cidx[nbr[keep]], d[keep]
        keep = d + np.minimum(ds[u] + dg[v], ds[v] + dg[u]) <= bound * (1.0 + 1e-6)
        pa.append(u[keep])
        pb.append(v[keep])
    lo, hi = unique_pairs(n, np.concatenate(pa), np.concatenate(pb))
    cptr = np.zeros(n + 1, np.int64)
    cptr[1:] = np.cumsum(np.bincount(lo, minlength=n))
    crange[:, 0], crange[:, 1] = cptr[:-1], cptr[1:]
    return crange, hi


def _endpoint_distances(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance of every node to the start (node 0) and to the goal (node 1)."""
    return (np.hypot(nodes[:, 0] - nodes[0, 0], nodes[:, 1] - nodes[0, 1]),
            np.hypot(nodes[:, 0] - nodes[1, 0], nodes[:, 1] - nodes[1, 1]))


@inlined  # one call site (_corner_edges)
def _detour_within(dx, dy, d2, m, bound):
    """``math.hypot(dx, dy) + m <= bound`` (``d2 = dx * dx + dy * dy``, ``m >= 0``), decided
    by the cheaper ``sqrt(d2)`` unless that sum is within ``1e-12`` x ``bound`` of ``bound``:
    ``sqrt(d2)`` differs from ``hypot(dx, dy)`` by at most about ``5e-16`` of it (``2e-154``
    absolute where ``d2`` underflows), so outside that margin both sums fall on the same side
    (the same answer, bit for bit; hypot, the C library's, costs about 20 ns a call)."""
    s = math.sqrt(d2) + m
    tol = 1e-12 * bound + 1e-150  # (bound inf: tol inf, and hypot decides)
    if s > bound + tol:
        return False
    if s < bound - tol:
        return True
    return math.hypot(dx, dy) + m <= bound


@compiled(F2, I1, I1, I2, I1, B1, f8, f8, F1, F1)
def _corner_edges(nodes, bi, bj, crange, cadj, okb, r2, bound, ds, dg):
    """All candidate pairs ``a < b`` in lexicographic order: the base edges ``(bi, bj)``
    (lexicographic, collision-free flags ``okb``) and the corner pairs ``(a, cadj[c])``,
    ``crange[a, 0] <= c < crange[a, 1]`` (:func:`_corner_partners`), at most ``sqrt(r2)``
    apart, whose start-goal detour ``|s - a| + |a - b| + |b - g|`` (the shorter orientation; ``ds``,
    ``dg``: :func:`_endpoint_distances`) is at most ``bound``, merged row by row (a pair that
    is both is a base edge).  Returns the pairs, their flags (the base flags, False for a
    corner pair) and the mask of the corner pairs (to be tested)."""
    n = nodes.shape[0]
    nbase = bi.shape[0]
    cap = nbase
    for a in range(n):
        cap += crange[a, 1] - crange[a, 0]
    I = np.empty(cap, np.int64)
    J = np.empty(cap, np.int64)
    ok = np.zeros(cap, np.bool_)
    todo = np.zeros(cap, np.bool_)
    q = 0
    e = 0  # next base edge
    for a in range(n):
        c = crange[a, 0]
        c1 = crange[a, 1]
        while True:
            b_base = bj[e] if e < nbase and bi[e] == a else n
            b_corn = cadj[c] if c < c1 else n
            if b_base == n and b_corn == n:
                break
            if b_base <= b_corn:
                I[q] = a
                J[q] = b_base
                ok[q] = okb[e]
                e += 1
                q += 1
                if b_corn == b_base:
                    c += 1
                continue
            c += 1
            dx = nodes[a, 0] - nodes[b_corn, 0]
            dy = nodes[a, 1] - nodes[b_corn, 1]
            d2 = dx * dx + dy * dy
            if d2 > r2:
                continue
            if _detour_within(dx, dy, d2, min(ds[a] + dg[b_corn], ds[b_corn] + dg[a]), bound):
                I[q] = a
                J[q] = b_corn
                todo[q] = True
                q += 1
    return I[:q], J[:q], ok[:q], todo[:q]


def _roadmap_csr(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, Z: np.ndarray,
                 keys: np.ndarray, stop: Callable[[], bool] | None = None
                 ) -> tuple[np.ndarray, ...]:
    """CSR arrays of :class:`Roadmap` (indptr, target, length, signature hash) of the free
    edges ``(i, j)`` (the hashes in passes of :data:`PAIRS_PER_POLL` edges, with the
    deadline's poll ``stop`` between two)."""
    indptr, target, weight, pos = edge_csr(nodes, i, j)
    eh = np.empty(len(i), np.int64)
    for a in range(0, max(len(i), 1), PAIRS_PER_POLL):
        _poll(stop if a else None)
        b = a + PAIRS_PER_POLL
        eh[a:b] = _segment_hashes(nodes[i[a:b]], nodes[j[a:b]], Z, keys)
    ehash = np.empty(2 * len(i), np.int64)
    ehash[pos[:len(i)]] = eh
    ehash[pos[len(i):]] = -eh
    return indptr, target, weight, ehash


def roadmap_corridors(space: SwarmSpace, n_paths: int, rng: np.random.Generator,
                      n_samples: int = 40, k_neighbours: int = 25,
                      boundary: int | None = None, medial: int | None = None,
                      slack: float = 1.1, node_classes: int = 20) -> list[np.ndarray]:
    """Collision-free start-goal paths of distinct homotopy classes from one sparse random
    roadmap (:func:`build_roadmap`; beyond the paper, no exact planner).

    * the ``n_paths`` shortest roadmap walks of distinct homotopy signatures
      (:func:`signature_hashes`; label setting, A*-ordered, at most ``node_classes``
      signatures per node), shortest first, none longer than ``slack`` x the shortest;

    Each walk is string-pulled (greedy, over nodes at most 8 apart; it can only shorten the
    walk).  A roadmap that does not connect start and goal gives no path.
    """
    try:
        g = build_roadmap(space, rng, n_samples, k_neighbours, boundary, medial, slack)
        if g is None or n_paths < 1:
            return []
        heur = g.to_goal()
        if not np.isfinite(heur[0]):  # start and goal are not connected
            return []
        goals, lab_node, lab_par = _k_classes((g.indptr, g.target, g.weight, g.ehash), heur,
                                              0, 1, int(n_paths),
                                              int(min(n_paths, node_classes)), float(slack),
                                              space.poll)
    except RoadmapStopped:  # the deadline: no corridor (the run stops at its next poll)
        return []
    walks = [g.walk(int(lab), lab_node, lab_par) for lab in goals]
    if not walks:
        return []
    pts, off = _flat(walks)
    pts, off = _pull(pts, off, space, 8)[:2]
    return [pts[off[i]:off[i + 1]] for i in range(len(walks))]
