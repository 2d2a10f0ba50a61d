"""The parsing context of the scenario format: its keys, and values checked with errors that
name the file and the key (:class:`ProblemError`)."""

from __future__ import annotations

import difflib
import math
from typing import Any

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Polygon

from optplan.problem.model import CLOSE_REL, MAX_COORD, MAX_POINTS, ProblemError, _show

# --------------------------------------------------------------------------------------
# parsing
# --------------------------------------------------------------------------------------

_TOP_KEYS = {
    "name": "str",
    "description": "str",
    "source": "str",
    "tags": "list",
    "bounds": "list",
    "goal_tolerance": "float",
    "length_scale": "float",
    "robots": "array of tables",
    "obstacles": "array of tables",
    "dynamic_obstacles": "array of tables",
    "formation": "table",
    "sensing": "table",
    "roadmap": "table",
}
_ROBOT_KEYS = {"id", "start", "goal", "radius", "max_speed"}
_OBST_KEYS = {
    "polygon": {"type", "vertices", "holes", "known", "name"},
    "rectangle": {"type", "min", "max", "center", "size", "known", "name"},
    "circle": {"type", "center", "radius", "known", "name"},
}
_DYN_KEYS = {"type", "radius", "vertices", "waypoints", "times", "velocity", "after", "name"}
_DYN_TYPE_KEYS = {"circle": _DYN_KEYS - {"vertices"}, "polygon": _DYN_KEYS - {"radius"}}
_FORM_KEYS = {"leader", "followers", "safety_distance"}
_FOLL_KEYS = {"id", "L", "phi"}
_SENS_KEYS = {"range"}
_ROADMAP_KEYS = {"nodes", "edges"}



def _plain_points(v: list, coord: bool) -> np.ndarray | None:
    """``v`` as an ``(n, 2)`` float array when every item is a list of two ints or floats
    (not bools) that the point checks accept (finite; within :data:`MAX_COORD` when
    ``coord``), converted at once; None otherwise (the point-by-point checks then name the
    first offending value).  A map's polygons have tens of thousands of vertices."""
    for p in v:
        if type(p) is not list or len(p) != 2:
            return None
        ta, tb = type(p[0]), type(p[1])
        if (ta is not float and ta is not int) or (tb is not float and tb is not int):
            return None
    try:
        arr = np.array(v, dtype=float).reshape(-1, 2)
    except OverflowError:  # an integer beyond the double range
        return None
    if not np.isfinite(arr).all() or (coord and bool((np.abs(arr) > MAX_COORD).any())):
        return None
    return arr

