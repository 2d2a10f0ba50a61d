"""ROS messages as plain dicts, without ROS: a timed path as ``nav_msgs/Path`` (out), an
occupancy grid as ``nav_msgs/OccupancyGrid`` (in and out).

The dicts have the fields of the ROS 2 messages (``rosidl_runtime_py``'s
``message_to_ordereddict`` / ``set_message_fields`` shape, and what ``ros2 topic pub`` reads
as YAML); times are ``builtin_interfaces/Time`` ``{"sec", "nanosec"}``.  No ROS package is
imported.  ``docs/maps.md`` ("ROS messages") has the field-by-field description.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from optplan.maps.checks import MAX_CELLS, check_cells, check_extent, err, is_real, number
from optplan.maps.grid import FREE, OCCUPIED, UNKNOWN, Grid
from optplan.maps.occupancy import _thresholds, classify

#: Largest stamp a ``builtin_interfaces/Time`` holds (``sec`` is an int32).
MAX_STAMP = 2.0**31 - 1.0
#: ``nav_msgs/OccupancyGrid`` cell values: unknown, free .. occupied (percent)
GRID_UNKNOWN, GRID_FREE, GRID_OCCUPIED = -1, 0, 100

_GRID_KEYS = ("header", "info", "data")
_INFO_KEYS = ("map_load_time", "resolution", "width", "height", "origin")


class TimedPath(NamedTuple):
    """A ``nav_msgs/Path`` read back (:func:`read_path_msg`)."""

    frame_id: str
    points: np.ndarray
    """``(n, 2)`` positions."""
    times: np.ndarray
    """``(n,)`` stamps, seconds."""
    yaw: np.ndarray
    """``(n,)`` headings, radians in ``(-pi, pi]``."""


# -- small pieces ------------------------------------------------------------------------


def stamp_msg(t: float) -> dict[str, int]:
    """``builtin_interfaces/Time`` of ``t`` seconds (``0 <= t <= MAX_STAMP``), to the
    nanosecond."""
    ns = round(float(t) * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def quaternion_msg(yaw: float) -> dict[str, float]:
    """``geometry_msgs/Quaternion`` of a rotation by ``yaw`` about the z axis."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * yaw), "w": math.cos(0.5 * yaw)}


def _mapping(v: Any, where: str, key: str, allowed: Sequence[str],
             required: Sequence[str]) -> Mapping[str, Any]:
    """``v`` is a mapping with the ``required`` keys and no key outside ``allowed``."""
    if not isinstance(v, Mapping):
        raise err(where, key, f"expected a mapping with the keys {', '.join(required)}, "
                              f"got {type(v).__name__}")
    for k in v:
        if k not in allowed:
            raise err(where, f"{key}.{k}" if key != "<root>" else str(k),
                      f"unknown key (allowed: {', '.join(allowed)})")
    for k in required:
        if k not in v:
            raise err(where, f"{key}.{k}" if key != "<root>" else k, "missing required key")
    return v


def _yaw(q: Any, where: str, key: str) -> float:
    """The yaw of a ``geometry_msgs/Quaternion`` that rotates about the z axis only."""
    q = _mapping(q, where, key, ("x", "y", "z", "w"), ("x", "y", "z", "w"))
    x, y, z, w = (number(q[c], where, f"{key}.{c}") for c in "xyzw")
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm == 0.0:
        raise err(where, key, "a zero quaternion is no rotation (expected a unit quaternion)")
    if max(abs(x), abs(y)) > 1e-9 * norm:
        raise err(where, key, f"only rotations about the z axis are supported (x = y = 0: a "
                              f"map in the plane), got x = {x!r}, y = {y!r}")
    return 2.0 * math.atan2(z, w)


