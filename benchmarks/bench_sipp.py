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
validator's exact continuous-time check.  The runs happen in a worker process (the script with
``--worker``, :mod:`against`), one at a time, after one warm-up solve (imports, compiled
kernels); the problem is built before the clock starts, and each run is the first on its map
(the obstacle sets and graphs that ``op.solve`` shares per static map and process,
``optplan.problem.shared``, are cleared before it where the checkout has them).  Per scene
family the table gives the statuses, the median expansions and gap to the lower bound, whether
every plan is feasible, the median and worst wall time (``perf_counter``) and CPU time
(``process_time``: the share of a loaded machine this process got) of ``op.solve``, a digest of
the answers (status, paths, time stamps, arrival; float64 bytes, in run order), and whether the
worst wall time and the worst CPU time meet the targets of issues 25 and 46 (<= 100 ms on
``paper-warehouse``, <= 1 s with 100 obstacles and 20 movers; set for the idle machine, where
the two agree).  The load average is printed before and after.

``--against REV [REV ...]`` runs a worker per commit ``REV`` (a temporary ``git worktree``)
beside this checkout's; the runs go to the workers in turn (the order reversed every run, never
two at once), so the machine's load hits all alike, and the table adds the ratio of the medians
(current / REV; below 1 is faster) and how many runs gave the same answer.  The worker needs
``optplan.solve``, ``load_problem``, ``generators.random_obstacles`` and
``problem.parse_problem`` at ``REV``.

Run: ``python benchmarks/bench_sipp.py [--seeds 10] [--repeats 5] [--against REV ...]``.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

import optplan as op
from optplan.generators import random_obstacles
from optplan.problem import Problem, parse_problem

sys.path.insert(0, str(Path(__file__).resolve().parent))
import against  # noqa: E402

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


def problem_of(family: str, k: int) -> Problem:
    """The problem of run ``k`` of a scene family: ``warehouse`` (the catalogue's
    ``paper-warehouse``, loaded afresh), ``random`` or ``crossing`` (seed ``k``)."""
    if family == "warehouse":
        return op.load_problem("paper-warehouse")
    return random_scene(100, 20, k, crossing=family == "crossing")


def worker() -> None:
    """Answer the requests ``family k`` with one timed ``sipp`` solve of
    :func:`problem_of`: wall and CPU seconds, status, expansions, gap, feasibility, digest."""
    warm: list[bool] = []
    try:  # the obstacle sets op.solve shares per static map (since 9ca108f)
        from optplan.problem.shared import clear as clear_shared
    except ImportError:
        clear_shared = None  # type: ignore[assignment]

    def answer(words: list[str]) -> dict:
        if not warm:  # imports and compiled kernels out of the timed runs; on the first
            warm.append(True)  # request, so that the other worker is idle meanwhile
            op.solve(problem_of("warehouse", 0), "sipp")
        problem = problem_of(words[0], int(words[1]))
        if clear_shared is not None:
            clear_shared()  # the first query on its map
        r, wall, cpu = against.timed(lambda: op.solve(problem, "sipp"))
        lead = next(iter(r.extras["sipp"].values()))
        paths = [x for rid in sorted(r.paths) for x in (rid, r.paths[rid])]
        times = np.zeros(0) if r.times is None else r.times
        arrival = math.nan if lead["arrival"] is None else lead["arrival"]
        return {"wall": wall, "cpu": cpu, "family": words[0], "status": str(r.status),
                "expansions": lead["expansions"], "gap": lead["gap"],
                "feasible": bool(r.metrics["feasible"]),
                "digest": against.digest(r.status.value, *paths, times, np.array([arrival]))}

    against.serve(answer)


def _cells(rows: list[dict]) -> list[str]:
    """The extra columns of :func:`against.table` (:data:`EXTRA`) of one family's runs."""
    gaps = [x["gap"] for x in rows if x["gap"] is not None]
    st = ", ".join(f"{k} {v}" for k, v in sorted(Counter(x["status"] for x in rows).items()))
    target = TARGET_WAREHOUSE if rows[0]["family"] == "warehouse" else TARGET_RANDOM
    met = ["met" if max(x[k] for x in rows) <= target else "NOT met" for k in ("wall", "cpu")]
    return [st, f"{statistics.median([x['expansions'] for x in rows]):.0f}",
            f"{100 * statistics.median(gaps):.3g} %" if gaps else "-",
            str(all(x["feasible"] for x in rows)),
            f"<= {1000 * target:.0f} ms: {met[0]}, {met[1]}"]


#: The extra columns of the table: headers and :func:`_cells`.
EXTRA = (["statuses", "expansions (median)", "gap to bound (median)", "all feasible",
          "worst vs target (wall, CPU)"], _cells)


def main(argv: list[str] | None = None) -> None:
    """Parse the options, run the scenes (beside ``--against``) and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="random scenes per family")
    ap.add_argument("--repeats", type=int, default=5, help="runs of paper-warehouse")
    ap.add_argument("--against", nargs="+", default=[], metavar="REV",
                    help="also run every scene on these commits")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker()
        return
    families = {"warehouse": ("paper-warehouse", range(a.repeats)),
                "random": ("random, 100 obstacles, 20 movers", range(a.seeds)),
                "crossing": ("random, 100 obstacles, 20 movers across the diagonal",
                             range(a.seeds))}
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    with against.workers(__file__, a.against) as pool:
        out: dict[tuple[str, ...], dict[str, list[dict]]] = {
            (label,): against.alternate(pool, [(fam, k) for k in ks])
            for fam, (label, ks) in families.items()}
    total = time.perf_counter() - t0
    load1 = os.getloadavg()
    print("sipp: wall and CPU time of optplan.solve(problem, 'sipp') (bound + search + "
          "validator)" + (f", this checkout beside {' '.join(a.against)} (alternating)"
                          if a.against else ""))
    print(f"Python {platform.python_version()}, numpy {np.__version__}. "
          f"{against.load_line(load0, load1)}\n")
    print(against.table(out, ["scene"], bool(a.against), "ms", EXTRA))
    print(f"\n{a.seeds} seeds per random family, {a.repeats} runs of paper-warehouse; "
          f"{total:.1f} s in all")


if __name__ == "__main__":
    main()
