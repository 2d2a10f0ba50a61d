"""The hybrid planner's answer: status, message, history and extras of a run, in world units.

The run is planned on the canonical image of the scene
(:func:`optplan.canonical.canonical_problem`); :func:`assemble` (after the simulation) and
:func:`early_answer` (when the run ends before it) build the answer there, :func:`world_answer`
maps its paths, lengths, history and extras back to the world scene.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np

from optplan.canonical import to_world
from optplan.geometry.polyline import path_lengths
from optplan.hybrid.subgoals import inflection_points
from optplan.interfaces import LocalController, stage_name
from optplan.problem import Problem
from optplan.result import History, Result, Status
from optplan.sim import SimOutcome

if TYPE_CHECKING:
    from optplan.hybrid.planner import Hybrid
    from optplan.hybrid.policy import HybridPolicy
    from optplan.hybrid.stages import GlobalStage

__all__ = ["assemble", "early_answer", "world_answer"]

#: History columns that are lengths (mapped back from the canonical frame).
_LENGTH_COLUMNS = ("best_cost", "dist_to_goal")
#: Extras whose values are points or lengths (mapped back from the canonical frame).
#: ``None``: the whole value; a tuple: those keys of a dict value.
_LENGTH_EXTRAS: dict[str, tuple[str, ...] | None] = {
    "global_path": None, "inflection_points": None, "subgoals": None, "global_paths": None,
    "subgoal_sequences": None, "global_length": None, "leader_field": None,
    "global_metrics": ("length", "min_clearance"), "formation_stats": ("max_slack",)}


def assemble(opts: Hybrid, glob: GlobalStage, policy: HybridPolicy, out: SimOutcome,
             t_start: float) -> dict[str, Any]:
    """The answer of a finished simulation (canonical frame): the :meth:`Backend.finish`
    arguments."""
    paths = out.paths()
    claim, msg = _outcome(opts, glob, policy, out)
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


def _outcome(opts: Hybrid, glob: GlobalStage, policy: HybridPolicy,
             out: SimOutcome) -> tuple[Status, str]:
    """The claim and the message of a finished simulation."""
    if out.reason == "done" and policy.tracker.all_done:
        claim, msg = Status.solved, "every sub-goal sequence completed"
    else:
        claim = Status.approximate
        msg = {"collision": f"collision: {out.collision}",
               "budget": f"step budget ({opts.max_steps}) exhausted",
               "gave_up": "; ".join(policy.gave_up) or "local planner gave up",
               "callback": "stopped by callback"}.get(out.reason, out.reason)
    notes = list(glob.messages)
    if (policy.k_arrived is not None and policy.fctrl is not None and out.reason == "done"
            and not policy.followers_settled(out.positions[-1])):
        notes.append("followers did not settle within settle_steps")
    return claim, "; ".join([msg, *notes])


def _extras(opts: Hybrid, glob: GlobalStage, policy: HybridPolicy,
            out: SimOutcome) -> dict[str, Any]:
    """The result's extras: the global path, sub-goals, stage names, statistics."""
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


def world_answer(world: Problem, image: Problem, answer: dict[str, Any]
                 ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``answer``, planned on the canonical ``image``, mapped back to ``world`` (x its unit;
    each path starts at the robot's exact start): ``(paths, the other finish arguments)``."""
    u = image.world_unit
    paths = {}
    for rid, p in answer.pop("paths").items():
        p = np.array(p, dtype=float) * u
        p[0] = world.robot(rid).start
        paths[rid] = p
    hist = answer.pop("history", None)
    if hist is not None:
        hist = History({k: (to_world(hist[k].tolist(), u) if k in _LENGTH_COLUMNS
                            else hist[k].tolist()) for k in hist.keys()})
    extras = answer.pop("extras")
    extras = {k: _extra_to_world(v, _LENGTH_EXTRAS[k], u) if k in _LENGTH_EXTRAS else v
              for k, v in extras.items()}
    extras["canonical_unit"] = u
    return paths, dict(cost=answer.pop("cost", float("nan")) * u, history=hist, extras=extras,
                       **answer)


def _extra_to_world(value: Any, keys: tuple[str, ...] | None, unit: float) -> Any:
    """An extras value of the canonical run in world units (``keys``: :data:`_LENGTH_EXTRAS`)."""
    if keys is None:
        return to_world(value, unit)
    return {k: to_world(v, unit) if k in keys else v for k, v in value.items()}


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
