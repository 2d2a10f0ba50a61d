"""Fuzz optplan's input validation (issue 14): bad input never crashes, never hangs, never lies.

Families of malformed input, each case run in a worker process with a limit of
:data:`HANG_S` seconds of CPU (the worker's and its children's), or of :data:`STALL_S` wall
seconds during which the worker used no CPU at all (a case blocked forever): a case still
running then is killed and counted as a hang.  No limit is a wall-clock one that a machine
shared with other jobs could reach: a loaded machine makes a case slower, not more
CPU-hungry, and a runnable process still gets CPU time.  Workers start with a readiness
handshake and no deadline of their own (one that dies, uses :data:`STARTUP_CPU_S` CPU seconds
or no CPU for :data:`STALL_S` seconds before it is ready is an error of the fuzz setup).  A
memory limit (:data:`MEMORY_LIMIT`) too:

* **scenario**: mutations of the catalogue's TOML scenes (``problems/*.toml``): deleted keys,
  wrong types (``type = ["polygon"]``, a table as ``type``, ``leader = ["r1"]``, 3000 nested
  arrays, ...), non-finite and huge numbers (``nan``, ``inf``, ``1e300``, ``-1e300``, ...),
  empty / degenerate / self-intersecting / duplicate-vertex polygons, starts and goals inside
  obstacles or outside the bounds, unknown keys, TOML syntax errors, non-UTF-8 bytes, empty
  files, directories, huge vertex counts, bad dynamic-obstacle time series, formations naming
  missing robots, the leader as a follower or no followers.  Each file is loaded with
  :func:`optplan.load_problem`; a rejected file is also given to ``optplan show`` (one line on
  stderr, exit 2); an accepted one is solved with ``visgraph`` and the solver's ``success`` is
  compared with an independent shapely check of the path (:func:`independent_check`).
* **option**: bad values for every option of every preset (:func:`optplan.list_solvers`): wrong
  types, ``nan``, ``inf``, ``-inf``, ``1e300``, ``-1e300``, ``0``, negative numbers, huge
  integers, wrong strings; as ``solve`` overrides and (for a share of them) inside a preset
  file.  Accepted values are solved on a small scene with a time limit.
* **init**: bad initial guesses for every preset (NaN, inf, huge, empty, wrong shapes, unknown
  robot ids, strings, ...).
* **result**: corrupted result JSON files (truncated, wrong types, shapes and lengths, ...),
  loaded with :meth:`optplan.Result.load` and drawn with ``optplan plot``.
* **map**: ROS ``map_server`` YAML files (every key out of range or of the wrong type,
  unknown and missing keys, bad YAML, non-UTF-8 bytes) with good and bad images (PGM
  ``maxval 0`` / 70000, zero width, truncated PGM and PNG, garbage), resolutions 1e-300 /
  1e300 / ``numpy.float32``, bare images, MovingAI ``.map`` files (a UTF-8 BOM, CRLF, a
  citation after the grid, a grid row too many) and in-memory ``nav_msgs/OccupancyGrid``
  dicts (wrong ``data`` length or values, ``"50"`` inside ``data``, numpy and ``bytes`` data,
  resolution <= 0 or 1e-300 or a numpy scalar, a tilted origin, 81M cells, ...), read with
  :func:`optplan.maps.read_grid` / :func:`~optplan.maps.read_occupancy_grid`; a rejected file
  is also given to ``optplan import-map``.
* **database**: results databases (intact, of another program, of schema version 99 or none,
  failing SQLite's integrity check, text SQLite cannot decode, truncated, byte flips, a text
  file, an empty file, a directory, a missing file, one locked by another connection) read
  with every :mod:`optplan.benchdb` reader, opened with ``ResultsDB`` and given to
  ``optplan report`` and ``optplan export-arena``.
* **path**: ``nav_msgs/Path`` dicts read with :func:`optplan.maps.read_path_msg`: stamps
  decreasing, out of ROS's range (``sec`` < 0 or >= 2**31, ``nanosec`` >= 10**9), of the
  wrong type, missing; bad poses, quaternions, keys; random stamp sequences; and paths
  written by :func:`~optplan.maps.timed_path_msg` read back.  An accepted path must have
  finite points and non-decreasing times in range.
* **crop**: ``import_map(..., crop=...)`` on a map with an unknown margin: ``"auto"``, bools
  and ``numpy.bool_`` must crop exactly when they say so, anything else (0, 1, 0.0,
  ``numpy.int64(0)``, strings, None, ...) is an error naming ``crop``; and extreme
  resolutions.
* **scen**: MovingAI ``.scen`` files read with :func:`optplan.maps.read_scen`: version lines,
  a UTF-8 BOM (in the ``.scen`` and the ``.map``), CRLF, blank lines, trailing text, wrong field
  counts, non-numbers, cells outside the map or blocked, bad optimal lengths, two maps, a
  missing map, non-UTF-8 bytes, empty files.
* **arena**: :func:`optplan.bench.summary.export_arena` and ``optplan export-arena`` of
  databases without runs or with a damaged row (``length = 'abc'``, a ``config`` that is not
  JSON, ...: the error names the file and the row), onto a directory, the database itself, a
  missing folder, an existing file; an export must load as an OMPL database with every run,
  and a failed one must leave no ``.tmp`` file behind.
* **plugin**: plugin distributions (entry points ``optplan.backends`` / ``optplan.presets``)
  whose package raises or exits when imported, with malformed entry points, missing modules,
  classes or preset folders, broken preset files, beside a working plugin; each case in a
  fresh Python process, which must still solve with ``visgraph``, run ``optplan list``, and
  name the distribution in the warning or error about the broken part.

Every case is classified:

==========================  ===========================================================
``clear error``             an optplan error (``ProblemError`` / ``ValueError`` /
                            ``ResultFileError``) whose message names the file (when there is
                            one) and the key or option
``accepted and solved``     accepted (and solved / loaded) without trouble
``crash``                   any other exception (or a dead worker)
``hang``                    still running after :data:`HANG_S` CPU seconds (or blocked,
                            with no CPU time, for :data:`STALL_S` seconds)
``unclear message``         an optplan error naming neither the file nor the key, a raw
                            ``UnicodeDecodeError`` / ``JSONDecodeError`` / numpy message, or
                            a CLI error that is not one line with exit status 2
``silently accepted``       a value outside its documented range accepted
``success disagrees``       the solver's ``success`` contradicts the independent path check
==========================  ===========================================================

Run ``python benchmarks/fuzz_inputs.py`` for the full run (>= 3,000 scenarios, >= 2,500 option
values, >= 200 inits, >= 50 result files, >= 100 maps, >= 25 databases, >= 15 plugins,
>= 50 path messages, >= 30 crop values, >= 30 ``.scen`` files, >= 15 exports;
``--workers N``, ``--seed S``, ``--quick``, ``--family F``) and the counts table;
``tests/tools/test_fuzz.py`` runs a bounded, seeded slice.  Known findings in files other
engineers own (backends, ``solve``'s option and ``init`` checks) are listed in
:data:`KNOWN_FINDINGS`: cases they explain are reported in their own column.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import functools
import io
import json
import math
import os
import pickle
import random
import re
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import tomllib
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"

#: A case still running after this many CPU seconds (its worker's and the worker's children's;
#: wall seconds where ``/proc`` is missing) is a hang (its worker is killed).
HANG_S = 10.0
#: ... or after this many wall seconds in which its worker used no CPU at all (a case blocked
#: forever: a deadlock).  Not a speed limit: a runnable process gets CPU time however loaded the
#: machine, and a case waiting for a kernel another process compiles (a lock) waits far less.
STALL_S = 600.0
#: A worker that used this many CPU seconds without becoming ready (it imports optplan: ~1-2 s)
#: is an error of the fuzz setup; so is one that died or stalled (:data:`STALL_S`) first.
STARTUP_CPU_S = 120.0
#: ``time_limit`` given to every solve of an accepted input (seconds).
SOLVE_TIME_LIMIT = 2.0
#: Extra time a case gets when it is the first of its preset (or family) in a worker process:
#: one-time costs of a fresh process (numba compilation, cvxpy, IPOPT, matplotlib) are not
#: the input's.  A worker killed after a hang is replaced by a fresh (cold) one.
COLD_S = 60.0
#: Address-space limit of a worker process (bytes).
MEMORY_LIMIT = 6 * 2**30
#: Longest acceptable error message (characters): longer ones dump the input.
MAX_MESSAGE = 1200

#: the families of inputs, in the order of the counts table
FAMILIES = ("scenario", "option", "init", "result", "map", "database", "plugin", "path", "crop",
            "scen", "arena")
CATEGORIES = ("clear error", "accepted and solved", "crash", "hang", "unclear message",
              "silently accepted", "success disagrees")
BAD = ("crash", "hang", "unclear message", "silently accepted", "success disagrees")


@dataclass
class Case:
    """One fuzz input.

    ``keys``: an error must name one of them (a scenario key such as ``obstacles[2].vertices``,
    which a more specific key such as ``obstacles[2].vertices[1][0]`` also satisfies, an option
    name, ``init`` or a pseudo key such as ``invalid TOML``).  ``must_reject``: the input is
    outside the documented ranges, so accepting it is a silent acceptance.
    """

    family: str
    id: str
    what: str
    data: dict[str, Any]
    keys: tuple[str, ...] = ()
    must_reject: bool = False


@dataclass
class Outcome:
    case: Case
    category: str
    detail: str = ""
    seconds: float = 0.0
    known: str | None = None
    compared: bool = False


# ======================================================================================
# a small TOML writer (the scenes are mutated as dicts and written back)
# ======================================================================================


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


# ======================================================================================
# scenario mutations
# ======================================================================================


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


class ScenarioFuzzer:
    """Mutations of the catalogue scenes; :meth:`cases` draws ``n`` of them."""

    def __init__(self, seed: int = 0, scenes: dict[str, dict] | None = None):
        self.rng = random.Random(seed)
        self.scenes = scenes if scenes is not None else catalogue()
        self.n = 0
        self.mutators: list[tuple[str, Callable[[str, dict], Case | None], float]] = [
            ("delete key", self.m_delete, 3.0),
            ("wrong type", self.m_wrong_type, 3.0),
            ("bad number", self.m_bad_number, 3.0),
            ("odd number", self.m_odd_number, 2.0),
            ("unknown key", self.m_unknown_key, 1.0),
            ("polygon", self.m_polygon, 3.0),
            ("rectangle", self.m_rectangle, 1.0),
            ("circle", self.m_circle, 1.0),
            ("start/goal", self.m_start_goal, 2.0),
            ("bounds", self.m_bounds, 1.0),
            ("robots", self.m_robots, 1.0),
            ("dynamic", self.m_dynamic, 2.0),
            ("formation", self.m_formation, 2.0),
            ("sensing/tolerance", self.m_scalars, 1.0),
            ("scale", self.m_scale, 1.0),
            ("text", self.m_text, 2.0),
            ("huge", self.m_huge, 0.3),
        ]

    # -- helpers ---------------------------------------------------------------------
    def _case(self, scene: str, what: str, text: str | bytes | None, keys: Iterable[str],
              must_reject: bool, kind: str = "file", note: str = "") -> Case:
        self.n += 1
        data = {"scene": scene, "kind": kind, "note": note,
                "bytes": text.encode("utf-8") if isinstance(text, str) else text}
        return Case("scenario", f"scenario/{self.n:05d}/{scene}", what, data,
                    tuple(dict.fromkeys(keys)), must_reject)

    def _dict_case(self, scene: str, what: str, d: dict, keys: Iterable[str],
                   must_reject: bool, note: str = "") -> Case:
        return self._case(scene, what, toml_dumps(d), keys, must_reject, note=note)

    def _pick(self, d: dict, pred: Callable[[str, Any], bool]) -> tuple[str, list, Any] | None:
        cands = [x for x in _leaves(d) if pred(x[0], x[2])]
        return self.rng.choice(cands) if cands else None

    def _obstacles(self, d: dict, kind: str | None = None) -> list[int]:
        return [i for i, o in enumerate(d.get("obstacles", []))
                if kind is None or o.get("type") == kind]

    # -- mutators --------------------------------------------------------------------
    def m_delete(self, scene: str, d: dict) -> Case | None:
        pick = self._pick(d, lambda kp, v: not kp.endswith("]") or self.rng.random() < 0.2)
        if pick is None:
            return None
        kp, path, _ = pick
        _del(d, path)
        # deleting a required key, a list element (changes lengths) ...: either outcome is
        # allowed, an error must name the key or its entry (or what it breaks)
        keys = list(_owner_keys(kp))
        top = kp.split(".")[0].split("[")[0]
        keys += [top]
        if kp.startswith("formation"):
            keys += [f"robots[{i}].goal" for i in range(len(d.get("robots", [])))]
            keys += ["formation"]
        if kp.startswith(("obstacles", "bounds", "robots")):
            keys += _robot_points(d)
        if kp.startswith("robots"):
            keys += ["formation.leader", "formation.followers", "formation.safety_distance"]
        if kp.startswith("bounds") or kp.startswith("obstacles"):
            keys += [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
        required = re.search(r"(^name$|^bounds$|^robots$|\.(id|start|radius|type|vertices|"
                             r"waypoints|leader|L|phi|range)$|\.center$)", kp)
        return self._dict_case(scene, "delete key", d, keys, bool(required), note=kp)

    def m_wrong_type(self, scene: str, d: dict) -> Case | None:
        pick = self._pick(d, lambda kp, v: True)
        if pick is None:
            return None
        kp, path, v = pick
        choices = [w for w in WRONG_TYPES if type(w) is not type(v) or w != v]
        last = kp.rsplit(".", 1)[-1]
        if last in ("type", "leader", "id", "after"):
            choices += [[v], {"x": v}, 3, [[v]]]
        if isinstance(v, list) and v and _is_number(v[0]):
            choices += [[v[0]], v + [v[0]], [str(x) for x in v]]
        if kp in ("tags", "name", "description", "source") or last == "name":
            choices += [3, 1.5, ["x"], {"a": "b"}]
        w = self.rng.choice(choices)
        if _is_number(v) and _is_number(w):
            return None  # an int where a float is expected is fine
        _set(d, path, w)
        keys = list(_owner_keys(kp)) + list(_robot_points(d))
        keys += ["formation", "formation.followers", "formation.leader"]
        if kp.startswith(("bounds", "obstacles")):
            keys += [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
        # which replacements are still valid scenes?
        same = type(w) is type(v) and isinstance(v, (str, bool))
        must = not same or last in ("type", "after", "leader") or kp.startswith(
            "formation.followers") and last == "id"
        if w == [] and (kp in ("tags", "obstacles", "dynamic_obstacles")
                        or kp.endswith(".holes")):
            must = False
        if kp == "tags" and isinstance(w, list) and all(isinstance(t, str) for t in w):
            must = False  # a list of strings is what tags are
        if kp.endswith(".waypoints") and isinstance(w, list) and all(
                isinstance(p, list) and len(p) == 2 and all(map(_is_number, p)) for p in w):
            must = False  # a single waypoint may be a parked obstacle
        if kp.startswith("robots") and last == "id" and isinstance(w, str) and w:
            must = False  # another id (a formation naming the old one is an error anyway)
        return self._dict_case(scene, "wrong type", d, keys, must, note=f"{kp} = {w!r}")

    def m_bad_number(self, scene: str, d: dict) -> Case | None:
        pick = self._pick(d, lambda kp, v: _is_number(v))
        if pick is None:
            return None
        kp, path, v = pick
        w, must = self.rng.choice(BAD_NUMBERS)
        _set(d, path, w)
        keys = list(_owner_keys(kp)) + list(_robot_points(d))
        if kp.startswith("formation"):
            keys += ["formation.safety_distance"]
        if kp.startswith("bounds"):
            keys += [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
        return self._dict_case(scene, "bad number", d, keys, must, note=f"{kp} = {w!r}")

    def m_odd_number(self, scene: str, d: dict) -> Case | None:
        pick = self._pick(d, lambda kp, v: _is_number(v))
        if pick is None:
            return None
        kp, path, v = pick
        w = self.rng.choice(ODD_NUMBERS + [v * (1 + 1e-15), v + 1e-12, -v, v * 1e6])
        _set(d, path, w)
        keys = list(_owner_keys(kp)) + list(_robot_points(d))
        keys += [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
        keys += [f"dynamic_obstacles[{i}]" for i in range(len(d.get("dynamic_obstacles", [])))]
        keys += ["bounds", "formation.safety_distance", "formation.followers"]
        must = outside_range(kp, w, d)
        return self._dict_case(scene, "odd number", d, keys, must, note=f"{kp} = {w!r}")

    def m_unknown_key(self, scene: str, d: dict) -> Case | None:
        tables = [("", d)] + [(kp, v) for kp, _, v in _leaves(d) if isinstance(v, dict)]
        kp, t = self.rng.choice(tables)
        if t and self.rng.random() < 0.5:
            k = self.rng.choice(list(t))
            new = k[:-1] if len(k) > 1 else k + "x"
            if new in t:
                return None
            t[new] = t.pop(k)
            key = f"{kp}.{new}" if kp else new
        else:
            new = self.rng.choice(["foo", "Name", "typ", "vertex", "speed", "holes", "times",
                                   "x y", "ünïcode"])
            if new in t:
                return None
            t[new] = 1.0
            key = f"{kp}.{new}" if kp else new
        keys = [key, _toml_key(new)] + list(_owner_keys(kp or new))
        if "holes" in key or "times" in key:
            keys += [key.rsplit(".", 1)[0]]
        return self._dict_case(scene, "unknown key", d, [k for k in keys if k], True, note=key)

    def _degenerate_ring(self, r: int, o: dict, v: list) -> bool:
        """Variants 0-5: too few, repeated or collinear vertices, a bow-tie (must reject,
        except a swap that may keep a non-convex ring simple)."""
        if r == 0:
            o["vertices"] = []
        elif r == 1:
            o["vertices"] = v[:1]
        elif r == 2:
            o["vertices"] = v[:2]
        elif r == 3:
            o["vertices"] = [v[0]] * len(v)
        elif r == 4:  # collinear
            a, b = v[0], v[1]
            o["vertices"] = [a, b, [2 * b[0] - a[0], 2 * b[1] - a[1]]]
        elif len(v) >= 4:  # bow-tie
            v[0], v[1] = v[1], v[0]
            return False  # a swap may keep it simple for non-convex rings
        else:  # no bow-tie of a triangle: the near-duplicate vertex instead
            return self._benign_rewrite(14, v)
        return True

    def _benign_rewrite(self, r: int, v: list) -> bool:
        """Variants 6, 7, 8, 12, 14: rewrites the parser must accept or reject cleanly."""
        k = self.rng.randrange(len(v)) if r in (6, 12, 14) else 0
        if r == 6:  # consecutive duplicate vertex: counts once
            v.insert(k, list(v[k]))
        elif r == 7:  # closing vertex
            v.append(list(v[0]))
        elif r == 8:  # reversed orientation
            v.reverse()
        elif r == 12:  # tiny perturbation of a vertex
            v[k] = [v[k][0] * (1 + 1e-14), v[k][1]]
        else:  # a near-duplicate vertex (a very short edge)
            e = self.rng.choice([1e-13, 1e-10, 1e-6]) * (1.0 + abs(v[k][0]))
            v.insert(k + 1, [v[k][0] + e, v[k][1]])
        return False

    def _malformed_ring(self, r: int, o: dict, v: list) -> bool | None:
        """Variants 9, 10, 11, 13: wrong coordinate counts, self-touching rings, bad holes,
        vertices as a table (``None``: the variant does not apply)."""
        if r == 9:  # a vertex with 3 coordinates / 1 coordinate
            k = self.rng.randrange(len(v))
            v[k] = v[k] + [0.0] if self.rng.random() < 0.5 else v[k][:1]
        elif r == 10:  # non-consecutive duplicate (ring touches itself)
            if len(v) < 4:
                return None
            v.insert(2, list(v[0]))
            return False
        elif r == 11:  # holes
            o["holes"] = self.rng.choice([
                [v[:3]], [[[x + 1e6, y] for x, y in v]], [v], "hole", [[1, 2]], [[]],
                [[[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]]])
        else:  # vertices as a table
            o["vertices"] = {"x": [p[0] for p in v], "y": [p[1] for p in v]}
        return True

    def m_polygon(self, scene: str, d: dict) -> Case | None:
        idx = self._obstacles(d, "polygon")
        if not idx:
            d.setdefault("obstacles", []).append(
                {"type": "polygon", "vertices": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]})
            idx = [len(d["obstacles"]) - 1]
        i = self.rng.choice(idx)
        o = d["obstacles"][i]
        v = o["vertices"]
        pre = f"obstacles[{i}]"
        r = self.rng.randrange(15)
        if r in (0, 1, 2, 3, 4, 5):
            must = self._degenerate_ring(r, o, v)
        elif r in (6, 7, 8, 12, 14):
            must = self._benign_rewrite(r, v)
        else:
            must = self._malformed_ring(r, o, v)
        if must is None:
            return None
        keys = [pre, *_robot_points(d)]
        return self._dict_case(scene, "polygon", d, keys, must, note=f"{pre} variant {r}")

    def m_rectangle(self, scene: str, d: dict) -> Case | None:
        idx = self._obstacles(d, "rectangle")
        if not idx:
            return None
        i = self.rng.choice(idx)
        o = d["obstacles"][i]
        pre = f"obstacles[{i}]"
        r = self.rng.randrange(6)
        must = True
        if "min" in o:
            lo, hi = o["min"], o["max"]
            if r == 0:
                o["min"], o["max"] = hi, lo
            elif r == 1:
                o["max"] = list(lo)
            elif r == 2:
                o["center"], o["size"] = [0.0, 0.0], [1.0, 1.0]
            elif r == 3:
                o["max"] = [hi[0], lo[1]]
            elif r == 4:
                o["min"] = [lo[0], lo[1], 0.0]
            else:
                o["max"] = [hi[0] + 1e-13 * abs(hi[0]), hi[1]]
                must = False
        else:
            if r <= 2:
                o["size"] = [-1.0, 1.0] if r == 0 else [0.0, 0.0] if r == 1 else [1e300, 1.0]
            else:
                o["min"] = [0.0, 0.0]
        return self._dict_case(scene, "rectangle", d, [pre, *_robot_points(d)], must,
                               note=f"{pre} variant {r}")

    def m_circle(self, scene: str, d: dict) -> Case | None:
        idx = self._obstacles(d, "circle")
        if not idx:
            return None
        i = self.rng.choice(idx)
        o = d["obstacles"][i]
        pre = f"obstacles[{i}]"
        x0, y0, x1, y1 = d["bounds"]
        L = math.hypot(x1 - x0, y1 - y0)
        choices: list[tuple[dict, bool]] = [
            ({"radius": 0.0}, True), ({"radius": -1.0}, True), ({"radius": 1e300}, True),
            ({"center": [-1e300, 0.0]}, True), ({"center": [1e300, 1e300]}, True),
            ({"radius": L * 1e3}, False), ({"center": [x0 - 1e9 * L, y0]}, False),
            ({"center": [x0 - 1e5 * L, y0], "radius": 1e5 * L}, False),
            ({"radius": 1e-300}, False), ({"center": [x0, y0]}, False),
            ({"center": [(x0 + x1) / 2, (y0 + y1) / 2]}, False),
        ]
        upd, must = self.rng.choice(choices)
        o.update(upd)
        return self._dict_case(scene, "circle", d, [pre, *_robot_points(d)], must,
                               note=f"{pre} {upd}")

    def _inside_point(self, d: dict) -> list[float] | None:
        idx = self._obstacles(d)
        if not idx:
            return None
        o = d["obstacles"][self.rng.choice(idx)]
        if o["type"] == "circle":
            return list(o["center"])
        if o["type"] == "rectangle":
            if "min" in o:
                return [(o["min"][0] + o["max"][0]) / 2, (o["min"][1] + o["max"][1]) / 2]
            return list(o["center"])
        if "holes" in o:
            return None
        vs = o["vertices"]
        return list(vs[self.rng.randrange(len(vs))])  # a vertex: on the boundary

    def m_start_goal(self, scene: str, d: dict) -> Case | None:
        robots = d.get("robots", [])
        i = self.rng.randrange(len(robots))
        r = robots[i]
        keys_all = ["start", "goal"] if "goal" in r else ["start"]
        key = self.rng.choice(keys_all)
        x0, y0, x1, y1 = d["bounds"]
        L = math.hypot(x1 - x0, y1 - y0)
        choices: list[tuple[Any, bool]] = [
            ([x1 + 1.0, y0], True), ([x0 - 1e-6 * L, (y0 + y1) / 2], True),
            ([x1, y1 + 1e-3 * L], True), ([x0, y0], False), ([x1, y1], False),
            ([(x0 + x1) / 2, (y0 + y1) / 2], False),
            ([x1 + 1e-12 * L, y1], False), (list(r.get("goal", r["start"])), False),
        ]
        p = self._inside_point(d)
        if p is not None:
            choices += [(p, False)] * 3
        v, must = self.rng.choice(choices)
        r[key] = v
        pre = f"robots[{i}].{key}"
        return self._dict_case(scene, "start/goal", d, [pre, f"robots[{i}]"], must,
                               note=f"{pre} = {v}")

    def m_bounds(self, scene: str, d: dict) -> Case | None:
        x0, y0, x1, y1 = d["bounds"]
        choices: list[tuple[Any, bool]] = [
            ([x1, y0, x0, y1], True), ([x0, y0, x0, y1], True), ([x0, y0, x1], True),
            ([x0, y0, x1, y1, 0.0], True), ([x0, y0, x0 + 1e-101, y0 + 1e-101], True),
            ([-1e101, -1e101, 1e101, 1e101], True), ([x0, y0, x1 * 2, y1 * 2], False),
            ([x0 + 1e15, y0, x1 + 1e15, y1], True), ("0 0 1 1", True), ({"min": 0}, True),
            ([x0, y0, (x0 + x1) / 2, (y0 + y1) / 2], False),
        ]
        v, must = self.rng.choice(choices)
        d["bounds"] = v
        keys = ["bounds", *_robot_points(d)]
        keys += [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
        return self._dict_case(scene, "bounds", d, keys, must, note=f"bounds = {v}")

    def m_robots(self, scene: str, d: dict) -> Case | None:
        robots = d.get("robots", [])
        r = self.rng.randrange(8)
        keys = ["robots", "formation.leader", "formation.followers"]
        must = True
        if r == 0:
            d["robots"] = []
        elif r == 1:
            d["robots"] = [3]
        elif r == 2:
            robots.append(copy.deepcopy(robots[0]))
            keys.append(f"robots[{len(robots) - 1}].id")
        elif r == 3:
            robots[0]["id"] = ""
            keys.append("robots[0].id")
        elif r == 4:
            robots[0]["id"] = 7
            keys.append("robots[0].id")
        elif r == 5:
            d["robots"] = {"r1": robots[0]}
        elif r == 6:  # many robots (each a copy with a new id)
            base = robots[0]
            if "goal" not in base:
                return None
            for k in range(40):
                robots.append({**copy.deepcopy(base), "id": f"extra{k}"})
            must = False
        else:  # robot radius larger than the map
            x0, y0, x1, y1 = d["bounds"]
            robots[0]["radius"] = 10 * math.hypot(x1 - x0, y1 - y0)
            keys += ["robots[0].radius", "robots[0].start", "robots[0].goal"]
        keys += _robot_points(d) if isinstance(d["robots"], list) else []
        return self._dict_case(scene, "robots", d, keys, must, note=f"variant {r}")

    def m_dynamic(self, scene: str, d: dict) -> Case | None:
        dyn = d.get("dynamic_obstacles")
        if not dyn:
            x0, y0, x1, y1 = d["bounds"]
            d["dynamic_obstacles"] = dyn = [{
                "type": "circle", "radius": 1.0, "waypoints": [[x0, y0], [x1, y1]],
                "times": [0.0, 10.0]}]
        i = self.rng.randrange(len(dyn))
        o = dyn[i]
        pre = f"dynamic_obstacles[{i}]"
        n = len(o.get("waypoints", []))
        choices: list[tuple[dict, bool]] = [
            ({"times": list(reversed(o.get("times", [0.0])))}, n > 1),
            ({"times": [0.0] * max(n, 2)}, True),
            ({"times": [0.0]}, n != 1),
            ({"times": "0"}, True),
            ({"times": [0.0, math.nan][:max(n, 1)] + [1.0] * (n - 2)}, n >= 2),
            ({"times": [i * 1e300 for i in range(n)]}, n >= 2),
            ({"times": [i * 1e-300 for i in range(n)]}, n >= 2),
            ({"times": [-1e300 + i for i in range(n)]}, True),
            ({"times": [k * 1e-7 for k in range(n)], "after": "bounce"}, n >= 2),
            ({"waypoints": []}, True),
            ({"waypoints": [[0.0, 0.0]] * n}, False),
            ({"velocity": [1.0, 0.0]}, n != 1),
            ({"velocity": [1e300, 0.0], "waypoints": o.get("waypoints", [[0, 0]])[:1],
              "times": [0.0]}, True),
            ({"velocity": [1e200, 0.0], "waypoints": o.get("waypoints", [[0, 0]])[:1],
              "times": [0.0]}, True),
            ({"velocity": [1.0, 0.0], "waypoints": o.get("waypoints", [[0, 0]])[:1],
              "times": []}, True),
            ({"after": "forever"}, True), ({"after": ["hold"]}, True),
            ({"after": {"a": 1}}, True), ({"type": "rectangle"}, True),
            ({"type": ["circle"]}, True), ({"type": {"t": "circle"}}, True),
            ({"type": "polygon", "vertices": [[0, 0], [1, 1], [2, 2]]}, True),
            ({"radius": 0.0}, o.get("type") == "circle"),
            ({"waypoints": [[1e140, 0.0]] * n}, False),
        ]
        upd, must = self.rng.choice(choices)
        o.update(upd)
        return self._dict_case(scene, "dynamic", d, [pre], must, note=f"{pre} {upd}")

    def m_formation(self, scene: str, d: dict) -> Case | None:
        f = d.get("formation")
        robots = d.get("robots", [])
        ids = [r["id"] for r in robots]
        if not isinstance(f, dict):
            return None
        fl = f.get("followers", [])
        leader = f.get("leader")
        nf = len(fl)
        choices: list[tuple[Callable[[], None], tuple[str, ...], bool]] = [
            (lambda: f.__setitem__("followers", []), ("formation.followers",), True),
            (lambda: f.pop("followers"), ("formation.followers",), True),
            (lambda: f.__setitem__("followers", 3), ("formation.followers",), True),
            (lambda: f.__setitem__("followers", {"id": "x"}), ("formation.followers",), True),
            (lambda: fl.__setitem__(0, 3), ("formation.followers[0]",), True),
            (lambda: fl[0].__setitem__("id", "nobody"), ("formation.followers[0].id",), True),
            (lambda: fl[0].__setitem__("id", leader), ("formation.followers[0].id",), True),
            (lambda: fl[0].__setitem__("id", 5), ("formation.followers[0].id",), True),
            (lambda: fl[0].__setitem__("id", [fl[0]["id"]]), ("formation.followers[0].id",),
             True),
            (lambda: fl[0].pop("id"), ("formation.followers[0].id",), True),
            (lambda: fl.append(copy.deepcopy(fl[0])), (f"formation.followers[{nf}].id",), True),
            (lambda: f.__setitem__("leader", [leader]), ("formation.leader",), True),
            (lambda: f.__setitem__("leader", {"id": leader}), ("formation.leader",), True),
            (lambda: f.__setitem__("leader", 1), ("formation.leader",), True),
            (lambda: f.__setitem__("leader", "nobody"), ("formation.leader",), True),
            (lambda: f.__setitem__("leader", fl[0]["id"]),
             ("formation.leader", "formation.followers[0].id",
              *(f"robots[{k}].goal" for k in range(len(ids)))), True),
            (lambda: f.pop("leader"), ("formation.leader",), True),
            (lambda: f.__setitem__("safety_distance", 1e300), ("formation.safety_distance",),
             True),
            (lambda: f.__setitem__("safety_distance", 0.0), ("formation.safety_distance",),
             True),
            (lambda: fl[0].__setitem__("L", 1e300), ("formation.followers[0].L",), True),
            (lambda: fl[0].__setitem__("L", 0), ("formation.followers[0].L",), True),
            (lambda: fl[0].__setitem__("phi", 4.0), ("formation.followers[0].phi",), True),
            (lambda: fl[0].__setitem__("phi", "pi"), ("formation.followers[0].phi",), True),
            (lambda: d.pop("formation"),
             tuple(f"robots[{k}].goal" for k in range(len(ids))), True),
            (lambda: d.__setitem__("formation", [f]), ("formation",), True),
            (lambda: robots.pop(ids.index(fl[0]["id"])) if fl[0]["id"] in ids else None,
             ("formation.followers[0].id", "formation.leader"), True),
        ]
        fn, keys, must = self.rng.choice(choices)
        try:
            fn()
        except (IndexError, KeyError, TypeError, AttributeError):
            return None
        return self._dict_case(scene, "formation", d, keys, must)

    def m_scalars(self, scene: str, d: dict) -> Case | None:
        x0, y0, x1, y1 = d["bounds"]
        L = math.hypot(x1 - x0, y1 - y0)
        choices: list[tuple[str, Any, bool]] = [
            ("goal_tolerance", 0.0, True), ("goal_tolerance", -1.0, True),
            ("goal_tolerance", 1e300, True), ("goal_tolerance", "1", True),
            ("goal_tolerance", 1e-300, False), ("goal_tolerance", L / 2, False),
            ("sensing", {"range": 0.0}, True), ("sensing", {"range": 1e300}, True),
            ("sensing", {"range": math.inf}, True), ("sensing", {"range": 1e-300}, False),
            ("sensing", {"range": 10 * L}, False), ("sensing", 5.0, True),
            ("sensing", {}, True), ("sensing", {"range": 1.0, "angle": 2.0}, True),
            ("tags", "paper", True), ("tags", [1, 2], True), ("tags", [], False),
            ("name", 42, True), ("name", ["a"], True), ("description", {"a": 1}, True),
            ("source", 1.5, True), ("name", "", False), ("name", "x" * 10000, False),
        ]
        k, v, must = self.rng.choice(choices)
        d[k] = v
        return self._dict_case(scene, "scalars", d, [k], must, note=f"{k} = {v!r}"[:80])

    def m_scale(self, scene: str, d: dict) -> Case | None:
        """Scale or translate every coordinate and length of the scene."""
        kind = self.rng.choice(["scale", "shift"])
        x0, y0, x1, y1 = d["bounds"]
        L = math.hypot(x1 - x0, y1 - y0)
        if kind == "scale":
            s = self.rng.choice([1e-90, 1e-50, 1e-6, 1e6, 1e50, 1e90, 1e-110, 1e110])
            must = not 1e-100 <= L * s <= 1e100

            def f(v: float) -> float:
                return v * s
            note = f"scale {s:g}"
        else:
            s = self.rng.choice([1e3, 1e6, 1e7, 1e9, 1e12, -1e7]) * L
            must = abs(s) > 1e6 * L * 1.01

            def f(v: float) -> float:
                return v + s
            note = f"shift {s:g}"
        coords = re.compile(r"(^bounds\[\d\]$|\.(start|goal|center|min|max)\[\d\]$|"
                            r"^obstacles\[\d+\]\.(vertices|holes)(\[\d+\])+$|"
                            r"waypoints\[\d+\]\[\d\]$)")
        lengths = re.compile(r"(\.radius$|\.size\[\d\]$|\.L$|safety_distance$|^goal_tolerance$"
                             r"|^sensing\.range$|\.max_speed$|velocity\[\d\]$|"
                             r"^dynamic_obstacles\[\d+\]\.vertices\[\d+\]\[\d\]$)")
        for kp, path, v in list(_leaves(d)):
            if not _is_number(v):
                continue
            if kind == "scale" and (coords.search(kp) or lengths.search(kp)):
                _set(d, path, float(f(v)))
            elif kind == "shift" and coords.search(kp) and not kp.startswith(
                    "dynamic_obstacles") or kind == "shift" and re.search(r"waypoints", kp):
                _set(d, path, float(f(v)))
        keys = ["bounds", *_robot_points(d)]
        keys += [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
        keys += [f"dynamic_obstacles[{i}]" for i in range(len(d.get("dynamic_obstacles", [])))]
        keys += [f"robots[{i}]" for i in range(len(d.get("robots", [])))]
        keys += ["formation", "sensing.range", "goal_tolerance"]
        return self._dict_case(scene, "scale", d, keys, must, note=note)

    def m_text(self, scene: str, d: dict) -> Case | None:
        """Text and file-level corruption."""
        text = (PROBLEMS / f"{scene}.toml").read_text(encoding="utf-8")
        r = self.rng.randrange(16)
        if r <= 6:
            return self._file_corruption(scene, d, text, r)
        return self._content_corruption(scene, d, text, r)

    def _file_corruption(self, scene: str, d: dict, text: str, r: int) -> Case:
        """Variants 0-6: truncated, empty, undecodable, not a file, missing."""
        syntax = ("invalid TOML",)
        if r == 0:
            cut = self.rng.randrange(1, max(2, len(text) - 1))
            return self._case(scene, "truncated", text[:cut], syntax + ("name", "bounds",
                              "robots", "nested too deeply") + _owner_all(d), False,
                              note=f"cut at {cut}")
        if r == 1:
            return self._case(scene, "empty file", "", ("name",), True)
        if r == 2:
            return self._case(scene, "whitespace", "\n\n  # nothing\n", ("name",), True)
        if r == 3:
            raw = text.encode("utf-8")
            k = self.rng.randrange(len(raw))
            return self._case(scene, "non-UTF-8", raw[:k] + b"\xff\xfe" + raw[k:],
                              ("not UTF-8",), True)
        if r == 4:
            raw = text.encode("utf-8").replace(b'"', b'"\xe9', 1)  # a Latin-1 e-acute
            return self._case(scene, "latin-1", raw, ("not UTF-8",), True)
        if r == 5:
            return self._case(scene, "directory", None, ("not a file", "is a directory",
                              "cannot read file"), True, kind="dir")
        return self._case(scene, "missing file", None, ("no such scenario file",),
                          True, kind="missing")

    def _content_corruption(self, scene: str, d: dict, text: str, r: int) -> Case:
        """Variants 7-15: nesting, syntax errors, NUL bytes, BOM, binary, size, line ends."""
        syntax = ("invalid TOML",)
        if r == 7:
            return self._case(scene, "nested arrays", text + "\nzz = " + _nested_text(3000)
                              + "\n", syntax + ("nested too deeply", "zz"), True)
        if r == 8:
            return self._case(scene, "nested vertices", text.replace(
                "vertices = [", "vertices = " + "[" * 3000 + "[", 1).replace(
                "]]\n", "]]" + "]" * 3000 + "\n", 1), syntax + ("nested too deeply",)
                + _owner_all(d), True)
        if r == 9:
            lines = text.splitlines()
            k = self.rng.randrange(len(lines))
            lines.insert(k, self.rng.choice(["[[robots", "x = ", "= 3", "bounds = [1, 2",
                                             "'''", "[formation]\n[formation]", "a.b = 1\na = 2",
                                             "name = \"dup\""]))
            return self._case(scene, "syntax", "\n".join(lines), syntax + _owner_all(d)
                              + ("name", "a", "x"), True)
        if r == 10:
            return self._case(scene, "NUL bytes", text.replace("\n", "\n\x00", 1),
                              syntax, True)
        if r == 11:
            return self._case(scene, "BOM", "\ufeff" + text, syntax, False)
        if r == 12:
            return self._case(scene, "binary", bytes(self.rng.randrange(256)
                                                     for _ in range(200)),
                              syntax + ("not UTF-8",), True)
        if r == 13:  # parse_problem on a dict holding 3000 nested lists (built in the worker)
            key = self.rng.choice(["x", "bounds", "robots[0].start", "obstacles[0].vertices"])
            return self._case(scene, "deep arrays (parse_problem)", None,
                              (key, key.split(".")[0].split("[")[0], "nested too deeply"),
                              True, kind="dict", note=key)
        if r == 14:
            return self._case(scene, "deep inline tables", text + "\nzz = " + "{a = " * 600
                              + "1" + "}" * 600 + "\n", syntax + ("zz", "nested too deeply"),
                              True)
        if self.rng.random() < 0.1:  # a file beyond the size limit (a long comment)
            return self._case(scene, "huge file", text + "#" + "x" * (9 * 2**20) + "\n",
                              ("larger than",), True)
        return self._case(scene, "CRLF", text.replace("\n", "\r\n"), (), False)

    def m_huge(self, scene: str, d: dict) -> Case | None:
        """Huge vertex counts: a polygon (or a hole) with many vertices."""
        x0, y0, x1, y1 = d["bounds"]
        cx, cy = x0 + 0.9 * (x1 - x0), y0 + 0.1 * (y1 - y0)
        R = 0.02 * min(x1 - x0, y1 - y0)
        n = self.rng.choice([1000, 5000, 20000, 110000])
        verts = [[cx + R * math.cos(2 * math.pi * k / n), cy + R * math.sin(2 * math.pi * k / n)]
                 for k in range(n)]
        d.setdefault("obstacles", []).append({"type": "polygon", "name": f"huge{n}",
                                              "vertices": verts})
        i = len(d["obstacles"]) - 1
        return self._dict_case(scene, "huge vertex count", d,
                               [f"obstacles[{i}]", *_robot_points(d)], n > 100_000,
                               note=f"{n} vertices")

    # -- the draw --------------------------------------------------------------------
    def cases(self, n: int, scenes: Iterable[str] | None = None) -> list[Case]:
        names = list(scenes or self.scenes)
        weights = [w for _, _, w in self.mutators]
        out: list[Case] = []
        tries = 0
        while len(out) < n and tries < 50 * n:
            tries += 1
            scene = names[len(out) % len(names)] if self.rng.random() < 0.5 else \
                self.rng.choice(names)
            what, fn, _ = self.rng.choices(self.mutators, weights)[0]
            d = copy.deepcopy(self.scenes[scene])
            try:
                c = fn(scene, d)
            except (IndexError, KeyError, TypeError, ValueError):
                continue
            if c is None:
                continue
            if c.data["kind"] == "dict":
                c.data["dict"] = self.scenes[scene]
            out.append(c)
        return out


def _owner_all(d: dict) -> tuple[str, ...]:
    keys = [f"obstacles[{i}]" for i in range(len(d.get("obstacles", [])))]
    keys += [f"robots[{i}]" for i in range(len(d.get("robots", [])))]
    keys += [f"dynamic_obstacles[{i}]" for i in range(len(d.get("dynamic_obstacles", [])))]
    return tuple(keys) + ("formation", "sensing", "bounds", "goal_tolerance", "tags",
                          "description", "source")


# ======================================================================================
# options, inits, result files
# ======================================================================================

#: The scene a preset's accepted options and inits are solved on.
FORMATION_BACKENDS = ("leader-follower", "formation-qp", "formation-nlp", "hybrid")


def option_scene(backend: str, opts: dict[str, Any] | None = None) -> str:
    """A team scene for a team planner (a formation backend, or ``orca`` with ``team``),
    else a single-robot trap."""
    team = backend in FORMATION_BACKENDS or bool((opts or {}).get("team"))
    return "formation-open-field" if team else "trap-u"


@functools.lru_cache(maxsize=1)
def preset_table() -> dict[str, tuple[str, dict[str, Any]]]:
    """preset -> (backend, effective options) of every preset."""
    import optplan as op
    from optplan.solver import get_solver

    out = {}
    for name in op.list_solvers():
        try:
            b = get_solver(name)
        except (ValueError, ImportError) as e:  # a preset broken in this checkout
            print(f"fuzz: skipping preset {name}: {e}", file=sys.stderr)
            continue
        out[name] = (b.name, b.options())
    return out


def _values_for(default: Any) -> list[tuple[Any, bool]]:
    """Bad values for an option with this default: (value, must it be rejected?)."""
    common: list[tuple[Any, bool]] = [([1], True), ({"a": 1}, True), (None, False)]
    if isinstance(default, bool):
        return common + [(1, True), (0, True), ("true", True), (0.5, True), (math.nan, True),
                         ("yes", True)]
    if isinstance(default, str):
        return common + [(3, True), ("no-such-thing", True), ("", False), (True, True),
                         ([default], True), (default.upper() + "x", True), (math.nan, True)]
    nums: list[tuple[Any, bool]] = [
        (math.nan, True), (math.inf, True), (-math.inf, True), (1e300, False),
        (-1e300, False), (0, False), (-1, False), (-0.5, False), (10**30, False),
        (2**63, False), (1e-300, False), ("3", True), (True, True), ("nan", True)]
    if isinstance(default, int) or default is None:
        nums += [(0.5, False), (-(10**30), False), (10**6, False)]
    if isinstance(default, float):
        nums += [(default * 1e6 if default else 1e6, False), (-default, False)]
    return common + nums


class OptionFuzzer:
    def __init__(self, seed: int = 0):
        self.rng = random.Random(seed)

    def cases(self, presets: dict[str, tuple[str, dict]] | None = None) -> list[Case]:
        presets = presets or preset_table()
        out = []
        n = 0
        for name, (backend, opts) in presets.items():
            for opt, default in opts.items():
                inf_ok = _declares_inf(name, opt)
                for value, must in _values_for(default):
                    if inf_ok and isinstance(value, float) and math.isinf(value) and value > 0:
                        must = False  # the option documents what infinity means
                    n += 1
                    via = "file" if self.rng.random() < 0.15 and _toml_ok(value) else "override"
                    out.append(Case("option", f"option/{n:05d}/{name}/{opt}",
                                    f"{opt} = {_short(value)}",
                                    {"preset": name, "backend": backend, "option": opt,
                                     "value": value, "via": via,
                                     "scene": option_scene(backend, opts)},
                                    (opt,), must))
        return out


def _declares_inf(preset: str, opt: str) -> bool:
    """Option ``opt`` of ``preset`` is declared ``inf_ok`` (``optplan.options.option``)."""
    import dataclasses

    from optplan.options import option_spec
    from optplan.solver import get_solver

    fields = {f.name: f for f in dataclasses.fields(type(get_solver(preset)))}
    spec = option_spec(fields[opt]) if opt in fields else None
    return bool(spec and spec.inf_ok)


def _toml_ok(v: Any) -> bool:
    try:
        tomllib.loads("v = " + _toml_value(v))
    except (TypeError, tomllib.TOMLDecodeError):
        return False
    return v is not None


def _short(v: Any, n: int = 40) -> str:
    s = repr(v)
    return s if len(s) <= n else s[: n - 3] + "..."


def init_cases(presets: dict[str, tuple[str, dict]] | None = None, seed: int = 0) -> list[Case]:
    """Bad (and odd but valid) initial guesses for every preset."""
    import numpy as np

    presets = presets or preset_table()
    rng = random.Random(seed)
    out = []
    n = 0
    for name, (backend, opts) in presets.items():
        scene = option_scene(backend, opts)
        sd = catalogue()[scene]
        lead = sd.get("formation", {}).get("leader") or sd["robots"][0]["id"]
        r0 = next(r for r in sd["robots"] if r["id"] == lead)
        s, g = np.array(r0["start"], float), np.array(r0["goal"], float)
        line = np.linspace(s, g, 6)
        variants: list[tuple[str, Any, bool]] = [
            ("nan", np.where(np.arange(12).reshape(6, 2) == 5, np.nan, line), True),
            ("inf", np.where(np.arange(12).reshape(6, 2) == 4, np.inf, line), True),
            ("-inf", np.where(np.arange(12).reshape(6, 2) == 7, -np.inf, line), True),
            ("1e300", line * 1e300, True), ("-1e300", line * -1e300, True),
            ("1e200 waypoint", np.vstack([line[:3], [[1e200, 0.0]], line[3:]]), True),
            ("empty", np.zeros((0, 2)), True), ("flat", line.ravel(), True),
            ("(4, 3)", np.ones((4, 3)), True), ("(6, 2, 1)", line[..., None], True),
            ("scalar", 3.0, True), ("string", "straight", True),
            ("list of strings", [["a", "b"]], True), ("ragged", [[1.0, 2.0], [3.0]], True),
            ("unknown robot", {"nobody": line}, True),
            ("dict of strings", {lead: "line"}, True),
            ("too many points", np.zeros((100_001, 2)), True),
            ("bool array", np.ones((4, 2), dtype=bool), False),
            ("single point", line[:1], False), ("outside bounds", line + 1e4, False),
            ("through obstacles", line, False), ("reversed", line[::-1], False),
            ("huge but finite", line * 1e9, True), ("integer list", line.astype(int).tolist(),
                                                    False),
            ("object array", np.array([[1.0, None]], dtype=object), True),
            ("complex", line.astype(complex) * 1j, True),
        ]
        rng.shuffle(variants)
        for what, value, must in variants:
            n += 1
            out.append(Case("init", f"init/{n:04d}/{name}/{what}", what,
                            {"preset": name, "backend": backend, "scene": scene,
                             "value": value}, ("init",), must))
    return out


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


# ======================================================================================
# the independent path check
# ======================================================================================


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


# ======================================================================================
# running a case (inside a worker process)
# ======================================================================================


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


def run_scenario(case: Case, tmp: Path) -> Outcome:
    import optplan as op

    if case.data["kind"] == "dict":
        d = copy.deepcopy(case.data["dict"])
        where = case.data["note"]
        deep = nested(3000)
        if where == "x":
            d["x"] = deep
        elif where == "bounds":
            d["bounds"] = [deep, 0.0, 1.0, 1.0]
        elif where == "robots[0].start":
            d["robots"][0]["start"] = [deep, 0.0]
        else:
            d["obstacles"] = [{"type": "polygon", "vertices": [deep, [0, 0], [1, 0]]}]
        try:
            prob = op.parse_problem(d, "fuzz.toml")
        except Exception as e:  # noqa: BLE001
            cat, det = _classify_error(e, case, "fuzz.toml")
            return Outcome(case, cat, det)
        return _solved_scenario(case, prob)
    path = _prepare(case, tmp, ".toml")
    try:
        prob = op.load_problem(path)
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, str(path))
        if cat == "clear error":
            ok, why = _cli_ok(["show", str(path)], case, str(path))
            if not ok:
                return Outcome(case, "unclear message", why)
        return Outcome(case, cat, det)
    return _solved_scenario(case, prob)


def _solved_scenario(case: Case, prob) -> Outcome:
    import optplan as op

    if case.must_reject:
        return Outcome(case, "silently accepted", "accepted: " + case.data.get("note", ""))
    try:
        res = op.solve(prob, "visgraph", rng=0, time_limit=SOLVE_TIME_LIMIT)
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, None)
        cat = "crash" if cat == "crash" else "unclear message"
        return Outcome(case, cat, "solve: " + det)
    return _compare(case, prob, res)


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


def run_option(case: Case, tmp: Path) -> Outcome:
    import optplan as op

    d = case.data
    opt, value = d["option"], d["value"]
    file = None
    kwargs: dict[str, Any] = {}
    solver: Any = d["preset"]
    if d["via"] == "file":
        from optplan.solver import all_preset_files

        src = tomllib.loads(all_preset_files()[d["preset"]].read_text(encoding="utf-8"))
        src.setdefault("options", {})[opt] = value
        path = tmp / f"{d['preset']}-fuzz.toml"
        path.write_text(toml_dumps(src), encoding="utf-8")
        solver, file = str(path), str(path)
    else:
        kwargs[opt] = value
    try:
        res = op.solve(d["scene"], solver, rng=0, time_limit=SOLVE_TIME_LIMIT, **kwargs)
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, file)
        return Outcome(case, cat, det)
    if case.must_reject:
        return Outcome(case, "silently accepted", f"accepted ({res.status})")
    return _compare(case, op.load_problem(d["scene"]), res) if not op.load_problem(
        d["scene"]).formation else Outcome(case, "accepted and solved", str(res.status))


def run_init(case: Case, tmp: Path) -> Outcome:
    import optplan as op

    d = case.data
    try:
        res = op.solve(d["scene"], d["preset"], rng=0, time_limit=SOLVE_TIME_LIMIT,
                       init=d["value"])
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, None)
        return Outcome(case, cat, det)
    if case.must_reject:
        return Outcome(case, "silently accepted", f"accepted ({res.status})")
    prob = op.load_problem(d["scene"])
    if prob.formation:
        return Outcome(case, "accepted and solved", str(res.status))
    return _compare(case, prob, res)


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


def run_selftest(case: Case, tmp: Path) -> Outcome:
    """Harness self-test cases: spin (a hang that computes), sleep (a hang that waits),
    raise (a crash or an error message)."""
    d = case.data
    if "spin" in d:
        t_end = time.process_time() + d["spin"]
        while time.process_time() < t_end:
            pass
    if "sleep" in d:
        time.sleep(d["sleep"])
    if "raise" in d:
        exc = {"TypeError": TypeError, "ValueError": ValueError}[d["raise"]]
        try:
            raise exc(d.get("message", "boom"))
        except Exception as e:  # noqa: BLE001
            return Outcome(case, *_classify_error(e, case, None))
    return Outcome(case, "accepted and solved", "ok")


# ======================================================================================
# maps, results databases and plugins (files and messages the toolkit reads besides scenes)
# ======================================================================================

_GRID_NAME = "<fuzz-grid>"


def _pgm(w: int = 4, h: int = 3, maxval: int = 255, body: bytes | None = None) -> bytes:
    """A binary PGM (P5): a free map with one occupied cell, or ``body`` as its pixels."""
    if body is None:
        px = bytearray([254 if maxval >= 254 else maxval] * (w * h))
        if px:
            px[len(px) // 2] = 0
        body = bytes(px)
    return f"P5\n{w} {h}\n{maxval}\n".encode() + body


def _png() -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    im = Image.new("L", (5, 4), 254)
    im.putpixel((2, 1), 0)
    im.save(buf, format="PNG")
    return buf.getvalue()


_ROS_YAML = {"image": "m.pgm", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "negate": 0,
             "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary"}


def _yaml_text(d: dict[str, Any]) -> bytes:
    """YAML of ``d``, each value in JSON's flow syntax (valid YAML)."""
    return "".join(f"{k}: {json.dumps(v)}\n" for k, v in d.items()).encode()


