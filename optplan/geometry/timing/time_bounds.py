"""Certified lower bounds on the arrival time of a robot among moving obstacles.

Moving obstacles can only delay a robot, never shorten its way, and a robot cannot end its
motion at a goal that a moving obstacle occupies.  :func:`arrival_lower_bound` combines both
into a bound that holds for *every* collision-free motion at speed ``<= max_speed``:

1. the static bound ``L* / v``: ``L*`` is the certified shortest path of the robot's disc among
   all static obstacles (temporary ones included: they are there all the time), the exact
   tangent graph (:mod:`optplan.geometry.tangent.tangent_graph`), ``v`` its ``max_speed``;
2. the goal bound: the robot parked at its goal overlaps a moving obstacle at the times of
   :func:`parked_contact_times` (closed form, :mod:`optplan.geometry.timing.contact_times`); an
   arrival at time ``T`` needs the goal free at ``T``, so the bound is the first free time of
   the goal at or after the static bound.

Both are proofs, not estimates; the bound is ``None`` (with the reason) when there is no
certified static optimum, and ``inf`` when the goal is occupied from the static bound on for
ever (no motion arrives).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from optplan.geometry.collision import cumulative_length
from optplan.geometry.timing.cell_bound import TimeBound, cell_lower_bound, check_level
from optplan.geometry.timing.contact_times import line_intervals, shape_pieces
from optplan.geometry.timing.intervals import Intervals, first_free, merge_open
from optplan.geometry.timing.motion import mover_period, mover_pieces

if TYPE_CHECKING:
    from optplan.problem import DynamicObstacle, Problem

__all__ = ["TimeBound", "parked_contact_times", "arrival_lower_bound", "arrival_time",
           "path_times"]


def parked_contact_times(movers: Sequence[DynamicObstacle], point, radius: float, t_lo: float,
                         t_hi: float) -> Intervals:
    """The times in ``[t_lo, t_hi]`` at which a disc of ``radius`` parked at ``point`` overlaps
    one of the moving obstacles ``movers`` (a problem's ``dynamic_obstacles``, or the few near
    the point): sorted disjoint open intervals (an interval may end at ``inf``).

    Per linear piece of each obstacle's motion
    (:func:`~optplan.geometry.timing.motion.mover_pieces`) and per convex piece of its shape, the
    parked disc seen from the obstacle moves on the line ``point - b - (t - ta) w``: one closed-form
    interval (:func:`~optplan.geometry.timing.contact_times.line_intervals`), clipped to the piece.
    """
    p = np.asarray(point, float)
    los, his = [], []
    for d in movers:
        ta, tb, b, w = mover_pieces(d, t_lo, t_hi)
        for shape in shape_pieces(d.kind, d.radius, d.local_geometry):
            lo, hi = line_intervals(p - b, -w, shape, float(radius))
            ok = ~np.isnan(lo)
            lo_t = np.maximum(ta + lo, ta)[ok]
            hi_t = np.minimum(ta + hi, tb)[ok]
            keep = (hi_t > lo_t) & (hi_t > t_lo) & (lo_t < t_hi)
            los.append(lo_t[keep])
            his.append(hi_t[keep])
    if not los:
        return []
    return merge_open(np.concatenate(los), np.concatenate(his))


def arrival_lower_bound(problem: Problem, robot_id: str | None = None, *,
                        level: int = 0, stop: Callable[[], bool] | None = None) -> TimeBound:
    """A certified lower bound on the arrival time of ``robot_id`` (default the planned robot,
    ``problem.leader``) at its goal; see the module docstring.

    ``level = 0`` is the bound above; ``level >= 1`` is its maximum with the cell-slab
    relaxation of :func:`optplan.geometry.timing.cell_bound.cell_lower_bound` at that level,
    which sees movers blocking the way and does not decrease as ``level`` grows; ``stop``
    (polled by the relaxation) ends it early, leaving the level-0 bound.

    Raises
    ------
    ValueError
        If the robot is unknown or has no goal (a formation follower), or for a ``level``
        outside ``0 .. 10``.
    """
    if check_level(level) > 0:
        return _refined(arrival_lower_bound(problem, robot_id),
                        cell_lower_bound(problem, robot_id, level=level, stop=stop))
    from optplan.geometry.tangent import problem_shortest_path

    robot = problem.leader if robot_id is None else problem.robot(robot_id)
    rid = robot.id
    if robot.goal is None:
        raise ValueError(f"robot {rid!r} has no goal (a formation follower): no arrival bound")
    res = problem_shortest_path(problem, robot, known_only=False)
    if res.polyline is None or not res.info.get("certified"):
        why = res.info.get("reason", "the shortest path is not certified")
        return TimeBound(None, None, None, f"no certified static optimum: {why}")
    static = float(res.length) / robot.max_speed
    periods = [p for p in map(mover_period, problem.dynamic_obstacles) if p is not None]
    knots = [float(np.max(d.times)) for d in problem.dynamic_obstacles]
    # past every knot a hold/velocity motion is known for ever (open-ended pieces); a repeating
    # one repeats: one more period than the window covers every free time there is
    t_hi = max([static, *knots]) + (max(periods) if periods else 0.0) + 1.0
    busy = parked_contact_times(problem.dynamic_obstacles, robot.goal, robot.radius, 0.0, t_hi)
    goal = first_free(busy, static)
    if goal > t_hi and periods:  # a repeating obstacle covers the goal for a whole period
        goal = math.inf
    if math.isinf(goal):
        return TimeBound(math.inf, static, math.inf,
                         "the goal is occupied by a moving obstacle for ever from the static "
                         f"bound {static:.6g} s on: no motion arrives")
    reason = ("static optimum / max_speed" if goal == static else
              "first time the goal is free at or after static optimum / max_speed")
    return TimeBound(goal, static, goal, reason)


def _refined(base: TimeBound, cell: TimeBound) -> TimeBound:
    """The larger of the level-0 bound and the cell relaxation's (``None``-safe)."""
    if cell.value is None or (base.value is not None and base.value >= cell.value):
        return base
    return TimeBound(cell.value, base.static_bound, base.goal_bound, cell.reason)


def path_times(path, max_speed: float, times=None) -> np.ndarray:
    """The time stamp of every point of a plan: its own ``times`` (a time-stepping planner's
    trajectory), else the validator's convention for a geometric path, driven from ``t = 0``
    at ``max_speed`` (``t_k = arc length to point k / max_speed``)."""
    if times is not None:
        return np.asarray(times, float)
    return cumulative_length(path) / max_speed


def arrival_time(problem: Problem, robot_id: str, path, times=None) -> float | None:
    """The arrival time of a plan as executed: the first time stamp (:func:`path_times`) at
    which ``robot_id`` is within the goal tolerance of its goal (``problem.goal_tol``), ``None``
    if it never is."""
    robot = problem.robot(robot_id)
    if robot.goal is None:
        return None
    pts = np.asarray(path, float)
    stamps = path_times(pts, robot.max_speed, times)
    near = np.hypot(*(pts - robot.goal).T) <= problem.goal_tol(robot) + problem.frame.eps
    return float(stamps[int(np.argmax(near))]) if near.any() else None
