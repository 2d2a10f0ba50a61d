"""Benchmarks at scale: a 2,000-run sweep into the SQLite results database, three engines.

The sweep: the four paper path scenes (``paper-env1``, ``paper-env2``, ``paper-apf-env1``,
``paper-apf-env2``) x five path presets (``visgraph``, ``pso-paper``, ``ipso-paper``,
``mpso-paper``, ``apf-paper``) x 100 seeds = 2,000 runs.  To keep the whole script within a few
minutes on two cores the three swarm presets run with ``k_max = 50`` instead of the paper's 200
(``--k-max``); the slow presets (``sa-apf-paper``, ``nlp-ipopt``: 1-2 s and 0.2-0.8 s per run)
are left out.

The same sweep runs three times, each into a new database: inline (``Engine()``), on the
process pool (``Engine(workers=2)``) and on a Dask ``LocalCluster`` of two worker processes
(``Engine(dask_local=2)``; skipped when ``dask[distributed]`` is missing).  For each it prints the
wall time (including starting the pool or the cluster), runs per second, the median per-run
wall time as recorded in the database (to show contention between workers), the database
size, the 1-minute load average before and after (other work on the machine skews every
figure), and checks that the three databases hold the same rows (statuses, lengths, ratios,
iterations; times excepted).  Then it times ``optplan report`` on the inline database.

Run: ``python benchmarks/bench_sweep.py [--seeds 100] [--k-max 50] [--out runs/bench_sweep]``
(the databases and the report stay in ``--out``).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import shutil
import statistics
import sys
import time
from pathlib import Path

from optplan import bench
from optplan.benchdb import read_runs
from optplan.report import write_report

SCENES = ("paper-env1", "paper-env2", "paper-apf-env1", "paper-apf-env2")
PRESETS = ("visgraph", "pso-paper", "ipso-paper", "mpso-paper", "apf-paper")
SWARMS = ("pso-paper", "ipso-paper", "mpso-paper")
VOLATILE = ("wall_time", "reference_time")


def _key(r: dict) -> tuple:
    return (r["problem"], r["solver"], r["seed"])


def _same(a: list[dict], b: list[dict]) -> bool:
    a, b = sorted(a, key=_key), sorted(b, key=_key)
    if len(a) != len(b):
        return False
    for x, y in zip(a, b):
        for k in bench.COLUMNS:
            if k in VOLATILE:
                continue
            u, v = x[k], y[k]
            if isinstance(u, float) and isinstance(v, float) and math.isnan(u) and math.isnan(v):
                continue
            if u != v:
                return False
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=100, help="seeds per cell (default 100)")
    ap.add_argument("--k-max", type=int, default=50,
                    help="iterations of the swarm presets (default 50; the paper: 200)")
    ap.add_argument("--out", default="runs/bench_sweep", help="databases and report")
    ap.add_argument("--engines", default="inline,workers2,dask2",
                    help="comma-separated subset of inline, workers2, dask2")
    args = ap.parse_args(argv)
    out = Path(args.out)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    overrides = {s: {"k_max": args.k_max} for s in SWARMS}
    n = len(SCENES) * len(PRESETS) * args.seeds
    print(f"sweep: {len(SCENES)} paper scenes x {len(PRESETS)} path presets x {args.seeds} "
          f"seeds = {n} runs; swarm presets with k_max = {args.k_max}")
    print(f"machine: {platform.node()}, {os.cpu_count()} CPUs, {platform.platform()}, Python "
          f"{sys.version.split()[0]}")
    engines = {"inline": bench.Engine(), "workers2": bench.Engine(workers=2),
               "dask2": bench.Engine(dask_local=2)}
    chosen = [e.strip() for e in args.engines.split(",") if e.strip()]
    results = {}
    for name in chosen:
        engine = engines[name]
        if engine.uses_dask:
            try:
                import distributed  # noqa: F401
            except ImportError:
                print(f"{name}: skipped (dask[distributed] is not installed)")
                continue
        db = out / f"{name}.sqlite"
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        bench.run_grid(SCENES, PRESETS, seeds=args.seeds, engine=engine,
                       overrides=overrides, db=db,
                       command_line=f"benchmarks/bench_sweep.py ({name})")
        wall = time.perf_counter() - t0
        rows = read_runs(db)
        per_run = statistics.median(r["wall_time"] for r in rows if r["status"] != "error")
        results[name] = {"wall": wall, "rows": rows, "size": db.stat().st_size,
                         "per_run": per_run, "load": (load0, os.getloadavg()[0]),
                         "errors": sum(r["status"] == "error" for r in rows)}
    print()
    print("| engine | runs | wall time (s) | runs/s | median run wall time (ms) | errors "
          "| database (MB) | same rows as inline | load average before / after |")
    print("|---|---:|---:|---:|---:|---:|---:|:---|---:|")
    base = results.get("inline", {}).get("rows")
    label = {"inline": "inline (workers 1)", "workers2": "process pool (--workers 2)",
             "dask2": "Dask LocalCluster (--dask-local 2)"}
    for name, r in results.items():
        same = "-" if base is None or name == "inline" else (
            "yes" if _same(base, r["rows"]) else "NO")
        print(f"| {label[name]} | {len(r['rows'])} | {r['wall']:.1f} | "
              f"{len(r['rows']) / r['wall']:.1f} | {1e3 * r['per_run']:.1f} | {r['errors']} | "
              f"{r['size'] / 1e6:.2f} | {same} | {r['load'][0]:.1f} / {r['load'][1]:.1f} |")
    first = next(iter(results), None)
    if first is not None:
        db = out / f"{first}.sqlite"
        t0 = time.perf_counter()
        index = write_report(db, out / "report")
        t_rep = time.perf_counter() - t0
        n_png = len(list(index.parent.glob("*.png")))
        print()
        print(f"optplan report {db} --out {out / 'report'}: {t_rep:.1f} s "
              f"({n_png} PNGs + index.html, {len(SCENES)} problems)")
    bad = [k for k, r in results.items() if base is not None and not _same(base, r["rows"])]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
