"""Planners on generated MovingAI benchmark maps (issue 27, must-show).

Generates seeded maps itself (:func:`optplan.generators.movingai_benchmark`): random at 10, 20
and 30 % density, room, maze and street-like, 32 x 32 to 256 x 256 cells, one or several maps
per family and size (``--maps``), with fewer ``.scen`` lines a map at the larger sizes
(``--lines``); reads every line as a problem (a point robot from cell centre to cell centre,
:func:`optplan.maps.read_scen`) and runs ``visgraph``, ``ipso``, ``sa-apf-paper``,
``sa-apf``, ``hybrid-paper``, ``hybrid-qp`` and ``hybrid-guided`` on it (or the presets of
``--solvers``; ``visgraph`` always runs: it is the reference).  Prints, per family and size
(the maps of that family and size pooled), for every solver:

* success: share of lines with status ``optimal`` or ``solved`` (validator-accepted);
* collision: share of lines whose path meets a static obstacle (the validator's
  ``static_collisions``; a local planner that stops at a collision counts here too, from its
  ``collision`` extra);
* ratio: median and worst ratio of the path length to ``visgraph``'s certified Euclidean
  optimum, over the successful lines;
* time: median CPU seconds (``time.process_time``) per line;

then one line per failed or colliding run (solver, family, size, map index, line index,
problem name, status, collision, message), and at the end, per solver, a table per family with
the sizes pooled: lines, successes, collisions, the success share and its one-sided 95 %
Clopper-Pearson lower bound (``scipy.stats.beta.ppf(0.05, k, n - k + 1)``, 0 when ``k == 0``,
``0.05 ** (1 / n)`` when ``k == n``: a share >= 0.99 is shown at 95 % confidence by
``n >= 299`` lines without a failure), the worst ratio, and per size the successes and the
bound.  ``--summarize`` prints the same per-family tables (and compact per-map tables and the
failed runs' lines) from the printed output of several runs, e.g. one process per size.

Run: ``.venv/bin/python benchmarks/bench_maps.py [--quick] [--sizes 32 64] [--maps 10 10]
[--lines 15 10] [--solvers ...]`` (the full run takes long at 256 x 256: run it in the
background, one size a process).  Seeds are fixed: map ``k`` (0, 1, ...) of a family and size
is drawn with ``default_rng(seed + size + 1000 * k)`` (map 0 is the single map of earlier
runs; ``--first-map K`` runs maps ``K`` on, whose sections, headed ``maps K to ...``, stay
apart from map 0's in ``--summarize`` and are pooled with them in the per-family tables),
solver ``rng=`` is the line's index in its map.  Progress (one line a map) goes to
standard error.
"""

from __future__ import annotations

import argparse
import platform
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import beta

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
SECTION = re.compile(r"^## (\S+), (\d+) x \d+")

Stats = tuple[int, int, int, float]  # lines, successes, collisions, worst ratio (nan: none)


def gen_lines(family: str, size: int, queries: int, seed: int, out: Path,
              k: int = 0) -> list:
    """The ``.scen`` lines of map ``k`` of a family and size as problems.

    Parameters
    ----------
    family : str
        A key of :data:`FAMILIES`.
    size : int
        Cells per side.
    queries : int
        Lines of the ``.scen``.
    seed : int
        The run's map seed.
    out : pathlib.Path
        Directory for the written files.
    k : int
        Map index: drawn with ``default_rng(seed + size + 1000 * k)``.

    Returns
    -------
    list
        The problems of the lines.
    """
    kind, density = FAMILIES[family]
    kw = {"density": density} if density is not None else {}
    g = movingai_benchmark(kind, size, out, rng=np.random.default_rng(seed + size + 1000 * k),
                           queries=queries, **kw)
    return read_scen(str(g.map_path) + ".scen")


def run_line(q, solver: str, k: int, opt: float) -> dict:
    """One solver on one line: success, collision, ratio, CPU time, status, message."""
    t0 = time.process_time()
    res = op.solve(q, solver, rng=k)
    t = time.process_time() - t0
    ok = res.status.value in ("optimal", "solved")
    m = res.metrics
    ctext = str(res.extras.get("collision", "") or "")
    coll = bool(m.get("static_collisions", 0)) or ctext != ""
    coll = coll or res.message.startswith("collision")
    ratio = float(m["length"]) / opt if ok and opt > 0 else float("nan")
    return {"ok": ok, "coll": coll, "ratio": ratio, "t": t, "status": res.status.value,
            "message": res.message, "collision": ctext,
            "static_collisions": m.get("static_collisions", 0)}


def lower_bound(k: int, n: int) -> float:
    """One-sided 95 % Clopper-Pearson lower bound of a share with ``k`` of ``n`` successes.

    Parameters
    ----------
    k, n : int
        Successes and trials.

    Returns
    -------
    float
        ``beta.ppf(0.05, k, n - k + 1)``; 0 when ``k == 0``, ``0.05 ** (1 / n)`` when
        ``k == n``.
    """
    if n <= 0 or k <= 0:
        return 0.0
    if k >= n:
        return float(0.05 ** (1.0 / n))
    return float(beta.ppf(0.05, k, n - k + 1))


