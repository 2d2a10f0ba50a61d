"""The time bracket on the scene families for time (optplan.time_families): bounds, gaps, checks.

For each family (``open``, ``doors``, ``warehouse``) and seed, builds the scene
(``time_family(kind, numpy.random.default_rng(seed))``) and solves it with

* the bracket (``--bracket``, default the ``time-bracket`` preset, ``time_limit``
  ``--time-limit``): ``metrics["arrival_upper"]``, ``["arrival_lower"]``; its plan validated
  (``metrics["collisions"]``);
* ``sipp`` (the earliest arrival within the tangent-roadmap model, ``metrics["arrival_time"]``);
* every heuristic (``--solvers``, ``rng=seed``, ``time_limit`` ``--heuristic-time-limit``,
  ``reference=False``): where the run is valid (``success`` and no collision), its arrival at
  the goal point, ``optplan.time_grading.grade_robot(...)["arrival_at_goal"]``;
* the bracket again on the same scene without its static obstacles
  (``problem.replaced(obstacles=())``), started from the plan of the upper side with them
  (``init``: a valid motion there is one here): its upper bound may be no later than with
  them; and once more without that start (``free alone``), to show what the start is for.

``--bracket sipp`` is the stand-in while the ``time-bracket`` preset is not there: the upper
bound is sipp's arrival, the lower bound
``optplan.geometry.timing.arrival_lower_bound(problem, leader).value``; the title says so.

Prints per family (Markdown): the gap ``(upper - lower) / upper`` and ``sipp / upper``
(median and worst over the seeds), the share of scenes whose upper bound is no later than every
valid heuristic arrival (target >= 95 %), invalid bracket plans, valid arrivals of any method
below the lower bound (relative tolerance 1e-9; target 0), scenes whose bound without static
obstacles is later than with them (target 0; and without the start, with the largest excess),
the wall time; and per heuristic the valid
arrival / upper.  The load average is printed before and after.

    python benchmarks/bench_time_bracket.py --bracket sipp --seeds 1 2 --time-limit 5
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import optplan as op
from optplan.geometry.timing import arrival_lower_bound
from optplan.problem import Problem
from optplan.time_families import TIME_FAMILY_KINDS, time_family
from optplan.time_grading import grade_robot

HEURISTICS = ["apf-paper", "sa-apf-paper", "hybrid-paper", "orca"]
REL = 1e-9
TARGET_SHARE = 0.95


@dataclass
class Bounds:
    """The bracket's answer on one scene (``None``: no such bound)."""

    upper: float | None
    lower: float | None
    status: str
    invalid: bool
    wall: float


@dataclass
class Scene:
    """Everything measured on one scene."""

    family: str
    seed: int
    bracket: Bounds
    free: Bounds
    free_alone: Bounds
    sipp: float | None
    sipp_valid: bool
    arrivals: dict[str, float | None] = field(default_factory=dict)


def _valid(res: op.Result) -> bool:
    """A run the validator accepts: success and no collision."""
    return bool(res.success and not res.metrics.get("collisions"))


def bracket_run(p: Problem, bracket: str, time_limit: float, sipp: op.Result | None = None,
                init: dict[str, np.ndarray] | None = None) -> tuple[Bounds, op.Result]:
    """The bracket's bounds on ``p`` and its result; with ``bracket == "sipp"`` the stand-in
    (module docstring), reusing ``sipp`` (the sipp result of ``p``) when given; ``init``:
    the path the bracket starts from (not for the stand-in)."""
    if bracket == "sipp":
        res = sipp if sipp is not None else op.solve(p, "sipp")
        upper = res.metrics.get("arrival_time")
        lower = arrival_lower_bound(p, p.leader.id).value
    else:
        res = op.solve(p, bracket, time_limit=time_limit, init=init)
        upper, lower = res.metrics.get("arrival_upper"), res.metrics.get("arrival_lower")
    invalid = upper is not None and not _valid(res)
    return Bounds(upper, lower, str(res.status), invalid, res.wall_time), res


