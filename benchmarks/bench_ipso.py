"""Speed of the swarm planners: ``ipso-paper`` (50 particles x 200 iterations) and ``ipso``.

1. Wall time (and process CPU time) per run on ``paper-env1`` of the one implementation: the
   compiled fitness kernel ``ObstacleSet.crossings`` and the IPSO step compiled with numba
   (``optplan.swarm.ipso``); targets (issue 12): ``ipso-paper`` <= 40 ms median, ``ipso``
   <= 45 ms median.
2. Where the time of one ``ipso-paper`` run goes: the compiled kernel loop, the Python wrapper
   of ``ObstacleSet.crossings`` around it (local frame, segment arrays, result object), the
   compiled IPSO step (``ga_pairs``, ``advance``, ``absorb``) and the rest (random draws,
   bookkeeping, history, validator).
3. Where the time of one ``ipso`` run goes: the roadmap and its corridor search, the swarm
   iterations, the end-game.
4. Scaling of one ``ipso-paper`` run's time with the number of obstacles (10 / 100 / 1000
   random squares and discs in a 500 x 500 map, obstacle size ~ 1/sqrt(N) so that the
   covered fraction is constant): it must grow sub-linearly.

The first run of a fresh install compiles the numba functions (a few seconds, cached on disk
in ``__pycache__``); every timing here is taken after a warm-up run.

Run: ``.venv/bin/python benchmarks/bench_ipso.py [--runs 15]``.  Prints markdown tables with
medians; the machine is shared, so take the numbers as indicative (the CPU time is less
affected by other jobs than the wall time).

``--against REV [REV ...]`` prints instead one table of this checkout beside the commits
``REV`` in the same session (:mod:`against`: a temporary worktree each, a worker process per
checkout, the runs alternating between them): per solver (``--solvers``, default ``ipso`` and
``ipso-paper``) and map (``--maps``: ``paper-env1``, ``paper-env2``, ``paper-warehouse`` and
the random maps of table 4 with ``random-N``) the median and worst wall and CPU time over
``--seeds`` seeds (30; ``op.solve(problem, solver, rng=seed)`` after one untimed warm-up solve
of the map), the ratio of the medians current / REV and how many runs returned the same status
and paths (float64 bytes). The worker calls only ``op.load_problem``, ``op.parse_problem`` and
``op.solve``, which every commit since 0.4 (98ffc45) has.

    python benchmarks/bench_ipso.py --against 98ffc45
    python benchmarks/bench_ipso.py --against HEAD~3 --solvers ipso --maps paper-env2 --seeds 10
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import optplan as op

sys.path.insert(0, str(Path(__file__).resolve().parent))
import against  # noqa: E402

#: Targets of the median runs on paper-env1 (seconds).
TARGETS = {"ipso-paper": 0.040, "ipso": 0.045}
#: The maps of ``--against`` (catalogue names, ``random-N``: :func:`random_map` of N).
AGAINST_MAPS = ("paper-env1", "paper-env2", "paper-warehouse", "random-10", "random-100",
                "random-1000")


def _time_runs(prob, solver, runs: int, **over) -> tuple[float, float, float]:
    """Median wall time, median CPU time per run, success rate."""
    op.solve(prob, solver, rng=0, **over)  # warm caches (obstacle set) and compiled code
    wall, cpu, ok = [], [], 0
    for s in range(runs):
        t, c = time.perf_counter(), time.process_time()
        r = op.solve(prob, solver, rng=s, **over)
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
        ok += r.success
    return float(np.median(wall)), float(np.median(cpu)), ok / runs


class _Timers:
    """Wall time spent in module functions, installed by replacing them (then restored)."""

    def __init__(self, spec: dict[str, tuple[object, str]]) -> None:
        self.spec = spec
        self.acc = dict.fromkeys(spec, 0.0)
        self.real = {k: getattr(m, n) for k, (m, n) in spec.items()}

    def __enter__(self):
        for key, (mod, name) in self.spec.items():
            setattr(mod, name, self._wrap(key, self.real[key]))
        return self

    def _wrap(self, key, fn):
        def timed(*a, **k):
            t = time.perf_counter()
            out = fn(*a, **k)
            self.acc[key] += time.perf_counter() - t
            return out
        return timed

    def __exit__(self, *exc) -> None:
        for key, (mod, name) in self.spec.items():
            setattr(mod, name, self.real[key])


def _split(prob, solver: str, runs: int, spec: dict) -> tuple[float, dict]:
    """Median run time and the median time per run in each timed function."""
    op.solve(prob, solver, rng=0)
    tot, parts = [], {k: [] for k in spec}
    for s in range(runs):
        with _Timers(spec) as tm:
            t = time.perf_counter()
            op.solve(prob, solver, rng=s)
            tot.append(time.perf_counter() - t)
        for k in spec:
            parts[k].append(tm.acc[k])
    return float(np.median(tot)), {k: float(np.median(v)) for k, v in parts.items()}


def random_map(n: int, seed: int = 0) -> op.Problem:
    rng = np.random.default_rng(seed)
    size = 500.0 * 0.3 / np.sqrt(n)
    obs = []
    for i in range(n):
        c = rng.uniform(30, 470, 2)
        if np.hypot(*(c - 10)) < 3 * size or np.hypot(*(c - 490)) < 3 * size:
            continue
        if i % 2:
            obs.append({"type": "circle", "center": c.tolist(), "radius": size / 2})
        else:
            obs.append({"type": "rectangle", "center": c.tolist(), "size": [size, size]})
    return op.parse_problem({
        "name": f"random-{n}", "bounds": [0.0, 0.0, 500.0, 500.0],
        "robots": [{"id": "r", "start": [10.0, 10.0], "goal": [490.0, 490.0], "radius": 1.0,
                    "max_speed": 1.0}],
        "obstacles": obs,
    })


def _problem(name: str) -> op.Problem:
    """A map of ``--against`` by name."""
    if name.startswith("random-"):
        return random_map(int(name.split("-", 1)[1]))
    return op.load_problem(name)


def worker() -> None:
    """Answer the requests ``solver map seed`` with the run's wall and CPU seconds, status
    and digest (status, robot ids and paths)."""
    probs: dict[str, op.Problem] = {}
    warm: set[tuple[str, str]] = set()

    def answer(words: list[str]) -> dict:
        solver, name, seed = words
        if name not in probs:
            probs[name] = _problem(name)
        if (solver, name) not in warm:  # compiled code, the map's obstacle set
            op.solve(probs[name], solver, rng=0)
            warm.add((solver, name))
        r, wall, cpu = against.timed(lambda: op.solve(probs[name], solver, rng=int(seed)))
        parts: list = [r.status.value]
        for rid in sorted(r.paths):
            parts += [rid, r.paths[rid]]
        return {"wall": wall, "cpu": cpu, "ok": bool(r.success), "digest": against.digest(*parts)}

    against.serve(answer)


def run_against(revs: list[str], solvers: list[str], maps: list[str], seeds: int) -> None:
    """The ``--against`` table: every (solver, map, seed) on every checkout, alternating."""
    load0 = os.getloadavg()
    with against.workers(__file__, revs) as pool:
        out = {(solver, m): against.alternate(pool, [(solver, m, s) for s in range(seeds)])
               for solver in solvers for m in maps}
    load1 = os.getloadavg()
    print(f"\nWarm runs, seeds 0-{seeds - 1} per map, this checkout beside {' '.join(revs)} "
          "(alternating)")
    print(against.load_line(load0, load1) + "\n")
    print(against.table(out, ["solver", "map"], True, "ms", (["success"], lambda rows: [
        f"{sum(r['ok'] for r in rows)}/{len(rows)}"])))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--against", nargs="+", metavar="REV",
                    help="this checkout beside these commits")
    ap.add_argument("--solvers", nargs="+", default=["ipso", "ipso-paper"],
                    help="with --against")
    ap.add_argument("--maps", nargs="+", default=list(AGAINST_MAPS), help="with --against")
    ap.add_argument("--seeds", type=int, default=30, help="with --against: seeds per map")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker()
        return 0
    if args.against:
        run_against(args.against, args.solvers, args.maps, args.seeds)
        return 0
    from optplan.geometry.collision import kernel
    from optplan.swarm import backend as be
    from optplan.swarm import endgame as eg
    from optplan.swarm import ipso as ip
    from optplan.swarm.core import make_space

    print(f"machine: {os.cpu_count()} cores (shared), {platform.processor() or platform.machine()}"
          f", Python {platform.python_version()}, numpy {np.__version__}, load average "
          f"{os.getloadavg()[0]:.1f}")
    print()
    prob = op.load_problem("paper-env1")
    print("### One run on paper-env1 (compiled kernel and IPSO step)")
    print()
    print("| solver | runs (seeds) | median wall time per run (ms) | median CPU time (ms) "
          "| target (ms) | success |")
    print("|---|---|---|---|---|---|")
    median = {}
    for solver in ("ipso-paper", "ipso"):
        median[solver], cpu, ok = _time_runs(prob, solver, args.runs)
        print(f"| {solver} | {args.runs} | {median[solver] * 1e3:.1f} | {cpu * 1e3:.1f} "
              f"| {TARGETS[solver] * 1e3:.0f} | {ok:.0%} |")
    print()
    for solver, t in median.items():
        print(f"{solver}: median {t * 1e3:.1f} ms per run; the <= {TARGETS[solver] * 1e3:.0f} "
              f"ms target is {'met' if t <= TARGETS[solver] else 'NOT met'}.")
    print()

    print("### Where the time of one ipso-paper run on paper-env1 goes")
    print()
    spec = {"kernel": (kernel, "crossings"),
            "crossings": (type(make_space(prob, prob.robots[0], 1).obstacles), "crossings"),
            "step": (ip, "advance"), "pairs": (ip, "ga_pairs"), "absorb": (ip, "absorb")}
    tot, part = _split(prob, "ipso-paper", args.runs, spec)
    step = part["step"] + part["pairs"] + part["absorb"]
    rows = [
        ("compiled kernel loop (`kernel.crossings`: fitness and validator)", part["kernel"]),
        ("`ObstacleSet.crossings` wrapper around it (local frame, segment arrays, result)",
         part["crossings"] - part["kernel"]),
        ("compiled IPSO step (`ga_pairs`, `advance`, `absorb`)", step),
        ("the rest (random draws, bookkeeping, history, validator)",
         tot - part["crossings"] - step),
    ]
    print("| part | median ms per run | per iteration (us) |")
    print("|---|---|---|")
    for label, t in rows:
        print(f"| {label} | {t * 1e3:.1f} | {t / 200 * 1e6:.0f} |")
    print(f"| total | {tot * 1e3:.1f} | {tot / 200 * 1e6:.0f} |")
    print()

    print("### Where the time of one ipso run on paper-env1 goes")
    print()
    spec2 = {"roadmap": (be, "roadmap_corridors"), "iterate": (ip.IPSO, "_iterate"),
             "endgame": (eg, "tighten")}
    tot2, part2 = _split(prob, "ipso", args.runs, spec2)
    k_max = op.get_solver("ipso").k_max
    print("| part | median ms per run |")
    print("|---|---|")
    print(f"| roadmap and corridor search (`roadmap_corridors`) | {part2['roadmap'] * 1e3:.1f} |")
    print(f"| {k_max} swarm iterations (`IPSO._iterate`) | {part2['iterate'] * 1e3:.1f} |")
    print(f"| end-game tightening (`tighten`) | {part2['endgame'] * 1e3:.1f} |")
    print(f"| the rest (initial swarm, validator, ...) | "
          f"{(tot2 - sum(part2.values())) * 1e3:.1f} |")
    print(f"| total | {tot2 * 1e3:.1f} |")
    print()

    print("### Scaling with the number of obstacles (ipso-paper, one run)")
    print()
    print("| obstacles (placed) | kernel items (convex pieces + circles) | grid "
          "| median ms per run | x vs 10 |")
    print("|---|---|---|---|---|")
    base = None
    for n in (10, 100, 1000):
        p = random_map(n)
        obs = make_space(p, p.robots[0], 1).obstacles
        t, _, _ = _time_runs(p, "ipso-paper", max(3, args.runs // 3))
        base = base or t
        grid = "-" if obs.grid is None else f"{obs.grid['nx']} x {obs.grid['ny']}"
        print(f"| {n} ({len(p.obstacles)}) | {obs.n_items} | {grid} | "
              f"{t * 1e3:.1f} | {t / base:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
