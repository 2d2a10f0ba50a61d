"""``optplan bench`` over a whole MovingAI ``.scen``: the sweep a user runs, timed end to end.

Per map kind (``--kinds``) a ``--size`` x ``--size`` map and its ``.scen`` of ``--queries``
lines (seed ``--seed``) are generated with ``optplan.maps.movingai_gen.generate_benchmark`` in a
temporary directory, then ``optplan bench --problems <the .scen> --solvers <--solver> --seeds
1`` runs in a child process (``--workers``, default 1: inline): every line named
``<file>.scen#line=N`` and read once per process, every solve on the map's one shared graph
(``visgraph``'s default ``graph = "auto"`` builds it on the first query), each run graded
against the certified optimum (``optplan.solver.reference_optimum``, one more query per line).

Printed per map: the child's wall and CPU seconds (the whole command: start-up, the import of
the map, the sweep, the report), the sum, median and worst of the runs' ``wall_time`` (the
solving) and of their ``reference_time`` (the grading; the first one builds the graph), the
statuses, and how many runs have ``|ratio - 1| <= 1e-12`` (the length of the run's polyline,
summed segment by segment, against the certified optimum's exact length).  The machine is
shared: CPU seconds beside wall seconds.

    python benchmarks/bench_scen_sweep.py --size 1024 --queries 1000
"""

from __future__ import annotations

import argparse
import csv
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from optplan.maps.movingai_gen import generate_benchmark


def sweep(kind: str, size: int, queries: int, seed: int, solver: str, workers: int) -> dict:
    """One generated map and its ``optplan bench`` run: the timings and the rows."""
    with tempfile.TemporaryDirectory() as tmp:
        gen = generate_benchmark(kind, size, tmp, rng=np.random.default_rng(seed),
                                 queries=queries)
        out = Path(tmp) / "run"
        cmd = [sys.executable, "-m", "optplan", "bench", "--problems", str(gen.scen_path),
               "--solvers", solver, "--seeds", "1", "--workers", str(workers), "--out",
               str(out), "--quiet"]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise SystemExit(f"optplan bench failed ({done.returncode}):\n{done.stderr}")
        with (out / "results.csv").open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return {"wall": wall, "cpu": cpu, "rows": rows}


def _times(rows: list[dict], key: str) -> str:
    t = [float(r[key]) for r in rows if r[key] not in ("", "nan")]
    if not t:
        return "-"
    return (f"{sum(t):.1f} s; {1e3 * statistics.median(t):.1f} / {1e3 * max(t):.0f} ms")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="street,room")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--queries", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--solver", default="visgraph")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    print(f"optplan bench over a generated .scen: {args.queries} lines, solver {args.solver}, "
          f"1 seed, workers {args.workers}; load average {os.getloadavg()[0]:.1f}\n")
    print("| map | lines | optplan bench wall s (CPU s) | solving: sum; median / worst "
          "| grading (reference): sum; median / worst | statuses | ratio within 1e-12 of 1 |")
    print("|---|---:|---:|---|---|---|---:|")
    for kind in args.kinds.split(","):
        r = sweep(kind, args.size, args.queries, args.seed, args.solver, args.workers)
        rows = r["rows"]
        st = ", ".join(f"{k} {v}" for k, v in sorted(Counter(x["status"] for x in rows).items()))
        exact = sum(1 for x in rows
                    if x["ratio"] not in ("", "nan") and abs(float(x["ratio"]) - 1) <= 1e-12)
        print(f"| {kind}-{args.size} | {len(rows)} | {r['wall']:.1f} ({r['cpu']:.1f}) "
              f"| {_times(rows, 'wall_time')} | {_times(rows, 'reference_time')} | {st} "
              f"| {exact} |")
    print(f"\nload average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