def heuristic_arrival(p: Problem, solver: str, seed: int, time_limit: float) -> float | None:
    """The arrival at the goal point of a valid run of ``solver``, else ``None``."""
    res = op.solve(p, solver, rng=seed, time_limit=time_limit, reference=False)
    if not _valid(res):
        return None
    rid = p.leader.id
    return grade_robot(p, rid, res.paths[rid], res.times).get("arrival_at_goal")


def run_scene(family: str, seed: int, a: argparse.Namespace) -> Scene:
    """All the solves of one scene (module docstring)."""
    p = time_family(family, np.random.default_rng(seed))
    sipp = op.solve(p, "sipp")
    bounds, res = bracket_run(p, a.bracket, a.time_limit, sipp)
    bare = p.replaced(obstacles=())
    start = None if bounds.upper is None or a.bracket == "sipp" else {
        p.leader.id: res.paths[p.leader.id]}
    free, _ = bracket_run(bare, a.bracket, a.time_limit, init=start)
    alone = free if start is None else bracket_run(bare, a.bracket, a.time_limit)[0]
    scene = Scene(family, seed, bounds, free, alone, sipp.metrics.get("arrival_time"),
                  _valid(sipp))
    for h in a.solvers:
        scene.arrivals[h] = heuristic_arrival(p, h, seed, a.heuristic_time_limit)
    return scene


def _below(x: float | None, y: float | None) -> bool:
    """``x < y`` beyond the relative tolerance (False when either is missing)."""
    return x is not None and y is not None and x < y * (1 - REL)


def _later(x: float | None, y: float | None) -> bool:
    """``x > y`` beyond the relative tolerance (False when either is missing)."""
    return x is not None and y is not None and x > y * (1 + REL)


def _ratio(x: float | None, y: float | None) -> float | None:
    """``x / y`` when both exist and ``y`` is positive and finite."""
    ok = x is not None and y is not None and 0 < y < math.inf
    return x / y if ok else None  # type: ignore[operator]


def _mw(xs: list[float]) -> str:
    """``median / worst`` of ``xs`` (worst: the largest), or ``-``."""
    return f"{statistics.median(xs):.3f} / {max(xs):.3f}" if xs else "-"


def _family_checks(rows: list[Scene]) -> dict[str, Any]:
    """The per-family counts of the module docstring."""
    gaps = [(s.bracket.upper - s.bracket.lower) / s.bracket.upper for s in rows
            if s.bracket.upper is not None and s.bracket.lower is not None
            and 0 < s.bracket.upper < math.inf]
    sipp = [r for s in rows if (r := _ratio(s.sipp, s.bracket.upper)) is not None]
    first = sum(all(not _later(s.bracket.upper, v) for v in s.arrivals.values() if v is not None)
                and s.bracket.upper is not None for s in rows)
    below = 0
    for s in rows:
        valid = [*s.arrivals.values(), s.sipp if s.sipp_valid else None,
                 None if s.bracket.invalid else s.bracket.upper]
        below += sum(_below(v, s.bracket.lower) for v in valid)  # None: not below
    return {"gaps": gaps, "sipp": sipp, "first": first, "below": below,
            "invalid": sum(s.bracket.invalid for s in rows),
            "no_upper": sum(s.bracket.upper is None for s in rows),
            "free_later": sum(_later(s.free.upper, s.bracket.upper) for s in rows),
            "alone_later": [s.free_alone.upper / s.bracket.upper - 1 for s in rows
                            if _later(s.free_alone.upper, s.bracket.upper)],
            "status": Counter(s.bracket.status for s in rows)}


