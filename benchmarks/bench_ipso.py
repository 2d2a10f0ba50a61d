"""Speed of the swarm planners: one ``ipso-paper`` run (50 particles x 200 iterations).

1. Wall time per run on ``paper-env1`` (target <= 40 ms median on the 2-core dev machine) of
   the one implementation (numpy: the vectorised fitness kernel ``ObstacleSet.crossings`` and
   the numpy IPSO step); the documented ``ipso`` variant for comparison.
2. Where the time of one ``ipso-paper`` run goes: the fitness kernel vs the rest of the loop.
3. Scaling of one run's time with the number of obstacles (10 / 100 / 1000 random squares and
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
from optplan.backends.swarm import make_space
from optplan.geometry import ObstacleSet

#: Target of the median ipso-paper run on paper-env1 (seconds).
TARGET = 0.040


def _time_runs(prob, solver, runs: int, **over) -> tuple[float, float]:
    ts, ok = [], 0
    op.solve(prob, solver, rng=0, **over)  # warm caches (inflation, obstacle set)
    for s in range(runs):
        t = time.perf_counter()
        r = op.solve(prob, solver, rng=s, **over)
        ts.append(time.perf_counter() - t)
        ok += r.success
    return float(np.median(ts)), ok / runs


def _kernel_share(prob, solver: str, runs: int, **over) -> tuple[float, float, int]:
    """Median run time, median time inside the fitness kernel's ``crossings`` (one run), and
    its number of calls (calls on other obstacle sets, e.g. the validator's, not counted)."""
    view = prob.known_view()  # what the swarm planners score on
    fitness = make_space(view, view.robots[0], 1).obstacles
    real = ObstacleSet.crossings
    acc = [0.0, 0]

    def timed(self, *a, **k):
        t = time.perf_counter()
        out = real(self, *a, **k)
        if self is fitness:
            acc[0] += time.perf_counter() - t
            acc[1] += 1
        return out

    ObstacleSet.crossings = timed
    try:
        tot, ker = [], []
        for s in range(runs):
            acc[0], acc[1] = 0.0, 0
            t = time.perf_counter()
            op.solve(prob, solver, rng=s, **over)
            tot.append(time.perf_counter() - t)
            ker.append(acc[0])
    finally:
        ObstacleSet.crossings = real
    return float(np.median(tot)), float(np.median(ker)), acc[1]


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
    print("### One run on paper-env1 (numpy implementation)")
    print()
    print("| solver | fitness kernel | runs (seeds) | median wall time per run (ms) | success |")
    print("|---|---|---|---|---|")
    median = {}
    for solver, runs in (("ipso-paper", args.runs), ("ipso", max(3, args.runs // 3))):
        median[solver], ok = _time_runs(prob, solver, runs)
        print(f"| {solver} | `ObstacleSet.crossings` (exact disc) | {runs} "
              f"| {median[solver] * 1e3:.1f} | {ok:.0%} |")
    t = median["ipso-paper"]
    print()
    print(f"ipso-paper: median {t * 1e3:.1f} ms per run; the <= {TARGET * 1e3:.0f} ms target is "
          f"{'met' if t <= TARGET else 'NOT met'}.")
    print()
    print("### Where the time of one ipso-paper run on paper-env1 goes")
    print()
    print("| part | median ms per run | per iteration (us) |")
    print("|---|---|---|")
    tot, ker, calls = _kernel_share(prob, "ipso-paper", args.runs)
    print(f"| fitness kernel (`ObstacleSet.crossings`, {calls} calls) | "
          f"{ker * 1e3:.1f} | {ker / 200 * 1e6:.0f} |")
    print(f"| everything else (IPSO step, GA, bookkeeping, validator) | "
          f"{(tot - ker) * 1e3:.1f} | {(tot - ker) / 200 * 1e6:.0f} |")
    print(f"| total | {tot * 1e3:.1f} | {tot / 200 * 1e6:.0f} |")
    print()
    print("### Scaling with the number of obstacles (ipso-paper, one run)")
    print()
    print("| obstacles (placed) | kernel items (convex pieces + circles) | grid "
          "| median ms per run | x vs 10 |")
    print("|---|---|---|---|---|")
    base = None
    for n in (10, 100, 1000):
        p = random_map(n)
        obs = make_space(p, p.robots[0], 1).obstacles
        t, _ = _time_runs(p, "ipso-paper", max(3, args.runs // 3))
        base = base or t
        grid = "-" if obs.grid is None else f"{obs.grid['nx']} x {obs.grid['ny']}"
        print(f"| {n} ({len(p.obstacles)}) | {obs.n_items} | {grid} | "
              f"{t * 1e3:.1f} | {t / base:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
