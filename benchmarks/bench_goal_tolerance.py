"""No valid run below its reference: the goal-tolerance rule (docs/time.md, "The goal tolerance").

Solves the catalogue's problems and fresh 32 x 32 MovingAI-type random maps (20 % blocked,
``--queries`` lines per map) with every solver, ``reference=True``, and prints per solver the
valid runs (solved or optimal, collision-free), how many of them end inside the goal
tolerance off the goal point, and the smallest ratios over the valid runs: to the certified
optimum (``ratio_to_optimum``, graded on ``length_to_goal``), of the arrival at the goal point
to the reference in time and to the lower bound.  The rule holds when no smallest ratio is
below ``1 - 1e-9``; the column "as executed" gives the smallest ratio a grading that ignored
the tolerance would show (``length / optimum``, ``arrival_time / sipp``).

    python benchmarks/bench_goal_tolerance.py --seeds 1001 1002 --queries 5
"""

from __future__ import annotations

import argparse
import math
import tempfile
from collections import defaultdict
from typing import Any

import numpy as np

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen

SOLVERS = ["visgraph", "ipso-paper", "pso-paper", "apf-paper", "sa-apf-paper", "orca",
           "hybrid-paper", "sipp"]
FLOOR = 1.0 - 1e-9


def problems(seeds: list[int], queries: int, tmp: str) -> list[tuple[str, Any]]:
    """The catalogue's single-leader problems and the lines of fresh random maps."""
    out = [(name, op.load_problem(name)) for name in op.list_problems()]
    for s in seeds:
        g = movingai_benchmark("random", 32, f"{tmp}/{s}", rng=np.random.default_rng(s),
                               queries=queries, density=0.2)
        out += [(f"random-{s}-{k}", q)
                for k, q in enumerate(read_scen(str(g.map_path) + ".scen"))]
    return out


def _min(values: list[float]) -> float:
    return min(values) if values else math.nan


def run(solvers: list[str], seeds: list[int], queries: int, time_limit: float
        ) -> list[dict[str, Any]]:
    """One row per solver (module docstring)."""
    acc: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    with tempfile.TemporaryDirectory() as tmp:
        for name, prob in problems(seeds, queries, tmp):
            for solver in solvers:
                try:
                    res = op.solve(prob, solver, rng=0, reference=True, time_limit=time_limit)
                except ValueError:  # a solver that does not take this problem (e.g. teams)
                    continue
                m, a = res.metrics, acc[solver]
                if not (res.success and not m.get("collisions")):
                    continue
                a["valid"].append(name)
                a["short"] += [name] if m.get("goal_completion") or m.get(
                    "arrival_completion") else []
                if m.get("ratio_to_optimum") is not None:
                    a["length"].append(m["ratio_to_optimum"])
                    a["length_raw"].append(m["length"] / m["optimum"])
                for key in ("arrival_ratio_to_reference", "arrival_ratio_to_lower"):
                    if m.get(key) is not None:
                        a[key].append(m[key])
                if m.get("arrival_time") is not None and m.get("time_reference"):
                    a["arrival_raw"].append(m["arrival_time"] / m["time_reference"])
    rows = []
    for solver in solvers:
        a = acc[solver]
        rows.append({"solver": solver, "valid": len(a["valid"]), "short": len(a["short"]),
                     "length": _min(a["length"]), "length_raw": _min(a["length_raw"]),
                     "to_reference": _min(a["arrival_ratio_to_reference"]),
                     "to_bound": _min(a["arrival_ratio_to_lower"]),
                     "arrival_raw": _min(a["arrival_raw"]),
                     "below": sum(v < FLOOR for k in ("length", "arrival_ratio_to_reference",
                                                      "arrival_ratio_to_lower") for v in a[k])})
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    lines = ["| solver | valid runs | inside the tolerance, off the goal | smallest length ratio "
             "(as executed) | smallest arrival ratio to reference (as executed) | smallest "
             "arrival ratio to lower bound | ratios below 1 - 1e-9 |", "|" + "---|" * 7]
    for r in rows:
        lines.append(f"| {r['solver']} | {r['valid']} | {r['short']} | {r['length']:.6f} "
                     f"({r['length_raw']:.6f}) | {r['to_reference']:.6f} "
                     f"({r['arrival_raw']:.6f}) | {r['to_bound']:.6f} | {r['below']} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--solvers", nargs="+", default=SOLVERS)
    ap.add_argument("--seeds", nargs="+", type=int, default=[1001, 1002])
    ap.add_argument("--queries", type=int, default=5, help="lines per random map")
    ap.add_argument("--time-limit", type=float, default=20.0)
    a = ap.parse_args(argv)
    rows = run(a.solvers, a.seeds, a.queries, a.time_limit)
    print(f"\nThe goal-tolerance rule: catalogue + random maps {a.seeds} x {a.queries} lines, "
          f"seed 0, time_limit {a.time_limit:g} s\n")
    print(table(rows))


if __name__ == "__main__":
    main()
