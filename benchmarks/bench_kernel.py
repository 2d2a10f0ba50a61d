"""Speed of the exact disc-robot kernel ``ObstacleSet.crossings`` (the one implementation:
compiled with numba in ``optplan.geometry.collision.kernel``).

1. Per-call time on ``paper-env1``: the fitness batches of one ``ipso-paper`` run (50-70
   paths x 7 segments, replayed) and one random 70-path x 7-segment batch, count only (what
   ``ipso-paper`` asks for) and with penetration; and the call overhead: the same batches
   through the public ``ObstacleSet.crossings`` and straight into the compiled loop
   ``kernel.crossings`` with the local segment arrays prepared once, and a one-segment call
   (the dispatch floor of the compiled function).
2. Per-call time on random maps of 10 / 100 / 1000 obstacles (rectangles, circles, triangles,
   hexagons, concave U shapes; size ~ 1/sqrt(N) in a 500 x 500 map so the covered fraction is
   constant): it must grow sub-linearly with N (grid pre-filter from 48 items on).
3. One full ``op.solve('paper-env1', 'ipso-paper', rng=s)`` (median over seeds) and the
   kernel's share of it.

Run: ``.venv/bin/python benchmarks/bench_kernel.py [--seeds 15]``.  Prints markdown tables with
medians; the machine is shared, so take the numbers as indicative.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import optplan as op
from optplan.generators import random_obstacles as _random_obstacles
from optplan.geometry import Frame, ObstacleSet, obstacle_set
from optplan.geometry.collision import kernel
from optplan.problem import Obstacle
from optplan.swarm.core import make_space


def per_call(obs: ObstacleSet, batches: list[np.ndarray], penetration: bool,
             repeats: int = 7, min_time: float = 0.05) -> float:
    """Median seconds per call over ``repeats`` timed passes over ``batches``."""
    for b in batches[:3]:
        obs.crossings(b, penetration=penetration)  # warm up
    loops = 1
    while True:  # enough passes that one timing lasts min_time
        t = time.perf_counter()
        for _ in range(loops):
            for b in batches:
                obs.crossings(b, penetration=penetration)
        if time.perf_counter() - t > min_time or loops > 1000:
            break
        loops *= 2
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(loops):
            for b in batches:
                obs.crossings(b, penetration=penetration)
        ts.append((time.perf_counter() - t) / (loops * len(batches)))
    return float(np.median(ts))


def ipso_batches(prob: op.Problem, seed: int = 0) -> list[np.ndarray]:
    """The path batches one ``ipso-paper`` run's fitness scores (recorded by wrapping
    crossings; calls on other obstacle sets, e.g. the validator's, are not recorded)."""
    view = prob.known_view()  # what the swarm planners score on
    fitness = make_space(view, view.robots[0], 1).obstacles
    real = ObstacleSet.crossings
    rec: list[np.ndarray] = []

    def spy(self, paths, *a, **k):
        if self is fitness:
            rec.append(np.array(paths))
        return real(self, paths, *a, **k)

    ObstacleSet.crossings = spy
    try:
        op.solve(prob, "ipso-paper", rng=seed)
    finally:
        ObstacleSet.crossings = real
    return rec


def overhead(obs: ObstacleSet, batches: list[np.ndarray], repeats: int = 7
             ) -> tuple[float, float, float]:
    """Median seconds per call: through ``ObstacleSet.crossings``, straight into the compiled
    loop with prepared local segments, and a one-segment compiled call."""
    prep = [obs._segments(b) for b in batches]
    arrays = obs.arrays
    grid = obs._grid_args()
    hits = np.empty((0, 2), np.int64)

    def direct(items):
        for A, D, _, S in items:
            kernel.crossings(A, D, S, arrays, obs.n_obstacles, grid, obs.radius, obs.eps,
                             False, hits)

    def wrapped(items):
        for b in items:
            obs.crossings(b, penetration=False)

    one = [(p[0][:1].copy(), p[1][:1].copy(), 1, 1) for p in prep]
    out = []
    for fn, items in ((wrapped, batches), (direct, prep), (direct, one)):
        fn(items[:3])
        ts = []
        for _ in range(repeats):
            t = time.perf_counter()
            for _ in range(5):
                fn(items)
            ts.append((time.perf_counter() - t) / (5 * len(items)))
        out.append(float(np.median(ts)))
    return out[0], out[1], out[2]


def random_batch(rng: np.random.Generator, start, goal, n_paths: int = 70,
                 n_way: int = 6, side: float = 500.0, walk: float | None = None) -> np.ndarray:
    """Paths start -> ``n_way`` waypoints -> goal: uniform waypoints, or a random walk."""
    paths = np.empty((n_paths, n_way + 2, 2))
    paths[:, 0], paths[:, -1] = start, goal
    if walk is None:
        paths[:, 1:-1] = rng.uniform(0, side, (n_paths, n_way, 2))
    else:  # waypoints spread along the start-goal line plus noise (an IPSO-like swarm)
        s = np.linspace(0, 1, n_way + 2)[1:-1]
        line = np.asarray(start) + s[:, None] * (np.asarray(goal) - np.asarray(start))
        paths[:, 1:-1] = line + rng.normal(0, walk, (n_paths, n_way, 2))
    return paths