def _pose(p: Any, where: str, key: str) -> tuple[float, float, float]:
    """``(x, y, yaw)`` of a ``geometry_msgs/Pose`` in the plane (``z`` is not used)."""
    p = _mapping(p, where, key, ("position", "orientation"), ("position", "orientation"))
    pos = _mapping(p["position"], where, f"{key}.position", ("x", "y", "z"), ("x", "y"))
    x, y = (number(pos[c], where, f"{key}.position.{c}") for c in "xy")
    if "z" in pos:
        number(pos["z"], where, f"{key}.position.z")
    return x, y, _yaw(p["orientation"], where, f"{key}.orientation")


# -- nav_msgs/Path -------------------------------------------------------------------------


def headings(points: Any) -> np.ndarray:
    """Heading of each point: the direction of travel to the next point; a point the robot
    waits at (the next point is the same) and the last point keep the heading before them;
    waits before the first move take the first move's heading; 0 when it never moves."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    d = np.diff(p, axis=0)
    span = float(np.max(np.abs(p - p[0]))) if len(p) else 0.0
    moving = np.hypot(d[:, 0], d[:, 1]) > 1e-12 * span
    if not np.any(moving):
        return np.zeros(len(p))
    seg = np.where(moving, np.arctan2(d[:, 1], d[:, 0]), np.nan)
    last = np.maximum.accumulate(np.where(moving, np.arange(len(seg)), -1))
    first = int(np.argmax(moving))
    seg = seg[np.where(last < 0, first, last)]
    return np.append(seg, seg[-1])


def timed_path_msg(points: Any, times: Any, *, frame_id: str = "map",
                   start_time: float = 0.0) -> dict[str, Any]:
    """A timed path as a ``nav_msgs/Path`` dict.

    Parameters
    ----------
    points : array ``(n, 2)``
        Positions (map units: metres for a ROS map), ``n >= 1``.
    times : array ``(n,)``
        Time of each point, seconds, non-decreasing (equal times: a jump; a repeated point at
        two times: a wait).
    frame_id : str
        The frame of every header (``map``).
    start_time : float
        Added to ``times`` (the stamp of ``t = 0``), seconds; every stamp must lie in
        ``[0, MAX_STAMP]``.

    Returns
    -------
    dict
        ``{"header": {"stamp", "frame_id"}, "poses": [PoseStamped, ...]}``: one
        ``geometry_msgs/PoseStamped`` per point (``header.stamp`` its time, ``pose.position``
        ``x, y, 0``, ``pose.orientation`` the heading of :func:`headings` about z).
    """
    p = np.asarray(points, dtype=float)
    t = np.asarray(times, dtype=float) + float(start_time)
    if p.ndim != 2 or p.shape[1:] != (2,) or not len(p) or not np.all(np.isfinite(p)):
        raise ValueError(f"points: expected finite (n, 2) positions, n >= 1, got shape {p.shape}")
    if t.shape != (len(p),) or not np.all(np.isfinite(t)):
        raise ValueError(f"times: expected {len(p)} finite stamps, got shape {t.shape}")
    if np.any(np.diff(t) < 0):
        raise ValueError("times: must be non-decreasing")
    if not isinstance(frame_id, str):
        raise ValueError(f"frame_id: expected a string, got {frame_id!r}")
    if t[0] < 0 or t[-1] > MAX_STAMP:
        raise ValueError(f"start_time: stamps must lie in [0, {MAX_STAMP:.0f}] s "
                         f"(builtin_interfaces/Time), got {t[0]:g} .. {t[-1]:g}")
    yaw = headings(p)
    poses = [{"header": {"stamp": stamp_msg(tk), "frame_id": frame_id},
              "pose": {"position": {"x": float(x), "y": float(y), "z": 0.0},
                       "orientation": quaternion_msg(float(a))}}
             for (x, y), tk, a in zip(p, t, yaw)]
    return {"header": {"stamp": stamp_msg(t[0]), "frame_id": frame_id}, "poses": poses}


def path_msg(result: Any, robot: str | None = None, *, frame_id: str = "map",
             start_time: float = 0.0) -> dict[str, Any]:
    """One robot's path of a :class:`~optplan.Result` as a ``nav_msgs/Path`` dict
    (:func:`timed_path_msg`).

    The times are the result's (``Result.times`` of a simulated trajectory, waits included)
    or, for a geometric path, those the validator grades it with: from the start at
    ``t = 0`` at the robot's ``max_speed`` (:func:`optplan.metrics.time_stamps`, on the
    problem embedded in the result).

    Parameters
    ----------
    result : Result
        A result of :func:`optplan.solve` or :meth:`optplan.Result.load`.
    robot : str, optional
        Robot id; default the leader (or the only robot), as ``Result.path``.
    frame_id, start_time
        As :func:`timed_path_msg`.
    """
    from optplan.metrics import time_stamps

    ids = list(result.paths)
    rid = robot if robot is not None else (result.metrics.get("leader") or ids[0])
    if rid not in result.paths:
        raise ValueError(f"robot: no robot {rid!r} in the result (allowed: {', '.join(ids)})")
    path = np.asarray(result.paths[rid], dtype=float).reshape(-1, 2)
    if result.times is None:
        prob = result.scenario_problem()
        if prob is None:
            raise ValueError("result: a geometric path is timed on the solved problem, and "
                             "this result embeds none (its 'scenario' key)")
        times = time_stamps(prob, {rid: path}, None)[rid]
    else:
        times = result.times
    return timed_path_msg(path, times, frame_id=frame_id, start_time=start_time)


def _int_field(v: Any, where: str, key: str, hi: int) -> int:
    """An integer field of a ``builtin_interfaces/Time`` in ``[0, hi)``."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) \
            or not 0 <= v < hi:
        raise err(where, key, f"expected an integer in [0, {hi - 1}], got {v!r}")
    return int(v)


