"""Speed of the swarm planners: one ``ipso-paper`` run (50 particles x 200 iterations).

1. Wall time per run on ``paper-env1`` (target <= 40 ms median on the 2-core dev machine),
   with the fast crossing kernel (default), the reference ``geometry.batch_crossings`` kernel,
   and the coarse planning map (``map_quad_segs = 2``).
2. Scaling of one run's time with the number of obstacles (10 / 100 / 1000 random squares and
   discs in a 500 x 500 map, obstacle size ~ 1/sqrt(N) so that the covered fraction is
   constant): it must grow sub-linearly.

Run: ``.venv/bin/python benchmarks/bench_ipso.py [--runs 15]``.  Prints markdown tables with
medians; the machine is shared, so take the numbers as indicative.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import optplan as op


def _time_runs(prob, solver, runs: int, **over) -> tuple[float, float]:
    ts, ok = [], 0
    op.solve(prob, solver, rng=0, **over)  # warm caches (inflation, kernel layout)
    for s in range(runs):
        t = time.perf_counter()
        r = op.solve(prob, solver, rng=s, **over)
        ts.append(time.perf_counter() - t)
        ok += r.success
    return float(np.median(ts)), ok / runs


def random_map(n: int, seed: int = 0) -> op.Problem:
    rng = np.random.default_rng(seed)
    size = 500.0 * 0.3 / np.sqrt(n)
    obs = []
    for i in range(n):
        c = rng.uniform(30, 470, 2)
        if np.hypot(*(c - 10)) < 3 * size or np.hypot(*(c - 490)) < 3 * size:
            continue
        if i % 2:
            obs.append({"type": "circle", "center": c.tolist(), "radius": size / 2})
        else:
            obs.append({"type": "rectangle", "center": c.tolist(), "size": [size, size]})
    return op.parse_problem({
        "name": f"random-{n}", "bounds": [0.0, 0.0, 500.0, 500.0],
        "robots": [{"id": "r", "start": [10.0, 10.0], "goal": [490.0, 490.0], "radius": 1.0,
                    "max_speed": 1.0}],
        "obstacles": obs,
    })


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    args = ap.parse_args(argv)
    print(f"machine: {os.cpu_count()} cores (shared), {platform.processor() or platform.machine()}"
          f", Python {platform.python_version()}, numpy {np.__version__}")
    print()
    prob = op.load_problem("paper-env1")
    print("### One run of ipso-paper (50 x 200) on paper-env1")
    print()
    print("| variant | median wall time per run (ms) | success |")
    print("|---|---|---|")
    for label, over in [("fast kernel (default)", {}),
                        ("fast kernel, coarse map (map_quad_segs = 2)", {"map_quad_segs": 2}),
                        ("geometry.batch_crossings kernel", {"kernel": "geometry"})]:
        runs = args.runs if "geometry" not in label else max(3, args.runs // 3)
        t, ok = _time_runs(prob, "ipso-paper", runs, **over)
        print(f"| {label} | {t * 1e3:.0f} | {ok:.0%} |")
    print()
    print("### Scaling with the number of obstacles (ipso-paper, one run)")
    print()
    print("| obstacles | inflated parts | boundary edges | median ms per run | x vs 10 |")
    print("|---|---|---|---|---|")
    base = None
    for n in (10, 100, 1000):
        p = random_map(n)
        imap = p.inflated(1.0)
        t, _ = _time_runs(p, "ipso-paper", max(3, args.runs // 3))
        base = base or t
        print(f"| {n} | {imap.n} | {int(imap.edge_mask.sum())} | {t * 1e3:.0f} | "
              f"{t / base:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