def _ros_variants() -> list[tuple[str, dict[str, Any] | bytes, tuple[str, ...], bool]]:
    """(what, YAML keys or raw bytes, keys an error must name, must it be rejected)."""
    out: list[tuple[str, dict[str, Any] | bytes, tuple[str, ...], bool]] = [
        ("intact", {}, (), False), ("origin [x, y]", {"origin": [1.0, -2.0]}, (), False),
        ("rotated origin", {"origin": [0.0, 0.0, 0.5]}, (), False),
        ("resolution 5e-2 (YAML 1.2)", b"resolution: 5e-2\n", (), False)]
    for key, bad in (("resolution", [0, -1, "abc", [1], None, True, 1e400, 1e-300, 5e-324,
                                     1e300]),
                     ("origin", [[0], [0, 0, 0, 0], "a b", [None, 0], [1e400, 0], 3]),
                     ("negate", [2, "yes", -1, 0.5]),
                     ("occupied_thresh", [1.5, -0.1, "x", 1e400]),
                     ("free_thresh", [0.9, -1, None]),
                     ("mode", ["trinari", 3, ""]),
                     ("image", ["missing.pgm", "", 5, None, "."])):
        for v in bad:
            out.append((f"{key} = {v!r}", {key: v}, (key,), True))
    out += [("unknown key", {"negat": 1}, ("negat",), True),
            ("no image", {"image": ...}, ("image",), True),
            ("no resolution", {"resolution": ...}, ("resolution",), True),
            ("no origin", {"origin": ...}, ("origin",), True),
            ("YAML list", b"- 1\n- 2\n", ("<root>",), True),
            ("YAML syntax", b"image: [m.pgm\n", ("invalid YAML",), True),
            ("not UTF-8", b"\xff\xfeimage: m.pgm\n", ("cannot read file", "invalid YAML",
                                                      "image", "not UTF-8"), True),
            ("empty file", b"", ("<root>",), True)]
    return out


