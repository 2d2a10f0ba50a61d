"""``optplan solve``: one problem, one solver, the result's summary lines."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

from optplan.cli.common import _fmt, parse_set


def _arrival_line(m: dict[str, Any]) -> list[str]:
    """The grading in time (``reference=True`` with moving obstacles): the arrival, then its
    ratios to the fastest timing of the same path, to the reference (the time bracket's upper
    side) and to the certified lower bound."""
    lines = [f"  arrival     {_fmt(m.get('arrival_time'))} s"]
    if m.get("arrival_completion"):  # accepted inside the goal tolerance: graded at the goal
        lines[0] += (f"   at goal {_fmt(m.get('arrival_at_goal'))} s "
                     f"({m.get('arrival_completion_status')})")
    source = ("this plan: earlier than the time bracket" if m.get("time_reference_source")
              else "time bracket")
    refs = (("schedule", "arrival_ratio_to_schedule", "schedule_arrival",
             "the fastest timing of this path"),
            ("reference", "arrival_ratio_to_reference", "time_reference", source),
            ("lower bound", "arrival_ratio_to_lower", "time_lower_bound",
             m.get("time_bound_reason")))
    for name, ratio, value, what in refs:
        if m.get(ratio) is not None:
            lines.append(f"    ratio to {name:<12}{_fmt(m[ratio])} ({_fmt(m[value])} s: {what})")
    if m.get("schedule_message"):
        lines.append(f"    schedule: {m['schedule_message']}")
    return lines


def _team_lines(m: dict[str, Any]) -> list[str]:
    """The grading against the team reference (``reference="team"``): the front of the best
    known team plans, its certified lower bound; robots with their own goals: their sum."""
    lines = []
    if m.get("team_reference_status", "no formation") != "no formation":
        lines.append(f"  team ref    {m['team_reference_status']}: "
                     f"{m.get('team_reference_message', '')}")
    rows = (("arrival", "arrival_ratio_to_team", "team_arrival_reference", "reference"),
            ("formation rmse", "formation_rmse_ratio_to_team", "team_formation_rmse_reference",
             "reference"),
            ("arrival", "arrival_ratio_to_team_lower", "team_arrival_lower_bound",
             "lower bound"),
            ("sum", "sum_ratio_to_reference", "sum_reference", "reference"),
            ("sum", "sum_ratio_to_lower", "sum_lower_bound", "lower bound"))
    for name, ratio, value, what in rows:
        if m.get(ratio) is not None:
            source = m.get(f"{value}_source")
            lines.append(f"    {name:<15} ratio to the {what} {_fmt(m[ratio])} "
                         f"({what} {_fmt(m[value])}" + (f": {source})" if source else ")"))
    return lines


def _length_lines(m: dict[str, Any]) -> list[str]:
    """The length (with its ratio to the certified optimum) and the arrival lines."""
    length = f"  length      {_fmt(m.get('length'))}"
    if m.get("goal_completion"):  # accepted inside the goal tolerance: graded at the goal
        length += f" (+{_fmt(m['goal_completion'])} to the goal point)"
    if m.get("ratio_to_optimum") is not None:
        length += (f"   ratio to optimum {_fmt(m['ratio_to_optimum'])}"
                   f" (optimum {_fmt(m.get('optimum'))})")
    return [length, *_arrival_line(m)] if "arrival_time" in m else [length]


def _result_lines(res: Any) -> list[str]:
    m = res.metrics
    lines = [f"{res.problem} / {res.solver} (backend {res.backend}, seed {res.seed})",
             f"  status      {res.status.value}"]
    lines.extend(_length_lines(m))
    lens = m.get("lengths") or {}
    if len(lens) > 1:
        lines.append("  lengths     " + ", ".join(f"{k} {_fmt(v, 2)}" for k, v in lens.items()))
    coll = f"  collisions  {m.get('collisions', '?')}"
    if m.get("collisions"):
        coll += (f" (static {m.get('static_collisions', 0)}, dynamic "
                 f"{m.get('dynamic_contacts', 0)}, separation "
                 f"{m.get('separation_violations', 0)})")
        if m.get("per_robot"):
            crossed = sorted({c for pr in m["per_robot"].values() for c in pr.get("crossed", [])})
            if crossed:
                coll += f"; crossed {', '.join(crossed)}"
    lines.append(coll)
    lines.append(f"  reached     {m.get('reached')}   min clearance "
                 f"{_fmt(m.get('min_clearance'), 3)}")
    if "formation_rmse" in m:
        lines.append(f"  formation   rmse {_fmt(m['formation_rmse'], 3)}, max error "
                     f"{_fmt(m.get('formation_max_error'), 3)}")
    if "min_separation" in m:
        lines.append(f"  separation  min {_fmt(m['min_separation'], 3)} (safety "
                     f"{_fmt(m.get('safety_distance'), 3)})")
    lines.extend(_team_lines(m))
    if res.times is not None and len(res.times):
        lines.append(f"  time to goal {_fmt(res.times[-1], 2)} (simulated)")
    lines.append(f"  effort      {res.n_iter} iterations, {res.n_eval} evaluations, "
                 f"{res.wall_time * 1e3:.1f} ms")
    if res.message:
        lines.append(f"  message     {res.message}")
    return lines


def progress_printer(err: TextIO) -> Callable[[Any], None]:
    """``optplan solve --progress``: a callback printing one line to ``err`` whenever what it
    shows changes: the iteration and the best cost, and for a bracket (``time-bracket``:
    ``arrival_lower`` and ``arrival_gap`` in ``info``) the bracket closing."""
    last = [""]

    def show(p: Any) -> None:
        line = f"progress: iteration {p.iteration}  best {_fmt(p.best_cost)}"
        if "arrival_lower" in p.info:
            line += (f"  bracket [{_fmt(p.info['arrival_lower'])}, {_fmt(p.best_cost)}] s, "
                     f"gap {100 * p.info['arrival_gap']:.3g} %")
        if line != last[0]:
            last[0] = line
            print(line, file=err, flush=True)

    return show


def cmd_solve(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.catalog import load_problem
    from optplan.solver import solve

    overrides = parse_set(args.set)
    reference: bool | str = "team" if args.team_reference else not args.no_reference
    res = solve(args.problem, args.solver, rng=args.seed, time_limit=args.time_limit,
                reference=reference, callback=progress_printer(sys.stderr) if args.progress
                else None, **overrides)
    for line in _result_lines(res):
        print(line, file=out)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        res.save(args.json)
        print(f"wrote {args.json}", file=out)
    if args.plot:
        from optplan.plot import plot_result

        plot_result(res, problem=load_problem(args.problem), out=args.plot)
        print(f"wrote {args.plot}", file=out)
    return 0
