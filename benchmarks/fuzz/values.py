"""Scenario values: a small TOML writer (scenes are mutated as dicts and written back), the
catalogue, the bad, odd and wrongly typed values, and the key-path helpers of the mutators."""

from __future__ import annotations

import json
import math
import re
import tomllib
from collections.abc import Iterable
from typing import Any

from benchmarks.fuzz.core import PROBLEMS


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k, ensure_ascii=False)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def toml_dumps(d: dict[str, Any]) -> str:
    """TOML text of ``d``: scalars and arrays first, then ``[table]`` and ``[[array]]`` sections
    (their entries inline)."""
    head, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append(f"\n[{_toml_key(k)}]")
            tables += [f"{_toml_key(a)} = {_toml_value(b)}" for a, b in v.items()]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for x in v:
                tables.append(f"\n[[{_toml_key(k)}]]")
                tables += [f"{_toml_key(a)} = {_toml_value(b)}" for a, b in x.items()]
        else:
            head.append(f"{_toml_key(k)} = {_toml_value(v)}")
    return "\n".join(head + tables) + "\n"


def nested(depth: int) -> list:
    """``depth`` nested arrays (built without recursion)."""
    v: list = []
    for _ in range(depth - 1):
        v = [v]
    return v


def _nested_text(depth: int, inner: str = "") -> str:
    return "[" * depth + inner + "]" * depth


def catalogue() -> dict[str, dict[str, Any]]:
    return {p.stem: tomllib.loads(p.read_text(encoding="utf-8"))
            for p in sorted(PROBLEMS.glob("*.toml"))}


#: Numbers a number may be replaced with: (value, must it be rejected wherever a number is?)
BAD_NUMBERS: list[tuple[Any, bool]] = [
    (math.nan, True), (math.inf, True), (-math.inf, True), (1e300, True), (-1e300, True),
    (10**400, True), (-(10**400), True), (1e151, True), (-1e151, True),
]
ODD_NUMBERS: list[Any] = [0, 0.0, -0.0, -1, -1.5, 1e-300, -1e-300, 1e-12, 1e150, -1e150,
                          1e100, 1e16, 2**63, 2**53 + 1, 1e6, 7, 0.5]
WRONG_TYPES: list[Any] = ["1.0", "", True, False, [], [1.0], [[1.0, 2.0]], {}, {"a": 1},
                          "polygon", [True, False]]

_SAFE_REPR = re.compile(r"\s+")


def _leaves(d: Any, prefix: str = "") -> Iterable[tuple[str, list, Any]]:
    """(key path, path in the dict, value) of every node below ``d``."""
    if isinstance(d, dict):
        for k, v in d.items():
            kp = f"{prefix}.{k}" if prefix else k
            yield kp, [k], v
            for sub, path, x in _leaves(v, kp):
                yield sub, [k, *path], x
    elif isinstance(d, list):
        for i, v in enumerate(d):
            kp = f"{prefix}[{i}]"
            yield kp, [i], v
            for sub, path, x in _leaves(v, kp):
                yield sub, [i, *path], x


def _get(d: Any, path: list) -> Any:
    for p in path:
        d = d[p]
    return d


def _set(d: Any, path: list, v: Any) -> None:
    _get(d, path[:-1])[path[-1]] = v


def _del(d: Any, path: list) -> None:
    del _get(d, path[:-1])[path[-1]]


def _owner_keys(kp: str) -> tuple[str, ...]:
    """Keys an error about the node ``kp`` may name: the node itself or its enclosing entry
    (``obstacles[2]``), plus what a geometry change can make invalid: the robots' starts and
    goals (now inside an obstacle or outside the bounds)."""
    m = re.match(r"^((?:obstacles|dynamic_obstacles|robots)\[\d+\]|formation\.followers\[\d+\]"
                 r"|formation|sensing|bounds)", kp)
    keys = [kp] + ([m.group(1)] if m else [])
    return tuple(dict.fromkeys(keys))


def _robot_points(scene: dict) -> tuple[str, ...]:
    out = []
    for i in range(len(scene.get("robots", []))):
        out += [f"robots[{i}].start", f"robots[{i}].goal"]
    return tuple(out)


def _followers(scene: dict) -> list[str]:
    f = scene.get("formation")
    if not isinstance(f, dict):
        return []
    return [x.get("id") for x in f.get("followers", []) if isinstance(x, dict)]


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


#: key paths (regex) whose value may be any finite number (no range to violate)
_FREE_NUMBERS = re.compile(r"^(dynamic_obstacles\[\d+\]\.(waypoints|velocity)\[\d+\]\[\d\]"
                           r"|dynamic_obstacles\[\d+\]\.times\[\d+\])$")


def outside_range(kp: str, w: Any, d: dict) -> bool:
    """Is the number ``w`` at key ``kp`` outside the documented range (problems/README.md)?
    ``d`` is the scene (its bounds give the diagonal ``L``)."""
    try:
        x0, y0, x1, y1 = (float(v) for v in d["bounds"])
        L = math.hypot(x1 - x0, y1 - y0)
    except (KeyError, TypeError, ValueError):
        return False
    if not math.isfinite(float(w)):
        return True
    if kp.startswith("bounds"):
        return not (x0 < x1 and y0 < y1 and 1e-100 <= L <= 1e100)
    last = kp.split(".")[-1]
    if kp.startswith("robots") and last == "radius":
        return not 0 <= w <= L
    if last == "max_speed":
        return not 1e-6 * L <= w <= 1e6 * L
    if last in ("goal_tolerance", "safety_distance", "L"):
        return not 0 < w <= L
    if kp == "sensing.range":
        return not 0 < w <= 1e6 * L
    if last == "radius":  # static and dynamic circles
        return not 0 < w <= 1e150
    if last == "phi":
        return abs(w) > math.pi
    if re.search(r"\.times\[\d+\]$", kp):
        return abs(w) > 1e9
    if re.search(r"\.velocity\[\d\]$", kp):
        return abs(w) > 1e6 * L
    return abs(w) > 1e150


def _short(v: Any, n: int = 40) -> str:
    s = repr(v)
    return s if len(s) <= n else s[: n - 3] + "..."