def _image_variants() -> list[tuple[str, bytes, bool]]:
    """(what, the image the YAML names, must it be rejected)."""
    png = _png()
    return [("PGM maxval 0", _pgm(maxval=0), True), ("PGM maxval 70000", _pgm(maxval=70000), True),
            ("PGM width 0", _pgm(w=0), True), ("PGM truncated", _pgm()[:-5], True),
            ("PGM header only", b"P5\n4 3\n255\n", True), ("garbage", b"not an image" * 9, True),
            ("empty image", b"", True), ("PNG truncated", png[: len(png) // 2], True),
            ("PNG", png, False), ("16-bit PGM", _pgm(maxval=65535, body=b"\xff\xfe" * 12), False)]


def _movingai_variants() -> list[tuple[str, bytes, tuple[str, ...], bool]]:
    ok = "type octile\nheight 3\nwidth 4\nmap\n@@@@\n@..@\n@@@@\n"
    keys = ("height", "width", "map", "type", "line", "not a MovingAI map")
    return [("intact .map", ok.encode(), (), False),
            ("UTF-8 BOM", b"\xef\xbb\xbf" + ok.encode(), (), False),
            ("CRLF", ok.replace("\n", "\r\n").encode(), (), False),
            ("trailing blanks on rows", ok.replace("@..@", "@..@  ").encode(), (), False),
            ("a citation after the grid", (ok + "Sturtevant 2012, grid benchmarks\n").encode(),
             (), False),
            ("a grid row after the grid", (ok + "@@@@\n").encode(), keys, True),
            ("BOM, then not UTF-8", b"\xef\xbb\xbf\xff\xfe" + ok.encode(), keys + (
                "not UTF-8",), True),
            ("height mismatch", ok.replace("height 3", "height 4").encode(), keys, True),
            ("width mismatch", ok.replace("width 4", "width 5").encode(), keys, True),
            ("unknown terrain", ok.replace("..", ".X").encode(), keys, True),
            ("no map line", ok.replace("map\n", "").encode(), keys, True),
            ("height 0", ok.replace("height 3", "height 0").encode(), keys, True),
            ("height -3", ok.replace("height 3", "height -3").encode(), keys, True),
            ("no header", b"@@@@\n@..@\n", keys, True), ("binary", b"\x00\xff" * 10, keys, True),
            ("empty .map", b"", keys, True)]


def _grid_msg_variants(rng: random.Random) -> list[tuple[str, Any, tuple[str, ...], bool]]:
    """nav_msgs/OccupancyGrid dicts: (what, message, keys, must it be rejected)."""
    def msg(**info: Any) -> dict[str, Any]:
        base: dict[str, Any] = {
            "resolution": 0.5, "width": 3, "height": 2,
            "origin": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
        base.update(info)
        return {"header": {"frame_id": "map"}, "info": base,
                "data": [0, 100, -1, 0, 0, 50]}

    out: list[tuple[str, Any, tuple[str, ...], bool]] = [("intact message", msg(), (), False)]
    tilted = {"position": {"x": 0.0, "y": 0.0}, "orientation": {"x": 0.7, "y": 0.0, "z": 0.0,
                                                                "w": 0.7}}
    yawed = {"position": {"x": 1.0, "y": 2.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.4,
                                                               "w": 0.9}}
    out.append(("rotated about z", msg(origin=yawed), (), False))
    import numpy as np

    out += [("resolution numpy.float32", msg(resolution=np.float32(0.5)), (), False),
            ("resolution numpy.float64", msg(resolution=np.float64(0.5)), (), False),
            ("resolution numpy.int64", msg(resolution=np.int64(1)), (), False)]
    for v in (1e-300, 5e-324, 1e300, np.float32(0.0), np.float64(math.inf)):
        out.append((f"info.resolution = {_short(v)}", msg(resolution=v), ("info.resolution",),
                    True))
    for what, data in (("data int8 array", np.array([0, 100, -1, 0, 0, 50], dtype=np.int8)),
                       ("data bytes", bytes([0, 100, 255, 0, 0, 50])),
                       ("data numpy ints", [np.int8(0), np.int64(100), -1, 0, 0, 50])):
        m = msg()
        m["data"] = data
        out.append((what, m, (), False))
    out.append(("81M cells (9001 x 9001)", {"big": [9001, 9001]}, ("info.width",), True))
    for key, v in (("resolution", 0.0), ("resolution", -1.0), ("resolution", math.nan),
                   ("resolution", "0.5"), ("width", 0), ("width", 2.5), ("height", True),
                   ("height", -2), ("width", 2**40), ("origin", tilted), ("origin", [0, 0]),
                   ("origin", {"position": {"x": 0.0}}), ("resoluton", 1.0)):
        out.append((f"info.{key} = {_short(v)}", msg(**{key: v}), (f"info.{key}",), True))
    for what, data, key in (("data short", [0] * 5, "data"), ("data long", [0] * 7, "data"),
                            ("data 101", [0, 101, 0, 0, 0, 0], "data[1]"),
                            ("data -2", [0, 0, -2, 0, 0, 0], "data[2]"),
                            ("data 0.5", [0.5] * 6, "data[0]"),
                            ("data nan", [math.nan] * 6, "data[0]"),
                            ("data string", "abcdef", "data"), ("data dict", {"a": 1}, "data"),
                            ("data nested", [[0, 0, 0], [0, 0, 0]], "data"),
                            ("data '50'", [0, "50", 0, 0, 0, 0], "data[1]"),
                            ("data True", [0, 0, True, 0, 0, 0], "data[2]"),
                            ("data numpy '50'", np.array(["0", "50", "0", "0", "0", "0"]),
                             "data"),
                            ("data None", None, "data")):
        m = msg()
        m["data"] = data
        out.append((what, m, (key,), True))
    for k in range(20):  # random values, some out of range
        m = msg()
        m["data"] = [rng.choice([-1, 0, 100, rng.randint(-130, 130)]) for _ in range(6)]
        bad = any(not -1 <= v <= 100 for v in m["data"])
        out.append((f"random data {k}", m, ("data",), bad))
    out += [("root list", [1, 2], ("<root>",), True), ("no info", {"data": []}, ("info",), True),
            ("no data", {"info": msg()["info"]}, ("data",), True)]
    return out


def map_cases(seed: int = 0) -> list[Case]:
    """ROS map_server YAML + image, bare images, MovingAI maps and OccupancyGrid messages."""
    rng = random.Random(seed)
    out: list[Case] = []

    def add(what: str, data: dict[str, Any], keys: tuple[str, ...], must: bool) -> None:
        out.append(Case("map", f"map/{len(out) + 1:04d}/{what}", what, data, keys, must))

    for what, edit, keys, must in _ros_variants():
        if isinstance(edit, bytes):
            text = edit if what != "resolution 5e-2 (YAML 1.2)" else \
                _yaml_text({k: v for k, v in _ROS_YAML.items() if k != "resolution"}) + edit
        else:
            d = {k: v for k, v in {**_ROS_YAML, **edit}.items() if v is not ...}
            text = _yaml_text(d)
        add(f"ROS YAML {what}", {"files": {"m.yaml": text, "m.pgm": _pgm()}, "open": "m.yaml"},
            keys, must)
    for what, img, must in _image_variants():
        name = "m.png" if "PNG" in what else "m.pgm"
        add(f"ROS image {what}", {"files": {"m.yaml": _yaml_text({**_ROS_YAML, "image": name}),
                                            name: img}, "open": "m.yaml"}, ("image",), must)
        add(f"bare image {what}", {"files": {name: img}, "open": name, "resolution": 0.1},
            ("image",), must)
    import numpy as np

    for what, res, must in (("resolution 1e-300", 1e-300, True), ("resolution 1e300", 1e300, True),
                            ("resolution numpy.float32", np.float32(0.1), False)):
        add(f"bare image {what}", {"files": {"m.pgm": _pgm()}, "open": "m.pgm",
                                   "resolution": res}, ("resolution",), must)
    for what, text, keys, must in _movingai_variants():
        add(f"MovingAI {what}", {"files": {"m.map": text}, "open": "m.map"}, keys, must)
    for what, msg, keys, must in _grid_msg_variants(rng):
        add(f"OccupancyGrid {what}", {"msg": msg}, keys, must)
    return out


def run_map(case: Case, tmp: Path) -> Outcome:
    from optplan.maps import read_grid, read_occupancy_grid

    d = case.data
    if "msg" in d:
        msg = copy.deepcopy(d["msg"])
        if isinstance(msg, dict) and "big" in msg:  # made here: 81 MB would not go in a pipe
            import numpy as np

            w, h = msg["big"]
            msg = {"header": {"frame_id": "map"}, "data": np.zeros(w * h, dtype=np.int8),
                   "info": {"resolution": 0.05, "width": w, "height": h, "origin": {
                       "position": {"x": 0.0, "y": 0.0, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}
        try:
            read_occupancy_grid(msg, name=_GRID_NAME)
        except Exception as e:  # noqa: BLE001
            return Outcome(case, *_classify_error(e, case, _GRID_NAME))
        return _accepted(case, "read")
    for name, content in d["files"].items():
        (tmp / name).write_bytes(content)
    path = tmp / d["open"]
    try:
        read_grid(path, resolution=d.get("resolution"))
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, str(path))
        if cat == "clear error":
            argv = ["import-map", str(path), "--radius", "0.01", "--start", "0.07,0.07",
                    "--goal", "0.12,0.07"]
            if d.get("resolution"):
                argv += ["--resolution", str(d["resolution"])]
            ok, why = _cli_ok(argv, case, str(path))
            if not ok:
                return Outcome(case, "unclear message", why)
        return Outcome(case, cat, det)
    return _accepted(case, "read")


def _accepted(case: Case, how: str) -> Outcome:
    if case.must_reject:
        return Outcome(case, "silently accepted", how)
    return Outcome(case, "accepted and solved", how)


# -- results databases -----------------------------------------------------------------------


def _db_bytes(tmp: Path, edit: Callable[[Any], None] | None = None, runs: int = 3) -> bytes:
    """A small results database (made-up runs), optionally edited with SQL, as bytes."""
    import sqlite3

    from optplan import benchdb

    path = tmp / f"db{random.random()}.sqlite"
    with benchdb.ResultsDB(path) as db:
        exp = db.begin_experiment(benchdb.experiment_info("fuzz"), planned=runs, skipped=0)
        for k in range(runs):
            row = {"problem": "open-field", "solver": "visgraph", "seed": k, "status": "optimal",
                   "success": True, "length": 10.0 + k, "optimum": 10.0, "ratio": 1.0,
                   "min_clearance": 1.0, "collisions": 0, "wall_time": 0.01, "n_iter": 1,
                   "n_eval": 1, "message": "fuzz run " * 4, "backend": "visgraph",
                   "options": "{}"}
            db.add_run(exp, row, "{}", [(i, 5.0 - i, i, 0.1 * i) for i in range(5)], "w")
        db.end_experiment(exp, "complete")
    if edit is not None:
        con = sqlite3.connect(path)
        edit(con)
        con.commit()
        con.close()
    return path.read_bytes()


def _corrupt(data: bytes, page: int, size: int = 4096) -> bytes:
    b = bytearray(data)
    b[page * size - 200: page * size - 50] = b"\xff" * 150
    return bytes(b)


def _root_page(table: str) -> Callable[[bytes, Path], int]:
    def find(data: bytes, tmp: Path) -> int:
        import sqlite3

        p = tmp / "probe.sqlite"
        p.write_bytes(data)
        con = sqlite3.connect(p)
        (root,) = con.execute("SELECT rootpage FROM sqlite_master WHERE name = ?",
                              (table,)).fetchone()
        con.close()
        p.unlink()
        return int(root)
    return find


def database_cases(seed: int = 0) -> list[Case]:
    """Results databases: intact, another program's, another version, damaged, locked."""
    rng = random.Random(seed)
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-db-"))
    out: list[Case] = []

    def add(what: str, content: bytes | None, keys: tuple[str, ...], must: bool,
            kind: str = "file") -> None:
        out.append(Case("database", f"database/{len(out) + 1:04d}/{what}", what,
                        {"bytes": content, "kind": kind}, keys, must))

    try:
        good = _db_bytes(tmp)
        add("intact", good, (), False)
        # report: "holds no runs"; export-arena: "no runs to export" (Planner Arena cannot
        # open a database without experiments)
        add("no runs", _db_bytes(tmp, runs=0), ("holds no runs", "no runs to export"), False)
        for what, sql, keys in (
                ("foreign runs table", "DROP TABLE progress", ("not an optplan results database",)),
                ("runs without columns", "ALTER TABLE runs DROP COLUMN message",
                 ("not an optplan results database",)),
                ("schema version 99", "UPDATE meta SET value = '99'", ("meta.schema_version",)),
                ("schema version text", "UPDATE meta SET value = 'x'", ("meta.schema_version",)),
                ("no schema version", "DELETE FROM meta", ("not an optplan results database",)),
                ("text not UTF-8", "UPDATE runs SET message = CAST(X'66ff' AS TEXT)",
                 ("damaged",))):
            # text SQLite cannot decode is found where it is read: the runs, not the progress
            add(what, _db_bytes(tmp, lambda con, s=sql: con.execute(s)), keys,
                "UTF-8" not in what)
        add("progress page damaged", _corrupt(good, _root_page("progress")(good, tmp)),
            ("integrity check", "damaged"), True)
        add("runs index damaged", _corrupt(good, _root_page("sqlite_autoindex_runs_1")(good, tmp)),
            ("integrity check", "damaged"), True)
        other = tmp / "other.sqlite"
        import sqlite3

        con = sqlite3.connect(other)
        con.execute("CREATE TABLE runs (x TEXT, y REAL)")
        con.commit()
        con.close()
        add("another program's file", other.read_bytes(), ("not an optplan results database",),
            True)
        for frac in (0.1, 0.5, 0.9):
            add(f"truncated {frac:g}", good[: int(len(good) * frac)],
                ("not an optplan results database", "damaged", "integrity check"), True)
        for k in range(12):
            i = rng.randrange(100, len(good))
            add(f"byte flip {k}", good[:i] + bytes([rng.randrange(256)]) + good[i + 1:],
                ("not an optplan results database", "damaged", "integrity check",
                 "meta.schema_version", "holds no runs", "no runs to export"), False)
        add("text file", b"hello, not a database\n" * 50, ("not an optplan results database",),
            True)
        add("empty file", b"", ("not an optplan results database", "holds no runs",
                                 "no runs to export"), False)
        add("locked", good, ("locked",), True, kind="locked")
        add("directory", None, ("no such results database", "cannot open the results database"),
            True, kind="dir")
        # a missing file is a new database to ResultsDB (a sweep creates it), an error to readers
        add("missing", None, ("no such results database",), False, kind="missing")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def _db_calls(path: Path) -> list[tuple[str, Callable[[], Any]]]:
    from optplan import benchdb

    return [("read_runs", lambda: benchdb.read_runs(path)),
            ("read_progress", lambda: benchdb.read_progress(path)),
            ("read_experiments", lambda: benchdb.read_experiments(path)),
            ("ResultsDB", lambda: benchdb.ResultsDB(path).close())]


def run_database(case: Case, tmp: Path) -> Outcome:
    import sqlite3

    from optplan import benchdb

    kind = case.data["kind"]
    path = _prepare(case, tmp, ".sqlite") if kind != "locked" else tmp / "locked.sqlite"
    holder = None
    if kind == "locked":
        path.write_bytes(case.data["bytes"])
        holder = sqlite3.connect(path, isolation_level=None)
        holder.execute("PRAGMA locking_mode = EXCLUSIVE")
        holder.execute("BEGIN EXCLUSIVE")
        benchdb.LOCK_TIMEOUT = 0.2
    accepted, errors = [], []
    try:
        for argv in (["report", str(path), "--out", str(tmp / "report")],
                     ["export-arena", str(path), str(tmp / "arena.db")]):
            rc, err = _cli(argv)
            lines = [ln for ln in err.splitlines() if ln.strip()]
            if rc == 0:
                accepted.append(argv[0])
            elif rc != 2 or len(lines) != 1 or not lines[0].startswith("optplan: error: "):
                return Outcome(case, "crash" if rc == 1 else "unclear message",
                               f"CLI {argv[0]} exit {rc}: {err[-300:]!r}")
            else:
                ok, why = _message_ok(lines[0], case.keys, str(path))
                if not ok:
                    return Outcome(case, "unclear message", f"CLI {argv[0]}: {why}: {lines[0]}")
                errors.append(f"{argv[0]}: {lines[0]}")
        for name, call in _db_calls(path):
            try:
                call()
                accepted.append(name)
            except (ValueError, FileNotFoundError) as e:
                ok, why = _message_ok(str(e), case.keys, str(path))
                if not ok:
                    return Outcome(case, "unclear message", f"{name}: {why}: {e}")
                errors.append(f"{name}: {e}")
            except Exception as e:  # noqa: BLE001
                return Outcome(case, "crash", f"{name}: {type(e).__name__}: {e}")
    finally:
        if holder is not None:
            holder.close()
            benchdb.LOCK_TIMEOUT = 30.0
    if case.must_reject and accepted:
        return Outcome(case, "silently accepted", f"accepted by {', '.join(accepted)}")
    if errors:
        return Outcome(case, "clear error", errors[0][:300])
    return Outcome(case, "accepted and solved", "read, reported and exported")


# -- plugins ---------------------------------------------------------------------------------

_PLUGIN_BACKEND = '''
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.result import Status
from optplan.solver import Backend


@dataclass(frozen=True, kw_only=True)
class Line(Backend):
    """A straight line from start to goal."""

    name: ClassVar[str] = "NAME"

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        paths = {r.id: np.array([r.start, r.goal]) for r in problem.robots}
        return self.finish(problem, paths, claim=Status.solved, n_iter=1, n_eval=1)
'''

_PLUGIN_RUN = '''
import contextlib, io, json, sys, warnings
import optplan as op
from optplan import cli

out = {"use": []}
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    try:
        out["visgraph"] = op.solve("open-field", "visgraph").status.value
        out["n_solvers"] = len(op.list_solvers())
    except BaseException as e:
        out["broke"] = f"{type(e).__name__}: {e}"
    for name in sys.argv[1:]:
        try:
            out["use"].append(["ok", op.solve("open-field", name).status.value])
        except (ImportError, ValueError) as e:
            out["use"].append(["error", f"{type(e).__name__}: {e}"])
        except BaseException as e:
            out["use"].append(["crash", f"{type(e).__name__}: {e}"])
out["warnings"] = [f"{w.category.__name__}: {w.message}" for w in caught]
err = io.StringIO()
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
    out["cli"] = cli.main(["list", "solvers"])
out["cli_err"] = err.getvalue()
print("FUZZ-RESULT " + json.dumps(out))
'''


def _plugin(dist: str, files: dict[str, str], backends: str = "",
            presets: str = "") -> dict[str, Any]:
    eps = (f"[optplan.backends]\n{backends}\n" if backends else "") + \
          (f"[optplan.presets]\n{presets}\n" if presets else "")
    return {"dist": dist, "files": files, "entry_points": eps}


def plugin_cases() -> list[Case]:
    """Plugin distributions that raise, are malformed or name what does not exist, beside the
    toolkit's own solvers (which must keep working)."""
    good = _PLUGIN_BACKEND.replace("NAME", "fzline")
    variants: list[tuple[str, dict[str, Any], list[str], bool]] = [
        ("working plugin", _plugin("fzgood", {"fzgood/__init__.py": "", "fzgood/b.py": good,
                                              "fzgood/presets/fzline-fast.toml":
                                              'backend = "fzline"\n'},
                                   "fzline = fzgood.b:Line", "fzgood = fzgood.presets"),
         ["fzline", "fzline-fast"], False),
        ("namespace presets", _plugin("fzns", {"fzns/b.py": good.replace("fzline", "fzns"),
                                               "fzns/presets/fzns-five.toml":
                                               'backend = "fzns"\n'},
                                      "fzns = fzns.b:Line", "fzns = fzns.presets"),
         ["fzns-five"], False)]
    for what, init in (("package raises", "raise RuntimeError('boom')"),
                       ("package SyntaxError", "def (:"),
                       ("package missing dependency", "import no_such_dependency_fz"),
                       ("package exits", "raise SystemExit(3)"),
                       ("package calls sys.exit()", "import sys\nsys.exit()"),
                       ("package raises a BaseException", "class Stop(BaseException):\n"
                                                          "    pass\nraise Stop('stop')")):
        variants.append((what, _plugin("fzbad", {"fzbad/__init__.py": init, "fzbad/b.py": good,
                                                 "fzbad/presets/fzbad-x.toml":
                                                 'backend = "fzline"\n'},
                                       "fzline = fzbad.b:Line", "fzbad = fzbad.presets"),
                         ["fzline"], True))
    for what, ep in (("no colon", "fzline = fzbad.b"), ("two colons", "fzline = fzbad.b:A:B"),
                     ("empty class", "fzline = fzbad.b:"), ("missing class",
                                                             "fzline = fzbad.b:Missing"),
                     ("missing module", "fzline = fzbad.nothere:Line"),
                     ("not a backend", "fzline = fzbad.b:np"), ("spaces", "fzline = fz bad:L")):
        variants.append((f"entry point {what}", _plugin(
            "fzbad", {"fzbad/__init__.py": "", "fzbad/b.py": good}, ep), ["fzline"], True))
    for what, files, ep in (
            ("presets missing", {}, "fzbad = fzbad.nothere"),
            ("presets a path", {}, "fzbad = fzbad/presets"),
            ("preset TOML broken", {"fzbad/presets/fzbad-x.toml": "backend = [\n"},
             "fzbad = fzbad.presets"),
            ("preset unknown backend", {"fzbad/presets/fzbad-x.toml": 'backend = "nope"\n'},
             "fzbad = fzbad.presets"),
            ("preset bad option", {"fzbad/presets/fzbad-x.toml":
                                   'backend = "visgraph"\n[options]\nnope = 1\n'},
             "fzbad = fzbad.presets")):
        variants.append((what, _plugin("fzbad", {"fzbad/__init__.py": "", **files}, presets=ep),
                         ["fzbad-x"], True))
    return [Case("plugin", f"plugin/{k + 1:04d}/{what}", what, {"plugin": p, "use": use},
                 (p["dist"], "fzbad-x", "fzline"), must)
            for k, (what, p, use, must) in enumerate(variants)]


def _install_plugin(root: Path, p: dict[str, Any]) -> None:
    for rel, text in p["files"].items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    info = root / f"{p['dist']}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {p['dist']}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(p["entry_points"])


def _unclear(dist: str, errors: list[str], warned: list[str]) -> str | None:
    """Why the errors about the plugin distribution ``dist`` are unclear (None when they are
    clear): one names neither the distribution nor the preset, or one naming the distribution
    was not also reported as a ``PluginWarning`` with the same text (``"ImportError: text"``,
    ``"PluginWarning: text"``)."""
    if any(f"'{dist}'" not in m and "fzbad-x" not in m for m in errors):
        return f"does not name the distribution: {errors}"
    texts = {w.removeprefix("PluginWarning: ") for w in warned}
    unwarned = [m for m in errors if f"distribution '{dist}'" in m
                and m.split(": ", 1)[-1] not in texts]
    return f"not reported as a PluginWarning: {unwarned}" if unwarned else None


def _plugin_verdict(case: Case, out: dict[str, Any]) -> Outcome:
    dist = case.data["plugin"]["dist"]
    if "broke" in out or out.get("visgraph") != "optimal" or out.get("cli") != 0:
        return Outcome(case, "crash", f"the toolkit broke: {out}")
    crashes = [m for k, m in out["use"] if k == "crash"]
    if crashes:
        return Outcome(case, "crash", crashes[0])
    errors = [m for k, m in out["use"] if k == "error"]
    said = errors + out["warnings"]
    unclear = _unclear(dist, errors, out["warnings"])
    if unclear:
        return Outcome(case, "unclear message", unclear)
    if not case.must_reject:
        if errors or out["warnings"]:
            return Outcome(case, "unclear message", f"a working plugin complained: {said}")
        return Outcome(case, "accepted and solved", f"used {case.data['use']}")
    if len(errors) < len(out["use"]):
        return Outcome(case, "silently accepted", f"a broken plugin was used: {out['use']}")
    if not any(dist in w for w in out["warnings"] + errors):
        return Outcome(case, "silently accepted", f"nothing names {dist!r}: {said}")
    return Outcome(case, "clear error", errors[0][:300])


def run_plugin(case: Case, tmp: Path) -> Outcome:
    root = tmp / "site"
    root.mkdir()
    _install_plugin(root, case.data["plugin"])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), str(ROOT)])}
    # no timeout: the parent counts this child's CPU time with its worker's (a hang kills both)
    proc = subprocess.run([sys.executable, "-c", _PLUGIN_RUN, *case.data["use"]], env=env,
                          capture_output=True, text=True, cwd=tmp)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("FUZZ-RESULT ")), None)
    if line is None:
        return Outcome(case, "crash", f"exit {proc.returncode}: {proc.stderr[-400:]!r}")
    return _plugin_verdict(case, json.loads(line.removeprefix("FUZZ-RESULT ")))


