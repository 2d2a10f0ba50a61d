r"""Arc-exact shortest path of a disc robot: A* over the tangent visibility graph.

Mathematics
-----------
A disc of radius ``r`` may be centred at ``x`` iff ``dist(x, O) >= r`` for every obstacle ``O``;
its configuration-space obstacles are the Minkowski sums ``O + disc(r)``: polygons grow into
rounded polygons (edges offset by ``r``, joined by arcs of radius ``r`` around the *convex*
vertices), a circle of radius ``R`` grows to ``R + r``.  A shortest path of the centre consists of
straight segments tangent to these arcs and arcs along them (Lozano-Pérez & Wesley 1979 for points;
Chew 1985; Liu & Arimoto 1992, the *tangent graph*).  Reflex vertices never touch a shortest path.

Construction (edges are generated when a node is expanded, and kept by a :class:`TangentGraph`):

* **Circles**: radius ``r`` at every convex vertex of every polygon ring (holes included), with
  its *normal cone* (the directions between the outward normals of the two edges); radius
  ``R + r`` around every circle obstacle (all directions).  Start and goal are circles of radius 0.
  For ``r = 0`` the circles are points: the classic visibility graph.
* **Tangents**: travelling around circle ``i`` with sense ``s_i`` (+1 counter-clockwise) and
  leaving towards circle ``j`` reached with sense ``s_j``, the unique common tangent has left
  normal ``n = exp(i beta)``, ``beta = arg(c_j - c_i) + arccos(delta / d)``, with
  ``delta = s_j rho_j - s_i rho_i`` and ``d = |c_j - c_i| > |delta|``; its tangent points are
  ``c - s rho n`` and its length ``sqrt(d^2 - delta^2)``.
* **Local filter**: a tangent point on a vertex circle must lie in the vertex's normal cone, and
  the arc from the arrival to the departure point (in the travel sense) must stay inside it;
  otherwise the path would cut into an offset edge.  This is the bitangent filter of the reduced
  visibility graph and removes most candidates.
* **Exact checks**: every tangent segment is tested with the exact segment predicate of
  :class:`~optplan.geometry.ObstacleSet`; every arc with an exact arc-to-segment / arc-to-circle
  distance against the items near its circle.
* **Search**: A* (Euclidean heuristic, consistent) with lazy edges: the successors of an
  expanded node, sorted by ``f = g + h``, are checked only when the cheapest open candidate.
  An arrival is dominated (not expanded) when an earlier expanded arrival on the same circle
  and sense reaches it along a free arc at no greater cost.
* **Build once, query many**: the successors of a circle and sense (the tangents that pass
  both cones) and the status of their segments do not depend on the query: a
  :class:`TangentGraph` keeps them (up to a memory bound) for the later queries on the map.

The length is exact up to round-off (segments plus arcs ``rho * angle``).  The returned polyline
replaces each arc by a *circumscribed* polyline (vertices outside the circle, every chord tangent
to it), so it stays ``>= r`` from the obstacle; its length is slightly larger and is reported
apart.

Bounds: the bounds are a wall of the obstacle set (:func:`~optplan.geometry.obstacles.bounds_wall`),
merged with every obstacle that touches them into one solid (its convex vertices are circles
like any other; the bounds' corners are reflex).  The search is complete and exact on a walled
set: its path is the shortest inside the bounds (certified), and none found proves that no path
exists.  On a set built with ``walls=False`` ``info["certified"]`` is False.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.geometry.arc_lines import arc_polyline, rebuild_polyline
from optplan.geometry.circles import ANGLE_TOL, TWO_PI, ArcChecker, Circles, circles_of
from optplan.geometry.obstacles import ObstacleSet

__all__ = ["TangentPath", "TangentGraph", "tangent_graph", "shortest_path",
           "problem_shortest_path", "arc_polyline"]

#: Default memory bound of the successors a :class:`TangentGraph` stores (bytes).
MAX_GRAPH_BYTES = 256 * 2**20


@dataclass(frozen=True)
class TangentPath:
    """Result of :func:`shortest_path` (world coordinates).

    Attributes
    ----------
    length : float
        Exact length (segments + arcs) of the shortest path, ``inf`` when none exists.
    polyline : numpy.ndarray or None
        ``(m, 2)``: the path with each arc replaced by a circumscribed polyline.
    waypoints : list
        Per circle visited: ``(centre, radius, angle_in, sweep, sense)`` (local angles).
    info : dict
        ``n_circles``, ``n_expanded``, ``n_generated``, ``n_checked``, ``reason``,
        ``certified`` (a path on a walled set: the shortest path inside the bounds).
    """

    length: float
    polyline: np.ndarray | None
    waypoints: list
    info: dict


class _Stream:
    """Sorted successor candidates of one expanded node."""

    __slots__ = ("node", "f", "g", "j", "sj", "pi", "pj", "th_d", "th_a", "sweep", "ok", "pos",
                 "checked", "edges", "eidx")

    def __init__(self, node, f, g, j, sj, pi, pj, th_d, th_a, sweep, edges=None, eidx=None):
        order = np.argsort(f, kind="stable")
        self.node = node
        self.f, self.g, self.j, self.sj = f[order], g[order], j[order], sj[order]
        self.pi, self.pj, self.th_d, self.th_a = pi[order], pj[order], th_d[order], th_a[order]
        self.sweep = sweep[order]
        self.ok = np.zeros(len(order), np.int8)  # 0 unknown, 1 free, -1 blocked
        self.pos = 0
        self.checked = 0
        # the query-independent edges the candidates come from (index -1: the goal)
        self.edges: _Edges | None = edges
        self.eidx = None if eidx is None else eidx[order]


class _Edges:
    """The query-independent successors of circle ``i`` in sense ``si``: the tangents to the
    other circles (both senses) that pass both cones, with their segment status (``ok``: 0
    unknown, 1 free, -1 blocked; filled in by the searches); ``pi`` is None for a point."""

    __slots__ = ("j", "sj", "seg", "pi", "pj", "th_d", "th_a", "od", "ok")

    def __init__(self, j, sj, seg, pi, pj, th_d, th_a, od):
        self.j, self.sj, self.seg, self.pi, self.pj, self.th_d = j, sj, seg, pi, pj, th_d
        self.th_a, self.od, self.ok = th_a, od, np.zeros(len(j), np.int8)

    @property
    def nbytes(self) -> int:
        return sum(getattr(getattr(self, k), "nbytes", 0) for k in self.__slots__)


class _Search:
    """State of one A* search over the tangent graph (see :func:`shortest_path`).

    Nodes are arrival states ``(circle, sense, arrival angle, g, pred, seg)``; the successors
    of an expanded node form one :class:`_Stream` sorted by ``f``, consumed lazily.
    """

    def __init__(self, oset: ObstacleSet, C: Circles, zs: complex, zg: complex, info: dict,
                 graph: TangentGraph | None = None):
        self.oset, self.C, self.zs, self.zg = oset, C, zs, zg
        self.fr = oset.frame
        self.eps = self.fr.eps
        self.info = info
        self.graph = TangentGraph(oset, C) if graph is None else graph  # None: a one-off
        self.arcs = self.graph.arcs
        self.box = self.fr.local_bounds
        self.n = C.n
        self.cen, self.rho, self.lo, self.width, self.full = (C.center, C.rho, C.lo, C.width,
                                                              C.full)
        self.nodes: list[tuple] = []
        self.closed: set = set()
        self.expanded: dict = {}  # (circle, sense) -> list of (theta, g)
        self.heap: list = []
        self.streams: list[_Stream] = []
        self.all_j = np.arange(self.n)
        self.senses = np.array([1, -1])
        self._pairs: tuple | None = None  # every circle in both senses (:meth:`edges`)

    def cone_off(self, k, th):
        """Offset of angle ``th`` from the cone start of circle(s) ``k``, or nan outside."""
        full, width = self.full, self.width
        off = np.mod(th - self.lo[k], TWO_PI)
        off = np.where(off > TWO_PI - ANGLE_TOL, 0.0, off)  # just below lo: on the boundary
        ok = full[k] | (off <= width[k] + ANGLE_TOL)
        return np.where(ok, np.minimum(off, np.where(full[k], off, width[k])), np.nan)

    def _candidates(self, i: int, si: int, ci: complex, ri: float, circles: bool = True,
                    goal: bool = True):
        """Tangents from circle ``i`` (sense ``si``; ``i < 0``: the start point) to every
        other circle with both senses (``circles``) and to the goal (``goal``).

        Returns ``jj, sj, dd, delta, nl, pj, th_arr`` (target circle, its sense, centre
        distance, radius difference, tangent normal, arrival point and angle) for the
        geometrically possible tangents (``|c_j - c_i| > |delta|``).
        """
        n = self.n if circles else 0
        g = 1 if goal else 0
        jj = np.concatenate([np.repeat(self.all_j[:n], 2), np.full(g, -2, np.int64)])
        sj = np.concatenate([np.tile(self.senses, n), np.ones(g, np.int64)])
        cj = np.concatenate([np.repeat(self.cen[:n], 2), [self.zg] * g])
        rj = np.concatenate([np.repeat(self.rho[:n], 2), [0.0] * g])
        if i >= 0:
            keep = jj != i
            jj, sj, cj, rj = jj[keep], sj[keep], cj[keep], rj[keep]
        D = cj - ci
        dd = np.abs(D)
        delta = sj * rj - (si * ri if i >= 0 else 0.0)
        ok = dd > np.abs(delta) + self.eps * 1e-3
        jj, sj, cj, rj, D, dd, delta = (x[ok] for x in (jj, sj, cj, rj, D, dd, delta))
        beta = np.angle(D) + np.arccos(np.clip(delta / dd, -1.0, 1.0))
        nl = np.exp(1j * beta)
        pj = cj - sj * rj * nl
        th_arr = np.angle(-sj * nl)
        return jj, sj, dd, delta, nl, pj, th_arr

    def _departures(self, i: int, si: int, th_a: float, ci: complex, ri: float, nl):
        """Departure points on circle ``i``, their angles, the arc swept from the arrival
        angle ``th_a`` and whether that arc stays in the cone: ``pi, th_d, sweep, ok``."""
        m = len(nl)
        if i < 0:
            return np.full(m, ci), np.zeros(m), np.zeros(m), np.ones(m, bool)
        pi = ci - si * ri * nl
        th_d = np.angle(-si * nl)
        # departure point in the cone of circle i and the arc from th_a to th_d inside it
        od = self.cone_off(np.full(len(th_d), i), th_d)
        sweep = self._sweep(i, si, th_a, th_d, od)
        ok = np.isfinite(od) & (sweep >= 0)
        return pi, th_d, sweep, ok

    def _sweep(self, i: int, si: int, th_a: float, th_d, od):
        """Arc swept on circle ``i`` (sense ``si``) from the arrival angle ``th_a`` to the
        departure angles ``th_d`` (cone offsets ``od``); negative or nan: not in the cone."""
        if self.full[i]:
            sweep = np.mod((th_d - th_a) * si, TWO_PI)
            return np.where(sweep > TWO_PI - ANGLE_TOL, 0.0, sweep)
        oa = float(self.cone_off(np.array([i]), np.array([th_a]))[0])
        sweep = (od - oa) * si
        return np.where((sweep < 0) & (sweep > -ANGLE_TOL), 0.0, sweep)

    def edges(self, i: int, si: int) -> _Edges:
        """The query-independent successors of circle ``i`` in sense ``si`` (module
        :class:`_Edges`): the tangents of :meth:`_candidates` to the other circles that pass
        both cones (the departure cone tested first, on fewer candidates; same values)."""
        if self._pairs is None:
            self._pairs = (np.repeat(self.all_j, 2), np.tile(self.senses, self.n),
                           np.repeat(self.cen, 2), np.repeat(self.rho, 2))
        jj, sj, cj, rj = self._pairs
        ci, ri = self.cen[i], float(self.rho[i])
        D = cj - ci
        dd = np.abs(D)
        delta = sj * rj - si * ri
        idx = np.flatnonzero((jj != i) & (dd > np.abs(delta) + self.eps * 1e-3))
        nl = np.exp(1j * (np.angle(D[idx]) + np.arccos(np.clip(delta[idx] / dd[idx], -1.0,
                                                                 1.0))))
        th_d = np.angle(-si * nl)
        od = self.cone_off(np.full(len(th_d), i), th_d)
        k = np.flatnonzero(np.isfinite(od))
        idx, nl, th_d, od = idx[k], nl[k], th_d[k], od[k]
        pj = cj[idx] - sj[idx] * rj[idx] * nl
        th_arr = np.angle(-sj[idx] * nl)
        k = np.flatnonzero(np.isfinite(self.cone_off(jj[idx], th_arr)))
        idx = idx[k]
        seg = np.sqrt(np.maximum(dd[idx] ** 2 - delta[idx] ** 2, 0.0))
        pi = (ci - si * ri * nl[k]) if ri > 0 else None
        return _Edges(jj[idx].astype(np.int32), sj[idx].astype(np.int8), seg, pi, pj[k],
                      th_d[k], th_arr[k], od[k])

    def expand(self, node_id: int) -> None:
        """Generate the successors of node ``node_id`` as a new stream."""
        i, si, th_a, g0 = self.nodes[node_id][:4]
        self.info["n_expanded"] += 1
        if i < 0:  # the start: a point
            ci, ri = self.zs, 0.0
        else:
            ci, ri = self.cen[i], self.rho[i]
        start = i < 0
        jj, sj, dd, delta, nl, pj, th_arr = self._candidates(i, si, ci, ri, circles=start)
        pi, th_d, sweep, ok = self._departures(i, si, th_a, ci, ri, nl)
        if start and self.n:  # arrival point in the cone of circle j (the goal has none)
            isg = jj < 0
            ok &= isg | np.isfinite(self.cone_off(np.where(isg, 0, jj), th_arr))
        seg = np.sqrt(np.maximum(dd * dd - delta * delta, 0.0))
        edges = eidx = None
        if not start:  # the circles' tangents from the graph, the goal's from above
            edges = self.graph.edges_of(self, i, si)
            sw = self._sweep(i, si, th_a, edges.th_d, edges.od)
            pie = edges.pi if edges.pi is not None else np.full(len(edges.j), ci)
            jj, sj = np.concatenate([edges.j, jj]), np.concatenate([edges.sj, sj])
            seg, pi = np.concatenate([edges.seg, seg]), np.concatenate([pie, pi])
            pj, th_d = np.concatenate([edges.pj, pj]), np.concatenate([edges.th_d, th_d])
            th_arr, sweep = np.concatenate([edges.th_a, th_arr]), np.concatenate([sw, sweep])
            ok = np.concatenate([sw >= 0, ok])
            eidx = np.concatenate([np.arange(len(edges.j)), np.full(len(dd), -1)])
        g = g0 + ri * sweep + seg
        f = g + np.abs(pj - self.zg)
        self.info["n_generated"] += int(np.count_nonzero(ok))
        if edges is not None:  # a segment an earlier search found blocked is never a step
            ok[:len(edges.j)] &= edges.ok != -1
        sel = np.flatnonzero(ok)
        if sel.size == 0:
            return
        st = _Stream(node_id, f[sel], g[sel], jj[sel], sj[sel], pi[sel], pj[sel], th_d[sel],
                     th_arr[sel], sweep[sel], edges, None if eidx is None else eidx[sel])
        self.streams.append(st)
        heapq.heappush(self.heap, (float(st.f[0]), len(self.streams) - 1))

    def check(self, st: _Stream, k: int) -> bool:
        """Exact checks of candidate ``k`` of ``st`` (and a batch after it)."""
        if st.ok[k] == 0:
            b = min(len(st.f), k + max(8, st.checked))
            idx = np.arange(k, b)
            idx = idx[st.ok[idx] == 0]
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

    def _segments_free(self, st: _Stream, idx: np.ndarray) -> np.ndarray:
        """Exact segment tests of candidates ``idx`` of ``st``; the status of a graph edge
        tested by an earlier search is reused, a new one is stored."""
        known = np.zeros(len(idx), np.int8)
        if st.edges is not None and st.eidx is not None:
            e = st.eidx[idx]
            known[e >= 0] = st.edges.ok[e[e >= 0]]
        todo = idx[known == 0]
        pi_w = self.fr.world(np.stack([st.pi[todo].real, st.pi[todo].imag], axis=1))
        pj_w = self.fr.world(np.stack([st.pj[todo].real, st.pj[todo].imag], axis=1))
        tested = self.oset.segment_free(pi_w, pj_w)
        self.graph.stats["segment_tests"] += len(todo)
        if st.edges is not None and st.eidx is not None:
            e = st.eidx[todo]
            st.edges.ok[e[e >= 0]] = np.where(tested[e >= 0], 1, -1)
        free = known == 1
        free[known == 0] = tested
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

    def _pop(self) -> tuple[_Stream, int]:
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
        :class:`_Stopped` when ``stop`` asks."""
        self.nodes.append((-1, 1, 0.0, 0.0, -1, None))
        self.expand(0)
        while self.heap:
            if self._stopped(stop):
                raise _Stopped
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
            self.nodes.append((j, sj, th, g, st.node, (st.pi[k], st.pj[k], float(st.th_d[k]),
                                                       float(st.sweep[k]))))
            if j < 0:
                return len(self.nodes) - 1
            if self.dominated(j, sj, th, g):
                continue
            self.expanded.setdefault((j, sj), []).append((th, g))
            self.expand(len(self.nodes) - 1)
        return None

    def polyline(self, goal_node: int, arc_step: float):
        """Local-frame points of the path ending at ``goal_node`` (arcs as circumscribed
        polylines) and its waypoints ``(centre, rho, arrival angle, sweep, sense)``."""
        chain = []
        k = goal_node
        while k > 0:
            chain.append(self.nodes[k])
            k = self.nodes[k][4]
        chain.reverse()
        cen, rho = self.cen, self.rho
        pts = [self.zs]
        wps = []
        for idx, nd in enumerate(chain):
            pi_, pj_, th_d, sweep = nd[5]
            if idx > 0:
                prev = chain[idx - 1]
                i, si, th_a = prev[0], prev[1], prev[2]
                if rho[i] > 0 and sweep > 0:
                    pts.extend(arc_polyline(cen[i], rho[i], th_a, sweep * si, arc_step)[1:-1])
                wps.append((cen[i], float(rho[i]), th_a, sweep, si))
                pts.append(pi_)
            pts.append(pj_)
        return np.array(pts), wps


