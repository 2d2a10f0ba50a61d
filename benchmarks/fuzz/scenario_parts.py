"""Mutators of a scene's parts (obstacles, starts and goals, bounds, robots, dynamic
obstacles, the formation): :class:`PartMutators`, a base of
:class:`benchmarks.fuzz.scenarios.ScenarioFuzzer`, with the helpers every mutator uses."""

from __future__ import annotations

import copy
import math
import random
from collections.abc import Callable, Iterable
from typing import Any

from benchmarks.fuzz.core import Case
from benchmarks.fuzz.values import _leaves, _robot_points, toml_dumps


class MutatorBase:
    """The helpers of the scenario mutators (``self.rng``, ``self.n``: set by
    :class:`~benchmarks.fuzz.scenarios.ScenarioFuzzer`)."""

    rng: random.Random
    n: int

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


class PartMutators(MutatorBase):
    """Mutators of the scene's parts (each returns a case, or None when it does not apply)."""

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
