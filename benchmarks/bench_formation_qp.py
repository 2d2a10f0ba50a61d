"""Per-step wall time of the formation QP (data assembly + parameter update + Clarabel solve).

Runs ``formation-qp`` on generated grid formations of 3, 30 and 100 robots and prints the median
time per control step (the first step, which builds the problem, is excluded and reported
separately).  Targets (issue 6): <= 1 ms, <= 5 ms, <= 40 ms median.

    .venv/bin/python benchmarks/bench_formation_qp.py [--steps 80] [--interfaces direct,cvxpy]
"""

from __future__ import annotations

import argparse
import os
import platform

import numpy as np

import optplan as op
from optplan.generators import formation_scene

TARGET_MS = {3: 1.0, 30: 5.0, 100: 40.0}


def run(n: int, interface: str, steps: int) -> dict:
    prob = formation_scene(n, "grid", spacing=12.0, obstacles=max(2, n // 10), seed=n)
    solver = op.get_solver("formation-qp", path_solver="visgraph", qp_interface=interface,
                           max_steps=steps, neighbor_radius=20.0)
    res = solver.solve(prob, rng=np.random.default_rng(0))
    h = res.history
    t = np.asarray(h["qp_time"]) * 1e3
    return {"n": n, "interface": interface, "build_ms": float(t[0]),
            "median_ms": float(np.median(t[1:])), "p90_ms": float(np.percentile(t[1:], 90)),
            "pairs": int(np.nanmax(h["qp_pairs"])), "failures": int(res.metrics["qp_failures"]),
            "min_sep_ok": bool(res.metrics.get("min_separation", np.inf)
                               >= prob.formation.safety_distance - 1e-6)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=80)
    ap.add_argument("--sizes", default="3,30,100")
    ap.add_argument("--interfaces", default="direct,cvxpy")
    a = ap.parse_args(argv)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores (shared, loaded); "
          f"python {platform.python_version()}; {a.steps} steps per run\n")
    print("| robots | interface | median ms/step | p90 ms | target ms | build ms | active "
          "pair rows | QP failures | min sep >= D_s |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---|")
    for n in [int(x) for x in a.sizes.split(",")]:
        for itf in a.interfaces.split(","):
            r = run(n, itf, a.steps)
            print(f"| {n} | {itf} | {r['median_ms']:.2f} | {r['p90_ms']:.2f} | "
                  f"{TARGET_MS.get(n, float('nan')):g} | {r['build_ms']:.0f} | {r['pairs']} | "
                  f"{r['failures']} | {r['min_sep_ok']} |")


if __name__ == "__main__":
    main()
