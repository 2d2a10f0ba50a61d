"""Grading a team plan against the team optimum: ``op.solve(..., reference="team")``.

The reference is the joint trajectory NLP of the team (the ``formation-nlp`` preset, found by
name in the solver registry: the core names no method family) warm-started from the plan
itself, so it is never worse than the plan (the NLP keeps its warm start when it cannot improve
on it).  It is a *local* optimum: the ratios bound how much a local improvement of the plan's
manoeuvre gains, they certify nothing global.

Metrics (robots of a formation with a leader that arrives):

* ``team_reference_status``, ``team_reference_message``: the NLP's outcome;
* ``team_arrival_reference``, ``team_formation_rmse_reference``,
  ``team_min_separation_reference``: its leader's arrival, formation RMSE and smallest
  distance between robot centres;
* ``arrival_ratio_to_team`` (plan / reference, ``>= 1``), ``formation_rmse_ratio_to_team``
  (plan / reference, ``>= 1`` up to the NLP's tolerance), ``separation_ratio_to_team``
  (plan / reference: below 1 when the reference keeps the robots further apart).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from optplan.geometry.timing import arrival_time
from optplan.problem import Problem
from optplan.result import Result

__all__ = ["with_team_reference", "TeamReference"]

#: ``reference(problem, result) -> Result``: the team optimum warm-started from ``result``.
TeamReference = Callable[[Problem, Result], Result]


def _ratio(a: Any, b: Any) -> float | None:
    ok = a is not None and b is not None and 0 < float(b) < float("inf")
    return float(a) / float(b) if ok else None


def with_team_reference(metrics: dict[str, Any], problem: Problem, res: Result,
                        reference: TeamReference) -> dict[str, Any]:
    """``metrics`` plus the team grading of ``res`` (module docstring); a problem without a
    formation gets ``team_reference_status = "no formation"`` and nothing else."""
    out = dict(metrics)
    form = problem.formation
    if form is None:
        out["team_reference_status"] = "no formation"
        return out
    ref = reference(problem, res)
    out["team_reference_status"] = ref.status.value
    out["team_reference_message"] = ref.message
    lead = form.leader
    plan_arrival = (arrival_time(problem, lead, res.paths[lead], res.times)
                    if lead in res.paths else None)
    ref_arrival = (arrival_time(problem, lead, ref.paths[lead], ref.times)
                   if lead in ref.paths and ref.success else None)
    rm = ref.metrics
    out["team_arrival_reference"] = ref_arrival
    out["team_formation_rmse_reference"] = rm.get("formation_rmse") if ref.success else None
    out["team_min_separation_reference"] = rm.get("min_separation") if ref.success else None
    out["arrival_ratio_to_team"] = _ratio(plan_arrival, ref_arrival)
    out["formation_rmse_ratio_to_team"] = _ratio(metrics.get("formation_rmse"),
                                                 out["team_formation_rmse_reference"])
    out["separation_ratio_to_team"] = _ratio(metrics.get("min_separation"),
                                             out["team_min_separation_reference"])
    return out