class TangentGraph:
    """The tangent graph of one static map and radius: build once, query many.

    Keeps the circles, the exact arc tests and, per circle and sense, the query-independent
    successors (:class:`_Edges`) with the status of every segment tested so far: a query
    reuses what earlier ones computed, only the start, the goal and the A* itself are per
    query.  Successors are made when a search first expands a circle (all: :meth:`build`).
    A query is the search of :func:`shortest_path` (same path and length; segments found
    blocked before are skipped, so ``info["n_checked"]`` may be lower).

    Parameters
    ----------
    oset : ObstacleSet
        Static obstacles and radius.
    circles : Circles, optional
        Precomputed :func:`circles_of`.
    max_bytes : int
        Successors are stored while they hold less memory than this (default
        :data:`MAX_GRAPH_BYTES`); beyond it they are made anew when a search needs them.

    Attributes
    ----------
    stats : dict
        ``queries``, ``nodes`` (circle-sense pairs whose successors are stored), ``edges``
        (stored successors), ``segment_tests`` (exact segment tests run).
    """

    def __init__(self, oset: ObstacleSet, circles: Circles | None = None,
                 max_bytes: int = MAX_GRAPH_BYTES):
        self.oset = oset
        self.circles = circles_of(oset) if circles is None else circles
        self.arcs = ArcChecker(oset, self.circles)
        self.max_bytes = int(max_bytes)
        self.nbytes = 0  # memory held by the stored successors
        self._edges: dict[tuple[int, int], _Edges] = {}
        self.stats = {"queries": 0, "nodes": 0, "edges": 0, "segment_tests": 0}

    def edges_of(self, search: _Search, i: int, si: int) -> _Edges:
        """The successors of circle ``i`` in sense ``si`` (made on first use; stored while
        the stored ones hold less than ``max_bytes``)."""
        e = self._edges.get((i, si))
        if e is None:
            e = search.edges(i, si)
            if 0 < self.max_bytes and self.nbytes + e.nbytes <= self.max_bytes:
                self._edges[(i, si)] = e
                self.nbytes += e.nbytes
                self.stats["nodes"] += 1
                self.stats["edges"] += len(e.j)
        return e

    def build(self) -> TangentGraph:
        """Make the successors of every circle and sense now (not only when a search
        reaches them); returns ``self``."""
        search = _Search(self.oset, self.circles, 0j, 0j, {}, self)
        for i in range(self.circles.n):
            for si in (1, -1):
                self.edges_of(search, i, si)
        return self

    def shortest_path(self, start, goal, *, arc_step: float = math.pi / 36,
                      stop: Callable[[], bool] | None = None) -> TangentPath:
        """:func:`shortest_path` from ``start`` to ``goal`` (world) on this graph."""
        self.stats["queries"] += 1
        return shortest_path(self.oset, start, goal, graph=self, arc_step=arc_step, stop=stop)


