"""Team planners beside the team optimum: collision-free share, arrival, formation, separation.

Scenes (``--seeds`` seeds each; the seed is the planners' ``rng`` and, for the random scenes,
the scene's):

* ``paper-warehouse`` and ``warehouse-team`` (catalogue);
* random team scenes (:func:`team_scene`): a three-robot wedge formation
  (``optplan.generators.formation_scene``) driving 200 units among 6 random discs, with two
  discs of radius 2 bouncing across its route at 2-4.5 units/s (the robots drive at 4).

Planners: ``hybrid-paper``, ``hybrid-qp``, ``leader-follower-paper``, ``formation-qp``,
``orca-team`` (when the ``orca`` backend is installed) and ``formation-nlp`` (warm-started from
the seed's ``hybrid-qp`` plan: the time printed for it is its own, from that plan to its graded
result).  Per planner: the share of runs that are collision-free in continuous time and reach
(the validator's ``feasible`` and ``reached``), the leader's arrival, the formation RMSE, the
smallest distance between robot centres and the wall time, as medians and worst cases over the
seeds; for ``formation-nlp`` also on how many seeds it is no worse than its warm start (arrival
and RMSE).  Targets (issue 26): ``formation-nlp`` on ``paper-warehouse`` <= 10 s,
collision-free, arrival and RMSE no worse than its warm start on every seed.

Run: ``python benchmarks/bench_team.py [--seeds 10] [--quick] [--only catalogue|random]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from typing import Any

import numpy as np

import optplan as op
from optplan.generators import formation_scene
from optplan.geometry.timing.time_bounds import arrival_time
from optplan.problem import Problem, parse_problem

PLANNERS = ("hybrid-paper", "hybrid-qp", "leader-follower-paper", "formation-qp", "orca-team")


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
    data = {
        "name": f"team-random-{seed}", "bounds": list(base.bounds),
        "robots": [{"id": r.id, "start": r.start.tolist(), "radius": r.radius,
                    "max_speed": r.max_speed,
                    **({"goal": r.goal.tolist()} if r.goal is not None else {})}
                   for r in base.robots],
        "formation": {"leader": base.formation.leader,  # type: ignore[union-attr]
                      "safety_distance": base.formation.safety_distance,  # type: ignore
                      "followers": [{"id": f.id, "L": f.L, "phi": f.phi}
                                    for f in base.formation.followers]},  # type: ignore
        "obstacles": [{"type": "circle", "center": o.center.tolist(), "radius": o.radius,
                       "known": o.known} for o in base.obstacles],
        "dynamic_obstacles": movers}
    return parse_problem(data, f"<{data['name']}>")


def _row(problem: Problem, res: op.Result, wall: float) -> dict[str, Any]:
    m = res.metrics
    lead = problem.formation.leader if problem.formation else problem.leader.id
    arr = (arrival_time(problem, lead, res.paths[lead], res.times)
           if lead in res.paths else None)
    return {"ok": bool(m.get("feasible") and m.get("reached")),
            "arrival": np.nan if arr is None else arr,
            "rmse": m.get("formation_rmse", np.nan), "sep": m.get("min_separation", np.nan),
            "wall": wall, "status": res.status.value}


def _available(name: str) -> bool:
    try:
        op.get_solver(name)
    except (ValueError, ImportError):
        return False
    return True


def run_scene(problem: Problem, seeds: list[int]) -> dict[str, list[dict]]:
    """Every planner on ``problem`` for every seed, and formation-nlp from hybrid-qp."""
    rows: dict[str, list[dict]] = {}
    nlp = op.get_solver("formation-nlp")
    for seed in seeds:
        warm = None
        for name in [p for p in PLANNERS if _available(p)]:
            t0 = time.perf_counter()
            res = op.solve(problem, name, rng=seed)
            rows.setdefault(name, []).append(_row(problem, res, time.perf_counter() - t0))
            if name == "hybrid-qp":
                warm = (res, rows[name][-1])
        assert warm is not None
        t0 = time.perf_counter()
        ref = nlp.reference(problem, warm[0])  # type: ignore[attr-defined]
        row = _row(problem, ref, time.perf_counter() - t0)
        w = warm[1]
        row["no_worse"] = bool(row["ok"] and (not w["ok"] or (
            row["arrival"] <= w["arrival"] * (1 + 1e-6)
            and row["rmse"] <= w["rmse"] + 1e-3 * _lbar(problem))))
        rows.setdefault("formation-nlp", []).append(row)
    return rows


def _lbar(problem: Problem) -> float:
    form = problem.formation
    return float(np.mean([f.L for f in form.followers])) if form else 1.0


def _med_worst(v: list[float], worst_is_max: bool = True) -> str:
    x = [a for a in v if np.isfinite(a)]
    if not x:
        return "-"
    w = max(x) if worst_is_max else min(x)
    return f"{statistics.median(x):.3f} / {w:.3f}"


def table(title: str, rows: dict[str, list[dict]]) -> str:
    """One Markdown table: a row per planner."""
    out = [f"### {title}", "",
           "| planner | collision-free and reached | arrival s (median / worst) "
           "| formation RMSE (median / worst) | min separation (median / worst) "
           "| wall s (median / worst) |", "|---|---:|---:|---:|---:|---:|"]
    for name, rs in rows.items():
        ok = sum(r["ok"] for r in rs)
        out.append(f"| {name} | {ok}/{len(rs)} | {_med_worst([r['arrival'] for r in rs])} "
                   f"| {_med_worst([r['rmse'] for r in rs])} "
                   f"| {_med_worst([r['sep'] for r in rs], worst_is_max=False)} "
                   f"| {_med_worst([r['wall'] for r in rs])} |")
    nlp = rows.get("formation-nlp", [])
    if nlp:
        out += ["", f"formation-nlp no worse than its hybrid-qp warm start (arrival, RMSE) and "
                    f"collision-free on {sum(r['no_worse'] for r in nlp)}/{len(nlp)} seeds."]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--quick", action="store_true", help="2 seeds")
    ap.add_argument("--only", choices=("catalogue", "random"), default=None,
                    help="only the catalogue scenes or only the random team scenes")
    args = ap.parse_args(argv)
    n = 2 if args.quick else args.seeds
    seeds = list(range(n))
    print(f"# bench_team ({platform.node()}, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}, seeds {seeds})\n")
    if args.only != "random":
        for name in ("paper-warehouse", "warehouse-team"):
            print(table(name, run_scene(op.load_problem(name), seeds)) + "\n")
    if args.only != "catalogue":
        merged: dict[str, list[dict]] = {}
        for seed in seeds:
            for k, v in run_scene(team_scene(seed), [seed]).items():
                merged.setdefault(k, []).extend(v)
        print(table("random team scenes (one per seed)", merged) + "\n")
    print("Target: formation-nlp on paper-warehouse <= 10 s (its own time, from the hybrid-qp "
          "plan), collision-free, no worse than its warm start on every seed.")
    print(f"load average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