# -- ROS path messages, import_map's crop, MovingAI .scen lines, Planner Arena export --------

_PATH_NAME = "<fuzz-path>"
_NS = 1_000_000_000


def _path_msg(stamps: list[tuple[Any, Any]], head_stamp: bool = True) -> dict[str, Any]:
    """A ``nav_msgs/Path`` dict with one pose per ``(sec, nanosec)``."""
    head: dict[str, Any] = {"frame_id": "map"}
    if head_stamp:
        head["stamp"] = {"sec": 0, "nanosec": 0}
    return {"header": head, "poses": [
        {"header": {"frame_id": "map", "stamp": {"sec": s, "nanosec": ns}},
         "pose": {"position": {"x": float(k), "y": 0.5 * k, "z": 0.0},
                  "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
        for k, (s, ns) in enumerate(stamps)]}


def _first_bad_stamp(stamps: list[tuple[Any, Any]]) -> int | None:
    """The index of the first pose whose stamp is out of range or before the previous one."""
    last = -1
    for k, (s, ns) in enumerate(stamps):
        if not (type(s) is int and type(ns) is int and 0 <= s < 2**31 and 0 <= ns < _NS):
            return k
        if s * _NS + ns < last:
            return k
        last = s * _NS + ns
    return None


def _path_variants(rng: random.Random) -> list[tuple[str, Any, tuple[str, ...], bool]]:
    """nav_msgs/Path dicts: (what, message, keys, must it be rejected)."""
    ok = [(0, 0), (1, 0), (2, 500_000_000)]
    out: list[tuple[str, Any, tuple[str, ...], bool]] = [
        ("intact", _path_msg(ok), (), False),
        ("equal stamps (a jump)", _path_msg([(0, 0), (1, 0), (1, 0)]), (), False),
        ("no header stamp", _path_msg(ok, head_stamp=False), (), False),
        ("largest stamp", _path_msg([(2**31 - 1, _NS - 1)]), (), False),
        ("empty path", _path_msg([]), ("poses",), False)]
    for what, st in (("decreasing sec", [(0, 0), (2, 0), (1, 0)]),
                     ("decreasing nanosec", [(1, 5), (1, 4)]),
                     ("sec -1", [(0, 0), (-1, 0)]), ("sec 2**31", [(0, 0), (2**31, 0)]),
                     ("sec 2**64", [(0, 0), (2**64, 0)]), ("nanosec 1e9", [(0, _NS)]),
                     ("nanosec -1", [(0, 0), (1, -1)]), ("sec 1.5", [(0, 0), (1.5, 0)]),
                     ("sec 1.0", [(1.0, 0)]), ("sec True", [(0, 0), (True, 0)]),
                     ("sec '1'", [(0, 0), ("1", 0)]), ("sec None", [(None, 0)]),
                     ("nanosec nan", [(0, math.nan)]), ("sec inf", [(0, 0), (math.inf, 0)])):
        k = _first_bad_stamp(st)
        out.append((what, _path_msg(st), (f"poses[{k}].header.stamp",), True))
    m = _path_msg(ok)
    m["header"]["stamp"] = {"sec": -1, "nanosec": 0}
    out.append(("header stamp sec -1", m, ("header.stamp",), True))

    def edit(what: str, f: Callable[[dict], Any], keys: tuple[str, ...]) -> None:
        m = _path_msg(ok)
        f(m)
        out.append((what, m, keys, True))

    p1 = "poses[1]"
    edit("pose without stamp", lambda m: m["poses"][1]["header"].pop("stamp"),
         (f"{p1}.header.stamp",))
    edit("pose without header", lambda m: m["poses"][1].pop("header"), (f"{p1}.header",))
    edit("unknown pose key", lambda m: m["poses"][1].__setitem__("twist", {}), (f"{p1}.twist",))
    edit("frame_id 5", lambda m: m["header"].__setitem__("frame_id", 5), ("header.frame_id",))
    edit("no header", lambda m: m.pop("header"), ("header",))
    edit("poses a string", lambda m: m.__setitem__("poses", "abc"), ("poses",))
    edit("poses None", lambda m: m.__setitem__("poses", None), ("poses",))
    edit("poses a dict", lambda m: m.__setitem__("poses", {"a": 1}), ("poses",))
    for v in (math.nan, math.inf, -math.inf, "1", None, True, [1.0]):
        edit(f"position.x {_short(v)}",
             lambda m, v=v: m["poses"][1]["pose"]["position"].__setitem__("x", v),
             (f"{p1}.pose.position.x",))
    edit("tilted orientation", lambda m: m["poses"][1]["pose"].__setitem__(
        "orientation", {"x": 0.7, "y": 0.0, "z": 0.0, "w": 0.7}), (f"{p1}.pose.orientation",))
    edit("zero quaternion", lambda m: m["poses"][1]["pose"].__setitem__(
        "orientation", {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}), (f"{p1}.pose.orientation",))
    out.append(("root a list", [1, 2], ("<root>",), True))
    for k in range(24):  # random stamp sequences, some out of range or decreasing
        st = [(rng.choice([0, 1, 2, 3, rng.randint(-2, 6), 2**31 - 1, 2**31]),
               rng.choice([0, 1, _NS - 1, rng.randrange(_NS), _NS, -1]))
              for _ in range(rng.randint(2, 6))]
        bad = _first_bad_stamp(st)
        keys = (f"poses[{bad}].header.stamp",) if bad is not None else ()
        out.append((f"random stamps {k}", _path_msg(st), keys, bad is not None))
    return out


def path_cases(seed: int = 0) -> list[Case]:
    """``nav_msgs/Path`` messages read with :func:`optplan.maps.read_path_msg`, and paths
    written with :func:`~optplan.maps.timed_path_msg` read back."""
    rng = random.Random(seed)
    out = [Case("path", f"path/{k + 1:04d}/{what}", what, {"msg": msg}, keys, must)
           for k, (what, msg, keys, must) in enumerate(_path_variants(rng))]
    for k in range(6):
        n = rng.randint(1, 6)
        times = sorted(rng.choice([0.0, 0.5, 1.0, rng.uniform(0, 9), 1e-9 * k]) for _ in range(n))
        pts = [[rng.uniform(-50, 50), rng.uniform(-50, 50)] for _ in range(n)]
        out.append(Case("path", f"path/{len(out) + 1:04d}/written {k}", f"written {k}",
                        {"write": [pts, times]}))
    return out


def _check_timed_path(case: Case, tp: Any) -> Outcome:
    """An accepted path: finite points, one per pose, non-decreasing times in ROS's range."""
    import numpy as np

    n = len(case.data["msg"]["poses"]) if "msg" in case.data else len(case.data["write"][1])
    t = np.asarray(tp.times, dtype=float)
    bad = (len(tp.points) != n or len(t) != n or not np.isfinite(tp.points).all()
           or not np.isfinite(t).all() or (t < 0).any() or (t > 2.0**31).any()
           or (np.diff(t) < 0).any())
    if bad or case.must_reject:
        return Outcome(case, "silently accepted", f"read {n} poses, times {t.tolist()[:8]}")
    return Outcome(case, "accepted and solved", f"{n} poses")


def run_path(case: Case, tmp: Path) -> Outcome:
    import numpy as np

    from optplan.maps import read_path_msg, timed_path_msg

    d = case.data
    try:
        if "write" in d:
            pts, times = d["write"]
            msg = timed_path_msg(np.asarray(pts, dtype=float), np.asarray(times, dtype=float))
        else:
            msg = copy.deepcopy(d["msg"])
        tp = read_path_msg(msg, name=_PATH_NAME)
    except Exception as e:  # noqa: BLE001
        return Outcome(case, *_classify_error(e, case, _PATH_NAME))
    return _check_timed_path(case, tp)


#: the crop map: 12 x 10 cells of 1 m, unknown (grey) but for a free block of 8 x 6 cells whose
#: world box is (2, 2)-(10, 8) (the bounds when cropped; (0, 0)-(12, 10) when not)
_CROP_SHAPE, _CROP_ROWS, _CROP_COLS = (10, 12), (2, 8), (2, 10)
_CROPPED, _UNCROPPED = (2.0, 2.0, 10.0, 8.0), (0.0, 0.0, 12.0, 10.0)


def _crop_pgm() -> bytes:
    h, w = _CROP_SHAPE
    px = bytearray([128] * (h * w))  # 128: unknown in trinary mode
    for r in range(*_CROP_ROWS):
        for c in range(*_CROP_COLS):
            px[r * w + c] = 254
    return _pgm(w, h, body=bytes(px))


def crop_cases() -> list[Case]:
    """``import_map(..., crop=...)`` on a map with an unknown margin: every switch value
    (``"auto"``, bools, ``numpy.bool_``) and values that are not one (numbers, 0 and 1
    included, strings, None, ...); an accepted value must crop exactly when it says so."""
    import numpy as np

    good: list[tuple[Any, str, bool]] = [
        ("auto", "occupied", True), ("auto", "free", False), (True, "occupied", True),
        (False, "occupied", False), (np.True_, "occupied", True),
        (np.False_, "occupied", False), (True, "free", True), (np.False_, "free", False)]
    bad: list[Any] = [0, 1, 0.0, 1.0, -1, 2, math.nan, np.int64(0), np.int8(1),
                      np.float64(0.0), np.float32(1.0), "yes", "no", "True", "false", "on",
                      "off", "", "AUTO", None, [True], [], {}, b"auto", 1 + 0j]
    out = [Case("crop", f"crop/{k + 1:04d}/crop={v!r} unknown={u}", f"crop={v!r} unknown={u}",
                {"crop": v, "unknown": u, "cropped": c})
           for k, (v, u, c) in enumerate(good)]
    out += [Case("crop", f"crop/{len(out) + k + 1:04d}/crop={v!r}", f"crop={v!r}",
                 {"crop": v, "unknown": "occupied"}, ("crop",), True)
            for k, v in enumerate(bad)]
    # the import's other numbers at their extremes (a raw GEOSException at 1e-300 once)
    out += [Case("crop", f"crop/{len(out) + k + 1:04d}/resolution={v!r}", f"resolution={v!r}",
                 {"crop": "auto", "unknown": "occupied", "resolution": v}, ("resolution",),
                 True) for k, v in enumerate((1e-300, 5e-324, 1e300, -1.0, math.nan))]
    return out


def run_crop(case: Case, tmp: Path) -> Outcome:
    import numpy as np

    from optplan.maps import import_map

    d = case.data
    (tmp / "m.pgm").write_bytes(_crop_pgm())
    path = tmp / "m.pgm"
    try:
        prob = import_map(path, radius=0.1, start=(3.0, 5.0), goal=(9.0, 5.0),
                          resolution=d.get("resolution", 1.0), crop=d["crop"],
                          unknown=d["unknown"])
    except Exception as e:  # noqa: BLE001
        return Outcome(case, *_classify_error(e, case, str(path)))
    bounds = tuple(float(b) for b in prob.bounds)
    if case.must_reject:
        return Outcome(case, "silently accepted", f"imported, bounds {bounds}")
    want = _CROPPED if d["cropped"] else _UNCROPPED
    if not np.allclose(bounds, want):
        return Outcome(case, "silently accepted", f"bounds {bounds}, expected {want} "
                       f"({'cropped' if d['cropped'] else 'not cropped'})")
    return Outcome(case, "accepted and solved", f"bounds {bounds}")


#: the .scen family's map: 6 x 4 cells, a wall cell at (2, 1) (column, row from the top)
_SCEN_MAP = "type octile\nheight 4\nwidth 6\nmap\n......\n..@...\n......\n......\n"
_SCEN_LINE = "0\tm.map\t6\t4\t{sx}\t{sy}\t{gx}\t{gy}\t{opt}"


def _scen(*lines: str, version: str | None = "version 1") -> str:
    return "".join(f"{ln}\n" for ln in ([version] if version else []) + list(lines))


def _scen_variants() -> list[tuple[str, bytes, bytes, tuple[str, ...], bool, int]]:
    """(what, .scen bytes, .map bytes, keys, must it be rejected, lines when accepted)."""
    ln = _SCEN_LINE.format(sx=0, sy=0, gx=5, gy=3, opt="6.24264069")
    ln2 = _SCEN_LINE.format(sx=1, sy=3, gx=4, gy=0, opt="4.24264069")
    mp = _SCEN_MAP.encode()
    out: list[tuple[str, bytes, bytes, tuple[str, ...], bool, int]] = [
        ("intact", _scen(ln, ln2).encode(), mp, (), False, 2),
        ("version 1.0", _scen(ln, version="version 1.0").encode(), mp, (), False, 1),
        ("no version line", _scen(ln, version=None).encode(), mp, (), False, 1),
        ("UTF-8 BOM", b"\xef\xbb\xbf" + _scen(ln).encode(), mp, (), False, 1),
        ("UTF-8 BOM in the map", _scen(ln).encode(), b"\xef\xbb\xbf" + mp, (), False, 1),
        ("CRLF", _scen(ln, ln2).replace("\n", "\r\n").encode(), mp, (), False, 2),
        ("blank lines", ("\n" + _scen(ln, "", ln2) + "\n\n").encode(), mp, (), False, 2),
        ("trailing blanks", _scen(ln + " \t ").encode(), mp, (), False, 1),
        ("spaces, no tabs", _scen(ln.replace("\t", " ")).encode(), mp, (), False, 1)]

    def bad(what: str, text: str | bytes, keys: tuple[str, ...], m: bytes = mp) -> None:
        out.append((what, text if isinstance(text, bytes) else text.encode(), m, keys, True, 0))

    for v in ("version 2", "version 1 extra", "version", "version 0.9", "version x",
              "VERSION 3"):
        bad(v, _scen(ln, version=v), ("line 1",))
    bad("trailing text", _scen(ln + "\tfrom a paper"), ("line 2",))
    bad("trailing text after a blank", _scen(ln + " extra"), ("line 2",))
    bad("8 fields", _scen(ln.rsplit("\t", 1)[0]), ("line 2",))
    bad("10 fields", _scen(ln + "\t7"), ("line 2",))
    for field, sub in (("width", "six"), ("start_x", "1.5"), ("opt", "abc")):
        bad(f"{field} not a number", _scen(ln.replace("\t6\t" if field == "width" else
                                                      "\t0\t0\t" if field == "start_x" else
                                                      "6.24264069",
                                                      f"\t{sub}\t" if field == "width" else
                                                      f"\t{sub}\t0\t" if field == "start_x"
                                                      else sub, 1)), ("line 2",))
    for what, kw in (("width 0", {"w": 0}), ("height -1", {"h": -1}),
                     ("start x = width", {"sx": 6}), ("goal y -1", {"gy": -1}),
                     ("start on the wall", {"sx": 2, "sy": 1}),
                     ("map size differs", {"w": 7}), ("optimal nan", {"opt": "nan"}),
                     ("optimal inf", {"opt": "inf"}), ("optimal -1", {"opt": "-1"}),
                     ("optimal 1e400", {"opt": "1e400"})):
        f = {"sx": 0, "sy": 0, "gx": 5, "gy": 3, "opt": "6.24264069", "w": 6, "h": 4, **kw}
        line = f"0\tm.map\t{f['w']}\t{f['h']}\t{f['sx']}\t{f['sy']}\t{f['gx']}\t{f['gy']}" \
               f"\t{f['opt']}"
        bad(what, _scen(line), ("line 2",))
    bad("two maps", _scen(ln, ln2.replace("m.map", "other.map")), ("line 3",))
    bad("missing map", _scen(ln.replace("m.map", "nope.map")), ("map",))
    bad("not UTF-8", b"version 1\n\xff\xfe" + ln.encode(), ("not UTF-8",))
    bad("empty file", "", ("<file>",))
    bad("version line only", _scen(), ("<file>",))
    bad("binary", b"\x00\x01\x02" * 20, ("line 1", "not UTF-8"))
    return out


def scen_cases() -> list[Case]:
    """MovingAI ``.scen`` files (with their ``.map``) read with
    :func:`optplan.maps.read_scen`."""
    return [Case("scen", f"scen/{k + 1:04d}/{what}", what,
                 {"files": {"m.scen": text, "m.map": mp}, "lines": n}, keys, must)
            for k, (what, text, mp, keys, must, n) in enumerate(_scen_variants())]


def run_scen(case: Case, tmp: Path) -> Outcome:
    from optplan.maps import read_scen

    for name, content in case.data["files"].items():
        (tmp / name).write_bytes(content)
    path = tmp / "m.scen"
    try:
        probs = read_scen(path)
    except Exception as e:  # noqa: BLE001
        return Outcome(case, *_classify_error(e, case, str(path)))
    if case.must_reject or len(probs) != case.data["lines"]:
        return Outcome(case, "silently accepted", f"{len(probs)} problems")
    return Outcome(case, "accepted and solved", f"{len(probs)} problems")


def arena_cases() -> list[Case]:
    """``export_arena`` (and ``optplan export-arena``) of results databases with damaged rows,
    without runs, and onto bad destinations; an export must load as an OMPL database with
    every run, and nothing (no ``.tmp``) may be left behind by a failed one."""
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-arena-"))
    out: list[Case] = []

    def add(what: str, db: bytes | None, keys: tuple[str, ...], must: bool,
            dest: str = "new", names: str = "db", runs: int = 3) -> None:
        out.append(Case("arena", f"arena/{len(out) + 1:04d}/{what}", what,
                        {"bytes": db, "dest": dest, "names": names, "runs": runs}, keys, must))

    try:
        good = _db_bytes(tmp)
        add("intact", good, (), False)
        add("into a missing folder", good, (), False, dest="deep")
        add("over an existing file", good, (), False, dest="existing")
        add("no runs", _db_bytes(tmp, runs=0), ("holds no runs", "no runs to export"), True,
            runs=0)
        add("onto a directory", good, ("is a directory", "file name"), True, dest="dir",
            names="out")
        add("onto itself", good, ("would replace the results database",), True, dest="same",
            names="out")
        add("missing database", None, ("no such results database",), True)
        add("a text file", b"not a database\n" * 40, ("not an optplan results database",), True)
        for col, val in (("length", "'abc'"), ("wall_time", "'x'"), ("seed", "'s'"),
                         ("success", "'maybe'"), ("collisions", "'many'"),
                         ("config", "'not json'"), ("config", "'[1]'"),
                         ("config", "'{\"time_limit\": \"soon\"}'"), ("options", "'{'"),
                         ("length", "X'00ff'")):
            add(f"row 2 {col} = {val}", _db_bytes(tmp, lambda con, c=col, v=val: con.execute(
                f"UPDATE runs SET {c} = {v} WHERE id = 2")), ("row id 2",), True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def _arena_dest(case: Case, tmp: Path, db: Path) -> Path:
    kind = case.data["dest"]
    if kind == "dir":
        (tmp / "arena.db").mkdir()
    elif kind == "existing":
        (tmp / "arena.db").write_bytes(b"old contents")
    return {"same": db, "deep": tmp / "x" / "y" / "arena.db"}.get(kind, tmp / "arena.db")


def _arena_loads(path: Path, runs: int) -> str | None:
    """Why ``path`` is not an OMPL benchmark database with ``runs`` runs (None when it is)."""
    import sqlite3

    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        need = {"experiments", "plannerConfigs", "enums", "runs", "progress"}
        if not need <= tables:
            return f"tables {sorted(tables)}"
        n_exp = con.execute("SELECT count(*) FROM experiments").fetchone()[0]
        n_runs = con.execute("SELECT count(*) FROM runs").fetchone()[0]
    finally:
        con.close()
    return None if n_exp >= 1 and n_runs == runs else f"{n_exp} experiments, {n_runs} runs"


def run_arena(case: Case, tmp: Path) -> Outcome:
    from optplan.bench.summary import export_arena

    d = case.data
    db = tmp / "r.sqlite"
    if d["bytes"] is not None:
        db.write_bytes(d["bytes"])
    dest = _arena_dest(case, tmp, db)
    named = str(db if d["names"] == "db" else dest)
    try:
        export_arena(db, dest)
        outcome = None
    except FileNotFoundError as e:  # documented, for a missing database
        ok, why = _message_ok(str(e), case.keys, named)
        outcome = Outcome(case, "clear error" if ok else "unclear message", f"{why}: {e}")
    except Exception as e:  # noqa: BLE001
        outcome = Outcome(case, *_classify_error(e, case, named))
        if outcome.category == "clear error":
            ok, why = _cli_ok(["export-arena", str(db), str(dest)], case, named)
            if not ok:
                outcome = Outcome(case, "unclear message", why)
    left = sorted(str(p.relative_to(tmp)) for p in tmp.rglob("*.tmp"))
    if left:
        return Outcome(case, "crash", f"left behind: {left}")
    if outcome is not None:
        return outcome
    if case.must_reject:
        return Outcome(case, "silently accepted", f"exported {dest}")
    why = _arena_loads(dest, d["runs"])
    if why:
        return Outcome(case, "silently accepted", f"the export does not load: {why}")
    return Outcome(case, "accepted and solved", "exported and loaded")


RUNNERS = {"scenario": run_scenario, "option": run_option, "init": run_init,
           "result": run_result, "selftest": run_selftest, "map": run_map,
           "database": run_database, "plugin": run_plugin, "path": run_path, "crop": run_crop,
           "scen": run_scen, "arena": run_arena}


def run_case(case: Case, tmp: Path) -> Outcome:
    import warnings

    t0 = time.perf_counter()
    sub = tmp / f"c{abs(hash(case.id)) % 10**8}"
    sub.mkdir(parents=True, exist_ok=True)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = RUNNERS[case.family](case, sub)
    except RecursionError as e:
        out = Outcome(case, "crash", f"RecursionError in the harness: {e}")
    finally:
        shutil.rmtree(sub, ignore_errors=True)
    out.seconds = time.perf_counter() - t0
    return out


# ======================================================================================
# worker processes (a case that overruns HANG_S CPU seconds or stalls is killed)
# ======================================================================================


def _send(stream, obj: Any) -> None:
    b = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    data = memoryview(struct.pack("<Q", len(b)) + b)
    while data:
        n = stream.write(data)
        data = data[n if n is not None else len(data):]
    stream.flush()


def _read_exactly(stream, n: int) -> bytes:
    buf = b""
    while len(buf) < n:
        chunk = stream.read(n - len(buf))
        if not chunk:
            raise EOFError
        buf += chunk
    return buf


def _recv(stream) -> Any:
    """One message; the parent reads an unbuffered pipe (no read-ahead hides a message from
    ``select``)."""
    (n,) = struct.unpack("<Q", _read_exactly(stream, 8))
    return pickle.loads(_read_exactly(stream, n))


def _case_to_dict(c: Case) -> dict:
    return dataclasses.asdict(c)


def _cold_key(case: Case) -> str:
    """What a case's first use in a process compiles (numba, cvxpy, IPOPT, matplotlib)."""
    return case.data.get("preset") or {"scenario": "visgraph", "result": "plot",
                                       "database": "plot"}.get(case.family, case.family)


def worker_main() -> None:
    """Serve cases on stdin/stdout (length-prefixed pickles); prints go to /dev/null."""
    try:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    except (ImportError, ValueError, OSError):
        pass
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 1000))
    proto_in = os.fdopen(os.dup(0), "rb")
    proto_out = os.fdopen(os.dup(1), "wb")
    devnull = os.open(os.devnull, os.O_RDWR)
    os.dup2(devnull, 0)
    os.dup2(devnull, 1)
    sys.stdout = open(os.devnull, "w")  # noqa: SIM115
    os.environ.setdefault("MPLBACKEND", "Agg")
    tmp = Path(tempfile.mkdtemp(prefix="optplan-fuzz-"))
    import optplan  # noqa: F401  (import once, before the first case)

    _send(proto_out, {"ready": True})
    warmed: set[str] = set()
    try:
        while True:
            try:
                msg = _recv(proto_in)
            except EOFError:
                break
            case = Case(**msg)
            key = _cold_key(case)
            _send(proto_out, {"started": True,
                              "cold": key not in warmed and case.family != "selftest"})
            warmed.add(key)
            try:
                out = run_case(case, tmp)
                reply = {"category": out.category, "detail": out.detail,
                         "seconds": out.seconds, "compared": out.compared}
            except MemoryError:
                reply = {"category": "crash", "detail": "MemoryError", "seconds": 0.0,
                         "compared": False}
            _send(proto_out, reply)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


class _Worker:
    def __init__(self, log: Path):
        self.log = open(log, "ab")  # noqa: SIM115
        env = {**os.environ, "PYTHONHASHSEED": "0", "MPLBACKEND": "Agg",
               "PYTHONWARNINGS": "ignore"}
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()),
                                      "--worker"], stdin=subprocess.PIPE, bufsize=0,
                                     stdout=subprocess.PIPE, stderr=self.log, env=env,
                                     cwd=str(ROOT))
        self.log_path = log
        self.case: Case | None = None
        self.t0 = time.monotonic()
        self.cpu0: float | None = _tree_cpu(self.proc.pid)
        self.ready = False
        self.running = False  # the case's clock runs
        self.budget = HANG_S
        self.last_cpu, self.progress_at = self.cpu0, self.t0  # the stall watch

    def start_case(self, case: Case) -> None:
        self.case, self.t0, self.running = case, time.monotonic(), False
        self.cpu0 = _tree_cpu(self.proc.pid)
        self.last_cpu, self.progress_at = self.cpu0, self.t0
        _send(self.proc.stdin, _case_to_dict(case))

    def used(self, now: float) -> tuple[float, float, float]:
        """``(CPU seconds, wall seconds, wall seconds without CPU progress)`` since the current
        case was sent (or since the worker started, before it is ready); CPU: wall where
        ``/proc`` is missing (and then no stall)."""
        wall = now - self.t0
        cpu = _tree_cpu(self.proc.pid)
        if cpu is None or self.cpu0 is None:
            return wall, wall, 0.0
        if self.last_cpu is None or cpu > self.last_cpu:
            self.last_cpu, self.progress_at = cpu, now
        return cpu - self.cpu0, wall, now - self.progress_at

    def log_tail(self) -> str:
        self.log.flush()
        try:
            return self.log_path.read_text(errors="replace")[-1500:]
        except OSError:
            return ""

    def kill(self) -> None:
        """Kill the worker and its descendants (a plugin case's child)."""
        _kill_tree(self.proc.pid)
        try:
            self.proc.wait(timeout=60)  # SIGKILLed: reaped at once (not a limit on the case)
        except (OSError, subprocess.TimeoutExpired):
            pass
        self.log.close()


