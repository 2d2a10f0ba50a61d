"""Trap-suite statistics: ``apf`` vs ``sa-apf`` on the four local-minimum traps (paper Cases 1-4).

``optplan bench --tag traps [--variants N] [--seed S] [--jitter J] [--solvers A,B]``

For every trap scene (``trap-saddle``, ``trap-gnron``, ``trap-channel``, ``trap-u``) the
catalogue scene and ``N`` seeded variants (every obstacle translated by a uniform random offset
in ``[-J, J]^2``, drawn from ``numpy.random.default_rng(seed)``; offsets that would put the start
or goal within the robot radius of an obstacle (exact test, :meth:`Problem.blocking_obstacle`)
or move an obstacle out of the bounds are redrawn) are solved by each solver.  Printed per trap
and solver: success rate, median time to goal and median length ratio to the ``visgraph``
optimum (over successful runs), local minima detected, escapes, SA steps, statuses and the
median wall time.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any

import numpy as np
import shapely

from optplan.catalog import load_problem
from optplan.problem import Obstacle, Problem
from optplan.result import Result
from optplan.solver import solve

__all__ = ["TRAPS", "jitter_problem", "variants", "run", "summarize", "format_table", "main"]

TRAPS = ("trap-saddle", "trap-gnron", "trap-channel", "trap-u")
SOLVERS = ("apf-paper", "sa-apf-paper")


def _moved(o: Obstacle, d: np.ndarray) -> Obstacle:
    """``o`` translated by ``d``: circles move their exact centre (no geometry), polygons
    their shapely polygon."""
    if o.is_circle:
        return dataclasses.replace(o, center=o.center + d)
    g = shapely.affinity.translate(o.geometry, float(d[0]), float(d[1]))
    return dataclasses.replace(o, geometry=g)


def _valid(prob: Problem) -> bool:
    x0, y0, x1, y1 = prob.bounds
    for r in prob.robots:
        for p in (r.start, r.goal):
            if p is not None and prob.blocking_obstacle(p, r.radius) is not None:
                return False
    for o in prob.obstacles:
        bx0, by0, bx1, by1 = o.bounds
        if bx0 < x0 or by0 < y0 or bx1 > x1 or by1 > y1:
            return False
    return True


def jitter_problem(problem: Problem, rng: np.random.Generator, jitter: float,
                   name: str | None = None, tries: int = 100) -> Problem:
    """A copy of ``problem`` with every static obstacle translated by ``U[-jitter, jitter]^2``.

    Offsets are redrawn (up to ``tries`` times) while a start or goal would lie within the
    robot radius of an obstacle (exact) or an obstacle would leave the bounds.
    """
    for _ in range(tries):
        d = rng.uniform(-jitter, jitter, size=(len(problem.obstacles), 2))
        obs = tuple(_moved(o, d[i]) for i, o in enumerate(problem.obstacles))
        prob = dataclasses.replace(problem, obstacles=obs, name=name or problem.name,
                                   _cache={}, path=None)
        if _valid(prob):
            return prob
    raise ValueError(f"{problem.name}: no valid jitter found in {tries} tries")


def variants(name: str, n: int, seed: int, jitter: float) -> list[Problem]:
    """The catalogue scene followed by ``n`` seeded jittered variants."""
    base = load_problem(name)
    rng = np.random.default_rng([seed, sum(map(ord, name))])
    return [base] + [jitter_problem(base, rng, jitter, f"{name}~{i + 1}") for i in range(n)]


def run(traps: tuple[str, ...] = TRAPS, solvers: tuple[str, ...] = SOLVERS, n_variants: int = 30,
        seed: int = 0, jitter: float = 4.0, progress: Any = None) -> list[dict[str, Any]]:
    """Solve every (trap variant, solver) pair; return one tidy row per run."""
    rows = []
    for trap in traps:
        for k, prob in enumerate(variants(trap, n_variants, seed, jitter)):
            for s in solvers:
                t0 = time.perf_counter()
                res: Result = solve(prob, s, rng=seed * 100_003 + k, reference=True)
                m, ex = res.metrics, res.extras
                det = ex.get("detections", {})
                rows.append({
                    "trap": trap, "variant": k, "solver": s, "status": res.status.value,
                    "success": res.success, "time_to_goal": ex.get("time_to_goal", np.nan),
                    "ratio": m.get("ratio_to_optimum", np.nan),
                    "minima": ex.get("local_minima_detected", 0),
                    "eq38": det.get("eq38", 0),
                    "stall_osc": det.get("stall", 0) + det.get("oscillation", 0),
                    "escapes": ex.get("local_minima_escaped", 0),
                    "sa_steps": ex.get("sa_steps", 0), "collisions": m.get("collisions", 0),
                    "wall": time.perf_counter() - t0, "message": res.message,
                })
                if progress:
                    progress(rows[-1])
    return rows


def _med(v: list) -> float:
    return float(np.median(v)) if len(v) else float("nan")


def _outcome_stats(rs: list[dict[str, Any]]) -> dict[str, Any]:
    """Runs, successes and the medians over the successful runs of one (trap, solver). Returns
    ``runs``, ``solved``, ``success_rate``, ``median_time_to_goal`` and ``median_ratio`` (``nan``
    without a successful run)."""
    ok = [r for r in rs if r["success"]]
    return {"runs": len(rs), "solved": len(ok), "success_rate": len(ok) / len(rs),
            "median_time_to_goal": _med([r["time_to_goal"] for r in ok]),
            "median_ratio": _med([r["ratio"] for r in ok])}


def _detection_totals(rs: list[dict[str, Any]]) -> dict[str, int]:
    """Local minima detected (all, eq 38, stall or oscillation) and escapes, summed. Returns
    ``minima``, ``eq38``, ``stall_osc`` and ``escapes``, each summed over ``rs``."""
    return {k: int(sum(r[k] for r in rs)) for k in ("minima", "eq38", "stall_osc", "escapes")}


def _cost_stats(rs: list[dict[str, Any]]) -> dict[str, Any]:
    """SA steps, failed runs and wall time of one (trap, solver). Returns ``median_sa_steps``,
    ``failed_collision`` (runs with status ``failed``) and ``median_wall_ms``."""
    return {"median_sa_steps": _med([r["sa_steps"] for r in rs]),
            "failed_collision": sum(r["status"] == "failed" for r in rs),
            "median_wall_ms": 1e3 * _med([r["wall"] for r in rs])}


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Aggregate rows per (trap, solver)."""
    out = []
    keys = list(dict.fromkeys((r["trap"], r["solver"]) for r in rows))
    for trap, s in keys:
        rs = [r for r in rows if r["trap"] == trap and r["solver"] == s]
        out.append({"trap": trap, "solver": s, **_outcome_stats(rs), **_detection_totals(rs),
                    **_cost_stats(rs)})
    return out