def _stamp(st: Any, where: str, key: str) -> int:
    """A ``builtin_interfaces/Time`` in nanoseconds: ``sec`` in ``[0, 2**31 - 1]`` (an
    int32, not negative: the stamps :func:`timed_path_msg` writes and ROS time accepts),
    ``nanosec`` in ``[0, 10**9)``."""
    st = _mapping(st, where, key, ("sec", "nanosec"), ("sec", "nanosec"))
    sec = _int_field(st["sec"], where, f"{key}.sec", 2**31)
    ns = _int_field(st["nanosec"], where, f"{key}.nanosec", 1_000_000_000)
    return sec * 1_000_000_000 + ns


def read_path_msg(msg: Any, name: str = "<nav_msgs/Path>") -> TimedPath:
    """A ``nav_msgs/Path`` dict (as :func:`path_msg` writes it) -> :class:`TimedPath`;
    errors name ``name`` and the key.

    Every pose's ``header.stamp`` is a ``builtin_interfaces/Time`` with integer ``sec`` in
    ``[0, 2**31 - 1]`` and ``nanosec`` in ``[0, 10**9)``, and the stamps are non-decreasing
    along the path (a timed path; equal stamps are a jump, as :func:`timed_path_msg` writes
    them, so every path it writes reads back); ``header.stamp``, when given, is checked the
    same way."""
    m = _mapping(msg, name, "<root>", ("header", "poses"), ("header", "poses"))
    head = _mapping(m["header"], name, "header", ("stamp", "frame_id"), ("frame_id",))
    if "stamp" in head:
        _stamp(head["stamp"], name, "header.stamp")
    if not isinstance(head["frame_id"], str):
        raise err(name, "header.frame_id", f"expected a string, got {head['frame_id']!r}")
    if not isinstance(m["poses"], Sequence) or isinstance(m["poses"], str):
        raise err(name, "poses", "expected a list of geometry_msgs/PoseStamped")
    pts, ts, yaw = [], [], []
    last = -1
    for k, ps in enumerate(m["poses"]):
        key = f"poses[{k}]"
        ps = _mapping(ps, name, key, ("header", "pose"), ("header", "pose"))
        st = _mapping(ps["header"], name, f"{key}.header", ("stamp", "frame_id"),
                      ("stamp",))["stamp"]
        ns = _stamp(st, name, f"{key}.header.stamp")
        if ns < last:
            raise err(name, f"{key}.header.stamp", f"{ns / 1e9:.9f} s is before the "
                      f"previous pose's {last / 1e9:.9f} s: the stamps of a timed path must "
                      f"be non-decreasing")
        last = ns
        ts.append(ns * 1e-9)
        x, y, a = _pose(ps["pose"], name, f"{key}.pose")
        pts.append((x, y))
        yaw.append(a)
    return TimedPath(head["frame_id"], np.asarray(pts, dtype=float).reshape(-1, 2),
                     np.asarray(ts, dtype=float), np.asarray(yaw, dtype=float))