class _Tally:
    """The outcomes of a fuzz run so far (and the progress callback)."""

    def __init__(self, total: int, progress: Callable[[int, int, Outcome], None] | None):
        self.results: dict[str, Outcome] = {}
        self.total = total
        self.progress = progress

    def record(self, out: Outcome) -> None:
        self.results[out.case.id] = out
        if self.progress:
            self.progress(len(self.results), self.total, out)


def _on_message(w: _Worker, msg: dict | None, tally: _Tally, hang_s: float) -> bool:
    """Handle one message of worker ``w``; ``True`` when the worker died and must be
    replaced (a case it was running is a crash)."""
    if msg is None:
        if not w.ready:
            raise RuntimeError(f"a fuzz worker exited before it was ready (exit "
                               f"{w.proc.wait()}); its log {w.log_path}:\n{w.log_tail()}")
        if w.case is not None:
            tally.record(Outcome(w.case, "crash", f"worker died (exit {w.proc.poll()})",
                                 time.monotonic() - w.t0))
        return True
    if "ready" in msg:
        w.ready = True
    elif "started" in msg:
        w.running = True
        w.budget = hang_s + (COLD_S if msg.get("cold") else 0.0)
    else:
        tally.record(Outcome(w.case, msg["category"], msg["detail"], msg["seconds"],
                             compared=msg["compared"]))
        w.case = None
    return False


