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
    untested.  Corridors
    (:func:`roadmap_corridors`): the k shortest walks of distinct homotopy signatures (label
    setting, A* with the exact roadmap distance to the goal, at most 1.1 x the shortest walk),
    string-pulled.

The nodes are sampled in :mod:`optplan.swarm.samples`, the signatures are
:mod:`optplan.swarm.signatures`; the graph loops (Dijkstra, the label-setting class search) are
compiled with numba, the rest (candidate edges, CSR form) is vectorised numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optplan.geometry.jit import (
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
from optplan.swarm.samples import roadmap_nodes
from optplan.swarm.signatures import _segment_hashes

__all__ = ["CORNER_REACH", "YAO_SECTORS", "Roadmap", "build_roadmap", "roadmap_corridors"]

@leaf(I2, I1, i8, i8)
def _has_class(shash, settled, v, h):
    """Whether node ``v`` has settled the signature ``h`` already (among its ``settled[v]``
    settled signatures ``shash[v, :settled[v]]``)."""
    for q in range(settled[v]):
        if shash[v, q] == h:
            return True
    return False


@compiled(I1, I1, F1, I1, F1, i8, i8, i8, i8, f8)
def _k_classes(indptr, nbr, weight, ehash, heur, src, dst, k_goal, k_node, slack):
    """Label-setting search for the ``k_goal`` shortest ``src -> dst`` walks of distinct
    homotopy signatures (each node settles at most ``k_node`` signatures, shortest first),
    A*-ordered by ``g + heur[node]`` (``heur``: a consistent lower bound of the distance to
    ``dst``, e.g. the exact roadmap distance, so each node still settles its labels shortest
    first; ``inf`` marks nodes that do not reach ``dst``).  The search stops at the
    first label longer than ``slack`` x the first walk found (the walks it could still find
    are at least that long).

    Returns the goal labels (shortest first), each label's node and parent label.
    """
    n = indptr.shape[0] - 1
    cap = k_node * nbr.shape[0] + 1  # every settled label pushes one label per edge
    lab_node = np.empty(cap, np.int64)
    lab_hash = np.empty(cap, np.int64)
    lab_par = np.empty(cap, np.int64)
    lab_g = np.empty(cap)
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    lab_node[0] = src
    lab_hash[0] = 0
    lab_par[0] = -1
    lab_g[0] = 0.0
    n_lab = 1
    settled = np.zeros(n, np.int64)
    shash = np.empty((n, k_node), np.int64)
    goals = np.empty(k_goal, np.int64)
    n_goal = 0
    size = heap_push(hk, hv, 0, heur[src], 0)
    bound = np.inf
    while size > 0 and n_goal < k_goal:
        f, lab, size = heap_pop(hk, hv, size)
        if f > bound:
            break
        v = lab_node[lab]
        d = lab_g[lab]
        h = lab_hash[lab]
        if settled[v] >= k_node or _has_class(shash, settled, v, h):
            continue
        shash[v, settled[v]] = h
        settled[v] += 1
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
        return _dijkstra(self.indptr, self.target, self.weight, 1)

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
    sectors, and every pair of corner nodes (taut paths run between corners; 0 neighbours:
    every pair of nodes), kept when collision-free with the margin of ``space.clear``.  None
    when no edge is free.

    ``slack`` (the search bound of :func:`roadmap_corridors`): the neighbour and Yao edges are
    tested first; with ``U`` the shortest start-goal walk over them, a corner pair ``(a, b)``
    with ``|s - a| + |a - b| + |b - g| > slack U`` (either orientation) is not tested and not
    kept.  No walk through it can be within ``slack`` x the shortest walk ``L <= U`` of the
    whole roadmap, nor on a shortest path to the goal from a node such a walk reaches, so the
    class search returns the same walks; it only skips the collision tests of long corner pairs
    far from the start-goal line.

    The candidate edges come from :func:`_base_edges` and :func:`_corner_edges`,
    and each group is tested in one call of the collision kernel (two calls in all)."""
    nodes, corner = roadmap_nodes(space, n_samples, rng, boundary, medial)
    n = len(nodes)
    if k_neighbours <= 0 or k_neighbours >= n - 1:  # every pair
        i, j = np.triu_indices(n, 1)
        ok = pairs_free(nodes, i, j, space)
    else:
        i, j, ok = _tested_edges(space, nodes, corner, k_neighbours, slack)
    i, j = i[ok], j[ok]
    if len(i) == 0:
        return None
    return Roadmap(nodes, *_roadmap_csr(nodes, i, j, space.signature_points,
                                        space.signature_keys))


def _tested_edges(space: SwarmSpace, nodes: np.ndarray, corner: np.ndarray, k: int,
                  slack: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The candidate edges ``i < j`` of :func:`build_roadmap` (lexicographic order) and their
    collision-free flags: the neighbour and Yao edges, tested first, then the corner pairs
    within :data:`CORNER_REACH` x diag and inside the ellipse of ``slack`` x the shortest
    walk over the free first edges (untested pairs outside it are returned as not free)."""
    from scipy.spatial import cKDTree

    n = len(nodes)
    tree = cKDTree(nodes)
    nb = tree.query(nodes, k=k + 1)[1][:, 1:]
    nb2 = tree.query(nodes[:2], k=min(2 * k, n - 1) + 1)[1][:, 1:]
    bi, bj = _base_edges(nodes, nb.astype(np.int64), nb2.astype(np.int64), YAO_SECTORS)
    okb = pairs_free(nodes, bi, bj, space)
    bound = math.inf
    if slack is not None and math.isfinite(slack):
        U = _walk_length(nodes, bi[okb], bj[okb])
        if math.isfinite(U):
            bound = slack * U * (1.0 + 1e-9)
    reach = CORNER_REACH * space.diag
    i, j, ok, todo = _corner_edges(nodes, bi, bj, corner, np.flatnonzero(corner), okb,
                                   reach * reach, bound, *_endpoint_distances(nodes))
    ok[todo] = pairs_free(nodes, i[todo], j[todo], space)
    return i, j, ok


def _walk_length(nodes: np.ndarray, i: np.ndarray, j: np.ndarray) -> float:
    """Shortest walk from node 0 to node 1 over the undirected edges ``(i, j)`` (inf: none)."""
    if len(i) == 0:
        return math.inf
    indptr, target, weight, _ = _csr(len(nodes), i, j, _edge_lengths(nodes, i, j))
    return float(_dijkstra(indptr, target, weight, 0)[1])


#: Corner nodes farther apart than this fraction of the map diagonal are not paired directly.
CORNER_REACH = 0.3

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


@compiled(F2, i8)
def _yao_nearest(nodes, sectors):
    """Per node its nearest other node in each of ``sectors`` equal angular sectors
    (:func:`_sector`; the lowest index on ties), ``-1`` for an empty sector: ``(n,
    sectors)``."""
    n = nodes.shape[0]
    X = nodes[:, 0].copy()
    Y = nodes[:, 1].copy()
    d2 = np.empty(n)
    sec = np.empty(n, np.int64)
    best = np.empty(sectors)
    arg = np.empty((n, sectors), np.int64)
    for i in range(n):
        xi = X[i]
        yi = Y[i]
        for j in range(n):
            dx = X[j] - xi
            dy = Y[j] - yi
            d2[j] = dx * dx + dy * dy
            sec[j] = _sector(dx, dy, sectors)
        best[:] = np.inf
        arg[i, :] = -1
        for j in range(n):
            if j != i and d2[j] < best[sec[j]]:
                best[sec[j]] = d2[j]
                arg[i, sec[j]] = j
    return arg


def _base_edges(nodes: np.ndarray, nb: np.ndarray, nb2: np.ndarray,
                sectors: int) -> tuple[np.ndarray, np.ndarray]:
    """The neighbour and Yao edges of :func:`build_roadmap`: each node to its nearest nodes
    ``nb`` (a row per node; ``nb2``: more for nodes 0 and 1, start and goal) and to its
    nearest node in each of ``sectors`` equal angular sectors (:func:`_yao_nearest`; a Yao
    graph: connected, and it bridges a dense cluster and a sparse region, which the k nearest
    neighbours of the cluster's nodes do not).  Returns those pairs ``i < j`` in
    lexicographic order."""
    n = len(nodes)
    M = np.zeros((n, n), bool)
    yao = _yao_nearest(nodes, sectors)
    for rows in (nb, nb2, yao):
        i = np.repeat(np.arange(len(rows)), rows.shape[1])
        j = rows.ravel()
        keep = (i != j) & (j >= 0)
        M[np.minimum(i, j)[keep], np.maximum(i, j)[keep]] = True
    bi, bj = np.nonzero(np.triu(M, 1))
    return bi.astype(np.int64), bj.astype(np.int64)


def _endpoint_distances(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance of every node to the start (node 0) and to the goal (node 1)."""
    return (np.hypot(nodes[:, 0] - nodes[0, 0], nodes[:, 1] - nodes[0, 1]),
            np.hypot(nodes[:, 0] - nodes[1, 0], nodes[:, 1] - nodes[1, 1]))


@compiled(F2, I1, I1, B1, I1, B1, f8, f8, F1, F1)
def _corner_edges(nodes, bi, bj, corner, cidx, okb, r2, bound, ds, dg):
    """All candidate pairs ``a < b`` in lexicographic order: the base edges ``(bi, bj)``
    (lexicographic, collision-free flags ``okb``) and the pairs of ``corner`` nodes (``cidx``:
    their indices, ascending) at most ``sqrt(r2)`` apart whose start-goal detour ``|s - a| +
    |a - b| + |b - g|`` (the shorter orientation; ``ds``, ``dg``:
    :func:`_endpoint_distances`) is at most ``bound``, merged row by row (a pair that is both
    is a base edge).  Returns the pairs, their flags (the base flags, False for a corner
    pair) and the mask of the corner pairs (to be tested)."""
    n = nodes.shape[0]
    nc = cidx.shape[0]
    nbase = bi.shape[0]
    cap = nbase + nc * (nc - 1) // 2
    I = np.empty(cap, np.int64)
    J = np.empty(cap, np.int64)
    ok = np.zeros(cap, np.bool_)
    todo = np.zeros(cap, np.bool_)
    q = 0
    e = 0  # next base edge
    c0 = 0  # first corner node after a
    for a in range(n):
        while c0 < nc and cidx[c0] <= a:
            c0 += 1
        c = c0 if corner[a] else nc
        while True:
            b_base = bj[e] if e < nbase and bi[e] == a else n
            b_corn = cidx[c] if c < nc else n
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
            if dx * dx + dy * dy > r2:
                continue
            if math.hypot(dx, dy) + min(ds[a] + dg[b_corn], ds[b_corn] + dg[a]) <= bound:
                I[q] = a
                J[q] = b_corn
                todo[q] = True
                q += 1
    return I[:q], J[:q], ok[:q], todo[:q]


def _edge_lengths(nodes: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Length of each edge ``nodes[i[e]] -> nodes[j[e]]``."""
    return np.hypot(nodes[i, 0] - nodes[j, 0], nodes[i, 1] - nodes[j, 1])


def _csr(n: int, i: np.ndarray, j: np.ndarray,
         w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Both directions of the undirected edges ``(i, j)`` (lengths ``w``) in CSR form, the
    edges of a node in the order of ``concat(i, j)`` (a stable sort by source); and the slot
    of each directed edge of ``concat(i, j)``."""
    src = np.concatenate((i, j)).astype(np.int64)
    order = np.argsort(src, kind="stable")
    indptr = np.zeros(n + 1, np.int64)
    indptr[1:] = np.cumsum(np.bincount(src, minlength=n))
    pos = np.empty(len(src), np.int64)
    pos[order] = np.arange(len(src))
    return (indptr, np.concatenate((j, i)).astype(np.int64)[order],
            np.concatenate((w, w))[order], pos)


def _roadmap_csr(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, Z: np.ndarray,
                 keys: np.ndarray) -> tuple[np.ndarray, ...]:
    """CSR arrays of :class:`Roadmap` (indptr, target, length, signature hash) of the free
    edges ``(i, j)``."""
    w = _edge_lengths(nodes, i, j)
    indptr, target, weight, pos = _csr(len(nodes), i, j, w)
    eh = _segment_hashes(nodes[i], nodes[j], Z, keys)
    ehash = np.empty(2 * len(i), np.int64)
    ehash[pos[:len(i)]] = eh
    ehash[pos[len(i):]] = -eh
    return indptr, target, weight, ehash


@compiled(I1, I1, F1, i8)
def _dijkstra(indptr, target, weight, src):
    """Shortest distances from ``src`` over a CSR graph (``inf``: not reached)."""
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
    g = build_roadmap(space, rng, n_samples, k_neighbours, boundary, medial, slack)
    if g is None or n_paths < 1:
        return []
    heur = g.to_goal()
    if not np.isfinite(heur[0]):  # start and goal are not connected
        return []
    goals, lab_node, lab_par = _k_classes(g.indptr, g.target, g.weight, g.ehash, heur, 0, 1,
                                          int(n_paths), int(min(n_paths, node_classes)),
                                          float(slack))
    walks = [g.walk(int(lab), lab_node, lab_par) for lab in goals]
    if not walks:
        return []
    pts, off = _flat(walks)
    pts, off = _pull(pts, off, space, 8)[:2]
    return [pts[off[i]:off[i + 1]] for i in range(len(walks))]
