r"""Safe-interval path planning on the exact tangent roadmap: the ``sipp`` preset.

The earliest arrival of a disc robot (speed limit ``max_speed``) among static obstacles (all
of them: temporary ``known = false`` ones are there all the time) and moving obstacles, *within
a model*: the roadmap of :mod:`optplan.exact.sipp_graph` (the arc-exact tangent visibility
graph of the static map, arcs drawn as circumscribed polylines), full speed on its edges,
waits at its vertices (arc corners included).  Safe-interval path planning (Phillips and
Likhachev, ICRA 2011; on any-angle roadmaps: Yakovlev and Andreychuk, ICAPS 2017): A* over
states ``(vertex, safe interval)`` with the earliest arrival per state; from a state, a chain is
entered at the earliest departure its forbidden departures and the safe intervals of its
corners allow (:func:`~optplan.exact.sipp_graph.chain_schedule`); the heuristic is the
straight-line distance to the goal over ``max_speed`` (consistent), and the chains out of a
vertex are consumed lazily in the order of their static lengths, as in the tangent graph.

**Horizon.**  The windows are exact on ``[0, H]``; an arrival found at or below ``H`` is the
earliest within the model.  ``H`` starts at twice the larger of the certified lower bound and
the last waypoint time of the moving obstacles, and doubles (at most ``max_doublings`` times)
while no arrival is found; past the cap the answer says so (it is not a proof).

**Several robots** (the backend): prioritised planning, the robots in turn, each avoiding the
movers and the robots before it (discs on their trajectories, parked at their goals), each
holding its goal until the team ends (passes until the last arrival stops moving); not jointly
optimal.

**Certificate.**  :func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound` holds for every
motion; the plan is ``optimal`` when its arrival equals the bound (relative
:data:`~optplan.result.OPTIMAL_REL_TOL`), else ``solved`` with the gap.  The earliest arrival
within the model is not the true time optimum (the robot could leave the roadmap, drive
slower, or wait elsewhere), so a gap is not an error of the search.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import shapely

from optplan.backend import ClaimsInTime
from optplan.exact.sipp_graph import (
    GOAL_KEY,
    START_KEY,
    MoverBoxes,
    Roadmap,
    chain_schedule,
)
from optplan.geometry.timing import (
    Intervals,
    PlanStatus,
    TimeBound,
    TimedPlan,
    arrival_lower_bound,
    free_intervals,
    positions_at,
)
from optplan.problem import DynamicObstacle, Problem
from optplan.result import (
    History,
    Progress,
    Result,
    Status,
    confirms_optimum,
    notify,
    optimum_gap,
)
from optplan.solver import Backend, option

__all__ = ["SIPP", "earliest_arrival"]

#: Units of work between two polls of ``stop``: a unit is a state expanded, a chain corner
#: drawn, a segment whose windows are computed or a segment scheduled.
_POLL = 256
#: Chains whose windows are computed together (one vectorised pass).
_WINDOW_BATCH = 8
#: Most segments in one vectorised pass of :func:`segment_windows` (a batch of long chains, as
#: with a small ``arc_step``, is cut into passes of this size with a poll between them).
_WINDOW_SEGMENTS = 4096


class _Stopped(Exception):
    """The search ended early (``stop`` asked, or the effort cap): ``status`` says which."""

    def __init__(self, status: PlanStatus):
        super().__init__(status)
        self.status = status


class _Sipp:
    """One A* search over ``(vertex, safe interval)`` states on ``[0, horizon]``.

    States are rows of parallel lists: vertex, interval index, time, parent state, the chain
    that led there (its source vertex and index) and the departures along it.  The heap holds
    states (``f = t + h``) and *streams*: the chains out of an expanded state, consumed in
    order of ``t + key / v`` (a lower bound of what they can give).
    """

    def __init__(self, rm: Roadmap, boxes: MoverBoxes, radius: float, speed: float,
                 horizon: float, budget: list[int], stop: Callable[[], bool] | None,
                 hold_until: float = 0.0):
        self.rm, self.boxes, self.radius, self.speed = rm, boxes, radius, speed
        self.horizon, self.budget, self.stop = horizon, budget, stop
        self.hold_until = hold_until
        self.unheld = False  # an arrival was found that could not hold the goal
        self.safe_of: dict[int, Intervals] = {}
        self.windows: dict[tuple[int, int], tuple[list[float], list[Intervals],
                                                  list[Intervals]]] = {}
        self.st: list[tuple[int, int, float, int, tuple[int, int] | None, list[float]]] = []
        self.best: dict[tuple[int, int], float] = {}
        self.closed: set[tuple[int, int]] = set()
        self.heap: list[tuple[float, int, int, int]] = []
        self.streams: list[list[int]] = []  # [state, next chain]
        self.seq = 0
        self.expanded = 0
        self.work = 0
        rm.tick = self.tick

    def tick(self, units: int) -> None:
        """Count ``units`` of work; every :data:`_POLL` units, poll ``stop`` (raises
        :class:`_Stopped` when it asks to end).  Every phase whose work grows with the options
        (drawing chains, their windows, the schedules along them, the expansions) counts here,
        so the search overruns its deadline by at most one bounded step."""
        self.work += units
        if self.work >= _POLL:
            self.work = 0
            if self.stop is not None and self.stop():
                raise _Stopped(PlanStatus.stopped)

    # ---- windows -------------------------------------------------------------------
    def safe(self, v: int) -> Intervals:
        """Safe intervals of vertex ``v`` on ``[0, horizon]``: of the start from
        :func:`~optplan.geometry.timing.time_bounds.parked_contact_times`, of a tangent point from
        the end of the first chain whose windows reach it (:meth:`_compute_windows`), of the goal
        all of it unless the robot must hold it (``hold_until``: the free times of the point)."""
        if v not in self.safe_of:
            vx = self.rm.vertices[v]
            if vx.key == GOAL_KEY and self.hold_until <= 0.0:
                self.safe_of[v] = [(0.0, self.horizon)]
            else:
                busy = self.boxes.parked_busy(vx.xy, self.radius, 0.0, self.horizon)
                self.safe_of[v] = free_intervals(busy, self.horizon)
        return self.safe_of[v]

    def _wanted(self, v: int, k: int) -> list[tuple[int, int]]:
        """The chains whose windows are computed with those of chain ``k`` out of ``v``: the
        free ones after it, and the next chain of the streams at the top of the heap (about to
        be taken: one vectorised pass for all)."""
        ch = self.rm.out_chains(v)
        out = [(v, m) for m in range(k, min(len(ch), k + _WINDOW_BATCH))]
        for _, kind, _, ref in heapq.nsmallest(_WINDOW_BATCH, self.heap):
            if kind == 1:
                s, m = self.streams[ref]
                out.append((self.st[s][0], m))
        return [(u, m) for u, m in dict.fromkeys(out) if (u, m) not in self.windows
                and m < len(self.rm.out_chains(u)) and self.rm.check(u, self.rm.chains[u], m)]

    def _compute_windows(self, v: int, k: int) -> None:
        """Windows of chain ``k`` out of ``v`` and of :meth:`_wanted`'s: segment lengths,
        forbidden departures, safe intervals of the inner corners (and of the end vertex, when
        it has none yet)."""
        want = self._wanted(v, k)
        pts = [self.rm.chains[u].points[m] for u, m in want]
        sizes = np.cumsum([len(p) - 1 for p in pts if p is not None])
        # the first chain (the one asked for) and the next ones while the pass stays small
        want = want[:max(1, int(np.searchsorted(sizes, _WINDOW_SEGMENTS, side="right")))]
        pts = pts[:len(want)]
        a = np.vstack([p[:-1] for p in pts if p is not None])
        b = np.vstack([p[1:] for p in pts if p is not None])
        forb: list[Intervals] = []
        busy: list[Intervals] = []
        for c in range(0, len(a), _WINDOW_SEGMENTS):
            ac, bc = a[c:c + _WINDOW_SEGMENTS], b[c:c + _WINDOW_SEGMENTS]
            f, bz = self.boxes.segment_windows(ac, bc, self.radius, self.speed)
            forb += f
            busy += bz
            self.tick(len(ac))
        lengths = np.hypot(*(b - a).T).tolist()
        safe = [free_intervals(x, self.horizon) for x in busy]
        at = 0
        for (u, m), p in zip(want, pts):
            assert p is not None
            n = len(p) - 1
            self.windows[(u, m)] = (lengths[at:at + n], forb[at:at + n], safe[at:at + n - 1])
            self.safe_of.setdefault(self.rm.target(self.rm.chains[u], m), safe[at + n - 1])
            at += n

    # ---- the search ----------------------------------------------------------------
    def _push(self, f: float, kind: int, ref: int) -> None:
        self.seq += 1
        heapq.heappush(self.heap, (f, kind, self.seq, ref))

    def _add_state(self, v: int, j: int, t: float, parent: int, chain: tuple[int, int] | None,
                   deps: list[float]) -> None:
        if (v, j) in self.closed or self.best.get((v, j), math.inf) <= t:
            return
        self.best[(v, j)] = t
        self.st.append((v, j, t, parent, chain, deps))
        self._push(t + self.rm.heuristic(v) / self.speed, 0, len(self.st) - 1)

    def _expand(self, s: int) -> None:
        """Open the stream of chains out of state ``s``."""
        self.expanded += 1
        self.budget[0] -= 1
        if self.budget[0] < 0:
            raise _Stopped(PlanStatus.effort)
        self.tick(1)
        v, _, t = self.st[s][:3]
        ch = self.rm.out_chains(v)
        if len(ch):
            self.streams.append([s, 0])
            self._push(t + float(ch.key[0]) / self.speed, 1, len(self.streams) - 1)

    def _follow(self, sid: int) -> None:
        """Take the next chain of stream ``sid``: the states it reaches."""
        s, k = self.streams[sid]
        v, j, t = self.st[s][:3]
        ch = self.rm.out_chains(v)
        self.streams[sid][1] = k + 1
        if k + 1 < len(ch):
            self._push(t + float(ch.key[k + 1]) / self.speed, 1, sid)
        if not self.rm.check(v, ch, k):
            return
        if (v, k) not in self.windows:
            self._compute_windows(v, k)
        lengths, forb, corners = self.windows[(v, k)]
        w = self.rm.target(ch, k)
        leave_by = self.safe(v)[j][1]
        out = chain_schedule(t, leave_by, lengths, forb, [*corners, self.safe(w)], self.speed,
                             self.horizon)
        self.tick(len(lengths))
        for jw, (arr, deps) in out.items():
            self._add_state(w, jw, arr, s, (v, k), deps)

    def run(self) -> int | None:
        """The goal state reached first (the earliest arrival), ``None`` when there is none
        up to the horizon.  Raises :class:`_Stopped`."""
        v0 = self.rm.index[START_KEY]
        j0 = next(j for j, (lo, hi) in enumerate(self.safe(v0)) if lo <= 0.0 <= hi)
        self._add_state(v0, j0, 0.0, -1, None, [])
        goal = self.rm.index[GOAL_KEY]
        while self.heap:
            _, kind, _, ref = heapq.heappop(self.heap)
            if kind == 1:
                self._follow(ref)
                continue
            v, j = self.st[ref][:2]
            if (v, j) in self.closed:
                continue
            self.closed.add((v, j))
            if v == goal:
                if self.safe(v)[j][1] >= self.hold_until:  # it stays there long enough
                    return ref
                self.unheld = True
                continue
            self._expand(ref)
        return None

    def trajectory(self, s: int) -> tuple[np.ndarray, np.ndarray]:
        """The timed trajectory ending at state ``s``: points and a time per point."""
        chain = []
        while s >= 0:
            chain.append(s)
            s = self.st[s][3]
        pts = [self.rm.start_xy]
        ts = [0.0]
        for s in reversed(chain[:-1]):
            src = self.st[s][4]
            assert src is not None
            p = self.rm.chains[src[0]].points[src[1]]
            assert p is not None
            lengths = self.windows[src][0]
            for k, dep in enumerate(self.st[s][5]):
                if dep > ts[-1]:  # a wait at point k
                    pts.append(p[k])
                    ts.append(dep)
                pts.append(p[k + 1])
                ts.append(dep + lengths[k] / self.speed)
        return np.array(pts), np.array(ts)


def _first_horizon(bound: float, movers: list[DynamicObstacle]) -> float:
    """Twice the larger of the lower bound and the last waypoint time of the movers."""
    knots = [float(np.max(d.times)) for d in movers if len(d.times)]
    return 2.0 * max([bound, *knots])


def _starts_inside(boxes: MoverBoxes, start, radius: float, horizon: float) -> bool:
    """Whether the disc at ``start`` overlaps a moving obstacle at t = 0 (the busy times on a
    window reaching before 0: an open interval around 0)."""
    busy = boxes.parked_busy(start, radius, -horizon, horizon)
    return any(lo < 0.0 < hi for lo, hi in busy)


def _early(robot, bound: TimeBound, movers: list[DynamicObstacle], horizon: float
           ) -> TimedPlan | None:
    """The answer that needs no search: no static path, a goal occupied for ever, a start
    inside a moving obstacle, or start = goal."""
    rid = robot.id
    if bound.value is None:
        return TimedPlan(PlanStatus.no_path, None, None, None, f"{rid}: {bound.reason}",
                         bound=bound)
    if math.isinf(bound.value):
        return TimedPlan(PlanStatus.goal_blocked, None, None, None, f"{rid}: {bound.reason}",
                         bound=bound)
    boxes = MoverBoxes.build(movers, robot.radius, horizon)
    if _starts_inside(boxes, robot.start, robot.radius, horizon):
        return TimedPlan(PlanStatus.start_blocked, None, None, None,
                         f"{rid}: the robot overlaps a moving obstacle at t = 0 at its start: "
                         "no collision-free motion exists", bound=bound)
    if bound.value == 0.0:  # start = goal, free at t = 0
        pts = np.vstack([robot.start, robot.goal])
        return TimedPlan(PlanStatus.arrived, 0.0, pts, np.zeros(2),
                         f"{rid}: starts at its goal", 0.0, bound=bound)
    return None


def earliest_arrival(problem: Problem, robot_id: str | None = None, *,
                     movers: list[DynamicObstacle] | None = None,
                     arc_step: float = math.pi / 36, max_doublings: int = 6,
                     max_expansions: int = 1_000_000,
                     stop: Callable[[], bool] | None = None,
                     waypoints: np.ndarray | None = None,
                     hold_until: float = 0.0) -> TimedPlan:
    """The earliest arrival of one robot within the tangent-roadmap model (module docstring).

    Parameters
    ----------
    problem : Problem
    robot_id : str, optional
        Default the planned robot (``problem.leader``).
    movers : list of DynamicObstacle, optional
        The moving obstacles (default ``problem.dynamic_obstacles``; the backend adds the
        robots planned before this one).
    arc_step, max_doublings, max_expansions : float, int, int
        The largest chord angle (rad) of the arc polylines, number of horizon doublings, and
        number of states expanded (all horizons together).
    waypoints : array, optional
        ``(m, 2)`` free points (world) added as vertices where the robot may wait
        (:class:`~optplan.exact.sipp_graph.Roadmap`): never a later arrival than without them.
    hold_until : float
        The robot must stay at its goal, unreached by any mover, from its arrival until this
        time (s; a team holds until it ends); 0: it need only arrive.
    stop : callable, optional
        Polled every 256 units of work (a bounded step whatever the options); True ends the
        search (status ``stopped``).

    Returns
    -------
    TimedPlan
        Status ``arrived`` (the earliest arrival within the model), ``no_path`` (the static
        map has none: a proof), ``start_blocked`` (the robot overlaps a moving obstacle at
        t = 0), ``goal_blocked`` (the goal is occupied for ever: a proof, from the lower
        bound), ``not_found`` (no arrival up to the largest horizon), ``stopped`` (``stop``
        asked) or ``effort`` (``max_expansions`` states expanded without an arrival);
        ``bound`` the certified lower bound
        (:func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound`); ``info`` holds
        ``expansions`` (states expanded, all horizons), ``states``, ``chains`` (windows
        computed), ``horizons`` (searches run), and the roadmap's counters.

    Raises
    ------
    ValueError
        If the robot is unknown or has no goal (a formation follower).
    """
    robot = problem.leader if robot_id is None else problem.robot(robot_id)
    movers = list(problem.dynamic_obstacles if movers is None else movers)
    bound = arrival_lower_bound(problem, robot.id)
    h0 = (max(_first_horizon(bound.value or 0.0, movers), 2.0 * hold_until)
          if bound.value is not None else 0.0)
    early = _early(robot, bound, movers, h0)
    if early is not None:
        return early
    oset = problem.obstacle_set(robot.radius, known_only=False)
    rm = Roadmap(oset, robot.start, robot.goal, arc_step, waypoints)
    budget = [int(max_expansions)]
    info: dict[str, Any] = {"expansions": 0, "states": 0, "chains": 0, "horizons": 0}
    horizon = h0
    for d in range(max_doublings + 1):
        horizon = h0 * 2.0 ** d
        boxes = MoverBoxes.build(movers, robot.radius, horizon)
        search = _Sipp(rm, boxes, robot.radius, robot.max_speed, horizon, budget, stop,
                       hold_until)
        info["horizons"] += 1
        try:
            goal = search.run()
        except _Stopped as e:
            _count(info, search, rm)
            why = ("stopped before an arrival was found" if e.status is PlanStatus.stopped
                   else f"no arrival found within {max_expansions} expansions")
            return TimedPlan(e.status, None, None, None, f"{robot.id}: {why}", horizon, info,
                             bound)
        _count(info, search, rm)
        if goal is not None:
            pts, ts = search.trajectory(goal)
            return TimedPlan(PlanStatus.arrived, float(ts[-1]), pts, ts, _arrival_text(
                robot.id, float(ts[-1]), bound), horizon, info, bound)
    held = (f" that holds the goal until {hold_until:.6g} s (arrivals were found; a moving "
            "obstacle reaches the goal before then)" if search.unheld else "")
    return TimedPlan(PlanStatus.not_found, None, None, None,
                     f"{robot.id}: no arrival{held} found up to the horizon {horizon:.6g} s "
                     f"(the cap: 2^{max_doublings} x the first horizon {h0:.6g} s); not a proof "
                     "that none exists", horizon, info, bound)


def _count(info: dict[str, Any], search: _Sipp, rm: Roadmap) -> None:
    """Add a search's counters to ``info``."""
    for k, n in (("expansions", search.expanded), ("states", len(search.st)),
                 ("chains", len(search.windows))):
        info[k] += n
    info.update({f"roadmap_{k}": v for k, v in rm.info.items()})


def _arrival_text(rid: str, arrival: float, bound: TimeBound) -> str:
    """The message of an arrival: equal to the certified bound, or the gap."""
    b = bound.value
    assert b is not None
    if confirms_optimum(arrival, b):
        return (f"{rid}: earliest arrival {arrival:.6g} s equals the certified lower bound "
                f"({bound.reason})")
    return (f"{rid}: earliest arrival within the tangent-roadmap model {arrival:.6g} s, "
            f"{100 * optimum_gap(arrival, b):.3g} % above the certified lower bound "
            f"{b:.6g} s ({bound.reason})")


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


def _robot_mover(rid: str, radius: float, plan: TimedPlan) -> DynamicObstacle:
    """A planned robot as a moving obstacle for the robots planned after it: a disc of its
    radius on its timed trajectory, parked at its goal afterwards."""
    assert plan.path is not None and plan.times is not None
    keep = np.r_[True, np.diff(plan.times) > 0]
    disc = shapely.Point(0.0, 0.0).buffer(max(radius, 1e-12))
    return DynamicObstacle("circle", disc, plan.times[keep], plan.path[keep], None, "hold",
                           f"robot {rid}", float(radius))


def _merged(plans: dict[str, TimedPlan]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The robots' trajectories on their common time stamps (each held at its goal after its
    arrival)."""
    stamps = np.unique(np.concatenate([p.times for p in plans.values() if p.times is not None]))
    paths = {}
    for rid, p in plans.items():
        assert p.path is not None and p.times is not None
        if len(plans) == 1:
            return {rid: p.path}, p.times
        paths[rid] = positions_at(p.times, p.path, stamps)
    return paths, stamps


def _bound(plan: TimedPlan) -> float | None:
    """The value of a plan's certified lower bound (every ``earliest_arrival`` plan has one)."""
    return None if plan.bound is None else plan.bound.value


def _gap(plan: TimedPlan) -> float | None:
    """``arrival / bound - 1`` (``None`` without an arrival or a positive finite bound)."""
    b = _bound(plan)
    if plan.arrival is None or b is None or math.isinf(b):
        return None
    return optimum_gap(plan.arrival, b)


#: Most passes of prioritised planning (each holds the goals until the last pass's team end).
_HOLD_PASSES = 4
#: TimedPlan status -> the claim of the backend.
_CLAIMS = {PlanStatus.no_path: Status.infeasible, PlanStatus.start_blocked: Status.failed,
           PlanStatus.goal_blocked: Status.failed, PlanStatus.not_found: Status.failed,
           PlanStatus.stopped: Status.approximate, PlanStatus.effort: Status.failed}


@dataclass(frozen=True, kw_only=True)
class SIPP(ClaimsInTime, Backend):
    """Earliest arrival among moving obstacles: safe-interval path planning on the exact
    tangent roadmap (model: the roadmap, full speed on its edges, waits at its vertices).

    Parameters
    ----------
    arc_step : float
        Largest angle (rad, in [1e-4, pi/2]) spanned by one chord of the circumscribed
        polyline an arc is driven along; its corners are vertices where the robot may wait.
        Default ``pi / 36`` (5 degrees), as ``visgraph``.
    max_doublings : int
        Largest number of times the time horizon doubles while no arrival is found (in
        [0, 20], default 6: up to 64 times the first horizon, which is twice the larger of the
        certified lower bound and the last waypoint time of the moving obstacles).
    max_expansions : int
        Largest number of states expanded per robot, all horizons together (default
        1,000,000); beyond it the run fails and says so.
    """

    name: ClassVar[str] = "sipp"
    certifies: ClassVar[bool] = True
    arc_step: float = option(math.pi / 36, lo=1e-4, hi=math.pi / 2)
    max_doublings: int = option(6, lo=0, hi=20)
    max_expansions: int = option(1_000_000, lo=1, hi=10**9)

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t0 = time.perf_counter()
        stopped = [False]

        def poll(k: int, rid: str) -> bool:
            stopped[0] = stopped[0] or notify(callback, Progress(
                iteration=k, best_cost=math.inf, n_eval=k, elapsed=time.perf_counter() - t0,
                info={"robot": rid}))
            return stopped[0]

        hold, note = 0.0, ""
        for _ in range(_HOLD_PASSES):
            plans = self._in_turn(problem, hold, poll if callback is not None else None)
            ends = [p.arrival for p in plans.values() if p.arrival is not None]
            if (len(plans) < 2 or stopped[0] or len(ends) < len(plans)
                    or max(ends) <= hold):
                break
            hold = max(ends)  # every robot holds its goal until the team ends
        else:
            note = (f"the goal holds are planned until {hold:.6g} s; the team ends later "
                    f"(after {_HOLD_PASSES} passes)")
        return self._answer(problem, plans, t0, note)

    def _in_turn(self, problem: Problem, hold: float,
                 poll: Callable[[int, str], bool] | None) -> dict[str, TimedPlan]:
        """One pass of prioritised planning: the robots in turn, each avoiding the movers and
        the robots before it, each holding its goal until ``hold``."""
        movers = list(problem.dynamic_obstacles)
        plans: dict[str, TimedPlan] = {}
        for k, r in enumerate(problem.planned_robots):
            stop = None if poll is None else (lambda k=k, r=r: poll(k, r.id))
            plan = earliest_arrival(problem, r.id, movers=movers, arc_step=self.arc_step,
                                    max_doublings=self.max_doublings,
                                    max_expansions=self.max_expansions, stop=stop,
                                    hold_until=hold)
            plans[r.id] = plan
            if plan.status is not PlanStatus.arrived or (stop is not None and stop()):
                break
            movers.append(_robot_mover(r.id, r.radius, plan))
        return plans

    def earliest_arrival(self, problem: Problem, robot_id: str) -> TimedPlan:
        """:func:`earliest_arrival` of one robot with this preset's options (the reference in
        time of ``op.solve(..., reference=True)``)."""
        return earliest_arrival(problem, robot_id, arc_step=self.arc_step,
                                max_doublings=self.max_doublings,
                                max_expansions=self.max_expansions)

    def _answer(self, problem: Problem, plans: dict[str, TimedPlan], t0: float,
                note: str = "") -> Result:
        """The Result of the plans (every planned robot gets a path)."""
        lead = problem.planned_robots[0].id
        msgs = [p.message for p in plans.values()] + ([note] if note else [])
        failed = [p for p in plans.values() if p.status is not PlanStatus.arrived]
        if failed or len(plans) < len(problem.planned_robots):
            claim = _CLAIMS.get(failed[0].status, Status.approximate) if failed else \
                Status.approximate
            paths = {r.id: np.vstack([r.start, r.start]) for r in problem.planned_robots}
            times = np.zeros(2)
        else:
            paths, times = _merged(plans)
            lp = plans[lead]
            one = len(plans) == 1
            b = _bound(lp)
            claim = (Status.optimal if one and b is not None and lp.arrival is not None and
                     confirms_optimum(lp.arrival, b) else Status.solved)
            if not one:
                msgs.append("robots planned in turn, each avoiding the ones before it and "
                            "holding its goal until the team ends")
        return self._finish(problem, plans, lead, paths, times, claim, "; ".join(msgs), t0)

    def _finish(self, problem: Problem, plans: dict[str, TimedPlan], lead: str,
                paths: dict[str, np.ndarray], times: np.ndarray, claim: Status, message: str,
                t0: float) -> Result:
        """:meth:`Backend.finish` with the extras of the plans."""
        lp = plans.get(lead)
        extras = {"sipp": {rid: {"status": p.status.value, "arrival": p.arrival,
                                 "lower_bound": _bound(p), "gap": _gap(p),
                                 "horizon": p.horizon, **p.info} for rid, p in plans.items()}}
        extra: dict[str, Any] = {}
        if lp is not None:
            extra = {"arrival_time": lp.arrival, "time_lower_bound": _bound(lp),
                     "arrival_gap": _gap(lp)}
        n_eval = sum(int(p.info.get("expansions", 0)) for p in plans.values())
        hist = History()
        cost = lp.arrival if lp is not None and lp.arrival is not None else math.inf
        hist.append(iteration=0, best_cost=cost, n_eval=n_eval,
                    time=time.perf_counter() - t0)
        return self.finish(problem, paths, claim=claim, times=times, cost=cost,
                           message=message, n_iter=sum(int(p.info.get("horizons", 0))
                                                       for p in plans.values()),
                           n_eval=n_eval, history=hist, extras=extras, metrics_extra=extra,
                           wall_time=time.perf_counter() - t0)
