"""Grading a team plan against the best known team plans: ``op.solve(..., reference="team")``.

**The reference is a property of the problem, not of the plan.**  A set of candidate team
plans is computed once per problem (cached on it, :meth:`~optplan.problem.Problem.memo`) by a
reference function found by name in the solver registry (``op.solve`` passes
:func:`optplan.solver.team_reference`: the ``formation-nlp`` preset's
``team_candidates``, the team heuristics each run with a fixed seed and the joint trajectory
NLP polished from each of them; the core names no method family).  The candidates the
validator accepts (``success``, ``feasible``, ``reached``, no collision, the leader's arrival
at its goal point valid) are points ``(arrival, rmse)``: the leader's arrival at its goal
*point* (``arrival_at_goal`` of :mod:`optplan.goal_completion`: a run accepted inside the goal
tolerance is completed by its shortest continuation at ``max_speed``, as in the grading in
time) and the formation RMSE.  The **front** is the set of non-dominated points (no other
candidate is as early and as well formed, and better on one).  Every plan of a problem is
graded against the same front.

**The rule** (two criteria, one tolerance :data:`RTOL`, "no worse" = within it):

* ``arrival_ratio_to_team`` = the plan's arrival / ``team_arrival_reference``, the earliest
  arrival of a front member whose RMSE is no worse than the plan's (``rmse_m <= rmse (1 +
  RTOL) + ABS_RMSE * Lbar``, ``Lbar`` the mean slot distance);
* ``formation_rmse_ratio_to_team`` = the plan's RMSE / ``team_formation_rmse_reference``, the
  smallest RMSE of a front member that arrives no later than the plan (``arrival_m <= arrival
  (1 + RTOL)``), both sides floored at ``ABS_RMSE * Lbar`` (the resolution of the RMSE);
* a plan the validator accepts joins the front for its own grading: when it is better than
  every front member that qualifies (or none qualifies), its own value is the reference and
  ``team_reference_source`` says ``"this plan"``.  So **no valid plan has a ratio below 1**
  (the rule of the grading in time: a valid plan better than the reference replaces it).  A
  plan the validator rejects is compared with the front members only (its ratios may be below
  1, or ``None`` when no member qualifies).

**What the numbers certify.**  Every front member is a feasible team plan, so a reference is
an *upper* bound on the best achievable value at that level of the other criterion, and a
ratio is an upper bound on how far the plan is from the best known plan, not from the true
optimum (the NLP is local: the true front may lie further down).  ``team_arrival_lower_bound``
is certified: the leader's :func:`~optplan.geometry.timing.arrival_lower_bound` (its static
shortest path at ``max_speed``, or the first time the goal is free after it), below every
motion of the leader whatever the formation; ``arrival_ratio_to_team_lower`` (plan / bound,
``>= 1`` for every valid plan) bounds how far the arrival is from the true optimum.

Metrics (problems with a formation whose leader has a goal):

* ``team_reference_status`` (``"solved"``: a front exists; ``"no valid candidate"``;
  ``"no formation"``), ``team_reference_message`` (the front and the candidates left out);
* ``team_arrival``: the plan's leader arrival at its goal point; ``team_plan_valid``;
* ``team_arrival_reference``, ``team_formation_rmse_reference`` and their sources
  (``team_arrival_reference_source``, ``team_formation_rmse_reference_source``, and
  ``team_reference_source``: the one source, or both named);
* ``team_min_separation_reference``: the smaller smallest distance between robot centres of
  the reference plans used (informational: ``separation_ratio_to_team`` is above or below 1);
* ``arrival_ratio_to_team``, ``formation_rmse_ratio_to_team``, ``separation_ratio_to_team``;
* ``team_arrival_lower_bound``, ``team_arrival_lower_bound_reason``,
  ``arrival_ratio_to_team_lower``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.geometry.timing import arrival_lower_bound, arrival_time, path_times
from optplan.goal_completion import completed_arrival
from optplan.problem import Problem
from optplan.result import Result

__all__ = ["with_team_reference", "team_front", "TeamReference", "TeamFront", "TeamPoint",
           "team_point", "RTOL", "ABS_RMSE"]

#: ``reference(problem) -> {source: plan}``: the candidate team plans of a problem.
TeamReference = Callable[[Problem], dict[str, Result]]

#: Relative tolerance of "no worse" on both criteria (0.1 %).
RTOL = 1e-3
#: The resolution of the formation RMSE, in mean slot distances (0.1 %, the NLP's own tolerance
#: on it): the absolute slack of "no worse" on the RMSE, and the floor of both sides of
#: ``formation_rmse_ratio_to_team`` (an RMSE of 1e-6 against one of 1e-7 is a tie, not 10).
ABS_RMSE = 1e-3

#: The source of a reference that is the graded plan itself.
THIS_PLAN = "this plan"


@dataclass(frozen=True)
class TeamPoint:
    """A team plan on the two criteria: the leader's ``arrival`` at its goal point (s), the
    formation ``rmse``, the smallest distance between robot centres ``separation``, whether
    the validator accepts it (``valid``, with ``why`` not when it does not) and the run's
    ``stop_reason`` (``"time_limit"``: cut short)."""

    source: str
    arrival: float | None
    rmse: float | None
    separation: float | None
    valid: bool
    why: str = ""
    stop_reason: str = ""


@dataclass(frozen=True)
class TeamFront:
    """The non-dominated valid candidates of a problem (``members``, by arrival) and every
    candidate graded (``candidates``)."""

    members: tuple[TeamPoint, ...]
    candidates: tuple[TeamPoint, ...]


def _leader_arrival(problem: Problem, lead: str, res: Result) -> tuple[float | None, str]:
    """The leader's arrival at its goal point and why there is none (``""`` when valid)."""
    if lead not in res.paths:
        return None, "no path for the leader"
    pts = np.asarray(res.paths[lead], float)
    t = arrival_time(problem, lead, pts, res.times)
    if t is None:
        return None, "the leader does not arrive"
    stamps = path_times(pts, problem.robot(lead).max_speed, res.times)
    done = completed_arrival(problem, lead, pts, stamps, int(np.searchsorted(stamps, t)))
    return done.arrival, ("" if done.valid else done.status)


