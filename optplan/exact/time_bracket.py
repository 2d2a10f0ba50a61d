r"""A certified bracket on the earliest arrival among moving obstacles: the ``time-bracket`` preset.

``sipp`` is the earliest arrival *within a model* (waits only at the vertices of the tangent
roadmap, full speed on its edges): a valid plan, so an upper bound on the true earliest arrival
over all motions, but not the optimum.  The certified lower bound
(:func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound`) holds for every motion.
This preset brackets the true earliest arrival ``T*`` of one robot,
``lower <= T* <= upper``, and refines both sides level by level until the relative gap
``(upper - lower) / upper`` is at most ``gap_tol`` or ``time_limit`` is spent (anytime: every
level's bracket is valid).

**Upper side** (a valid motion, so ``T* <= upper``).  At level ``L`` the roadmap gains free
waypoints (:func:`lattice`: a lattice of ``2^L - 1`` by ``2^L - 1`` points over the map and rings of
points beside the moving obstacles' waypoints; nested, each level's points contain the
previous level's) as vertices where
the robot may wait, reachable from every vertex by a straight segment or an arc and a tangent
(:class:`~optplan.exact.sipp_graph.Roadmap` ``waypoints``); safe-interval planning on that
larger model (:func:`~optplan.exact.sipp.earliest_arrival`) cannot be later than on the smaller
one.  With ``retime = true`` its path is then re-timed exactly along the
same curve (:func:`~optplan.geometry.timing.schedule.fastest_schedule`: waits anywhere on the
path, not only at vertices), and so is the path with its corners cut where the cut is free
(:func:`shortcut`).  Every candidate is checked by the validator (static map and moving
obstacles in continuous time) before it counts, and the best so far is kept, so the upper
side never rises.  Level 0 is exactly ``sipp``.

**Lower side** (``lower <= T*``).  The bound of
:func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound` (level 0: the static optimum
over ``max_speed``, pushed past the goal's busy times; at upper level ``L >= 1`` the space-time
cell relaxation of :mod:`optplan.geometry.timing.cell_bound` at level
``min(L + LOWER_AHEAD, MAX_LOWER_LEVEL)``); the best so far is kept, so the lower side never
falls.

**Status.**  ``optimal`` when the bracket closes within :data:`~optplan.result.OPTIMAL_REL_TOL`
(the plan's arrival is certified to be the earliest over all motions), else ``solved`` with
the gap in the message.  The metrics carry ``arrival_upper``, ``arrival_lower`` and
``arrival_gap``; ``extras["time_bracket"]["levels"]`` the bracket after each level.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan import solver
from optplan.backend import ClaimsInTime
from optplan.exact.sipp import earliest_arrival
from optplan.geometry.collision import farthest_clear
from optplan.geometry.timing import (
    PlanStatus,
    TimeBound,
    TimedPlan,
    arrival_lower_bound,
    fastest_schedule,
)
from optplan.metrics import evaluate
from optplan.problem import Problem
from optplan.result import History, Progress, Result, Status, confirms_optimum, notify
from optplan.solver import Backend, option

__all__ = ["TimeBracket", "Bracket", "lattice", "shortcut", "time_bracket"]


def _reach(dyn: Any) -> float:
    """The largest distance from a moving obstacle's reference point to its shape."""
    if dyn.kind == "circle" and dyn.radius is not None:
        return float(dyn.radius)
    return float(np.max(np.hypot(*np.asarray(dyn.local_geometry.exterior.coords).T)))


def lattice(problem: Problem, robot_id: str, level: int) -> np.ndarray:
    """The free waypoints of level ``level`` (world ``(m, 2)``): the lattice points
    ``x0 + i (x1 - x0) / 2^level``, ``y0 + j (y1 - y0) / 2^level`` (``0 < i, j < 2^level``),
    and beside every moving obstacle's waypoints (where it parks, turns or passes a door) the
    points at ``1.05 x`` its reach plus the robot's radius in ``2^(level + 1)`` directions;
    those whose disc of the robot's radius is free of the static map (temporary obstacles
    included).  Level ``L + 1``'s points contain level ``L``'s; level 0 has none."""
    if level <= 0:
        return np.zeros((0, 2))
    x0, y0, x1, y1 = problem.bounds
    n = 2 ** int(level)
    k = np.arange(1, n) / n
    xx, yy = np.meshgrid(x0 + (x1 - x0) * k, y0 + (y1 - y0) * k, indexing="ij")
    pts = [np.column_stack([xx.ravel(), yy.ravel()])]
    r = problem.robot(robot_id).radius
    ang = 2 * np.pi * np.arange(2 * n) / (2 * n)
    ring = np.column_stack([np.cos(ang), np.sin(ang)])
    for d in problem.dynamic_obstacles:
        rho = 1.05 * (_reach(d) + r)
        pts += [np.asarray(w, float) + rho * ring for w in np.asarray(d.waypoints, float)]
    out = np.vstack(pts)
    inside = ((out[:, 0] > x0) & (out[:, 0] < x1) & (out[:, 1] > y0) & (out[:, 1] < y1))
    out = out[inside]
    oset = problem.obstacle_set(r, known_only=False)
    return out[oset.segment_free(out, out)]


