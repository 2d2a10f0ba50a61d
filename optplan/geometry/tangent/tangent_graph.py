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

Bounds: the bounds are a wall of the obstacle set
(:func:`~optplan.geometry.collision.obstacles.bounds_wall`), merged with every obstacle that touches
them into one solid (its convex vertices are circles like any other; the bounds' corners are
reflex).  The search is complete and exact on a walled set: its path is the shortest inside the
bounds (certified), and none found proves that no path exists.  On a set built with ``walls=False``
``info["certified"]`` is False.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.geometry.collision import ObstacleSet, solid_edges
from optplan.geometry.tangent.arc_lines import (
    arc_polyline,
    exact_path,
    rebuild_polyline,
    world_polyline,
)
from optplan.geometry.tangent.chain_search import ChainSearch
from optplan.geometry.tangent.circles import ArcChecker, Circles, circles_of
from optplan.geometry.tangent.sightlines import OverBudget, Sightlines
from optplan.geometry.tangent.tangent_chains import ChainGraph, chains_of
from optplan.geometry.tangent.tangent_edges import Edges, cone_off, edges_of_one, tangent_edges
from optplan.geometry.tangent.tangent_search import Stopped, TangentSearch

__all__ = ["TangentPath", "TangentGraph", "tangent_graph", "shortest_path",
           "problem_shortest_path", "arc_polyline"]

#: Default memory bound of the successors a :class:`TangentGraph` stores (bytes).
MAX_GRAPH_BYTES = 256 * 2**20
#: Circles from which a :class:`TangentGraph` filters its tangents by sight lines by default
#: (below it, every circle is a candidate: ``O(n)`` per expansion is cheap there, and the
#: expansion kernels, several seconds of CPU to compile once, are not needed).
SIGHTLINES_MIN = 1000
#: Candidate tangents :meth:`TangentGraph.build` computes in one batch (two batches at a
#: time: bounds its temporary memory to a few hundred MB).
BUILD_PAIRS = 500_000
#: The sight-line work (views of the triangular expansion) ``graph = "auto"`` lets a build
#: run, per circle and in all: past ``VIEWS_PER_CIRCLE n + VIEWS_BASE`` the map is searched
#: lazily (:func:`problem_shortest_path`), so that a first query never pays for a build
#: whose sight lines grow with the square of the circles.  The maps of
#: ``benchmarks/bench_maps_scale.py`` run 34-150 views per circle; a polygon of 20,000
#: vertices round a small circle about 9,000 (``benchmarks/bench_crowded.py``).
VIEWS_PER_CIRCLE = 1000
VIEWS_BASE = 10_000_000


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


