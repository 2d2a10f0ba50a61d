"""Parsing of the scenario's static and moving obstacles (``[[obstacles]]``,
``[[dynamic_obstacles]]``; problems/README.md).

The parsers share their parameters' names: ``ctx`` the parsing context (file name, error
messages), ``o`` the table (its keys checked once its type is known), ``i`` its index in its
list, ``pre`` the key prefix (``obstacles[i].``, ``dynamic_obstacles[i].``), ``kind`` its
checked type, ``known`` whether it is on the known map, ``name`` its name, ``frame`` the map's
frame (extents and speeds are checked against it), ``wps`` a moving obstacle's waypoints and
``vmax`` the largest speed allowed.
"""

from __future__ import annotations

import difflib
from typing import Any

import numpy as np
from shapely.geometry import Point

from optplan.problem.context import _DYN_TYPE_KEYS, _OBST_KEYS, _Ctx
from optplan.problem.model import (
    CIRCLE_QUAD_SEGS,
    MAX_REL_SPEED,
    MAX_TIME,
    DynamicObstacle,
    Obstacle,
    _show,
)


def _parse_obstacle(ctx: _Ctx, o: Any, i: int) -> Obstacle:
    """One ``[[obstacles]]`` table. Returns a circle, rectangle or polygon obstacle."""
    pre = f"obstacles[{i}]."
    kind = _obstacle_kind(ctx, o, i, pre)
    ctx.check_keys(o, _OBST_KEYS[kind], pre)
    known = o.get("known", True)
    if not isinstance(known, bool):
        raise ctx.err(f"{pre}known", f"expected true or false, got {_show(known)}")
    name = ctx.string(o, "name", pre, f"obstacle{i}")
    if kind == "circle":
        return _parse_circle(ctx, o, pre, known, name)
    if kind == "rectangle":
        return _parse_rectangle(ctx, o, pre, known, name)
    return _parse_polygon(ctx, o, pre, known, name)


