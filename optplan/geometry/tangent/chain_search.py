r"""Compiled A* over a built tangent graph (:mod:`optplan.geometry.tangent.tangent_chains`).

A query adds to the static graph of :class:`~optplan.geometry.tangent.tangent_chains.ChainGraph` its
own nodes: the start ``S``, the goal ``G``, the arrival point ``A_k`` of every tangent from the
start to a circle and the departure point ``D_m`` of every tangent from a circle to the goal
(tangents from the circles the start or the goal may see,
:meth:`~optplan.geometry.tangent.tangent_graph.TangentGraph.visible_from`, that pass the circle's
cone, their segments tested exactly), and its edges: ``S -> A_k`` and ``D_m -> G`` (the
tangents), ``S -> G`` (the straight line), ``A_k`` to the next node of its chain, the node
before ``D_m`` on its chain to ``D_m``, and ``A_k -> D_m`` when no chain node lies between
them (each arc tested exactly).  :func:`chain_astar` then runs A* (Euclidean heuristic,
consistent: a tangent is a straight segment and an arc is no shorter than its chord) over
static and query edges, in compiled code, pausing every ``chunk`` expansions so that a
``stop`` callback can end it.

The result is the length of the shortest path of the tangent graph, as
:class:`~optplan.geometry.tangent.tangent_search.TangentSearch` finds it on the same graph
(``tests/geometry/test_chain_search.py`` compares the two on maps with point robots, disc
robots and circle obstacles).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import types

from optplan.geometry.compiled import F1, F2, I1, compiled, f8, heap_pop, heap_push, i8
from optplan.geometry.tangent.circles import ANGLE_TOL, TWO_PI, Circles
from optplan.geometry.tangent.tangent_chains import (
    ChainGraph,
    arcs_free,
    chain_key,
    entry_of,
    first_above,
)
from optplan.geometry.tangent.tangent_edges import cone_off, tangent_exists, tangent_normal
from optplan.geometry.tangent.tangent_search import Stopped

__all__ = ["chain_astar", "ChainSearch"]

#: Expansions between two polls of a search's ``stop`` callback.
CHUNK = 1 << 16


@compiled(F2, f8, F1, I1, i8, f8, f8, i8, i8, f8)
def _relax(nt, q, hk, hv, size, gx, gy, x, y, ng):  # pragma: no cover - compiled
    """Relax the edge ``x -> y`` to ``g = ng``: open ``y`` (push it with
    ``f = g + |y - goal|``) unless it is closed or open at no greater ``g``; the heap's
    new size."""
    st = nt[y, 3]
    if st == -q or (st == q and ng >= nt[y, 0]):
        return size
    nt[y, 3] = q
    nt[y, 0] = ng
    nt[y, 4] = x
    return heap_push(hk, hv, size, ng + math.hypot(nt[y, 1] - gx, nt[y, 2] - gy), y)


@compiled(types.Tuple((I1, F1, I1, F1)), types.Tuple((I1, I1, F1)), F2, i8, f8, f8, f8,
          types.Tuple((F1, I1)), I1, i8)
def chain_astar(static, query, nt, g_node, gx, gy, q, heap, state,
                chunk):  # pragma: no cover - compiled
    """A* to ``g_node`` (from the nodes on the heap: the start) over the static edges
    ``static = (tgt, tcost, nxt, ncost)`` (node ``x`` to ``tgt[x]`` of length ``tcost[x]``, to
    ``nxt[x]`` of length ``ncost[x]``; ``-1``: none) and the query edges ``query = (vsrc, vdst,
    vcost)``, ``vsrc -> vdst`` (sorted by ``vsrc``) of lengths ``vcost``; nodes from
    ``len(tgt)`` on are the query's.

    A closed node's chain successor at the same point and no cost (every chain of a point
    robot) is closed at once, with the same ``g``: its ``f`` is the minimum too (a
    consistent heuristic pops nothing cheaper before it), so the heap never holds it.

    ``nt`` is the node table, one row per node (what one relaxation reads is one cache
    line): ``g``, ``x``, ``y`` (its point), stamp (``q``: open, ``-q``: closed, anything
    else: not seen in this query), predecessor.  ``heap = (hk, hv)`` is the heap,
    ``state = [size, expanded, pushed]``.  Runs at most ``chunk`` pops; returns 0 when the
    goal is closed (its ``g`` in ``nt[g_node, 0]``), 1 when the heap is empty (no path), 2
    when paused (call again with the same arrays to go on).
    """
    tgt, tcost, nxt, ncost = static
    vsrc, vdst, vcost = query
    hk, hv = heap
    size = state[0]
    n_static = tgt.shape[0]
    nv = vsrc.shape[0]
    for _ in range(chunk):
        if size == 0:
            state[0] = size
            return 1
        f, x, size = heap_pop(hk, hv, size)
        if nt[x, 3] == -q:
            continue
        while True:  # x, then its chain's nodes at the same point and no cost
            nt[x, 3] = -q
            state[1] += 1
            if x == g_node:
                state[0] = size
                return 0
            g0 = nt[x, 0]
            before = size
            a = np.searchsorted(vsrc, x)
            while a < nv and vsrc[a] == x:  # the query's edges
                size = _relax(nt, q, hk, hv, size, gx, gy, x, vdst[a], g0 + vcost[a])
                a += 1
            y = -1
            if x < n_static:
                if tgt[x] >= 0:  # the tangent
                    size = _relax(nt, q, hk, hv, size, gx, gy, x, tgt[x], g0 + tcost[x])
                y = nxt[x]
            if y >= 0 and nt[y, 3] != -q:
                if ncost[x] == 0.0 and nt[y, 1] == nt[x, 1] and nt[y, 2] == nt[x, 2]:
                    nt[y, 0] = g0
                    nt[y, 4] = x
                    state[2] += size - before
                    x = y
                    continue
                size = _relax(nt, q, hk, hv, size, gx, gy, x, y, g0 + ncost[x])
            state[2] += size - before
            break
    state[0] = size
    return 2


def _gap_pairs(group: np.ndarray, order: np.ndarray, a_key: np.ndarray, G: int, C: Circles,
               uptr: np.ndarray, D: dict, uD: np.ndarray, pD: np.ndarray):
    """Arrivals (sorted by gap: ``group``, ``order``; keys ``a_key``; ``G`` the group base)
    that reach a goal departure of ``D`` along the arc without passing a departure:
    (arrival, departure index m, sweep).  Same gap and not behind it; or, on a circle
    obstacle, after the chain's last departure and the goal's before its first (round)."""
    lo, hi = uptr[uD], uptr[uD + 1]
    wrap = C.full[D["c"]] & (pD == lo) & (hi > lo)
    gk = np.concatenate([uD * G + pD, (uD * G + hi)[wrap]])
    ms = np.concatenate([np.arange(len(uD)), np.flatnonzero(wrap)])
    a = np.searchsorted(group, gk, "left")
    cnt = np.searchsorted(group, gk, "right") - a
    m = np.repeat(ms, cnt)
    first = np.repeat(a - np.cumsum(cnt) + cnt, cnt)
    x = order[first + np.arange(len(m))]
    d = D["key"][m] - a_key[x]
    full, empty = C.full[D["c"][m]], (hi == lo)[m]
    rnd = np.repeat(np.r_[np.zeros(len(uD), bool), np.ones(int(wrap.sum()), bool)], cnt)
    sw = np.where(rnd | ((d <= -ANGLE_TOL) & full & empty), d + TWO_PI,
                  np.where(d > -ANGLE_TOL, np.maximum(d, 0.0), -1.0))
    ok = sw >= 0
    return x[ok], m[ok], sw[ok]


class ChainSearch:
    """One query on :class:`~optplan.geometry.tangent.tangent_chains.ChainGraph`: its own nodes and
    edges (module docstring), the compiled A*, the path.

    Parameters
    ----------
    graph : TangentGraph
        The built graph (its ``oset``, ``circles``, ``arcs``, ``visible_from`` and ``stats``).
    chains : ChainGraph
        Its chains.
    work : dict
        The graph's work arrays, shared by its queries (grown here when too small).
    zs, zg : complex
        Start and goal (local frame).
    info : dict
        Counters, filled in (``n_expanded``, ``n_generated``, ``n_checked``).
    """

    def __init__(self, graph: Any, chains: ChainGraph, work: dict, zs: complex, zg: complex,
                 info: dict):
        self.graph, self.ch, self.work, self.zs, self.zg, self.info = (graph, chains, work,
                                                                        zs, zg, info)
        self.C: Circles = graph.circles
        self.oset = graph.oset

    def _tangents(self, z: complex, to_goal: bool) -> dict[str, np.ndarray]:
        """Tangents between the point ``z`` and the circles it may see, both senses, whose
        tangent point is in the circle's cone: circle, sense, point, angle, key, length."""
        C = self.C
        idx = self.graph.visible_from(z)
        c = np.repeat(idx, 2)
        s = np.tile(np.array([1, -1]), len(idx))
        rho = C.rho[c]
        # from z to circle c reached with sense s, or from circle c left with sense s to z
        D = (z - C.center[c]) if to_goal else (C.center[c] - z)
        delta = -s * rho if to_goal else s * rho
        dd = np.abs(D)
        k = np.flatnonzero(tangent_exists(dd, delta, self.oset.eps))
        c, s, rho, D, dd, delta = c[k], s[k], rho[k], D[k], dd[k], delta[k]
        nl = tangent_normal(D, dd, delta)
        th = np.angle(-s * nl)
        off = cone_off(C, c, th)
        k = np.flatnonzero(np.isfinite(off))
        c, s = c[k], s[k]
        return {"c": c, "s": s, "p": C.center[c] - s * rho[k] * nl[k], "th": th[k],
                "key": chain_key(C, c, s, off[k]),
                "seg": np.sqrt(np.maximum(dd[k] ** 2 - delta[k] ** 2, 0.0))}

    def _free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Exact tests of the segments ``a[k] -> b[k]`` (local complex)."""
        fr = self.oset.frame
        pa = fr.world(np.stack([a.real, a.imag], axis=1))
        pb = fr.world(np.stack([b.real, b.imag], axis=1))
        self.info["n_checked"] += len(a)
        self.graph.stats["segment_tests"] += len(a)
        return self.oset.segment_free(pa, pb)

    def _query_graph(self) -> None:
        """The query's nodes and edges (module docstring)."""
        ch, C, zs, zg = self.ch, self.C, self.zs, self.zg
        A, D = self._tangents(zs, False), self._tangents(zg, True)
        nA, nD = len(A["c"]), len(D["c"])
        free = self._free(np.concatenate([[zs], np.full(nA, zs), D["p"]]),
                          np.concatenate([[zg], A["p"], np.full(nD, zg)]))
        A = {k: v[free[1:1 + nA]] for k, v in A.items()}
        D = {k: v[free[1 + nA:]] for k, v in D.items()}
        self.A, self.D = A, D
        K, M = len(A["c"]), len(D["c"])
        N0 = ch.n_edges
        S, G = N0, N0 + 1
        a_id, d_id = N0 + 2 + np.arange(K), N0 + 2 + K + np.arange(M)
        src, dst, cost = [np.full(K, S)], [a_id], [A["seg"]]
        if free[0]:
            src.append(np.array([S]))
            dst.append(np.array([G]))
            cost.append(np.array([abs(zg - zs)]))
        src.append(d_id)
        dst.append(np.full(M, G))
        cost.append(D["seg"])
        # arcs: from each start arrival to its entry, from the departure before each goal
        # departure to it, from the arrivals in its gap (tangents' and the start's) to it
        uA, uD = 2 * A["c"] + (A["s"] < 0), 2 * D["c"] + (D["s"] < 0)
        pA = first_above(ch.uptr, ch.key, uA, A["key"] - ANGLE_TOL)
        pD = first_above(ch.uptr, ch.key, uD, D["key"])
        entry, sw_e = entry_of(C, ch.uptr, ch.key, A["c"], uA, A["key"], pA)
        k = np.flatnonzero(entry >= 0)
        arcs = [(A["c"][k], A["th"][k], sw_e[k], A["s"][k], a_id[k], entry[k],
                 np.zeros(len(k)))]
        arcs.append(self._before(d_id, D, uD, pD))
        G1 = ch.n_edges + 1
        x, m, sw = _gap_pairs(ch.a_group, ch.a_order, ch.a_key, G1, C, ch.uptr, D, uD, pD)
        arcs.append((ch.a_circle[x], ch.a_theta[x], sw, ch.a_sense[x], x, d_id[m], ch.seg[x]))
        grp = uA * G1 + pA
        order = np.argsort(grp, kind="stable")
        x, m, sw = _gap_pairs(grp[order], order, A["key"], G1, C, ch.uptr, D, uD, pD)
        arcs.append((A["c"][x], A["th"][x], sw, A["s"][x], a_id[x], d_id[m],
                     np.zeros(len(x))))
        circ, th, sw, sense, s2, d2, base = (np.concatenate([a[i] for a in arcs])
                                             for i in range(7))
        ok, n_arc = arcs_free(self.graph.arcs, C, circ, th, sw, sense)
        self.info["n_checked"] += n_arc
        src.append(s2[ok])
        dst.append(d2[ok])
        cost.append(base[ok] + C.rho[circ[ok]] * sw[ok])
        vs, vd, vc = (np.concatenate(v) for v in (src, dst, cost))
        order = np.argsort(vs, kind="stable")
        self.vsrc, self.vdst, self.vcost = vs[order], vd[order], vc[order]
        self.S, self.G, self.K = S, G, K
        self.vpoint = np.concatenate([[zs, zg], A["p"], D["p"]])

    def _before(self, d_id, D, uD, pD):
        """Arcs from the departure before each goal departure on its chain to it."""
        ch, C = self.ch, self.C
        lo, hi = ch.uptr[uD], ch.uptr[uD + 1]
        full = C.full[D["c"]] & (hi > lo)
        has = (pD > lo) | full
        nd = np.where(pD > lo, pD - 1, hi - 1)[has]
        wrap = (pD <= lo)[has]
        sw = np.maximum(D["key"][has] + np.where(wrap, TWO_PI, 0.0) - ch.key[nd], 0.0)
        return (D["c"][has], ch.theta[nd], sw, D["s"][has], nd, d_id[has],
                np.zeros(len(nd)))

    def _arrays(self, n_nodes: int, n_push: int) -> dict:
        """The work arrays, grown to ``n_nodes`` nodes and ``n_push`` heap entries."""
        w = self.work
        if len(w.get("nt", ())) < n_nodes:
            n_nodes += n_nodes // 8  # room for the next queries' own nodes
            nt = np.zeros((n_nodes, 5))
            nt[:len(self.ch.point), 1] = self.ch.point.real
            nt[:len(self.ch.point), 2] = self.ch.point.imag
            w["nt"], w["q"] = nt, 0.0
        if len(w.get("hk", ())) < n_push:
            n_push += n_push // 8
            w["hk"], w["hv"] = np.zeros(n_push), np.zeros(n_push, np.int64)
        return w

    def length(self, stop: Callable[[], bool] | None) -> float:
        """The length of the shortest path (``inf`` when none); raises
        :class:`~optplan.geometry.tangent.tangent_search.Stopped` when ``stop`` asks."""
        self._query_graph()
        ch = self.ch
        N0 = ch.n_edges
        nv = len(self.vpoint)
        w = self._arrays(N0 + nv, 2 * ch.n_edges + len(self.vsrc) + 2)
        nt, hk, hv = w["nt"], w["hk"], w["hv"]
        nt[N0:N0 + nv, 1], nt[N0:N0 + nv, 2] = self.vpoint.real, self.vpoint.imag
        w["q"] += 1.0
        q = w["q"]
        nt[self.S, 0], nt[self.S, 3], nt[self.S, 4] = 0.0, q, -1.0
        gx, gy = self.zg.real, self.zg.imag
        state = np.zeros(3, np.int64)
        state[0] = heap_push(hk, hv, 0, abs(self.zg - self.zs), self.S)
        while True:
            code = chain_astar((ch.tgt, ch.tcost, ch.nxt, ch.ncost),
                               (self.vsrc, self.vdst, self.vcost), nt, self.G, gx, gy, q,
                               (hk, hv), state, CHUNK)
            if code != 2:
                break
            if stop is not None and stop():
                raise Stopped
        self.info["n_expanded"] += int(state[1])
        self.info["n_generated"] += int(state[2])
        self.q = q
        return float(nt[self.G, 0]) if code == 0 else math.inf

    def visits(self) -> list[tuple[int, int]]:
        """The circles (and senses) the path found by :meth:`length` follows, in order, as
        :meth:`~optplan.geometry.tangent.tangent_search.TangentSearch.visits` gives them (the
        path's length and polyline are made from them, the same way for both searches)."""
        pred = self.work["nt"][:, 4]
        path = [self.G]
        while path[-1] != self.S:
            path.append(int(pred[path[-1]]))
        path.reverse()
        ch, N0, A = self.ch, self.ch.n_edges, self.A
        out: list[tuple[int, int]] = []
        for x, y in zip(path[:-1], path[1:]):
            if x == self.S:
                if y != self.G:  # a tangent from the start to a circle
                    k = y - N0 - 2
                    out.append((int(A["c"][k]), int(A["s"][k])))
            elif x < N0 and y != self.G and (int(ch.circle[y]) if y < N0 else int(
                    self.D["c"][y - N0 - 2 - self.K])) != ch.circle[x]:  # a tangent
                out.append((int(ch.a_circle[x]), int(ch.a_sense[x])))
        return out
