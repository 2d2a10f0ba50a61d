"""``optplan bench --tag hybrid``: the paper's hybrid-planner experiments (§V, §VI.B-C).

Two tables, each printed as markdown:

1. **Three-way comparison** (paper Figs 28-30) on ``paper-hybrid`` over ``--seeds`` seeds:
   the global planner alone (IPSO on the known map, executed as planned: it runs into the
   temporary obstacles it could not see), the local planner alone (SA-APF from start to goal)
   and the hybrid (IPSO -> inflection points -> SA-APF).  Columns: success, median length,
   median collisions, runs colliding with a temporary obstacle, median time to goal, median
   ratio to the static optimum (certified visibility-graph length on the known map) and to the
   full-map optimum (temporary obstacles included), median wall time.
2. **Formation runs** (paper Figs 32, 34) on ``paper-formation`` and ``paper-warehouse`` with
   ``hybrid-paper`` (leader-follower) and ``hybrid-qp`` (formation QP).

Usage::

    optplan bench --tag hybrid [--seeds 30] [--formation-seeds 5] [--save DIR] [--quick]

Time to goal: simulated arrival time for trajectories; for a geometric path (IPSO alone) the
nominal ``length / max_speed`` of driving it at full speed.  Wall times are medians on a
shared 2-core machine.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import optplan as op
from optplan.exact.visgraph import shortest_length

__all__ = ["main", "three_way", "formation_runs", "temporary_collision", "time_to_goal",
           "format_three_way", "format_formation"]

THREE_WAY = (("IPSO alone", "ipso"), ("SA-APF alone", "sa-apf-paper"),
             ("hybrid", "hybrid-paper"))
FORMATION_SCENES = ("paper-formation", "paper-warehouse")
FORMATION_SOLVERS = ("hybrid-paper", "hybrid-qp")


def temporary_collision(problem: op.Problem, res: op.Result) -> bool:
    """True when a path of ``res`` crosses (the inflation of) a temporary obstacle."""
    temp = {o.name for o in problem.obstacles if not o.known}
    per = res.metrics.get("per_robot", {})
    return any(temp & set(m.get("crossed", [])) for m in per.values())


def time_to_goal(problem: op.Problem, res: op.Result) -> float:
    """Arrival time of the leader (``nan`` if it never arrives).

    Simulated trajectories: the first time stamp within the goal tolerance.  Geometric paths:
    ``length / max_speed`` (driving the path at full speed).
    """
    lead = problem.leader
    path = res.paths.get(lead.id)
    if path is None or lead.goal is None:
        return math.nan
    if res.times is None:
        if not res.metrics.get("reached"):
            return math.nan
        return float(res.metrics["length"]) / lead.max_speed
    d = np.hypot(*(np.asarray(path) - lead.goal).T)
    hit = np.nonzero(d <= problem.goal_tol(lead) + 1e-9)[0]
    return float(res.times[hit[0]]) if len(hit) else math.nan


def _median(xs: Sequence[float]) -> float:
    a = np.asarray([x for x in xs if x is not None and math.isfinite(x)], dtype=float)
    return float(np.median(a)) if len(a) else math.nan


def three_way(seeds: Sequence[int], problem: str = "paper-hybrid",
              methods: Sequence[tuple[str, str]] = THREE_WAY,
              save: Path | None = None, global_solver: str = "ipso"
              ) -> dict[str, list[dict[str, Any]]]:
    """Run each method on ``problem`` for every seed; rows of per-run numbers per method.

    ``global_solver`` replaces ``ipso`` (the "IPSO alone" row and the hybrid's global
    stage).
    """
    prob = op.load_problem(problem)
    opt_known = shortest_length(prob, prob.leader, known_only=True)
    opt_full = shortest_length(prob, prob.leader, known_only=False)
    rows: dict[str, list[dict[str, Any]]] = {}
    for label, solver in methods:
        rows[label] = []
        for s in seeds:
            t0 = time.perf_counter()
            if solver == "ipso":
                res = op.solve(prob, global_solver, rng=int(s))
            elif solver.startswith("hybrid") and global_solver != "ipso":
                res = op.solve(prob, solver, rng=int(s), global_solver=global_solver)
            else:
                res = op.solve(prob, solver, rng=int(s))
            wall = time.perf_counter() - t0
            m = res.metrics
            rows[label].append({
                "seed": int(s), "status": res.status.value, "success": res.success,
                "length": float(m["length"]), "collisions": int(m["collisions"]),
                "static_collisions": int(m["static_collisions"]),
                "dynamic_contacts": int(m["dynamic_contacts"]),
                "dynamic_checked": bool(m.get("dynamic_checked")),
                "temporary_collision": temporary_collision(prob, res),
                "reached": bool(m["reached"]),
                "time_to_goal": time_to_goal(prob, res),
                "ratio_known": float(m["length"]) / opt_known if opt_known else math.nan,
                "ratio_full": float(m["length"]) / opt_full if opt_full else math.nan,
                "global_length": res.extras.get("global_length", math.nan),
                "wall": wall,
            })
            if save is not None:
                save.mkdir(parents=True, exist_ok=True)
                res.save(save / f"{problem}_{solver}_seed{s}.json")
    rows["_optimum"] = [{"known": opt_known, "full": opt_full}]
    return rows


def _three_way_header(rows: dict[str, list[dict[str, Any]]], problem: str) -> list[str]:
    """Title (seeds, both optima) and column heads of the three-way table."""
    opt = rows["_optimum"][0]
    n = max(len(v) for k, v in rows.items() if not k.startswith("_"))
    return [f"Three-way comparison on `{problem}` ({n} seeds; medians; static optimum on the "
            f"known map {opt['known']:.2f}, with the temporary obstacles {opt['full']:.2f})",
            "", "| method | success | length | collisions | temp. obstacle hit "
            "| time to goal (s) | ratio to static optimum | ratio to full-map optimum "
            "| wall time (s) |", "|---|---|---|---|---|---|---|---|---|"]


def _three_way_line(label: str, rs: list[dict[str, Any]]) -> str:
    """One method's line: successes, temporary-obstacle hits and medians over its runs."""
    ok = sum(r["success"] for r in rs)
    hit = sum(r["temporary_collision"] for r in rs)
    return (f"| {label} | {ok}/{len(rs)} | {_median([r['length'] for r in rs]):.1f} "
            f"| {_median([r['collisions'] for r in rs]):g} | {hit}/{len(rs)} "
            f"| {_median([r['time_to_goal'] for r in rs]):.1f} "
            f"| {_median([r['ratio_known'] for r in rs]):.3f} "
            f"| {_median([r['ratio_full'] for r in rs]):.3f} "
            f"| {_median([r['wall'] for r in rs]):.2f} |")


