"""Time per query of ``sa-apf-paper`` and ``hybrid-paper`` on 32 x 32 MovingAI-type random
maps with 20 % blocked cells (issue 46 item 4), optionally beside an older commit.

Generates ``len(--seeds)`` maps (``optplan.generators.movingai_benchmark("random", 32, ...,
rng=default_rng(seed), density=0.2)``, ``--queries`` lines each) in a temporary directory.  A
worker process per checkout reads the ``.scen`` files (``optplan.maps.read_scen``) and solves
every line with every solver (``op.solve(q, solver, rng=line index)``, the preset's options,
after one warm-up solve), one query at a time on request.  Per solver the table gives the
statuses, the median and worst wall time and CPU time (``time.process_time``) per query, and a
digest: the SHA-256 of every returned path (float64 bytes) and status, in query order.

``--against REV`` checks ``REV`` out in a temporary ``git worktree`` and runs a second worker
on it (``PYTHONPATH`` = the worktree).  The queries alternate between the two workers (the
order swapped every query, never both at once), so the machine's load hits both alike; the
table then gives both checkouts' times, the ratio of the medians (current / REV; below 1 is
faster) and how many queries returned the same answer.  A run stopped by the preset's
``time_limit`` (``stop_reason``) depends on the wall clock, so its answer is left out of the
comparison and counted in the column "time limit" (``--time-limit 1e6``: no run is
stopped).  The load average is printed before and after.

    python benchmarks/bench_sa_apf_grid.py                      # current checkout only
    python benchmarks/bench_sa_apf_grid.py --against HEAD~1     # beside an older commit
    python benchmarks/bench_sa_apf_grid.py --solvers sa-apf-paper --seeds 1001 --queries 5
    python benchmarks/bench_sa_apf_grid.py --solvers hybrid-paper --time-limit 1e6 --against REV
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SOLVERS = ("sa-apf-paper", "hybrid-paper")


def worker(scens: list[str]) -> None:
    """Answer the requests ``solver map line limit`` of standard input with one JSON line
    each (wall and CPU seconds, status, stop reason, the digest of the paths); ``limit`` is
    ``op.solve``'s ``time_limit`` in seconds, ``-`` for the preset's own."""
    import hashlib
    import time

    import optplan as op
    from optplan.maps import read_scen

    probs: dict[tuple[str, int], list] = {}
    warm: set[str] = set()
    for line in sys.stdin:
        solver, m, k, limit = line.split()
        kw = {} if limit == "-" else {"time_limit": float(limit)}
        key = (solver, int(m))
        if key not in probs:  # every solver gets the problems fresh (nothing cached)
            probs[key] = read_scen(scens[int(m)])
        if solver not in warm:  # imports and compiled kernels out of the timed runs
            op.solve(read_scen(scens[0])[0], solver, rng=0)
            warm.add(solver)
        q = probs[key][int(k)]
        c0, t0 = time.process_time(), time.perf_counter()
        res = op.solve(q, solver, rng=int(k), **kw)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        h = hashlib.sha256(res.status.value.encode())
        for rid in sorted(res.paths):
            h.update(rid.encode() + np.ascontiguousarray(res.paths[rid], float).tobytes())
        print(json.dumps({"wall": wall, "cpu": cpu, "status": res.status.value,
                          "stop": res.stop_reason or "", "digest": h.hexdigest()}), flush=True)


class Worker:
    """A worker process of :func:`worker` on the checkout at ``root``."""

    def __init__(self, root: Path, scens: list[str]):
        env = dict(os.environ, PYTHONPATH=str(root))
        self.p = subprocess.Popen([sys.executable, __file__, "--worker", *scens], env=env,
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                  cwd=root)

    def ask(self, solver: str, m: int, k: int, limit: float | None) -> dict:
        """Solve line ``k`` of map ``m`` with ``solver`` (``time_limit`` ``limit``, None: the
        preset's); the worker's JSON answer."""
        assert self.p.stdin is not None and self.p.stdout is not None
        self.p.stdin.write(f"{solver} {m} {k} {'-' if limit is None else limit}\n")
        self.p.stdin.flush()
        out = self.p.stdout.readline()
        if not out:
            raise RuntimeError(f"the worker of {solver} stopped (map {m}, line {k})")
        return json.loads(out)

    def close(self) -> None:
        """End the worker (closing its input ends its loop)."""
        assert self.p.stdin is not None
        self.p.stdin.close()
        self.p.wait()


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


def run(solvers: list[str], seeds: list[int], queries: int, against: str | None,
        limit: float | None = None) -> dict[str, dict[str, list[dict]]]:
    """Every query with every solver on the current checkout (and ``against``), alternating;
    ``{solver: {"current": [...], REV: [...]}}`` of the workers' answers, in query order."""
    with tempfile.TemporaryDirectory() as tmp:
        maps = _maps(seeds, queries, tmp)
        scens = [s for s, _ in maps]
        roots = {"current": ROOT}
        if against:
            wt = Path(tmp) / "against"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt),
                            against], check=True, capture_output=True)
            roots[against] = wt
        workers = {name: Worker(root, scens) for name, root in roots.items()}
        try:
            out: dict[str, dict[str, list[dict]]] = {}
            for solver in solvers:
                out[solver] = {name: [] for name in workers}
                jobs = [(m, k) for m, (_, n) in enumerate(maps) for k in range(n)]
                for j, (m, k) in enumerate(jobs):
                    order = list(workers) if j % 2 == 0 else list(workers)[::-1]
                    for name in order:
                        out[solver][name].append(workers[name].ask(solver, m, k, limit))
                    print(f"  {solver} map {seeds[m]} line {k}: " + ", ".join(
                        f"{name} {r['wall']:.2f} s" for name, r in
                        ((n, out[solver][n][-1]) for n in workers)), file=sys.stderr, flush=True)
            return out
        finally:
            for w in workers.values():
                w.close()
            if against:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                str(Path(tmp) / "against")], check=False, capture_output=True)