def table(rows: dict[str, list[dict]]) -> list[str]:
    """Per solver: successes, collisions, median and worst ratio, median time."""
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


def stats_of(rs: list[dict]) -> Stats:
    """Lines, successes, collisions and worst ratio of a solver's runs."""
    r = [x["ratio"] for x in rs if x["ok"]]
    return (len(rs), sum(x["ok"] for x in rs), sum(x["coll"] for x in rs),
            max(r) if r else float("nan"))


def pool(a: Stats, b: Stats) -> Stats:
    """Two sets of runs' stats pooled."""
    w = [x for x in (a[3], b[3]) if not np.isnan(x)]
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], max(w) if w else float("nan"))


NONE: Stats = (0, 0, 0, float("nan"))


def family_tables(stats: dict[str, dict[str, dict[int, Stats]]]) -> list[str]:
    """Per solver, a table of the families (sizes pooled) with the lower bound of the share.

    Parameters
    ----------
    stats : dict
        ``stats[family][solver][size]``: lines, successes, collisions, worst ratio.

    Returns
    -------
    list of str
        Markdown lines: per family (and all families) lines, successes, collisions, share,
        its one-sided 95 % lower bound and the worst ratio, the sizes pooled; in the last
        column per size successes/lines and the lower bound.
    """
    solvers = [s for s in SOLVERS if any(s in v for v in stats.values())]
    solvers += sorted({s for v in stats.values() for s in v} - set(solvers))
    fams = [f for f in FAMILIES if f in stats] + sorted(set(stats) - set(FAMILIES))
    out: list[str] = []
    for s in solvers:
        out += [f"### {s}", "",
                "| family | lines | successes | collisions | success share "
                "| 95 % lower bound | worst ratio | per size: successes/lines, lower bound |",
                "|---|---|---|---|---|---|---|---|"]
        tot: dict[int, Stats] = {}
        for fam in fams:
            if s not in stats[fam]:
                continue
            for size, st in stats[fam][s].items():
                tot[size] = pool(tot.get(size, NONE), st)
            out.append(_family_row(fam, stats[fam][s]))
        out += [_family_row("all", tot), ""]
    return out


def _family_row(name: str, by_size: dict[int, Stats]) -> str:
    n, k, c, w = NONE
    for st in by_size.values():
        n, k, c, w = pool((n, k, c, w), st)
    share = f"{k / n:.4f}" if n else "-"
    worst = "-" if np.isnan(w) else f"{w:.3f}"
    sizes = "; ".join(f"{z}: {st[1]}/{st[0]}, {lower_bound(st[1], st[0]):.4f}"
                      for z, st in sorted(by_size.items()))
    return (f"| {name} | {n} | {k} | {c} | {share} | {lower_bound(k, n):.4f} | {worst} "
            f"| {sizes} |")


def _frac(cell: str) -> tuple[int, int]:
    a, b = cell.split("/")
    return int(a), int(b)


def summarize(files: list[str]) -> None:
    """Compact tables from printed runs (several processes' outputs): per map and solver,
    "successes/lines (collisions)" and "median ratio, median time"; per solver and family
    (sizes pooled) lines, successes, collisions, share and its 95 % lower bound; the failed
    or colliding runs' lines."""
    res: dict[str, dict[str, list[str]]] = {}
    fails: list[str] = []
    head = ""
    for f in files:
        for ln in Path(f).read_text().splitlines():
            if ln.startswith("## "):  # a family and size's section, or the totals
                head = ln[3:].split(" (")[0] if SECTION.match(ln) else ""
                if head:
                    res.setdefault(head, {})
            elif ln.startswith("| ") and head and not ln.startswith("| solver"):
                cells = [c.strip() for c in ln.strip("|").split("|")]
                res[head][cells[0]] = cells[1:]
            elif ln.startswith("- fail ") and head:
                fails.append(ln)
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
    stats: dict[str, dict[str, dict[int, Stats]]] = {}
    for m, r in res.items():
        fam, size = SECTION.match("## " + m).groups()
        for s, cells in r.items():
            k, n = _frac(cells[0])
            c, _ = _frac(cells[1])
            w = float("nan") if cells[3] == "-" else float(cells[3])
            by_size = stats.setdefault(fam, {}).setdefault(s, {})
            by_size[int(size)] = pool(by_size.get(int(size), NONE), (n, k, c, w))
    print("\nPer family, the sizes pooled (lower bound: one-sided 95 % Clopper-Pearson):\n")
    print("\n".join(family_tables(stats)))
    print("Failed or colliding runs:" + ("" if fails else " none"))
    for ln in fails:
        print(ln)