def shortcut(problem: Problem, robot_id: str, path: np.ndarray) -> np.ndarray:
    """``path`` (without waits) with its corners cut where the straight cut is free of the
    static map: from each kept point, the farthest later point in plain sight."""
    oset = problem.obstacle_set(problem.robot(robot_id).radius, known_only=False)
    pts = _no_waits(path)
    out, i = [pts[0]], 0
    while i < len(pts) - 1:
        j = farthest_clear(pts[i], pts, lambda p, q: oset.segment_free(
            np.broadcast_to(p, q.shape), q), np.arange(i + 1, len(pts)))
        i = i + 1 if j is None else int(j)
        out.append(pts[i])
    return np.asarray(out)


def _no_waits(path: np.ndarray) -> np.ndarray:
    """``path`` without consecutive repeated points (a wait is a repeated point)."""
    keep = np.r_[True, np.any(np.diff(path, axis=0) != 0, axis=1)]
    return path[keep]


@dataclass
class Bracket:
    """The bracket ``lower <= T* <= upper`` of one robot's earliest arrival.

    Attributes
    ----------
    upper : float
        The earliest valid arrival found (``inf`` before one is found).
    lower : float
        The best certified lower bound.
    plan : TimedPlan or None
        The plan of ``upper``.
    levels : list of dict
        Per level reached: ``level``, ``upper``, ``lower``, ``gap``, ``seconds`` (since the
        start), ``source`` of the upper side (``"sipp"``, ``"retimed"``, ``"shortcut"``).
    stopped : bool
        The limit or the callback ended the refinement.
    """

    upper: float = math.inf
    lower: float = 0.0
    plan: TimedPlan | None = None
    levels: list[dict[str, Any]] = field(default_factory=list)
    stopped: bool = False

    @property
    def gap(self) -> float:
        """``(upper - lower) / upper`` (1 without an upper side, 0 when both are 0)."""
        if not math.isfinite(self.upper):
            return 1.0
        return 0.0 if self.upper <= 0.0 else max(self.upper - self.lower, 0.0) / self.upper


def _valid(problem: Problem, rid: str, plan: TimedPlan) -> bool:
    """Whether the validator accepts ``plan`` for robot ``rid`` (reaches its goal, no
    contact with the static map or the moving obstacles, in continuous time)."""
    if plan.path is None or plan.times is None or plan.arrival is None:
        return False
    m = evaluate(problem, {rid: np.asarray(plan.path, float)}, np.asarray(plan.times, float))
    return bool(m["reached"] and m["collisions"] == 0 and m["in_bounds"])


def _candidates(problem: Problem, rid: str, plan: TimedPlan) -> list[tuple[str, TimedPlan]]:
    """The path-velocity improvements of ``plan``: its path re-timed, and cut and re-timed."""
    path = _no_waits(np.asarray(plan.path, float))
    out = [("retimed", fastest_schedule(problem, path, rid))]
    cut = shortcut(problem, rid, path)
    if len(cut) < len(path):
        out.append(("shortcut", fastest_schedule(problem, cut, rid)))
    return out


#: The lower side's level is the upper side's plus this (its cells are cheaper than
#: waypoints), at most :data:`MAX_LOWER_LEVEL`.
LOWER_AHEAD = 3
#: The finest level of the lower side (``8^8`` booleans in its blocked table).
MAX_LOWER_LEVEL = 8


#: The finest level of the bracket that grades plans (``reference=True``): deterministic, a
#: few seconds at most on the catalogue's and the families' scenes.
GRADING_LEVEL = 2
#: Outcomes of a level's search that no refinement changes (proofs, or a start inside a mover).
_FINAL = (PlanStatus.no_path, PlanStatus.goal_blocked, PlanStatus.start_blocked)


def _upper(problem: Problem, rid: str, br: Bracket, plan: TimedPlan, retime: bool,
           stop: Callable[[], bool]) -> str:
    """Lower ``br``'s upper side to the earliest valid candidate of a level's ``plan`` (its
    re-timings with ``retime``); the candidate's name, or ``"-"``."""
    if plan.status is not PlanStatus.arrived:
        return "-"
    found = [("sipp", plan)]
    if retime and not stop():
        found += _candidates(problem, rid, plan)
    source = "-"
    for name, cand in found:
        if cand.arrival is not None and cand.arrival < br.upper and _valid(problem, rid, cand):
            br.upper, br.plan, source = float(cand.arrival), cand, name
    return source


