"""``optplan bench --tag formation``: leader-follower-paper vs formation-qp (issue 6).

Both formation solvers run on ``paper-formation`` and ``paper-warehouse`` over ``--seeds``
seeded variants (every moving obstacle's phase jittered by
:func:`optplan.generators.jitter_phases`; seed 0 is the scene as written).  The leader's
reference is planned by ``--path-solver`` (default ``visgraph``: the certified shortest path, so
the comparison isolates the formation controllers from global-planner randomness).

Printed (markdown): per scene and solver, the success rate, median formation RMSE, worst
formation error and final formation error (map units, against the L-phi slots), min
inter-robot separation (and the scene's safety distance), min clearance to static and to moving
obstacles, total collisions, median time to goal, QP failures and median wall time.

Usage::

    optplan bench --tag formation [--seeds 5] [--path-solver visgraph] [--scenes a,b]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

import optplan as op
from optplan.generators import jitter_phases

__all__ = ["main", "run_comparison", "format_table"]

SCENES = ("paper-formation", "paper-warehouse")
SOLVERS = ("leader-follower-paper", "formation-qp")


def run_comparison(scenes: Sequence[str] = SCENES, solvers: Sequence[str] = SOLVERS,
                   seeds: int = 5, path_solver: str = "visgraph") -> list[dict[str, Any]]:
    """One row per (scene, solver, seed)."""
    rows = []
    for scene in scenes:
        base = op.load_problem(scene)
        if base.formation is None:
            raise ValueError(f"{scene}: not a formation scene")
        safety = base.formation.safety_distance
        for seed in range(seeds):
            prob = base if seed == 0 else jitter_phases(base, np.random.default_rng(seed))
            for solver in solvers:
                t0 = time.perf_counter()
                res = op.solve(prob, solver, rng=seed, path_solver=path_solver)
                m = res.metrics
                rows.append({
                    "scene": scene, "solver": solver, "seed": seed,
                    "success": bool(res.success), "status": res.status.value,
                    "rmse": m.get("formation_rmse", np.nan),
                    "max_err": m.get("formation_max_error", np.nan),
                    "final_err": m.get("formation_final_error", np.nan),
                    "min_sep": m.get("min_separation", np.nan),
                    "safety": safety,
                    "clear": m.get("min_clearance", np.nan),
                    "clear_dyn": m.get("min_clearance_dynamic", np.nan),
                    "collisions": int(m.get("collisions", 0)),
                    "time": res.extras.get("time_to_goal", np.nan) if res.success else np.nan,
                    "qp_failures": res.extras.get("qp_failures", 0),
                    "wall": time.perf_counter() - t0, "message": res.message,
                })
    return rows


def _med(v: list[float]) -> float:
    a = np.asarray(v, float)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if len(a) else float("nan")


def _error_cells(g: list[dict[str, Any]]) -> str:
    """Success count and the median formation errors (RMSE, worst, final) of one group (the rows
    ``g`` of one scene and solver). Returns the four cells, joined by ``" | "``."""
    n_ok = sum(r["success"] for r in g)
    return (f"{n_ok}/{len(g)} | {_med([r['rmse'] for r in g]):.2f} | "
            f"{_med([r['max_err'] for r in g]):.1f} | {_med([r['final_err'] for r in g]):.2g}")


def _safety_cells(g: list[dict[str, Any]]) -> str:
    """Worst separation (with the safety distance), clearances and total collisions. Returns the
    three cells, joined by ``" | "``."""
    return (f"{min(r['min_sep'] for r in g):.2f} ({g[0]['safety']:g}) | "
            f"{min(r['clear'] for r in g):.2f} / {min(r['clear_dyn'] for r in g):.1f} | "
            f"{sum(r['collisions'] for r in g)}")


def _run_cells(g: list[dict[str, Any]]) -> str:
    """Median time to goal, total QP failures and median wall time of one group. Returns the three
    cells, joined by ``" | "``."""
    return (f"{_med([r['time'] for r in g]):.1f} | {sum(r['qp_failures'] for r in g)} | "
            f"{_med([r['wall'] for r in g]):.1f}")


def format_table(rows: list[dict[str, Any]]) -> str:
    """Markdown summary: one line per (scene, solver)."""
    out = ["| scene | solver | success | formation RMSE | worst error | final error (median) "
           "| min separation (D_s) | min clearance static / moving | collisions | time to goal s "
           "| QP failures | wall s |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for scene, solver in dict.fromkeys((r["scene"], r["solver"]) for r in rows):
        g = [r for r in rows if r["scene"] == scene and r["solver"] == solver]
        out.append(f"| {scene} | {solver} | {_error_cells(g)} | {_safety_cells(g)} | "
                   f"{_run_cells(g)} |")
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="optplan bench --tag formation",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="variants per scene (default 5)")
    ap.add_argument("--path-solver", default="visgraph",
                    help="planner of the leader's reference (default visgraph)")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--solvers", default=",".join(SOLVERS))
    ap.add_argument("--verbose", action="store_true", help="also print every run")
    a = ap.parse_args(list(argv) if argv is not None else None)
    rows = run_comparison(a.scenes.split(","), a.solvers.split(","), a.seeds, a.path_solver)
    print(f"formation comparison: {a.seeds} seeded variant(s) per scene (moving obstacles' "
          f"phases jittered), leader reference by {a.path_solver}\n")
    print(format_table(rows))
    if a.verbose:
        print()
        for r in rows:
            print(f"{r['scene']} {r['solver']} seed {r['seed']}: {r['status']} - {r['message']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
