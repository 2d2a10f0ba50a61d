"""The ``optplan`` entry point: experiments by tag, dispatch to a command, one-line errors."""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
import warnings
from typing import Any, TextIO

from optplan.cli.common import PROG, CLIError
from optplan.cli.parser import build_parser
from optplan.cli.sweep import cmd_validate


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
    args.argv = list(argv)  # the command line as given (main(argv) from Python too)
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