def format_table(summary: list[dict[str, Any]]) -> str:
    """Markdown table of :func:`summarize` output."""
    head = ("| trap | solver | success | median time to goal (s) | median length / optimum | "
            "minima detected (eq 38 / stall or oscillation) | escapes | median SA steps | "
            "collisions | median wall (ms) |")
    lines = [head, "|" + "---|" * 10]
    for r in summary:
        lines.append(
            f"| {r['trap']} | {r['solver']} | {r['solved']}/{r['runs']} "
            f"({100 * r['success_rate']:.0f} %) | {r['median_time_to_goal']:.1f} | "
            f"{r['median_ratio']:.3f} | {r['minima']} ({r['eq38']} / {r['stall_osc']}) | "
            f"{r['escapes']} | "
            f"{r['median_sa_steps']:.0f} | {r['failed_collision']} | {r['median_wall_ms']:.0f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="optplan bench --tag traps", description=__doc__.split(
        "\n\n")[0])
    ap.add_argument("--variants", type=int, default=30, help="seeded variants per trap (30)")
    ap.add_argument("--seed", type=int, default=0, help="master seed (0)")
    ap.add_argument("--jitter", type=float, default=4.0,
                    help="obstacle jitter half-width, map units (4)")
    ap.add_argument("--solvers", default=",".join(SOLVERS),
                    help="comma-separated solvers (apf-paper,sa-apf-paper)")
    ap.add_argument("--traps", default=",".join(TRAPS), help="comma-separated trap scenes")
    ap.add_argument("--csv", default=None, help="also write the per-run rows to this CSV file")
    a = ap.parse_args(argv)
    if a.variants < 0:
        ap.error("--variants must be >= 0")
    t0 = time.perf_counter()
    rows = run(tuple(a.traps.split(",")), tuple(a.solvers.split(",")), a.variants, a.seed,
               a.jitter)
    print(f"Trap suite: {a.variants} seeded variants + the catalogue scene per trap, "
          f"jitter +-{a.jitter:g}, seed {a.seed}\n")
    print(format_table(summarize(rows)))
    stat: dict[str, int] = {}
    for r in rows:
        stat[r["status"]] = stat.get(r["status"], 0) + 1
    print(f"\n{len(rows)} runs in {time.perf_counter() - t0:.1f} s; statuses: "
          + ", ".join(f"{k} {v}" for k, v in sorted(stat.items())))
    if a.csv:
        import csv

        with open(a.csv, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
