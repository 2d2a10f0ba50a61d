"""Team planners graded against the team reference: ratios to the front of the best known plans.

Per scene, the team reference (:mod:`optplan.team_grading`) is built once: the candidates of
the ``formation-nlp`` preset (``team_candidates``: ``formation-qp``, ``leader-follower-paper``,
``hybrid-qp`` and ``orca-team`` with ``rng = 0``, and ``formation-nlp`` polished from each, each
polish within the preset's ``time_limit``), of which the valid, non-dominated ones in (leader
arrival at the goal point, formation RMSE) form the front.  The script prints the front, then
every team heuristic (``hybrid-paper`` too, which is no candidate) over ``--seeds`` seeds, graded
against that one front: the share the validator accepts, the leader's arrival and the formation
RMSE, ``arrival_ratio_to_team``, ``formation_rmse_ratio_to_team`` and
``arrival_ratio_to_team_lower`` (to the certified lower bound) as median / worst over the
seeds, the count of ratios below 1 among valid plans (0 by the rule) and of plans that are
their own reference on a criterion ("this plan"), and the wall time of a solve
(``Result.wall_time``, median / worst; the ``formation-nlp`` preset's includes its warm start,
``hybrid-qp``).  The formation RMSE ratio floors both RMSEs
at 0.1 % of the mean slot distance (:data:`optplan.team_grading.ABS_RMSE`).

The deadline clock (``optplan.solver.clock``) counts this process's CPU seconds
(``time.process_time``), not the wall clock: the polishes' ``time_limit`` (60 s) and the hybrid
presets' then depend far less on the load other processes put on the machine (a polish stopped
by the limit keeps its warm start, and the front would shrink on a loaded machine); the script
prints the load average all the same.  The seed-0
runs of the candidate heuristics are the candidates themselves (not run twice); the
``formation-nlp from NAME`` candidates are graded too (one run each).

Scenes: ``paper-warehouse`` and ``warehouse-team`` (catalogue, ``--seeds`` seeds each), and
``--random`` random team scenes (:func:`team_scene`; a reference each, the planners with seeds
0 and 1): a three-robot wedge formation (``optplan.generators.formation_scene``) driving 200
units among 6 random discs, with two discs of radius 2 bouncing across its route at 2-4.5
units/s (the robots drive at 4).

Run: ``python benchmarks/bench_team.py [--seeds 5] [--random 2] [--only catalogue|random]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import optplan as op
import optplan.solver as solver_mod
from optplan.generators import formation_scene
from optplan.problem import Problem, parse_problem
from optplan.team_grading import team_front, with_team_reference

PLANNERS = ("hybrid-paper", "hybrid-qp", "leader-follower-paper", "formation-qp", "orca-team",
            "formation-nlp")


def team_scene(seed: int) -> Problem:
    """A wedge of three robots among random discs, two movers bouncing across its route (the
    first scene seed from ``100 seed`` whose obstacles leave the starts and the goal free)."""
    for k in range(100 * seed, 100 * seed + 100):
        try:
            return _team_scene(k)
        except op.ProblemError:
            continue
    raise RuntimeError(f"no valid team scene for seed {seed}")


def _team_scene(seed: int) -> Problem:
    base = formation_scene(3, "wedge", spacing=12.0, distance=200.0, obstacles=6, seed=seed)
    rng = np.random.default_rng(1000 + seed)
    x0, y0, x1, y1 = base.bounds
    movers = []
    for k in range(2):
        x = float(rng.uniform(x0 + 0.35 * (x1 - x0), x0 + 0.85 * (x1 - x0)))
        t = float(rng.uniform(25.0, 50.0))  # 2-4.5 units/s against the robots' 4
        movers.append({"type": "circle", "name": f"crosser{k}", "radius": 2.0,
                       "waypoints": [[x, y0 + 4.0], [x, y1 - 4.0]], "times": [0.0, t],
                       "after": "bounce"})
    form = base.formation
    assert form is not None
    data = {
        "name": f"team-random-{seed}", "bounds": list(base.bounds),
        "robots": [{"id": r.id, "start": r.start.tolist(), "radius": r.radius,
                    "max_speed": r.max_speed,
                    **({"goal": r.goal.tolist()} if r.goal is not None else {})}
                   for r in base.robots],
        "formation": {"leader": form.leader, "safety_distance": form.safety_distance,
                      "followers": [{"id": f.id, "L": f.L, "phi": f.phi}
                                    for f in form.followers]},
        "obstacles": [{"type": "circle", "center": o.center.tolist(), "radius": o.radius,
                       "known": o.known} for o in base.obstacles],
        "dynamic_obstacles": movers}
    return parse_problem(data, f"<{data['name']}>")


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _row(problem: Problem, res: op.Result, reference: Callable) -> dict[str, Any]:
    m = with_team_reference(res.metrics, problem, res, reference)
    src = (m.get("team_arrival_reference_source"), m.get("team_formation_rmse_reference_source"))
    return {"ok": bool(m["team_plan_valid"]), "arrival": m["team_arrival"],
            "rmse": res.metrics.get("formation_rmse"), "ra": m["arrival_ratio_to_team"],
            "re": m["formation_rmse_ratio_to_team"], "rl": m["arrival_ratio_to_team_lower"],
            "own": "this plan" in src, "wall": res.wall_time}


def run_scene(problem: Problem, seeds: list[int]) -> tuple[dict[str, list[dict]], str]:
    """Every planner on ``problem`` for every seed against the scene's one front; the rows and
    the front's description."""
    t0 = time.perf_counter()
    cands = op.get_solver("formation-nlp").team_candidates(problem)  # type: ignore[attr-defined]
    built = time.perf_counter() - t0

    def reference(p: Problem) -> dict[str, op.Result]:
        return cands

    front = team_front(problem, reference)
    rows: dict[str, list[dict]] = {}
    for seed in seeds:
        for name in PLANNERS:
            res = cands.get(name) if seed == 0 else None
            if res is None:
                try:
                    res = op.solve(problem, name, rng=seed)
                except ImportError:  # orca-team without pyrvo
                    continue
            rows.setdefault(name, []).append(_row(problem, res, reference))
    for name, res in cands.items():
        if name.startswith("formation-nlp"):
            rows.setdefault(f"{name} (seed 0)", []).append(_row(problem, res, reference))
    members = ", ".join(f"{m.source} ({m.arrival:.3f} s, rmse {m.rmse:.3f})"
                        for m in front.members)
    lines = [f"front ({len(front.members)} of {len(front.candidates)} candidates, built in "
             f"{built:.1f} s wall): {members}"]
    stopped = [k for k, r in cands.items() if r.stop_reason == "time_limit"]
    if stopped:
        lines.append(f"stopped by the time limit: {', '.join(stopped)}")
    bad = [f"{c.source} ({c.why})" for c in front.candidates if not c.valid]
    if bad:
        lines.append("not valid: " + ", ".join(bad))
    return rows, "\n".join(lines)


