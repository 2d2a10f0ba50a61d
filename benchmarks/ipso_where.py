"""Where one ``ipso`` run and one NLP polish spend their time on a map (issue 18).

For each map (default ``shelves-1`` and ``doors-0`` of :func:`optplan.generators.corridor_scene`;
the paper scene names also work) and seeds ``0 .. --seeds-1``, after a warm-up run:

1. ``ipso``: median wall time of the run and of its parts (the roadmap: nodes, edge tests,
   the rest of :func:`~optplan.swarm.roadmap.build_roadmap`; the corridor search
   :func:`~optplan.swarm.roadmap._k_classes`; the swarm iterations; the end-game
   :func:`~optplan.swarm.refine.tighten`), and the median number of roadmap segments
   tested (neighbour and Yao edges, corner pairs) and of labels of the corridor search.
2. ``nlp-ipopt`` warm-started from each ``ipso`` path: total time, IPOPT iterations, the
   CasADi function evaluations (IPOPT's ``t_wall_nlp_*`` statistics), the CasADi build time,
   as median and for the slowest seed.

Run: ``.venv/bin/python benchmarks/ipso_where.py [--maps shelves-1 doors-0] [--seeds 30]``.
The machine is shared: the load average is printed at the start and the end.
"""

from __future__ import annotations

import argparse
import collections
import os
import time

import numpy as np

import optplan as op
from optplan.generators import corridor_scene
from optplan.swarm import endgame as eg
from optplan.swarm import ipso as ip
from optplan.swarm import roadmap as rm


def load(name: str) -> op.Problem:
    if name.startswith("paper"):
        return op.load_problem(name).known_view()
    kind, seed = name.rsplit("-", 1)
    return corridor_scene(kind, int(seed))


class Timers:
    """Wall time of wrapped functions, per run; counts of roadmap segments and labels."""

    def __init__(self) -> None:
        self.t: dict[str, float] = collections.defaultdict(float)
        self.n: dict[str, int] = collections.defaultdict(int)
        self._orig: list = []

    def wrap(self, owner, name: str, label: str, count=None) -> None:
        orig = getattr(owner, name)
        self._orig.append((owner, name, orig))

        def timed(*a, **k):
            t = time.perf_counter()
            out = orig(*a, **k)
            self.t[label] += time.perf_counter() - t
            if count is not None:
                count(self, a, out)
            return out

        setattr(owner, name, timed)

    def restore(self) -> None:
        for owner, name, orig in reversed(self._orig):
            setattr(owner, name, orig)


def _count_labels(tm: Timers, a, out) -> None:
    tm.n["labels of the corridor search"] += len(out[1])


def ipso_parts(prob: op.Problem, seeds: int) -> None:
    op.solve(prob, "ipso", rng=0)
    rows = []
    tm = Timers()
    tm.wrap(rm, "roadmap_nodes", "roadmap nodes (samples, their tests)")
    tm.wrap(rm, "_tested_edges", "roadmap edges (candidates and their tests)")
    tm.wrap(rm, "build_roadmap", "build_roadmap (all)")
    tm.wrap(rm, "_k_classes", "corridor search (_k_classes)", _count_labels)
    tm.wrap(ip.IPSO, "_iterate", "swarm iterations")
    tm.wrap(eg, "tighten", "end-game (tighten)")
    edges = Timers()
    orig_tested = rm._tested_edges

    def tested(space, nodes, corner, k, slack):
        real = rm.pairs_free

        def counting(pts, i, j, s):
            edges.n["tested"] += len(i)
            return real(pts, i, j, s)

        rm.pairs_free = counting
        try:
            return orig_tested(space, nodes, corner, k, slack)
        finally:
            rm.pairs_free = real

    rm._tested_edges = tested
    try:
        for s in range(seeds):
            tm.t.clear()
            tm.n.clear()
            edges.n.clear()
            t = time.perf_counter()
            op.solve(prob, "ipso", rng=s)
            row = {"run (total)": time.perf_counter() - t, **tm.t}
            rows.append((row, {**tm.n, "roadmap edges tested": edges.n["tested"]}))
    finally:
        rm._tested_edges = orig_tested
        tm.restore()
    print("| part | median ms per run |")
    print("|---|---|")
    for key in rows[0][0]:
        print(f"| {key} | {np.median([r[0].get(key, 0.0) for r in rows]) * 1e3:.1f} |")
    print()
    print("| count per run | median |")
    print("|---|---|")
    for key in rows[0][1]:
        print(f"| {key} | {np.median([r[1].get(key, 0) for r in rows]):.0f} |")
    print()


def nlp_parts(prob: op.Problem, seeds: int) -> None:
    warm = op.solve(prob, "ipso", rng=0)
    op.solve(prob, "nlp-ipopt", init=warm.paths)
    out = []
    for s in range(seeds):
        r = op.solve(prob, "ipso", rng=s)
        t = time.perf_counter()
        q = op.solve(prob, "nlp-ipopt", init=r.paths)
        total = time.perf_counter() - t
        info = next(iter(q.extras["ipopt"].values()))
        f_eval = sum(st.get("t_wall") or 0.0 for st in info["rounds"])
        out.append((total, info["iterations"], f_eval, info["build_time"], s))
    arr = np.array(out)
    worst = out[int(np.argmax(arr[:, 0]))]
    print("| NLP polish | total ms | IPOPT iterations | CasADi function evaluations ms "
          "| CasADi build ms |")
    print("|---|---|---|---|---|")
    print(f"| median over seeds | {np.median(arr[:, 0]) * 1e3:.0f} | {np.median(arr[:, 1]):.0f} "
          f"| {np.median(arr[:, 2]) * 1e3:.1f} | {np.median(arr[:, 3]) * 1e3:.1f} |")
    print(f"| slowest (seed {worst[4]}) | {worst[0] * 1e3:.0f} | {worst[1]} "
          f"| {worst[2] * 1e3:.1f} | {worst[3] * 1e3:.1f} |")
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="*", default=["shelves-1", "doors-0"])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--no-nlp", action="store_true")
    args = ap.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.2f} at the start; {args.seeds} seeds per map")
    print()
    for name in args.maps:
        prob = load(name)
        print(f"### {name}")
        print()
        ipso_parts(prob, args.seeds)
        if not args.no_nlp:
            nlp_parts(prob, args.seeds)
    print(f"(load average {os.getloadavg()[0]:.2f} at the end)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