def team_point(problem: Problem, res: Result, source: str = THIS_PLAN) -> TeamPoint:
    """``res`` on the two criteria (:class:`TeamPoint`), judged by the validator's metrics:
    valid when it succeeds, is feasible, reached, has no collision and its leader's arrival
    at the goal point is valid."""
    form = problem.formation
    assert form is not None, "a team point needs a formation"
    m = res.metrics
    arrival, why = _leader_arrival(problem, form.leader, res)
    rmse, sep = m.get("formation_rmse"), m.get("min_separation")
    checks = ((res.success, f"status {res.status.value}"),
              (m.get("feasible") and m.get("reached"), "not feasible or not reached"),
              (m.get("collisions", 0) == 0, f"{m.get('collisions')} collisions"),
              (rmse is not None, "no formation RMSE"), (not why, why))
    bad = [text for ok, text in checks if not ok]
    return TeamPoint(source, arrival, None if rmse is None else float(rmse),
                     None if sep is None else float(sep), not bad, "; ".join(bad),
                     res.stop_reason)


def _front(points: list[TeamPoint]) -> tuple[TeamPoint, ...]:
    """The valid points no other valid point dominates (ties: the first), by arrival."""
    ok = [(p.arrival, p.rmse, p) for p in points
          if p.valid and p.arrival is not None and p.rmse is not None]
    keep = []
    for i, (a, e, p) in enumerate(ok):
        if not any((b, f) == (a, e) and j < i or (b <= a and f <= e and (b, f) != (a, e))
                   for j, (b, f, _) in enumerate(ok)):
            keep.append((a, e, p))
    return tuple(p for _, _, p in sorted(keep, key=lambda k: (k[0], k[1])))


def team_front(problem: Problem, reference: TeamReference) -> TeamFront:
    """The front of ``reference(problem)``'s candidates (module docstring), built once per
    problem and reference function (cached on the problem)."""
    def build() -> TeamFront:
        pts = [team_point(problem, res, source) for source, res in reference(problem).items()]
        return TeamFront(_front(pts), tuple(pts))

    return problem.memo(("team_front", reference), build)


def _ratio(a: Any, b: Any) -> float | None:
    ok = a is not None and b is not None and 0 < float(b) < math.inf
    return float(a) / float(b) if ok else None


def _best(front: tuple[TeamPoint, ...], plan: TeamPoint, key: str, other: str,
          tol: float) -> TeamPoint | None:
    """The front member (or the valid plan itself) with the smallest ``key`` among those no
    worse than the plan on ``other`` (within ``tol``); ties go to the front member."""
    bar = getattr(plan, other)
    if bar is None:
        return None
    ok = [m for m in front if getattr(m, other) <= bar + tol]
    best = min(ok, key=lambda m: getattr(m, key), default=None)
    mine = getattr(plan, key)
    if plan.valid and (best is None or mine < getattr(best, key)):
        return plan
    return best


