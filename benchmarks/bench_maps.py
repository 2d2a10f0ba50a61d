"""Planners on generated MovingAI benchmark maps (issue 27, must-show).

Generates seeded maps itself (:func:`optplan.generators.movingai_benchmark`): random at 10, 20
and 30 % density, room, maze and street-like, 32 x 32 to 256 x 256 cells, with fewer
``.scen`` lines at the larger sizes; reads every line as a problem (a point robot from cell
centre to cell centre, :func:`optplan.maps.read_scen`) and runs ``visgraph``, ``ipso``,
``sa-apf-paper``, ``sa-apf``, ``hybrid-paper``, ``hybrid-qp`` and ``hybrid-guided`` on it.
Prints, per family and size, for every solver:

* success: share of lines with status ``optimal`` or ``solved`` (validator-accepted);
* collision: share of lines whose path meets a static obstacle (the validator's
  ``static_collisions``; a local planner that stops at a collision counts here too, from its
  ``collision`` extra);
* ratio: median and worst ratio of the path length to ``visgraph``'s certified Euclidean
  optimum, over the successful lines;
* time: median CPU seconds (``time.process_time``) per line.

Run: ``.venv/bin/python benchmarks/bench_maps.py [--quick] [--sizes 32 64] [--solvers ...]``
(the full run takes long at 256 x 256: run it in the background).  Seeds are fixed: map ``k``
of a family and size is drawn with ``default_rng(seed + size)``, solver ``rng=`` is the line
number.
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen

FAMILIES = {"random-10": ("random", 0.1), "random-20": ("random", 0.2),
            "random-30": ("random", 0.3), "room": ("room", None), "maze": ("maze", None),
            "street": ("street", None)}
SOLVERS = ("visgraph", "ipso", "sa-apf-paper", "sa-apf", "hybrid-paper", "hybrid-qp",
           "hybrid-guided")
QUERIES = {32: 20, 64: 10, 128: 5, 256: 3}
QUICK_QUERIES = {32: 5, 64: 3}


def gen_lines(family: str, size: int, queries: int, seed: int, out: Path) -> list:
    """The ``.scen`` lines of one generated map as problems."""
    kind, density = FAMILIES[family]
    kw = {"density": density} if density is not None else {}
    g = movingai_benchmark(kind, size, out, rng=np.random.default_rng(seed + size),
                           queries=queries, **kw)
    return read_scen(str(g.map_path) + ".scen")


def run_line(q, solver: str, k: int, opt: float) -> dict:
    """One solver on one line: success, collision, ratio, CPU time."""
    t0 = time.process_time()
    res = op.solve(q, solver, rng=k)
    t = time.process_time() - t0
    ok = res.status.value in ("optimal", "solved")
    m = res.metrics
    coll = bool(m.get("static_collisions", 0)) or str(res.extras.get("collision", "")) != ""
    coll = coll or res.message.startswith("collision")
    ratio = float(m["length"]) / opt if ok and opt > 0 else float("nan")
    return {"ok": ok, "coll": coll, "ratio": ratio, "t": t}


def table(rows: dict[str, list[dict]]) -> list[str]:
    out = ["| solver | success | collision | ratio median | ratio worst | time median (s) |",
           "|---|---|---|---|---|---|"]
    for s, rs in rows.items():
        n = len(rs)
        r = np.array([x["ratio"] for x in rs if x["ok"]])
        med = f"{np.median(r):.3f}" if len(r) else "-"
        worst = f"{r.max():.3f}" if len(r) else "-"
        out.append(f"| {s} | {sum(x['ok'] for x in rs)}/{n} | {sum(x['coll'] for x in rs)}/{n} "
                   f"| {med} | {worst} | {np.median([x['t'] for x in rs]):.2f} |")
    return out


def summarize(files: list[str]) -> None:
    """Two compact tables from printed runs (several processes' outputs): per map and
    solver, "successes/lines (collisions)" and "median ratio, median time"."""
    res: dict[str, dict[str, list[str]]] = {}
    head = ""
    for f in files:
        for ln in Path(f).read_text().splitlines():
            if ln.startswith("## "):  # a map's section, or the totals (not summarised)
                head = "" if ln.startswith("## all maps") else ln[3:].split(" (")[0]
                if head:
                    res.setdefault(head, {})
            elif ln.startswith("| ") and head and not ln.startswith("| solver"):
                cells = [c.strip() for c in ln.strip("|").split("|")]
                res[head][cells[0]] = cells[1:]
    solvers = [s for s in ["visgraph", *SOLVERS[1:]] if any(s in r for r in res.values())]
    top = "| map | " + " | ".join(solvers) + " |\n|---|" + "---|" * len(solvers)
    print("Success (validator-accepted) of the lines, in brackets those with a collision:\n")
    print(top)
    for m, r in res.items():
        print(f"| {m} | " + " | ".join(
            f"{r[s][0]} ({r[s][1].split('/')[0]})" if s in r else "" for s in solvers) + " |")
    print("\nMedian (worst) ratio to the certified optimum over the successes; median CPU "
          "seconds per line:\n")
    print(top)
    for m, r in res.items():
        print(f"| {m} | " + " | ".join(
            f"{r[s][2]} ({r[s][3]}); {r[s][4]} s" if s in r else "" for s in solvers) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="32 and 64 cells, 5/3 lines")
    ap.add_argument("--sizes", type=int, nargs="*", help="map sizes (default 32 64 128 256)")
    ap.add_argument("--families", nargs="*", choices=sorted(FAMILIES), help="map families")
    ap.add_argument("--solvers", nargs="*", help=f"presets (default {' '.join(SOLVERS)})")
    ap.add_argument("--seed", type=int, default=0, help="map seed (default 0)")
    ap.add_argument("--lines", type=int, nargs="*",
                    help="lines per map, one number per size (default 20 10 5 3)")
    ap.add_argument("--summarize", nargs="*", metavar="FILE",
                    help="print the compact tables of earlier runs' printed output and exit")
    a = ap.parse_args()
    if a.summarize:
        summarize(a.summarize)
        return
    qn = QUICK_QUERIES if a.quick else QUERIES
    if a.lines:
        if not a.sizes or len(a.lines) != len(a.sizes):
            ap.error("--lines needs --sizes and one number per size")
        qn = dict(zip(a.sizes, a.lines, strict=True))
    sizes = a.sizes or sorted(qn)
    families = a.families or list(FAMILIES)
    solvers = [s for s in (a.solvers or SOLVERS) if s != "visgraph"]
    print(f"# bench_maps: {platform.processor() or platform.machine()}, python "
          f"{platform.python_version()}; CPU seconds per line; map seed {a.seed}\n")
    totals: dict[str, list[dict]] = {s: [] for s in ["visgraph", *solvers]}
    with tempfile.TemporaryDirectory() as tmp:
        for size in sizes:
            for fam in families:
                lines = gen_lines(fam, size, qn.get(size, 3), a.seed, Path(tmp))
                rows: dict[str, list[dict]] = {s: [] for s in ["visgraph", *solvers]}
                for k, q in enumerate(lines):
                    t0 = time.process_time()
                    v = op.solve(q, "visgraph")
                    tv = time.process_time() - t0
                    opt = float(v.metrics.get("optimum", v.metrics["length"]))
                    rows["visgraph"].append({"ok": v.status.value == "optimal",
                                             "coll": False, "ratio": 1.0, "t": tv})
                    for s in solvers:
                        rows[s].append(run_line(q, s, k, opt))
                print(f"## {fam}, {size} x {size} ({len(lines)} lines)\n")
                print("\n".join(table(rows)) + "\n", flush=True)
                for s, rs in rows.items():
                    totals[s].extend(rs)
    print("## all maps\n")
    print("\n".join(table(totals)))


if __name__ == "__main__":
    main()
