"""Seeded scene families for the references in time: :func:`time_family`.

Three kinds, each one robot (radius in ``[0.3, 2.5]``, ``max_speed`` in ``[1, 5]``) among
moving obstacles of speed 1-5 (map units per second):

* ``"open"``: an open square field (60 on a side, larger for robots above radius 1) with 0-4
  small static obstacles and 5-20 movers crossing the start-goal line, circles and convex
  polygons, of every motion kind (``hold``, ``loop``, ``bounce``, constant ``velocity``);
* ``"doors"``: two or three rooms side by side, joined by doors 2.5-4 robot diameters wide in
  thin walls; movers bounce through the doors, loop around the rooms, park in a doorway for
  5-20 s and then leave, and one may sit on the goal for 5-20 s at the start;
* ``"warehouse"``: 50-100 rectangular shelves in rows with aisles 2.5-4 robot diameters wide
  and 20 movers along the aisles (``bounce`` in an aisle, ``loop`` around a block of shelves).

:func:`door_scene` is the fixed two-room scene of docs/time.md ("The time bracket").

Every scene is drawn again from the same generator until the robot's start disc is clear of
every mover at ``t = 0``, no mover rests on the goal for ever, and the goal is reachable on the
static map (the certified shortest path,
:func:`optplan.geometry.tangent.problem_shortest_path`), so the scene depends on the
generator's state alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Point

from optplan.problem import Problem, parse_problem

__all__ = ["TIME_FAMILY_KINDS", "time_family", "door_scene"]

#: The kinds of :func:`time_family`.
TIME_FAMILY_KINDS = ("open", "doors", "warehouse")

#: Draws before :func:`time_family` gives up (every kind is accepted far sooner).
_ATTEMPTS = 50

_MOTIONS = ("hold", "loop", "bounce", "velocity")


def _robot(rng: np.random.Generator) -> tuple[float, float]:
    """The robot's radius and max_speed."""
    return float(rng.uniform(0.3, 2.5)), float(rng.uniform(1.0, 5.0))


def _rect(x0: float, y0: float, x1: float, y1: float, name: str) -> dict[str, Any]:
    """A ``rectangle`` obstacle table."""
    return {"type": "rectangle", "min": [float(x0), float(y0)], "max": [float(x1), float(y1)],
            "name": name}


def _convex(rng: np.random.Generator, size: float) -> list[list[float]]:
    """A random convex polygon of 3-6 vertices about the origin, within ``size`` of it."""
    while True:
        ang = np.sort(rng.uniform(0.0, 2 * math.pi, int(rng.integers(3, 7))))
        rad = size * rng.uniform(0.6, 1.0, ang.size)
        hull = shapely.MultiPoint(np.c_[rad * np.cos(ang), rad * np.sin(ang)]).convex_hull
        if hull.geom_type == "Polygon" and hull.area > 0.25 * size * size:
            return [[float(x), float(y)] for x, y in list(hull.exterior.coords)[:-1]]


def _shape(rng: np.random.Generator, size: float, circle: bool) -> dict[str, Any]:
    """A mover's shape keys: a circle of radius ``size`` or a convex polygon within it."""
    if circle:
        return {"type": "circle", "radius": float(size)}
    return {"type": "polygon", "vertices": _convex(rng, size)}


def _timed(points: list[np.ndarray], speed: float, t0: float) -> list[float]:
    """Times at which a mover of ``speed`` starting at ``t0`` reaches each of ``points``."""
    legs = [math.dist(a, b) / speed for a, b in zip(points, points[1:])]
    return [float(t) for t in t0 + np.concatenate([[0.0], np.cumsum(legs)])]


def _path_mover(name: str, shape: dict[str, Any], points: list[np.ndarray], times: list[float],
                after: str) -> dict[str, Any]:
    """A ``[[dynamic_obstacles]]`` table moving along ``points`` at ``times``."""
    return {**shape, "name": name, "waypoints": [[float(v) for v in p] for p in points],
            "times": [float(t) for t in times], "after": after}