def _stats(rows: list[dict]) -> str:
    """``median / worst`` wall and CPU seconds of ``rows``."""
    w = [r["wall"] for r in rows]
    c = [r["cpu"] for r in rows]
    return (f"{statistics.median(w):.2f} / {max(w):.2f} | "
            f"{statistics.median(c):.2f} / {max(c):.2f}")


def table(out: dict[str, dict[str, list[dict]]], against: str | None) -> str:
    """The markdown table: per solver and checkout the statuses, times and digest."""
    import hashlib
    from collections import Counter

    head = ["solver", "checkout", "queries", "statuses", "time limit",
            "wall median / worst (s)", "CPU median / worst (s)", "digest"]
    if against:
        head += [f"median ratio current / {against} (wall, CPU)", "same answer"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for solver, by in out.items():
        cur = by["current"]
        for name, rows in by.items():
            st = Counter(r["status"] for r in rows)
            lim = sum(r["stop"] == "time_limit" for r in rows)
            dig = hashlib.sha256("".join(r["digest"] for r in rows).encode()).hexdigest()[:12]
            cells = [solver, name, str(len(rows)),
                     ", ".join(f"{k} {v}" for k, v in sorted(st.items())), str(lim),
                     *_stats(rows).split(" | "), dig]
            if against:
                cells += _compare(cur, rows) if name != "current" else ["", ""]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _compare(cur: list[dict], old: list[dict]) -> list[str]:
    """The ratio of the medians (wall, CPU) and the queries with the same answer (runs that
    the time limit stopped left out)."""
    rw = statistics.median(r["wall"] for r in cur) / statistics.median(r["wall"] for r in old)
    rc = statistics.median(r["cpu"] for r in cur) / statistics.median(r["cpu"] for r in old)
    both = [(a, b) for a, b in zip(cur, old, strict=True)
            if a["stop"] != "time_limit" and b["stop"] != "time_limit"]
    same = sum(a["digest"] == b["digest"] for a, b in both)
    return [f"{rw:.2f}, {rc:.2f}", f"{same}/{len(both)}"]


def main(argv: list[str] | None = None) -> None:
    """Parse the options, run the queries and print the table with the load average."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    ap.add_argument("--seeds", nargs="+", type=int, default=[1001, 1002, 1003],
                    help="map seeds (one map each)")
    ap.add_argument("--queries", type=int, default=10, help="lines per map")
    ap.add_argument("--against", metavar="REV", help="also run the queries on commit REV")
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
    print(f"Machine: {platform.machine()}, {os.cpu_count()} cores; load average (1, 5, 15 min) "
          f"before {load0[0]:.1f} {load0[1]:.1f} {load0[2]:.1f}, "
          f"after {load1[0]:.1f} {load1[1]:.1f} {load1[2]:.1f}\n")
    print(table(out, a.against))


if __name__ == "__main__":
    main()
