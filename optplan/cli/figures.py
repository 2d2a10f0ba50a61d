"""``optplan plot`` and ``optplan animate``: a saved result checked, then drawn."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any, TextIO

from optplan.cli.common import CLIError


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


def _is_count(v: Any) -> bool:
    import numbers

    return isinstance(v, numbers.Integral) and not isinstance(v, bool) and int(v) >= 0


def _is_robot_table(v: Any) -> bool:
    return isinstance(v, dict) and all(isinstance(x, dict) for x in v.values())


#: (metric keys, the test each value passes, what is expected), checked in this order
_METRIC_KINDS = (
    (("length", "ratio_to_optimum", "optimum", "min_clearance"), _is_num, "a number"),
    (("collisions", "dynamic_contacts", "separation_violations", "static_collisions"),
     _is_count, "a non-negative integer"),
    (("in_bounds", "reached", "feasible"), lambda v: isinstance(v, bool), "true or false"),
    (("leader",), lambda v: isinstance(v, str), "a robot id string"),
    (("per_robot",), _is_robot_table, "an object robot id -> object"),
)


def _check_metric_types(m: dict[str, Any], path: str) -> None:
    """The scalar metrics the plots draw: numbers, counts, flags, the leader, per_robot."""
    for keys, ok, want in _METRIC_KINDS:
        for key in keys:
            if m.get(key) is not None and not ok(m[key]):
                raise _bad_metric(m, key, want, path)


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
