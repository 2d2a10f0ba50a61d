"""The hybrid presets on fresh 32 x 32 MovingAI-type random maps (20 % blocked cells).

Generates ``len(seeds)`` maps (``optplan.generators.movingai_benchmark("random", 32, ...,
rng=default_rng(seed))``, ``--queries`` lines each) in a temporary directory, solves every
line with every solver (``rng`` = the line's index, ``reference=True``) and prints per
solver: the collision-free count (no contact in the validator's metrics and no run stopped at
a step the step guard found crossing an obstacle or the bounds), the statuses, how many runs
the time limit stopped, the median and worst wall time and the median and worst ratio of the
path to the certified optimum over the solved runs.  ``--detail`` also prints every run that
is not solved: what ended it and where (docs/solvers/hybrid.md, "Grid maps").

    python benchmarks/bench_hybrid_grid.py --seeds 1001 1002 1003 --queries 10
    python benchmarks/bench_hybrid_grid.py --solvers hybrid-paper hybrid-qp --detail \\
        --set leader_safe_step=true
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
import tempfile
import time
from collections import Counter
from typing import Any

import numpy as np

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen

_STEP = re.compile(r"collision: (\S+)'s step from \(([^)]*)\) to \(([^)]*)\) at t=([\d.]+) s "
                   r"(.*)")


def collided(res: op.Result) -> bool:
    """A contact in the validator's metrics, or a run stopped at a step that would cross an
    obstacle or the bounds (the step guard's ``collision: ...`` message)."""
    m = res.metrics
    return bool(m.get("collisions") or m.get("static_collisions")
                or res.message.startswith("collision"))


def classify(res: op.Result, bounds: tuple[float, float, float, float]) -> str:
    """Where a run that is not solved ended: the stage, the step, the obstacle."""
    m = _STEP.match(res.message)
    if m:
        end = np.array([float(v) for v in m.group(3).split(",")])
        x0, y0, x1, y1 = bounds
        where = ("leaves the map" if not (x0 <= end[0] <= x1 and y0 <= end[1] <= y1)
                 else m.group(5)[:60])
        return f"local step (guard) at t={m.group(4)} s to ({m.group(3)}): {where}"
    if res.stop_reason == "time_limit":
        return "time limit: " + res.message[:90]
    return res.message[:110]


def run(solvers: list[str], seeds: list[int], queries: int, overrides: dict[str, Any],
        detail: bool) -> list[dict[str, Any]]:
    """Solve every line of every map with every solver; one row per solver."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        probs = []
        for s in seeds:
            g = movingai_benchmark("random", 32, f"{tmp}/{s}", rng=np.random.default_rng(s),
                                   queries=queries, density=0.2)
            probs += [(s, k, q) for k, q in enumerate(read_scen(str(g.map_path) + ".scen"))]
        for name in solvers:
            out = []
            for s, k, q in probs:
                t0 = time.perf_counter()
                res = op.solve(q, name, rng=k, reference=True, **overrides)
                out.append((s, k, q, res, time.perf_counter() - t0))
                if detail and not res.success:
                    print(f"  {name} map {s} line {k}: {res.status.value}; "
                          f"{classify(res, q.bounds)}", flush=True)
            rows.append(_row(name, seeds, out))
    return rows


def _row(name: str, seeds: list[int], out: list) -> dict[str, Any]:
    times = [t for *_, t in out]
    ratios = [r.metrics["ratio_to_optimum"] for _, _, _, r, _ in out
              if r.success and "ratio_to_optimum" in r.metrics]
    st = Counter(r.status.value for _, _, _, r, _ in out)
    return {
        "solver": name, "seeds": ",".join(map(str, seeds)), "queries": len(out),
        "collision_free": sum(not collided(r) for _, _, _, r, _ in out),
        "statuses": ", ".join(f"{k} {v}" for k, v in sorted(st.items())),
        "time_limit": sum(r.stop_reason == "time_limit" for _, _, _, r, _ in out),
        "long_note": sum("the certified optimum" in r.message for _, _, _, r, _ in out),
        "t_med": statistics.median(times), "t_max": max(times),
        "r_med": statistics.median(ratios) if ratios else math.nan,
        "r_max": max(ratios) if ratios else math.nan,
    }


def table(rows: list[dict[str, Any]]) -> str:
    head = ("| solver | map seeds | queries | collision-free | statuses | time limit | "
            "> 3x note | median / worst time (s) | median / worst ratio (solved) |")
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        lines.append(f"| {r['solver']} | {r['seeds']} | {r['queries']} | "
                     f"{r['collision_free']}/{r['queries']} | {r['statuses']} | "
                     f"{r['time_limit']} | {r['long_note']} | {r['t_med']:.2f} / "
                     f"{r['t_max']:.1f} | {r['r_med']:.2f} / {r['r_max']:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--solvers", nargs="+", default=["hybrid-qp"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[1001, 1002, 1003])
    ap.add_argument("--queries", type=int, default=10, help="lines per map")
    ap.add_argument("--set", nargs="*", default=[], metavar="OPTION=JSON",
                    help="option overrides, e.g. leader_safe_step=true time_limit=null")
    ap.add_argument("--detail", action="store_true", help="print every run not solved")
    a = ap.parse_args(argv)
    overrides = {k: json.loads(v) for k, v in (s.split("=", 1) for s in a.set)}
    rows = run(a.solvers, a.seeds, a.queries, overrides, a.detail)
    what = f" ({', '.join(a.set)})" if a.set else ""
    print(f"\nHybrid presets on 32 x 32 random maps, 20 % blocked{what}\n")
    print(table(rows))


if __name__ == "__main__":
    main()