# -- nav_msgs/OccupancyGrid ------------------------------------------------------------------


def _size(v: Any, where: str, key: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 2**32 - 1:
        raise err(where, key, f"expected an integer in [1, {2**32 - 1}] (cells), got {v!r}")
    return int(v)


def _check_numbers(data: Sequence[Any], where: str, expected: str) -> None:
    """Every entry of ``data`` is a real number (``int``, ``float``, numpy; not a bool, not a
    string such as ``"50"``); the first other one is an error naming its index."""
    kinds = set(map(type, data))
    if all(issubclass(t, (int, float, np.integer, np.floating))
           and not issubclass(t, (bool, np.bool_)) for t in kinds):
        return
    k = next(i for i, v in enumerate(data) if not is_real(v))
    raise err(where, f"data[{k}]", f"{data[k]!r} ({type(data[k]).__name__}) is not a number: "
                                   f"{expected}")


def _as_values(data: Any, where: str) -> np.ndarray:
    """``data`` (a list, an array, ``bytes`` as int8) as a float array; every entry a number."""
    expected = "expected a sequence of int8 values -1 (unknown) or 0..100 (occupancy, percent)"
    if isinstance(data, (bytes, bytearray)):
        return np.frombuffer(bytes(data), dtype=np.int8).astype(float)
    if isinstance(data, (str, Mapping)):
        raise err(where, "data", f"{expected}, got {type(data).__name__}")
    if isinstance(data, (list, tuple)):
        _check_numbers(data, where, expected)
    try:
        a = np.asarray(data)
    except (TypeError, ValueError):
        raise err(where, "data", f"{expected}, got {type(data).__name__}") from None
    if a.dtype.kind == "O" and a.ndim == 1:  # e.g. Python ints beyond int64
        _check_numbers(a.tolist(), where, expected)
        return np.array([float(v) if abs(v) < 1e300 else 1e300 if v > 0 else -1e300
                         for v in a.tolist()])
    if a.dtype.kind not in "iuf":
        raise err(where, "data", f"{expected}, got an array of {a.dtype}")
    return a.astype(float)


def _grid_values(data: Any, width: int, height: int, where: str) -> np.ndarray:
    """``data`` as ``(height, width)`` int values, checked: numbers, the length and -1..100."""
    a = _as_values(data, where)
    if a.ndim != 1 or len(a) != width * height:
        raise err(where, "data", f"{a.size} values, expected info.width x info.height = "
                                 f"{width} x {height} = {width * height} (row-major from the "
                                 f"origin cell)")
    bad = np.flatnonzero(~((a == np.round(a)) & (a >= GRID_UNKNOWN) & (a <= GRID_OCCUPIED)))
    if len(bad):
        k = int(bad[0])
        raise err(where, f"data[{k}]", f"{a[k]:g} is not an occupancy value: expected an "
                                       f"integer in -1..100 (-1 unknown, 0 free .. 100 "
                                       f"occupied)")
    return a.astype(np.int16).reshape(height, width)


def read_occupancy_grid(msg: Any, *, name: str = "<nav_msgs/OccupancyGrid>",
                        occupied_thresh: float = 0.65, free_thresh: float = 0.196,
                        max_cells: int = MAX_CELLS) -> Grid:
    """An in-memory ``nav_msgs/OccupancyGrid`` dict -> :class:`~optplan.maps.Grid`.

    ``info``: ``resolution`` (> 0, m / cell), ``width`` and ``height`` (cells), ``origin`` (a
    ``geometry_msgs/Pose``: the world pose of the corner of cell ``(0, 0)``; rotations about
    z only); ``map_load_time`` is allowed and not used.  ``data``: ``width x height`` int8
    values, row-major from the origin cell (row 0 is the bottom row of the map), ``-1``
    unknown, ``0..100`` occupancy in percent.  Values are classified as ``map_server``'s
    ``raw`` mode classifies pixels (:func:`~optplan.maps.classify`, one implementation):
    occupied when ``v / 100 > occupied_thresh``, free when ``v / 100 < free_thresh``, unknown
    otherwise (so ``0`` free, ``100`` occupied, ``-1`` unknown with the defaults).  The
    entries must be numbers (a string such as ``"50"`` is an error); ``resolution`` may be a
    numpy scalar; the map's diagonal must lie in ``[1e-100, 1e100]`` and its centre within
    ``1e6`` diagonals of the coordinate origin (:data:`~optplan.maps.checks.MAP_MIN_LENGTH`); a
    map of more than ``max_cells`` cells (:data:`~optplan.maps.MAX_CELLS` by default) is an
    error, as it is for the file readers.

    Raises
    ------
    ProblemError
        Naming ``name`` and the key (``info.resolution``, ``data[17]``, ...) and the allowed
        values.
    """
    m = _mapping(msg, name, "<root>", _GRID_KEYS, ("info", "data"))
    info = _mapping(m["info"], name, "info", _INFO_KEYS, _INFO_KEYS[1:])
    res = number(info["resolution"], name, "info.resolution", positive=True)
    width = _size(info["width"], name, "info.width")
    height = _size(info["height"], name, "info.height")
    origin = _pose(info["origin"], name, "info.origin")
    check_cells(name, "info.width", height, width, max_cells,
                "info.width x info.height: ")
    check_extent(name, width, height, res, origin, "info.resolution", "info.origin")
    occ, free, _, _ = _thresholds(name, occupied_thresh, free_thresh, "raw", 0)
    v = _grid_values(m["data"], width, height, name)[::-1]  # row 0 of a Grid is the top
    pixels = np.where(v < 0, 255, v).astype(float)  # map_server's raw -1 is 255: unknown
    cells = classify(pixels, None, occupied_thresh=occ, free_thresh=free, mode="raw")
    return Grid(cells, res, origin, name)


def occupancy_grid_msg(grid: Grid, *, frame_id: str = "map",
                       stamp: float = 0.0) -> dict[str, Any]:
    """A :class:`~optplan.maps.Grid` as a ``nav_msgs/OccupancyGrid`` dict (free 0, occupied
    100, unknown -1; rows from the origin cell), which :func:`read_occupancy_grid` reads back
    to the same grid."""
    values = np.full(grid.cells.shape, GRID_UNKNOWN, dtype=int)
    values[grid.cells == FREE] = GRID_FREE
    values[grid.cells == OCCUPIED] = GRID_OCCUPIED
    values[grid.cells == UNKNOWN] = GRID_UNKNOWN
    x, y, yaw = grid.origin
    return {"header": {"stamp": stamp_msg(stamp), "frame_id": frame_id},
            "info": {"map_load_time": stamp_msg(stamp), "resolution": float(grid.resolution),
                     "width": grid.width, "height": grid.height,
                     "origin": {"position": {"x": float(x), "y": float(y), "z": 0.0},
                                "orientation": quaternion_msg(float(yaw))}},
            "data": values[::-1].ravel().tolist()}