def _g(x: float | None) -> str:
    """``x`` to 6 significant digits."""
    return "-" if x is None else f"{x:.6g}"


def _message(front: TeamFront) -> str:
    """The front and the candidates left out, for ``team_reference_message``."""
    members = ", ".join(f"{m.source} ({_g(m.arrival)} s, rmse {_g(m.rmse)})"
                        for m in front.members)
    out = [f"front of {len(front.members)} of {len(front.candidates)} candidates: {members}"
           if front.members else f"no valid plan among {len(front.candidates)} candidates"]
    bad = [f"{c.source} ({c.why})" for c in front.candidates if not c.valid]
    if bad:
        out.append("not valid: " + ", ".join(bad))
    cut = [c.source for c in front.candidates if c.stop_reason == "time_limit"]
    if cut:
        out.append("stopped by the time limit: " + ", ".join(cut))
    return "; ".join(out)


def _sources(a: TeamPoint | None, e: TeamPoint | None) -> str | None:
    """``team_reference_source``: the one source of both references, or both named."""
    if a is None and e is None:
        return None
    if a is not None and e is not None and a.source == e.source:
        return a.source
    return (f"arrival: {a.source if a else 'none'}; "
            f"formation rmse: {e.source if e else 'none'}")


def _references(front: TeamFront, plan: TeamPoint, lbar: float
                ) -> tuple[TeamPoint | None, TeamPoint | None]:
    """The references of ``plan`` in arrival and in formation RMSE (module docstring's rule;
    ``lbar`` the mean slot distance)."""
    by_arrival = by_rmse = None
    if plan.rmse is not None:
        by_arrival = _best(front.members, plan, "arrival", "rmse",
                           RTOL * plan.rmse + ABS_RMSE * lbar)
    if plan.arrival is not None:
        by_rmse = _best(front.members, plan, "rmse", "arrival", RTOL * plan.arrival)
    return by_arrival, by_rmse


def grade_team(problem: Problem, res: Result, front: TeamFront) -> dict[str, Any]:
    """The team grades of ``res`` against ``front`` (module docstring)."""
    form = problem.formation
    assert form is not None, "team grading needs a formation"
    plan = team_point(problem, res)
    lbar = float(np.mean([f.L for f in form.followers])) if form.followers else 1.0
    by_arrival, by_rmse = _references(front, plan, lbar)
    used = [p.separation for p in (by_arrival, by_rmse)
            if p is not None and p.separation is not None]
    out: dict[str, Any] = {
        "team_reference_status": "solved" if front.members else "no valid candidate",
        "team_reference_message": _message(front),
        "team_arrival": plan.arrival, "team_plan_valid": plan.valid,
        "team_arrival_reference": by_arrival.arrival if by_arrival else None,
        "team_arrival_reference_source": by_arrival.source if by_arrival else None,
        "team_formation_rmse_reference": by_rmse.rmse if by_rmse else None,
        "team_formation_rmse_reference_source": by_rmse.source if by_rmse else None,
        "team_reference_source": _sources(by_arrival, by_rmse),
        "team_min_separation_reference": min(used, default=None)}
    out["arrival_ratio_to_team"] = _ratio(plan.arrival, out["team_arrival_reference"])
    floor = ABS_RMSE * lbar
    ref_rmse = out["team_formation_rmse_reference"]
    out["formation_rmse_ratio_to_team"] = (
        None if plan.rmse is None or ref_rmse is None
        else max(plan.rmse, floor) / max(ref_rmse, floor))
    out["separation_ratio_to_team"] = _ratio(plan.separation,
                                             out["team_min_separation_reference"])
    lead = form.leader
    bound = problem.memo(("arrival_lower_bound", lead),
                         lambda: arrival_lower_bound(problem, lead))
    out["team_arrival_lower_bound"] = bound.value
    out["team_arrival_lower_bound_reason"] = bound.reason
    out["arrival_ratio_to_team_lower"] = _ratio(plan.arrival, bound.value)
    return out


def with_team_reference(metrics: dict[str, Any], problem: Problem, res: Result,
                        reference: TeamReference) -> dict[str, Any]:
    """``metrics`` plus the team grading of ``res`` (module docstring); a problem without a
    formation (or whose leader has no goal) gets ``team_reference_status = "no formation"``
    and nothing else."""
    out = dict(metrics)
    form = problem.formation
    if form is None or not form.followers or problem.robot(form.leader).goal is None:
        out["team_reference_status"] = "no formation"
        return out
    out.update(grade_team(problem, res, team_front(problem, reference)))
    return out
