"""Known findings, the case lists of a run, the classification summary (the counts table,
the failures) and :func:`main`, the full run (``python benchmarks/fuzz_inputs.py``)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable
from pathlib import Path

from benchmarks.fuzz.core import BAD, CATEGORIES, FAMILIES, HANG_S, Case, Outcome
from benchmarks.fuzz.databases import database_cases
from benchmarks.fuzz.inits import init_cases
from benchmarks.fuzz.maps import map_cases
from benchmarks.fuzz.options import OptionFuzzer, preset_table
from benchmarks.fuzz.plugins import plugin_cases
from benchmarks.fuzz.results import result_cases
from benchmarks.fuzz.runner import run_cases, worker_main
from benchmarks.fuzz.scenarios import ScenarioFuzzer
from benchmarks.fuzz.surfaces import arena_cases, crop_cases, path_cases, scen_cases

#: finding id -> (where, what happens, predicate on a bad outcome).  A bad outcome a finding
#: explains is reported in the "known findings" column (and ``tests/tools/test_fuzz.py`` does
#: not count it).  Strict: an entry that explains no outcome of that test's slice is stale
#: (:func:`stale_findings`) and fails the test, so a fixed finding is removed, not kept; an entry
#: must therefore come with a case in the slice that reproduces it.  (Removed, no longer
#: reproducing: ``int-option-recompiles``, an integer value for a float swarm option compiled
#: a new numba specialisation; ``optplan.geometry.compiled.jit.OneSignature`` converts it since.)
KNOWN_FINDINGS: dict[str, tuple[str, str, Callable[[Outcome], bool]]] = {}


def stale_findings(outcomes: list[Outcome]) -> list[str]:
    """The :data:`KNOWN_FINDINGS` entries that explain none of ``outcomes`` (annotated by
    :func:`annotate`): fixed, or not reproduced by these cases."""
    return [fid for fid in KNOWN_FINDINGS if not any(o.known == fid for o in outcomes)]


def known_finding(outcome: Outcome) -> str | None:
    for fid, (_, _, pred) in KNOWN_FINDINGS.items():
        try:
            if pred(outcome):
                return fid
        except (KeyError, TypeError, AttributeError):
            continue
    return None



def surface_cases(seed: int = 0, families: Iterable[str] = ("path", "crop", "scen",
                                                            "arena")) -> list[Case]:
    """The ROS path message, ``crop=``, ``.scen`` and Planner Arena export families."""
    make = {"path": lambda: path_cases(seed), "crop": crop_cases, "scen": scen_cases,
            "arena": arena_cases}
    return [c for f in families for c in make[f]()]


def build_cases(seed: int = 0, n_scenarios: int = 3000, options: bool = True,
                inits: bool = True, results: bool = True,
                scenes: Iterable[str] | None = None, maps: bool = True,
                databases: bool = True, plugins: bool = True,
                surfaces: Iterable[str] = ("path", "crop", "scen", "arena")) -> list[Case]:
    cases = ScenarioFuzzer(seed).cases(n_scenarios, scenes)
    presets = preset_table() if (options or inits) else {}
    if options:
        cases += OptionFuzzer(seed).cases(presets)
    if inits:
        cases += init_cases(presets, seed)
    if results:
        cases += result_cases(seed)
    if maps:
        cases += map_cases(seed)
    if databases:
        cases += database_cases(seed)
    if plugins:
        cases += plugin_cases()
    return cases + surface_cases(seed, surfaces)


def annotate(outcomes: list[Outcome]) -> list[Outcome]:
    for o in outcomes:
        if o.category in BAD:
            o.known = known_finding(o)
    return outcomes


def counts_table(outcomes: list[Outcome]) -> str:
    fams = list(FAMILIES)
    head = ["family", "cases", *CATEGORIES, "known findings", "compared"]
    rows = []
    for fam in [*fams, "all"]:
        sel = [o for o in outcomes if fam == "all" or o.case.family == fam]
        c = Counter(o.category for o in sel)
        rows.append([fam, str(len(sel)), *(str(c[k]) for k in CATEGORIES),
                     str(sum(1 for o in sel if o.known)), str(sum(o.compared for o in sel))])
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(head, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    body = ["| " + " | ".join(v.rjust(w) if i else v.ljust(w)
                              for i, (v, w) in enumerate(zip(r, widths))) + " |"
            for r in rows]
    return "\n".join([line, sep, *body])


def failures(outcomes: list[Outcome], include_known: bool = False) -> list[Outcome]:
    return [o for o in outcomes if o.category in BAD and (include_known or not o.known)]


def main(argv: list[str] | None = None) -> int:
    import benchmarks.fuzz as package

    ap = argparse.ArgumentParser(description=(package.__doc__ or "").splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenarios", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=max(1, min(4, os.cpu_count() or 1)))
    ap.add_argument("--family", action="append", choices=list(FAMILIES))
    ap.add_argument("--quick", action="store_true", help="300 scenarios, every family")
    ap.add_argument("--show", type=int, default=40, help="failures to list (default 40)")
    ap.add_argument("--json", help="write every outcome to this JSON file")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker_main()
        return 0
    fam = set(args.family or FAMILIES)
    n_sc = 300 if args.quick else args.scenarios
    t0 = time.perf_counter()
    cases = build_cases(args.seed, n_sc if "scenario" in fam else 0, "option" in fam,
                        "init" in fam, "result" in fam, maps="map" in fam,
                        databases="database" in fam, plugins="plugin" in fam,
                        surfaces=[f for f in ("path", "crop", "scen", "arena") if f in fam])
    print(f"{len(cases)} cases ({time.perf_counter() - t0:.1f} s to generate); "
          f"{args.workers} workers, hang limit {HANG_S:g} CPU s", file=sys.stderr)
    last = [0.0]

    def prog(done: int, total: int, out: Outcome) -> None:
        now = time.perf_counter()
        if out.category in BAD or now - last[0] > 10 or done == total:
            last[0] = now
            mark = "" if out.category not in BAD else f"  {out.category}: {out.case.id}"
            print(f"[{done}/{total}] {now - t0:.0f} s{mark}", file=sys.stderr)

    outcomes = annotate(run_cases(cases, args.workers, progress=prog))
    print(counts_table(outcomes))
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")
    bad = failures(outcomes, include_known=True)
    if bad:
        print(f"\n{len(bad)} bad outcomes (first {args.show}):")
        for o in bad[: args.show]:
            tag = f" [known: {o.known}]" if o.known else ""
            print(f"- {o.category}{tag}: {o.case.id} ({o.case.what}; "
                  f"{o.case.data.get('note', '')}): {o.detail[:400]}")
    if args.json:
        Path(args.json).write_text(json.dumps([
            {"id": o.case.id, "family": o.case.family, "what": o.case.what,
             "note": o.case.data.get("note", ""), "category": o.category, "detail": o.detail,
             "seconds": round(o.seconds, 3), "known": o.known} for o in outcomes], indent=1))
    stale = stale_findings(outcomes)
    if stale and fam == set(FAMILIES) and n_sc >= 3000:  # the full run: every case was tried
        print(f"\nKNOWN_FINDINGS entries no outcome reproduced (fixed? remove them): {stale}")
    return 0 if not failures(outcomes) else 1
