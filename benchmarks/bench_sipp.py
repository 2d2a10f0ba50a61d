"""Speed of the ``sipp`` preset: earliest arrival on the tangent roadmap among moving obstacles.

Scenes:

* ``paper-warehouse`` (catalogue: 600 x 600, shelves, machines, three temporary obstacles, a
  bouncing forklift; the leader is planned), one problem, ``--repeats`` runs after a warm-up;
* random scenes (:func:`random_scene`): ``optplan.generators.random_obstacles(100, seed)`` in
  500 x 500 and 20 seeded moving obstacles (circles and rectangles, 2-4 waypoints at 3-12
  units/s with ``hold``, ``loop`` or ``bounce``, or a constant velocity), a robot of radius 1
  and speed 10 from (10, 10) to (490, 490), over ``--seeds`` seeds;
* the same with 20 discs going back and forth across the start-goal diagonal (``loop`` or
  ``bounce``, 3-12 units/s), so that many of them delay the robot.

Each run is ``optplan.solve(problem, "sipp")``: the certified lower bound, the search and the
validator's exact continuous-time check; the wall time is the one ``Result.wall_time``
reports.  The script prints the median and the worst over runs, the status counts, the
expansions and the gap to the lower bound, against the targets of issue 25: <= 100 ms on
``paper-warehouse``, <= 1 s with 100 obstacles and 20 movers.

Run: ``python benchmarks/bench_sipp.py [--seeds 10] [--repeats 5]``.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time
from collections import Counter

import numpy as np

import optplan as op
from optplan.generators import random_obstacles
from optplan.problem import Problem, parse_problem

SIDE = 500.0
START, GOAL = (10.0, 10.0), (490.0, 490.0)
TARGET_WAREHOUSE = 0.1
TARGET_RANDOM = 1.0


def _obstacle_dict(o) -> dict:
    """A static obstacle of :func:`random_obstacles` as a scenario table."""
    if o.kind == "circle":
        return {"type": "circle", "center": [float(x) for x in o.center],
                "radius": float(o.radius), "name": o.name}
    ring = np.asarray(o.geometry.exterior.coords)[:-1]
    return {"type": "polygon", "vertices": ring.tolist(), "name": o.name}


def _mover(rng: np.random.Generator, k: int) -> dict:
    """One random moving obstacle (a table of ``[[dynamic_obstacles]]``)."""
    if rng.random() < 0.5:
        shape = {"type": "circle", "radius": float(rng.uniform(3.0, 8.0))}
    else:
        w, h = rng.uniform(6.0, 14.0, 2) / 2
        shape = {"type": "polygon", "vertices": [[-w, -h], [w, -h], [w, h], [-w, h]]}
    first = rng.uniform(0.05, 0.95, 2) * SIDE
    while math.dist(first, START) < 60 or math.dist(first, GOAL) < 60:
        first = rng.uniform(0.05, 0.95, 2) * SIDE
    speed = float(rng.uniform(3.0, 12.0))
    if rng.random() < 0.2:
        ang = rng.uniform(0.0, 2 * math.pi)
        return {**shape, "name": f"m{k}", "waypoints": [first.tolist()],
                "velocity": [speed * math.cos(ang), speed * math.sin(ang)]}
    pts = [first] + [rng.uniform(0.05, 0.95, 2) * SIDE for _ in range(int(rng.integers(1, 4)))]
    t0 = float(rng.uniform(0.0, 20.0))
    times = t0 + np.concatenate([[0.0], np.cumsum([math.dist(a, b) / speed
                                                   for a, b in zip(pts, pts[1:])])])
    return {**shape, "name": f"m{k}", "waypoints": [p.tolist() for p in pts],
            "times": times.tolist(), "after": str(rng.choice(["hold", "loop", "bounce"]))}


def _crossing_mover(rng: np.random.Generator, k: int) -> dict:
    """A disc going back and forth across the start-goal diagonal (``loop`` or ``bounce``)."""
    c = np.full(2, rng.uniform(0.1, 0.9) * SIDE)
    d = np.array([1.0, -1.0]) / math.sqrt(2) * rng.uniform(40.0, 120.0)
    speed = float(rng.uniform(3.0, 12.0))
    t0 = float(rng.uniform(0.0, 30.0))
    return {"type": "circle", "radius": float(rng.uniform(3.0, 8.0)), "name": f"m{k}",
            "waypoints": [(c - d).tolist(), (c + d).tolist()],
            "times": [t0, t0 + 2 * float(np.hypot(*d)) / speed],
            "after": str(rng.choice(["loop", "bounce"]))}


def random_scene(n_obstacles: int, n_movers: int, seed: int, crossing: bool = False
                 ) -> Problem:
    """A seeded 500 x 500 scene: ``n_obstacles`` random static obstacles, ``n_movers`` moving
    obstacles (anywhere, or with ``crossing`` all across the start-goal diagonal), one robot
    (radius 1, speed 10) from (10, 10) to (490, 490)."""
    rng = np.random.default_rng([seed, 25])
    obs = random_obstacles(n_obstacles, seed=seed, keep_free=(START, GOAL))
    make = _crossing_mover if crossing else _mover
    tag = "-crossing" if crossing else ""
    return parse_problem({
        "name": f"sipp-random-{n_obstacles}-{n_movers}-{seed}{tag}",
        "bounds": [0.0, 0.0, SIDE, SIDE],
        "obstacles": [_obstacle_dict(o) for o in obs],
        "robots": [{"id": "r", "start": list(START), "goal": list(GOAL), "radius": 1.0,
                    "max_speed": 10.0}],
        "dynamic_obstacles": [make(rng, k) for k in range(n_movers)],
    }, "<bench_sipp>")


def run(problem: Problem) -> dict:
    """One ``sipp`` solve: wall time, status, expansions, gap."""
    r = op.solve(problem, "sipp")
    lead = next(iter(r.extras["sipp"].values()))
    return {"wall": r.wall_time, "status": str(r.status), "expansions": lead["expansions"],
            "gap": lead["gap"], "arrival": lead["arrival"], "feasible": r.metrics["feasible"]}


def _line(label: str, rows: list[dict], target: float) -> str:
    walls = [x["wall"] for x in rows]
    gaps = [x["gap"] for x in rows if x["gap"] is not None]
    med, worst = statistics.median(walls), max(walls)
    ok = "met" if worst <= target else "NOT met"
    st = ", ".join(f"{k} {v}" for k, v in sorted(Counter(x["status"] for x in rows).items()))
    exp = statistics.median([x["expansions"] for x in rows])
    gap = f"{100 * statistics.median(gaps):.3g} %" if gaps else "-"
    return (f"| {label} | {len(rows)} | {1000 * med:.1f} | {1000 * worst:.1f} | {st} | "
            f"{exp:.0f} | {gap} | {all(x['feasible'] for x in rows)} | "
            f"<= {1000 * target:.0f} ms: {ok} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print("sipp: wall time of optplan.solve(problem, 'sipp') (bound + search + validator)")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}; "
          f"load average {os.getloadavg()[0]:.2f}")
    print()
    wh = op.load_problem("paper-warehouse")
    run(wh)  # warm-up: numba kernels, imports
    rows_wh = []
    for _ in range(args.repeats):
        rows_wh.append(run(op.load_problem("paper-warehouse")))  # fresh caches each time
    t0 = time.perf_counter()
    rows_rd = [run(random_scene(100, 20, s)) for s in range(args.seeds)]
    rows_cx = [run(random_scene(100, 20, s, crossing=True)) for s in range(args.seeds)]
    total = time.perf_counter() - t0
    print("| scene | runs | median ms | worst ms | statuses | expansions (median) | "
          "gap to bound (median) | all feasible | target |")
    print("|---|---:|---:|---:|---|---:|---:|:---|---|")
    print(_line("paper-warehouse", rows_wh, TARGET_WAREHOUSE))
    print(_line("random, 100 obstacles, 20 movers", rows_rd, TARGET_RANDOM))
    print(_line("random, 100 obstacles, 20 movers across the diagonal", rows_cx,
                TARGET_RANDOM))
    print()
    print(f"random scenes: 2 x {args.seeds} seeds in {total:.1f} s")


if __name__ == "__main__":
    main()