class TangentGraph:
    """The tangent graph of one static map and radius: build once, query many.

    Keeps the circles, the exact arc tests, the candidate sight lines
    (:mod:`~optplan.geometry.tangent.sightlines`) and, per circle and sense, the query-independent
    successors (:class:`~optplan.geometry.tangent.tangent_edges.Edges`) with the status of every
    segment tested so far: a query reuses what earlier ones computed, only the start, the
    goal and the A* itself are per query.  Successors are made when a search first expands
    a circle, or all at once, their segments tested in one batch, by :meth:`build`.  A query
    is the search of :func:`shortest_path` (same path and length; segments found blocked
    before are skipped, so ``info["n_checked"]`` may be lower).

    Parameters
    ----------
    oset : ObstacleSet
        Static obstacles and radius.
    circles : Circles, optional
        Precomputed :func:`circles_of`.
    max_bytes : int
        Successors are stored while they hold less memory than this (default
        :data:`MAX_GRAPH_BYTES`); beyond it they are made anew when a search needs them.
    sightlines : bool or None
        Tangents only towards the circles the sight lines of
        :mod:`~optplan.geometry.tangent.sightlines` lists (True), or towards every circle (False:
        each expansion costs ``O(n)``, no kernel to compile).  ``None`` (default) uses them from
        :data:`SIGHTLINES_MIN` circles on.  Both give the same edges, paths and lengths
        (``tests/geometry/test_sightlines.py``).

    Attributes
    ----------
    stats : dict
        ``queries``, ``nodes`` (circle-sense pairs whose successors are stored), ``edges``
        (stored successors), ``segment_tests`` (exact segment tests run); after
        :meth:`build`, ``arc_tests`` (exact arc tests of its chains).
    """

    def __init__(self, oset: ObstacleSet, circles: Circles | None = None,
                 max_bytes: int = MAX_GRAPH_BYTES, sightlines: bool | None = None):
        self.oset = oset
        self.circles = circles_of(oset) if circles is None else circles
        self.use_sightlines = (self.circles.n >= SIGHTLINES_MIN if sightlines is None
                               else bool(sightlines))
        self._all = np.arange(self.circles.n)
        self.arcs = ArcChecker(oset, self.circles)
        self.max_bytes = int(max_bytes)
        self.nbytes = 0  # memory held by the stored successors
        self._edges: dict[tuple[int, int], Edges] = {}
        self._visible: dict[int, np.ndarray] = {}
        self._sight: Sightlines | None = None
        self.chains: ChainGraph | None = None
        self._work: dict = {}
        self.stats: dict[str, Any] = {"queries": 0, "nodes": 0, "edges": 0, "segment_tests": 0}
        self.lock = threading.RLock()  # one query or build at a time (shared work arrays)
        #: A build under a budget ran past it (``graph = "auto"`` searches lazily then).
        self.crowded = False

    @property
    def sightlines(self) -> Sightlines:
        """The candidate sight lines to the polygon-vertex circles (made on first use)."""
        if self._sight is None:
            C = self.circles
            self._pts = np.flatnonzero(~C.full)  # vertex circles: the centres to find
            self._full = np.flatnonzero(C.full)  # circle obstacles: always candidates
            z = C.center[self._pts]
            xy = np.stack([z.real, z.imag], 1)
            self._sight = Sightlines(solid_edges(self.oset), xy, xy, self.oset.eps,
                                     self.oset.frame.local_bounds)
        return self._sight

    def _windows(self, idx: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Directions in which circles ``idx`` may see a tangent's other circle, as windows
        ``(owner, start, width, sense)`` (``owner``: the position in ``idx``).  A point
        (``rho = 0``) leaves perpendicular to a normal of its cone: in sense ``s`` the
        tangent's direction is the departure's normal turned by ``s`` quarter turns, so two
        windows, the cone turned by a quarter turn either way (``1e-7`` rad of slack, beyond
        the cone test's ``ANGLE_TOL``), of senses ``-1`` and ``+1``; any other circle one
        window of all directions and either sense (``0``: an inner tangent of two discs
        leaves at any angle)."""
        C = self.circles
        pt = (C.rho[idx] == 0.0) & ~C.full[idx]
        own = np.concatenate([np.arange(len(idx)), np.flatnonzero(pt)])
        k = idx[own]
        two = np.concatenate([pt, np.ones(int(pt.sum()), bool)])
        sense = np.where(np.arange(len(own)) < len(idx), -1, 1) * two
        lo = np.where(two, C.lo[k] + 0.5 * math.pi * sense - 1e-7, 0.0)
        wd = np.where(two, C.width[k] + 2e-7, 4 * math.pi)
        return own, lo, wd, sense.astype(np.int8)

    def _with_full(self, found: np.ndarray) -> np.ndarray:
        return np.sort(np.concatenate([self._pts[found], self._full]))

    def _seen_keys(self, idx: np.ndarray, senses: bool = False, budget: int | None = None
                   ) -> tuple[np.ndarray, np.ndarray | None]:
        """The circles that circles ``idx`` may see (:meth:`visible`) as keys ``i n + j``, in
        no particular order, each once (the windows of a circle share their stamps), or with
        ``senses`` once per window that sees it, with the window's sense (``-1``, ``+1``;
        ``0``: either); the sources split between two threads (the expansion runs without
        the GIL).  ``budget``: the views the expansion may run (each thread its share, in
        proportion to its sources), past which
        :class:`~optplan.geometry.tangent.sightlines.OverBudget` is raised."""
        own, lo, wd, sense = self._windows(idx)
        order = np.argsort(own, kind="stable")  # a circle's windows one after the other
        own, lo, wd, sense = own[order], lo[order], wd[order], sense[order]
        z = self.circles.center[idx[own]]
        xy = np.stack([z.real, z.imag], 1)
        cut = int(np.searchsorted(own, len(idx) // 2))  # between two circles
        sight = self.sightlines
        group = np.arange(len(own)) if senses else own

        def run(k: slice) -> tuple[np.ndarray, np.ndarray]:
            share = None if budget is None else budget * len(xy[k]) // max(len(xy), 1)
            return sight.candidates_flat(xy[k], lo[k], wd[k], group[k], share)

        if len(own) < 128:  # a few sources (a lazy search's circle): no threads
            halves = [run(slice(None))]
        else:
            with ThreadPoolExecutor(2) as pool:
                halves = list(pool.map(run, [slice(0, cut), slice(cut, None)]))
        counts = np.concatenate([c for c, _ in halves])
        n, m = self.circles.n, len(self._full)
        seen = np.concatenate([self._pts[f] for _, f in halves]
                              + [np.tile(self._full, len(idx))])
        src = np.concatenate([np.repeat(own, counts), np.repeat(np.arange(len(idx)), m)])
        keys = idx[src] * n + seen
        if not senses:
            return keys, None
        return keys, np.concatenate([np.repeat(sense, counts), np.zeros(len(idx) * m, np.int8)])

    def visible(self, i: int) -> np.ndarray:
        """Indices of the circles whose tangents from circle ``i`` may be free (a superset
        of those that are: :mod:`optplan.geometry.tangent.sightlines`), made on first use."""
        if self.circles.full[i] or not self.use_sightlines:
            return self._all  # every circle: one shared array, not a copy per circle
        v = self._visible.get(i)
        if v is None:
            v = np.sort(self._seen_keys(np.array([i]))[0] % self.circles.n)
            self._visible[i] = v
        return v

    def visible_from(self, z: complex) -> np.ndarray:
        """Indices of the circles a tangent from the point ``z`` (local) may reach."""
        if not self.use_sightlines:
            return self._all
        found = self.sightlines.candidates([[z.real, z.imag]], 0.0, 4 * math.pi)[0]
        return self._with_full(found)

    def edges_of(self, i: int, si: int) -> Edges:
        """The successors of circle ``i`` in sense ``si`` (made on first use; stored while
        the stored ones hold less than ``max_bytes``)."""
        e = self._edges.get((i, si))
        if e is None:
            e = edges_of_one(self.circles, i, si, self.visible(i), self.oset.eps)
            self._store(i, si, e)
        return e

    def _store(self, i: int, si: int, e: Edges) -> None:
        if 0 < self.max_bytes and self.nbytes + e.nbytes <= self.max_bytes:
            self._edges[(i, si)] = e
            self.nbytes += e.nbytes
            self.stats["nodes"] += 1
            self.stats["edges"] += len(e.j)

    def build(self, stop: Callable[[], bool] | None = None,
              budget: int | None = None) -> TangentGraph:
        """Make the whole graph now, not only what the searches reach, and search it with
        compiled code from now on; returns ``self``.  ``stop`` (the deadline) is polled
        between the phases and between two steps of two batches; when it asks, the build
        raises :class:`~optplan.geometry.tangent.tangent_search.Stopped` and the graph stays unbuilt
        (lazy: a later :meth:`build` starts again).

        Every free tangent: the sight lines of every circle
        (:mod:`~optplan.geometry.tangent.sightlines`, the sources split between two threads: the
        expansion runs without the GIL), the circle pairs each of which may see the other, each pair
        once, the tangents of the sense pairs of the windows that see across it (:meth:`_batches`:
        one for two points, four for two discs) in vectorised batches (at most :data:`BUILD_PAIRS`
        each, two at a time in two threads), their segments tested in one call of
        :meth:`~optplan.geometry.collision.obstacles.ObstacleSet.pairs_free` per batch (a segment
        that several sense pairs share tested once), the blocked
        ones dropped and each free tangent stored in both directions (travelled backwards, a
        tangent leaves ``j`` in sense ``-s_j`` and reaches ``i`` in sense ``-s_i``).  The free
        tangents become the explicit graph of :mod:`~optplan.geometry.tangent.tangent_chains`
        (``chains``), and every later query is the compiled A* of
        :mod:`~optplan.geometry.tangent.chain_search` (same lengths).  What earlier lazy searches
        stored is dropped; ``max_bytes`` bounds what lazy searches store, not this.
        ``budget``: the views the sight lines may run
        (:meth:`~optplan.geometry.tangent.sightlines.Sightlines.candidates_flat`); past it
        :class:`~optplan.geometry.tangent.sightlines.OverBudget` is raised and the graph
        stays unbuilt (``None``: no bound).
        """
        with self.lock:
            if self.chains is None:
                self._build(stop, budget)
        return self

    def _build(self, stop: Callable[[], bool] | None, budget: int | None) -> None:
        """:meth:`build` (under the lock)."""
        C = self.circles
        t0 = time.perf_counter()
        if self.use_sightlines:
            self.sightlines  # noqa: B018 - the triangulation, timed on its own
        _poll(stop)
        tt = time.perf_counter()
        keys, sense = self._all_keys(budget)
        _poll(stop)
        t1 = time.perf_counter()
        batches, self.stats["build_pairs"] = self._batches(keys, sense)
        del keys, sense
        self._edges, self.nbytes = {}, 0
        self.oset.pairs_free(np.zeros((1, 2)), [0], [0])  # its arrays made before the threads
        made: list[tuple[dict[str, np.ndarray], int]] = []
        with ThreadPoolExecutor(2) as pool:  # two batches at a time, a poll between
            for q in range(0, len(batches), 2):
                _poll(stop)
                made += pool.map(self._free_tangents, batches[q:q + 2])
        _poll(stop)
        self.stats["segment_tests"] += sum(n for _, n in made)
        self._visible = {}  # no longer needed: memory for the chains
        parts = [t for t, _ in made] or [self._free_tangents(np.zeros((0, 4), np.int64))[0]]
        del made
        t = {k: np.concatenate([p.pop(k) for p in parts]) for k in list(parts[0])}
        del parts
        self.stats["nodes"] = 2 * C.n
        self.stats["edges"] = len(t["j"])
        t2 = time.perf_counter()
        self.chains = chains_of(C, t, self.arcs)
        self.stats["build_wall_s"] = {"triangulation": tt - t0, "sightlines": t1 - tt,
                                      "tangents": t2 - t1,
                                      "chains": time.perf_counter() - t2}
        self.nbytes = self.chains.nbytes
        self.stats["arc_tests"] = self.chains.arc_tests

    def _all_keys(self, budget: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Every circle's :meth:`visible` circles as keys ``i n + j``, once per window that
        sees them, and the window's sense (``0``: either; circle obstacles see every circle
        in either sense)."""
        C = self.circles
        n = C.n
        if not self.use_sightlines:
            return np.arange(n * n), np.zeros(n * n, np.int8)
        full = np.flatnonzero(C.full)
        every = np.repeat(full, n) * n + np.tile(np.arange(n), len(full))
        keys, sense = self._seen_keys(np.flatnonzero(~C.full), senses=True, budget=budget)
        assert sense is not None
        return np.r_[keys, every], np.r_[sense, np.zeros(len(every), np.int8)]

    def _batches(self, keys: np.ndarray, sense: np.ndarray) -> tuple[list[np.ndarray], int]:
        """The tangents to try, rows ``(i, s_i, j, s_j)`` with ``i < j``, of the circle pairs
        each of which may see the other, in an even number of batches (two threads) of at
        most :data:`BUILD_PAIRS` rows (bounded memory), and the number of such pairs.

        ``keys``: ``a`` may see ``b`` (``a n + b``) in a window of sense ``sense`` (``0``:
        either).  A tangent from ``i`` in sense ``s_i`` to ``j`` in sense ``s_j`` leaves
        ``i`` in a direction of its window of sense ``s_i`` and, travelled backwards, leaves
        ``j`` in sense ``-s_j`` (:meth:`_windows`), so each pair gets the sense pairs of the
        windows that see across it: one for two points, four for two discs.
        """
        n = self.circles.n
        a, b = keys // n, keys % n
        keep = a != b
        a, b, s = a[keep], b[keep], sense[keep].astype(np.int64)
        up = a > b  # listed from the pair's upper end: that end's arrival sense is -s
        two = s == 0  # either sense: both
        s = np.where(up, -s, s)
        code = ((np.minimum(a, b) * n + np.maximum(a, b)) * 2 + up) * 2
        code = np.sort(np.r_[code + (s > 0), code[two] + 1])  # (np.unique: 20x slower)
        first = np.ones(len(code), bool)
        first[1:] = code[1:] != code[:-1]
        code = code[first]
        pk, side, sg = code >> 2, (code >> 1) & 1, 2 * (code & 1) - 1
        start = np.flatnonzero(np.r_[len(pk) > 0, pk[1:] != pk[:-1]])
        c0 = np.add.reduceat(1 - side, start) if len(start) else start
        c1 = np.diff(np.r_[start, len(pk)]) - c0
        ok = (c0 > 0) & (c1 > 0)  # seen from both ends
        start, c0, c1 = start[ok], c0[ok], c1[ok]
        nr = c0 * c1  # each departure sense with each arrival sense
        g = np.repeat(np.arange(len(start)), nr)
        r = np.arange(int(nr.sum())) - np.repeat(np.cumsum(nr) - nr, nr)
        e0, e1 = start[g] + r // c1[g], start[g] + c0[g] + r % c1[g]
        rows = np.stack([pk[e0] // n, sg[e0], pk[e0] % n, sg[e1]], axis=1)
        parts = 2 * -(-len(rows) // (2 * BUILD_PAIRS))
        return [p for p in np.array_split(rows, max(parts, 2)) if len(p)], len(start)

    def _free_tangents(self, rows: np.ndarray) -> tuple[dict[str, np.ndarray], int]:
        """The free tangents among ``rows`` (``(i, s_i, j, s_j)``, :meth:`_batches`) in both
        directions (:func:`~optplan.geometry.tangent.tangent_edges.tangent_edges`, the segments
        tested) and the number of segments tested (counted by the caller: this runs in a
        thread)."""
        t = tangent_edges(self.circles, rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3],
                          self.oset.eps)
        # rows of one pair are adjacent: test a segment once where they share it
        new = np.ones(len(t["i"]), bool)
        new[1:] = ((t["i"][1:] != t["i"][:-1]) | (t["j"][1:] != t["j"][:-1])
                   | (t["pi"][1:] != t["pi"][:-1]) | (t["pj"][1:] != t["pj"][:-1]))
        first = np.flatnonzero(new)
        free = self._segments_free(t["pi"][first], t["pj"][first])[np.cumsum(new) - 1]
        t = {k: v[free] for k, v in t.items()}
        back = {"i": t["j"], "si": -t["sj"], "j": t["i"], "sj": -t["si"], "seg": t["seg"],
                "pi": t["pj"], "pj": t["pi"], "th_d": t["th_a"], "th_a": t["th_d"],
                "od": cone_off(self.circles, t["j"], t["th_a"])}
        return {k: np.concatenate([t[k], back[k]]) for k in t}, len(first)

    def _segments_free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Exact tests of the segments ``a[k] -> b[k]`` (local complex), in one batch."""
        pts = self.oset.frame.world(np.stack([np.r_[a.real, b.real], np.r_[a.imag, b.imag]],
                                             axis=1))
        n = len(a)
        return self.oset.pairs_free(pts, np.arange(n), np.arange(n, 2 * n))

    def shortest_path(self, start, goal, *, arc_step: float = math.pi / 36,
                      stop: Callable[[], bool] | None = None) -> TangentPath:
        """:func:`shortest_path` from ``start`` to ``goal`` (world) on this graph (one query
        at a time: threads that share the graph wait for each other)."""
        with self.lock:
            self.stats["queries"] += 1
            return shortest_path(self.oset, start, goal, graph=self, arc_step=arc_step,
                                 stop=stop)


def tangent_graph(oset: ObstacleSet) -> TangentGraph:
    """The :class:`TangentGraph` of ``oset``, made once and kept with it (every query on the
    same obstacle set, also through :func:`problem_shortest_path`, shares it)."""
    g = oset._cache.get("tangent_graph")
    if g is None:
        g = oset._cache["tangent_graph"] = TangentGraph(oset)
    return g


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
    search: TangentSearch | ChainSearch
    if graph.chains is not None:
        search = ChainSearch(graph, graph.chains, graph._work, zs, zg, info)
    else:
        search = TangentSearch(oset, C, zs, zg, info, graph)
    try:
        length = search.length(stop)
    except Stopped:
        info["reason"] = "stopped before the search finished"
        info["stopped"] = True
        return TangentPath(math.inf, None, [], info)
    if not math.isfinite(length):
        info["reason"] = "the goal is not reachable from the start"
        return TangentPath(math.inf, None, [], info)
    # the path's length and polyline from its circles, the same way for both searches
    length, z, wps = exact_path(C, zs, zg, search.visits(), arc_step)
    info["certified"] = bool(oset.walled)
    return TangentPath(length, world_polyline(fr, z, start, goal), wps, info)


def _poll(stop: Callable[[], bool] | None) -> None:
    """Raise :class:`~optplan.geometry.tangent.tangent_search.Stopped` when ``stop`` asks."""
    if stop is not None and stop():
        raise Stopped


class _Uncached(Exception):
    """A search stopped by its ``stop`` callback: its partial result is not cached."""
    def __init__(self, result: TangentPath):
        super().__init__("stopped")
        self.result = result


def problem_shortest_path(problem, robot, known_only: bool = True,
                          arc_step: float = math.pi / 36,
                          stop: Callable[[], bool] | None = None,
                          build: bool | None = None) -> TangentPath:
    """:func:`shortest_path` of ``robot`` on ``problem``'s static map, cached per problem.

    ``known_only``: plan on the known obstacles only (the map a global planner sees).  The
    obstacle set is walled (the bounds are a wall), so a path found is the certified shortest
    path inside the bounds and none found proves that no path exists.  The search runs on
    the map's graph (:func:`tangent_graph`), which every problem with the same static map
    shares in the process (:mod:`optplan.problem.shared`).  ``build``: make the whole graph
    first (:meth:`TangentGraph.build`, once per map; ``stop`` is polled by the build too) and
    search it compiled (True), or search it lazily (False); ``None`` (default) builds it on
    maps of :data:`SIGHTLINES_MIN` circles or more (where the sight lines make the build
    cheap and a lazy query slow: ``benchmarks/bench_maps_scale.py``) unless the circles
    crowd together: a build whose sight lines run past ``VIEWS_PER_CIRCLE n + VIEWS_BASE``
    views stops there (:class:`~optplan.geometry.tangent.sightlines.OverBudget`) and the
    map is searched lazily from then on (``graph.crowded``); smaller maps are searched
    lazily (no build, no compiled kernel).  The choice depends on the map only (the budget
    counts views, not seconds); both searches give the same path and bits but where
    shortest paths tie (``tests/geometry/test_chain_search.py``).
    """

    def plan() -> TangentPath:
        oset = problem.obstacle_set(robot.radius, known_only=known_only)
        graph = tangent_graph(oset)
        if build or (build is None and graph.use_sightlines and not graph.crowded):
            budget = (None if build else
                      VIEWS_PER_CIRCLE * graph.circles.n + VIEWS_BASE)
            try:
                graph.build(stop, budget)
            except OverBudget:  # crowded circles: searched lazily, now and later
                graph.crowded = True
            except Stopped:  # not cached: a later call builds the graph
                raise _Uncached(TangentPath(math.inf, None, [], {
                    "n_circles": graph.circles.n, "certified": False, "stopped": True,
                    "reason": "stopped before the graph was built"})) from None
        res = graph.shortest_path(robot.start, robot.goal, arc_step=arc_step, stop=stop)
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
        return problem.memo(("tangent_path", robot.id, bool(known_only), float(arc_step),
                             build), plan)
    except _Uncached as e:
        return e.result
