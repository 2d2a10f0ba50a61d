r"""The fastest schedule along a given path (path-velocity decomposition).

Kant and Zucker (IJRR 1986) split motion planning among moving obstacles into a path and a
velocity profile along it.  :func:`fastest_schedule` solves the second half exactly: for a
fixed polyline path of a disc robot with speed limit ``max_speed`` (waits allowed), it returns
the earliest arrival at the path's end and a timed trajectory achieving it, or says that no
schedule exists.  The moving obstacles become forbidden regions of the (arc length, time) plane
in closed form (:mod:`optplan.geometry.timing.st_regions`), and the earliest arrival is the lowest
monotone path among them (:mod:`optplan.geometry.timing.st_sweep`).

**What is exact.**  No schedule of *this path* arrives earlier (up to round-off: the events
where two regions begin to overlap are roots of convex functions found by bisection).  Contact
is strict, as in the validator: touching a moving obstacle is allowed.  Static obstacles
(temporary ones included) do not move: a path that crosses one has no schedule at all.

**Horizon.**  The obstacles' motion is known in closed form for ever, but a repeating
(``loop``, ``bounce``) motion has infinitely many pieces, so the sweep works on a time window
``[0, H]``.  The answer is exact whenever the arrival is below ``H``; otherwise ``H`` doubles.
Without repeating movers there is a time after which every mover stands still or has left the
path's neighbourhood for good; a window reaching past it by the time to drive the whole path
settles the question, so "no schedule" is then a proof.  With repeating movers, an empty
window up to the cap is reported as such, never as a proof.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from optplan.geometry.collision import cumulative_length, path_lengths
from optplan.geometry.timing.motion import mover_period
from optplan.geometry.timing.plan import PlanStatus, TimedPlan
from optplan.geometry.timing.st_regions import path_regions
from optplan.geometry.timing.st_sweep import sweep

if TYPE_CHECKING:
    from optplan.problem import DynamicObstacle, Problem

__all__ = ["fastest_schedule"]

#: the largest horizon is this many times the first one
_MAX_DOUBLINGS = 6


def _checked_path(problem: Problem, robot, path) -> tuple[np.ndarray | None, str]:
    p = np.asarray(path, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
        raise ValueError(f"path: an (m, 2) array of points is needed, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("path: every coordinate must be finite")
    eps = problem.frame.eps
    if np.hypot(*(p[0] - robot.start)) > eps:
        return None, (f"the path starts at {p[0].tolist()}, not at robot {robot.id!r}'s start "
                      f"{robot.start.tolist()}")
    for d in problem.dynamic_obstacles:
        if float(d.distance(robot.start[None, :], 0.0)[0]) < robot.radius - eps:
            return None, (f"robot {robot.id!r} starts inside the moving obstacle {d.name!r} at "
                          "t = 0")
    oset = problem.obstacle_set(robot.radius, known_only=False)
    if len(p) > 1 and oset.crossings(p, penetration=False).count[0]:
        return None, ("the path crosses a static obstacle (temporary ones included): no "
                      "schedule can make it collision-free")
    keep = np.concatenate([[True], np.hypot(*np.diff(p, axis=0).T) > 0])
    return p[keep], ""


def _velocity_gone(dyn: DynamicObstacle, centre: np.ndarray, reach: float) -> float:
    """The time after which a constant-velocity mover stays farther than ``reach`` from
    ``centre`` (``-inf`` for a mover standing still: it is settled from the start)."""
    vel = np.asarray(dyn.velocity, float)
    vv = float(vel @ vel)
    if vv == 0.0:
        return -math.inf
    q = np.asarray(dyn.waypoints[0], float) - float(dyn.times[0]) * vel - centre
    b, c = float(q @ vel), float(q @ q) - reach * reach
    disc = b * b - vv * c
    return -math.inf if disc <= 0 else (-b + math.sqrt(disc)) / vv


def _settle_time(movers: list[DynamicObstacle], path: np.ndarray, radius: float
                 ) -> float | None:
    """A time after which no mover changes what the path meets, ``None`` with a repeating
    mover (it never settles)."""
    if any(mover_period(d) is not None for d in movers):
        return None
    centre = 0.5 * (path.min(axis=0) + path.max(axis=0))
    half = 0.5 * float(np.hypot(*(path.max(axis=0) - path.min(axis=0))))
    out = 0.0
    for d in movers:
        if d.velocity is None:
            out = max(out, float(np.max(d.times)))
            continue
        size = (float(d.radius or 0.0) if d.kind == "circle" else
                float(np.max(np.hypot(*np.asarray(d.local_geometry.exterior.coords).T))))
        out = max(out, _velocity_gone(d, centre, half + radius + size))
    return out


def _first_horizon(movers: list[DynamicObstacle], drive: float, settle: float | None
                   ) -> float:
    knots = [float(np.max(d.times)) for d in movers]
    periods = [p for p in map(mover_period, movers) if p is not None]
    base = max([0.0, *knots]) + 2.0 * max([0.0, *periods]) + 2.0 * drive
    if settle is not None:
        base = max(base, settle + 2.0 * drive)
    return base if base > 0 else 1.0


def _trajectory(path: np.ndarray, corners: np.ndarray, speed: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """Points and times from the staircase ``(s, tau)``, with the path's corners added."""
    cum = cumulative_length(path)
    s_c, tau_c = corners[:, 0], corners[:, 1]
    extra = cum[(cum > s_c[0]) & (cum < s_c[-1])]
    # the delay at a path corner: the level of the staircase step that covers it
    pos = np.searchsorted(s_c, extra, side="right") - 1
    s = np.concatenate([s_c, extra])
    tau = np.concatenate([tau_c, tau_c[pos]])
    order = np.lexsort((tau, s))
    s, tau = s[order], tau[order]
    keep = np.concatenate([[True], (np.diff(s) > 0) | (np.diff(tau) > 0)])
    s, tau = s[keep], tau[keep]
    pts = np.stack([np.interp(s, cum, path[:, 0]), np.interp(s, cum, path[:, 1])], axis=1)
    return pts, s / speed + tau


