"""The **result** family: corrupted result JSON files (from a few real solves), loaded with
``Result.load`` and drawn with ``optplan plot``."""

from __future__ import annotations

import copy
import functools
import json
import math
import random
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error, _cli, _cli_ok, _message_ok, _prepare
from benchmarks.fuzz.core import Case, Outcome
from benchmarks.fuzz.values import nested


@functools.lru_cache(maxsize=1)
def _base_results() -> dict[str, dict]:
    """Result dicts of a few real solves (geometric, time-stamped formation, APF)."""
    import optplan as op

    out = {}
    for scene, solver in (("open-field", "visgraph"), ("trap-u", "apf-paper"),
                          ("formation-open-field", "leader-follower-paper")):
        try:
            res = op.solve(scene, solver, rng=0, time_limit=5.0)
        except (ValueError, ImportError) as e:  # a backend broken in this checkout
            print(f"fuzz: no base result {scene}/{solver}: {e}", file=sys.stderr)
            continue
        out[f"{scene}/{solver}"] = res.to_dict()
    return out


def _result_variants(base: dict, rid: str, path: list
                 ) -> list[tuple[str, Callable[[dict], Any], tuple[str, ...], bool]]:
    """(what, mutation of a copy of ``base``, keys an error may name, must it be rejected?)"""
    return [
        ("empty object", lambda d: d.clear(), ("status",), True),
        ("paths 3 columns", lambda d: d["paths"].__setitem__(
            rid, [p + [0.0] for p in path]), (f"paths.{rid}",), True),
        ("paths flat", lambda d: d["paths"].__setitem__(
            rid, [x for p in path for x in p]), (f"paths.{rid}",), True),
        ("paths empty", lambda d: d["paths"].__setitem__(rid, []), (f"paths.{rid}",),
         True),
        ("paths no robots", lambda d: d.__setitem__("paths", {}), ("paths",), True),
        ("paths list", lambda d: d.__setitem__("paths", [path]), ("paths",), True),
        ("paths nan", lambda d: d["paths"].__setitem__(
            rid, [[math.nan, 0.0]] + path[1:]), (f"paths.{rid}",), True),
        ("paths strings", lambda d: d["paths"].__setitem__(rid, [["a", "b"]]),
         (f"paths.{rid}",), True),
        ("paths 1e300", lambda d: d["paths"].__setitem__(
            rid, [[1e300, 1e300]] + path[1:]), (f"paths.{rid}",), True),
        ("paths unknown robot", lambda d: d["paths"].__setitem__("nobody", path),
         ("paths.nobody", "paths"), True),
        ("paths ragged", lambda d: d["paths"].__setitem__(rid, [[1.0, 2.0], [3.0]]),
         (f"paths.{rid}",), True),
        ("metrics list", lambda d: d.__setitem__("metrics", [1, 2]), ("metrics",), True),
        ("metrics length string", lambda d: d["metrics"].__setitem__("length", "long"),
         ("metrics.length", "metrics"), True),
        ("metrics per_robot list", lambda d: d["metrics"].__setitem__("per_robot", [1]),
         ("metrics.per_robot", "metrics"), True),
        ("metrics collisions list", lambda d: d["metrics"].__setitem__("collisions", [1]),
         ("metrics.collisions", "metrics"), True),
        ("times wrong length", lambda d: d.__setitem__(
            "times", [float(k) for k in range(len(path) + 1)]), ("times",), True),
        ("scenario list", lambda d: d.__setitem__("scenario", [1]), ("scenario",), True),
        ("scenario bad radius", lambda d: d["scenario"]["robots"][0].__setitem__(
            "radius", -1.0), ("scenario",), True),
        ("scenario no robots", lambda d: d["scenario"].pop("robots"), ("scenario",), True),
        ("scenario other robot ids", lambda d: d["scenario"]["robots"][0].__setitem__(
            "id", "zz"), ("scenario", f"paths.{rid}"), True),
        ("scenario dropped", lambda d: d.pop("scenario"), (), False),
        ("times 2-D", lambda d: d.__setitem__("times", [[0.0]] * len(path)), ("times",),
         True),
        ("times strings", lambda d: d.__setitem__("times", ["t"] * len(path)),
         ("times",), True),
        ("times nan", lambda d: d.__setitem__("times", [math.nan] * len(path)),
         ("times",), True),
        ("times decreasing", lambda d: d.__setitem__(
            "times", [float(-k) for k in range(len(path))]), ("times",), True),
        ("status unknown", lambda d: d.__setitem__("status", "great"), ("status",), True),
        ("status int", lambda d: d.__setitem__("status", 1), ("status",), True),
        ("status missing", lambda d: d.pop("status"), ("status",), True),
        ("schema 99", lambda d: d.__setitem__("schema", 99), ("schema",), True),
        ("schema string", lambda d: d.__setitem__("schema", "1"), ("schema",), True),
        ("solver int", lambda d: d.__setitem__("solver", 3), ("solver",), True),
        ("problem unknown", lambda d: d.__setitem__("problem", "no-such-problem"),
         ("problem",), "scenario" not in base),
        ("problem unknown, no scenario", lambda d: (d.pop("scenario", None), d.__setitem__(
            "problem", "no-such-problem")), ("problem",), True),
        ("problem int", lambda d: d.__setitem__("problem", 3), ("problem",), True),
        ("n_iter negative", lambda d: d.__setitem__("n_iter", -1), ("n_iter",), True),
        ("n_eval float", lambda d: d.__setitem__("n_eval", 1.5), ("n_eval",), True),
        ("wall_time string", lambda d: d.__setitem__("wall_time", "1s"), ("wall_time",),
         True),
        ("wall_time nan", lambda d: d.__setitem__("wall_time", math.nan), ("wall_time",),
         True),
        ("seed string", lambda d: d.__setitem__("seed", "0"), ("seed",), True),
        ("history ragged", lambda d: d.__setitem__("history", {"a": [1], "b": [1, 2]}),
         ("history",), True),
        ("history not list", lambda d: d.__setitem__("history", {"a": 3}), ("history",),
         True),
        ("extras list", lambda d: d.__setitem__("extras", [1]), ("extras",), True),
        ("extras global_path odd", lambda d: d.__setitem__(
            "extras", {"global_path": [1.0, 2.0, 3.0]}),
         ("extras.global_path", "extras"), True),
        ("options list", lambda d: d.__setitem__("options", [1]), ("options",), True),
        ("message dict", lambda d: d.__setitem__("message", {}), ("message",), True),
        ("cost string", lambda d: d.__setitem__("cost", "cheap"), ("cost",), True),
        ("deep nesting", lambda d: d.__setitem__("extras", {"x": nested(100)}), (), False),
    ]