def _phase(rng: np.random.Generator, times: list[float], after: str) -> list[float]:
    """``times`` shifted by a random phase: back within a period, or a ``hold`` on by 0-20 s."""
    span = times[-1] - times[0]
    shift = -rng.uniform(0.0, 2 * span if after == "bounce" else span) if after != "hold" \
        else rng.uniform(0.0, 20.0)
    return [t + float(shift) for t in times]


# ---- open ----------------------------------------------------------------------------------

def _open_ends(rng: np.random.Generator, side: float) -> tuple[np.ndarray, np.ndarray]:
    """Start and goal on a random diameter of the field, 0.8 x the side apart."""
    th = rng.uniform(0.0, 2 * math.pi)
    d = np.array([math.cos(th), math.sin(th)])
    mid = np.full(2, side / 2) + rng.uniform(-0.05, 0.05, 2) * side
    half = 0.4 * side / np.abs(d).max()
    return mid - half * d, mid + half * d


def _open_statics(rng: np.random.Generator, side: float, r: float,
                  ends: tuple[np.ndarray, np.ndarray]) -> list[dict[str, Any]]:
    """0-4 small boxes and discs, each at least its size + 2 radii from start and goal."""
    out: list[dict[str, Any]] = []
    for k in range(int(rng.integers(0, 5))):
        s = float(rng.uniform(0.03, 0.08) * side)
        c = rng.uniform(0.15, 0.85, 2) * side
        if min(math.dist(c, e) for e in ends) < 1.5 * s + 2 * r:
            continue
        if k % 2:
            out.append({"type": "circle", "center": c.tolist(), "radius": s, "name": f"disc{k}"})
        else:
            out.append(_rect(c[0] - s, c[1] - s / 2, c[0] + s, c[1] + s / 2, f"box{k}"))
    return out


def _crossing_mover(rng: np.random.Generator, k: int, motion: str, start: np.ndarray,
                    goal: np.ndarray, side: float) -> dict[str, Any]:
    """Mover ``k`` crossing the start-goal line with ``motion`` (one of ``_MOTIONS``)."""
    c = start + rng.uniform(0.15, 0.85) * (goal - start)
    u = (goal - start) / np.linalg.norm(goal - start)
    a = rng.uniform(-math.pi / 4, math.pi / 4)
    n = np.array([-u[1], u[0]]) * math.cos(a) + u * math.sin(a)  # across the line, +-45 deg
    n *= 1.0 if rng.random() < 0.5 else -1.0
    reach = float(rng.uniform(0.1, 0.3) * side)
    speed = float(rng.uniform(1.0, 5.0))
    shape = _shape(rng, float(rng.uniform(0.01, 0.04) * side), circle=bool(k % 2))
    name = f"{motion}{k}"
    if motion == "velocity":
        t_cross = rng.uniform(0.0, 2 * reach / speed)  # reaches the line at this time
        return {**shape, "name": name, "waypoints": [(c - t_cross * speed * n).tolist()],
                "velocity": (speed * n).tolist(), "times": [0.0]}
    if motion == "loop":  # a closed quadrilateral around the crossing point
        th = rng.uniform(0.0, 2 * math.pi) + np.arange(4) * math.pi / 2
        pts = [c + reach * rng.uniform(0.5, 1.0) * np.array([math.cos(t), math.sin(t)])
               for t in th]
        pts.append(pts[0])
    else:
        pts = [c - reach * n, c + reach * n]
    pts = [np.clip(p, 0.02 * side, 0.98 * side) for p in pts]
    return _path_mover(name, shape, pts, _phase(rng, _timed(pts, speed, 0.0), motion), motion)