def _hybrid_vs_ipso(rows: dict[str, list[dict[str, Any]]]) -> list[str]:
    """A blank line and the hybrid's length over IPSO's, seed by seed (median and max), of the
    :func:`three_way` ``rows``; nothing unless both methods ran."""
    if "hybrid" not in rows or "IPSO alone" not in rows:
        return []
    rat = [h["length"] / i["length"] for h, i in zip(rows["hybrid"], rows["IPSO alone"])]
    return ["", f"hybrid length / IPSO length, same seed: median {_median(rat):.3f}, "
            f"max {max(rat):.3f}"]


def format_three_way(rows: dict[str, list[dict[str, Any]]], problem: str = "paper-hybrid"
                     ) -> str:
    """Markdown three-way comparison of :func:`three_way` rows.

    Parameters
    ----------
    rows
        Output of :func:`three_way`.
    problem
        The scene named in the title.

    Returns
    -------
    str
        The title, one line per method, then the hybrid / IPSO length ratio.
    """
    out = _three_way_header(rows, problem)
    out += [_three_way_line(label, rs) for label, rs in rows.items()
            if not label.startswith("_")]
    return "\n".join(out + _hybrid_vs_ipso(rows))


def formation_runs(seeds: Sequence[int], scenes: Sequence[str] = FORMATION_SCENES,
                   solvers: Sequence[str] = FORMATION_SOLVERS,
                   save: Path | None = None, global_solver: str = "ipso"
                   ) -> list[dict[str, Any]]:
    """Hybrid formation runs: one row per (scene, solver, seed)."""
    rows = []
    for scene in scenes:
        prob = op.load_problem(scene)
        for solver in solvers:
            for s in seeds:
                t0 = time.perf_counter()
                over: dict[str, Any] = ({} if global_solver == "ipso"
                                        else {"global_solver": global_solver})
                try:
                    res = op.solve(prob, solver, rng=int(s), **over)
                except (ValueError, ImportError) as e:  # a stage not available in this build
                    rows.append({"scene": scene, "solver": solver, "seed": int(s),
                                 "status": f"unavailable: {e}"})
                    break
                m = res.metrics
                rows.append({
                    "scene": scene, "solver": solver, "seed": int(s),
                    "status": res.status.value, "reached": bool(m["reached"]),
                    "collisions": int(m["collisions"]),
                    "min_separation": m.get("min_separation", math.nan),
                    "safety": m.get("safety_distance", math.nan),
                    "rmse": m.get("formation_rmse", math.nan),
                    "min_clearance": min(m["min_clearance"], m["min_clearance_dynamic"]),
                    "time_to_goal": time_to_goal(prob, res),
                    "wall": time.perf_counter() - t0, "message": res.message,
                })
                if save is not None:
                    save.mkdir(parents=True, exist_ok=True)
                    res.save(save / f"{scene}_{solver}_seed{s}.json")
    return rows


