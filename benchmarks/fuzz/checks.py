"""What every runner uses: the independent shapely path check, the classification of an
error message (does it name the file and the key?), the CLI's one-line-error check, and the
case file."""

from __future__ import annotations

import io
import json
import math
import re
from pathlib import Path
from typing import Any

from benchmarks.fuzz.core import MAX_MESSAGE, Case, Outcome


def independent_check(prob, paths: dict[str, Any]) -> tuple[bool, str]:
    """Is every path feasible and does it reach its goal?  Checked with shapely directly on
    the scenario's obstacles (polygons as written, circles as exact centre and radius), in
    coordinates relative to the centre of the bounds; not with optplan's geometry core.

    A path is feasible when it starts at its start, keeps its disc in the bounds (the centre
    at least ``radius - eps`` from the edge: the bounds are a wall) and keeps a distance
    ``>= radius - eps`` from every static obstacle (known or temporary), ``eps = 1e-9 x`` the
    bounds diagonal; a point robot may touch but not enter (by more than ``eps``) a polygon.
    """
    import numpy as np
    import shapely
    from shapely.affinity import translate
    from shapely.geometry import LineString, Point

    x0, y0, x1, y1 = prob.bounds
    diag = math.hypot(x1 - x0, y1 - y0)
    eps = 1e-9 * diag
    c = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    robots = {r.id: r for r in prob.robots}
    for rid, path in paths.items():
        if rid not in robots:
            return False, f"path of unknown robot {rid!r}"
        r = robots[rid]
        p = np.asarray(path, dtype=float).reshape(-1, 2) - c
        if len(p) == 0 or not np.all(np.isfinite(p)):
            return False, f"{rid}: empty or non-finite path"
        if math.hypot(*(p[0] - (r.start - c))) > eps:
            return False, f"{rid}: does not start at the start"
        if r.goal is not None:
            tol = prob.goal_tolerance if prob.goal_tolerance is not None else (
                r.radius if r.radius > 0 else 1e-6 * diag)
            if math.hypot(*(p[-1] - (r.goal - c))) > tol + eps:
                return False, f"{rid}: goal not reached"
        # the bounds are a wall: the robot's disc stays inside them
        hx, hy = (x1 - x0) / 2 - r.radius + eps, (y1 - y0) / 2 - r.radius + eps
        if np.any(np.abs(p[:, 0]) > hx) or np.any(np.abs(p[:, 1]) > hy):
            return False, f"{rid}: out of bounds"
        geom = LineString(p) if len(p) > 1 else Point(p[0])
        for o in prob.obstacles:
            if o.is_circle:
                d = shapely.distance(geom, Point(*(o.center - c))) - float(o.radius)
                if d < r.radius - eps:
                    return False, f"{rid}: hits circle {o.name!r} (distance {d:.6g})"
            else:
                poly = translate(o.geometry, -c[0], -c[1])
                if r.radius > eps:
                    d = shapely.distance(geom, poly)
                    if d < r.radius - eps:
                        return False, f"{rid}: hits {o.name!r} (distance {d:.6g})"
                else:
                    inner = poly.buffer(-eps)
                    if not inner.is_empty and shapely.intersects(geom, inner):
                        return False, f"{rid}: enters {o.name!r}"
    return True, "feasible and reaching"


def _message_ok(msg: str, keys: tuple[str, ...], file: str | None) -> tuple[bool, str]:
    """Does ``msg`` name ``file`` (when given) and one of ``keys``?"""
    if len(msg) > MAX_MESSAGE:
        return False, f"message of {len(msg)} characters"
    if "\n" in msg.strip():
        return False, "multi-line message"
    if file is not None and file not in msg:
        return False, "does not name the file"
    if not keys:
        return True, ""
    for k in keys:
        pat = r"(?:^|(?<=[\s'\"(\[]))" + re.escape(k) + r"(?=$|[\s:.\[',\")\]])"
        if re.search(pat, msg):
            return True, ""
    return False, f"names none of {list(keys)[:6]}"


def _classify_error(e: BaseException, case: Case, file: str | None) -> tuple[str, str]:
    from optplan.problem import ProblemError
    from optplan.result import ResultFileError

    msg = str(e)
    raw = isinstance(e, (UnicodeError, json.JSONDecodeError))
    if isinstance(e, ValueError) and not raw:
        ok, why = _message_ok(msg, case.keys, file)
        name = type(e).__name__
        if ok:
            return "clear error", f"{name}: {msg}"
        if isinstance(e, (ProblemError, ResultFileError)) or name.endswith("Error"):
            return "unclear message", f"{why}: {name}: {msg[:300]}"
    if raw:
        return "unclear message", f"raw {type(e).__name__}: {msg[:300]}"
    return "crash", f"{type(e).__name__}: {msg[:300]}"


def _cli(argv: list[str]) -> tuple[int, str]:
    """Run ``optplan ARGV`` in this process; (exit status, stderr).  Every warning is shown
    (``always``), so a warning the CLI lets through appears on stderr."""
    import contextlib
    import warnings

    from optplan import cli

    err, out = io.StringIO(), io.StringIO()
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            try:
                rc = cli.main(argv)
            except SystemExit as e:  # pragma: no cover - main returns
                rc = e.code if isinstance(e.code, int) else 1
    return rc, err.getvalue()


def _cli_ok(argv: list[str], case: Case, file: str | None) -> tuple[bool, str]:
    """A bad input through the CLI: exit 2 and exactly one line, naming file and key."""
    try:
        rc, err = _cli(argv)
    except BaseException as e:  # noqa: BLE001 - anything escaping main is a crash
        return False, f"CLI raised {type(e).__name__}: {str(e)[:200]}"
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if rc != 2 or len(lines) != 1 or not lines[0].startswith("optplan: error: "):
        return False, f"CLI exit {rc}, stderr {err[:300]!r}"
    ok, why = _message_ok(lines[0], case.keys, file)
    return ok, "" if ok else f"CLI: {why}: {lines[0][:300]}"


def _prepare(case: Case, tmp: Path, suffix: str) -> Path:
    path = tmp / f"{re.sub(r'[^A-Za-z0-9_-]', '-', case.id)}{suffix}"
    kind = case.data.get("kind", "file")
    if kind == "dir":
        path.mkdir()
    elif kind == "file":
        path.write_bytes(case.data["bytes"] or b"")
    return path


def _compare(case: Case, prob, res) -> Outcome:
    """The solver's success against :func:`independent_check`.  Full comparison without
    dynamic obstacles and with one path; otherwise only soundness (success => feasible)."""
    ok, why = independent_check(prob, res.paths)
    full = not prob.dynamic_obstacles and len(res.paths) == 1
    if res.success and not ok:
        return Outcome(case, "success disagrees", f"success but {why}", compared=True)
    if full and ok and not res.success:
        return Outcome(case, "success disagrees",
                       f"not success ({res.status}: {res.message[:150]}) but {why}",
                       compared=True)
    return Outcome(case, "accepted and solved", f"{res.status}: {why}", compared=True)