def _obstacle_kind(ctx: _Ctx, o: Any, i: int, pre: str) -> str:
    """The checked ``type`` of obstacle ``i`` (the table itself checked first). Returns one of
    the keys of ``_OBST_KEYS``."""
    if not isinstance(o, dict):
        raise ctx.err(f"obstacles[{i}]", f"expected a table, got {_show(o)}")
    kind = ctx.require(o, "type", pre)
    if not isinstance(kind, str):
        raise ctx.err(f"{pre}type", f"expected a string ({', '.join(map(repr, _OBST_KEYS))}), "
                                    f"got {_show(kind)}")
    if kind not in _OBST_KEYS:
        close = difflib.get_close_matches(kind, list(_OBST_KEYS), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ctx.err(f"{pre}type", f"unknown obstacle type {_show(kind)}{hint} "
                      f"(allowed: {', '.join(_OBST_KEYS)})")
    return kind


def _parse_circle(ctx: _Ctx, o: dict, pre: str, known: bool, name: str) -> Obstacle:
    """A circle obstacle: ``center`` and ``radius``."""
    c = ctx.point(ctx.require(o, "center", pre), f"{pre}center", coord=True)
    r = ctx.number(ctx.require(o, "radius", pre), f"{pre}radius", positive=True, coord=True)
    return Obstacle("circle", None, known, name, center=c, radius=r)


def _parse_rectangle(ctx: _Ctx, o: dict, pre: str, known: bool, name: str) -> Obstacle:
    """A rectangle obstacle: ``min``/``max`` or ``center``/``size``, not both."""
    if ("min" in o or "max" in o) and ("center" in o or "size" in o):
        raise ctx.err(f"{pre}center", "give either min/max or center/size, not both")
    if "min" in o or "max" in o:
        key = f"{pre}min"
        lo, hi = _rectangle_min_max(ctx, o, pre)
    else:
        key = f"{pre}center"
        lo, hi = _rectangle_center_size(ctx, o, pre)
    verts = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    return Obstacle("rectangle", ctx.polygon(verts, key), known, name)


def _rectangle_min_max(ctx: _Ctx, o: dict, pre: str) -> tuple[np.ndarray, np.ndarray]:
    """The corners of a rectangle given by ``min`` and ``max``. Returns ``(lo, hi)``,
    with ``lo < hi`` in both axes."""
    lo = ctx.point(ctx.require(o, "min", pre), f"{pre}min", coord=True)
    hi = ctx.point(ctx.require(o, "max", pre), f"{pre}max", coord=True)
    if np.any(hi <= lo):
        raise ctx.err(f"{pre}max", "rectangle needs min < max in both axes, got "
                      f"{lo.tolist()} {hi.tolist()}")
    return lo, hi


def _rectangle_center_size(ctx: _Ctx, o: dict, pre: str) -> tuple[np.ndarray, np.ndarray]:
    """The corners of a rectangle given by ``center`` and ``size``. Returns
    ``(lo, hi)``, with ``lo < hi`` in both axes."""
    c = ctx.point(ctx.require(o, "center", pre), f"{pre}center", coord=True)
    s = ctx.point(ctx.require(o, "size", pre), f"{pre}size", coord=True)
    lo, hi = c - s / 2, c + s / 2
    if np.any(hi <= lo):
        raise ctx.err(f"{pre}size", f"rectangle needs a size > 0 in both axes (that "
                      f"double precision resolves at its centre), got {s.tolist()}")
    return lo, hi


def _parse_polygon(ctx: _Ctx, o: dict, pre: str, known: bool, name: str) -> Obstacle:
    """A polygon obstacle: ``vertices`` and optional ``holes``."""
    verts = ctx.points(ctx.require(o, "vertices", pre), f"{pre}vertices", 3, coord=True)
    holes = None
    if "holes" in o:
        raw = o["holes"]
        if not isinstance(raw, list):
            raise ctx.err(f"{pre}holes", f"expected a list of rings [[[x, y], ...], ...], got "
                                         f"{_show(raw)}")
        holes = [ctx.points(h, f"{pre}holes[{k}]", 3, coord=True) for k, h in enumerate(raw)]
    poly = ctx.polygon(verts, f"{pre}vertices", holes, f"{pre}holes")
    return Obstacle("polygon", poly, known, name)


def _extent_key(o: dict, i: int) -> str:
    """The key named when obstacle ``i`` has coordinates the map's frame cannot resolve."""
    pre = f"obstacles[{i}]."
    kind = o.get("type")
    if kind == "circle":
        return pre + "center"
    if kind == "rectangle":
        return pre + ("min" if "min" in o else "center")
    return pre + "vertices"


def _check_extent(ctx: _Ctx, frame, o: Obstacle, key: str, margin: float) -> None:
    """Reject an obstacle reaching into the working region (bounds grown by ``margin``) with
    coordinates beyond :meth:`~optplan.geometry.Frame.check_extent`; the same region and extent
    as :func:`optplan.geometry.clip_obstacles` (obstacles outside it are ignored there)."""
    x0, y0, x1, y1 = frame.local_bounds
    lo = np.array([x0 - margin, y0 - margin])
    hi = np.array([x1 + margin, y1 + margin])
    if o.is_circle:
        center, radius = o.disc()
        c = frame.local(center)
        R = float(radius)
        if np.any(c + R < lo) or np.any(c - R > hi):
            return
        extent = float(np.max(np.abs(c))) + R
    else:
        wx0, wy0, wx1, wy1 = o.polygon().bounds
        blo, bhi = frame.local([wx0, wy0]), frame.local([wx1, wy1])
        if np.any(bhi < lo) or np.any(blo > hi):
            return
        extent = float(max(np.max(np.abs(blo)), np.max(np.abs(bhi))))
    try:
        frame.check_extent(extent, f"obstacle {o.name!r}")
    except ValueError as e:
        raise ctx.err(key, str(e)) from None


def _parse_dynamic(ctx: _Ctx, o: Any, i: int, frame: Any) -> DynamicObstacle:
    """One ``[[dynamic_obstacles]]`` table."""
    pre = f"dynamic_obstacles[{i}]."
    kind = _dynamic_kind(ctx, o, i, pre)
    ctx.check_keys(o, _DYN_TYPE_KEYS[kind], pre)
    radius, local, size = _dynamic_shape(ctx, o, kind, pre)
    name = ctx.string(o, "name", pre, f"dynamic{i}")
    # the shape and every waypoint must be resolvable in the map's frame (moving obstacles are
    # compared with robots in relative coordinates; one far away has no business in the map)
    _check_dynamic_size(ctx, frame, f"{pre}{'radius' if radius is not None else 'vertices'}",
                        name, size)
    wps = _dynamic_waypoints(ctx, o, frame, pre, name, size)
    vmax = MAX_REL_SPEED * frame.length
    velocity = None
    if "velocity" in o:
        velocity, times = _velocity_schedule(ctx, o, pre, wps, vmax)
    else:
        times = _timed_schedule(ctx, o, pre, wps, vmax)
    after = o.get("after", "hold")
    if not isinstance(after, str) or after not in ("hold", "loop", "bounce"):
        raise ctx.err(f"{pre}after", f"expected 'hold', 'loop' or 'bounce', got {_show(after)}")
    return DynamicObstacle(kind, local, times, wps, velocity, after, name, radius)


def _dynamic_kind(ctx: _Ctx, o: Any, i: int, pre: str) -> str:
    """The checked ``type`` of dynamic obstacle ``i`` (the table itself checked first). Returns
    ``"circle"`` or ``"polygon"``."""
    if not isinstance(o, dict):
        raise ctx.err(f"dynamic_obstacles[{i}]", f"expected a table, got {_show(o)}")
    kind = ctx.require(o, "type", pre)
    if not isinstance(kind, str) or kind not in _DYN_TYPE_KEYS:
        raise ctx.err(f"{pre}type", f"dynamic obstacles are 'circle' or 'polygon', got "
                                    f"{_show(kind)}")
    return kind


def _dynamic_shape(ctx: _Ctx, o: dict, kind: str,
                   pre: str) -> tuple[float | None, Any, float]:
    """The shape of a dynamic obstacle in its own frame. Returns ``(radius, local, size)``: the
    radius (None for a polygon), the shapely shape centred on the origin, and the shape's extent
    about its origin (the radius, or the largest vertex coordinate in absolute value)."""
    if kind == "circle":
        radius = ctx.number(ctx.require(o, "radius", pre), f"{pre}radius", positive=True,
                            coord=True)
        return (radius, Point(0.0, 0.0).buffer(radius, quad_segs=CIRCLE_QUAD_SEGS),
                float(radius))
    verts = ctx.points(ctx.require(o, "vertices", pre), f"{pre}vertices", 3, coord=True)
    return None, ctx.polygon(verts, f"{pre}vertices"), float(np.max(np.abs(verts)))


def _check_dynamic_size(ctx: _Ctx, frame: Any, key: str, name: str, size: float) -> None:
    """Reject a moving shape the map's frame cannot resolve (``size``: its extent about its
    origin; ``key``: the entry an error names, its radius or its vertices)."""
    try:
        frame.check_extent(size, f"the shape of dynamic obstacle {name!r}")
    except ValueError as e:
        raise ctx.err(key, str(e)) from None


def _dynamic_waypoints(ctx: _Ctx, o: dict, frame: Any, pre: str, name: str,
                       size: float) -> np.ndarray:
    """The ``waypoints``, each with the shape resolvable in the map's frame (``size``: the shape's
    extent about its origin). Returns ``(W, 2)`` waypoints."""
    wps = ctx.points(ctx.require(o, "waypoints", pre), f"{pre}waypoints", 1, coord=True)
    far = np.max(np.abs(frame.local(wps)), axis=1) + size
    k = int(np.argmax(far))
    try:
        frame.check_extent(float(far[k]), f"dynamic obstacle {name!r} at this waypoint")
    except ValueError as e:
        raise ctx.err(f"{pre}waypoints[{k}]", str(e)) from None
    return wps


def _velocity_schedule(ctx: _Ctx, o: dict, pre: str, wps: np.ndarray,
                       vmax: float) -> tuple[np.ndarray, np.ndarray]:
    """A constant-velocity motion: ``velocity``, one start waypoint and one start time. Returns
    ``(velocity, times)``."""
    velocity = ctx.point(o["velocity"], f"{pre}velocity", coord=True)
    if float(np.hypot(*velocity)) > vmax:
        raise ctx.err(f"{pre}velocity", f"speed {float(np.hypot(*velocity)):.6g} is above "
                      f"{vmax:.6g} ({MAX_REL_SPEED:g} x the bounds diagonal per second)")
    if len(wps) != 1:
        raise ctx.err(f"{pre}waypoints", "with 'velocity' give exactly one start waypoint")
    raw_t = o.get("times", [0.0])
    if not isinstance(raw_t, list) or len(raw_t) != 1:
        raise ctx.err(f"{pre}times", "with 'velocity' give one start time, e.g. times = [0.0]")
    return velocity, np.array([_time(ctx, raw_t[0], f"{pre}times[0]")])


def _timed_schedule(ctx: _Ctx, o: dict, pre: str, wps: np.ndarray, vmax: float) -> np.ndarray:
    """The ``times`` of a waypoint motion: one per waypoint, increasing, speeds at most ``vmax``.
    Returns the time stamps."""
    raw_t = ctx.require(o, "times", pre)
    if not isinstance(raw_t, list) or len(raw_t) != len(wps):
        got = f"{len(raw_t)}" if isinstance(raw_t, list) else _show(raw_t)
        raise ctx.err(f"{pre}times", f"expected {len(wps)} time stamps (one per waypoint), "
                                     f"got {got}")
    times = np.array([_time(ctx, t, f"{pre}times[{k}]") for k, t in enumerate(raw_t)])
    if np.any(np.diff(times) <= 0):
        raise ctx.err(f"{pre}times", "time stamps must be strictly increasing")
    if len(wps) > 1:
        _check_leg_speeds(ctx, pre, wps, times, vmax)
    return times


def _check_leg_speeds(ctx: _Ctx, pre: str, wps: np.ndarray, times: np.ndarray,
                      vmax: float) -> None:
    """Reject a leg between consecutive waypoints faster than ``vmax`` (``times``: their strictly
    increasing time stamps)."""
    step = np.hypot(*np.diff(wps, axis=0).T)
    with np.errstate(over="ignore", divide="ignore"):
        speed = step / np.diff(times)
    k = int(np.argmax(speed))
    if not speed[k] <= vmax:
        raise ctx.err(f"{pre}times", f"waypoints {k} -> {k + 1} imply a speed of "
                      f"{speed[k]:.6g}, above {vmax:.6g} ({MAX_REL_SPEED:g} x the bounds "
                      "diagonal per second)")


def _time(ctx: _Ctx, v: Any, key: str) -> float:
    t = ctx.number(v, key)
    if abs(t) > MAX_TIME:
        raise ctx.err(key, f"magnitude {abs(t):.3g} s is beyond {MAX_TIME:g} s")
    return t
