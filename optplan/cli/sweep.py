"""``optplan bench``, ``optplan report`` and ``optplan validate``: sweeps and their reports."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import TextIO

from optplan.cli.common import PROG, CLIError, _split_list, parse_set


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
    """MovingAI ``.scen`` entries of ``--problems`` as the names of their lines,
    ``<file>.scen#line=N`` (:func:`optplan.bench.expand_scen`)."""
    from optplan.bench import expand_scen
    from optplan.bench.scen import parse_buckets

    has_scen = any(p.lower().endswith(".scen") for p in problems)
    for flag, v, what in (("--radius", args.radius, "the robot radius"),
                          ("--buckets", args.buckets, "the bucket selection")):
        if v is not None and not has_scen:
            raise CLIError(f"{flag} is {what} of .scen problems; --problems has no .scen file")
    if not has_scen:
        return problems
    radius = 0.0 if args.radius is None else args.radius
    if not (math.isfinite(radius) and radius >= 0):
        raise CLIError(f"--radius must be a finite number >= 0, got {radius:g}")
    try:
        buckets = None if args.buckets is None else parse_buckets(args.buckets, "--buckets")
    except ValueError as e:
        raise CLIError(str(e)) from None
    return expand_scen(problems, radius=radius, buckets=buckets)


def _bench_problems(args: argparse.Namespace) -> list[str]:
    """``--problems`` and the problems tagged ``--tag``, ``.scen`` files expanded."""
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
    return _expand_scen(problems, args)


def _bench_solvers(args: argparse.Namespace) -> list[str]:
    """``--solvers``; ``all``: every preset."""
    solvers = _split_list(args.solvers)
    if not solvers:
        raise CLIError("bench needs --solvers x,y (or --solvers all)")
    if solvers == ["all"]:
        from optplan.solver import list_solvers

        solvers = list_solvers()
    return solvers


def _bench_engine(args: argparse.Namespace) -> str:
    """The engine's description, after checking that one engine is asked for."""
    if args.scheduler and args.dask_local is not None:
        raise CLIError("give --scheduler ADDRESS or --dask-local N, not both")
    if (args.scheduler or args.dask_local is not None) and args.workers != 1:
        raise CLIError("--workers is the local process pool; with --scheduler/--dask-local the "
                       "Dask workers run the sweep (drop --workers)")
    return (f"Dask scheduler {args.scheduler}" if args.scheduler else
            f"Dask LocalCluster of {args.dask_local} workers" if args.dask_local is not None
            else f"workers {args.workers}")


def _summary_head(args: argparse.Namespace, problems: list[str], solvers: list[str],
                  engine: str, wall: float, overrides: dict | None) -> str:
    """The head of ``summary.md``: what ran, on what, how long, and how to read the table."""
    limit = f"; time limit {args.time_limit:g} s per run" if args.time_limit else ""
    named = ", ".join(problems)
    if any(p.lower().endswith(".scen") for p in _split_list(args.problems)):
        named = (f"{args.problems} ({len(problems)} problems, each .scen line one"
                 + (f" of the buckets {args.buckets}" if args.buckets else "") + ")")
    head = (f"# optplan bench\n\nproblems: {named}; solvers: "
            f"{', '.join(solvers)}; seeds 0..{args.seeds - 1} (common to every solver); "
            f"{engine}{limit}; total wall time {wall:.1f} s"
            + (f"; database {args.db}" if args.db else "") + ".\n"
            "Length and ratio: medians and inter-quartile ranges over the successful runs only "
            "(status optimal or solved, the success column); time over every run that did not "
            "raise; each run solves a fresh copy of its problem (no cached results); ratio = "
            "length / certified optimum (exact shortest path on the known static map).\n\n")
    if overrides:
        head = head.replace("\n\n", f"\noverrides: {overrides['*']}\n\n", 1)
    return head


def _print_failures(rows: list[dict], out: TextIO) -> None:
    """How many runs raised (the first message) and how many the harness stopped."""
    errors = [r for r in rows if r["status"] == "error"]
    if errors:
        print(f"\n{len(errors)} run(s) raised; first: {errors[0]['message']}", file=out)
    killed = [r for r in rows if r["status"] == "time_limit"]
    if killed:
        print(f"\n{len(killed)} run(s) ignored the time limit and were stopped by the harness",
              file=out)


def _tables(rows: list[dict]) -> tuple[str, str]:
    """The tables of a sweep: (printed, written to ``summary.md``).  Without ``.scen`` lines
    both are the table per problem and solver; with them, the printed one has the other
    problems' rows and the table per ``.scen`` file, bucket and solver
    (:func:`optplan.bench.buckets.summarise_buckets`), ``summary.md`` also every line's."""
    from optplan.bench import summarise, to_markdown
    from optplan.bench.buckets import buckets_markdown, has_buckets, summarise_buckets

    table = to_markdown(summarise(rows))
    if not has_buckets(rows):
        return table, table
    per_bucket = ("Per bucket (the .scen lines; ratios over the successful runs: to the "
                  "certified Euclidean optimum and to the file's octile optimum):\n\n"
                  + buckets_markdown(summarise_buckets(rows)))
    others = [r for r in rows if r.get("bucket") is None]
    printed = (to_markdown(summarise(others)) + "\n\n" if others else "") + per_bucket
    return printed, per_bucket + "\n\nPer problem:\n\n" + table


def cmd_bench(args: argparse.Namespace, out: TextIO) -> int:
    import shlex

    from optplan.bench import Engine, run_grid, write_csv

    problems = _bench_problems(args)
    solvers = _bench_solvers(args)
    engine_text = _bench_engine(args)
    overrides = {"*": parse_set(args.set)} if args.set else None
    bar = _Bar(sys.stderr) if not args.quiet else None
    t0 = time.perf_counter()
    try:
        rows = run_grid(problems, solvers, args.seeds,
                        engine=Engine(workers=args.workers, scheduler=args.scheduler,
                                      dask_local=args.dask_local),
                        overrides=overrides, progress=bar, time_limit=args.time_limit,
                        db=args.db,
                        command_line=shlex.join([PROG, *getattr(args, "argv", sys.argv[1:])]))
    except KeyboardInterrupt:
        kept = (f"; every finished run is in {args.db}: run the same command again to resume"
                if args.db else " (no --db: nothing was kept)")
        print(f"\n{PROG}: interrupted{kept}", file=sys.stderr)
        return 130
    wall = time.perf_counter() - t0
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    write_csv(rows, outdir / "results.csv")
    head = _summary_head(args, problems, solvers, engine_text, wall, overrides)
    printed, written = _tables(rows)
    (outdir / "summary.md").write_text(head + written + "\n", encoding="utf-8")
    print(printed, file=out)
    _print_failures(rows, out)
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


def cmd_export_arena(args: argparse.Namespace, out: TextIO) -> int:
    """``optplan export-arena RUNS.sqlite ARENA.db``: the sweep as an OMPL benchmark database
    (:func:`optplan.bench.summary.export_arena`) for Planner Arena."""
    from optplan.bench.summary import export_arena

    n = export_arena(args.db, args.out)
    print(f"wrote {args.out}: {n['experiments']} experiment(s), {n['planners']} planner "
          f"configuration(s), {n['runs']} run(s), {n['progress']} progress row(s) "
          f"(open it in Planner Arena: plannerarena, then upload the file)", file=out)
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
