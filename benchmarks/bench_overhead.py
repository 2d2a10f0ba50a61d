"""What ``optplan.solve`` adds to a backend, the cost of the optional reference, time limits.

1. A 300-obstacle map (``optplan.generators.random_obstacles(300)`` in 500 x 500): ``ipso``
   through ``op.solve`` against the backend's own ``solve`` on the same problem (both on a fresh
   problem, so both build the obstacle set), then ``op.solve(..., reference=True)``, whose
   ``metrics["reference_time"]`` is the certified optimum's own cost (not part of
   ``wall_time``).  Medians over seeds.  ``Result.wall_time`` is printed against the measured
   ``op.solve`` time (target: ratio >= 0.95, i.e. it is what the caller waited for), and
   ``wall_time + reference_time`` against the measured ``op.solve(reference=True)``.
2. ``time_limit=0.2`` on ``ipso`` with ``k_max = 10**6``, ``nlp-ipopt``, ``sa-apf-paper`` and
   ``hybrid-paper``: wall time until ``solve`` returns (target <= 0.3 s) and ``stop_reason``.

Run: ``python benchmarks/bench_overhead.py [--seeds 5]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import optplan as op
from optplan.generators import random_obstacles
from optplan.solver import get_solver, make_rng


def big_map(n: int = 300) -> op.Problem:
    base = op.parse_problem({
        "name": f"random-{n}", "bounds": [0.0, 0.0, 500.0, 500.0],
        "robots": [{"id": "r1", "start": [10.0, 10.0], "goal": [490.0, 490.0], "radius": 1.0,
                    "max_speed": 5.0}]})
    obs = tuple(random_obstacles(n, seed=1, keep_free=((10.0, 10.0), (490.0, 490.0))))
    return dataclasses.replace(base, obstacles=obs, _cache={})


def fresh(p: op.Problem) -> op.Problem:
    return dataclasses.replace(p, _cache={})


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args(argv)
    prob = big_map()
    op.solve(fresh(prob), "ipso", rng=0)  # warm-up: imports and compiled kernels
    backend = get_solver("ipso")
    t_back, t_solve, t_ref, ref_cost, w_solve, w_ref = [], [], [], [], [], []
    for seed in range(args.seeds):
        p = fresh(prob)
        gen, _ = make_rng(seed)
        t0 = time.perf_counter()
        backend.solve(p, rng=gen, init=None, callback=None)
        t_back.append(time.perf_counter() - t0)
        q = fresh(prob)
        t0 = time.perf_counter()
        res = op.solve(q, "ipso", rng=seed)
        t_solve.append(time.perf_counter() - t0)
        w_solve.append(res.wall_time)
        q = fresh(prob)
        t0 = time.perf_counter()
        res = op.solve(q, "ipso", rng=seed, reference=True)
        t_ref.append(time.perf_counter() - t0)
        ref_cost.append(res.metrics["reference_time"])
        w_ref.append(res.wall_time + res.metrics["reference_time"])
    med = statistics.median
    print(f"## op.solve overhead, ipso on a {len(prob.obstacles)}-obstacle map "
          f"(median of {args.seeds} seeds)")
    print()
    print("| what | median s |")
    print("|---|---|")
    print(f"| backend.solve (grading included) | {med(t_back):.3f} |")
    print(f"| op.solve (no reference) | {med(t_solve):.3f} |")
    print(f"| op.solve(reference=True) | {med(t_ref):.3f} |")
    print(f"| of which metrics['reference_time'] | {med(ref_cost):.3f} |")
    print(f"| Result.wall_time of op.solve (no reference) | {med(w_solve):.3f} |")
    print(f"| wall_time + reference_time of op.solve(reference=True) | {med(w_ref):.3f} |")
    print()
    ratio = med(t_solve) / med(t_back)
    verdict = "met" if ratio <= 1.1 else "NOT met"
    print(f"op.solve / backend = {ratio:.3f} (target <= 1.1: {verdict})")
    worst = min(w / t for w, t in zip(w_solve, t_solve))
    wr = med(w_solve) / med(t_solve)
    verdict = "met" if worst >= 0.95 else "NOT met"
    print(f"wall_time / measured op.solve = {wr:.3f} (median), {worst:.3f} (worst seed) "
          f"(target >= 0.95: {verdict})")
    wr = med(w_ref) / med(t_ref)
    print(f"(wall_time + reference_time) / measured op.solve(reference=True) = {wr:.3f}")
    print()
    print("## time_limit = 0.2 s (one warm-up run each, then 3 runs; worst wall time)")
    print()
    print("| solver | problem | worst s | stop_reason | status |")
    print("|---|---|---|---|---|")
    cases = [("ipso", "paper-env1", {"k_max": 10**6}), ("nlp-ipopt", "paper-warehouse", {}),
             ("sa-apf-paper", "paper-hybrid", {}), ("hybrid-paper", "paper-warehouse", {})]
    for solver, name, over in cases:
        p = op.load_problem(name)
        op.solve(p, solver, rng=0, time_limit=0.2, **over)
        times, res = [], None
        for seed in range(3):
            t0 = time.perf_counter()
            res = op.solve(p, solver, rng=seed, time_limit=0.2, **over)
            times.append(time.perf_counter() - t0)
        print(f"| {solver} | {name} | {max(times):.3f} | {res.stop_reason or '-'} "
              f"| {res.status.value} |")
    print()
    print("target: every run returns within 0.3 s with stop_reason = time_limit "
          "(a run that finishes sooner shows '-')")



if __name__ == "__main__":
    main()