def _formation_line(scene: str, solver: str, rs: list[dict[str, Any]]) -> str:
    """One (scene, solver) line of the formation table: counts and medians over seeds."""
    if rs[0]["status"].startswith("unavailable"):
        return f"| {scene} | {solver} | {rs[0]['status']} | | | | | | | |"
    ok = sum(r["status"] in ("solved", "optimal") for r in rs)
    return (f"| {scene} | {solver} | {ok}/{len(rs)} | {sum(r['reached'] for r in rs)}/{len(rs)} "
            f"| {_median([r['collisions'] for r in rs]):g} "
            f"| {_median([r['min_separation'] for r in rs]):.2f} ({rs[0]['safety']:g}) "
            f"| {_median([r['rmse'] for r in rs]):.2f} "
            f"| {_median([r['min_clearance'] for r in rs]):.2f} "
            f"| {_median([r['time_to_goal'] for r in rs]):.1f} "
            f"| {_median([r['wall'] for r in rs]):.2f} |")


def _formation_failures(rows: list[dict[str, Any]]) -> list[str]:
    """A blank line, a heading and one list item per run of the :func:`formation_runs`
    ``rows`` that was available but neither solved nor optimal; nothing when there is none."""
    fails = [r for r in rows if r["status"] not in ("solved", "optimal")
             and not r["status"].startswith("unavailable")]
    if not fails:
        return []
    return ["", "Unsuccessful runs:"] + [
        f"- {r['scene']} / {r['solver']} seed {r['seed']}: {r['status']} ({r['message']})"
        for r in fails]


def format_formation(rows: list[dict[str, Any]]) -> str:
    """Markdown table of :func:`formation_runs` rows, then the unsuccessful runs.

    Parameters
    ----------
    rows
        Rows of :func:`formation_runs`.

    Returns
    -------
    str
        One line per (scene, solver), in first-seen order, then the list of failures.
    """
    out = ["Hybrid formation runs (medians over seeds)", "",
           "| scene | solver | solved | all reached | collisions | min separation (safety) "
           "| formation RMSE | min clearance | time to goal (s) | wall time (s) |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for scene, solver in dict.fromkeys((r["scene"], r["solver"]) for r in rows):
        rs = [r for r in rows if (r["scene"], r["solver"]) == (scene, solver)]
        out.append(_formation_line(scene, solver, rs))
    return "\n".join(out + _formation_failures(rows))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="optplan bench --tag hybrid", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=30, help="seeds of the three-way comparison")
    ap.add_argument("--formation-seeds", type=int, default=5,
                    help="seeds of each formation run")
    ap.add_argument("--problem", default="paper-hybrid", help="scene of the three-way table")
    ap.add_argument("--save", type=Path, default=None, help="write every Result JSON here")
    ap.add_argument("--quick", action="store_true", help="3 seeds, 1 formation seed")
    ap.add_argument("--global-solver", default="ipso",
                    help="replace ipso (IPSO-alone row and the hybrids' global stage)")
    ap.add_argument("--skip-formation", action="store_true")
    ap.add_argument("--skip-three-way", action="store_true")
    a = ap.parse_args(argv)
    if a.quick:
        a.seeds, a.formation_seeds = 3, 1
    import os

    print(f"machine: {os.cpu_count()} cores (shared); optplan {op.__version__}\n")
    if not a.skip_three_way:
        rows = three_way(range(a.seeds), a.problem, save=a.save,
                         global_solver=a.global_solver)
        print(format_three_way(rows, a.problem))
        print()
    if not a.skip_formation:
        print(format_formation(formation_runs(range(a.formation_seeds), save=a.save,
                                              global_solver=a.global_solver)))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