def tangent_graph(oset: ObstacleSet) -> TangentGraph:
    """The :class:`TangentGraph` of ``oset``, made once and kept with it (every query on the
    same obstacle set, also through :func:`problem_shortest_path`, shares it)."""
    g = oset._cache.get("tangent_graph")
    if g is None:
        g = oset._cache["tangent_graph"] = TangentGraph(oset)
    return g


class _Stopped(Exception):
    """The ``stop`` callback of :func:`shortest_path` ended the search."""


def shortest_path(oset: ObstacleSet, start, goal, *, circles: Circles | None = None,
                  arc_step: float = math.pi / 36,
                  stop: Callable[[], bool] | None = None,
                  graph: TangentGraph | None = None) -> TangentPath:
    """Arc-exact shortest path of a disc of radius ``oset.radius`` from ``start`` to ``goal``.

    Parameters
    ----------
    oset : ObstacleSet
        Static obstacles and radius (:meth:`optplan.problem.Problem.obstacle_set`).
    start, goal : array-like ``(2,)``
        World coordinates.
    circles : Circles, optional
        Precomputed :func:`circles_of` (reused across queries).
    graph : TangentGraph, optional
        The map's graph (:func:`tangent_graph`): its circles and stored successors are
        reused, and what this search computes is stored for later queries.  Default: a
        graph of this search only (on ``circles`` or :func:`circles_of`).
    arc_step : float
        Largest angle (rad) spanned by one chord of the circumscribed arc polylines.
    stop : callable, optional
        Polled every 64 expansions; when it returns True the search ends without a path
        (``info["reason"]`` says so, ``info["stopped"]`` is True).

    Returns
    -------
    TangentPath
    """
    fr = oset.frame
    s_loc = fr.local(np.asarray(start, float))
    g_loc = fr.local(np.asarray(goal, float))
    zs, zg = complex(s_loc[0], s_loc[1]), complex(g_loc[0], g_loc[1])
    graph = TangentGraph(oset, circles) if graph is None else graph
    C = graph.circles
    info: dict[str, Any] = {"n_circles": C.n, "n_expanded": 0, "n_generated": 0, "n_checked": 0,
            "certified": False}
    why = oset.ends_problem(start, goal)
    if why is not None:
        info["reason"] = why
        return TangentPath(math.inf, None, [], info)
    if abs(zg - zs) <= fr.eps:  # start = goal: the empty path
        info["certified"] = bool(oset.walled)
        poly = np.vstack([np.asarray(start, float), np.asarray(goal, float)])
        return TangentPath(0.0, poly, [], info)
    search = _Search(oset, C, zs, zg, info, graph)
    try:
        goal_node = search.run(stop)
    except _Stopped:
        info["reason"] = "stopped before the search finished"
        info["stopped"] = True
        return TangentPath(math.inf, None, [], info)
    if goal_node is None:
        info["reason"] = "the goal is not reachable from the start"
        return TangentPath(math.inf, None, [], info)
    length = float(search.nodes[goal_node][3])
    z, wps = search.polyline(goal_node, arc_step)
    poly = fr.world(np.stack([z.real, z.imag], axis=1))
    keep = np.r_[True, np.any(np.diff(poly, axis=0) != 0, axis=1)]
    poly = poly[keep]
    poly[0], poly[-1] = np.asarray(start, float), np.asarray(goal, float)
    info["certified"] = bool(oset.walled)
    return TangentPath(length, poly, wps, info)


