"""The arrival lower bound per refinement level (docs/time.md, "A lower bound that tightens").

Prints, for the door scene of the page (a square mover parked on a 1-unit door until
t = 20), the bound of ``arrival_lower_bound(problem, level=L)`` per level, the number of cells
and the seconds it took; with ``--seeds``, also the median over ``doors`` scenes of
:func:`optplan.time_families.time_family` of the bound relative to level 0 and of the seconds.

    python benchmarks/bench_cell_bound.py --levels 0 6 --seeds 1 2 3
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from optplan.geometry.timing import arrival_lower_bound
from optplan.problem import Problem, parse_problem


def door_scene(parked_until: float | None = 20.0) -> Problem:
    """Two rooms of a 16 x 16 map joined by a door ``y in [7.5, 8.5]`` in a wall
    ``x in [7, 9]``; a 2.4 x 2.4 square parked on the door until ``parked_until``, then up to
    ``(8, 14)`` in 1 s (``None``: for ever); the robot (radius 0.2, speed 1) from (2, 8) to
    (14, 8)."""
    half = [[-1.2, -1.2], [1.2, -1.2], [1.2, 1.2], [-1.2, 1.2]]
    track = ({"waypoints": [[8, 8]], "times": [0]} if parked_until is None else
             {"waypoints": [[8, 8], [8, 8], [8, 14]],
              "times": [0, parked_until, parked_until + 1]})
    return parse_problem({
        "name": "door", "bounds": [0, 0, 16, 16],
        "robots": [{"id": "r", "start": [2, 8], "goal": [14, 8], "radius": 0.2,
                    "max_speed": 1.0}],
        "obstacles": [{"type": "rectangle", "min": [7, 0], "max": [9, 7.5]},
                      {"type": "rectangle", "min": [7, 8.5], "max": [9, 16]}],
        "dynamic_obstacles": [{"type": "polygon", "vertices": half, **track}]})


def timed(problem: Problem, level: int) -> tuple[float, float]:
    """The bound at ``level`` and the seconds it took."""
    t0 = time.perf_counter()
    value = arrival_lower_bound(problem, level=level).value
    return float("nan") if value is None else float(value), time.perf_counter() - t0


def main(argv: list[str] | None = None) -> None:
    """Print the tables."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--levels", type=int, nargs=2, default=[0, 6], metavar=("LO", "HI"))
    ap.add_argument("--seeds", type=int, nargs="*", default=[])
    args = ap.parse_args(argv)
    levels = range(args.levels[0], args.levels[1] + 1)
    p = door_scene()
    print("door scene (sipp's earliest arrival, graded collision-free: 27.603 s)")
    print(f"{'level':>5} {'bound':>10} {'cells':>7} {'seconds':>8}")
    for lv in levels:
        value, sec = timed(p, lv)
        print(f"{lv:>5} {value:>10.4f} {4 ** lv:>7} {sec:>8.3f}")
    if not args.seeds:
        return
    from optplan.time_families import time_family

    scenes = [time_family("doors", np.random.default_rng(s)) for s in args.seeds]
    print(f"\ndoors scenes, {len(scenes)} seeds: medians")
    print(f"{'level':>5} {'bound / level 0':>16} {'seconds':>8}")
    base = [timed(q, 0)[0] for q in scenes]
    for lv in levels:
        rows = [timed(q, lv) for q in scenes]
        ratio = np.median([v / b for (v, _), b in zip(rows, base)])
        print(f"{lv:>5} {ratio:>16.4f} {np.median([s for _, s in rows]):>8.3f}")


if __name__ == "__main__":
    main()