def _med_worst(v: list[Any], fmt: str = ".3f") -> str:
    x = [float(a) for a in v if a is not None and np.isfinite(a)]
    if not x:
        return "-"
    return f"{statistics.median(x):{fmt}} / {max(x):{fmt}}"


def table(title: str, rows: dict[str, list[dict]], notes: str) -> str:
    """One Markdown table: a row per planner (ratios over the valid runs)."""
    out = [f"### {title}", "", notes, "",
           "| planner | valid | arrival s | formation RMSE | arrival / team | RMSE / team "
           "| arrival / lower bound | valid ratios < 1 | own reference | wall s |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, rs in rows.items():
        ok = [r for r in rs if r["ok"]]
        below = sum((r["ra"] is not None and r["ra"] < 1) + (r["re"] is not None and r["re"] < 1)
                    for r in ok)
        out.append(f"| {name} | {len(ok)}/{len(rs)} | {_med_worst([r['arrival'] for r in rs])} "
                   f"| {_med_worst([r['rmse'] for r in rs])} "
                   f"| {_med_worst([r['ra'] for r in ok])} | {_med_worst([r['re'] for r in ok])} "
                   f"| {_med_worst([r['rl'] for r in ok])} | {below} "
                   f"| {sum(r['own'] for r in ok)} | {_med_worst([r['wall'] for r in rs])} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds per catalogue scene")
    ap.add_argument("--random", type=int, default=2, help="random team scenes")
    ap.add_argument("--only", choices=("catalogue", "random"), default=None,
                    help="only the catalogue scenes or only the random team scenes")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.random < 0:
        ap.error("--seeds must be >= 1 and --random >= 0")
    solver_mod.clock = time.process_time  # deadlines in CPU seconds (module docstring)
    t0 = time.perf_counter()
    print(f"# bench_team ({platform.node()}, {os.cpu_count()} cores, load average "
          f"{_load()}, seeds 0-{args.seeds - 1}, {args.random} random scenes; deadlines in CPU "
          "seconds)\n")
    if args.only != "random":
        for name in ("paper-warehouse", "warehouse-team"):
            rows, notes = run_scene(op.load_problem(name), list(range(args.seeds)))
            print(table(name, rows, notes) + f"\n\nload average {_load()}\n", flush=True)
    if args.only != "catalogue":
        for k in range(args.random):
            p = team_scene(k)
            rows, notes = run_scene(p, [0, 1])
            print(table(f"{p.name} (random team scene {k}, seeds 0-1)", rows, notes)
                  + f"\n\nload average {_load()}\n", flush=True)
    print(f"total {time.perf_counter() - t0:.0f} s; load average at the end: {_load()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
