"""Speed of the exact disc-robot kernel ``ObstacleSet.crossings``: numpy vs compiled (numba).

1. Per-call time on ``paper-env1``: the fitness batches of one ``ipso-paper`` run (50-70
   paths x 7 segments, replayed) and one random 70-path x 7-segment batch, count only (what
   ``ipso-paper`` asks for) and with penetration.
2. Per-call time on random maps of 10 / 100 / 1000 obstacles (rectangles, circles, triangles,
   hexagons, concave U shapes; size ~ 1/sqrt(N) in a 500 x 500 map so the covered fraction is
   constant): it must grow sub-linearly with N (grid pre-filter from 48 items on).
3. One full ``op.solve('paper-env1', 'ipso-paper', rng=s)`` (median over seeds) with
   ``OPTPLAN_ENGINE`` unset (auto: numba) and ``OPTPLAN_ENGINE=numpy``.
4. Compile time of the first compiled call in a fresh process: cold (empty numba cache) and
   with the on-disk cache warm.

Run: ``.venv/bin/python benchmarks/bench_kernel.py [--seeds 15]``.  Prints markdown tables with
medians; the machine is shared, so take the numbers as indicative.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

import optplan as op
from optplan.backends.swarm import make_space
from optplan.generators import random_obstacles as _random_obstacles
from optplan.geometry import ObstacleSet, kernel_engine, obstacle_set
from optplan.problem import Obstacle

ENGINES = ("numpy", "numba")


def per_call(obs: ObstacleSet, batches: list[np.ndarray], engine: str, penetration: bool,
             repeats: int = 7, min_time: float = 0.05) -> float:
    """Median seconds per call over ``repeats`` timed passes over ``batches``."""
    for b in batches[:3]:
        obs.crossings(b, penetration=penetration, engine=engine)  # compile / warm up
    loops = 1
    while True:  # enough passes that one timing lasts min_time
        t = time.perf_counter()
        for _ in range(loops):
            for b in batches:
                obs.crossings(b, penetration=penetration, engine=engine)
        if time.perf_counter() - t > min_time or loops > 1000:
            break
        loops *= 2
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(loops):
            for b in batches:
                obs.crossings(b, penetration=penetration, engine=engine)
        ts.append((time.perf_counter() - t) / (loops * len(batches)))
    return float(np.median(ts))


def ipso_batches(prob: op.Problem, seed: int = 0) -> list[np.ndarray]:
    """The path batches one ``ipso-paper`` run scores (recorded by wrapping crossings)."""
    real = ObstacleSet.crossings
    rec: list[np.ndarray] = []

    def spy(self, paths, *a, **k):
        rec.append(np.array(paths))
        return real(self, paths, *a, **k)

    ObstacleSet.crossings = spy
    try:
        op.solve(prob, "ipso-paper", rng=seed)
    finally:
        ObstacleSet.crossings = real
    return rec


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


def solve_times(seeds: int) -> dict[str, float]:
    """Median wall time of one ipso-paper run on paper-env1 per engine (interleaved)."""
    prob = op.load_problem("paper-env1")
    saved = os.environ.pop("OPTPLAN_ENGINE", None)
    ts: dict[str, list[float]] = {"auto": [], "numpy": []}
    try:
        for mode in ts:  # warm caches (obstacle set, compiled kernel)
            _set_engine(mode)
            op.solve(prob, "ipso-paper", rng=0)
        for s in range(seeds):
            for mode in ts:
                _set_engine(mode)
                t = time.perf_counter()
                op.solve(prob, "ipso-paper", rng=s)
                ts[mode].append(time.perf_counter() - t)
    finally:
        os.environ.pop("OPTPLAN_ENGINE", None)
        if saved is not None:
            os.environ["OPTPLAN_ENGINE"] = saved
    return {m: float(np.median(v)) for m, v in ts.items()}


def _set_engine(mode: str) -> None:
    if mode == "auto":
        os.environ.pop("OPTPLAN_ENGINE", None)
    else:
        os.environ["OPTPLAN_ENGINE"] = mode


_FIRST_CALL = """
import time, numpy as np
t0 = time.perf_counter()
import numba  # noqa
t1 = time.perf_counter()
import optplan as op
from optplan.backends.swarm import make_space
p = op.load_problem("paper-env1")
obs = make_space(p, p.robots[0], 6).obstacles
x = np.random.default_rng(0).uniform(0, 500, (70, 8, 2))
t2 = time.perf_counter()
obs.crossings(x, penetration=False, engine="numba")
t3 = time.perf_counter()
print(t1 - t0, t3 - t2)
"""


def first_call(cache_dir: str | None) -> tuple[float, float]:
    """(import numba, first compiled call) seconds in a fresh process."""
    env = dict(os.environ)
    env.pop("OPTPLAN_ENGINE", None)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = cache_dir
    out = subprocess.run([sys.executable, "-c", _FIRST_CALL], capture_output=True, text=True,
                         check=True, env=env)
    a, b = out.stdout.split()
    return float(a), float(b)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=15)
    args = ap.parse_args(argv)
    import numba

    print(f"machine: {os.cpu_count()} cores (shared), {platform.processor() or platform.machine()}"
          f", Python {platform.python_version()}, numpy {np.__version__}, "
          f"numba {numba.__version__}; auto engine: {kernel_engine()}")
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
    print("### Per call on paper-env1 (8 obstacles, all-pairs pre-filter)")
    print()
    print("| workload | penetration | numpy (us/call) | numba (us/call) | speed-up |")
    print("|---|---|---|---|---|")
    for label, batches in workloads:
        for pen in (False, True):
            t = {e: per_call(obs, batches, e, pen) for e in ENGINES}
            print(f"| {label} | {'yes' if pen else 'no'} | {t['numpy'] * 1e6:.0f} | "
                  f"{t['numba'] * 1e6:.1f} | {t['numpy'] / t['numba']:.1f}x |")
    print()
    print("### Per call on random maps (70 paths x 7 segments, count only)")
    print()
    print("| obstacles (placed) | items (pieces + circles) | pre-filter | paths "
          "| numpy (us/call) | numba (us/call) | speed-up | numba x vs 10 |")
    print("|---|---|---|---|---|---|---|---|")
    base: dict[str, float] = {}
    for n in (10, 100, 1000):
        obstacles = random_obstacles(n)
        rs = obstacle_set(obstacles, 1.0)
        grid = "all pairs" if rs.grid is None else f"grid {rs.grid['nx']} x {rs.grid['ny']}"
        for kind, walk in (("uniform", None), ("near the line", 40.0)):
            r2 = np.random.default_rng(n)
            batches = [random_batch(r2, (5.0, 5.0), (495.0, 495.0), walk=walk)
                       for _ in range(10)]
            t = {e: per_call(rs, batches, e, False) for e in ENGINES}
            base.setdefault(kind, t["numba"])
            print(f"| {n} ({len(obstacles)}) | {rs.n_items} | {grid} | {kind} | "
                  f"{t['numpy'] * 1e6:.0f} | {t['numba'] * 1e6:.1f} | "
                  f"{t['numpy'] / t['numba']:.1f}x | {t['numba'] / base[kind]:.1f} |")
    print()
    print(f"### One ipso-paper run on paper-env1 (median of {args.seeds} seeds, interleaved)")
    print()
    st = solve_times(args.seeds)
    print("| OPTPLAN_ENGINE | kernel engine | median ms per run |")
    print("|---|---|---|")
    print(f"| unset (auto) | numba | {st['auto'] * 1e3:.1f} |")
    print(f"| numpy | numpy | {st['numpy'] * 1e3:.1f} |")
    print()
    print("### First compiled call in a fresh process (paper-env1, 70 x 7 batch)")
    print()
    print("| numba cache | import numba (s) | first call (s) |")
    print("|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        cold = first_call(tmp)
        warm_tmp = first_call(tmp)  # the cache written by the cold run
    warm = first_call(None)  # the package's own __pycache__
    print(f"| cold (empty cache dir) | {cold[0]:.2f} | {cold[1]:.2f} |")
    print(f"| warm (same cache dir) | {warm_tmp[0]:.2f} | {warm_tmp[1]:.3f} |")
    print(f"| default (`optplan/__pycache__`) | {warm[0]:.2f} | {warm[1]:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