def _check_hangs(pool: list[_Worker], tally: _Tally, hang_s: float, log_dir: Path,
                 stall_s: float = STALL_S, startup_cpu_s: float = STARTUP_CPU_S) -> None:
    """A case over its CPU budget, or whose worker used no CPU for ``stall_s`` wall seconds,
    is a hang (its worker is replaced); a worker that does not become ready (it stalls, or
    uses ``startup_cpu_s`` CPU seconds first) is an error of the fuzz setup.  No wall-clock
    limit otherwise: a loaded machine only makes the wait longer."""
    now = time.monotonic()
    for w in list(pool):
        if not w.ready:
            cpu, wall, stalled = w.used(now)
            if cpu > startup_cpu_s or stalled > stall_s:
                why = (f"used {cpu:.0f} CPU s" if cpu > startup_cpu_s else
                       f"used no CPU for {stalled:.0f} s (blocked)")
                raise RuntimeError(f"a fuzz worker {why} without becoming ready ({wall:.0f} s "
                                   f"after it started); its log {w.log_path}:\n{w.log_tail()}")
            continue
        if w.case is None:
            continue
        over = w.budget if w.running else startup_cpu_s  # sent, not yet started: the import
        cpu, wall, stalled = w.used(now)
        if cpu > over or stalled > stall_s:
            cold = " (including a cold start)" if over > hang_s else ""
            why = (f"still running after {over:g} CPU s{cold}" if cpu > over else
                   f"blocked: its worker used no CPU for {stalled:.0f} s (a deadlock?)")
            tally.record(Outcome(w.case, "hang", f"{why} ({cpu:.1f} CPU s, {wall:.1f} wall s)",
                                 wall))
            w.case = None
            _replace(pool, w, log_dir)


