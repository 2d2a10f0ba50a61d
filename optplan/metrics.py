"""The one validator: every solver's result is graded here, never by the solver itself.

:func:`evaluate` checks bounds, static obstacles (known and temporary alike: temporary
obstacles are real even if a global planner cannot see them), contacts with dynamic obstacles and
between robots *in continuous time* (a geometric path is timed at the robot's ``max_speed``),
goal reach, lengths, clearances and, for teams, separation and formation error.

Static feasibility is exact (:class:`optplan.geometry.ObstacleSet`): a segment is free when its
Euclidean distance to every true polygon and circle is ``>= r - eps``, ``eps = 1e-9 x`` the
bounds diagonal (``docs/geometry.md``).  ``min_clearance`` is the exact minimum distance minus
the radius; a value within ``eps`` of contact is reported as 0, so a path called feasible never
shows a negative clearance.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from optplan.geometry import Frame, ObstacleSet, obstacle_set, path_lengths
from optplan.geometry.timing import (
    mover_track,
    path_times,
    polyline_segments,
    positions_at,
    relative_contact,
    relative_segments,
)
from optplan.problem import Obstacle, Problem, Robot

__all__ = ["evaluate", "leader_headings", "formation_errors", "time_stamps", "time_checks"]



def leader_headings(leader_path: np.ndarray, fallback: float = 0.0,
                    min_step: float | None = None) -> np.ndarray:
    """Heading (rad) of the leader at each sample: direction of the next displacement.

    Displacements shorter than ``min_step`` (default ``1e-6`` times the path's extent) do not
    change the heading: samples where the leader (almost) stands still keep the previous
    heading (forward fill), so numerical jitter at the goal cannot rotate the formation frame.
    The last sample repeats the one before.  ``fallback`` is used until the leader first moves.
    """
    p = np.asarray(leader_path, dtype=float)
    if len(p) < 2:
        return np.full(len(p), float(fallback))
    d = np.diff(p, axis=0)
    if min_step is None:
        min_step = 1e-6 * max(1.0, float(np.ptp(p, axis=0).max()))
    moving = np.hypot(d[:, 0], d[:, 1]) > min_step
    th = np.r_[fallback, np.arctan2(d[:, 1], d[:, 0])]
    idx = np.where(np.r_[True, moving], np.arange(len(th)), 0)
    th = th[np.maximum.accumulate(idx)][1:]
    return np.r_[th, th[-1]]


def formation_errors(problem: Problem, paths: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per-step formation errors for a formation problem with synchronised trajectories.

    Returns arrays of shape ``(n_steps, n_followers)``: ``position`` (distance of each follower
    from its slot), ``distance`` (``|r| - L``) and ``angle`` (wrapped ``phi_actual - phi``).
    """
    f = problem.formation
    if f is None:
        raise ValueError(f"problem {problem.name!r} has no formation")
    lead = np.asarray(paths[f.leader])
    lead_r = problem.robot(f.leader)
    fb = 0.0
    if lead_r.goal is not None:
        g = lead_r.goal - lead_r.start
        fb = float(np.arctan2(g[1], g[0]))
    th = leader_headings(lead, fb, min_step=1e-6 * problem.extent)
    slots = lead[:, None, :] + f.slot_offsets(th)
    fol = np.stack([np.asarray(paths[x.id]) for x in f.followers], axis=1)
    rel = fol - lead[:, None, :]
    dist = np.hypot(rel[..., 0], rel[..., 1])
    L = np.array([x.L for x in f.followers])
    phi_des = np.array([x.phi for x in f.followers])
    # actual phi: angle from the backward heading, positive to the left
    back = th[:, None] + np.pi
    phi_act = np.arctan2(rel[..., 1], rel[..., 0]) - back
    phi_act = -((phi_act + np.pi) % (2 * np.pi) - np.pi)
    ang = (phi_act - phi_des + np.pi) % (2 * np.pi) - np.pi
    pos = np.hypot(*(fol - slots).transpose(2, 0, 1))
    return {"position": pos, "distance": dist - L, "angle": ang}


def _robot_metrics(problem: Problem, robot: Robot, path: np.ndarray) -> dict[str, Any]:
    """Static part for one robot: bounds, exact obstacle test, clearance, goal, lengths."""
    frame = problem.frame
    tol = frame.eps
    in_bounds = bool(np.all(frame.in_bounds(path)))
    oset = problem.obstacle_set(robot.radius)
    seg_path = path if len(path) > 1 else np.vstack([path, path])
    cr = oset.crossings(seg_path[None], details=True)
    static_coll = int(cr.count[0])
    crossed = sorted({oset.solid_name(int(k)) for k in cr.pairs[2]})
    clear = float(oset.clearance(seg_path[None])[0])
    if -tol <= clear < 0.0:
        clear = 0.0  # contact within the tolerance: touching is allowed
    reached = None
    if robot.goal is not None:
        reached = bool(np.hypot(*(path[-1] - robot.goal)) <= problem.goal_tol(robot) + tol)
    return {
        "length": float(path_lengths(path)),
        "in_bounds": in_bounds,
        "static_collisions": static_coll,
        "penetration": float(cr.penetration[0]),
        "crossed": crossed,
        "min_clearance": float(clear),
        "reached": reached,
        "starts_at_start": bool(np.hypot(*(path[0] - robot.start)) <= tol),
    }


def time_stamps(problem: Problem, paths: dict[str, np.ndarray],
                times: np.ndarray | None) -> dict[str, np.ndarray]:
    """Time stamps of every path (:func:`~optplan.geometry.timing.time_bounds.path_times`): the
    shared ``times`` of a simulated trajectory, else each robot from its start at t = 0 at its
    ``max_speed``."""
    return {k: path_times(v, problem.robot(k).max_speed, times) for k, v in paths.items()}


def shape_set(kind: str, radius: float | None, local_geometry, robot_radius: float,
              length: float) -> ObstacleSet:
    """Exact engine for a shape placed at the origin (a translating obstacle in its own frame),
    with the tolerance of a map of diagonal ``length``."""
    h = length / (2.0 * math.sqrt(2.0))
    frame = Frame.from_bounds((-h, -h, h, h))
    if kind == "circle":
        if radius is None:
            raise ValueError("a moving circle needs a radius")
        o = Obstacle("circle", None, name="moving", center=np.zeros(2), radius=float(radius))
    else:
        o = Obstacle("polygon", local_geometry, name="moving")
    return obstacle_set([o], robot_radius, frame, walls=False)


def _shape_set(problem: Problem, k: int, radius: float):
    d = problem.dynamic_obstacles[k]
    return problem.memo(("moving_shape_set", k, float(radius)),
                        lambda: shape_set(d.kind, d.radius, d.local_geometry, radius,
                                          problem.extent))


def _disc_set(problem: Problem, r_other: float, radius: float):
    return problem.memo(("disc_set", float(r_other), float(radius)),
                        lambda: shape_set("circle", r_other, None, radius, problem.extent))


def time_checks(problem: Problem, paths: dict[str, np.ndarray],
                stamps: dict[str, np.ndarray]) -> dict[str, Any]:
    """Exact continuous-time contacts with dynamic obstacles and between robots.

    The check covers ``[min(0, first stamp), horizon]``, the horizon being the last robot's last
    stamp.  Every robot follows its polyline linearly between its stamps, waits at its first
    point before its first stamp and holds its last position until the horizon.  Each moving
    obstacle follows its exact track (:func:`optplan.geometry.timing.motion.mover_track`: ``hold``,
    ``loop`` with its jump back to the first waypoint at each period end, ``bounce``, constant
    velocity).  Per (robot, dynamic obstacle) and per robot pair, the relative motion on the
    merged stamps and knots is a sequence of segments tested with the exact engine
    (:mod:`optplan.geometry.timing.motion`), so nothing can pass between two stamps unseen; a jump
    of an obstacle ends one segment and starts the next (checked on both sides, never swept).
    """
    ids = list(paths)
    t_end = max(float(stamps[k][-1]) for k in ids)
    t_lo = min(0.0, min(float(stamps[k][0]) for k in ids))
    per_dyn: dict[str, float] = {}
    contacts: list[dict] = []
    n_dyn = 0
    tracks = [mover_track(d, t_lo, t_end) for d in problem.dynamic_obstacles]
    for k in ids:
        r = problem.robot(k).radius
        best = float("inf")
        for j, d in enumerate(problem.dynamic_obstacles):
            rel, T = relative_segments(stamps[k], paths[k], *tracks[j], t_lo, t_end)
            oset = _shape_set(problem, j, r)
            best = min(best, float(oset.clearance(rel).min()))
            c = relative_contact(rel, T, oset)
            if c is not None:
                n_dyn += 1
                pos = positions_at(stamps[k], paths[k], np.array([c.time]))[0]
                contacts.append({"kind": "moving obstacle", "robot": k, "other": d.name,
                                 "time": c.time, "position": pos.tolist()})
        per_dyn[k] = best
    n_sep = 0
    min_sep = float("inf")
    for a, b in itertools.combinations(ids, 2):
        T = np.unique(np.concatenate([stamps[a], stamps[b], [t_lo, t_end]]))
        rel, TT = polyline_segments(positions_at(stamps[a], paths[a], T)
                                    - positions_at(stamps[b], paths[b], T), T)
        min_sep = min(min_sep, float(_disc_set(problem, 0.0, 0.0).clearance(rel).min()))
        oset = _disc_set(problem, problem.robot(b).radius, problem.robot(a).radius)
        c = relative_contact(rel, TT, oset)
        if c is not None:
            n_sep += 1
            pos = positions_at(stamps[a], paths[a], np.array([c.time]))[0]
            contacts.append({"kind": "robot", "robot": a, "other": b, "time": c.time,
                             "position": pos.tolist()})
    first = min(contacts, key=lambda c: c["time"]) if contacts else None
    return {"dynamic_contacts": n_dyn, "separation_violations": n_sep,
            "min_clearance_dynamic_per_robot": per_dyn, "min_separation": min_sep,
            "first_contact": first, "contacts": contacts}


def _formation_metrics(problem: Problem, P: dict[str, np.ndarray]) -> dict[str, Any]:
    fe = formation_errors(problem, P)
    return {"_fe_final": fe["position"][-1],
            "formation_rmse": float(np.sqrt(np.mean(fe["position"] ** 2))),
            "formation_max_error": float(np.max(fe["position"])),
            "formation_distance_rmse": float(np.sqrt(np.mean(fe["distance"] ** 2))),
            "formation_angle_rmse": float(np.sqrt(np.mean(fe["angle"] ** 2))),
            "formation_final_error": float(np.max(fe["position"][-1]))}


def _reached(problem: Problem, P: dict, per: dict, fe_final) -> bool:
    """All robots with a goal reached it; a follower without a goal sits within L / 4 of its
    slot at the end while the leader has reached."""
    form = problem.formation
    reached = []
    for k, m in per.items():
        if m["reached"] is None and form is not None and form.leader in P:
            fl = next(x for x in form.followers if x.id == k)
            end_err = None
            if fe_final is not None:
                end_err = float(fe_final[[x.id for x in form.followers].index(k)])
            m["reached"] = bool(per[form.leader]["reached"] and end_err is not None
                                and end_err <= 0.25 * fl.L)
        if m["reached"] is not None:
            reached.append(m["reached"])
    return bool(all(reached)) if reached else False


def _checked_inputs(problem: Problem, paths: dict[str, np.ndarray], times: Any
                    ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """The paths as ``(n, 2)`` float arrays of known robots and the times as an array, with
    one stamp per path point."""
    if not paths:
        raise ValueError("evaluate() needs at least one path")
    P = {k: np.asarray(v, dtype=float).reshape(-1, 2) for k, v in paths.items()}
    for k in P:
        problem.robot(k)  # raises KeyError on unknown ids
    if times is not None:
        times = np.asarray(times, dtype=float)
        for k, v in P.items():
            if len(v) != len(times):
                raise ValueError(f"path {k!r} has {len(v)} points but times has {len(times)}")
    return P, times


def _team_metrics(problem: Problem, P: dict[str, np.ndarray], per: dict[str, dict],
                  tc: dict[str, Any], times: np.ndarray | None) -> dict[str, Any]:
    """The team's totals of the per-robot metrics ``per`` and the time checks ``tc`` (adds
    each robot's ``min_clearance_dynamic`` to ``per``); ``min_separation`` and
    ``safety_distance`` for teams."""
    for k, m in per.items():
        m["min_clearance_dynamic"] = tc["min_clearance_dynamic_per_robot"][k]
    lead = problem.leader.id if problem.leader.id in P else next(iter(P))
    out: dict[str, Any] = {
        "leader": lead,
        "length": per[lead]["length"],
        "lengths": {k: m["length"] for k, m in per.items()},
        "min_clearance": min(m["min_clearance"] for m in per.values()),
        "min_clearance_dynamic": min(m["min_clearance_dynamic"] for m in per.values()),
        "static_collisions": sum(m["static_collisions"] for m in per.values()),
        "dynamic_contacts": tc["dynamic_contacts"],
        "separation_violations": tc["separation_violations"],
        "first_contact": tc["first_contact"],
        "penetration": sum(m["penetration"] for m in per.values()),
        "crossed": sorted({n for m in per.values() for n in m["crossed"]}),
        "in_bounds": all(m["in_bounds"] for m in per.values()),
        "timing": "simulated" if times is not None else "max_speed",
        "dynamic_checked": True,  # always, in continuous time (kept for older readers)
        "per_robot": per,
    }
    if len(P) > 1:
        out["min_separation"] = tc["min_separation"]
        out["safety_distance"] = float(problem.formation.safety_distance if problem.formation
                                       else 2 * max(problem.robot(k).radius for k in P))
    return out


def evaluate(problem: Problem, paths: dict[str, np.ndarray],
             times: np.ndarray | None = None) -> dict[str, Any]:
    """Grade paths (or synchronised trajectories) against a problem, in continuous time.

    Parameters
    ----------
    problem : Problem
    paths : dict
        ``robot id -> (n_points, 2)`` array, first point = the robot's start.
    times : array, optional
        ``(n_points,)`` time stamps shared by all paths (simulated trajectories).  Without
        times a geometric path is time-parameterised at the robot's ``max_speed``
        (:func:`time_stamps`).  Either way, contacts with dynamic obstacles and between robots
        are checked exactly between the stamps (:func:`time_checks`).

    Returns
    -------
    dict
        ``feasible``, ``length`` (leader / first robot), ``lengths``, ``min_clearance``,
        ``min_clearance_dynamic``, ``collisions`` (static crossings + colliding (robot, moving
        obstacle) pairs + colliding robot pairs), ``static_collisions``, ``dynamic_contacts``,
        ``separation_violations``, ``first_contact`` (``None`` or ``kind``, ``robot``,
        ``other``, ``time``, ``position``), ``reached`` (all robots with a goal, followers by
        their slot), ``per_robot``, ``timing`` (``"simulated"`` or ``"max_speed"``); for teams
        ``min_separation`` and, with a formation, ``formation_rmse``, ``formation_max_error``,
        ``formation_distance_rmse``, ``formation_angle_rmse``.
    """
    P, times = _checked_inputs(problem, paths, times)
    # robot part: each path against the static map
    per = {k: _robot_metrics(problem, problem.robot(k), v) for k, v in P.items()}
    # team part: moving obstacles and the other robots, in continuous time
    tc = time_checks(problem, P, time_stamps(problem, P, times))
    out = _team_metrics(problem, P, per, tc, times)
    # formation part: simulated trajectories of a complete formation only
    form = problem.formation
    fe_final = None
    if form is not None and times is not None and form.leader in P and all(
            x.id in P for x in form.followers):
        fm = _formation_metrics(problem, P)
        fe_final = fm.pop("_fe_final")
        out.update(fm)
    out["reached"] = _reached(problem, P, per, fe_final)
    out["collisions"] = (out["static_collisions"] + out["dynamic_contacts"]
                         + out["separation_violations"])
    out["starts_ok"] = all(m["starts_at_start"] for m in per.values())
    out["feasible"] = bool(out["in_bounds"] and out["collisions"] == 0 and out["starts_ok"])
    return out
