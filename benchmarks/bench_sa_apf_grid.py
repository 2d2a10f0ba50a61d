"""Time per query of ``sa-apf-paper`` and ``hybrid-paper`` on 32 x 32 MovingAI-type random
maps with 20 % blocked cells (issue 46 item 4), optionally beside an older commit.

Generates ``len(--seeds)`` maps (``optplan.generators.movingai_benchmark("random", 32, ...,
rng=default_rng(seed), density=0.2)``, ``--queries`` lines each) in a temporary directory.  A
worker process per checkout reads the ``.scen`` files (``optplan.maps.read_scen``) and solves
every line with every solver (``op.solve(q, solver, rng=line index)``, the preset's options,
after one warm-up solve), one query at a time on request.  Per solver the table gives the
statuses, the median and worst wall time and CPU time (``time.process_time``) per query, and a
digest: the SHA-256 of every returned path (float64 bytes) and status, in query order.

``--against REV [REV ...]`` checks each ``REV`` out in a temporary ``git worktree`` and runs a
worker on it (``PYTHONPATH`` = the worktree; :mod:`against`). The queries alternate between the
workers (the order reversed every query, never two at once), so the machine's load hits all
alike; the table then gives every checkout's times, the ratio of the medians (current / REV;
below 1 is faster) and how many queries returned the same answer. A run stopped by the preset's
``time_limit`` (``stop_reason``) depends on the wall clock, so its answer is left out of the
comparison and counted in the column "time limit" (``--time-limit 1e6``: no run is stopped).
The load average is printed before and after.

    python benchmarks/bench_sa_apf_grid.py                      # current checkout only
    python benchmarks/bench_sa_apf_grid.py --against HEAD~1     # beside an older commit
    python benchmarks/bench_sa_apf_grid.py --solvers sa-apf-paper --seeds 1001 --queries 5
    python benchmarks/bench_sa_apf_grid.py --solvers hybrid-paper --time-limit 1e6 --against REV
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import against  # noqa: E402

SOLVERS = ("sa-apf-paper", "hybrid-paper")


def worker(scens: list[str]) -> None:
    """Answer the requests ``solver map line limit`` of standard input with one JSON line
    each (wall and CPU seconds, status, stop reason, the digest of the paths); ``limit`` is
    ``op.solve``'s ``time_limit`` in seconds, ``-`` for the preset's own."""
    import optplan as op
    from optplan.maps import read_scen

    probs: dict[tuple[str, int], list] = {}
    warm: set[str] = set()

    def answer(words: list[str]) -> dict:
        solver, m, k, limit = words
        kw = {} if limit == "-" else {"time_limit": float(limit)}
        key = (solver, int(m))
        if key not in probs:  # every solver gets the problems fresh (nothing cached)
            probs[key] = read_scen(scens[int(m)])
        if solver not in warm:  # imports and compiled kernels out of the timed runs
            op.solve(read_scen(scens[0])[0], solver, rng=0)
            warm.add(solver)
        q = probs[key][int(k)]
        res, wall, cpu = against.timed(lambda: op.solve(q, solver, rng=int(k), **kw))
        parts = [res.status.value]
        for rid in sorted(res.paths):
            parts += [rid, res.paths[rid]]
        return {"wall": wall, "cpu": cpu, "status": res.status.value,
                "stop": res.stop_reason or "", "digest": against.digest(*parts)}

    against.serve(answer)


def _maps(seeds: list[int], queries: int, tmp: str) -> list[tuple[str, int]]:
    """Write the maps; their ``.scen`` paths and line counts."""
    from optplan.generators import movingai_benchmark
    from optplan.maps import read_scen

    out = []
    for s in seeds:
        g = movingai_benchmark("random", 32, f"{tmp}/{s}", rng=np.random.default_rng(s),
                               queries=queries, density=0.2)
        scen = str(g.map_path) + ".scen"
        out.append((scen, len(read_scen(scen))))
    return out


def run(solvers: list[str], seeds: list[int], queries: int, revs: list[str],
        limit: float | None = None) -> dict[str, dict[str, list[dict]]]:
    """Every query with every solver on the current checkout (and ``revs``), alternating;
    ``{solver: {"current": [...], REV: [...]}}`` of the workers' answers, in query order."""
    with tempfile.TemporaryDirectory() as tmp:
        maps = _maps(seeds, queries, tmp)
        lim = "-" if limit is None else limit
        with against.workers(__file__, revs, [s for s, _ in maps]) as pool:
            return {solver: against.alternate(
                pool, [(solver, m, k, lim) for m, (_, n) in enumerate(maps) for k in range(n)])
                for solver in solvers}


def table(out: dict[str, dict[str, list[dict]]], revs: list[str]) -> str:
    """The markdown table: per solver and checkout the statuses, time-limited runs, times and
    digest (:func:`against.table`; runs that the time limit stopped are left out of the
    comparison)."""
    from collections import Counter

    def extra(rows: list[dict]) -> list[str]:
        st = Counter(r["status"] for r in rows)
        return [", ".join(f"{k} {v}" for k, v in sorted(st.items())),
                str(sum(r["stop"] == "time_limit" for r in rows))]

    return against.table({(s,): by for s, by in out.items()}, ["solver"], bool(revs), "s",
                         (["statuses", "time limit"], extra),
                         lambda r: r["stop"] != "time_limit")


def main(argv: list[str] | None = None) -> None:
    """Parse the options, run the queries and print the table with the load average."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    ap.add_argument("--seeds", nargs="+", type=int, default=[1001, 1002, 1003],
                    help="map seeds (one map each)")
    ap.add_argument("--queries", type=int, default=10, help="lines per map")
    ap.add_argument("--against", nargs="+", default=[], metavar="REV",
                    help="also run the queries on these commits")
    ap.add_argument("--time-limit", type=float, metavar="S",
                    help="op.solve's time_limit (default: the preset's; hybrid-paper 60 s)")
    ap.add_argument("--worker", nargs="+", metavar="SCEN", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker(a.worker)
        return
    load0 = os.getloadavg()
    out = run(a.solvers, a.seeds, a.queries, a.against, a.time_limit)
    load1 = os.getloadavg()
    print(f"\n{a.queries} queries on each of {len(a.seeds)} 32 x 32 random maps, 20 % blocked "
          f"(map seeds {' '.join(map(str, a.seeds))}; rng = line index; time_limit "
          f"{'of the preset' if a.time_limit is None else f'{a.time_limit:g} s'})")
    print(against.load_line(load0, load1) + "\n")
    print(table(out, a.against))


if __name__ == "__main__":
    main()
