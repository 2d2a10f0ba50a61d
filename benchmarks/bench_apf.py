"""Speed of the local planners (issue 5).

1. A full ``sa-apf-paper`` run on ``paper-apf-env1`` (simulation + validator): median wall time,
   target <= 100 ms.
2. Per-step controller cost vs the number of obstacles *outside* the sensing range: the
   geometry core's bounding-circle screen (behind ``ObstacleField.nearest``) should keep it flat.
3. One ``ObstacleField.nearest`` call (one point, the sensing range 22): the small query the
   controllers and the contact check make several times per step.

Run: ``.venv/bin/python benchmarks/bench_apf.py [--repeat N]``.  Prints markdown tables.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time

import numpy as np
import shapely

import optplan as op
from optplan.problem import Obstacle
from optplan.sim import ObstacleField, SimState


def full_run(repeat: int) -> list[float]:
    prob = op.load_problem("paper-apf-env1")
    op.solve(prob, "sa-apf-paper", rng=0)  # warm-up (imports, visgraph reference cached)
    ts = []
    for k in range(repeat):
        t0 = time.perf_counter()
        res = op.solve(prob, "sa-apf-paper", rng=k)
        ts.append(time.perf_counter() - t0)
        if not res.success:
            raise RuntimeError(f"sa-apf-paper failed on paper-apf-env1 (seed {k}): {res.message}")
    return ts


def with_far_obstacles(n_far: int) -> op.Problem:
    """trap-gnron widened by 400 units, with ``n_far`` small squares there (outside sensing)."""
    base = op.load_problem("trap-gnron")
    x0, y0, x1, y1 = base.bounds
    big = dataclasses.replace(base, bounds=(x0, y0, x1 + 400.0, y1), _cache={}, path=None)
    obs = list(big.obstacles)
    rng = np.random.default_rng(0)
    for i in range(n_far):
        c = np.array([x1 + 60.0 + rng.uniform(0, 320), rng.uniform(5, y1 - 5)])
        obs.append(Obstacle("rectangle", shapely.box(*(c - 1.5), *(c + 1.5)), True, f"far{i}"))
    return dataclasses.replace(big, obstacles=tuple(obs), _cache={})


def per_step(n_far: int, steps: int = 300) -> float:
    prob = with_far_obstacles(n_far)
    solver = op.get_solver("sa-apf-paper")
    ctrl = solver.controller(prob, "r1", np.random.default_rng(0))
    fld = ObstacleField(prob)
    r = prob.robots[0]
    xs = np.linspace(r.start, r.goal - [10, 0], steps)
    st = SimState(0, 0.0, ["r1"], xs[:1].copy(), np.zeros((1, 2)), fld, dt=solver.dt)
    t0 = time.perf_counter()
    for k in range(steps):
        st.k, st.t, st.positions = k, 0.2 * k, xs[k:k + 1]
        ctrl.velocity(st, 0)
        fld.nearest(st.positions, st.t, max_range=r.radius + 1.0)  # the simulator's contact check
    return (time.perf_counter() - t0) / steps


def per_query(name: str, n: int = 2000) -> float:
    prob = op.load_problem(name)
    fld = ObstacleField(prob)
    x = np.asarray(prob.robots[0].start, float)[None] + [30.0, 3.0]
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(n):
            fld.nearest(x, 1.0, max_range=22.0)
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=15)
    a = ap.parse_args()
    print(f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
          "(shared with other jobs; medians)\n")
    ts = full_run(a.repeat)
    print("| benchmark | median | min | max | target |")
    print("|---|---|---|---|---|")
    print(f"| full sa-apf-paper run on paper-apf-env1 ({a.repeat} runs) | "
          f"{1e3 * np.median(ts):.1f} ms | {1e3 * min(ts):.1f} ms | {1e3 * max(ts):.1f} ms | "
          "<= 100 ms |")
    print("\n| obstacles outside the sensing range | per-step cost (controller + contact check) |")
    print("|---|---|")
    base = None
    for n in (0, 10, 100, 1000):
        v = float(np.median([per_step(n) for _ in range(3)]))
        base = base or v
        print(f"| {n} | {1e6 * v:.0f} us ({v / base:.2f}x) |")
    print("\n| map | one `ObstacleField.nearest` call (1 point, range 22; best of 5) |")
    print("|---|---|")
    for name in ("paper-apf-env1", "paper-hybrid", "trap-gnron"):
        print(f"| {name} | {1e6 * per_query(name):.1f} us |")


if __name__ == "__main__":
    main()
