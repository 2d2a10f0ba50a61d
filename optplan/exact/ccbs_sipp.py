r"""The low level of ``ccbs``: safe-interval path planning for one robot on a straight-line graph.

The robot (a disc: ``radius``, full speed ``speed``) drives along the graph's edges at full
speed and waits at its nodes for any duration; it must reach its goal node and stay there for
ever.  Its *constraints* (from the high level, :mod:`optplan.exact.ccbs`) are

* vertex constraints ``(v, [t1, t2))``: the robot is not at node ``v`` at any time of
  ``[t1, t2)`` (it may arrive at ``t2``); it may not leave ``v`` in ``[t1, t2)`` either;
* edge constraints ``(u -> v, [t1, t2))``: the robot does not depart along ``u -> v`` at a time
  of ``[t1, t2)``;
* positive constraints ``(u -> v, [t1, t2))`` (disjoint splitting): the robot departs along
  ``u -> v`` at least once at a time of ``[t1, t2)``;
* a hold constraint ``hold_from``: the robot's final arrival at its goal (where it then stays
  for ever) is at or after ``hold_from`` (it may pass through its goal before);

and the moving obstacles are hard constraints: their busy times at a node
(:meth:`~optplan.exact.sipp_graph.MoverBoxes.parked_busy`) and their forbidden departures on an
edge (:func:`~optplan.exact.sipp_graph.segment_windows`, the one mover kernel of ``sipp``),
computed on ``[0, horizon]`` (nothing is known of them afterwards: the plan is not checked
against them after the horizon).

Safe-interval path planning (Phillips and Likhachev, ICRA 2011): A* over states ``(node, safe
interval)``, the earliest arrival per state (an earlier arrival in the same safe interval can
do whatever a later one can: the constraints restrict departures, not arrivals), the heuristic
the graph distance to the goal over ``speed`` (consistent).  A state at the goal counts only
when its safe interval is unbounded (the robot holds its goal for ever), so the first one taken
from the queue is the earliest arrival under the constraints: *optimal*.

With positive constraints a state also records which of them its way has met (a bit mask; the
goal counts only with all of them), and an edge is tried at its earliest allowed departure and
at the earliest one in each positive window of that edge (the earliest departure meeting a set
of windows of one edge is the earliest one after the latest of their starts, so these reach
every set a departure can meet, at the earliest time); a state whose unmet window has closed
is dropped.  An earlier arrival in the same (node, safe interval, mask) can still do whatever a
later one can, so the search stays optimal.  Without positive constraints the mask is always
empty and the search is the plain one.

With a hold constraint, an arrival at the goal before ``hold_from`` is a state of its own (it
may wait there and leave again, but it is not the final arrival), and an edge into the goal is
also tried at the earliest departure arriving at ``hold_from`` or later; the heuristic is
``max(t + h, hold_from)`` (still consistent).
"""

from __future__ import annotations

import bisect
import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from optplan.exact.sipp_graph import MoverBoxes, segment_windows
from optplan.geometry.timing import Intervals, first_free, free_intervals, merge_open

__all__ = ["AgentModel", "Constraints", "Plan", "plan_agent", "graph_distances"]

#: States expanded between two polls of ``stop``.
_POLL = 256


def graph_distances(nbrs: list[list[tuple[int, float]]], goal: int) -> np.ndarray:
    """Shortest graph distance from every node to ``goal`` (Dijkstra; ``inf`` unreachable)."""
    dist = np.full(len(nbrs), math.inf)
    dist[goal] = 0.0
    heap = [(0.0, goal)]
    while heap:
        d, v = heapq.heappop(heap)
        if d > dist[v]:
            continue
        for w, length in nbrs[v]:
            if d + length < dist[w]:
                dist[w] = d + length
                heapq.heappush(heap, (d + length, w))
    return dist