def _open(rng: np.random.Generator) -> dict[str, Any]:
    """One draw of the ``open`` kind (module docstring)."""
    r, vmax = _robot(rng)
    side = 60.0 * max(1.0, r)
    start, goal = _open_ends(rng, side)
    n = int(rng.integers(5, 21))
    motions = [_MOTIONS[(k + int(rng.integers(0, 4))) % 4] if k >= 4 else _MOTIONS[k]
               for k in range(n)]
    order = rng.permutation(n)
    movers = [_crossing_mover(rng, int(k), motions[k], start, goal, side) for k in order]
    return {"bounds": [0.0, 0.0, side, side], "robot": (start, goal, r, vmax),
            "obstacles": _open_statics(rng, side, r, (start, goal)),
            "dynamic_obstacles": movers}


# ---- doors ---------------------------------------------------------------------------------

def _doors_walls(rng: np.random.Generator, n_rooms: int, room_w: float, height: float,
                 r: float) -> tuple[list[dict[str, Any]], list[tuple[float, float, float]]]:
    """The thin walls between the rooms with 1-2 doors each; the pieces and doors (x, y, w)."""
    walls: list[dict[str, Any]] = []
    doors: list[tuple[float, float, float]] = []
    t = float(rng.uniform(0.2, 0.5) * r + 0.1)
    for w in range(1, n_rooms):
        x = w * room_w
        n_doors = int(rng.integers(1, 3))
        band = np.linspace(0.0, height, n_doors + 1)  # one door per band: they never overlap
        y = 0.0
        for k in range(n_doors):
            width = float(rng.uniform(2.5, 4.0) * 2 * r)
            m = width / 2 + 0.05 * height  # a piece of wall below and above every door
            yc = float(rng.uniform(band[k] + m, band[k + 1] - m))
            walls.append(_rect(x - t / 2, y, x + t / 2, yc - width / 2, f"wall{w}-{k}"))
            y = yc + width / 2
            doors.append((x, yc, width))
        walls.append(_rect(x - t / 2, y, x + t / 2, height, f"wall{w}-{n_doors}"))
    return walls, doors


def _room_point(rng: np.random.Generator, room: int, room_w: float, height: float,
                margin: float) -> np.ndarray:
    """A random point of room ``room`` at least ``margin`` from its walls."""
    return np.array([rng.uniform(room * room_w + margin, (room + 1) * room_w - margin),
                     rng.uniform(margin, height - margin)])


def _door_mover(rng: np.random.Generator, k: int, door: tuple[float, float, float],
                room_w: float, height: float, park: bool) -> dict[str, Any]:
    """A mover filling ``door``: bouncing through it, or with ``park`` sitting in it 5-20 s."""
    # 0.3-0.45 x the door's width: the robot cannot pass it in the doorway; a parked one comes
    # from one room, sits in the doorway, then leaves into the other room and stays there
    x, y, width = door
    size = float(rng.uniform(0.3, 0.45) * width)
    room = int(round(x / room_w))  # the room right of the wall
    side = rng.random() < 0.5
    a = _room_point(rng, room - 1 if side else room, room_w, height, 2 * size)
    b = _room_point(rng, room if side else room - 1, room_w, height, 2 * size)
    e = float(width)
    sgn = 1.0 if side else -1.0
    near, far = np.array([x - sgn * e, y]), np.array([x + sgn * e, y])
    speed = float(rng.uniform(1.0, 5.0))
    shape = _shape(rng, size, circle=bool(k % 2))
    if park:
        pts = [a, near, np.array([x, y]), np.array([x, y]), far, b]
        ts = _timed([a, near, np.array([x, y])], speed, float(rng.uniform(0.0, 15.0)))
        wait = float(rng.uniform(5.0, 20.0))
        ts += [t + ts[-1] + wait for t in _timed([np.array([x, y]), far, b], speed, 0.0)]
        return _path_mover(f"park{k}", shape, pts, ts, "hold")
    pts = [a, near, far, b]
    return _path_mover(f"door{k}", shape, pts, _phase(rng, _timed(pts, speed, 0.0), "bounce"),
                       "bounce")


