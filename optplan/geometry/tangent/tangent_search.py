r"""The A* of the tangent graph: one search from a start to a goal over the graph's edges.

Nodes are arrival states ``(circle, sense, arrival angle, g, pred)``; the successors of
an expanded node (the query-independent :class:`~optplan.geometry.tangent.tangent_edges.Edges` of
its circle and sense, kept by the :class:`~optplan.geometry.tangent.tangent_graph.TangentGraph`,
plus the tangent to the goal) form one :class:`Stream` sorted by ``f = g + h`` (Euclidean ``h``,
consistent) and are checked lazily: only when the cheapest open candidate (exact segment test
of :class:`~optplan.geometry.collision.obstacles.ObstacleSet`, exact arc test of
:class:`~optplan.geometry.tangent.circles.ArcChecker`).  An arrival is dominated (not expanded) when
an earlier expanded arrival on the same circle and sense reaches it along a free arc at no
greater cost.  The mathematics is in :mod:`optplan.geometry.tangent.tangent_graph`.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from optplan.geometry.collision import ObstacleSet
from optplan.geometry.tangent.circles import TWO_PI, Circles
from optplan.geometry.tangent.tangent_edges import (
    Edges,
    arc_sweep,
    both_senses,
    cone_off,
    tangent_exists,
    tangent_normal,
)

__all__ = ["Stream", "TangentSearch", "Stopped"]


class Stopped(Exception):
    """The ``stop`` callback of a search ended it."""


class Stream:
    """Sorted successor candidates of one expanded node.

    ``f``, ``g`` and the arrays of ``steps = (j, sj, pi, pj, th_d, th_a, sweep)`` are parallel,
    one entry per candidate; ``eidx`` (same length) indexes ``edges``.  The stream holds the
    entries ``sel`` (all by default), sorted here by ``f``.
    """

    __slots__ = ("node", "f", "g", "j", "sj", "pi", "pj", "th_d", "th_a", "sweep", "ok", "pos",
                 "checked", "edges", "eidx")

    def __init__(self, node: int, f: np.ndarray, g: np.ndarray,
                 steps: tuple[np.ndarray, ...], edges: Edges | None = None,
                 eidx: np.ndarray | None = None, sel: np.ndarray | None = None) -> None:
        j, sj, pi, pj, th_d, th_a, sweep = steps
        order = np.argsort(f, kind="stable") if sel is None else sel[
            np.argsort(f[sel], kind="stable")]
        self.node = node
        self.f, self.g, self.j, self.sj = f[order], g[order], j[order], sj[order]
        self.pi, self.pj, self.th_d, self.th_a = pi[order], pj[order], th_d[order], th_a[order]
        self.sweep = sweep[order]
        self.ok = np.zeros(len(order), np.int8)  # 0 unknown, 1 free, -1 blocked
        self.pos = 0
        self.checked = 0
        # the query-independent edges the candidates come from (index -1: the goal)
        self.edges: Edges | None = edges
        self.eidx = None if eidx is None else eidx[order]


class TangentSearch:
    """State of one A* search over the tangent graph
    (:func:`optplan.geometry.tangent.tangent_graph.shortest_path`).

    Nodes are arrival states ``(circle, sense, arrival angle, g, pred)``; the successors
    of an expanded node form one :class:`Stream` sorted by ``f``, consumed lazily.

    Parameters
    ----------
    oset, C : the obstacle set and its circles; zs, zg : start and goal (local, complex);
    info : dict
        Counters, filled in (``n_expanded``, ``n_generated``, ``n_checked``).
    graph : TangentGraph
        The map's :class:`~optplan.geometry.tangent.tangent_graph.TangentGraph` (its ``edges_of``,
        ``visible``, ``visible_from``, ``arcs`` and ``stats``; typed loosely here, since that
        module imports this one).
    """

    def __init__(self, oset: ObstacleSet, C: Circles, zs: complex, zg: complex, info: dict,
                 graph: Any):
        self.oset, self.C, self.zs, self.zg = oset, C, zs, zg
        self.fr = oset.frame
        self.eps = self.fr.eps
        self.info = info
        self.graph = graph
        self.arcs = self.graph.arcs
        self.box = self.fr.local_bounds
        self.n = C.n
        self.cen, self.rho, self.lo, self.width, self.full = (C.center, C.rho, C.lo, C.width,
                                                              C.full)
        self.nodes: list[tuple] = []
        self.closed: set = set()
        self.expanded: dict = {}  # (circle, sense) -> list of (theta, g)
        self.heap: list = []
        self.streams: list[Stream] = []
        # the goal as a target of :meth:`candidates`: (target, sense, centre, radius)
        self._goal = (np.array([-2]), np.array([1]), np.array([zg]), np.zeros(1))

    def cone_off(self, k, th):
        """Offset of angle ``th`` from the cone start of circle(s) ``k``, or nan outside
        (:func:`~optplan.geometry.tangent.tangent_edges.cone_off`)."""
        return cone_off(self.C, k, th)

    def candidates(self, i: int, si: int, ci: complex, ri: float, circles: bool = True,
                   goal: bool = True, points: np.ndarray | None = None):
        """Tangents from circle ``i`` (sense ``si``; ``i < 0``: the point ``ci``) to every
        other circle with both senses (``circles``), to the goal (``goal``) and to the extra
        points ``points`` (local complex; target ``-3 - k`` for point ``k``): with
        :meth:`departures`, the successors of an arrival (also the chains of the ``sipp``
        roadmap, :mod:`optplan.exact.sipp_graph`).

        Returns ``jj, sj, dd, delta, nl, pj, th_arr`` (target circle, its sense, centre
        distance, radius difference, tangent normal, arrival point and angle) for the
        geometrically possible tangents (``|c_j - c_i| > |delta|``).
        """
        parts = []  # (target, sense, centre, radius) of each kind of target
        if circles:  # the circles it may see (a superset: :mod:`~.sightlines`), not itself
            idx = self.graph.visible(i) if i >= 0 else self.graph.visible_from(ci)
            idx = idx[idx != i] if i >= 0 else idx
            parts.append((*both_senses(idx),
                          np.repeat(self.cen[idx], 2), np.repeat(self.rho[idx], 2)))
        if goal:
            parts.append(self._goal)
        if points is not None and len(points):
            pts = np.asarray(points, complex)
            m = len(pts)
            parts.append((-3 - np.arange(m, dtype=np.int64), np.ones(m, np.int64), pts,
                          np.zeros(m)))
        if len(parts) == 1:
            jj, sj, cj, rj = parts[0]
        else:
            jj, sj, cj, rj = (np.concatenate([q[k] for q in parts]) if parts else
                              np.zeros(0, (np.int64, np.int64, complex, float)[k])
                              for k in range(4))
        D = cj - ci
        dd = np.abs(D)
        delta = sj * rj - (si * ri if i >= 0 else 0.0)
        ok = tangent_exists(dd, delta, self.eps)
        if not ok.all():
            jj, sj, cj, rj, D, dd, delta = (x[ok] for x in (jj, sj, cj, rj, D, dd, delta))
        nl = tangent_normal(D, dd, delta)
        pj = cj - sj * rj * nl
        z = -sj * nl
        return jj, sj, dd, delta, nl, pj, np.arctan2(z.imag, z.real)

    def departures(self, i: int, si: int, th_a: float, ci: complex, ri: float, nl):
        """Departure points on circle ``i`` of the tangents of normals ``nl``
        (:meth:`candidates`), their angles, the arc swept from the arrival angle ``th_a`` and
        whether that arc stays in the cone: ``pi, th_d, sweep, ok``."""
        m = len(nl)
        if i < 0:
            return np.full(m, ci), np.zeros(m), np.zeros(m), np.ones(m, bool)
        pi, th_d, od = self._leave(i, si, ci, ri, nl)
        sweep = self._sweep(i, si, th_a, th_d, od)
        return pi, th_d, sweep, np.isfinite(od) & (sweep >= 0)

    def _leave(self, i: int, si: int, ci: complex, ri: float, nl):
        """Departure points on circle ``i`` (sense ``si``, centre ``ci``, radius ``ri``) of
        the tangents of normals ``nl``, their angles and cone offsets (nan: outside the
        cone): ``pi, th_d, od``."""
        z = -si * nl
        th_d = np.arctan2(z.imag, z.real)
        return ci - si * ri * nl, th_d, self.cone_off(i, th_d)

    def _sweep(self, i: int, si: int, th_a: float, th_d, od):
        """Arc swept on circle ``i`` (sense ``si``) from the arrival angle ``th_a`` to the
        departure angles ``th_d`` (cone offsets ``od``; :func:`~optplan.geometry.tangent.
        tangent_edges.arc_sweep`); negative or nan: not in the cone."""
        return arc_sweep(self.C, i, si, th_a, th_d, od)

    def expand(self, node_id: int) -> None:
        """Generate the successors of node ``node_id`` as a new stream."""
        i, si, th_a, g0 = self.nodes[node_id][:4]
        self.info["n_expanded"] += 1
        if i < 0:  # the start: a point
            ci, ri = self.zs, 0.0
        else:
            ci, ri = self.cen[i], self.rho[i]
        start = i < 0
        jj, sj, dd, delta, nl, pj, th_arr = self.candidates(i, si, ci, ri, circles=start)
        seg = np.sqrt(np.maximum(dd * dd - delta * delta, 0.0))
        edges = eidx = None
        if start:
            pi, th_d, sweep, ok = self.departures(i, si, th_a, ci, ri, nl)
            if self.n:  # arrival point in the cone of circle j (the goal has none)
                isg = jj < 0
                ok &= isg | np.isfinite(self.cone_off(np.where(isg, 0, jj), th_arr))
        else:  # the circles' tangents from the graph, the goal's from above: one sweep
            edges = self.graph.edges_of(i, si)
            pi, th_d, od = self._leave(i, si, ci, ri, nl)
            od = np.concatenate([edges.od, od])
            th_d = np.concatenate([edges.th_d, th_d])
            sweep = self._sweep(i, si, th_a, th_d, od)
            ok = np.isfinite(od) & (sweep >= 0)
            pie = edges.pi if edges.pi is not None else np.full(len(edges.j), ci)
            jj, sj = np.concatenate([edges.j, jj]), np.concatenate([edges.sj, sj])
            seg, pi = np.concatenate([edges.seg, seg]), np.concatenate([pie, pi])
            pj, th_arr = np.concatenate([edges.pj, pj]), np.concatenate([edges.th_a, th_arr])
            eidx = np.concatenate([np.arange(len(edges.j)), np.full(len(dd), -1)])
        g = g0 + ri * sweep + seg
        f = g + np.abs(pj - self.zg)
        self.info["n_generated"] += int(np.count_nonzero(ok))
        if edges is not None:  # a segment an earlier search found blocked is never a step
            ok[:len(edges.j)] &= edges.ok != -1
        sel = np.flatnonzero(ok)
        if sel.size == 0:
            return
        st = Stream(node_id, f, g, (jj, sj, pi, pj, th_d, th_arr, sweep), edges, eidx, sel)
        self.streams.append(st)
        heapq.heappush(self.heap, (float(st.f[0]), len(self.streams) - 1))

    def check(self, st: Stream, k: int) -> bool:
        """Exact checks of candidate ``k`` of ``st`` (and a batch after it)."""
        if st.ok[k] == 0:
            b = min(len(st.f), k + max(8, st.checked))
            idx = k + (st.ok[k:b] == 0).nonzero()[0]
            self.info["n_checked"] += len(idx)
            free = self._segments_free(st, idx)
            i, si, th_a = self.nodes[st.node][:3]
            if i >= 0 and self.rho[i] > 0:
                m = free & (st.sweep[idx] > 0)
                if m.any():
                    free[m] = self.arcs.free(i, np.full(int(m.sum()), th_a),
                                             st.sweep[idx][m], si)
            st.ok[idx] = np.where(free, 1, -1)
            st.checked += len(idx)
        return st.ok[k] == 1

    def _segments_free(self, st: Stream, idx: np.ndarray) -> np.ndarray:
        """Exact segment tests of candidates ``idx`` of ``st``; the status of a graph edge
        tested by an earlier search is reused, a new one is stored."""
        known = np.zeros(len(idx), np.int8)
        edges = st.edges
        e = None if edges is None or st.eidx is None else st.eidx[idx]
        if edges is not None and e is not None:
            has = e >= 0
            known[has] = edges.ok[e[has]]
        new = known == 0
        todo = idx[new]
        z = np.empty((len(todo), 2), complex)  # the segments' ends: (n, 2, 2) real below
        z[:, 0], z[:, 1] = st.pi[todo], st.pj[todo]
        tested = self.oset.segment_free(self.fr.world(z.view(float).reshape(-1, 2, 2)))
        self.graph.stats["segment_tests"] += len(todo)
        if edges is not None and e is not None:
            e = e[new]
            has = e >= 0
            edges.ok[e[has]] = np.where(tested[has], 1, -1)
        free = known == 1
        free[new] = tested
        return free

    def dominated(self, j: int, sj: int, th: float, g: float) -> bool:
        """Whether an expanded arrival on circle ``j`` (sense ``sj``) reaches angle ``th``
        along a free arc at cost <= ``g``."""
        lst = self.expanded.get((j, sj))
        if not lst:
            return False
        rho = self.rho
        th_e = np.array([x[0] for x in lst])
        g_e = np.array([x[1] for x in lst])
        if self.full[j]:
            sw = np.mod((th - th_e) * sj, TWO_PI)
        else:
            o_new = self.cone_off(np.array([j]), np.array([th]))[0]
            o_e = self.cone_off(np.full(len(th_e), j), th_e)
            sw = (o_new - o_e) * sj
        cand = (sw >= 0) & (g_e + rho[j] * sw <= g + 1e-12 * max(1.0, g))
        if not cand.any():
            return False
        if rho[j] == 0:
            return True
        idx = np.flatnonzero(cand)
        return bool(self.arcs.free(j, th_e[idx], sw[idx], sj).any())

    def _stopped(self, stop: Callable[[], bool] | None) -> bool:
        """Poll ``stop`` every 64 expansions."""
        n_exp = self.info["n_expanded"]
        return stop is not None and n_exp % 64 == 0 and bool(n_exp) and bool(stop())

    def _pop(self) -> tuple[Stream, int]:
        """The cheapest open candidate: (stream, index); its stream's next one goes back."""
        _, sid = heapq.heappop(self.heap)
        st = self.streams[sid]
        k = st.pos
        st.pos += 1
        if st.pos < len(st.f):
            heapq.heappush(self.heap, (float(st.f[st.pos]), sid))
        return st, k

    def run(self, stop: Callable[[], bool] | None) -> int | None:
        """A* from the start; the goal's node index, None when unreachable.  Raises
        :class:`Stopped` when ``stop`` asks."""
        self.nodes.append((-1, 1, 0.0, 0.0, -1))
        self.expand(0)
        while self.heap:
            if self._stopped(stop):
                raise Stopped
            st, k = self._pop()
            j, sj = int(st.j[k]), int(st.sj[k])
            i, si = self.nodes[st.node][:2]
            key = (i, si, j, sj) if j >= 0 else (i, si, -2, 0)
            if key in self.closed or not self.check(st, k):
                continue
            self.closed.add(key)
            g = float(st.g[k])
            # arrival angle: direction from the centre to the tangent point (for a point
            # circle the direction it would have for an infinitesimal radius)
            th = float(st.th_a[k])
            self.nodes.append((j, sj, th, g, st.node))
            if j < 0:
                return len(self.nodes) - 1
            if self.dominated(j, sj, th, g):
                continue
            self.expanded.setdefault((j, sj), []).append((th, g))
            self.expand(len(self.nodes) - 1)
        return None

    def length(self, stop: Callable[[], bool] | None) -> float:
        """:meth:`run`; the length of the path found (``inf`` when none)."""
        self.goal_node = self.run(stop)
        return math.inf if self.goal_node is None else float(self.nodes[self.goal_node][3])

    def visits(self) -> list[tuple[int, int]]:
        """The circles (and senses) the path found by :meth:`length` follows, in order: with
        the start and the goal, all that defines the path
        (:func:`~optplan.geometry.tangent.arc_lines.exact_path` makes its length and polyline)."""
        out = []
        k = self.goal_node if self.goal_node is not None else 0
        while k > 0:
            i, si = self.nodes[k][:2]
            if i >= 0:
                out.append((int(i), int(si)))
            k = self.nodes[k][4]
        return out[::-1]