def _proc_table() -> dict[int, tuple[int, int]] | None:
    """pid -> (parent pid, CPU clock ticks incl. reaped children) of every process
    (``/proc``: Linux; None elsewhere)."""
    try:
        stats = {}
        for d in os.listdir("/proc"):
            if d.isdigit():
                try:
                    with open(f"/proc/{d}/stat") as f:
                        rest = f.read().rpartition(")")[2].split()
                except OSError:
                    continue
                # fields after the name: state, ppid, ..., utime (12th), stime, cutime, cstime
                stats[int(d)] = (int(rest[1]), sum(int(x) for x in rest[11:15]))
    except OSError:
        return None
    return stats


def _tree(pid: int, stats: dict[int, tuple[int, int]]) -> list[int]:
    """``pid`` and its descendants in ``stats`` (:func:`_proc_table`)."""
    out, todo = [], [pid] if pid in stats else []
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, (pp, _) in stats.items() if pp == p]
    return out


def _tree_cpu(pid: int) -> float | None:
    """CPU seconds used so far by process ``pid`` and its descendants (``/proc``: Linux;
    None elsewhere or when ``pid`` is gone)."""
    stats = _proc_table()
    if stats is None or pid not in stats:
        return None
    return sum(stats[p][1] for p in _tree(pid, stats)) / os.sysconf("SC_CLK_TCK")