def _lower(problem: Problem, rid: str, br: Bracket, level: int,
           stop: Callable[[], bool]) -> None:
    """Raise ``br``'s lower side to the bound of ``level`` (:data:`LOWER_AHEAD` ahead)."""
    lv = 0 if level == 0 else min(level + LOWER_AHEAD, MAX_LOWER_LEVEL)
    bound = arrival_lower_bound(problem, rid, stop=stop, level=lv)
    if bound.value is not None:
        br.lower = max(br.lower, float(bound.value))


def time_bracket(problem: Problem, robot_id: str, *, gap_tol: float, max_level: int,
                 stop: Callable[[], bool], on_level: Callable[[Bracket], Any] | None = None,
                 bracket: Bracket | None = None, retime: bool = False) -> Bracket:
    """Refine the bracket of ``robot_id``'s earliest arrival (module docstring) level by level
    from 0 to ``max_level`` until its gap is at most ``gap_tol`` or ``stop()`` says so
    (polled by every search and by the lower bound's relaxation); ``on_level(bracket)`` after
    each level.  ``bracket``: the record to fill (a caller may read it while ``stop`` runs);
    ``retime``: also re-time each level's path exactly (:func:`fastest_schedule`, which does
    not poll ``stop``)."""
    br, t0 = (Bracket() if bracket is None else bracket), time.perf_counter()
    for level in range(max_level + 1):
        plan = earliest_arrival(problem, robot_id, waypoints=lattice(problem, robot_id, level),
                                stop=stop)
        source = _upper(problem, robot_id, br, plan, retime, stop)
        br.stopped = plan.status is PlanStatus.stopped or stop()
        if level == 0 or not br.stopped:  # a stopped level keeps the last lower side
            _lower(problem, robot_id, br, level, stop)
        br.levels.append({"level": level, "upper": br.upper, "lower": br.lower, "gap": br.gap,
                          "seconds": time.perf_counter() - t0, "source": source})
        if on_level is not None:
            on_level(br)
        if br.stopped or br.gap <= gap_tol or plan.status in _FINAL:
            break
    return br