def _room_loop(rng: np.random.Generator, k: int, room: int, room_w: float, height: float,
               r: float) -> dict[str, Any]:
    """A mover looping around room ``room`` on a rectangle inset from its walls."""
    size = float(rng.uniform(0.5, 1.5) * r)
    m = rng.uniform(0.15, 0.3, 2) * np.array([room_w, height])
    x0, x1 = room * room_w + m[0], (room + 1) * room_w - m[0]
    y0, y1 = m[1], height - m[1]
    pts = [np.array(p) for p in ((x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0))]
    if rng.random() < 0.5:
        pts = pts[::-1]
    ts = _phase(rng, _timed(pts, float(rng.uniform(1.0, 5.0)), 0.0), "loop")
    return _path_mover(f"loop{k}", _shape(rng, size, circle=bool(k % 2)), pts, ts, "loop")


def _goal_parker(rng: np.random.Generator, goal: np.ndarray, r: float, room: int,
                 room_w: float, height: float) -> dict[str, Any]:
    """A disc sitting on the goal from ``t = 0`` for 5-20 s, then leaving for good."""
    size = float(rng.uniform(0.5, 1.5) * r)
    at = goal + rng.uniform(-0.5, 0.5, 2) * r
    away = _room_point(rng, room, room_w, height, 2 * size)
    while math.dist(away, goal) < 2 * (size + r):
        away = _room_point(rng, room, room_w, height, 2 * size)
    wait = float(rng.uniform(5.0, 20.0))
    ts = [0.0, wait, wait + math.dist(at, away) / float(rng.uniform(1.0, 5.0))]
    return _path_mover("goal-parker", {"type": "circle", "radius": size}, [at, at, away], ts,
                       "hold")


def _doors(rng: np.random.Generator) -> dict[str, Any]:
    """One draw of the ``doors`` kind (module docstring)."""
    r, vmax = _robot(rng)
    n_rooms = int(rng.integers(2, 4))
    width = 60.0 * max(1.0, r)
    height = float(rng.uniform(0.6, 0.8) * width)
    room_w = width / n_rooms
    walls, doors = _doors_walls(rng, n_rooms, room_w, height, r)
    start = _room_point(rng, 0, room_w, height, 2 * r)
    goal = _room_point(rng, n_rooms - 1, room_w, height, 2 * r)
    movers = [_door_mover(rng, k, d, room_w, height, park=bool(k % 2 == 0))
              for k, d in enumerate(doors)]
    movers += [_door_mover(rng, len(movers) + k, doors[int(rng.integers(0, len(doors)))],
                           room_w, height, park=bool(rng.random() < 0.5))
               for k in range(int(rng.integers(0, 3)))]
    movers += [_room_loop(rng, len(movers) + q, q, room_w, height, r) for q in range(n_rooms)
               if rng.random() < 0.8]
    if rng.random() < 0.5:
        movers.append(_goal_parker(rng, goal, r, n_rooms - 1, room_w, height))
    return {"bounds": [0.0, 0.0, width, height], "robot": (start, goal, r, vmax),
            "obstacles": walls, "dynamic_obstacles": movers}


# ---- warehouse -----------------------------------------------------------------------------

def _warehouse_grid(rng: np.random.Generator) -> tuple[int, int]:
    """Shelf columns and rows, 50-100 shelves in all."""
    while True:
        cols, rows = int(rng.integers(4, 9)), int(rng.integers(8, 15))
        if 50 <= cols * rows <= 100:
            return cols, rows


