"""The one validator: every solver's result is graded here, never by the solver itself.

:func:`evaluate` checks bounds, static obstacles (known and temporary alike: temporary
obstacles are real even if a global planner cannot see them), contacts with dynamic obstacles at
the time stamps of a trajectory, goal reach, lengths, clearances and, for teams, separation and
formation error.

Static feasibility is exact (:class:`optplan.geometry.ObstacleSet`): a segment is free when its
Euclidean distance to every true polygon and circle is ``>= r - eps``, ``eps = 1e-9 x`` the
bounds diagonal (``docs/tolerances.md``).  ``min_clearance`` is the exact minimum distance minus
the radius; a value within ``eps`` of contact is reported as 0, so a path called feasible never
shows a negative clearance.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from optplan.geometry import path_lengths
from optplan.problem import Problem, Robot

__all__ = ["evaluate", "leader_headings", "formation_errors"]



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
    lead = np.asarray(paths[f.leader])
    lead_r = problem.robot(f.leader)
    fb = 0.0
    if lead_r.goal is not None:
        g = lead_r.goal - lead_r.start
        fb = float(np.arctan2(g[1], g[0]))
    th = leader_headings(lead, fb, min_step=1e-6 * problem.extent)
    slots = lead[:, None, :] + problem.formation.slot_offsets(th)
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


def _robot_metrics(problem: Problem, robot: Robot, path: np.ndarray,
                   times: np.ndarray | None) -> dict[str, Any]:
    frame = problem.frame
    tol = frame.eps
    in_bounds = bool(np.all(frame.in_bounds(path)))
    oset = problem.obstacle_set(robot.radius)
    seg_path = path if len(path) > 1 else np.vstack([path, path])
    cr = oset.crossings(seg_path[None], details=True)
    static_coll = int(cr.count[0])
    crossed = sorted({oset.names[int(k)] for k in cr.pairs[2]})
    dyn_contacts = 0
    min_dyn = float("inf")
    if times is not None and problem.dynamic_obstacles:
        for d in problem.dynamic_obstacles:
            dist = d.distance(path, times) - robot.radius
            min_dyn = min(min_dyn, float(dist.min()))
            dyn_contacts += int(np.sum(dist < -tol))
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
        "dynamic_contacts": dyn_contacts,
        "min_clearance": float(clear),
        "min_clearance_dynamic": float(min_dyn),
        "reached": reached,
        "starts_at_start": bool(np.hypot(*(path[0] - robot.start)) <= tol),
    }


def evaluate(problem: Problem, paths: dict[str, np.ndarray],
             times: np.ndarray | None = None) -> dict[str, Any]:
    """Grade paths (or synchronised trajectories) against a problem.

    Parameters
    ----------
    problem : Problem
    paths : dict
        ``robot id -> (n_points, 2)`` array, first point = the robot's start.
    times : array, optional
        ``(n_points,)`` time stamps shared by all paths (simulated trajectories).  With times,
        contacts with dynamic obstacles and inter-robot separation are checked at every stamp.

    Returns
    -------
    dict
        ``feasible``, ``length`` (leader / first robot), ``lengths``, ``min_clearance``,
        ``min_clearance_dynamic``, ``collisions`` (static crossings + dynamic contacts +
        separation violations), ``static_collisions``, ``dynamic_contacts``, ``reached``
        (all robots with a goal, followers by their slot), ``per_robot``; for teams
        ``min_separation``, ``separation_violations`` and, with a formation,
        ``formation_rmse``, ``formation_max_error``, ``formation_distance_rmse``,
        ``formation_angle_rmse``.
    """
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
    per = {k: _robot_metrics(problem, problem.robot(k), v, times) for k, v in P.items()}
    lead = problem.leader.id if problem.leader.id in P else next(iter(P))
    out: dict[str, Any] = {
        "leader": lead,
        "length": per[lead]["length"],
        "lengths": {k: m["length"] for k, m in per.items()},
        "min_clearance": min(m["min_clearance"] for m in per.values()),
        "min_clearance_dynamic": min(m["min_clearance_dynamic"] for m in per.values()),
        "static_collisions": sum(m["static_collisions"] for m in per.values()),
        "dynamic_contacts": sum(m["dynamic_contacts"] for m in per.values()),
        "penetration": sum(m["penetration"] for m in per.values()),
        "crossed": sorted({n for m in per.values() for n in m["crossed"]}),
        "in_bounds": all(m["in_bounds"] for m in per.values()),
        "dynamic_checked": times is not None,
        "per_robot": per,
    }
    sep_viol = 0
    if len(P) > 1 and times is not None:
        ids = list(P)
        arr = np.stack([P[k] for k in ids], axis=1)  # (T, R, 2)
        diff = arr[:, :, None, :] - arr[:, None, :, :]
        dist = np.hypot(diff[..., 0], diff[..., 1])
        iu = np.triu_indices(len(ids), 1)
        pair = dist[:, iu[0], iu[1]]
        out["min_separation"] = float(pair.min())
        if problem.formation is not None:
            safety = problem.formation.safety_distance
        else:
            safety = 2 * max(problem.robot(k).radius for k in ids)
        out["safety_distance"] = float(safety)
        radii = np.array([problem.robot(k).radius for k in ids])
        contact = radii[iu[0]] + radii[iu[1]]
        sep_viol = int(np.sum(pair < contact[None, :] - problem.frame.eps))
        out["separation_violations"] = sep_viol
    reached = []
    form = problem.formation
    if form is not None and times is not None and all(
        x.id in P for x in form.followers
    ) and form.leader in P:
        fe = formation_errors(problem, P)
        out["_fe_final"] = fe["position"][-1]
        out["formation_rmse"] = float(np.sqrt(np.mean(fe["position"] ** 2)))
        out["formation_max_error"] = float(np.max(fe["position"]))
        out["formation_distance_rmse"] = float(np.sqrt(np.mean(fe["distance"] ** 2)))
        out["formation_angle_rmse"] = float(np.sqrt(np.mean(fe["angle"] ** 2)))
        out["formation_final_error"] = float(np.max(fe["position"][-1]))
    for k, m in per.items():
        if m["reached"] is not None:
            reached.append(m["reached"])
        elif form is not None and form.leader in P:
            # a follower without a goal has reached when the leader has and it sits within
            # a quarter of L of its slot at the end
            fl = next(x for x in form.followers if x.id == k)
            lead_ok = per[form.leader]["reached"]
            end_err = None
            if "_fe_final" in out:
                idx = [x.id for x in form.followers].index(k)
                end_err = float(out["_fe_final"][idx])
            m["reached"] = bool(lead_ok and end_err is not None and end_err <= 0.25 * fl.L)
            reached.append(m["reached"])
    out.pop("_fe_final", None)
    out["reached"] = bool(all(reached)) if reached else False
    out["collisions"] = out["static_collisions"] + out["dynamic_contacts"] + sep_viol
    out["starts_ok"] = all(m["starts_at_start"] for m in per.values())
    out["feasible"] = bool(out["in_bounds"] and out["collisions"] == 0 and out["starts_ok"])
    return out