def _kill_tree(pid: int) -> None:
    """SIGKILL process ``pid`` and its descendants."""
    import signal

    for p in _tree(pid, _proc_table() or {}) or [pid]:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


def run_cases(cases: list[Case], workers: int = 2, hang_s: float = HANG_S,
              progress: Callable[[int, int, Outcome], None] | None = None,
              log_dir: Path | None = None, stall_s: float = STALL_S,
              startup_cpu_s: float = STARTUP_CPU_S) -> list[Outcome]:
    """Run every case in ``workers`` worker processes; a case running longer than
    ``hang_s`` CPU seconds, or whose worker used no CPU for ``stall_s`` wall seconds, is a
    hang (its worker is killed and replaced).  A worker has no start-up deadline: it is
    used once it says it is ready (:func:`_check_hangs` catches one that never will)."""
    log_dir = Path(log_dir or tempfile.mkdtemp(prefix="optplan-fuzz-logs-"))
    log_dir.mkdir(parents=True, exist_ok=True)
    todo = list(reversed(cases))
    tally = _Tally(len(cases), progress)
    pool = [_Worker(log_dir / f"worker{i}.log") for i in range(max(1, workers))]
    try:
        while len(tally.results) < len(cases):
            for w in pool:
                if w.ready and w.case is None and todo:
                    w.start_case(todo.pop())
            fds = {w.proc.stdout.fileno(): w for w in pool}
            ready, _, _ = select.select(list(fds), [], [], 0.2)
            for fd in ready:
                w = fds[fd]
                try:
                    msg = _recv(w.proc.stdout)
                except EOFError:
                    msg = None
                if _on_message(w, msg, tally, hang_s):
                    _replace(pool, w, log_dir)
            _check_hangs(pool, tally, hang_s, log_dir, stall_s, startup_cpu_s)
    finally:
        for w in pool:
            w.kill()
    return [tally.results[c.id] for c in cases]


def _replace(pool: list[_Worker], w: _Worker, log_dir: Path) -> None:
    i = pool.index(w)
    w.kill()
    pool[i] = _Worker(log_dir / f"worker{i}.log")


# ======================================================================================
# known findings in files other engineers own (backends, solve's checks)
# ======================================================================================

#: finding id -> (where, what happens, predicate on a bad outcome).  A bad outcome a finding
#: explains is reported in the "known findings" column (and ``tests/tools/test_fuzz.py`` does
#: not count it).  Strict: an entry that explains no outcome of that test's slice is stale
#: (:func:`stale_findings`) and fails the test, so a fixed finding is removed, not kept; an entry
#: must therefore come with a case in the slice that reproduces it.  (Removed, no longer
#: reproducing: ``int-option-recompiles``, an integer value for a float swarm option compiled
#: a new numba specialisation; ``optplan.geometry.jit.OneSignature`` converts it since.)
KNOWN_FINDINGS: dict[str, tuple[str, str, Callable[[Outcome], bool]]] = {}


def stale_findings(outcomes: list[Outcome]) -> list[str]:
    """The :data:`KNOWN_FINDINGS` entries that explain none of ``outcomes`` (annotated by
    :func:`annotate`): fixed, or not reproduced by these cases."""
    return [fid for fid in KNOWN_FINDINGS if not any(o.known == fid for o in outcomes)]


def known_finding(outcome: Outcome) -> str | None:
    for fid, (_, _, pred) in KNOWN_FINDINGS.items():
        try:
            if pred(outcome):
                return fid
        except (KeyError, TypeError, AttributeError):
            continue
    return None


# ======================================================================================
# the run
# ======================================================================================


def surface_cases(seed: int = 0, families: Iterable[str] = ("path", "crop", "scen",
                                                            "arena")) -> list[Case]:
    """The ROS path message, ``crop=``, ``.scen`` and Planner Arena export families."""
    make = {"path": lambda: path_cases(seed), "crop": crop_cases, "scen": scen_cases,
            "arena": arena_cases}
    return [c for f in families for c in make[f]()]


def build_cases(seed: int = 0, n_scenarios: int = 3000, options: bool = True,
                inits: bool = True, results: bool = True,
                scenes: Iterable[str] | None = None, maps: bool = True,
                databases: bool = True, plugins: bool = True,
                surfaces: Iterable[str] = ("path", "crop", "scen", "arena")) -> list[Case]:
    cases = ScenarioFuzzer(seed).cases(n_scenarios, scenes)
    presets = preset_table() if (options or inits) else {}
    if options:
        cases += OptionFuzzer(seed).cases(presets)
    if inits:
        cases += init_cases(presets, seed)
    if results:
        cases += result_cases(seed)
    if maps:
        cases += map_cases(seed)
    if databases:
        cases += database_cases(seed)
    if plugins:
        cases += plugin_cases()
    return cases + surface_cases(seed, surfaces)


def annotate(outcomes: list[Outcome]) -> list[Outcome]:
    for o in outcomes:
        if o.category in BAD:
            o.known = known_finding(o)
    return outcomes


def counts_table(outcomes: list[Outcome]) -> str:
    fams = list(FAMILIES)
    head = ["family", "cases", *CATEGORIES, "known findings", "compared"]
    rows = []
    for fam in [*fams, "all"]:
        sel = [o for o in outcomes if fam == "all" or o.case.family == fam]
        c = Counter(o.category for o in sel)
        rows.append([fam, str(len(sel)), *(str(c[k]) for k in CATEGORIES),
                     str(sum(1 for o in sel if o.known)), str(sum(o.compared for o in sel))])
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(head, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    body = ["| " + " | ".join(v.rjust(w) if i else v.ljust(w)
                              for i, (v, w) in enumerate(zip(r, widths))) + " |"
            for r in rows]
    return "\n".join([line, sep, *body])


def failures(outcomes: list[Outcome], include_known: bool = False) -> list[Outcome]:
    return [o for o in outcomes if o.category in BAD and (include_known or not o.known)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenarios", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=max(1, min(4, os.cpu_count() or 1)))
    ap.add_argument("--family", action="append", choices=list(FAMILIES))
    ap.add_argument("--quick", action="store_true", help="300 scenarios, every family")
    ap.add_argument("--show", type=int, default=40, help="failures to list (default 40)")
    ap.add_argument("--json", help="write every outcome to this JSON file")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker_main()
        return 0
    fam = set(args.family or FAMILIES)
    n_sc = 300 if args.quick else args.scenarios
    t0 = time.perf_counter()
    cases = build_cases(args.seed, n_sc if "scenario" in fam else 0, "option" in fam,
                        "init" in fam, "result" in fam, maps="map" in fam,
                        databases="database" in fam, plugins="plugin" in fam,
                        surfaces=[f for f in ("path", "crop", "scen", "arena") if f in fam])
    print(f"{len(cases)} cases ({time.perf_counter() - t0:.1f} s to generate); "
          f"{args.workers} workers, hang limit {HANG_S:g} CPU s", file=sys.stderr)
    last = [0.0]

    def prog(done: int, total: int, out: Outcome) -> None:
        now = time.perf_counter()
        if out.category in BAD or now - last[0] > 10 or done == total:
            last[0] = now
            mark = "" if out.category not in BAD else f"  {out.category}: {out.case.id}"
            print(f"[{done}/{total}] {now - t0:.0f} s{mark}", file=sys.stderr)

    outcomes = annotate(run_cases(cases, args.workers, progress=prog))
    print(counts_table(outcomes))
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")
    bad = failures(outcomes, include_known=True)
    if bad:
        print(f"\n{len(bad)} bad outcomes (first {args.show}):")
        for o in bad[: args.show]:
            tag = f" [known: {o.known}]" if o.known else ""
            print(f"- {o.category}{tag}: {o.case.id} ({o.case.what}; "
                  f"{o.case.data.get('note', '')}): {o.detail[:400]}")
    if args.json:
        Path(args.json).write_text(json.dumps([
            {"id": o.case.id, "family": o.case.family, "what": o.case.what,
             "note": o.case.data.get("note", ""), "category": o.category, "detail": o.detail,
             "seconds": round(o.seconds, 3), "known": o.known} for o in outcomes], indent=1))
    stale = stale_findings(outcomes)
    if stale and fam == set(FAMILIES) and n_sc >= 3000:  # the full run: every case was tried
        print(f"\nKNOWN_FINDINGS entries no outcome reproduced (fixed? remove them): {stale}")
    return 0 if not failures(outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