def fastest_schedule(problem: Problem, path, robot_id: str | None = None) -> TimedPlan:
    """The earliest arrival of a robot driving along ``path`` among the moving obstacles.

    Parameters
    ----------
    problem : Problem
        The scene; its moving obstacles follow their known motion (``problems/README.md``).
    path : array_like ``(m, 2)``
        A polyline from the robot's start (repeated points are ignored).
    robot_id : str, optional
        The robot (default: the planned robot, ``problem.leader``); its ``radius`` and
        ``max_speed`` are used.  Other robots are not obstacles here.

    Returns
    -------
    TimedPlan
        Status ``scheduled`` with the earliest ``arrival`` at the path's end and the trajectory
        (``path``, ``times``) achieving it; otherwise ``arrival`` is ``None``, the status is
        ``no_schedule`` (none exists: a proof), ``not_found`` (none below the largest horizon,
        repeating movers) or ``invalid`` (the path misses the start, crosses a static obstacle,
        or the robot starts inside a moving obstacle), and ``message`` says why (module
        docstring).  ``horizon`` is the time window of the last sweep; ``info`` holds
        ``events`` (of the last sweep), ``regions`` (convex forbidden regions) and ``sweeps``.

    Raises
    ------
    ValueError
        If ``path`` is not an array of finite points, or the robot is unknown.
    """
    robot = problem.leader if robot_id is None else problem.robot(robot_id)
    p, why = _checked_path(problem, robot, path)
    if p is None:
        return TimedPlan(PlanStatus.invalid, None, None, None, why)
    movers = list(problem.dynamic_obstacles)
    v = float(robot.max_speed)
    S = float(path_lengths(p))
    settle = _settle_time(movers, p, robot.radius)
    H = _first_horizon(movers, S / v, settle)
    if S == 0.0:
        p = np.vstack([p, p])  # a zero-length path: the robot only has to be at its start
    cum = cumulative_length(p)
    for n in range(_MAX_DOUBLINGS + 1):
        out = _one_sweep(problem, robot, p, cum, S, v, H)
        if out.status in (PlanStatus.scheduled, PlanStatus.invalid):
            return dataclasses.replace(out, info=dict(out.info, sweeps=n + 1))
        if settle is not None and H > settle + S / v:
            return TimedPlan(PlanStatus.no_schedule, None, None, None,
                            f"no schedule exists: the movers settle by t = {settle:.6g} s and "
                            f"no schedule arrives before t = {H:.6g} s", H,
                            dict(out.info, sweeps=n + 1))
        H *= 2.0
    return TimedPlan(PlanStatus.not_found, None, None, None,
                     f"no schedule arrives before t = {H / 2:.6g} s (the largest horizon; "
                     "repeating movers: not a proof that none exists)", H / 2,
                     dict(out.info, sweeps=_MAX_DOUBLINGS + 1))


def _one_sweep(problem: Problem, robot, p: np.ndarray, cum: np.ndarray, S: float, v: float,
               H: float) -> TimedPlan:
    """One sweep with the horizon ``H``: ``scheduled`` when the arrival is below it."""
    reg = path_regions(list(problem.dynamic_obstacles), p, robot.radius, H)
    tol = 1e-10 * H
    if S == 0.0:
        reg = path_regions(list(problem.dynamic_obstacles), p + [[0.0, 0.0], [1e-300, 0.0]],
                           robot.radius, H)
    res = sweep(reg, v, cum, max(S, 1e-300), tol)
    info = {"events": res.events, "regions": len(reg)}
    if res.start_blocked:
        return TimedPlan(PlanStatus.invalid, None, None, None,
                         f"robot {robot.id!r} starts inside a moving obstacle at t = 0", H, info)
    if res.arrival_tau is None or S / v + res.arrival_tau >= H:
        return TimedPlan(PlanStatus.not_found, None, None, None, "", H, info)
    pts, times = _trajectory(p, res.corners, v)
    arrival = S / v + res.arrival_tau
    return TimedPlan(PlanStatus.scheduled, arrival, pts, times,
                     f"earliest arrival along the path: {arrival:.6g} s "
                     f"({res.arrival_tau:.6g} s of waiting)", H, info)
