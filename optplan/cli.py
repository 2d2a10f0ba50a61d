"""The ``optplan`` command: list, show, solve, bench, validate, plot, animate.

This is the only module that prints.  Bad input (unknown names, malformed scenarios or options,
missing files) ends with a one-line ``optplan: error: ...`` on stderr and exit status 2; pass
``--traceback`` (before the command) to see the Python traceback instead.  matplotlib is
imported only by the commands that draw.

Run ``optplan -h`` or ``optplan COMMAND -h`` for the options; ``docs/cli.md`` has examples.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
import math
import os
import re
import sys
import time
import tomllib
import warnings
from pathlib import Path
from typing import Any, TextIO

__all__ = ["main", "parse_set"]

PROG = "optplan"


class CLIError(Exception):
    """A user error detected by the CLI itself (exit status 2)."""


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def parse_set(items: list[str] | None) -> dict[str, Any]:
    """Parse ``key=value`` items; values are TOML literals, else bare strings.

    >>> parse_set(["w=[0.9, 0.2]", "n=30", "name=ipso-paper", "flag=true"])
    {'w': [0.9, 0.2], 'n': 30, 'name': 'ipso-paper', 'flag': True}
    """
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise CLIError(f"--set expects key=value, got {item!r}")
        value = value.strip()
        try:
            out[key] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            out[key] = value
    return out


def _split_list(s: str | None) -> list[str]:
    return [x.strip() for x in (s or "").split(",") if x.strip()]


def _fmt(x: Any, digits: int = 4) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return str(v)
    return f"{v:.{digits}f}"


def _experiment(name: str) -> Any | None:
    """The module ``optplan.experiments.<name>`` (dashes -> underscores) or None."""
    mod = "optplan.experiments." + name.replace("-", "_")
    try:
        spec = importlib.util.find_spec(mod)
    except (ModuleNotFoundError, ValueError):
        return None
    if spec is None:
        return None
    return importlib.import_module(mod)


def _run_experiment(module: Any, argv: list[str]) -> int:
    fn = getattr(module, "main", None)
    if fn is None:
        raise CLIError(f"{module.__name__} has no main(argv) function")
    try:
        rc = fn(argv)
    except SystemExit as e:  # an experiment using argparse
        code = e.code
        return code if isinstance(code, int) else (0 if code is None else 2)
    return 0 if rc is None else int(rc)


# --------------------------------------------------------------------------------------
# commands
# --------------------------------------------------------------------------------------


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


def cmd_list(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.catalog import load_problem, problem_files, read_preset
    from optplan.solver import BACKENDS, all_preset_files, list_backends

    what = args.what or "all"
    if what in ("all", "problems"):
        rows = []
        for name, path in problem_files().items():
            try:
                prob = load_problem(path)
            except ValueError as e:
                rows.append((name, "", f"(invalid: {e})"))
                continue
            if args.tag and args.tag not in prob.tags:
                continue
            rows.append((name, ",".join(prob.tags), prob.description))
        print(f"problems ({len(rows)}{', tag ' + args.tag if args.tag else ''}):", file=out)
        w = max((len(r[0]) for r in rows), default=0)
        wt = max((len(r[1]) for r in rows), default=0)
        for n, tags, desc in rows:
            print(f"  {n:<{w}}  [{tags:<{wt}}]  {desc}", file=out)
    if what in ("all", "solvers"):
        if what == "all":
            print(file=out)
        avail = set(list_backends())
        rows = []
        for name, path in all_preset_files().items():
            try:
                data = read_preset(path)
            except ValueError as e:
                rows.append((name, "?", f"(invalid: {e})"))
                continue
            if args.tag and data["backend"] != args.tag:
                continue
            note = "" if data["backend"] in avail else " (backend not available yet)"
            rows.append((name, data["backend"], data["summary"] + note))
        print(f"solvers ({len(rows)}{', backend ' + args.tag if args.tag else ''}):", file=out)
        w = max((len(r[0]) for r in rows), default=0)
        wb = max((len(r[1]) for r in rows), default=0)
        for n, b, summ in rows:
            print(f"  {n:<{w}}  {b:<{wb}}  {summ}", file=out)
        bare = [b for b in BACKENDS if b in avail]
        print(f"backends usable by name with their defaults: {', '.join(bare)}", file=out)
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


def _result_lines(res: Any) -> list[str]:
    m = res.metrics
    lines = [f"{res.problem} / {res.solver} (backend {res.backend}, seed {res.seed})",
             f"  status      {res.status.value}"]
    length = f"  length      {_fmt(m.get('length'))}"
    if m.get("ratio_to_optimum") is not None:
        length += (f"   ratio to optimum {_fmt(m['ratio_to_optimum'])}"
                   f" (optimum {_fmt(m.get('optimum'))})")
    lines.append(length)
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
    if res.times is not None and len(res.times):
        lines.append(f"  time to goal {_fmt(res.times[-1], 2)} (simulated)")
    lines.append(f"  effort      {res.n_iter} iterations, {res.n_eval} evaluations, "
                 f"{res.wall_time * 1e3:.1f} ms")
    if res.message:
        lines.append(f"  message     {res.message}")
    return lines


def cmd_solve(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.catalog import load_problem
    from optplan.solver import solve

    overrides = parse_set(args.set)
    res = solve(args.problem, args.solver, rng=args.seed, time_limit=args.time_limit,
                reference=not args.no_reference, **overrides)
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


class _Bar:
    """A one-line progress bar on stderr."""

    def __init__(self, stream: TextIO, width: int = 30):
        self.stream, self.width, self.t0 = stream, width, time.perf_counter()
        isatty = getattr(stream, "isatty", None)
        self.tty = bool(isatty and isatty())
        self.last_decile = -1

    def __call__(self, done: int, total: int, row: dict) -> None:
        frac = done / max(total, 1)
        fill = int(round(self.width * frac))
        el = time.perf_counter() - self.t0
        eta = el / done * (total - done) if done else 0.0
        msg = (f"\r[{'#' * fill}{'.' * (self.width - fill)}] {done}/{total} "
               f"{el:5.1f}s eta {eta:5.1f}s  {row['problem']}/{row['solver']}/{row['seed']}"
               f" {row['status']}")
        if self.tty:
            self.stream.write(msg[:150].ljust(100))
            if done == total:
                self.stream.write("\n")
        else:  # a log file: one line per tenth of the grid
            decile = (10 * done) // max(total, 1)
            if decile == self.last_decile:
                return
            self.last_decile = decile
            self.stream.write(msg[1:].rstrip() + "\n")
        self.stream.flush()


def _expand_scen(problems: list[str], args: argparse.Namespace) -> list[str]:
    """MovingAI ``.scen`` entries of ``--problems`` as one scenario TOML per line, written
    under ``<--out>/problems/`` (:func:`optplan.bench.expand_scen`)."""
    from optplan.bench import expand_scen

    has_scen = any(p.lower().endswith(".scen") for p in problems)
    if args.radius is not None and not has_scen:
        raise CLIError("--radius is the robot radius of .scen problems; --problems has no "
                       ".scen file")
    if not has_scen:
        return problems
    radius = 0.0 if args.radius is None else args.radius
    if not (math.isfinite(radius) and radius >= 0):
        raise CLIError(f"--radius must be a finite number >= 0, got {radius:g}")
    return expand_scen(problems, Path(args.out) / "problems", radius=radius)


def cmd_bench(args: argparse.Namespace, out: TextIO) -> int:
    import shlex

    from optplan.bench import run_grid, summarise, to_markdown, write_csv
    from optplan.catalog import list_problems

    problems = _split_list(args.problems)
    if args.tag:
        tagged = list_problems(tag=args.tag)
        if not tagged:
            raise CLIError(f"no experiment optplan.experiments.{args.tag.replace('-', '_')} "
                           f"and no problem tagged {args.tag!r}")
        problems = problems + [p for p in tagged if p not in problems]
    if not problems:
        raise CLIError("bench needs --problems a,b (or --tag NAME)")
    problems = _expand_scen(problems, args)
    solvers = _split_list(args.solvers)
    if not solvers:
        raise CLIError("bench needs --solvers x,y (or --solvers all)")
    if solvers == ["all"]:
        from optplan.solver import list_solvers

        solvers = list_solvers()
    if args.scheduler and args.dask_local is not None:
        raise CLIError("give --scheduler ADDRESS or --dask-local N, not both")
    if (args.scheduler or args.dask_local is not None) and args.workers != 1:
        raise CLIError("--workers is the local process pool; with --scheduler/--dask-local the "
                       "Dask workers run the sweep (drop --workers)")
    overrides = {"*": parse_set(args.set)} if args.set else None
    bar = _Bar(sys.stderr) if not args.quiet else None
    engine = (f"Dask scheduler {args.scheduler}" if args.scheduler else
              f"Dask LocalCluster of {args.dask_local} workers" if args.dask_local is not None
              else f"workers {args.workers}")
    t0 = time.perf_counter()
    try:
        rows = run_grid(problems, solvers, args.seeds, workers=args.workers,
                        overrides=overrides, progress=bar, time_limit=args.time_limit,
                        db=args.db, scheduler=args.scheduler, dask_local=args.dask_local,
                        command_line=shlex.join([PROG, *sys.argv[1:]]))
    except KeyboardInterrupt:
        kept = (f"; every finished run is in {args.db}: run the same command again to resume"
                if args.db else " (no --db: nothing was kept)")
        print(f"\n{PROG}: interrupted{kept}", file=sys.stderr)
        return 130
    wall = time.perf_counter() - t0
    summary = summarise(rows)
    table = to_markdown(summary)
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    write_csv(rows, outdir / "results.csv")
    limit = f"; time limit {args.time_limit:g} s per run" if args.time_limit else ""
    head = (f"# optplan bench\n\nproblems: {', '.join(problems)}; solvers: "
            f"{', '.join(solvers)}; seeds 0..{args.seeds - 1} (common to every solver); "
            f"{engine}{limit}; total wall time {wall:.1f} s"
            + (f"; database {args.db}" if args.db else "") + ".\n"
            "Length and ratio: medians and inter-quartile ranges over the successful runs only "
            "(status optimal or solved, the success column); time over every run that did not "
            "raise; each run solves a fresh copy of its problem (no cached results); ratio = "
            "length / certified optimum (exact shortest path on the known static map).\n\n")
    if overrides:
        head = head.replace("\n\n", f"\noverrides: {overrides['*']}\n\n", 1)
    (outdir / "summary.md").write_text(head + table + "\n", encoding="utf-8")
    print(table, file=out)
    errors = [r for r in rows if r["status"] == "error"]
    if errors:
        print(f"\n{len(errors)} run(s) raised; first: {errors[0]['message']}", file=out)
    killed = [r for r in rows if r["status"] == "time_limit"]
    if killed:
        print(f"\n{len(killed)} run(s) ignored the time limit and were stopped by the harness",
              file=out)
    written = f"{outdir / 'results.csv'} and {outdir / 'summary.md'}"
    if args.db:
        written += f"; runs stored in {args.db} (optplan report {args.db} --out DIR)"
    print(f"\nwrote {written}", file=out)
    return 0


def cmd_report(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.report import write_report

    t0 = time.perf_counter()
    index = write_report(args.db, args.out, dpi=args.dpi)
    n_png = len(list(index.parent.glob("*.png")))
    print(f"wrote {index} ({n_png} PNGs in {index.parent}) in {time.perf_counter() - t0:.1f} s",
          file=out)
    return 0


def _load_result(path: str, problem: str | None) -> tuple[Any, Any]:
    """The result file and the problem to draw it on, both checked: one error naming the file
    and the key for anything the drawing code could not use (or would draw wrongly)."""
    from optplan.catalog import load_problem
    from optplan.problem import ProblemError, parse_problem
    from optplan.result import Result

    p = Path(path)
    if not p.exists():
        raise CLIError(f"{path}: no such result file")
    try:
        res = Result.load(p)
    except (json.JSONDecodeError, KeyError, TypeError) as e:
        raise CLIError(f"{path}: not an optplan result JSON ({type(e).__name__}: {e})") from None
    if problem:
        prob = load_problem(problem)
    elif isinstance(res.scenario, dict):
        prob = parse_problem(res.scenario, f"{path}: scenario")
    else:
        try:
            prob = load_problem(res.problem)
        except ProblemError as e:
            raise CLIError(f"{path}: problem: {e}; pass --problem NAME_OR_TOML") from None
    _check_result_for(res, prob, path)
    return res, prob


def _finite_points(v: Any, key: str, path: str, prob: Any) -> Any:
    import numpy as np

    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise CLIError(f"{path}: {key}: expected a list of [x, y] numbers") from None
    if a.ndim != 2 or a.shape[1:] != (2,) or not np.all(np.isfinite(a)):
        raise CLIError(f"{path}: {key}: expected finite [x, y] points, got shape {a.shape}")
    if len(a):
        try:
            prob.frame.check_extent(float(np.max(np.abs(prob.frame.local(a)))), key)
        except ValueError as e:
            raise CLIError(f"{path}: {key}: {e}") from None
    return a


def _is_num(v: Any) -> bool:
    import numbers

    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _bad_metric(m: dict[str, Any], key: str, want: str, path: str) -> CLIError:
    v = m[key]
    return CLIError(f"{path}: metrics.{key}: expected {want}, got {type(v).__name__} "
                    f"{str(v)[:40]!r}")


def _check_paths_times(res: Any, prob: Any, path: str) -> None:
    """Robot ids of ``prob`` with resolvable coordinates; finite non-decreasing times."""
    import numpy as np

    for rid, pts in res.paths.items():
        if rid not in prob.robot_ids:
            raise CLIError(f"{path}: paths.{rid}: problem {prob.name!r} has no robot {rid!r} "
                           f"(robots: {', '.join(prob.robot_ids)}); pass --problem")
        _finite_points(pts, f"paths.{rid}", path, prob)
    if res.times is not None:
        t = np.asarray(res.times, dtype=float)
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise CLIError(f"{path}: times: expected finite, non-decreasing time stamps")


def _check_metric_types(m: dict[str, Any], path: str) -> None:
    """The scalar metrics the plots draw: numbers, counts, flags, the leader, per_robot."""
    import numbers

    for key in ("length", "ratio_to_optimum", "optimum", "min_clearance"):
        if m.get(key) is not None and not _is_num(m[key]):
            raise _bad_metric(m, key, "a number", path)
    for key in ("collisions", "dynamic_contacts", "separation_violations", "static_collisions"):
        if m.get(key) is not None and not (isinstance(m[key], numbers.Integral)
                                           and not isinstance(m[key], bool) and m[key] >= 0):
            raise _bad_metric(m, key, "a non-negative integer", path)
    for key in ("in_bounds", "reached", "feasible"):
        if m.get(key) is not None and not isinstance(m[key], bool):
            raise _bad_metric(m, key, "true or false", path)
    if m.get("leader") is not None and not isinstance(m["leader"], str):
        raise _bad_metric(m, "leader", "a robot id string", path)
    if m.get("per_robot") is not None and not (
            isinstance(m["per_robot"], dict)
            and all(isinstance(v, dict) for v in m["per_robot"].values())):
        raise _bad_metric(m, "per_robot", "an object robot id -> object", path)


def _check_contacts(m: dict[str, Any], prob: Any, path: str) -> None:
    """``first_contact`` and ``contacts``: objects with a numeric time, kind, other and an
    optional finite position."""
    contacts = m.get("contacts")
    if contacts is not None and not isinstance(contacts, list):
        raise _bad_metric(m, "contacts", "a list", path)
    named = [("first_contact", m.get("first_contact"))] + [
        (f"contacts[{k}]", c) for k, c in enumerate(contacts or [])]
    for key, c in named:
        if c is None:
            continue
        if not isinstance(c, dict) or not _is_num(c.get("time")) or not isinstance(
                c.get("other", ""), str) or not isinstance(c.get("kind", ""), str):
            raise CLIError(f"{path}: metrics.{key}: expected an object with a numeric time, "
                           "'kind' and 'other'")
        if c.get("position") is not None:
            _finite_points([c["position"]], f"metrics.{key}.position", path, prob)


def _check_result_for(res: Any, prob: Any, path: str) -> None:
    """What ``plot_result`` / ``animate`` read: robot ids of ``prob``, resolvable coordinates,
    finite non-decreasing times, and the metrics and extras they draw with the right types."""
    _check_paths_times(res, prob, path)
    _check_metric_types(res.metrics, path)
    _check_contacts(res.metrics, prob, path)
    for key in ("global_path", "inflection_points"):
        if res.extras.get(key) is not None:
            _finite_points(res.extras[key], f"extras.{key}", path, prob)


#: Largest --dpi of ``show``, ``plot`` and ``animate`` (a 6-inch figure at 1200 dpi is 7200 px).
MAX_DPI = 1200
#: Figure formats of ``show --out`` and ``plot --out``.
FIG_SUFFIXES = (".png", ".svg", ".pdf")


def _check_out(out: str, suffixes: tuple[str, ...], flag: str = "--out") -> None:
    p = Path(out)
    if p.suffix.lower() not in suffixes:
        raise CLIError(f"{flag} {out}: unsupported format {p.suffix or '(none)'!r}; use "
                       + ", ".join(suffixes))
    if p.is_dir():
        raise CLIError(f"{flag} {out}: is a directory")


def _check_dpi(dpi: float) -> None:
    if not (isinstance(dpi, (int, float)) and math.isfinite(dpi) and 1 <= dpi <= MAX_DPI):
        raise CLIError(f"--dpi must be in [1, {MAX_DPI}], got {dpi}")


def cmd_plot(args: argparse.Namespace, out: TextIO) -> int:
    _check_out(args.out, FIG_SUFFIXES)
    _check_dpi(args.dpi)
    if args.snapshot_every is not None and args.snapshot_every < 0:
        raise CLIError(f"--snapshot-every must be >= 0, got {args.snapshot_every}")
    res, prob = _load_result(args.result, args.problem)
    from optplan.plot import plot_result

    plot_result(res, problem=prob, out=args.out, snapshot_every=args.snapshot_every,
                dpi=args.dpi)
    print(f"wrote {args.out}", file=out)
    return 0


def cmd_animate(args: argparse.Namespace, out: TextIO) -> int:
    _check_out(args.out, (".gif",))
    _check_dpi(args.dpi)
    if not (math.isfinite(args.fps) and 0 < args.fps <= 100):
        raise CLIError(f"--fps must be > 0 and at most 100 (GIF frames last >= 10 ms), got "
                       f"{args.fps}")
    if not 1 <= args.max_frames <= 10_000:
        raise CLIError(f"--max-frames must be in [1, 10000], got {args.max_frames}")
    res, prob = _load_result(args.result, args.problem)
    from optplan.plot import animate

    animate(res, args.out, problem=prob, fps=args.fps, max_frames=args.max_frames,
            dpi=args.dpi)
    print(f"wrote {args.out}", file=out)
    return 0


#: Largest ``optplan validate --seeds``.
MAX_SEEDS = 100_000


def cmd_validate(argv: list[str]) -> None:
    """Check the arguments of ``optplan validate`` before the experiment runs: the problem
    loads, ``--seeds`` in [1, MAX_SEEDS], ``--first-seed >= 0``, ``--solver`` / ``--nlp`` name
    solvers (each error names the flag).  Malformed command lines are left to the experiment's
    own parser (its usage message)."""
    from optplan.catalog import load_problem
    from optplan.solver import get_solver

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("problem", nargs="?")
    ap.add_argument("--seeds", type=int)
    ap.add_argument("--first-seed", type=int)
    ap.add_argument("--solver")
    ap.add_argument("--nlp")
    ap.add_argument("-h", "--help", action="store_true")
    try:
        args, _ = ap.parse_known_args(argv)
    except SystemExit:  # the experiment's parser reports it
        return
    if args.help:
        return
    if args.seeds is not None and not 1 <= args.seeds <= MAX_SEEDS:
        raise CLIError(f"--seeds must be in [1, {MAX_SEEDS}], got {args.seeds}")
    if args.first_seed is not None and args.first_seed < 0:
        raise CLIError(f"--first-seed must be >= 0, got {args.first_seed}")
    if args.problem:
        load_problem(args.problem)
    for flag, name in (("--solver", args.solver), ("--nlp", args.nlp)):
        if name:
            try:
                get_solver(name)
            except ValueError as e:
                raise CLIError(f"{flag} {name}: {e}") from None


def _xy(text: str, flag: str) -> tuple[float, ...]:
    try:
        vals = tuple(float(t) for t in text.replace(",", " ").split())
    except ValueError:
        vals = ()
    if len(vals) != 2 or not all(math.isfinite(v) for v in vals):
        raise CLIError(f"{flag}: expected X,Y (two numbers), got {text!r}")
    return vals


def cmd_import_map(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.catalog import find_map
    from optplan.maps import import_map, to_toml

    path = find_map(args.map)
    starts = [_xy(s, "--start") for s in args.start]
    goals = [_xy(g, "--goal") for g in args.goal]
    if len(starts) != len(goals):
        raise CLIError(f"give one --goal per --start (got {len(starts)} and {len(goals)})")
    if args.robot and len(args.robot) != len(starts):
        raise CLIError(f"give one --robot per --start (got {len(args.robot)} and {len(starts)})")
    origin = None
    if args.origin is not None:
        try:
            origin = [float(t) for t in args.origin.replace(",", " ").split()]
        except ValueError:
            origin = []
        if len(origin) not in (2, 3):
            raise CLIError(f"--origin: expected X,Y or X,Y,YAW, got {args.origin!r}")
    info: dict[str, Any] = {}
    t0 = time.perf_counter()
    prob = import_map(
        path, radius=args.radius, start=starts, goal=goals, robot_id=args.robot or None,
        max_speed=args.max_speed, resolution=args.resolution, origin=origin,
        negate=True if args.negate else None, mode=args.mode,
        occupied_thresh=args.occupied_thresh, free_thresh=args.free_thresh,
        unknown=args.unknown, grow=args.grow, simplify=args.simplify, join=args.join,
        fill_unreachable=not args.keep_holes, name=args.name, info=info)
    dt = time.perf_counter() - t0
    header = (f"Imported from {path} by 'optplan import-map' (grow {args.grow:g} cells, "
              f"simplify {args.simplify:g} cells, unknown = {args.unknown}).")
    text = to_toml(prob, header)
    if not args.out:
        out.write(text)
        return 0
    dest = Path(args.out)
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_text(text, encoding="utf-8")
    c = info["cells"]
    print(f"{path}: {c['occupied']} occupied, {c['unknown']} unknown, {c['free']} free cells "
          f"-> {info['polygons']} polygons, {info['vertices']} vertices "
          f"({info['holes_filled']} unreachable holes filled) in {dt * 1e3:.0f} ms", file=out)
    print(f"wrote {dest} (try: {PROG} solve {dest} visgraph)", file=out)
    return 0


# --------------------------------------------------------------------------------------
# parser and entry point
# --------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="optplan: optimisation-centric path planning for robot teams.",
        epilog="Run 'optplan COMMAND -h' for a command's options.",
    )
    p.add_argument("--traceback", action="store_true",
                   help="show Python tracebacks instead of one-line errors")
    from optplan import __version__

    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    s = sub.add_parser("list", help="list catalogue problems and solver presets")
    s.add_argument("what", nargs="?", choices=["problems", "solvers"],
                   help="only problems or only solvers")
    s.add_argument("--tag", help="problems carrying this tag / solvers of this backend")
    s.set_defaults(func=cmd_list)

    s = sub.add_parser("show-solver",
                       help="a solver's options: value, default, allowed values, meaning")
    s.add_argument("solver", help="preset name, backend name or .toml preset")
    s.set_defaults(func=cmd_show_solver)

    s = sub.add_parser("show", help="describe a problem and its certified optimum")
    s.add_argument("problem", help="catalogue name or .toml path")
    s.add_argument("--out", help="write a PNG of the map")
    s.add_argument("--dpi", type=int, default=120, help="PNG resolution (default 120)")
    s.set_defaults(func=cmd_show)

    s = sub.add_parser("solve", help="solve one problem with one solver")
    s.add_argument("problem", help="catalogue name or .toml path")
    s.add_argument("solver", help="preset name, backend name or .toml preset")
    s.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    s.add_argument("--time-limit", type=float, default=None, metavar="S",
                   help="stop after S seconds and return the best result so far")
    s.add_argument("--no-reference", action="store_true",
                   help="do not compute the certified optimum (no ratio to optimum)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override an option; VALUE is a TOML literal (repeatable)")
    s.add_argument("--json", metavar="FILE", help="save the Result as JSON")
    s.add_argument("--plot", metavar="PNG", help="save a picture of the result")
    s.set_defaults(func=cmd_solve)

    s = sub.add_parser(
        "bench", help="problems x solvers x seeds, or a named experiment (--tag)",
        description="Run problems x solvers x seeds (common seeds across solvers). With "
                    "--tag NAME: if optplan.experiments.NAME exists, the remaining arguments "
                    "go to its main(); otherwise the problems tagged NAME are benchmarked.")
    s.add_argument("--problems",
                   help="comma-separated problem names, .toml paths or MovingAI .scen files "
                        "(one problem per .scen line)")
    s.add_argument("--radius", type=float, default=None, metavar="R",
                   help="robot radius of the problems read from .scen files (map units; "
                        "default 0: point robots)")
    s.add_argument("--solvers", help="comma-separated solver names, or 'all' (every preset)")
    s.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 (default 10)")
    s.add_argument("--workers", type=int, default=1, help="processes (default 1: inline)")
    s.add_argument("--out", default="runs/bench", help="output directory (default runs/bench)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override an option of every solver (TOML literal; repeatable)")
    s.add_argument("--tag", help="experiment name or problem tag")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.add_argument("--db", metavar="FILE.sqlite",
                   help="store every run in this SQLite file as it finishes; rerunning the "
                        "same command resumes (finished problem/solver/seed cells are skipped)")
    s.add_argument("--time-limit", type=float, default=None, metavar="S",
                   help="seconds per run: the solver stops at its first iteration after S; a "
                        "run still going at S + max(1, S/2) is stopped by the harness")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on an existing Dask cluster (e.g. tcp://host:8786; needs "
                        "dask[distributed])")
    s.add_argument("--dask-local", type=int, default=None, metavar="N",
                   help="run on a Dask LocalCluster of N worker processes")
    s.set_defaults(func=cmd_bench)

    s = sub.add_parser("report", help="HTML + PNG report of a bench results database",
                       description="Write a static HTML page (no server) with PNG plots per "
                                   "problem from a database written by 'optplan bench --db': "
                                   "outcome and success rate, length / optimum and wall-time "
                                   "box plots per solver, convergence curves, summary tables.")
    s.add_argument("db", help="results database (SQLite) written by 'optplan bench --db'")
    s.add_argument("--out", default="report", help="output directory (default report)")
    s.add_argument("--dpi", type=int, default=100, help="PNG resolution (default 100)")
    s.set_defaults(func=cmd_report)

    s = sub.add_parser("validate", add_help=False,
                       help="certify a solver against the exact references "
                            "(optplan.experiments.validate; 'optplan validate -h')")
    s.set_defaults(func=None)

    s = sub.add_parser("plot", help="draw a saved result (JSON) as a PNG, SVG or PDF")
    s.add_argument("result", help="result JSON written by 'optplan solve --json'")
    s.add_argument("--out", required=True,
                   help="figure to write: .png, .svg or .pdf (the suffix picks the format)")
    s.add_argument("--dpi", type=float, default=100, help="PNG resolution (default 100)")
    s.add_argument("--snapshot-every", type=int, default=None, metavar="K",
                   help="formation snapshot every K steps (0: none; default about 8 per run)")
    s.add_argument("--problem", help="problem name or .toml path (default: the result's)")
    s.set_defaults(func=cmd_plot)

    s = sub.add_parser("animate", help="animate a saved result (JSON) as a GIF")
    s.add_argument("result", help="result JSON written by 'optplan solve --json'")
    s.add_argument("--out", required=True, help="GIF to write")
    s.add_argument("--dpi", type=float, default=80, help="frame resolution (default 80)")
    s.add_argument("--fps", type=float, default=10, help="frames per second (default 10)")
    s.add_argument("--max-frames", type=int, default=150, help="frame limit (default 150)")
    s.add_argument("--problem", help="problem name or .toml path (default: the result's)")
    s.set_defaults(func=cmd_animate)

    s = sub.add_parser(
        "import-map", help="turn an occupancy map into a scenario TOML",
        description="Import a ROS map_server YAML (+ image), a bare PNG/PGM image (with "
                    "--resolution and --origin) or a MovingAI .map as a scenario: obstacle "
                    "cells become conservative polygons (every cell inside; docs/maps.md). "
                    "MAP may also name a shipped map (problems/maps/), e.g. 'warehouse'.")
    # values such as "-11,-11.5" are points, not options (argparse only knows "-11" and "-1.5")
    s._negative_number_matcher = re.compile(r"^-\d+$|^-\d*\.\d+$|^-\d*\.?\d*(e-?\d+)?[, ]")
    s.add_argument("map", help="map file (.yaml, .png/.pgm/..., .map) or shipped map name")
    s.add_argument("--radius", type=float, required=True, help="robot radius (map units)")
    s.add_argument("--start", action="append", required=True, metavar="X,Y",
                   help="start of a robot (repeat for several robots)")
    s.add_argument("--goal", action="append", required=True, metavar="X,Y",
                   help="goal of a robot (one per --start)")
    s.add_argument("--robot", action="append", metavar="ID",
                   help="robot id (one per --start; default r1, r2, ...)")
    s.add_argument("--max-speed", type=float, default=1.0, metavar="V",
                   help="speed limit of every robot (map units / s, default 1)")
    s.add_argument("--out", metavar="TOML", help="scenario file to write (default: stdout)")
    s.add_argument("--name", help="scenario name (default: the map file's stem)")
    s.add_argument("--resolution", type=float, metavar="RES",
                   help="cell size of a bare image or MovingAI map (map units per cell)")
    s.add_argument("--origin", metavar="X,Y[,YAW]",
                   help="world pose of the lower-left corner of a bare image or .map")
    s.add_argument("--negate", action="store_true", help="bare image: dark pixels are free")
    s.add_argument("--mode", choices=["trinary", "scale", "raw"],
                   help="bare image: map_server mode (default trinary)")
    s.add_argument("--occupied-thresh", type=float, metavar="P",
                   help="bare image: occupied above this probability (default 0.65)")
    s.add_argument("--free-thresh", type=float, metavar="P",
                   help="bare image: free below this probability (default 0.196)")
    s.add_argument("--unknown", choices=["occupied", "free"], default="occupied",
                   help="what unknown cells are (default occupied)")
    s.add_argument("--grow", type=float, default=0.5, metavar="CELLS",
                   help="growth of the cell union before simplifying (cells, default 0.5)")
    s.add_argument("--simplify", type=float, default=0.5, metavar="CELLS",
                   help="Douglas-Peucker tolerance (cells, default 0.5; reduced where the "
                        "simplified polygon would not cover every cell)")
    s.add_argument("--join", choices=["round", "mitre"], default="round",
                   help="growth corners: round (Euclidean, default) or mitre (square)")
    s.add_argument("--keep-holes", action="store_true",
                   help="keep free holes no start or goal lies in (default: fill them)")
    s.set_defaults(func=cmd_import_map)
    return p


def _tag_of(argv: list[str]) -> tuple[str | None, list[str]]:
    """Extract ``--tag NAME`` / ``--tag=NAME`` from ``argv``; return (NAME, the rest)."""
    for i, a in enumerate(argv):
        if a == "--tag" and i + 1 < len(argv):
            return argv[i + 1], argv[:i] + argv[i + 2:]
        if a.startswith("--tag="):
            return a.split("=", 1)[1], argv[:i] + argv[i + 1:]
    return None, argv


def _dispatch(argv: list[str], out: TextIO) -> int:
    # global flags before the command
    i = 0
    while i < len(argv) and argv[i] == "--traceback":
        i += 1
    cmd, rest = (argv[i], argv[i + 1:]) if i < len(argv) else (None, [])
    if cmd == "validate":
        mod = _experiment("validate")
        if mod is None:
            raise CLIError("'validate' is not available in this build "
                           "(module optplan.experiments.validate is missing)")
        cmd_validate(rest)
        return _run_experiment(mod, rest)
    if cmd == "bench":
        tag, others = _tag_of(rest)
        if tag:
            mod = _experiment(tag)
            if mod is not None:
                return _run_experiment(mod, others)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
    if args.command is None:
        parser.print_help(out)
        return 0
    return args.func(args, out)


def _one_line(msg: Any) -> str:
    return " ".join(str(msg).split())


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``optplan`` console script; returns the exit status.

    Bad input ends with one line ``optplan: error: ...`` on stderr and exit status 2; an
    unexpected exception (a bug) with one line ``optplan: internal error: ...`` and exit status
    1.  Warnings raised while a command runs are held back: none is printed before an error
    line; after a successful command each distinct one is printed once as ``optplan: warning:``.
    ``--traceback`` (before the command) shows Python's tracebacks and warnings instead.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    show_tb = bool(argv) and argv[0] == "--traceback"
    from optplan.problem import ProblemError

    if show_tb:
        return _dispatch(argv, sys.stdout)
    with warnings.catch_warnings(record=True) as caught:
        try:
            rc = _dispatch(argv, sys.stdout)
        except BrokenPipeError:
            # the reader went away (e.g. `optplan list | head`): stop quietly, as Unix tools do
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            return 0
        except (CLIError, ProblemError, ValueError, FileNotFoundError, KeyError, ImportError,
                OSError) as e:
            msg = e.args[0] if isinstance(e, KeyError) and e.args else str(e)
            print(f"{PROG}: error: {_one_line(msg)}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print(f"\n{PROG}: interrupted", file=sys.stderr)
            return 130
        except Exception as e:  # a bug, not bad input: one line, and how to see more
            print(f"{PROG}: internal error: {type(e).__name__}: {_one_line(e)[:500]} (a bug; "
                  f"rerun with '{PROG} --traceback ...' and report it)", file=sys.stderr)
            return 1
    seen = set()
    for w in caught:
        line = f"{PROG}: warning: {w.category.__name__}: {_one_line(w.message)}"
        if line not in seen:
            seen.add(line)
            print(line, file=sys.stderr)
    return rc


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