class _Uncached(Exception):
    """A search stopped by its ``stop`` callback: its partial result is not cached."""
    def __init__(self, result: TangentPath):
        super().__init__("stopped")
        self.result = result


def problem_shortest_path(problem, robot, known_only: bool = True,
                          arc_step: float = math.pi / 36,
                          stop: Callable[[], bool] | None = None) -> TangentPath:
    """:func:`shortest_path` of ``robot`` on ``problem``'s static map, cached per problem.

    ``known_only``: plan on the known obstacles only (the map a global planner sees).  The
    obstacle set is walled (the bounds are a wall), so a path found is the certified shortest
    path inside the bounds and none found proves that no path exists.
    """

    def build() -> TangentPath:
        oset = problem.obstacle_set(robot.radius, known_only=known_only)
        res = tangent_graph(oset).shortest_path(robot.start, robot.goal, arc_step=arc_step,
                                                stop=stop)
        if res.info.get("stopped"):
            raise _Uncached(res)  # a later call without a stop must finish the search
        if res.polyline is not None:
            # the circumscribed arcs stay >= r from the arc's own obstacle; refine where they
            # come too close to a neighbour
            step = arc_step
            for _ in range(4):
                if oset.crossings(res.polyline[None]).count[0] == 0:
                    break
                step /= 4
                res = TangentPath(res.length, rebuild_polyline(res.waypoints, problem.frame,
                                                               robot, step),
                                  res.waypoints, res.info)
        return res

    try:
        return problem.memo(("tangent_path", robot.id, bool(known_only), float(arc_step)),
                            build)
    except _Uncached as e:
        return e.result
