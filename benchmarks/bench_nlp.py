"""Speed and quality of the waypoint NLP (``nlp-ipopt``) as a reference and as a polisher.

Table 1 (polish, ``paper-env1``): for seeds ``0 .. --seeds-1`` each heuristic (the presets
``ipso-paper`` and ``ipso``) is solved, then the NLP is warm-started from its path.  Medians
of the heuristic time, the NLP time and their sum, the lengths and the gap to the certified
visgraph optimum.  Target (issue 4): IPSO + NLP polish
<= 250 ms median.

Table 2 (reference): the NLP started from the visgraph path (no ``init``) on the paper maps
in both clearance modes, temporary obstacles included (``see_temporary = true``): status,
length ratio to visgraph, IPOPT iterations and the median wall time over ``--reps`` runs.

Run: ``python benchmarks/bench_nlp.py [--seeds 15] [--reps 5]``.  Timings are wall-clock
medians on a shared machine; the printed header says how many cores it has and its load.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import optplan as op

TARGET_MS = 250.0


def _ms(xs: list[float]) -> str:
    return f"{statistics.median(xs) * 1e3:.0f}"


def polish_table(problem: str, heuristic: str, seeds: int) -> str:
    prob = op.load_problem(problem)
    rid = prob.leader.id
    L_opt = op.solve(prob, "visgraph").metrics["length"]
    op.solve(prob, "nlp-ipopt")  # build the CasADi structures once (not timed)
    th, tn, tt, Lh, Ln, gh, gn, st, fh = [], [], [], [], [], [], [], [], []
    for s in range(seeds):
        t0 = time.perf_counter()
        h = op.solve(prob, heuristic, rng=s)
        t1 = time.perf_counter()
        n = op.solve(prob, "nlp-ipopt", init={rid: h.paths[rid]})
        t2 = time.perf_counter()
        th.append(t1 - t0)
        tn.append(t2 - t1)
        tt.append(t2 - t0)
        Lh.append(h.metrics["length"])
        Ln.append(n.metrics["length"])
        gh.append(100 * (h.metrics["length"] / L_opt - 1))
        gn.append(100 * (n.metrics["length"] / L_opt - 1))
        st.append(n.status.value)
        fh.append(bool(h.metrics["feasible"] and h.metrics["reached"]))
    ok = sum(x == "optimal" for x in st)
    tot = statistics.median(tt) * 1e3
    lines = [
        "| problem | heuristic | seeds | t heuristic ms | t NLP ms | t total ms | target ms "
        "| heuristic feasible | L heuristic | L NLP | gap heuristic % | gap NLP % | NLP optimal |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        f"| {problem} | {heuristic} | {seeds} | {_ms(th)} | {_ms(tn)} | {tot:.0f} "
        f"| {TARGET_MS:.0f} ({'met' if tot <= TARGET_MS else 'NOT met'}) | {sum(fh)}/{seeds} "
        f"| {statistics.median(Lh):.3f} | {statistics.median(Ln):.3f} "
        f"| {statistics.median(gh):.3f} | {statistics.median(gn):.4f} | {ok}/{seeds} |",
    ]
    return "\n".join(lines)


def reference_table(problems: list[str], reps: int) -> str:
    lines = ["| problem | clearance mode | status | L visgraph | L NLP | ratio | iterations "
             "| pairs | t NLP ms |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|"]
    for name in problems:
        prob = op.load_problem(name)
        rid = prob.leader.id
        vg = op.solve(prob, "visgraph", see_temporary=True)
        for mode in ("exact", "inscribed"):
            ts = []
            for _ in range(reps + 1):
                t0 = time.perf_counter()
                r = op.solve(prob, "nlp-ipopt", clearance_mode=mode, see_temporary=True)
                ts.append(time.perf_counter() - t0)
            e = r.extras["ipopt"][rid]
            lines.append(
                f"| {name} | {mode} | {r.status.value} | {vg.metrics['length']:.3f} "
                f"| {r.metrics['length']:.3f} | {r.metrics['length'] / vg.metrics['length']:.6f} "
                f"| {e['iterations']} | {e['n_pairs']} | {_ms(ts[1:])} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=15)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--problem", default="paper-env1")
    args = ap.parse_args(argv)
    heuristics = [h for h in ("ipso-paper", "ipso") if h in op.list_solvers()] or ["ipso"]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"Machine: {platform.machine()}, {os.cpu_count()} cores, load average {load:.1f} "
          f"(shared with other jobs); Python {platform.python_version()}.\n")
    print(f"### IPSO + NLP polish ({args.problem})\n")
    for i, h in enumerate(heuristics):
        table = polish_table(args.problem, h, args.seeds)
        print(table if i == 0 else table.split("\n", 2)[2])
    print("\n### NLP from the visgraph path (reference consistency)\n")
    print(reference_table(["paper-env1", "paper-env2", "paper-warehouse"], args.reps))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
