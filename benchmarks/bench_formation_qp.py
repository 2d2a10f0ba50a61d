"""Per-step wall time of the formation QP (the cvxpy DPP model solved by Clarabel).

Runs ``formation-qp`` on generated grid formations of 3, 30 and 100 robots (spacing 12,
neighbour radius 20, a few random discs) and prints, per size, the median and 90th percentile
over the control steps of

* the *solve path*: setting the Parameter vector and cvxpy's re-solve (``get_problem_data`` on
  the cached DPP model, Clarabel updated in place and solved, ``unpack_results``), history
  column ``qp_solve_time``;
* the *whole step*: sensing, the row builders, the solve path and the post-processing,
  history column ``qp_time``.

The first step builds and compiles the model and is excluded (reported as "build").  Targets
(issue 18): 0.5 / 1.5 / 4 ms per step at 3 / 30 / 100 robots.  With ``--repeat k`` each size is
run ``k`` times and the medians of the per-run medians are printed (the machine is shared).

    .venv/bin/python benchmarks/bench_formation_qp.py [--steps 80] [--sizes 3,30,100] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import platform

import numpy as np

import optplan as op
from optplan.generators import formation_scene

TARGET_MS = {3: 0.5, 30: 1.5, 100: 4.0}


def run(n: int, steps: int) -> dict:
    prob = formation_scene(n, "grid", spacing=12.0, obstacles=max(2, n // 10), seed=n)
    solver = op.get_solver("formation-qp", path_solver="visgraph", max_steps=steps,
                           neighbor_radius=20.0)
    res = solver.solve(prob, rng=np.random.default_rng(0))
    h, ex = res.history, res.extras
    step = np.asarray(h["qp_time"]) * 1e3
    solve = np.asarray(h["qp_solve_time"]) * 1e3
    return {"n": n, "build_ms": float(step[0]),
            "solve_ms": float(np.median(solve[1:])),
            "solve_p90": float(np.percentile(solve[1:], 90)),
            "step_ms": float(np.median(step[1:])),
            "step_p90": float(np.percentile(step[1:], 90)),
            "pairs": int(np.nanmax(h["qp_pairs"])), "failures": int(ex["qp_failures"]),
            "slack_steps": int(ex["slack_steps"]), "rebuilds": int(ex["rebuilds"]),
            "min_sep_ok": bool(res.metrics.get("min_separation", np.inf)
                               >= prob.formation.safety_distance - 1e-6)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=80)
    ap.add_argument("--sizes", default="3,30,100")
    ap.add_argument("--repeat", type=int, default=1)
    a = ap.parse_args(argv)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores (shared; load average {load}); "
          f"python {platform.python_version()}; {a.steps} steps per run, {a.repeat} run(s) "
          "per size\n")
    print("| robots | solve path median ms | p90 ms | whole step median ms | p90 ms | target ms "
          "| build ms | active pair rows | rebuilds | slack steps | QP failures | "
          "min sep >= D_s |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for n in [int(x) for x in a.sizes.split(",")]:
        runs = [run(n, a.steps) for _ in range(a.repeat)]
        r = {k: (float(np.median([x[k] for x in runs])) if isinstance(runs[0][k], float)
                 else runs[-1][k]) for k in runs[0]}
        print(f"| {n} | {r['solve_ms']:.2f} | {r['solve_p90']:.2f} | {r['step_ms']:.2f} | "
              f"{r['step_p90']:.2f} | {TARGET_MS.get(n, float('nan')):g} | {r['build_ms']:.0f} | "
              f"{r['pairs']} | {r['rebuilds']} | {r['slack_steps']} | {r['failures']} | "
              f"{r['min_sep_ok']} |")


if __name__ == "__main__":
    main()