@dataclass
class AgentModel:
    """One robot on its graph, with the moving obstacles' windows (computed lazily, cached).

    Attributes
    ----------
    nodes : ndarray ``(n, 2)``
        Node coordinates (map units).
    nbrs : list of list of (int, float)
        Per node, its neighbours on this robot's graph and the edge lengths.
    start, goal : int
        Nodes.
    radius, speed : float
        The disc and its full speed (> 0).
    boxes : MoverBoxes or None
        The moving obstacles (``None``: there are none).
    horizon : float
        The moving obstacles' windows are exact on ``[0, horizon]`` (``inf`` without movers).
    """

    nodes: np.ndarray
    nbrs: list[list[tuple[int, float]]]
    start: int
    goal: int
    radius: float
    speed: float
    boxes: MoverBoxes | None = None
    horizon: float = math.inf
    h: list[float] = field(init=False, repr=False)
    _busy: dict[int, Intervals] = field(default_factory=dict, repr=False)
    _forb: dict[tuple[int, int], Intervals] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.h = (graph_distances(self.nbrs, self.goal) / self.speed).tolist()

    def busy(self, v: int) -> Intervals:
        """The moving obstacles' busy times at node ``v`` (open intervals)."""
        if self.boxes is None:
            return []
        if v not in self._busy:
            self._busy[v] = self.boxes.parked_busy(self.nodes[v], self.radius, 0.0,
                                                   self.horizon)
        return self._busy[v]

    def mover_forbidden(self, u: int, v: int) -> Intervals:
        """The departures along ``u -> v`` at which the robot overlaps a moving obstacle."""
        if self.boxes is None:
            return []
        if (u, v) not in self._forb:
            a, b = self.nodes[u][None], self.nodes[v][None]
            near = self.boxes.near_segments(a, b)
            forb, _ = segment_windows(near, a, b, self.radius, self.speed, self.horizon)
            self._forb[(u, v)] = forb[0]
        return self._forb[(u, v)]


def _add_half_open(ivs: Intervals, lo: float, hi: float) -> Intervals:
    """``ivs`` (sorted, disjoint half-open ``[lo, hi)``) with ``[lo, hi)`` added (merged,
    touching ones too: :func:`~optplan.geometry.timing.merge_open`)."""
    return merge_open(np.array([x[0] for x in ivs] + [lo]), np.array([x[1] for x in ivs] + [hi]))


def _first_allowed(cons: Intervals, t: float) -> float:
    """The earliest time ``>= t`` outside the half-open intervals ``cons``."""
    k = bisect.bisect_right(cons, (t, math.inf)) - 1
    if k >= 0 and cons[k][1] > t:
        return cons[k][1]
    return t


@dataclass
class Constraints:
    """One robot's constraints: ``vertex[v]`` and ``edge[(u, v)]``, each a sorted list of
    disjoint half-open time intervals ``[t1, t2)``; the required departures ``positive``
    ``(u, v, t1, t2)``; the earliest final arrival at the goal ``hold_from``."""

    vertex: dict[int, Intervals] = field(default_factory=dict)
    edge: dict[tuple[int, int], Intervals] = field(default_factory=dict)
    positive: tuple[tuple[int, int, float, float], ...] = ()
    hold_from: float = 0.0
    #: the constraints added so far, as ``(kind, u, v, t1, t2)`` (:func:`~optplan.exact.
    #: ccbs_conflicts.constrain`): equal keys, equal constraints (the low level's memo)
    key: frozenset = frozenset()

    def add_vertex(self, v: int, lo: float, hi: float) -> None:
        """Forbid node ``v`` on ``[lo, hi)``."""
        self.vertex[v] = _add_half_open(self.vertex.get(v, []), lo, hi)

    def add_edge(self, u: int, v: int, lo: float, hi: float) -> None:
        """Forbid departures along ``u -> v`` on ``[lo, hi)``."""
        self.edge[(u, v)] = _add_half_open(self.edge.get((u, v), []), lo, hi)

    def add_positive(self, u: int, v: int, lo: float, hi: float) -> None:
        """Require a departure along ``u -> v`` in ``[lo, hi)``."""
        self.positive = (*self.positive, (u, v, lo, hi))

    def add_hold(self, t: float) -> None:
        """Require the final arrival at the goal at ``t`` or later."""
        self.hold_from = max(self.hold_from, t)


