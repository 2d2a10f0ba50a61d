"""The **scenario** family: mutations of the catalogue's TOML scenes (:class:`ScenarioFuzzer`)
and their runner (load, ``optplan show`` on a rejection, a ``visgraph`` solve checked against
the independent shapely check on an acceptance)."""

from __future__ import annotations

import copy
import math
import random
import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error, _cli_ok, _compare, _prepare
from benchmarks.fuzz.core import PROBLEMS, SOLVE_TIME_LIMIT, Case, Outcome
from benchmarks.fuzz.scenario_parts import PartMutators
from benchmarks.fuzz.values import (
    BAD_NUMBERS,
    ODD_NUMBERS,
    WRONG_TYPES,
    _del,
    _is_number,
    _leaves,
    _nested_text,
    _owner_keys,
    _robot_points,
    _set,
    _toml_key,
    catalogue,
    nested,
    outside_range,
)


class ScenarioFuzzer(PartMutators):
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