class _Ctx:
    """Carries the file name for error messages."""

    def __init__(self, where: str):
        self.where = where
        self.n_points = 0

    def err(self, key: str, msg: str) -> ProblemError:
        return ProblemError(f"{self.where}: {key}: {msg}")

    def check_keys(self, table: dict, allowed: set[str] | dict, prefix: str) -> None:
        for k in table:
            if k not in allowed:
                close = difflib.get_close_matches(k, list(allowed), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise self.err(
                    f"{prefix}{k}",
                    f"unknown key{hint} (allowed: {', '.join(sorted(allowed))})",
                )

    def require(self, table: dict, key: str, prefix: str) -> Any:
        if key not in table:
            raise self.err(f"{prefix}{key}", "missing required key")
        return table[key]

    def number(self, v: Any, key: str, *, positive: bool = False, nonneg: bool = False,
               coord: bool = False, hi: float | None = None, hi_what: str = "") -> float:
        """A finite number; ``positive`` (> 0), ``nonneg`` (>= 0), ``coord`` (magnitude at
        most :data:`MAX_COORD`) and ``hi`` (at most ``hi``, described by ``hi_what``)."""
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(key, f"expected a number, got {_show(v)}")
        try:
            x = float(v)
        except OverflowError:  # a TOML integer beyond the double range
            raise self.err(key, f"must be finite, got an integer of {len(str(abs(v)))} "
                                "digits") from None
        if not math.isfinite(x):
            raise self.err(key, f"must be finite, got {v!r}")
        if positive and x <= 0:
            raise self.err(key, f"must be > 0, got {v!r}")
        if nonneg and x < 0:
            raise self.err(key, f"must be >= 0, got {v!r}")
        if coord and abs(x) > MAX_COORD:
            raise self.err(key, f"magnitude {abs(x):.3g} is beyond {MAX_COORD:g}: double "
                                "precision cannot compute distances with it (its square "
                                "overflows)")
        if hi is not None and x > hi:
            raise self.err(key, f"must be <= {hi:.6g} ({hi_what}), got {x:.6g}")
        return x

    def string(self, table: dict, key: str, prefix: str, default: str | None = None) -> str:
        """A string value (``default`` when absent; required when ``default`` is None)."""
        v = self.require(table, key, prefix) if default is None else table.get(key, default)
        if not isinstance(v, str):
            raise self.err(f"{prefix}{key}", f"expected a string, got {_show(v)}")
        return v

    def point(self, v: Any, key: str, coord: bool = False) -> np.ndarray:
        if not isinstance(v, list) or len(v) != 2:
            raise self.err(key, f"expected a point [x, y], got {_show(v)}")
        return np.array([self.number(v[0], f"{key}[0]", coord=coord),
                         self.number(v[1], f"{key}[1]", coord=coord)])

    def points(self, v: Any, key: str, min_len: int, coord: bool = False) -> np.ndarray:
        if not isinstance(v, list) or len(v) < min_len:
            got = f"{len(v)} point(s)" if isinstance(v, list) else _show(v)
            raise self.err(key, f"expected a list of at least {min_len} points [x, y], "
                                f"got {got}")
        self.n_points += len(v)
        if self.n_points > MAX_POINTS:
            raise self.err(key, f"too many points: the scenario's vertices and waypoints "
                                f"exceed {MAX_POINTS} in all")
        plain = _plain_points(v, coord)
        if plain is not None:
            return plain
        return np.array([self.point(p, f"{key}[{i}]", coord) for i, p in enumerate(v)])

    def ring(self, verts: np.ndarray, key: str, what: str = "polygon") -> Polygon:
        """A simple polygon of ``verts`` (no holes), every distinct vertex kept.

        Dropped: a closing vertex that repeats the first one (exactly, or within
        :data:`CLOSE_REL` ``x`` the ring's own size) and exact consecutive repeats (zero-length
        edges carry no geometry).  Rejected: fewer than 3 distinct vertices, a
        self-intersecting or otherwise invalid ring, zero area (relative:
        ``area <= CLOSE_REL x size^2``).
        """
        verts = np.asarray(verts, dtype=float).reshape(-1, 2)
        if len(verts) >= 2:
            size = float(np.hypot(*np.ptp(verts, axis=0)))
            gap = float(np.hypot(*(verts[-1] - verts[0])))
            if gap == 0.0 or gap <= CLOSE_REL * size:
                verts = verts[:-1]
        if len(verts) > 1:
            verts = verts[np.any(verts != np.roll(verts, 1, axis=0), axis=1)]
        if len(verts) < 3:
            raise self.err(key, f"a {what} needs at least 3 distinct vertices "
                                f"(consecutive repeats count once)")
        poly = Polygon(verts)
        if not poly.is_valid:
            reason = shapely.is_valid_reason(poly)
            raise self.err(key, f"{what} is degenerate or self-intersecting ({reason})")
        size = float(np.hypot(*np.ptp(verts, axis=0)))
        if not poly.area > CLOSE_REL * size * size:
            raise self.err(key, f"{what} has zero area (its vertices are collinear up to "
                                f"{CLOSE_REL:g} x its size)")
        return poly

    def polygon(self, verts: np.ndarray, key: str, holes: list | None = None,
                holes_key: str = "") -> Polygon:
        """:meth:`ring` plus optional holes (each a ring inside the outer one); CCW oriented."""
        shell = self.ring(verts, key)
        if not holes:
            return shapely.geometry.polygon.orient(shell, 1.0)
        rings = []
        for k, h in enumerate(holes):
            hk = f"{holes_key}[{k}]"
            hp = self.ring(h, hk, "hole")
            if not shell.contains(hp):
                raise self.err(hk, "the hole is not inside the outer ring (vertices)")
            rings.append(np.asarray(hp.exterior.coords))
        poly = Polygon(np.asarray(shell.exterior.coords), rings)
        if not poly.is_valid:
            reason = shapely.is_valid_reason(poly)
            raise self.err(holes_key, f"holes overlap each other or cut the outer ring "
                                      f"({reason})")
        if not poly.area > 0:
            raise self.err(holes_key, "the holes leave no area")
        return shapely.geometry.polygon.orient(poly, 1.0)
