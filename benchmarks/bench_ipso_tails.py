"""Tails of the swarm planners: worst ratio to the certified optimum over many seeds per map.

For every map (the known static maps of the paper scenes ``paper-env1``, ``paper-env2``,
``paper-hybrid``, ``paper-warehouse`` and the generated corridor family
:func:`optplan.generators.corridor_scene`: walls with narrow doors, shelf rows, U traps) and
every seed ``0 .. --seeds-1`` each solver runs once; the ratio of its path length to the
certified optimum (:func:`optplan.geometry.tangent.tangent_graph.problem_shortest_path`, computed
once per map) is recorded for the collision-free runs.  Printed (markdown):

1. ``ipso`` per map: collision-free runs, median and worst ratio, runs above 1.01 and 1.001,
   median and worst wall time and median CPU time (``time.process_time``: what a busy shared
   machine inflates less) per run (``optplan.solve``, warm: the map's obstacle set and
   the NLP's first CasADi build on the map are made before the timed runs), and ``ipso`` +
   NLP polish (``nlp-ipopt`` warm-started from the ``ipso`` path): worst ratio, runs above
   1.001, median and worst total time (``--no-nlp`` skips it).  The worst times are single
   runs on a shared machine.
2. The ablation table: every ``ipso`` variant with one addition switched off, per map the worst
   ratio, and over all maps the runs above 1.01 / 1.001, the collision-free runs and the median
   time.
3. The paper presets (``pso-paper``, ``mpso-paper``, ``ipso-paper``): collision-free runs and
   median / worst ratio per map.

A failed run (not collision-free, or not at the goal) counts as ratio ``inf``.  The targets
(issue 18): 100 % collision-free, worst ratio <= 1.01 on every map, median <= 1.002, median
wall time <= 40 ms, ``ipso`` + NLP <= 1.001 on every seed within 250 ms.  Nothing is
hard-coded: every number is measured by this run.

Run: ``.venv/bin/python benchmarks/bench_ipso_tails.py [--seeds 30] [--corridor-seeds 0 1]
[--solvers ...] [--ablations ...] [--no-nlp] [--no-paper] [--lengths FILE]``.  The machine is
shared, so take the times as indicative.  ``--lengths FILE`` writes the NLP-polished statuses
and lengths to ``FILE`` (when it does not exist) or compares this run's with them (largest
relative length difference, status changes): run it once with the code before a speed change
and once after.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

import optplan as op
from optplan.generators import CORRIDOR_KINDS, corridor_scene
from optplan.geometry.tangent.tangent_graph import problem_shortest_path

PAPER_MAPS = ("paper-env1", "paper-env2", "paper-hybrid", "paper-warehouse")

#: ``ipso`` with one addition beyond the paper switched off or changed (name, overrides).
ABLATIONS = (
    ("ipso", {}),
    ("the paper's 200 iterations", {"k_max": 200}),
    ("25 iterations", {"k_max": 25}),
    ("no swarm iterations", {"k_max": 0}),
    ("no roadmap seeds", {"init_mode": "sorted"}),
    ("one roadmap corridor", {"corridors": 1}),
    ("no boundary / corner samples", {"roadmap_boundary": 0}),
    ("no medial-axis samples", {"roadmap_medial": 0}),
    ("end-game on islands only", {"endgame": "islands"}),
    ("no end-game", {"tighten_rounds": 0}),
    ("one island", {"islands": 1}),
    ("the text's fragment-swap crossover", {"crossover": "swap"}),
)


def maps(corridor_seeds: list[int]) -> list[tuple[str, op.Problem]]:
    """The known static maps of the paper scenes and the generated corridor maps."""
    out = [(n, op.load_problem(n).known_view()) for n in PAPER_MAPS]
    out += [(f"{k}-{s}", corridor_scene(k, s)) for k in CORRIDOR_KINDS for s in corridor_seeds]
    return out


def run_solver(prob: op.Problem, optimum: float, solver: str, seeds: int,
               nlp: bool = False, **over) -> dict:
    """Ratios, times (and NLP-polished ratios / total times) of one solver over the seeds."""
    warm = op.solve(prob, solver, rng=0, **over)  # warm: obstacle set, compiled code
    if nlp and warm.success:  # and the NLP's first build on this map (CasADi structures)
        op.solve(prob, "nlp-ipopt", init=warm.paths)
    ratio, times, cpu, pol, pol_t, pol_only, ok = [], [], [], [], [], [], 0
    polished: list[tuple[str, float]] = []
    for s in range(seeds):
        t, c = time.perf_counter(), time.process_time()
        r = op.solve(prob, solver, rng=s, **over)
        dt = time.perf_counter() - t
        cpu.append(time.process_time() - c)
        times.append(dt)
        ok += bool(r.success)
        ratio.append(r.metrics["length"] / optimum if r.success else np.inf)
        if nlp:
            t = time.perf_counter()
            q = op.solve(prob, "nlp-ipopt", init=r.paths)
            pol_only.append(time.perf_counter() - t)
            polished.append((q.status.name, float(q.metrics["length"])))
            pol_t.append(dt + pol_only[-1])
            pol.append(q.metrics["length"] / optimum if q.success else np.inf)
    return {"ratio": np.array(ratio), "time": np.array(times), "cpu": np.array(cpu), "ok": ok,
            "nlp": np.array(pol), "nlp_time": np.array(pol_t), "polish_time": np.array(pol_only),
            "polished": polished}


def _f(x: float, nd: int = 4) -> str:
    return "fail" if not np.isfinite(x) else f"{x:.{nd}f}"


def _lengths_file(path: str, polished: dict[str, list]) -> str:
    """Write ``polished`` ({map: [(status, length) per seed]}) to ``path`` when it does not
    exist, else compare with it: the largest relative length difference and the status
    changes (the check that a speed change returns the same paths)."""
    if not os.path.exists(path):
        with open(path, "w") as f:
            json.dump(polished, f)
        return f"polished statuses and lengths written to {path}"
    with open(path) as f:
        ref = json.load(f)
    rel, changed, n = 0.0, 0, 0
    for m, rows in polished.items():
        for (st, ln), (st0, ln0) in zip(rows, ref.get(m, [])):
            n += 1
            changed += st != st0
            rel = max(rel, abs(ln / ln0 - 1.0) if ln0 else abs(ln))
    return (f"polished paths against {path} ({n} runs): largest relative length difference "
            f"{rel:.1e}, status changes {changed}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--corridor-seeds", type=int, nargs="*", default=[0, 1],
                    help="seeds of the generated corridor maps (each kind)")
    ap.add_argument("--ablations", nargs="*", default=None,
                    help="ablation names to run (default: all; none: skip the table)")
    ap.add_argument("--no-nlp", action="store_true", help="skip ipso + NLP polish")
    ap.add_argument("--no-paper", action="store_true", help="skip the paper presets")
    ap.add_argument("--maps", nargs="*", default=None, help="only these map names")
    ap.add_argument("--lengths", default=None,
                    help="JSON file of the polished statuses and lengths: written when absent, "
                         "else compared with this run's")
    args = ap.parse_args(argv)
    t_all = time.perf_counter()
    print(f"machine: {os.cpu_count()} cores (shared), {platform.processor() or platform.machine()}"
          f", Python {platform.python_version()}, numpy {np.__version__}; "
          f"{args.seeds} seeds per map; load average {os.getloadavg()[0]:.2f} at the start")
    print()
    todo = maps(args.corridor_seeds)
    if args.maps:
        todo = [(n, p) for n, p in todo if n in args.maps]
    opt = {n: problem_shortest_path(p, p.planned_robots[0]).length for n, p in todo}

    # 1. ipso per map (+ NLP polish)
    res = {n: run_solver(p, opt[n], "ipso", args.seeds, nlp=not args.no_nlp) for n, p in todo}
    print("### `ipso` per map (ratio = length / certified optimum)")
    print()
    head = ("| map | optimum | collision-free | median | worst | > 1.01 | > 1.001 "
            "| median ms | worst ms | median CPU ms |")
    sep = "|---|---|---|---|---|---|---|---|---|---|"
    if not args.no_nlp:
        head += " + NLP worst | + NLP > 1.001 | + NLP median ms | + NLP worst ms |"
        sep += "---|---|---|---|"
    print(head)
    print(sep)
    for n, _ in todo:
        d = res[n]
        row = (f"| {n} | {opt[n]:.2f} | {d['ok']}/{args.seeds} | {_f(np.median(d['ratio']))} "
               f"| {_f(d['ratio'].max())} | {(d['ratio'] > 1.01).sum()} "
               f"| {(d['ratio'] > 1.001).sum()} | {np.median(d['time']) * 1e3:.1f} "
               f"| {d['time'].max() * 1e3:.1f} | {np.median(d['cpu']) * 1e3:.1f} |")
        if not args.no_nlp:
            row += (f" {_f(d['nlp'].max())} | {(d['nlp'] > 1.001).sum()} "
                    f"| {np.median(d['nlp_time']) * 1e3:.0f} | {d['nlp_time'].max() * 1e3:.0f} |")
        print(row)
    allr = np.concatenate([res[n]["ratio"] for n, _ in todo])
    allt = np.concatenate([res[n]["time"] for n, _ in todo])
    print()
    print(f"ipso over all {len(allr)} runs: collision-free {np.isfinite(allr).sum()}, median "
          f"{_f(np.median(allr))}, worst {_f(allr.max())}, above 1.01: {(allr > 1.01).sum()}, "
          f"above 1.001: {(allr > 1.001).sum()}; median wall time {np.median(allt) * 1e3:.1f}"
          f" ms, worst {allt.max() * 1e3:.1f} ms (per-map medians "
          f"{min(np.median(res[n]['time']) for n, _ in todo) * 1e3:.1f}"
          f" - {max(np.median(res[n]['time']) for n, _ in todo) * 1e3:.1f} ms; median CPU time "
          f"{np.median(np.concatenate([res[n]['cpu'] for n, _ in todo])) * 1e3:.1f} ms, "
          f"per-map medians {min(np.median(res[n]['cpu']) for n, _ in todo) * 1e3:.1f} - "
          f"{max(np.median(res[n]['cpu']) for n, _ in todo) * 1e3:.1f} ms)")
    if not args.no_nlp:
        alln = np.concatenate([res[n]["nlp"] for n, _ in todo])
        allnt = np.concatenate([res[n]["nlp_time"] for n, _ in todo])
        allpt = np.concatenate([res[n]["polish_time"] for n, _ in todo])
        print(f"ipso + NLP polish: worst {_f(alln.max())}, above 1.001: {(alln > 1.001).sum()}"
              f"/{len(alln)}; median total time {np.median(allnt) * 1e3:.0f} ms, max "
              f"{allnt.max() * 1e3:.0f} ms, above 250 ms: {(allnt > 0.25).sum()}; the polish "
              f"alone: median {np.median(allpt) * 1e3:.0f} ms, max {allpt.max() * 1e3:.0f} ms")
        if args.lengths:
            print(_lengths_file(args.lengths, {n: res[n]["polished"] for n, _ in todo}))
    print()

    # 2. ablations
    names = [a for a, _ in ABLATIONS] if args.ablations is None else args.ablations
    abl = [(a, o) for a, o in ABLATIONS if a in names]
    if abl:
        print("### Ablations of `ipso` (worst ratio per map; counts and times over all maps)")
        print()
        print("| variant | options | " + " | ".join(n for n, _ in todo)
              + " | collision-free | > 1.01 | > 1.001 | median ms |")
        print("|---|---|" + "---|" * len(todo) + "---|---|---|---|")
        for a, o in abl:
            rr = {n: res[n] if not o else run_solver(p, opt[n], "ipso", args.seeds, **o)
                  for n, p in todo}
            r_all = np.concatenate([rr[n]["ratio"] for n, _ in todo])
            t_med = np.median(np.concatenate([rr[n]["time"] for n, _ in todo]))
            opts = ", ".join(f"{k}={v}" for k, v in o.items()) or "(preset)"
            print(f"| {a} | {opts} | " + " | ".join(_f(rr[n]["ratio"].max()) for n, _ in todo)
                  + f" | {np.isfinite(r_all).sum()}/{len(r_all)} | {(r_all > 1.01).sum()} "
                  f"| {(r_all > 1.001).sum()} | {t_med * 1e3:.1f} |", flush=True)
        print()

    # 3. the paper presets
    if not args.no_paper:
        print("### Paper presets (collision-free runs, median / worst ratio)")
        print()
        pres = ("pso-paper", "mpso-paper", "ipso-paper")
        print("| map | " + " | ".join(pres) + " |")
        print("|---|" + "---|" * len(pres))
        for n, p in todo:
            cells = []
            for solver in pres:
                d = run_solver(p, opt[n], solver, args.seeds)
                cells.append(f"{d['ok']}/{args.seeds}, {_f(np.median(d['ratio']), 3)} / "
                             f"{_f(d['ratio'].max(), 3)}")
            print(f"| {n} | " + " | ".join(cells) + " |", flush=True)
        print()
    print(f"(total {time.perf_counter() - t_all:.0f} s; load average "
          f"{os.getloadavg()[0]:.2f} at the end)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
