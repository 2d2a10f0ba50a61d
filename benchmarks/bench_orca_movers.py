"""``orca`` among moving obstacles: the whole avoidance of a mover against RVO2's half.

RVO2 treats every neighbour agent as reciprocating: each side takes half of an avoidance.  A
moving obstacle keeps its prescribed velocity, so a robot that takes half runs into it.  The
``orca`` option ``mover_share`` (1: the whole, the default; 0.5: RVO2's rule) says how much a
robot takes (docs/solvers/orca.md).  For each scene (the time families of
``optplan.time_families``, ``--seeds`` each, and the catalogue scenes with moving obstacles)
this script runs ``orca`` with both shares (``rng=0``) and prints per family: runs, runs with a
contact (with a mover or anything else, the validator's count), solved runs, and the median
arrival of the runs solved by both.  The load average is printed before and after.

    python benchmarks/bench_orca_movers.py --seeds 1 2 3 4 5 6 7 8
"""

from __future__ import annotations

import argparse
import os
import statistics

import numpy as np

import optplan as op
from optplan.catalog import list_problems
from optplan.time_families import TIME_FAMILY_KINDS, time_family

SHARES = (0.5, 1.0)


def _scenes(seeds: list[int]) -> list[tuple[str, op.Problem]]:
    """(family, problem) for every scene of the run."""
    out = [(kind, time_family(kind, np.random.default_rng(s)))
           for kind in TIME_FAMILY_KINDS for s in seeds]
    for name in list_problems():
        p = op.load_problem(name)
        if p.dynamic_obstacles:
            out.append(("catalogue", p))
    return out


def _load() -> str:
    """The load average (1, 5, 15 min) and the cores."""
    return ", ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} cores"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(1, 9)))
    ap.add_argument("--time-limit", type=float, default=60.0)
    a = ap.parse_args(argv)
    load0 = _load()
    rows: dict[str, list[dict[float, op.Result]]] = {}
    for fam, p in _scenes(a.seeds):
        rows.setdefault(fam, []).append({s: op.solve(p, "orca", mover_share=s, rng=0,
                                                     time_limit=a.time_limit)
                                         for s in SHARES})
    print(f"\n## orca among moving obstacles: mover_share 0.5 (RVO2's rule) and 1 (the "
          f"whole)\n\nseeds {a.seeds}; load average before {load0}, after {_load()}\n")
    print("| family | runs | with a contact (0.5 / 1) | solved (0.5 / 1) | median arrival of "
          "the runs both solve (0.5 / 1) |\n|---|---|---|---|---|")
    for fam, rs in rows.items():
        hit = [sum(r[s].metrics.get("collisions", 0) > 0 for r in rs) for s in SHARES]
        ok = [sum(r[s].status is op.Status.solved for r in rs) for s in SHARES]
        both = [r for r in rs if all(r[s].status is op.Status.solved for s in SHARES)]
        arr = [statistics.median(r[s].times[-1] for r in both) if both else float("nan")
               for s in SHARES]
        print(f"| {fam} | {len(rs)} | {hit[0]} / {hit[1]} | {ok[0]} / {ok[1]} | "
              f"{arr[0]:.2f} / {arr[1]:.2f} ({len(both)} runs) |")


if __name__ == "__main__":
    main()