@dataclass(frozen=True)
class Plan:
    """A robot's plan: the nodes it visits, and the arrival at and departure from each.

    ``arrive[0] = 0`` (the start), ``depart[-1] = inf`` (it holds its goal for ever);
    ``cost`` is the arrival at the goal, ``expanded`` the states the search expanded.
    """

    nodes: tuple[int, ...]
    arrive: tuple[float, ...]
    depart: tuple[float, ...]
    expanded: int = 0

    @property
    def cost(self) -> float:
        """The arrival at the goal (s)."""
        return self.arrive[-1]


class _Search:
    """The A* over ``(node, safe interval)`` states of :func:`plan_agent`."""

    def __init__(self, m: AgentModel, cons: Constraints, stop: Callable[[], bool] | None):
        self.m, self.cons, self.stop = m, cons, stop
        self.safe_of: dict[int, Intervals] = {}
        self.st: list[tuple[int, int, float, int, float, int, tuple]] = []  # node, interval,
        # t, parent, departure, mask of the positive constraints met, key (:meth:`push`)
        self.best: dict[tuple[int, int, int], float] = {}
        self.full = (1 << len(cons.positive)) - 1
        self.windows: dict[tuple[int, int], list[tuple[int, float, float]]] = {}
        for b, (u, v, lo, hi) in enumerate(cons.positive):
            self.windows.setdefault((u, v), []).append((1 << b, lo, hi))
        self.heap: list[tuple[float, float, int]] = []
        self.expanded = 0
        self.close_of: dict[int, float] = {}

    def safe(self, v: int) -> Intervals:
        """Safe intervals of node ``v``: the closed complement of the movers' busy times and
        the vertex constraints (a constraint ``[t1, t2)`` as the open ``(t1, t2)``: leaving at
        ``t1`` is forbidden by :meth:`departure`), the last one ``inf`` past the horizon."""
        if v not in self.safe_of:
            busy = self.m.busy(v)
            cons = self.cons.vertex.get(v, [])
            merged = merge_open(np.array([x[0] for x in busy + cons]),
                                np.array([x[1] for x in busy + cons])) if busy or cons else []
            out = free_intervals(merged, math.inf)
            if out and out[-1][1] >= self.m.horizon:
                out[-1] = (out[-1][0], math.inf)
            self.safe_of[v] = out
        return self.safe_of[v]

    def departure(self, u: int, v: int, t: float) -> float:
        """The earliest departure ``>= t`` along ``u -> v`` allowed by the moving obstacles,
        the edge constraints and the vertex constraints of ``u``."""
        forb = self.m.mover_forbidden(u, v) if self.m.boxes is not None else []
        edge = self.cons.edge.get((u, v))
        vert = self.cons.vertex.get(u)
        if not (forb or edge or vert):
            return t
        while True:
            x = first_free(forb, t)
            if edge:
                x = _first_allowed(edge, x)
            if vert:
                x = _first_allowed(vert, x)
            if x == t:
                return t
            t = x

    def closes(self, mask: int) -> float:
        """The earliest end of a positive window not met in ``mask``."""
        if mask not in self.close_of:
            self.close_of[mask] = min((hi for b, (*_, hi) in enumerate(self.cons.positive)
                                       if not mask >> b & 1), default=math.inf)
        return self.close_of[mask]

    def push(self, v: int, j: int, t: float, parent: int, dep: float, mask: int = 0) -> None:
        """Add the state ``(v, j, mask)`` reached at ``t`` unless it was reached earlier or an
        unmet positive window has closed."""
        hold = self.cons.hold_from
        # an arrival at the goal before hold_from is not a final one: a state of its own (~j)
        key = (v, ~j if t < hold and v == self.m.goal else j, mask)
        if self.best.get(key, math.inf) <= t:
            return
        if mask != self.full and t >= self.closes(mask):
            return
        self.best[key] = t
        self.st.append((v, j, t, parent, dep, mask, key))
        f = t + self.m.h[v]
        heapq.heappush(self.heap, (f if f >= hold else hold, -t, len(self.st) - 1))

    def departures(self, u: int, v: int, lo: float, hi: float, mask: int, dt: float
                   ) -> list[tuple[float, int]]:
        """The departures along ``u -> v`` in ``[lo, hi]`` worth trying (module docstring)
        and the mask each reaches (``dt``: the edge's duration)."""
        windows = self.windows.get((u, v))
        starts = [lo]
        if v == self.m.goal and lo + dt < self.cons.hold_from:
            starts.append(self.cons.hold_from - dt)
        if windows is None:  # no positive constraint on this edge
            deps = [self.departure(u, v, x) for x in starts]
            return [(dep, mask) for dep in dict.fromkeys(deps) if dep <= hi]
        out = []
        for start in (*starts, *(max(lo, w_lo) for _, w_lo, _ in windows)):
            dep = self.departure(u, v, start)
            if dep <= hi:
                met = mask
                for bit, w_lo, w_hi in windows:
                    met |= bit if w_lo <= dep < w_hi else 0
                out.append((dep, met))
        return out

    def expand(self, s: int) -> None:
        """The successors of state ``s``: every neighbour's safe intervals it can reach."""
        u, j, t, _, _, mask, _ = self.st[s]
        leave_by = self.safe(u)[j][1]
        h, speed, goal = self.m.h, self.m.speed, self.m.goal
        held = self.cons.hold_from > 0.0
        for v, length in self.m.nbrs[u]:
            if h[v] == math.inf:
                continue
            dt = length / speed
            safe = self.safe_of[v] if v in self.safe_of else self.safe(v)
            plain = (u, v) not in self.windows and not (held and v == goal)
            k0 = max(bisect.bisect_right(safe, (t + dt, math.inf)) - 1, 0)
            for k in range(k0, len(safe)):
                c, d = safe[k]
                if c - dt > leave_by:
                    break
                lo, hi = max(t, c - dt), min(leave_by, d - dt)
                if lo > hi:
                    continue
                if plain:  # one departure to try (:meth:`departures`, inlined)
                    dep = self.departure(u, v, lo)
                    if dep <= hi:
                        self.push(v, k, dep + dt, s, dep, mask)
                    continue
                for dep, met in self.departures(u, v, lo, hi, mask, dt):
                    self.push(v, k, dep + dt, s, dep, met)

    def run(self) -> int | None:
        """The goal state with an unbounded safe interval reached first, else ``None``."""
        m = self.m
        safe0 = self.safe(m.start)
        j0 = next((j for j, (lo, hi) in enumerate(safe0) if lo <= 0.0 <= hi), None)
        if j0 is None or not math.isfinite(m.h[m.start]):
            return None
        self.push(m.start, j0, 0.0, -1, math.nan)
        closed: set[tuple[int, int, int]] = set()
        while self.heap:
            _, _, s = heapq.heappop(self.heap)
            v, j, t, *_, key = self.st[s]
            if key in closed:
                continue
            closed.add(key)
            if (v == m.goal and math.isinf(self.safe(v)[j][1]) and key[2] == self.full
                    and t >= self.cons.hold_from):
                return s
            self.expanded += 1
            if self.stop is not None and self.expanded % _POLL == 0 and self.stop():
                raise StopIteration
            self.expand(s)
        return None

    def plan(self, s: int) -> Plan:
        """The plan ending at state ``s``."""
        chain = []
        while s >= 0:
            chain.append(s)
            s = self.st[s][3]
        chain.reverse()
        nodes = tuple(self.st[k][0] for k in chain)
        arrive = tuple(self.st[k][2] for k in chain)
        depart = tuple(self.st[k][4] for k in chain[1:]) + (math.inf,)
        return Plan(nodes, arrive, depart, self.expanded)


def plan_agent(model: AgentModel, cons: Constraints,
               stop: Callable[[], bool] | None = None) -> Plan | None:
    """The earliest arrival of one robot at its goal (held for ever) under its constraints.

    Parameters
    ----------
    model : AgentModel
        The robot, its graph and the moving obstacles.
    cons : Constraints
        Its vertex and edge constraints.
    stop : callable, optional
        Polled every 256 states expanded; True ends the search (raises ``StopIteration``).

    Returns
    -------
    Plan or None
        The optimal plan under the constraints (module docstring), ``None`` when there is none.

    Raises
    ------
    StopIteration
        When ``stop`` asked to end.
    """
    search = _Search(model, cons, stop)
    goal = search.run()
    return None if goal is None else search.plan(goal)