def family_table(rows: list[Scene], walls: dict[str, float]) -> str:
    """One line per family (module docstring)."""
    lines = ["| family | scenes | bracket statuses | no upper | gap med / worst | sipp / upper "
             "med / worst (largest) | upper <= every valid heuristic (>= 95 %) | invalid "
             "bracket plans | valid arrivals below lower (0) | no-static bound later (0) | "
             "... without the start: later (largest excess) | "
             "bracket wall med (s) | family wall (s) |", "|" + "---|" * 13]
    for fam in walls:
        fr = [s for s in rows if s.family == fam]
        c = _family_checks(fr)
        share = c["first"] / len(fr)
        st = ", ".join(f"{k} {v}" for k, v in sorted(c["status"].items()))
        ok = "met" if share >= TARGET_SHARE else "NOT met"
        wall = statistics.median(s.bracket.wall for s in fr)
        al = c["alone_later"]
        alone = f"{len(al)} ({100 * max(al):.3g} %)" if al else "0"
        lines.append(f"| {fam} | {len(fr)} | {st} | {c['no_upper']} | {_mw(c['gaps'])} | "
                     f"{_mw(c['sipp'])} | {100 * share:.0f} % ({ok}) | {c['invalid']} | "
                     f"{c['below']} | {c['free_later']} | {alone} | {wall:.2f} | "
                     f"{walls[fam]:.1f} |")
    return "\n".join(lines)


def heuristic_table(rows: list[Scene], solvers: list[str]) -> str:
    """Per family and heuristic: valid runs and valid arrival / upper."""
    lines = ["| family | heuristic | valid runs | arrival / upper med / worst (largest) | "
             "smallest |", "|" + "---|" * 5]
    for fam in dict.fromkeys(s.family for s in rows):
        fr = [s for s in rows if s.family == fam]
        for h in solvers:
            rs = [r for s in fr if (r := _ratio(s.arrivals.get(h), s.bracket.upper)) is not None]
            n_valid = sum(s.arrivals.get(h) is not None for s in fr)
            low = f"{min(rs):.3f}" if rs else "-"
            lines.append(f"| {fam} | {h} | {n_valid} / {len(fr)} | {_mw(rs)} | {low} |")
    return "\n".join(lines)


def _load() -> str:
    """The load average (1, 5, 15 min) and the cores."""
    return ", ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} cores"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", nargs="+", default=list(TIME_FAMILY_KINDS),
                    choices=TIME_FAMILY_KINDS)
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(1, 9)))
    ap.add_argument("--time-limit", type=float, default=10.0, help="the bracket's (s)")
    ap.add_argument("--heuristic-time-limit", type=float, default=30.0)
    ap.add_argument("--solvers", nargs="+", default=HEURISTICS)
    ap.add_argument("--bracket", default="time-bracket",
                    help="the bracket preset; 'sipp' is the stand-in (module docstring)")
    a = ap.parse_args(argv)
    load0 = _load()
    rows: list[Scene] = []
    walls: dict[str, float] = {}
    for fam in a.families:
        t0 = time.perf_counter()
        try:
            rows += [run_scene(fam, s, a) for s in a.seeds]
        except ValueError as e:
            if "unknown solver" not in str(e):
                raise
            raise SystemExit(f"{e}\n(while the time-bracket preset is missing: --bracket sipp, "
                             "the stand-in)") from None
        walls[fam] = time.perf_counter() - t0
    what = ("STAND-IN: sipp as the bracket (upper = sipp's arrival, lower = "
            "arrival_lower_bound)" if a.bracket == "sipp" else f"bracket {a.bracket!r}")
    print(f"\n## Time bracket on the time families: {what}\n")
    print(f"seeds {a.seeds}, bracket time_limit {a.time_limit:g} s, heuristics "
          f"time_limit {a.heuristic_time_limit:g} s; load average before {load0}, after "
          f"{_load()}\n")
    print(family_table(rows, walls))
    if a.solvers:
        print("\n### Heuristics: valid arrival at the goal point / upper bound\n")
        print(heuristic_table(rows, a.solvers))


if __name__ == "__main__":
    main()
