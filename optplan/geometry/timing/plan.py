"""The one record of a timed plan: what every reference in time returns.

:func:`~optplan.geometry.timing.schedule.fastest_schedule` (the fastest timing of a given
path) and :func:`~optplan.exact.sipp.earliest_arrival` (the ``sipp`` preset's earliest arrival)
both answer with a :class:`TimedPlan`; its :class:`PlanStatus` says which outcome it is.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optplan.geometry.timing.time_bounds import TimeBound

__all__ = ["PlanStatus", "TimedPlan"]


class PlanStatus(enum.StrEnum):
    """The outcome of a reference in time (a ``str``: it compares and prints as its value)."""

    #: the earliest arrival of the model (``sipp``)
    arrived = "arrived"
    #: the earliest arrival along the given path (``fastest_schedule``)
    scheduled = "scheduled"
    #: the static map has no path (a proof)
    no_path = "no_path"
    #: no schedule of the path exists (a proof: the movers settle)
    no_schedule = "no_schedule"
    #: the robot overlaps a moving obstacle at t = 0
    start_blocked = "start_blocked"
    #: the goal is occupied for ever (a proof, from the lower bound)
    goal_blocked = "goal_blocked"
    #: no arrival up to the largest horizon (not a proof)
    not_found = "not_found"
    #: the input cannot be scheduled (the path misses the start, crosses a static obstacle,
    #: or the robot starts inside a moving obstacle)
    invalid = "invalid"
    #: ``stop`` asked before an arrival
    stopped = "stopped"
    #: the effort cap was reached without an arrival
    effort = "effort"


@dataclass(frozen=True)
class TimedPlan:
    """A timed plan of one robot, or why there is none.

    Attributes
    ----------
    status : PlanStatus
    arrival : float or None
        The arrival time at the end (s).
    path, times : ndarray or None
        The timed trajectory: ``(m, 2)`` points and a time per point, waits included (a wait
        is the same point at two times).
    message : str
        What was found, or why not.
    horizon : float
        The time window of the last search or sweep (s; NaN when none ran).
    info : dict
        The planner's counters.
    bound : TimeBound or None
        The certified lower bound the plan is compared with (``sipp``; None without one).
    """

    status: PlanStatus
    arrival: float | None
    path: np.ndarray | None
    times: np.ndarray | None
    message: str
    horizon: float = math.nan
    info: dict[str, Any] = field(default_factory=dict)
    bound: TimeBound | None = None

