"""The references in time: the motion of translating obstacles and exact contact with moving
discs (:mod:`.motion`), closed-form contact intervals of a disc on a line
(:mod:`.contact_times`), unions and complements of intervals in time (:mod:`.intervals`), the
one record of a timed plan (:mod:`.plan`), the forbidden regions of the (arc length, time) plane
(:mod:`.st_regions`) and the earliest-arrival sweep over them (:mod:`.st_sweep`), the fastest
schedule along a path (:mod:`.schedule`) and certified bounds on arrival times
(:mod:`.time_bounds`, refined by the cell-slab relaxation of :mod:`.cell_bound`).
"""

from optplan.geometry.timing.cell_bound import cell_lower_bound
from optplan.geometry.timing.contact_times import shape_pieces
from optplan.geometry.timing.intervals import Intervals, first_free, free_intervals, merge_open
from optplan.geometry.timing.motion import (
    mover_period,
    mover_pieces,
    mover_position,
    mover_track,
    polyline_segments,
    positions_at,
    relative_contact,
    relative_segments,
)
from optplan.geometry.timing.plan import PlanStatus, TimedPlan
from optplan.geometry.timing.schedule import fastest_schedule
from optplan.geometry.timing.st_regions import path_regions, region_extremes, sections
from optplan.geometry.timing.time_bounds import (
    TimeBound,
    arrival_lower_bound,
    arrival_time,
    parked_contact_times,
    path_times,
)

__all__ = [
    "cell_lower_bound",
    "shape_pieces",
    "Intervals",
    "first_free",
    "free_intervals",
    "merge_open",
    "mover_period",
    "mover_pieces",
    "mover_position",
    "mover_track",
    "polyline_segments",
    "positions_at",
    "relative_contact",
    "relative_segments",
    "PlanStatus",
    "TimedPlan",
    "fastest_schedule",
    "path_regions",
    "region_extremes",
    "sections",
    "TimeBound",
    "arrival_lower_bound",
    "arrival_time",
    "parked_contact_times",
    "path_times",
]
