"""``optplan list``, ``optplan show`` and ``optplan show-solver``: the catalogue and the presets."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

from optplan.cli.figures import FIG_SUFFIXES, _check_dpi, _check_out


def cmd_show_solver(args: argparse.Namespace, out: TextIO) -> int:
    """Print a solver's options: value, default, allowed values and meaning."""
    import textwrap

    from optplan.options import describe_options
    from optplan.solver import get_solver

    solver = get_solver(args.solver)
    cls = type(solver)
    doc = (cls.__doc__ or "").strip().splitlines()
    print(f"{args.solver}: backend {cls.name!r} ({cls.__module__}.{cls.__name__})", file=out)
    if doc:
        print(f"  {doc[0]}", file=out)
    print(file=out)
    rows = describe_options(cls)
    w = max(len(r["name"]) for r in rows)
    for r in rows:
        val = getattr(solver, r["name"])
        mark = "" if val == r["default"] else f"   (default {r['default']!r})"
        print(f"  {r['name']:<{w}}  = {val!r}{mark}", file=out)
        print(f"  {'':<{w}}    {r['allowed']}", file=out)
        if r["meaning"]:
            for ln in textwrap.wrap(r["meaning"], 96 - w):
                print(f"  {'':<{w}}    {ln}", file=out)
    return 0


def _rows(files: dict[str, Any], read: Callable[[Any], Any], none: str,
          row: Callable[[str, Any], tuple[str, str, str] | None]) -> list[tuple[str, str, str]]:
    """``row(name, read(path))`` of every file that ``row`` keeps; ``(name, none, "(invalid:
    ...)")`` of a file ``read`` rejects."""
    rows = []
    for name, path in files.items():
        try:
            item = read(path)
        except ValueError as e:
            rows.append((name, none, f"(invalid: {e})"))
            continue
        if (r := row(name, item)) is not None:
            rows.append(r)
    return rows


def _problem_rows(tag: str | None) -> list[tuple[str, str, str]]:
    """(name, tags, description) of every catalogue problem (with ``tag``, those tagged so)."""
    from optplan.catalog import load_problem, problem_files

    return _rows(problem_files(), load_problem, "", lambda name, prob: (
        None if tag and tag not in prob.tags else (name, ",".join(prob.tags), prob.description)))


def _solver_rows(tag: str | None, avail: set[str]) -> list[tuple[str, str, str]]:
    """(name, backend, summary) of every preset (with ``tag``, those of that backend)."""
    from optplan.catalog import read_preset
    from optplan.solver import all_preset_files

    def row(name: str, data: dict[str, Any]) -> tuple[str, str, str] | None:
        if tag and data["backend"] != tag:
            return None
        note = "" if data["backend"] in avail else " (backend not available yet)"
        return name, data["backend"], data["summary"] + note

    return _rows(all_preset_files(), read_preset, "?", row)


def _list_problems(args: argparse.Namespace, out: TextIO) -> None:
    rows = _problem_rows(args.tag)
    print(f"problems ({len(rows)}{', tag ' + args.tag if args.tag else ''}):", file=out)
    w = max((len(r[0]) for r in rows), default=0)
    wt = max((len(r[1]) for r in rows), default=0)
    for n, tags, desc in rows:
        print(f"  {n:<{w}}  [{tags:<{wt}}]  {desc}", file=out)


def _list_solvers(args: argparse.Namespace, out: TextIO) -> None:
    from optplan.solver import BACKENDS, list_backends

    avail = set(list_backends())
    rows = _solver_rows(args.tag, avail)
    print(f"solvers ({len(rows)}{', backend ' + args.tag if args.tag else ''}):", file=out)
    w = max((len(r[0]) for r in rows), default=0)
    wb = max((len(r[1]) for r in rows), default=0)
    for n, b, summ in rows:
        print(f"  {n:<{w}}  {b:<{wb}}  {summ}", file=out)
    bare = [b for b in BACKENDS if b in avail]
    print(f"backends usable by name with their defaults: {', '.join(bare)}", file=out)


def cmd_list(args: argparse.Namespace, out: TextIO) -> int:
    what = args.what or "all"
    if what in ("all", "problems"):
        _list_problems(args, out)
    if what in ("all", "solvers"):
        if what == "all":
            print(file=out)
        _list_solvers(args, out)
    return 0


def cmd_show(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.catalog import load_problem
    from optplan.solver import solve

    if args.out:
        _check_out(args.out, FIG_SUFFIXES)
        _check_dpi(args.dpi)
    prob = load_problem(args.problem)
    print(prob.summary(), file=out)
    for r in prob.robots:
        goal = "formation slot" if r.goal is None else f"({r.goal[0]:g}, {r.goal[1]:g})"
        print(f"  robot {r.id}: start ({r.start[0]:g}, {r.start[1]:g}) -> goal {goal}, "
              f"radius {r.radius:g}, max speed {r.max_speed:g}", file=out)
    if prob.sensing_range is not None:
        print(f"  sensing range {prob.sensing_range:g}", file=out)
    ref = solve(prob, "visgraph")
    if ref.status.value != "optimal":
        print(f"  visgraph: {ref.status.value}: {ref.message}", file=out)
    exact = ref.metrics.get("lengths_exact", {})
    for rid, length in exact.items():
        poly = ref.metrics.get("lengths", {}).get(rid, float("nan"))
        print(f"  visgraph optimum ({rid}, known static map): {length:.4f} exact "
              f"(segments + arcs; returned polyline {poly:.4f})", file=out)
    if args.out:
        from optplan.plot import plot_problem

        fig = plot_problem(prob)
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.out, dpi=args.dpi, bbox_inches="tight")
        print(f"wrote {args.out}", file=out)
    return 0
