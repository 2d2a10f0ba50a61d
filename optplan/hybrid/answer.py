"""The hybrid planner's answer: status, message, history and extras of a run, in world units.

The run is planned on the canonical image of the scene
(:func:`optplan.canonical.canonical_problem`); :func:`assemble` (after the simulation) and
:func:`early_answer` (when the run ends before it) build the answer there, :func:`world_answer`
maps its paths, lengths, history and extras back to the world scene.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from optplan.geometry.collision import path_lengths
from optplan.hybrid.steps import GlobalStage, RunOptions
from optplan.hybrid.subgoals import inflection_points
from optplan.interfaces import LocalController, stage_name
from optplan.problem import Problem
from optplan.result import History, Result, Status
from optplan.sim import SimOutcome
from optplan.units import Each, Record, Unit, to_scale

if TYPE_CHECKING:
    from optplan.hybrid.policy import HybridPolicy

__all__ = ["assemble", "early_answer", "world_answer", "extras_units", "long_path_note",
           "HISTORY_UNITS", "LONG_PATH_RATIO"]

#: A successful run whose leader path is more than this many times the certified optimum of
#: the known map says so in its message (:func:`long_path_note`); the status is unchanged.
LONG_PATH_RATIO = 3.0

#: The units of the history's columns (:mod:`optplan.units`).
HISTORY_UNITS = Record({
    "iteration": Unit.DIMENSIONLESS, "best_cost": Unit.LENGTH, "dist_to_goal": Unit.LENGTH,
    "n_eval": Unit.DIMENSIONLESS, "time": Unit.TIME})
_D = Unit.DIMENSIONLESS


def extras_units(local_stats: Record, formation_stats: Record) -> Record:
    """The units of the run's extras (:func:`_extras`, :func:`early_answer`,
    :func:`world_answer`), given those of the local controllers' and of the follower
    controller's ``stats`` (the stages' ``stats_units``)."""
    return Record({
        "global_path": Unit.POINT, "inflection_points": Unit.POINT, "subgoals": Unit.POINT,
        "global_paths": Each(Unit.POINT), "subgoal_sequences": Each(Unit.POINT),
        "global_solver": Unit.TEXT, "local_solver": Unit.TEXT, "formation_solver": Unit.TEXT,
        "global_status": Unit.TEXT, "global_length": Unit.LENGTH,
        "global_metrics": Record({"feasible": _D, "length": Unit.LENGTH, "collisions": _D,
                                  "static_collisions": _D, "min_clearance": Unit.LENGTH,
                                  "reached": _D}),
        "global_wall_time": Unit.WALL_TIME,
        "subgoal_events": Each(Each(Record({"subgoal": _D, "t": Unit.TIME, "how": Unit.TEXT}))),
        "subgoal_times": Unit.TIME, "time_to_goal": Unit.TIME,
        "local_stats": Each(local_stats),
        "leader_field": Record({"rho_0": Unit.LENGTH, "sense_range": Unit.LENGTH,
                                "length_scale": Unit.LENGTH}),
        "formation_stats": formation_stats, "sim_reason": Unit.TEXT, "contacts": Unit.TEXT,
        "dt": Unit.TIME, "canonical_unit": Unit.LENGTH})


def assemble(opts: RunOptions, glob: GlobalStage, policy: HybridPolicy, out: SimOutcome,
             t_start: float, stop_text: str = "stopped by callback") -> dict[str, Any]:
    """The answer of a finished simulation (canonical frame): the :meth:`Backend.finish`
    arguments.  ``stop_text`` says what stopped a run that ended by its callback (the
    caller's, or the time limit)."""
    paths = out.paths()
    claim, msg = _outcome(opts, glob, policy, out, stop_text)
    ld = policy.lead
    lp = paths[ld.robot.id]
    dist_goal = np.hypot(*(lp - ld.robot.goal).T)
    hist = History({
        "iteration": list(range(len(out.times))),
        "best_cost": np.minimum.accumulate(dist_goal).tolist(),
        "dist_to_goal": dist_goal.tolist(),
        "n_eval": list(range(len(out.times))),
        "time": out.times.tolist(),
    })
    n_eval = glob.result.n_eval if glob.result is not None else 0
    return dict(
        paths=paths, claim=claim, times=out.times,
        cost=path_lengths(lp), message=msg,
        n_iter=out.steps, n_eval=n_eval + out.steps, history=hist,
        extras=_extras(opts, glob, policy, out), wall_time=time.perf_counter() - t_start,
    )


def _outcome(opts: RunOptions, glob: GlobalStage, policy: HybridPolicy,
             out: SimOutcome, stop_text: str) -> tuple[Status, str]:
    """The claim and the message of a finished simulation."""
    if out.reason == "done" and policy.tracker.all_done:
        claim, msg = Status.solved, "every sub-goal sequence completed"
    else:
        claim = Status.approximate
        msg = {"collision": f"collision: {out.collision}",
               "budget": f"step budget ({opts.max_steps}) exhausted",
               "gave_up": (f"collision: {policy.guard.collision}" if policy.guard.collision
                           else "; ".join(policy.gave_up) or "local planner gave up"),
               "callback": f"{stop_text} after {out.steps} steps (t={out.times[-1]:.2f} s)",
               }.get(out.reason, out.reason)
    notes = list(glob.messages)
    if (policy.k_arrived is not None and policy.fctrl is not None and out.reason == "done"
            and not policy.followers_settled(out.positions[-1])):
        notes.append("followers did not settle within settle_steps")
    return claim, "; ".join([msg, *notes])


def _extras(opts: RunOptions, glob: GlobalStage, policy: HybridPolicy,
            out: SimOutcome) -> dict[str, Any]:
    """The result's extras (units: :func:`extras_units`): the global path, sub-goals, stage
    names, statistics."""
    ld, gres, fctrl = policy.lead, glob.result, policy.fctrl
    gpath = glob.paths[ld.robot.id]
    return {
        "global_path": gpath,
        "inflection_points": inflection_points(gpath, opts.angle_tol),
        "subgoals": ld.goals,
        "global_paths": glob.paths,
        "subgoal_sequences": {d.robot.id: d.goals for d in policy.drivers},
        "global_solver": stage_name(opts.global_solver),
        "local_solver": stage_name(opts.local_solver),
        "formation_solver": stage_name(opts.formation) if fctrl is not None else "",
        "global_status": gres.status.value if gres is not None else "init",
        "global_length": path_lengths(gpath),
        "global_metrics": _small_metrics(gres.metrics) if gres is not None else {},
        "global_wall_time": glob.wall_time,
        "subgoal_events": {d.robot.id: [{"subgoal": j, "t": t, "how": h}
                                        for j, t, h in d.reached_at]
                           for d in policy.drivers},
        "subgoal_times": [t for _, t, _ in ld.reached_at],
        "time_to_goal": ld.t_goal,
        "local_stats": {d.robot.id: dict(d.controller.stats) for d in policy.drivers},
        "leader_field": _field_summary(ld.controller),
        "formation_stats": dict(fctrl.stats) if fctrl is not None else {},
        "sim_reason": out.reason,
        "contacts": list(out.contacts),
        "dt": opts.dt,
    }


def early_answer(problem: Problem, ids: list[str], gres: Result | None, msg: str,
                 t_start: float, angle_tol: float,
                 status: Status = Status.approximate) -> dict[str, Any]:
    """The answer when the run ends before the simulation: robots stay at their starts."""
    paths = {i: problem.robot(i).start[None, :].copy() for i in ids}
    extras: dict[str, Any] = {"global_status": gres.status.value if gres else "none"}
    if gres is not None:
        lp = gres.paths.get(problem.leader.id)
        if lp is not None:
            extras["global_path"] = np.asarray(lp)
            extras["inflection_points"] = inflection_points(lp, angle_tol)
    return dict(paths=paths, claim=status, times=np.zeros(1), message=msg,
                n_eval=gres.n_eval if gres else 0, extras=extras,
                wall_time=time.perf_counter() - t_start)


def world_answer(world: Problem, image: Problem, answer: dict[str, Any], units: Record
                 ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``answer``, planned on the canonical ``image``, mapped back to ``world`` (x its unit;
    each path starts at the robot's exact start): ``(paths, the other finish arguments)``.

    The history and the extras are mapped by their declared units (:data:`HISTORY_UNITS`,
    ``units``: :func:`extras_units`); a column or an extra without one raises
    :class:`~optplan.units.UndeclaredUnit`."""
    u = image.world_unit
    paths = {}
    for rid, p in answer.pop("paths").items():
        p = np.array(p, dtype=float) * u
        p[0] = world.robot(rid).start
        paths[rid] = p
    hist = answer.pop("history", None)
    if hist is not None:
        hist = History(to_scale({k: hist[k].tolist() for k in hist.keys()}, HISTORY_UNITS, u,
                                "history"))
    extras = to_scale(answer.pop("extras"), units, u)
    extras["canonical_unit"] = u
    return paths, dict(cost=answer.pop("cost", float("nan")) * u, history=hist, extras=extras,
                       **answer)


def _field_summary(ctrl: LocalController) -> dict:
    """The leader's potential-field lengths (map units) when its controller has them."""
    p = getattr(ctrl, "params", None)
    if p is None:
        return {}
    return {"rho_0": float(p.rho_0), "sense_range": float(p.sense_range),
            "length_scale": float(p.unit)}


def _small_metrics(m: dict) -> dict:
    keep = ("feasible", "length", "collisions", "static_collisions", "min_clearance", "reached")
    return {k: m[k] for k in keep if k in m}


def long_path_note(world: Problem, res: Result) -> str:
    """``"path 30.1x the certified optimum 12.1 (...)"`` when ``res`` succeeded with a leader
    path longer than :data:`LONG_PATH_RATIO` times the certified optimum of the known map
    (:func:`optplan.solver.reference_optimum`, cached per problem), else ``""``.

    The optimum is computed only when the path is longer than that many straight-line
    distances (the optimum is at least the straight line, so a shorter path cannot qualify).
    The note says whether the global path already was that long or the local planner's
    detours between the sub-goals made it so."""
    from optplan.solver import reference_optimum  # the solver module imports the backends

    lead = world.leader
    length = res.metrics.get("length")
    if (res.status not in (Status.optimal, Status.solved) or lead.goal is None
            or length is None or not length > LONG_PATH_RATIO * math.dist(lead.start, lead.goal)):
        return ""
    opt = reference_optimum(world)["optimum"]
    if not opt or not length > LONG_PATH_RATIO * opt:
        return ""
    g = res.extras.get("global_length", math.nan) / opt
    why = (f"the global path is already {g:.1f}x" if g > LONG_PATH_RATIO else
           f"global path {g:.2f}x; the rest is the local planner's detours between sub-goals")
    return f"path {length / opt:.1f}x the certified optimum {opt:.4g} ({why})"
