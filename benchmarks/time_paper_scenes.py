"""The paper's local-planner scenes re-read against the references in time.

The scenes are those of the local-planner and hybrid fidelity experiments
(``optplan.experiments.apf_fidelity.KB_SCENES`` and ``hybrid_fidelity.RHO_SCENES``) that have
moving obstacles (``trap-u`` has none, so nothing to grade in time).  On each, ``sa-apf-paper``
runs ``--seeds`` seeds through ``optplan.solve(problem, "sa-apf-paper", rng=seed,
reference=True)``, and the table shows, for the leader:

* SA-APF's ``arrival_time`` (its own time stamps: the first within the goal tolerance);
* ``schedule_arrival``: the fastest timing of SA-APF's own path up to that point
  (:func:`optplan.geometry.timing.schedule.fastest_schedule`, exact);
* ``arrival_at_goal``: the arrival completed to the goal point (docs/time.md, "The goal
  tolerance"), which the ratios to the references use;
* ``time_reference`` and ``time_lower_bound``: the time bracket's upper side (a valid plan,
  never later than ``sipp``) and lower side (certified for every motion) at its grading
  level, with their ratio;
* the ratios ``arrival / schedule`` (what SA-APF loses by its timing), ``arrival / reference``,
  ``arrival / bound`` and ``schedule / reference`` (what it loses by its path), each the median
  and the worst (largest) over the seeds, on the collision-free plans that reach the goal.

Run: ``python benchmarks/time_paper_scenes.py [--seeds 5]`` (about half a minute).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from typing import Any

import numpy as np

import optplan as op
from optplan.experiments.apf_fidelity import KB_SCENES
from optplan.experiments.hybrid_fidelity import RHO_SCENES

PRESET = "sa-apf-paper"


def scenes() -> list[str]:
    """The fidelity experiments' scenes with moving obstacles, in their order."""
    names = dict.fromkeys((*KB_SCENES, *RHO_SCENES))
    return [n for n in names if op.load_problem(n).dynamic_obstacles]


def runs(name: str, seeds: int) -> list[dict[str, Any]]:
    """``sa-apf-paper`` on catalogue scene ``name``, seeds ``0 .. seeds - 1``, graded in time.

    Returns
    -------
    list of dict
        Per seed: ``valid`` (reaches the goal and the validator's ``feasible``) and the
        metrics of ``reference=True`` (``arrival_time``, ``schedule_arrival``,
        ``time_reference``, ``time_lower_bound``, the ratios).
    """
    prob = op.load_problem(name)
    out = []
    for seed in range(seeds):
        m = op.solve(prob, PRESET, rng=seed, reference=True).metrics
        sch, ref = m.get("schedule_arrival"), m.get("time_reference")
        out.append({**m, "valid": m.get("arrival_time") is not None and bool(m["feasible"]),
                    "schedule_to_ref": None if sch is None or not ref else sch / ref})
    return out


def _mw(rows: list[dict[str, Any]], key: str, fmt: str = ".3f") -> str:
    xs = [r[key] for r in rows if r.get(key) is not None]
    if not xs:
        return "-"
    return f"{statistics.median(xs):{fmt}} / {max(xs):{fmt}}"


def table(results: dict[str, list[dict[str, Any]]]) -> str:
    """One row per scene: the arrivals (s) and the ratios, median / worst over the seeds."""
    out = ["| scene | seeds | collision-free and reached | SA-APF arrival s | at goal s | "
           "fastest timing of its path s | reference s | lower bound s | reference / bound | "
           "arrival / schedule | arrival / reference | arrival / bound | schedule / reference |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, rs in results.items():
        ok = [r for r in rs if r["valid"]]
        first = rs[0]
        ref, bound = first.get("time_reference"), first.get("time_lower_bound")
        ref_s = "-" if ref is None else f"{ref:.2f}"
        bound_s = "-" if bound is None else f"{bound:.2f}"
        gap = "-" if ref is None or not bound else f"{ref / bound:.6f}"
        out.append(f"| {name} | {len(rs)} | {len(ok)} | {_mw(ok, 'arrival_time', '.2f')} | "
                   f"{_mw(ok, 'arrival_at_goal', '.2f')} | "
                   f"{_mw(ok, 'schedule_arrival', '.2f')} | {ref_s} | {bound_s} | {gap} | "
                   f"{_mw(ok, 'arrival_ratio_to_schedule')} | "
                   f"{_mw(ok, 'arrival_ratio_to_reference')} | "
                   f"{_mw(ok, 'arrival_ratio_to_lower')} | {_mw(ok, 'schedule_to_ref')} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args(argv)
    names = scenes()
    print(f"time_paper_scenes: {PRESET} on the paper's local-planner scenes with moving "
          f"obstacles, seeds 0-{args.seeds - 1}, against the references in time")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
          f"(shared), Python {platform.python_version()}, numpy {np.__version__}\n")
    l0, t0 = os.getloadavg()[0], time.perf_counter()
    results = {n: runs(n, args.seeds) for n in names}
    print(f"load average {l0:.2f} before, {os.getloadavg()[0]:.2f} after "
          f"({time.perf_counter() - t0:.0f} s)\n")
    print(table(results))
    print("\nArrivals in s; each cell 'median / worst' (worst: the latest arrival, the largest "
          "ratio) over the collision-free plans that reach the goal.  The ratios to the "
          "references use the arrival at the goal point.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