def _per_size(values: list[int] | None, sizes: list[int], what: str,
              ap: argparse.ArgumentParser) -> dict[int, int] | None:
    if not values:
        return None
    if len(values) == 1:
        return dict.fromkeys(sizes, values[0])
    if len(values) != len(sizes):
        ap.error(f"{what}: one number, or one per size of --sizes")
    return dict(zip(sizes, values, strict=True))


def main() -> None:
    """Parse the options, run the maps or summarise earlier runs."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="32 and 64 cells, 5/3 lines")
    ap.add_argument("--sizes", type=int, nargs="*", help="map sizes (default 32 64 128 256)")
    ap.add_argument("--families", nargs="*", choices=sorted(FAMILIES), help="map families")
    ap.add_argument("--solvers", nargs="*", help=f"presets (default {' '.join(SOLVERS)})")
    ap.add_argument("--seed", type=int, default=0, help="map seed (default 0)")
    ap.add_argument("--maps", type=int, nargs="*",
                    help="maps per family and size: one number, or one per size (default 1)")
    ap.add_argument("--first-map", type=int, default=0, metavar="K",
                    help="run maps K to K + M - 1 (default 0): more maps for an earlier run")
    ap.add_argument("--lines", type=int, nargs="*",
                    help="lines per map: one number, or one per size (default 20 10 5 3)")
    ap.add_argument("--summarize", nargs="*", metavar="FILE",
                    help="print the compact and per-family tables of earlier runs' output, exit")
    a = ap.parse_args()
    if a.summarize:
        summarize(a.summarize)
        return
    qn = QUICK_QUERIES if a.quick else QUERIES
    if a.lines and len(a.lines) > 1 and not a.sizes:
        ap.error("--lines with several numbers needs --sizes")
    sizes = a.sizes or sorted(qn)
    qn = _per_size(a.lines, sizes, "--lines", ap) or qn
    maps = _per_size(a.maps, sizes, "--maps", ap) or {}
    families = a.families or list(FAMILIES)
    solvers = [s for s in (a.solvers or SOLVERS) if s != "visgraph"]
    print(f"# bench_maps: {platform.processor() or platform.machine()}, python "
          f"{platform.python_version()}; CPU seconds per line; map seed {a.seed}\n")
    totals: dict[str, list[dict]] = {s: [] for s in ["visgraph", *solvers]}
    fam_stats: dict[str, dict[str, dict[int, Stats]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for size in sizes:
            for fam in families:
                rows: dict[str, list[dict]] = {s: [] for s in ["visgraph", *solvers]}
                fails: list[str] = []
                nmaps = maps.get(size, 1)
                for mk in range(a.first_map, a.first_map + nmaps):
                    c0 = time.process_time()
                    lines = gen_lines(fam, size, qn.get(size, 3), a.seed, Path(tmp), mk)
                    where = f"{fam} {size}, map {mk}"
                    for k, q in enumerate(lines):
                        t0 = time.process_time()
                        v = op.solve(q, "visgraph")
                        tv = time.process_time() - t0
                        opt = float(v.metrics.get("optimum", v.metrics["length"]))
                        vok = v.status.value == "optimal"
                        rows["visgraph"].append({"ok": vok, "coll": False, "ratio": 1.0,
                                                 "t": tv})
                        if not vok:
                            fails.append(f"- fail visgraph, {where}, line {k} ({q.name}): "
                                         f"status {v.status.value}; {v.message}")
                        for s in solvers:
                            r = run_line(q, s, k, opt)
                            rows[s].append(r)
                            if not r["ok"] or r["coll"]:
                                fails.append(
                                    f"- fail {s}, {where}, line {k} ({q.name}): status "
                                    f"{r['status']}, static_collisions "
                                    f"{r['static_collisions']}, collision "
                                    f"'{r['collision']}'; {r['message']}")
                    print(f"{fam} {size} map {mk} (to {a.first_map + nmaps - 1}): "
                          f"{len(lines)} lines, "
                          f"{time.process_time() - c0:.1f} CPU s", file=sys.stderr, flush=True)
                nl = len(rows["visgraph"])
                span = (f", maps {a.first_map} to {a.first_map + nmaps - 1}" if a.first_map
                        else "")
                print(f"## {fam}, {size} x {size}{span} ({nmaps} map{'s' * (nmaps > 1)}, "
                      f"{nl} lines)\n")
                print("\n".join(table(rows)) + "\n")
                if fails:
                    print("\n".join(fails) + "\n")
                sys.stdout.flush()
                for s, rs in rows.items():
                    totals[s].extend(rs)
                    fam_stats.setdefault(fam, {}).setdefault(s, {})[size] = stats_of(rs)
    print("## all maps\n")
    print("\n".join(table(totals)) + "\n")
    print("## per family, sizes pooled (lower bound: one-sided 95 % Clopper-Pearson)\n")
    print("\n".join(family_tables(fam_stats)))


if __name__ == "__main__":
    main()
