"""Grading a plan in time: every robot's arrival against the references in time.

On a problem with moving obstacles, ``op.solve(..., reference=True)`` grades each robot of the
plan (:func:`with_time_reference`):

* ``arrival_time``: the plan as executed (:func:`~optplan.geometry.timing.time_bounds.arrival_time`:
  the first stamp within the goal tolerance; a geometric path is timed at ``max_speed``).  A
  follower has no goal: its arrival is the time it reaches the end of its path for good;
* ``schedule_arrival``: the fastest timing of the same geometric path up to that point
  (:func:`~optplan.geometry.timing.schedule.fastest_schedule`, exact): how much the planner lost by
  its timing alone;
* ``arrival_at_goal``: for a robot with a goal, the arrival at the goal *point* of the plan
  completed from where it enters the goal tolerance by the shortest continuation at
  ``max_speed`` (:mod:`optplan.goal_completion`): every reference is for the goal point;
* ``time_reference``: the upper side of the reference in time (``op.solve`` passes the
  ``time-bracket`` preset's bracket at its grading level,
  :meth:`optplan.exact.time_bracket.TimeBracket.reference`: ``sipp`` on the exact tangent
  roadmap and on free waypoints; at most ``sipp``'s arrival), for robots with a goal.  The
  reference planner's model is narrower than the motions a plan may make: when the completed
  plan is valid and reaches the goal point earlier, it is the better upper bound
  on the earliest arrival and becomes the reference of this grading
  (``time_reference_source`` says so), so no valid plan has a ratio to the reference below 1;
* ``time_lower_bound``: the certified bound of
  :func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound`, or the reference's lower
  side when it is higher (robots with a goal);
* the ratios of ``arrival_at_goal`` to the reference and the bound, and of ``arrival_time``
  to ``schedule_arrival``.

The planned robot's (the leader's) grades are metrics of their own; with more than one robot,
``time_per_robot`` holds every robot's.  The references are cached on the problem.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from optplan.geometry.timing import (
    PlanStatus,
    TimedPlan,
    arrival_lower_bound,
    arrival_time,
    fastest_schedule,
    path_times,
)
from optplan.goal_completion import completed_arrival
from optplan.problem import Problem

__all__ = ["with_time_reference", "grade_robot", "Reference"]

#: ``reference(problem, robot_id)``: the earliest arrival of a reference planner in time.
Reference = Callable[[Problem, str], TimedPlan]


def _arrival(problem: Problem, rid: str, pts: np.ndarray, times: Any
             ) -> tuple[float | None, int | None]:
    """The arrival as executed and the index of the point where it happens."""
    robot = problem.robot(rid)
    stamps = path_times(pts, robot.max_speed, times)
    if robot.goal is not None:
        t = arrival_time(problem, rid, pts, times)
        return t, (None if t is None else int(np.searchsorted(stamps, t)))
    moved = np.flatnonzero(np.any(pts != pts[-1], axis=1))
    end = 0 if len(moved) == 0 else int(moved[-1]) + 1
    return float(stamps[end]), end


def _reference(problem: Problem, rid: str, reference: Reference) -> dict[str, Any]:
    """The reference planner's earliest arrival of one robot (cached on the problem)."""

    def build() -> dict[str, Any]:
        plan = reference(problem, rid)
        return {"time_reference": plan.arrival, "time_reference_status": plan.status.value,
                "time_reference_message": plan.message, "bound": plan.bound}

    return dict(problem.memo(("time_reference", rid), build))


def _ratio(a: float | None, b: float | None) -> float | None:
    ok = a is not None and b is not None and 0 < b < math.inf
    return float(a) / float(b) if ok else None  # type: ignore[arg-type]


def _against_reference(out: dict[str, Any], problem: Problem, rid: str, reference: Reference,
                       done: Any, bound: Any) -> Any:
    """Put the reference's upper side in ``out`` (the completed plan's arrival when it is valid
    and earlier); the better of ``bound`` and the reference's own lower side."""
    got = _reference(problem, rid, reference)
    ref_bound = got.pop("bound")  # the reference's own lower side (a bracket's)
    if ref_bound is not None and ref_bound.value is not None and (
            bound.value is None or ref_bound.value > bound.value):
        bound = ref_bound
    out.update(got)
    ref, at_goal = out["time_reference"], None if done is None else done.arrival
    if done is not None and done.valid and at_goal is not None and (ref is None or at_goal < ref):
        out["time_reference"] = at_goal  # a valid motion: an upper bound on the optimum
        out["time_reference_source"] = "this plan (earlier than the reference planner)"
    return bound


def grade_robot(problem: Problem, rid: str, path: Any, times: Any = None,
                reference: Reference | None = None) -> dict[str, Any]:
    """One robot's grades in time (module docstring): ``arrival_time``, ``schedule_arrival``,
    ``schedule_status`` and, for a robot with a goal, ``arrival_at_goal``,
    ``arrival_completion`` and ``arrival_completion_status``
    (:func:`~optplan.goal_completion.completed_arrival`), ``time_reference``,
    ``time_lower_bound``, ``time_bound_reason``; the ratios ``arrival_ratio_to_schedule``,
    ``arrival_ratio_to_reference``, ``arrival_ratio_to_lower`` where both sides exist
    (``time_reference`` only with a ``reference`` planner)."""
    pts = np.asarray(path, float)
    arrival, end = _arrival(problem, rid, pts, times)
    out: dict[str, Any] = {"arrival_time": arrival, "schedule_arrival": None,
                           "schedule_status": "no arrival"}
    if end is not None:
        sch = fastest_schedule(problem, pts[:end + 1], rid)
        out["schedule_arrival"], out["schedule_status"] = sch.arrival, sch.status.value
        if sch.status is not PlanStatus.scheduled:
            out["schedule_message"] = sch.message
    out["arrival_ratio_to_schedule"] = _ratio(arrival, out["schedule_arrival"])
    robot = problem.robot(rid)
    if robot.goal is None:
        return out
    done = None
    if end is not None:
        done = completed_arrival(problem, rid, pts, path_times(pts, robot.max_speed, times), end)
        out.update(arrival_at_goal=done.arrival, arrival_completion=done.distance,
                   arrival_completion_status=done.status)
    at_goal = None if done is None else done.arrival
    bound = problem.memo(("arrival_lower_bound", rid), lambda: arrival_lower_bound(problem, rid))
    if reference is not None:
        bound = _against_reference(out, problem, rid, reference, done, bound)
    out["time_lower_bound"], out["time_bound_reason"] = bound.value, bound.reason
    out["arrival_ratio_to_reference"] = _ratio(at_goal, out.get("time_reference"))
    out["arrival_ratio_to_lower"] = _ratio(at_goal, bound.value)
    return out


def with_time_reference(metrics: dict[str, Any], problem: Problem, paths: dict[str, Any],
                        times: Any, reference: Reference | None = None) -> dict[str, Any]:
    """``metrics`` plus the grades in time of the plan (module docstring; ``reference``: see
    :func:`grade_robot`); unchanged on a problem without moving obstacles."""
    if not problem.dynamic_obstacles or not paths:
        return metrics
    out = dict(metrics)
    per = {rid: grade_robot(problem, rid, p, times, reference) for rid, p in paths.items()}
    lead = problem.leader.id
    if lead in per:
        out.update(per[lead])
    if len(per) > 1:
        out["time_per_robot"] = per
    return out