def _warehouse(rng: np.random.Generator) -> dict[str, Any]:
    """One draw of the ``warehouse`` kind (module docstring)."""
    r, vmax = _robot(rng)
    d = 2 * r
    cols, rows = _warehouse_grid(rng)
    aisle = float(rng.uniform(2.5, 4.0) * d)
    shelf_l, shelf_t = float(rng.uniform(4.0, 8.0) * d), float(rng.uniform(0.5, 1.2) * d)
    cross = float(rng.uniform(2.5, 4.0) * d)
    x_lo = [aisle + c * (shelf_l + cross) for c in range(cols)]
    width = x_lo[-1] + shelf_l + aisle
    # lanes: the centre lines of the free corridors (margins, aisles, cross aisles)
    xs = [aisle / 2] + [x + shelf_l + cross / 2 for x in x_lo[:-1]] + [width - aisle / 2]
    y_lo = [aisle + q * (shelf_t + aisle) for q in range(rows)]
    height = y_lo[-1] + shelf_t + aisle
    ys = [aisle / 2] + [y + shelf_t + aisle / 2 for y in y_lo]
    shelves = [_rect(x, y, x + shelf_l, y + shelf_t, f"shelf{c}-{q}")
               for c, x in enumerate(x_lo) for q, y in enumerate(y_lo)]
    start = np.array([xs[0], ys[int(rng.integers(0, len(ys)))]])
    goal = np.array([xs[-1], ys[int(rng.integers(0, len(ys)))]])
    if rng.random() < 0.5:
        start, goal = goal, start
    movers = [_aisle_mover(rng, k, xs, ys, aisle, width, height) for k in range(20)]
    return {"bounds": [0.0, 0.0, width, height], "robot": (start, goal, r, vmax),
            "obstacles": shelves, "dynamic_obstacles": movers}


def _aisle_mover(rng: np.random.Generator, k: int, xs: list[float], ys: list[float],
                 aisle: float, width: float, height: float) -> dict[str, Any]:
    """A cart bouncing along one lane (``xs`` up, ``ys`` across) or looping around a block."""
    # at most a quarter of an aisle across: a robot passes it
    size = float(rng.uniform(0.15, 0.25) * aisle)
    shape = _shape(rng, size, circle=bool(k % 2))
    speed = float(rng.uniform(1.0, 5.0))
    if k % 3 == 2:  # loop around a block
        i0, i1 = np.sort(rng.choice(len(xs), 2, replace=False))
        j0, j1 = np.sort(rng.choice(len(ys), 2, replace=False))
        c = [(xs[i0], ys[j0]), (xs[i1], ys[j0]), (xs[i1], ys[j1]), (xs[i0], ys[j1]),
             (xs[i0], ys[j0])]
        pts = [np.array(p) for p in (c if rng.random() < 0.5 else c[::-1])]
        return _path_mover(f"cart{k}", shape, pts, _phase(rng, _timed(pts, speed, 0.0), "loop"),
                           "loop")
    if rng.random() < 0.5:  # along an aisle
        y = ys[int(rng.integers(0, len(ys)))]
        a, b = np.sort(rng.uniform(aisle / 2, width - aisle / 2, 2))
        pts = [np.array([a, y]), np.array([max(b, a + aisle), y])]
    else:  # along a cross aisle
        x = xs[int(rng.integers(0, len(xs)))]
        a, b = np.sort(rng.uniform(aisle / 2, height - aisle / 2, 2))
        pts = [np.array([x, a]), np.array([x, max(b, a + aisle)])]
    return _path_mover(f"cart{k}", shape, pts, _phase(rng, _timed(pts, speed, 0.0), "bounce"),
                       "bounce")


# ---- acceptance ----------------------------------------------------------------------------

def _ends_clear(problem: Problem) -> bool:
    """The start disc clear of the movers at ``t = 0``, the goal disc of their resting places."""
    robot = problem.leader
    start, goal = Point(robot.start), Point(np.asarray(robot.goal, float))
    for d in problem.dynamic_obstacles:
        if d.geometry_at(0.0).distance(start) <= robot.radius:
            return False
        if d.velocity is None and d.after == "hold" and \
                d.geometry_at(float(d.times[-1])).distance(goal) <= robot.radius:
            return False
    return True


def _reachable(problem: Problem) -> bool:
    """The goal reachable on the static map (certified shortest path)."""
    from optplan.geometry.tangent import problem_shortest_path

    res = problem_shortest_path(problem, problem.leader, known_only=False)
    return res.polyline is not None and math.isfinite(res.length)


_BUILDERS: dict[str, Callable[[np.random.Generator], dict[str, Any]]] = {
    "open": _open, "doors": _doors, "warehouse": _warehouse}