def random_obstacles(n: int, seed: int = 0, side: float = 500.0) -> list[Obstacle]:
    """Seeded random obstacles keeping the corners (5, 5) and (side - 5, side - 5) free."""
    return _random_obstacles(n, seed, side, keep_free=((5.0, 5.0), (side - 5.0, side - 5.0)))


def solve_times(seeds: int) -> tuple[float, float]:
    """Median wall time of one ipso-paper run on paper-env1, and the median time spent in the
    fitness kernel during it."""
    prob = op.load_problem("paper-env1")
    view = prob.known_view()  # what the swarm planners score on
    fitness = make_space(view, view.robots[0], 1).obstacles
    op.solve(prob, "ipso-paper", rng=0)  # warm caches (obstacle set, inflation)
    real = ObstacleSet.crossings
    acc = [0.0]

    def timed(self, *a, **k):
        t = time.perf_counter()
        out = real(self, *a, **k)
        if self is fitness:
            acc[0] += time.perf_counter() - t
        return out

    tot, ker = [], []
    ObstacleSet.crossings = timed
    try:
        for s in range(seeds):
            acc[0] = 0.0
            t = time.perf_counter()
            op.solve(prob, "ipso-paper", rng=s)
            tot.append(time.perf_counter() - t)
            ker.append(acc[0])
    finally:
        ObstacleSet.crossings = real
    return float(np.median(tot)), float(np.median(ker))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=15)
    args = ap.parse_args(argv)
    print(f"machine: {os.cpu_count()} cores (shared), {platform.processor() or platform.machine()}"
          f", Python {platform.python_version()}, numpy {np.__version__}")
    print()
    prob = op.load_problem("paper-env1")
    robot = prob.robots[0]
    obs = make_space(prob, robot, 6).obstacles
    rng = np.random.default_rng(0)
    rec = ipso_batches(prob)
    sizes = sorted({len(b) for b in rec})
    workloads = [
        (f"paper-env1, the {len(rec)} batches of one ipso-paper run ({sizes[0]}-{sizes[-1]} "
         "paths x 7 segments)", rec),
        ("paper-env1, random 70 paths x 7 segments (uniform waypoints)",
         [random_batch(rng, robot.start, robot.goal) for _ in range(20)]),
    ]
    screen = "all-pairs screen" if obs.grid is None else "grid screen"
    print(f"### Per call on paper-env1 ({len(prob.obstacles)} obstacles, {screen})")
    print()
    print("| workload | penetration | us/call |")
    print("|---|---|---|")
    for label, batches in workloads:
        for pen in (False, True):
            t = per_call(obs, batches, pen)
            print(f"| {label} | {'yes' if pen else 'no'} | {t * 1e6:.0f} |")
    print()
    w, d, one = overhead(obs, rec)
    print(f"### Call overhead on paper-env1 (the {len(rec)} batches of one ipso-paper run, "
          "count only)")
    print()
    print("| call | us/call |")
    print("|---|---|")
    print(f"| `ObstacleSet.crossings` (world paths in, result object out) | {w * 1e6:.1f} |")
    print(f"| `kernel.crossings` with the local segment arrays prepared once | {d * 1e6:.1f} |")
    print(f"| `kernel.crossings` on one segment (dispatch floor) | {one * 1e6:.1f} |")
    print()
    print(f"The wrapper adds {(w - d) * 1e6:.1f} us per call ({(w - d) / w:.0%} of a fitness "
          f"call; {(w - d) * len(rec) * 1e3:.1f} ms per ipso-paper run).")
    print()
    print("### Per call on random maps (70 paths x 7 segments, count only)")
    print()
    print("| obstacles (placed) | items (pieces + circles) | screen | paths "
          "| us/call | x vs 10 |")
    print("|---|---|---|---|---|---|")
    base: dict[str, float] = {}
    frame = Frame.from_bounds((0.0, 0.0, 500.0, 500.0))
    for n in (10, 100, 1000):
        obstacles = random_obstacles(n)
        rs = obstacle_set(obstacles, 1.0, frame)
        grid = "all pairs" if rs.grid is None else f"grid {rs.grid['nx']} x {rs.grid['ny']}"
        for kind, walk in (("uniform", None), ("near the line", 40.0)):
            r2 = np.random.default_rng(n)
            batches = [random_batch(r2, (5.0, 5.0), (495.0, 495.0), walk=walk)
                       for _ in range(10)]
            t = per_call(rs, batches, False)
            base.setdefault(kind, t)
            print(f"| {n} ({len(obstacles)}) | {rs.n_items} | {grid} | {kind} | "
                  f"{t * 1e6:.0f} | {t / base[kind]:.1f} |")
    print()
    print(f"### One ipso-paper run on paper-env1 (median of {args.seeds} seeds)")
    print()
    tot, ker = solve_times(args.seeds)
    print("| median ms per run | of which fitness kernel (ms) |")
    print("|---|---|")
    print(f"| {tot * 1e3:.1f} | {ker * 1e3:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