def result_cases(seed: int = 0, n_random: int = 40) -> list[Case]:
    """Corrupted result files (and intact ones: they must load and plot)."""
    rng = random.Random(seed)
    bases = copy.deepcopy(_base_results())
    out: list[Case] = []
    n = 0

    def add(what: str, content: bytes | None, keys: Iterable[str], must: bool,
            kind: str = "file") -> None:
        nonlocal n
        n += 1
        out.append(Case("result", f"result/{n:04d}/{what}", what,
                        {"bytes": content, "kind": kind}, tuple(keys), must))

    def js(d: Any) -> bytes:
        return json.dumps(d, allow_nan=True).encode("utf-8")

    for bname, base in bases.items():
        text = json.dumps(base, indent=1).encode("utf-8")
        add(f"intact {bname}", text, (), False)
        for frac in (0.0, 0.1, 0.5, 0.9, 0.999):
            add(f"truncated {frac:g} {bname}", text[: int(len(text) * frac)],
                ("invalid JSON", "<root>"), True)
        rid = next(iter(base["paths"]))
        variants = _result_variants(base, rid, base["paths"][rid])
        for what, fn, keys, must in variants:
            d = copy.deepcopy(base)
            try:
                fn(d)
            except (KeyError, TypeError, IndexError):  # e.g. no embedded scenario
                continue
            add(f"{what} {bname}", js(d), keys, must)
        for _ in range(n_random // len(bases)):  # random byte damage
            k = rng.randrange(len(text))
            add(f"byte flip {bname}", text[:k] + bytes([rng.randrange(256)]) + text[k + 1:],
                ("invalid JSON", "not UTF-8", "<root>", "paths", "status", "times", "metrics",
                 "schema", "solver", "backend", "problem", "n_iter", "n_eval", "wall_time",
                 "seed", "history", "extras", "options", "message", "cost", "stop_reason"),
                False)
    add("empty file", b"", ("invalid JSON",), True)
    add("not UTF-8", b"\xff\xfe{}", ("not UTF-8",), True)
    add("JSON list", b"[]", ("<root>",), True)
    add("JSON null", b"null", ("<root>",), True)
    add("JSON number", b"3", ("<root>",), True)
    add("deep brackets", b"[" * 100000 + b"]" * 100000, ("nested too deeply", "<root>"), True)
    add("directory", None, ("cannot read file", "is a directory", "no such result file"),
        True, kind="dir")
    add("missing", None, ("no such result file", "cannot read file"), True, kind="missing")
    return out


def run_result(case: Case, tmp: Path) -> Outcome:
    from optplan.cli import _result_lines
    from optplan.result import Result

    path = _prepare(case, tmp, ".json")
    try:
        res = Result.load(path)
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, str(path))
        if cat == "clear error":
            ok, why = _cli_ok(["plot", str(path), "--out", str(tmp / "x.png")], case,
                              str(path))
            if not ok:
                return Outcome(case, "unclear message", why)
        return Outcome(case, cat, det)
    try:
        res.summary()
        _result_lines(res)
    except Exception as e:  # noqa: BLE001
        return Outcome(case, "crash", f"summary: {type(e).__name__}: {e}")
    png = tmp / "plot.png"
    try:
        rc, err = _cli(["plot", str(path), "--out", str(png)])
    except BaseException as e:  # noqa: BLE001
        return Outcome(case, "crash", f"CLI plot raised {type(e).__name__}: {e}")
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if rc == 0 and not lines:
        if case.must_reject:
            return Outcome(case, "silently accepted", "loaded and plotted")
        return Outcome(case, "accepted and solved", "loaded and plotted")
    if rc == 2 and len(lines) == 1 and lines[0].startswith("optplan: error: "):
        ok, why = _message_ok(lines[0], case.keys, str(path))
        if ok:
            return Outcome(case, "clear error", "CLI plot: " + lines[0])
        return Outcome(case, "unclear message", f"CLI plot: {why}: {lines[0][:300]}")
    return Outcome(case, "crash" if rc not in (0, 2) else "unclear message",
                   f"CLI plot exit {rc}: {err[-400:]!r}")