@dataclass(frozen=True, kw_only=True)
class TimeBracket(ClaimsInTime, Backend):
    """The certified bracket on one robot's earliest arrival over all motions
    (:mod:`optplan.exact.time_bracket`).

    Parameters
    ----------
    gap_tol : float
        Stop refining when ``(upper - lower) / upper`` is at most this (in [0, 1], default
        0.02).
    max_level : int
        Finest level (in [0, 8], default 6): the lattice of level ``L`` has ``(2^L - 1)^2``
        points.
    time_limit : float or None
        Seconds (> 0, default 10); the refinement stops at the first poll after it and
        returns the bracket reached.  ``solve(time_limit=S)`` replaces it.
    retime : bool
        Also re-time each level's path exactly along its curve and along its shortcut
        (``fastest_schedule``, waits anywhere on the path; default false: it does not poll
        the time limit, and can take many seconds on long paths among many movers).

    Notes
    -----
    ``solve(init={robot: path})`` starts the upper side from ``path`` (any valid motion is an
    upper bound): the fastest schedule along it (``fastest_schedule``: its time counts against
    the time limit, which it does not poll) counts when the validator accepts it, and
    ``extras["time_bracket"]["init"]`` says what became of it.  A plan of the same scene with
    more static obstacles is such a path: the bracket without them is then never later.
    """

    name: ClassVar[str] = "time-bracket"
    certifies: ClassVar[bool] = True
    gap_tol: float = option(0.02, lo=0.0, hi=1.0)
    max_level: int = option(6, lo=0, hi=8)
    time_limit: float | None = option(10.0, lo=0.0, lo_open=True, inf_ok=True, none_ok=True)
    retime: bool = option(False)

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        if len(problem.planned_robots) != 1:
            raise ValueError(f"time-bracket plans one robot; problem {problem.name!r} has "
                             f"{len(problem.planned_robots)} planned robots")
        t0, start = time.perf_counter(), solver.clock()  # the module's: tests replace it
        rid = problem.planned_robots[0].id
        br = Bracket()
        state = {"stop": False, "timed_out": False}

        def report() -> bool:
            level = br.levels[-1]["level"] if br.levels else -1
            return notify(callback, Progress(
                iteration=level + 1, best_cost=br.upper, n_eval=level + 1,
                elapsed=time.perf_counter() - t0,
                info={"arrival_lower": br.lower, "arrival_gap": br.gap}))

        def stop() -> bool:
            if not state["stop"] and self.time_limit is not None and \
                    solver.clock() - start >= self.time_limit:
                state["stop"] = state["timed_out"] = True
            state["stop"] = state["stop"] or report()
            return state["stop"]

        seeded = _seed(problem, rid, br, init)
        time_bracket(problem, rid, gap_tol=self.gap_tol, max_level=self.max_level,
                     stop=stop, on_level=lambda b: stop(), bracket=br, retime=self.retime)
        res = self._answer(problem, rid, br, t0, "time_limit" if state["timed_out"] else "")
        if seeded is not None:
            res.extras["time_bracket"]["init"] = seeded
        return res

    def reference(self, problem: Problem, robot_id: str) -> TimedPlan:
        """The bracket of ``robot_id`` up to :data:`GRADING_LEVEL` without a time limit (the
        reference in time of ``op.solve(..., reference=True)``: deterministic, cached by the
        grading): the plan of its upper side, ``bound`` its lower side."""
        br = time_bracket(problem, robot_id, gap_tol=self.gap_tol,
                          max_level=min(self.max_level, GRADING_LEVEL), stop=lambda: False)
        lower = TimeBound(br.lower, None, None, f"time bracket, level "
                          f"{br.levels[-1]['level']}: gap {100 * br.gap:.3g} %")
        if br.plan is None:
            first = earliest_arrival(problem, robot_id)  # why there is no arrival
            return dataclasses.replace(first, bound=lower if first.bound is None or (
                first.bound.value is not None and br.lower > first.bound.value) else
                first.bound)
        return dataclasses.replace(br.plan, status=PlanStatus.arrived, arrival=br.upper,
                                   bound=lower, message=f"{robot_id}: bracket [{br.lower:.6g}, "
                                   f"{br.upper:.6g}] s (gap {100 * br.gap:.3g} %)")

    def _answer(self, problem: Problem, rid: str, br: Bracket, t0: float,
                stop_reason: str) -> Result:
        """The Result of a bracket: the plan of its upper side and its figures."""
        figures = {"arrival_upper": br.upper if br.plan is not None else None,
                   "arrival_lower": br.lower, "arrival_gap": br.gap if br.plan else None}
        hist = History()
        for lv in br.levels:
            hist.append(iteration=lv["level"], best_cost=lv["upper"], n_eval=lv["level"] + 1,
                        time=lv["seconds"])
        level = br.levels[-1]["level"] if br.levels else -1
        if br.plan is None:
            r = problem.robot(rid)
            paths, times = {rid: np.vstack([r.start, r.start])}, np.zeros(2)
            claim, msg = Status.failed, f"{rid}: no valid arrival found up to level {level}"
        else:
            paths, times = {rid: np.asarray(br.plan.path)}, np.asarray(br.plan.times)
            closed = confirms_optimum(br.upper, br.lower)
            claim = Status.optimal if closed else Status.solved
            msg = (f"{rid}: arrival {br.upper:.6g} s in [{br.lower:.6g}, {br.upper:.6g}] s "
                   f"(gap {100 * br.gap:.3g} %, level {level}"
                   + ("; the earliest over all motions)" if closed else ")"))
        if stop_reason:
            msg += "; stopped by the time limit"
        res = self.finish(problem, paths, claim=claim, times=times,
                          cost=br.upper, message=msg, history=hist,
                          extras={"time_bracket": {"levels": br.levels}},
                          metrics_extra={**figures, "arrival_time": figures["arrival_upper"]},
                          n_iter=len(br.levels), n_eval=len(br.levels),
                          wall_time=time.perf_counter() - t0)
        return res if not stop_reason else _stopped(res)


def _seed(problem: Problem, rid: str, br: Bracket, init: dict[str, np.ndarray] | None
          ) -> dict[str, Any] | None:
    """Start ``br``'s upper side from ``init[rid]`` timed by the fastest schedule along it,
    when the validator accepts that; what became of it (``None`` without ``init``)."""
    if not init or rid not in init:
        return None
    plan = fastest_schedule(problem, np.asarray(init[rid], float), rid)
    used = plan.arrival is not None and _valid(problem, rid, plan)
    if used:
        br.upper, br.plan = float(plan.arrival), plan  # type: ignore[arg-type]
    return {"arrival": plan.arrival, "status": plan.status.value, "used": used,
            "message": plan.message}


def _stopped(res: Result) -> Result:
    """``res`` marked as ended by the time limit."""
    return dataclasses.replace(res, stop_reason="time_limit")
