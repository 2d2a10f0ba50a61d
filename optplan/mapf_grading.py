"""Grading the plan of robots with their own goals: the team's sum of arrivals against ``ccbs``.

On a problem whose planned robots each have a goal (no formation: multi-agent path finding),
``op.solve(..., reference=True)`` grades the whole plan (:func:`with_sum_reference`):

* ``sum_of_arrivals``: the sum over the robots of their arrival at the goal *point* (a robot
  accepted inside its goal tolerance is completed by its shortest continuation at
  ``max_speed``, :mod:`optplan.goal_completion`); ``None`` when a robot does not arrive or a
  continuation meets a moving obstacle;
* ``sum_reference``: the sum of the ``ccbs`` preset's plan (the team optimum within its
  roadmap model, found by name in the solver registry; computed once per problem), when the
  validator accepts that plan.  It is a valid team motion, so an upper bound on the best sum
  over all motions; it is not a bound the other way: planners that move in the plane, off the
  roadmap, may beat it.  When this plan is valid (success, no contact) and its sum is smaller,
  it is the better upper bound and becomes the reference of this grading
  (``sum_reference_source`` says so), so no valid plan has ``sum_ratio_to_reference < 1``;
* ``sum_lower_bound``: the sum of the robots' certified arrival lower bounds
  (:func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound`, each valid for every
  motion of that robot alone, so their sum for every team motion);
* ``sum_ratio_to_reference`` and ``sum_ratio_to_lower``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from optplan.geometry.timing import arrival_lower_bound, arrival_time, path_times
from optplan.goal_completion import completed_arrival
from optplan.problem import Problem
from optplan.result import Result

__all__ = ["with_sum_reference", "SumReference", "applies"]

#: ``reference(problem) -> Result``: a team plan of every planned robot (``ccbs``'s).
SumReference = Callable[[Problem], Result]


def applies(problem: Problem) -> bool:
    """Whether ``problem`` is graded by its sum of arrivals: two or more planned robots, each
    with a goal, and no formation."""
    robots = problem.planned_robots
    return (problem.formation is None and len(robots) >= 2
            and all(r.goal is not None for r in robots))


def _sum(problem: Problem, paths: dict[str, Any], times: Any) -> float | None:
    """The sum of the robots' arrivals at their goal points (module docstring)."""
    total = 0.0
    for r in problem.planned_robots:
        if r.id not in paths:
            return None
        pts = np.asarray(paths[r.id], float)
        t = arrival_time(problem, r.id, pts, times)
        if t is None:
            return None
        stamps = path_times(pts, r.max_speed, times)
        done = completed_arrival(problem, r.id, pts, stamps, int(np.searchsorted(stamps, t)))
        if done.arrival is None:
            return None
        total += float(done.arrival)
    return total


def _valid(res: Result) -> bool:
    """Success and no contact of any kind (the validator's word)."""
    return bool(res.success and not res.metrics.get("collisions"))


def _reference(problem: Problem, reference: SumReference) -> dict[str, Any]:
    """The reference's figures, computed once per problem."""

    def build() -> dict[str, Any]:
        ref = reference(problem)
        ok = _valid(ref)
        return {"sum_reference": _sum(problem, ref.paths, ref.times) if ok else None,
                "sum_reference_status": ref.status.value,
                "sum_reference_message": ref.message if ok else
                f"not a valid team plan: {ref.message}"}

    return dict(problem.memo(("sum_reference",), build))


def _lower(problem: Problem) -> float | None:
    """The sum of the robots' certified arrival lower bounds (cached per robot)."""
    total = 0.0
    for r in problem.planned_robots:
        b = problem.memo(("arrival_lower_bound", r.id),
                         functools.partial(arrival_lower_bound, problem, r.id))
        if b.value is None:
            return None
        total += float(b.value)
    return total


def _ratio(a: float | None, b: float | None) -> float | None:
    ok = a is not None and b is not None and 0 < b < float("inf")
    return float(a) / float(b) if ok else None  # type: ignore[arg-type]


def with_sum_reference(metrics: dict[str, Any], problem: Problem, res: Result,
                       reference: SumReference) -> dict[str, Any]:
    """``metrics`` plus the grading of the team's sum of arrivals (module docstring);
    unchanged when the problem is not one of robots with their own goals (:func:`applies`)."""
    if not applies(problem):
        return metrics
    out = dict(metrics)
    mine = _sum(problem, res.paths, res.times)
    out["sum_of_arrivals"] = mine
    out.update(_reference(problem, reference))
    ref = out["sum_reference"]
    if mine is not None and _valid(res) and (ref is None or mine < ref):
        out["sum_reference"] = mine  # a valid team motion: an upper bound on the best sum
        out["sum_reference_source"] = "this plan (earlier than the reference planner)"
    out["sum_lower_bound"] = _lower(problem)
    out["sum_ratio_to_reference"] = _ratio(mine, out["sum_reference"])
    out["sum_ratio_to_lower"] = _ratio(mine, out["sum_lower_bound"])
    return out