def _to_problem(kind: str, draw: dict[str, Any]) -> Problem:
    """The scenario of one draw."""
    start, goal, r, vmax = draw.pop("robot")
    data = {"name": f"time-{kind}",
            "description": f"generated scene for the references in time ({kind})",
            "source": "optplan.time_families.time_family (synthetic)",
            "tags": ["generated", "time", kind],
            "robots": [{"id": "r1", "start": [float(v) for v in start],
                        "goal": [float(v) for v in goal], "radius": r, "max_speed": vmax}],
            **draw}
    return parse_problem(data, f"<time family {kind}>")


def time_family(kind: str, rng: np.random.Generator) -> Problem:
    """A random scene of a family for the references in time (module docstring).

    Parameters
    ----------
    kind : str
        ``"open"``, ``"doors"`` or ``"warehouse"`` (:data:`TIME_FAMILY_KINDS`).
    rng : numpy.random.Generator
        All randomness; the same generator state gives the same scene.

    Returns
    -------
    Problem
        Named ``time-{kind}``, one robot ``r1`` whose start disc is clear of every moving
        obstacle at ``t = 0`` and whose goal is reachable on the static map.

    Raises
    ------
    ValueError
        For an unknown ``kind`` (the message lists the kinds).
    RuntimeError
        If no acceptable scene was drawn in 50 draws (not seen in practice).
    """
    if kind not in _BUILDERS:
        raise ValueError(f"unknown time family {kind!r}; the kinds are "
                         f"{', '.join(TIME_FAMILY_KINDS)}")
    for _ in range(_ATTEMPTS):
        problem = _to_problem(kind, _BUILDERS[kind](rng))
        if _ends_clear(problem) and _reachable(problem):
            return problem
    raise RuntimeError(f"time_family({kind!r}): no acceptable scene in {_ATTEMPTS} draws")


#: the door scene's walls: a 1-wide wall at x = 20 with a door at 9 < y < 11
_DOOR_WALLS = [[[19.5, 0], [20.5, 0], [20.5, 9], [19.5, 9]],
               [[19.5, 11], [20.5, 11], [20.5, 20], [19.5, 20]]]
#: a disc parked in the door until t = 20, then leaving upwards at speed 2
DOOR_KEEPER = {"type": "circle", "radius": 0.8, "name": "door-keeper",
               "waypoints": [[20, 10], [20, 10], [20, 30]], "times": [0, 20, 30]}


def door_scene(scale: float = 1.0, shift: tuple[float, float] = (0.0, 0.0),
               movers: tuple[dict[str, Any], ...] = (DOOR_KEEPER,)) -> Problem:
    """Two 20 x 20 rooms joined by a door held shut by a parked disc until ``t = 20``; the
    robot (radius 0.3, speed 1) crosses from (2, 10) to (38, 10).

    Parameters
    ----------
    scale : float
        Space and time scaled together (speeds unchanged): the arrival scales by ``scale``.
    shift : (float, float)
        Added to every point.
    movers : tuple of dict
        The ``[[dynamic_obstacles]]`` tables in the unscaled frame (default the door keeper).

    Returns
    -------
    Problem
    """
    sx, sy = shift

    def pt(p: Any) -> list[float]:
        return [p[0] * scale + sx, p[1] * scale + sy]

    dyn = [dict(m, waypoints=[pt(w) for w in m["waypoints"]],
                times=[t * scale for t in m["times"]], radius=m["radius"] * scale)
           for m in movers]
    return parse_problem({
        "name": "door", "bounds": [sx, sy, sx + 40 * scale, sy + 20 * scale],
        "robots": [{"id": "r", "start": pt([2, 10]), "goal": pt([38, 10]),
                    "radius": 0.3 * scale, "max_speed": 1.0}],
        "obstacles": [{"type": "polygon", "vertices": [pt(v) for v in w]}
                      for w in _DOOR_WALLS],
        "dynamic_obstacles": dyn})
