r"""Continuous-time conflict-based search: the ``ccbs`` preset, the team reference on a roadmap.

Andreychuk, Yakovlev, Atzmon and Stern, "Multi-agent pathfinding with continuous time" (IJCAI
2019, AIJ 2022), with the delta branching rule of Combrink, Roselli and Fabian, "Optimal
multi-agent path finding in continuous time" (2025), which makes it sound (every conflict-free
solution survives in a child) and terminating.

**Model.**  Disc robots (own radius, own full speed) drive along the straight edges of a graph
at full speed and wait at its nodes for any duration; each ends at its goal node and stays there
for ever.  Cost: the sum of the arrival times (``objective = "sum"``) or the latest one
(``"makespan"``).  The graph is ``problem.roadmap`` when the problem has one, else the roadmap
model of :mod:`optplan.exact.ccbs_roadmap`.  Moving obstacles are hard constraints of every
robot (:mod:`optplan.exact.ccbs_sipp`).

**Search** (:func:`ccbs_search`).  A best-first search over a constraint tree: each node holds a
set of constraints per robot and each robot's optimal plan under them
(:func:`~optplan.exact.ccbs_sipp.plan_agent`); its cost is a lower bound of every solution in its
subtree.  A node without conflicts is optimal within the model.  Otherwise one conflict is
branched on (:func:`~optplan.exact.ccbs_conflicts.branch`).  Options (Andreychuk et al., AAAI
2021): ``cardinal`` branches first on conflicts both of whose children cost more (cardinal; of
them the one whose cheaper child adds most), then on those with one (semi-cardinal), else on
any, ties going to the latest conflict, as in the authors' implementation (without the option:
the earliest conflict); ``heuristic`` adds to a node's cost a
lower bound of what its cardinal conflicts must add (the largest of ``min(increase_i,
increase_j)`` over disjoint pairs of robots, greedily; sum objective only), computed when the
node is first taken from the queue (it goes back when that raises its bound); ``disjoint``
(Li et al., ICAPS 2019; in continuous time Andreychuk et al., AAAI 2021) splits disjointly:
the child of the other robot also *requires* the move that the mover's own child forbids (a
positive constraint, :func:`~optplan.exact.ccbs_sipp.plan_agent`), given to a mover of the
conflict (of two, the one with fewer positive constraints).  The soundness argument with the
delta rule is in :mod:`optplan.exact.ccbs_conflicts`.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.backend import ClaimsInTime
from optplan.exact.ccbs_conflicts import (
    Conflict,
    Timeline,
    branch,
    constrain,
    first_conflict,
    timeline_of,
)
from optplan.exact.ccbs_roadmap import agent_models, roadmap_model
from optplan.exact.ccbs_sipp import AgentModel, Constraints, Plan, plan_agent
from optplan.geometry.timing import arrival_lower_bound, positions_at
from optplan.geometry.timing.disc_conflict import CONTACT_REL_TOL
from optplan.problem import Problem
from optplan.result import History, Progress, Result, Status, confirms_optimum, notify
from optplan.solver import Backend, clock, option

__all__ = ["CCBS", "CCBSOptions", "CCBSOutcome", "ccbs_search"]

#: Relative tolerance of a cost increase (cardinal conflicts, the heuristic).
_COST_TOL = 1e-9


@dataclass(frozen=True)
class CCBSOptions:
    """Options of :func:`ccbs_search` (the preset's, :class:`CCBS`)."""

    objective: str = "sum"
    cardinal: bool = True
    heuristic: bool = True
    gamma: float = 0.5
    max_expansions: int = 100_000
    disjoint: bool = True


@dataclass
class CCBSOutcome:
    """What :func:`ccbs_search` found.

    Attributes
    ----------
    status : str
        ``"optimal"`` (conflict-free plans of least cost within the model), ``"effort"``
        (``max_expansions`` nodes expanded), ``"stopped"`` (``stop`` asked), ``"no_solution"``
        (the tree is exhausted: no conflict-free plans within the model) or ``"goals_overlap"``
        (two robots' goals overlap: no solution at all).
    plans : list of Plan or None
        Per robot, its plan (``status == "optimal"``).
    cost : float
        The plans' cost (``inf`` without plans).
    lower_bound : float
        The least bound of the open nodes when the search ended (the cost when optimal): a
        lower bound of the optimum within the model.
    expansions, low_level : int
        Constraint-tree nodes expanded and low-level searches run.
    """

    status: str
    plans: list[Plan] | None = None
    cost: float = math.inf
    lower_bound: float = 0.0
    expansions: int = 0
    low_level: int = 0


@dataclass
class _Node:
    """A constraint-tree node."""

    cons: list[Constraints]
    plans: list[Plan]
    lines: list[Timeline]
    conflicts: dict[tuple[int, int], Conflict]
    cost: float
    h: float = 0.0
    evaluated: bool = False
    children: dict[tuple[int, int], tuple] = field(default_factory=dict)


class _Search:
    """The constraint-tree search of :func:`ccbs_search`."""

    def __init__(self, nodes: np.ndarray, models: list[AgentModel], opts: CCBSOptions,
                 stop: Callable[[], bool] | None):
        self.nodes, self.models, self.opts, self.stop = nodes, models, opts, stop
        self.out = CCBSOutcome("no_solution")
        self.heap: list[tuple[float, int, int, _Node]] = []
        self.seq = 0
        self.lines: dict[tuple, Timeline] = {}
        self.pairs: dict[tuple[int, int, int, int], Conflict | None] = {}
        self.plans: dict[tuple[int, frozenset], Plan | None] = {}

    def cost(self, plans: list[Plan]) -> float:
        """The objective of a set of plans."""
        costs = [p.cost for p in plans]
        return max(costs) if self.opts.objective == "makespan" else sum(costs)

    def plan(self, k: int, cons: Constraints) -> Plan | None:
        """Robot ``k``'s optimal plan under ``cons`` (remembered by the constraints' key: the
        same constraints recur in many nodes, e.g. a robot's child of a conflict that the
        other robot's replanning left as it was)."""
        key = (k, cons.key)
        if key not in self.plans:
            self.out.low_level += 1
            self.plans[key] = plan_agent(self.models[k], cons, self.stop)
        return self.plans[key]

    def line(self, plan: Plan) -> Timeline:
        """The timeline of ``plan``, one object per distinct plan (so pairs of them can be
        remembered by identity)."""
        key = (plan.nodes, plan.arrive, plan.depart)
        if key not in self.lines:
            self.lines[key] = timeline_of(self.nodes, plan)
        return self.lines[key]

    def first(self, i: int, j: int, node: _Node) -> Conflict | None:
        """The first conflict of robots ``i < j`` in ``node`` (remembered per pair of
        timelines: children share the plans they did not change)."""
        key = (i, j, id(node.lines[i]), id(node.lines[j]))
        if key not in self.pairs:
            contact = self.models[i].radius + self.models[j].radius
            self.pairs[key] = first_conflict(i, j, node.lines[i], node.lines[j], contact)
        return self.pairs[key]

    def conflicts_of(self, node: _Node, only: int | None = None) -> None:
        """Fill ``node.conflicts``: every pair's first conflict (only the pairs of robot
        ``only`` when given; the others are the parent's)."""
        n = len(node.plans)
        for i in range(n):
            for j in range(i + 1, n):
                if only is not None and only not in (i, j):
                    continue
                c = self.first(i, j, node)
                node.conflicts.pop((i, j), None)
                node.children.pop((i, j), None)
                if c is not None:
                    node.conflicts[(i, j)] = c

    def push(self, node: _Node) -> None:
        """Put ``node`` on the queue (by bound, then fewer conflicts)."""
        self.seq += 1
        heapq.heappush(self.heap, (node.cost + node.h, len(node.conflicts), self.seq, node))

    def child(self, node: _Node, k: int, constraint: tuple) -> tuple | None:
        """Robot ``k`` replanned with one constraint more: ``(constraints, plan)`` or
        ``None`` when it has no plan."""
        cons = constrain(node.cons[k], constraint)
        p = self.plan(k, cons)
        return None if p is None else (cons, p)

    def children_of(self, node: _Node, c: Conflict) -> tuple:
        """The two children of conflict ``c`` and their constraints (cached per pair)."""
        key = (c.i, c.j)
        if key not in node.children:
            contact = self.models[c.i].radius + self.models[c.j].radius
            ci, cj = branch(self.nodes, c, contact, self.opts.gamma)
            node.children[key] = (self.child(node, c.i, ci), self.child(node, c.j, cj), ci, cj)
        return node.children[key]

    def positive(self, node: _Node, c: Conflict) -> tuple[int, tuple] | None:
        """Disjoint splitting: the robot whose move the other child requires, and that
        requirement (its own child's edge constraint as a positive one); of two moves, the
        robot with fewer positive constraints (``None`` without the option)."""
        if not self.opts.disjoint:
            return None
        movers = [(len(node.cons[k].positive), n, k) for n, (k, a) in
                  enumerate(((c.i, c.act_i), (c.j, c.act_j))) if a.is_move]
        _, n, k = min(movers)
        _, u, v, lo, hi = self.children_of(node, c)[2 + n]
        return k, ("positive", u, v, lo, hi)

    def increases(self, node: _Node, c: Conflict) -> tuple[float, float]:
        """The cost increases of robots ``c.i`` and ``c.j`` in the two children."""
        out = []
        for k, ch in zip((c.i, c.j), self.children_of(node, c)[:2]):
            old = node.plans[k].cost
            out.append(math.inf if ch is None else ch[1].cost - old)
        return out[0], out[1]

    def choose(self, node: _Node) -> tuple[Conflict, float]:
        """The conflict to branch on and the node's heuristic (module docstring)."""
        confs = sorted(node.conflicts.values(), key=lambda c: c.time)
        if not (self.opts.cardinal or self.opts.heuristic):
            return confs[0], 0.0
        scale = max(node.cost, 1.0) * _COST_TOL
        rank = []
        for c in confs:
            di, dj = self.increases(node, c)
            card = (di > scale) + (dj > scale)
            rank.append((-card, c.time, c, min(di, dj)))
        h = 0.0
        if self.opts.heuristic and self.opts.objective == "sum":
            used: set[int] = set()
            for _, _, c, gain in sorted((r for r in rank if r[0] == -2), key=lambda r: -r[3]):
                if c.i not in used and c.j not in used and math.isfinite(gain):
                    h += gain
                    used.update((c.i, c.j))
        if not self.opts.cardinal:
            return rank[0][2], h
        # cardinal first, the one whose cheaper child adds most; then semi-cardinal, then the
        # rest; ties to the latest (as the authors' implementation)
        best = min(rank, key=lambda r: (r[0], -r[3] if r[0] == -2 else 0.0, -r[1]))
        return best[2], h

    def expand(self, node: _Node, c: Conflict) -> None:
        """Branch ``node`` on ``c``: push its feasible children."""
        self.out.expansions += 1
        pos = self.positive(node, c)
        for k, ch in zip((c.i, c.j), self.children_of(node, c)[:2]):
            if ch is None:
                continue
            cons, plans, lines = list(node.cons), list(node.plans), list(node.lines)
            cons[k], plans[k] = ch
            lines[k] = self.line(plans[k])
            changed = {k}
            if pos is not None and pos[0] != k:  # its plan already meets the requirement
                cons[pos[0]] = constrain(node.cons[pos[0]], pos[1])
                changed.add(pos[0])
            kid = _Node(cons, plans, lines, dict(node.conflicts), self.cost(plans),
                        children={p: v for p, v in node.children.items()
                                  if not changed.intersection(p)})
            self.conflicts_of(kid, only=k)
            self.push(kid)

    def root(self) -> _Node | None:
        """The root: every robot's unconstrained plan (``None`` when one has none)."""
        cons = [Constraints() for _ in self.models]
        plans = []
        for k, c in enumerate(cons):
            p = self.plan(k, c)
            if p is None:
                return None
            plans.append(p)
        node = _Node(cons, plans, [self.line(p) for p in plans], {}, self.cost(plans))
        self.conflicts_of(node)
        return node

    def run(self) -> CCBSOutcome:
        """The search (:func:`ccbs_search`)."""
        out = self.out
        root = self.root()
        if root is None:
            return out
        self.push(root)
        while self.heap:
            f, _, _, node = self.heap[0]
            out.lower_bound = f
            if not node.conflicts:
                out.status, out.plans, out.cost = "optimal", node.plans, node.cost
                return out
            if out.expansions >= self.opts.max_expansions:
                out.status = "effort"
                return out
            if self.stop is not None and self.stop():
                out.status = "stopped"
                return out
            heapq.heappop(self.heap)
            c, h = self.choose(node)
            if not node.evaluated:
                node.evaluated, node.h = True, h
                if h > 0:
                    self.push(node)
                    continue
            self.expand(node, c)
        out.lower_bound = math.inf
        return out


def _goals_overlap(nodes: np.ndarray, models: list[AgentModel]) -> bool:
    """Whether two robots' goals overlap (no solution holds both)."""
    for i, a in enumerate(models):
        for b in models[i + 1:]:
            d = float(np.hypot(*(nodes[a.goal] - nodes[b.goal])))
            if d < (a.radius + b.radius) * (1.0 - CONTACT_REL_TOL):
                return True
    return False


def ccbs_search(nodes: np.ndarray, models: list[AgentModel], options: CCBSOptions | None = None,
                stop: Callable[[], bool] | None = None) -> CCBSOutcome:
    """Conflict-based search in continuous time with the delta branching rule.

    Parameters
    ----------
    nodes : ndarray ``(n, 2)``
        The graph's node coordinates (map units).
    models : list of AgentModel
        Per robot: its graph (neighbours and edge lengths), start and goal nodes, radius,
        full speed and the moving obstacles (:class:`~optplan.exact.ccbs_sipp.AgentModel`).
    options : CCBSOptions, optional
        ``objective`` (``"sum"`` or ``"makespan"``), ``cardinal``, ``heuristic``, ``gamma``
        (the delta rule's fraction, in ``(0, 1)``), ``max_expansions`` and ``disjoint``
        (disjoint splitting).
    stop : callable, optional
        Polled once per node and every 256 low-level states; True ends the search (status
        ``"stopped"``).

    Returns
    -------
    CCBSOutcome
        The plans, their cost, the open list's lower bound, the counts and a status.
    """
    opts = options or CCBSOptions()
    if _goals_overlap(nodes, models):
        return CCBSOutcome("goals_overlap", lower_bound=math.inf)
    search = _Search(np.asarray(nodes, float), models, opts, stop)
    try:
        return search.run()
    except StopIteration:
        search.out.status = "stopped"
        return search.out


# --------------------------------------------------------------------------------------
# the preset
# --------------------------------------------------------------------------------------


def _timeline(nodes: np.ndarray, plan: Plan) -> tuple[np.ndarray, np.ndarray]:
    """A plan's stamps and points (an arrival and, after a wait, a departure per node)."""
    ts, pts = [], []
    for k, v in enumerate(plan.nodes):
        ts.append(plan.arrive[k])
        pts.append(nodes[v])
        if math.isfinite(plan.depart[k]) and plan.depart[k] > plan.arrive[k]:
            ts.append(plan.depart[k])
            pts.append(nodes[v])
    return np.array(ts), np.array(pts)


def _paths(problem: Problem, nodes: np.ndarray, plans: list[Plan]
           ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Every robot's polyline on the shared stamps (each holds its goal after its arrival)."""
    lines = [_timeline(nodes, p) for p in plans]
    stamps = np.unique(np.concatenate([t for t, _ in lines]))
    if len(stamps) < 2:
        stamps = np.r_[stamps, stamps]
    return ({r.id: positions_at(t, x, stamps) for r, (t, x) in
             zip(problem.planned_robots, lines)}, stamps)


def _bounds(problem: Problem) -> tuple[list[float | None], list[str]]:
    """Per robot, :func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound` (valid for
    every motion) and its reason."""
    out = [arrival_lower_bound(problem, r.id) for r in problem.planned_robots]
    return [b.value for b in out], [b.reason for b in out]


def _horizon(problem: Problem, team_bound: float) -> float:
    """Where the moving obstacles' windows end: four times the team's lower bound plus the
    movers' last waypoint time and longest period (``inf`` without movers)."""
    if not problem.dynamic_obstacles:
        return math.inf
    from optplan.geometry.timing import mover_period

    knots = [float(np.max(d.times)) for d in problem.dynamic_obstacles if len(d.times)]
    periods = [p for p in map(mover_period, problem.dynamic_obstacles) if p is not None]
    return 4.0 * (team_bound + max(knots, default=0.0) + max(periods, default=0.0)) or 1.0


_WHY = {"effort": "{n} constraint-tree nodes expanded (max_expansions) without a solution",
        "stopped": "stopped after {n} constraint-tree nodes without a solution",
        "no_solution": "no conflict-free plans within the roadmap model (the constraint tree "
                       "is exhausted; not a proof that none exists in the plane)",
        "goals_overlap": "two robots' goals overlap: no plan can hold both"}


@dataclass(frozen=True, kw_only=True)
class CCBS(ClaimsInTime, Backend):
    """Continuous-time conflict-based search with the delta branching rule: the team of disc
    robots on a roadmap, optimal sum of arrival times within the roadmap model
    (:mod:`optplan.exact.ccbs`).

    Parameters
    ----------
    time_limit : float or None
        Seconds (> 0, default 30); the search stops at the first poll after it (status
        ``failed``, the open list's lower bound in the metrics).  ``solve(time_limit=S)``
        replaces it.
    max_expansions : int
        Most constraint-tree nodes expanded (in [1, 10^9], default 100,000).
    objective : str
        ``"sum"`` (default: the sum of the arrival times) or ``"makespan"`` (the last one).
    disjoint : bool
        Disjoint splitting (default true): one child forbids a robot's move in a time window,
        the other requires it there (a positive constraint) and carries the other robot's
        constraint; sound with the delta rule (:mod:`optplan.exact.ccbs_conflicts`).
    cardinal : bool
        Branch on cardinal conflicts first (the one whose cheaper child adds most), then
        semi-cardinal ones, ties to the latest (default true; false: the earliest conflict).
    heuristic : bool
        The high-level heuristic of the cardinal conflicts (default true; sum objective only).
    gamma : float
        The delta rule's fraction of the contact interval (in (0, 1), default 0.5).
    """

    name: ClassVar[str] = "ccbs"
    certifies: ClassVar[bool] = True
    time_limit: float | None = option(30.0, lo=0.0, lo_open=True, inf_ok=True, none_ok=True)
    max_expansions: int = option(100_000, lo=1, hi=10**9)
    objective: str = option("sum", choices=("sum", "makespan"))
    disjoint: bool = option(True)
    cardinal: bool = option(True)
    heuristic: bool = option(True)
    gamma: float = option(0.5, lo=0.0, hi=1.0, lo_open=True, hi_open=True)

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t0, start = time.perf_counter(), clock()
        values, reasons = _bounds(problem)
        if any(v is None or math.isinf(v) for v in values):
            k = next(k for k, v in enumerate(values) if v is None or math.isinf(v))
            rid = problem.planned_robots[k].id
            return self._answer(problem, None, None, t0, f"{rid}: {reasons[k]}",
                                Status.infeasible if values[k] is None else Status.failed)
        team = [float(v) for v in values if v is not None]
        graph = roadmap_model(problem)
        models = agent_models(problem, graph, _horizon(problem, sum(team)))
        state = {"n": 0, "timed_out": False}

        def stop() -> bool:
            state["n"] += 1
            if self.time_limit is not None and clock() - start >= self.time_limit:
                state["timed_out"] = True
                return True
            return notify(callback, Progress(iteration=state["n"], best_cost=math.inf,
                                             n_eval=state["n"],
                                             elapsed=time.perf_counter() - t0))

        opts = CCBSOptions(self.objective, self.cardinal, self.heuristic, self.gamma,
                           self.max_expansions, self.disjoint)
        out = ccbs_search(graph.nodes, models, opts, stop)
        res = self._answer(problem, out, graph, t0, "", Status.failed, team)
        return res if not state["timed_out"] else _stopped(res)

    def _answer(self, problem: Problem, out: CCBSOutcome | None, graph, t0: float,
                why: str, claim: Status, team: list[float] | None = None) -> Result:
        """The Result of a search (or of the bounds alone: ``out = None``)."""
        metrics: dict[str, Any] = {"team_lower_bound": sum(team) if team else None,
                                   "makespan_lower_bound": max(team) if team else None}
        paths = {r.id: np.vstack([r.start, r.start]) for r in problem.planned_robots}
        times, cost, msg = np.zeros(2), math.inf, why
        if out is not None:
            metrics.update(expansions=out.expansions, open_lower_bound=out.lower_bound,
                           low_level_searches=out.low_level, roadmap_nodes=len(graph),
                           roadmap_edges=len(graph.edges), objective=self.objective)
            msg = _WHY.get(out.status, "").format(n=out.expansions)
            if out.status == "goals_overlap":
                claim = Status.infeasible
            if out.plans is not None:
                paths, times = _paths(problem, graph.nodes, out.plans)
                arrivals = [p.cost for p in out.plans]
                cost = out.cost
                metrics.update(sum_of_arrivals=sum(arrivals), makespan=max(arrivals),
                               arrival_times={r.id: a for r, a in
                                              zip(problem.planned_robots, arrivals)})
                claim, msg = _claim(problem, cost, metrics, self.objective)
                msg = (f"{self.objective} of arrivals {cost:.6g} s: optimal within the roadmap "
                       f"model ({len(graph)} nodes, full speed on edges, waits at nodes){msg}; "
                       f"lower bound over all motions {_team_bound(metrics, self.objective)}")
            elif out.status in ("effort", "stopped"):
                msg += f"; open-list lower bound {out.lower_bound:.6g} s"
        hist = History()
        hist.append(iteration=0, best_cost=cost, n_eval=0 if out is None else out.low_level,
                    time=time.perf_counter() - t0)
        return self.finish(problem, paths, claim=claim, times=times, cost=cost, message=msg,
                           history=hist, metrics_extra=metrics,
                           n_iter=0 if out is None else out.expansions,
                           n_eval=0 if out is None else out.low_level,
                           wall_time=time.perf_counter() - t0)


def _claim(problem: Problem, cost: float, metrics: dict[str, Any], objective: str
           ) -> tuple[Status, str]:
    """``optimal`` when the roadmap is the problem's own (its robots keep to it) or the cost
    meets the lower bound over all motions; else ``solved``: the roadmap model of the map's
    grown corners is narrower than the plane (and a note saying so)."""
    bound = metrics["team_lower_bound" if objective == "sum" else "makespan_lower_bound"]
    if problem.roadmap is not None:
        return Status.optimal, ""
    if bound is not None and confirms_optimum(cost, bound):
        return Status.optimal, " and over all motions (it meets the lower bound)"
    return Status.solved, (" built from the map's grown corners, not the problem's: in the "
                           "plane this is a valid plan, not a certified optimum")


def _team_bound(metrics: dict[str, Any], objective: str) -> str:
    """The bound over all motions of the objective, as text."""
    v = metrics["team_lower_bound" if objective == "sum" else "makespan_lower_bound"]
    return f"{v:.6g} s"


def _stopped(res: Result) -> Result:
    """``res`` marked as ended by the time limit."""
    import dataclasses

    return dataclasses.replace(res, stop_reason="time_limit")
