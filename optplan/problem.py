"""Problem model and the TOML scenario format (problems/README.md).

A :class:`Problem` is an immutable description of a 2-D workspace: rectangular bounds,
disc robots (radius ``>= 0``; ``0`` is a point robot) with start/goal, static obstacles
(polygons with optional holes, rectangles, circles; each either *known* to a global planner or
*temporary*), dynamic obstacles moving along time-stamped waypoints or with a constant velocity,
an optional leader-follower formation and an optional sensing range.  ``problems/README.md``
documents every key with its unit.

Static obstacles are kept exactly: polygons as the vertices the user wrote (shapely
``Polygon``), circles as centre and radius (never polygonised).  Collision and clearance
questions go to the one exact engine, :meth:`Problem.obstacle_set`
(:class:`optplan.geometry.ObstacleSet`).

All parsing errors raise :class:`ProblemError` naming the file and the key.
"""

from __future__ import annotations

import difflib
import math
import reprlib
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Point, Polygon

__all__ = [
    "ProblemError",
    "Robot",
    "Obstacle",
    "DynamicObstacle",
    "Follower",
    "Formation",
    "Problem",
    "parse_problem",
    "read_problem",
    "problem_to_dict",
    "transform_problem",
]

#: Segments per quarter circle of the ``local_geometry`` polygon of a *dynamic* circle (shapely
#: ``quad_segs``; used for drawing and shapely queries only, the distance is exact).  Static
#: circles are never polygonised.
CIRCLE_QUAD_SEGS = 16

#: Largest magnitude accepted for an obstacle coordinate or size (map units).  Squares of such
#: numbers (and of their differences) stay finite doubles (``1e300 < 1.8e308``).  Obstacles far
#: outside the bounds are accepted below this and ignored by the geometry core; those reaching
#: into the map must further satisfy :meth:`optplan.geometry.Frame.check_extent`.
MAX_COORD = 1e150

#: A closing vertex within this fraction of the polygon's own size (bounding-box diagonal of
#: its vertices) of the first vertex repeats it and is dropped; zero-area tests use the square.
CLOSE_REL = 1e-12

#: Largest speed (``max_speed``, dynamic-obstacle ``velocity`` and the speed implied by
#: consecutive ``waypoints`` / ``times``) and sensing range, as a multiple of the bounds
#: diagonal ``L`` (per second for speeds): beyond it the map is crossed in under a microsecond
#: (or sensed a million times over) and squares of positions reached in one step stop being
#: resolvable.
MAX_REL_SPEED = 1e6

#: Smallest robot ``max_speed`` as a multiple of the bounds diagonal per second: crossing the
#: map may take at most a million seconds (11.6 days).
MIN_REL_SPEED = 1e-6

#: Smallest period of a looping or bouncing dynamic obstacle as a fraction of the time the
#: slowest robot needs to cross the map (bounds diagonal / its ``max_speed``): the validator
#: follows every period in continuous time, at most about ``1 / MIN_REL_PERIOD`` of them per
#: map crossing.
MIN_REL_PERIOD = 1e-5

#: Largest magnitude of a dynamic-obstacle time stamp (seconds; about 31,700 years, so Unix
#: epoch times fit).
MAX_TIME = 1e12

#: Largest number of points (polygon and hole vertices, dynamic-obstacle vertices and
#: waypoints) in one scenario.
MAX_POINTS = 100_000

#: Largest ratio of the longer to the shorter side of the bounds: beyond it the tolerance
#: ``1e-9 x`` the diagonal is no longer small against the shorter side.
MAX_ASPECT = 1e6

#: Largest scenario file :func:`read_problem` reads (bytes; 100,000 points take about 4 MB),
#: so that reading a rejected file takes a few seconds at most.
MAX_FILE_BYTES = 8 * 2**20


class ProblemError(ValueError):
    """A scenario (or an option) is malformed; the message names the file and key."""


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict = 3, 6, 6, 4
_REPR.maxstring, _REPR.maxlong, _REPR.maxother = 60, 40, 60


def _show(v: Any) -> str:
    """A short ``repr`` of a TOML value for messages (long and deeply nested values cut)."""
    try:
        return _REPR.repr(v)
    except RecursionError:  # pragma: no cover - reprlib stops at maxlevel
        return f"<deeply nested {type(v).__name__}>"


# --------------------------------------------------------------------------------------
# value objects
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Robot:
    """A disc robot.

    Attributes
    ----------
    id : str
        Unique identifier.
    start, goal : numpy.ndarray
        Positions, shape ``(2,)``, map units.  ``goal`` is ``None`` for a follower whose
        goal is its formation slot.
    radius : float
        Disc radius (map units), ``>= 0``; ``0`` is a point robot.  A robot is clear of an
        obstacle when the exact distance from its centre is ``>= radius - eps``
        (:attr:`Problem.frame`).
    max_speed : float
        Speed limit (map units per second) used by time-stepping controllers.
    """

    id: str
    start: np.ndarray
    goal: np.ndarray | None
    radius: float
    max_speed: float


@dataclass(frozen=True, eq=False)
class Obstacle:
    """A static obstacle.

    ``kind`` is ``"polygon"``, ``"rectangle"`` or ``"circle"``.

    * polygons and rectangles: ``geometry`` is the shapely ``Polygon`` of the vertices as given
      (CCW exterior, holes allowed); ``center`` and ``radius`` are ``None``.
    * circles: ``geometry`` is ``None``.  The exact ``center`` (shape ``(2,)``) and ``radius``
      *are* the model; nothing polygonises a static circle (draw it with
      ``matplotlib.patches.Circle``, query it through :meth:`Problem.obstacle_set`).

    ``known = False`` marks a temporary obstacle that global planners do not see but local
    planners and the validator do.
    """

    kind: str
    geometry: Polygon | None
    known: bool = True
    name: str = ""
    center: np.ndarray | None = None
    radius: float | None = None

    @property
    def is_circle(self) -> bool:
        return self.kind == "circle"

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """Exact axis-aligned bounding box ``(xmin, ymin, xmax, ymax)`` (world coordinates)."""
        if self.is_circle:
            cx, cy = (float(v) for v in self.center)
            r = float(self.radius)
            return (cx - r, cy - r, cx + r, cy + r)
        return tuple(float(v) for v in self.geometry.bounds)


@dataclass(frozen=True, eq=False)
class DynamicObstacle:
    """An obstacle whose shape translates over time.

    The shape is given in a local frame (circle of ``radius`` around the origin, or polygon
    ``vertices`` relative to the reference point).  The reference point moves either along
    time-stamped ``waypoints`` (piecewise linear; before the first time it holds the first
    waypoint, after the last it follows ``after``: ``"hold"``, ``"loop"`` or ``"bounce"``) or
    from ``waypoints[0]`` with a constant ``velocity``.
    """

    kind: str
    local_geometry: Polygon
    times: np.ndarray
    waypoints: np.ndarray
    velocity: np.ndarray | None = None
    after: str = "hold"
    name: str = ""
    radius: float | None = None

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Reference position at time(s) ``t``; shape ``(2,)`` or ``(len(t), 2)``.

        The motion model of ``problems/README.md``, evaluated on the one track of
        :func:`optplan.geometry.motion.mover_track` (right-continuous: at a ``loop`` period
        boundary the obstacle is at its first waypoint).
        """
        from optplan.geometry.motion import mover_position

        return mover_position(self, t)

    def geometry_at(self, t: float) -> Polygon:
        """The obstacle's shapely geometry at time ``t``."""
        p = self.position(float(t))
        return shapely.affinity.translate(self.local_geometry, float(p[0]), float(p[1]))

    def distance(self, points: np.ndarray, t: float | np.ndarray) -> np.ndarray:
        """Distance from ``points`` (``(m, 2)``) to the obstacle's boundary at time(s) ``t``.

        Zero inside.  ``t`` is a scalar or one time per point.
        """
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        centre = self.position(t)
        rel = pts - centre
        if self.kind == "circle":
            return np.maximum(np.hypot(rel[:, 0], rel[:, 1]) - float(self.radius), 0.0)
        return shapely.distance(shapely.points(rel), self.local_geometry)


@dataclass(frozen=True)
class Follower:
    """A follower slot: desired distance ``L`` (map units) and angle ``phi`` (rad).

    Convention (checked against paper Fig. 13 and the ``paper-formation`` start): ``phi`` is
    measured from the leader's *backward* heading, positive to the leader's left, so the slot is
    ``p_L + L * R(theta_L) @ [-cos(phi), sin(phi)]``.  ``phi = 0`` is directly behind.
    """

    id: str
    L: float
    phi: float


@dataclass(frozen=True)
class Formation:
    """Leader-follower (L-phi) formation; ``safety_distance`` is the minimum centre distance."""

    leader: str
    followers: tuple[Follower, ...]
    safety_distance: float

    def slot_offsets(self, heading: float | np.ndarray) -> np.ndarray:
        """Desired follower offsets from the leader, shape ``(..., n_followers, 2)``."""
        th = np.asarray(heading, dtype=float)[..., None]
        L = np.array([f.L for f in self.followers])
        phi = np.array([f.phi for f in self.followers])
        ang = th + np.pi - phi
        return np.stack([L * np.cos(ang), L * np.sin(ang)], axis=-1)


@dataclass(frozen=True, eq=False)
class Problem:
    """A planning scenario.  Build with :func:`parse_problem` / :func:`optplan.load_problem`."""

    name: str
    bounds: tuple[float, float, float, float]
    robots: tuple[Robot, ...]
    obstacles: tuple[Obstacle, ...] = ()
    dynamic_obstacles: tuple[DynamicObstacle, ...] = ()
    formation: Formation | None = None
    sensing_range: float | None = None
    goal_tolerance: float | None = None
    scale: float | None = None
    description: str = ""
    source: str = ""
    tags: tuple[str, ...] = ()
    path: str | None = None
    world_unit: float = 1.0
    """World length of one unit of these coordinates: 1, except for the canonical image of a
    scene (:func:`optplan.canonical.canonical_problem`), whose planners report in world units."""
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    # -- convenience ---------------------------------------------------------------
    def robot(self, rid: str) -> Robot:
        for r in self.robots:
            if r.id == rid:
                return r
        raise KeyError(f"problem {self.name!r} has no robot {rid!r}; robots: {self.robot_ids}")

    @property
    def robot_ids(self) -> list[str]:
        return [r.id for r in self.robots]

    @property
    def leader(self) -> Robot:
        """The formation leader, or the first robot."""
        return self.robot(self.formation.leader) if self.formation else self.robots[0]

    @property
    def planned_robots(self) -> list[Robot]:
        """Robots a path solver plans: the leader with a formation, else every robot."""
        return [self.leader] if self.formation else list(self.robots)

    @property
    def extent(self) -> float:
        """Diagonal length of the bounds (map units)."""
        x0, y0, x1, y1 = self.bounds
        return float(math.hypot(x1 - x0, y1 - y0))

    def static_obstacles(self, known_only: bool = False) -> tuple[Obstacle, ...]:
        return tuple(o for o in self.obstacles if o.known or not known_only)

    def memo(self, key: tuple, build: Callable[[], Any]) -> Any:
        """The value derived from this problem under ``key``, built by ``build()`` once.

        A problem is immutable, so what is derived from it (obstacle sets, the certified
        optimum, the known view) is computed once and kept with it.  ``key`` is a tuple whose
        first item names what is cached (``("obstacle_set", radius, known_only)``); this is the
        only way modules read or write the cache.
        """
        if key not in self._cache:
            self._cache[key] = build()
        return self._cache[key]

    def known_view(self) -> Problem:
        """A copy without temporary (``known = false``) obstacles and without dynamic ones.

        This is the map a global planner is allowed to see (paper §V, step 3).
        """
        import dataclasses

        return self.memo(("known_view",), lambda: dataclasses.replace(
            self, obstacles=self.static_obstacles(known_only=True), dynamic_obstacles=(),
            _cache={}))

    def goal_tol(self, robot: Robot) -> float:
        """Goal tolerance for ``robot`` (map units).

        The scenario's ``goal_tolerance`` when given, else the robot radius; for a point robot
        (``radius = 0``) without ``goal_tolerance`` it is :data:`POINT_GOAL_TOL_REL` ``x``
        :attr:`extent` (``1e-6`` of the bounds diagonal), so that "reached" stays a
        tolerance test rather than exact equality.
        """
        if self.goal_tolerance is not None:
            return float(self.goal_tolerance)
        if robot.radius > 0:
            return float(robot.radius)
        return POINT_GOAL_TOL_REL * self.extent

    def blocking_obstacle(self, point, radius: float, known_only: bool = False) -> int | None:
        """Index (into :meth:`static_obstacles`) of an obstacle a disc at ``point`` overlaps.

        Exact test on the true obstacles (:meth:`obstacle_set`): the disc of ``radius`` at
        ``point`` overlaps an obstacle when the signed distance from ``point`` to it (negative
        inside: minus the distance to its boundary) is ``< radius - eps``.  For ``radius > eps``
        that is ``ObstacleSet.point_distances(point) < radius - eps``; a point robot
        (``radius = 0``) may touch a boundary but not be inside by more than ``eps``.  The most
        deeply overlapped obstacle is returned, ``None`` when the disc is free.

        Raises
        ------
        ValueError
            From the geometry core, for obstacles double precision cannot resolve in this map.
        """
        oset = self.obstacle_set(radius, known_only)
        if oset.n_items == 0:
            return None
        p = np.asarray(point, dtype=float).reshape(1, 2)
        near, dist = oset.nearest(p)
        d = dist[0]
        depth = np.hypot(*(self.frame.local(near[0]) - self.frame.local(p)).T)
        with np.errstate(invalid="ignore"):
            signed = np.where(d > 0, d, -depth)
            bad = np.flatnonzero(signed < float(radius) - self.frame.eps)
        if bad.size == 0:
            return None
        return int(bad[np.argmin(signed[bad])])

    def obstacle_set(self, radius: float, known_only: bool = False, walls: bool = True):
        """The exact collision/clearance engine for a disc of ``radius`` (cached).

        See :class:`optplan.geometry.ObstacleSet`: every solver and the validator use it with
        the bounds as a wall (``walls=True``); the simulator's sensing sees the obstacles
        only (``walls=False``).
        """
        from optplan.geometry import obstacle_set

        # without temporary obstacles the known map is the whole map: one set serves both
        known_only = known_only and any(not o.known for o in self.obstacles)
        key = ("obstacle_set", float(radius), known_only) + (() if walls else ("no walls",))
        return self.memo(key, lambda: obstacle_set(self.static_obstacles(known_only),
                                                   float(radius), self.frame, walls=walls))

    @property
    def frame(self):
        """The local frame and tolerance of this map (:class:`optplan.geometry.Frame`)."""
        from optplan.geometry import Frame

        return self.memo(("frame",), lambda: Frame.from_bounds(self.bounds))

    @property
    def length_scale(self) -> float:
        """The problem's length unit for scale-relative options (map units).

        The scenario's ``length_scale`` key when given; otherwise derived from the map extent,
        ``bounds diagonal / REFERENCE_DIAGONAL`` (1 on a 500 x 500 map, the paper's maps).
        Options of the time-stepping planners marked "x length_scale" (influence distance, SA
        step, rollout, tolerances...) are multiples of it, so the same preset behaves the same on
        a scene drawn in centimetres, metres or kilometres.
        """
        if self.scale is not None:
            return float(self.scale)
        return float(self.frame.length) / REFERENCE_DIAGONAL

    def summary(self) -> str:
        x0, y0, x1, y1 = self.bounds
        n_tmp = sum(not o.known for o in self.obstacles)
        lines = [
            f"{self.name}: {self.description}".rstrip(": "),
            f"  bounds [{x0:g}, {y0:g}] x [{x1:g}, {y1:g}]; {len(self.robots)} robot(s); "
            f"{len(self.obstacles)} static obstacle(s) ({n_tmp} temporary); "
            f"{len(self.dynamic_obstacles)} dynamic",
        ]
        if self.formation:
            fs = ", ".join(f"{f.id} (L={f.L:g}, phi={f.phi:.3f})" for f in self.formation.followers)
            lines.append(f"  formation: leader {self.formation.leader}; followers {fs}")
        if self.source:
            lines.append(f"  source: {self.source}")
        return "\n".join(lines)


#: Bounds diagonal whose derived :attr:`Problem.length_scale` is 1 (the paper's 500 x 500 maps).
REFERENCE_DIAGONAL = 500.0 * math.sqrt(2.0)

#: Default goal tolerance of a point robot, relative to the bounds diagonal (:meth:`goal_tol`).
POINT_GOAL_TOL_REL = 1e-6


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


def _parse_obstacle(ctx: _Ctx, o: Any, i: int) -> Obstacle:
    pre = f"obstacles[{i}]."
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
    ctx.check_keys(o, _OBST_KEYS[kind], pre)
    known = o.get("known", True)
    if not isinstance(known, bool):
        raise ctx.err(f"{pre}known", f"expected true or false, got {_show(known)}")
    name = ctx.string(o, "name", pre, f"obstacle{i}")
    if kind == "circle":
        c = ctx.point(ctx.require(o, "center", pre), f"{pre}center", coord=True)
        r = ctx.number(ctx.require(o, "radius", pre), f"{pre}radius", positive=True, coord=True)
        return Obstacle("circle", None, known, name, center=c, radius=r)
    if kind == "rectangle":
        if ("min" in o or "max" in o) and ("center" in o or "size" in o):
            raise ctx.err(f"{pre}center", "give either min/max or center/size, not both")
        if "min" in o or "max" in o:
            key = f"{pre}min"
            lo = ctx.point(ctx.require(o, "min", pre), f"{pre}min", coord=True)
            hi = ctx.point(ctx.require(o, "max", pre), f"{pre}max", coord=True)
            if np.any(hi <= lo):
                raise ctx.err(f"{pre}max", "rectangle needs min < max in both axes, got "
                              f"{lo.tolist()} {hi.tolist()}")
        else:
            key = f"{pre}center"
            c = ctx.point(ctx.require(o, "center", pre), f"{pre}center", coord=True)
            s = ctx.point(ctx.require(o, "size", pre), f"{pre}size", coord=True)
            lo, hi = c - s / 2, c + s / 2
            if np.any(hi <= lo):
                raise ctx.err(f"{pre}size", f"rectangle needs a size > 0 in both axes (that "
                              f"double precision resolves at its centre), got {s.tolist()}")
        verts = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        return Obstacle("rectangle", ctx.polygon(verts, key), known, name)
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
        c = frame.local(o.center)
        R = float(o.radius)
        if np.any(c + R < lo) or np.any(c - R > hi):
            return
        extent = float(np.max(np.abs(c))) + R
    else:
        wx0, wy0, wx1, wy1 = o.geometry.bounds
        blo, bhi = frame.local([wx0, wy0]), frame.local([wx1, wy1])
        if np.any(bhi < lo) or np.any(blo > hi):
            return
        extent = float(max(np.max(np.abs(blo)), np.max(np.abs(bhi))))
    try:
        frame.check_extent(extent, f"obstacle {o.name!r}")
    except ValueError as e:
        raise ctx.err(key, str(e)) from None


def _parse_dynamic(ctx: _Ctx, o: Any, i: int, frame) -> DynamicObstacle:
    pre = f"dynamic_obstacles[{i}]."
    if not isinstance(o, dict):
        raise ctx.err(f"dynamic_obstacles[{i}]", f"expected a table, got {_show(o)}")
    kind = ctx.require(o, "type", pre)
    if not isinstance(kind, str) or kind not in _DYN_TYPE_KEYS:
        raise ctx.err(f"{pre}type", f"dynamic obstacles are 'circle' or 'polygon', got "
                                    f"{_show(kind)}")
    ctx.check_keys(o, _DYN_TYPE_KEYS[kind], pre)
    radius = None
    if kind == "circle":
        radius = ctx.number(ctx.require(o, "radius", pre), f"{pre}radius", positive=True,
                            coord=True)
        local = Point(0.0, 0.0).buffer(radius, quad_segs=CIRCLE_QUAD_SEGS)
    else:
        verts = ctx.points(ctx.require(o, "vertices", pre), f"{pre}vertices", 3, coord=True)
        local = ctx.polygon(verts, f"{pre}vertices")
    name = ctx.string(o, "name", pre, f"dynamic{i}")
    # the shape and every waypoint must be resolvable in the map's frame (moving obstacles are
    # compared with robots in relative coordinates; one far away has no business in the map)
    size = float(radius) if radius is not None else float(np.max(np.abs(verts)))
    try:
        frame.check_extent(size, f"the shape of dynamic obstacle {name!r}")
    except ValueError as e:
        raise ctx.err(f"{pre}{'radius' if radius is not None else 'vertices'}", str(e)) from None
    wps = ctx.points(ctx.require(o, "waypoints", pre), f"{pre}waypoints", 1, coord=True)
    far = np.max(np.abs(frame.local(wps)), axis=1) + size
    k = int(np.argmax(far))
    try:
        frame.check_extent(float(far[k]), f"dynamic obstacle {name!r} at this waypoint")
    except ValueError as e:
        raise ctx.err(f"{pre}waypoints[{k}]", str(e)) from None
    vmax = MAX_REL_SPEED * frame.length
    velocity = None
    if "velocity" in o:
        velocity = ctx.point(o["velocity"], f"{pre}velocity", coord=True)
        if float(np.hypot(*velocity)) > vmax:
            raise ctx.err(f"{pre}velocity", f"speed {float(np.hypot(*velocity)):.6g} is above "
                          f"{vmax:.6g} ({MAX_REL_SPEED:g} x the bounds diagonal per second)")
        if len(wps) != 1:
            raise ctx.err(f"{pre}waypoints", "with 'velocity' give exactly one start waypoint")
        raw_t = o.get("times", [0.0])
        if not isinstance(raw_t, list) or len(raw_t) != 1:
            raise ctx.err(f"{pre}times", "with 'velocity' give one start time, e.g. times = [0.0]")
        times = np.array([_time(ctx, raw_t[0], f"{pre}times[0]")])
    else:
        raw_t = ctx.require(o, "times", pre)
        if not isinstance(raw_t, list) or len(raw_t) != len(wps):
            got = f"{len(raw_t)}" if isinstance(raw_t, list) else _show(raw_t)
            raise ctx.err(f"{pre}times", f"expected {len(wps)} time stamps (one per waypoint), "
                                         f"got {got}")
        times = np.array([_time(ctx, t, f"{pre}times[{k}]") for k, t in enumerate(raw_t)])
        if np.any(np.diff(times) <= 0):
            raise ctx.err(f"{pre}times", "time stamps must be strictly increasing")
        if len(wps) > 1:
            step = np.hypot(*np.diff(wps, axis=0).T)
            with np.errstate(over="ignore", divide="ignore"):
                speed = step / np.diff(times)
            k = int(np.argmax(speed))
            if not speed[k] <= vmax:
                raise ctx.err(f"{pre}times", f"waypoints {k} -> {k + 1} imply a speed of "
                              f"{speed[k]:.6g}, above {vmax:.6g} ({MAX_REL_SPEED:g} x the bounds "
                              "diagonal per second)")
    after = o.get("after", "hold")
    if not isinstance(after, str) or after not in ("hold", "loop", "bounce"):
        raise ctx.err(f"{pre}after", f"expected 'hold', 'loop' or 'bounce', got {_show(after)}")
    return DynamicObstacle(kind, local, times, wps, velocity, after, name, radius)


def _time(ctx: _Ctx, v: Any, key: str) -> float:
    t = ctx.number(v, key)
    if abs(t) > MAX_TIME:
        raise ctx.err(key, f"magnitude {abs(t):.3g} s is beyond {MAX_TIME:g} s")
    return t


def _parse_formation(ctx: _Ctx, tbl: Any, robots: list[Robot], diag: float) -> Formation:
    if not isinstance(tbl, dict):
        raise ctx.err("formation", f"expected a table, got {_show(tbl)}")
    ctx.check_keys(tbl, _FORM_KEYS, "formation.")
    ids = [r.id for r in robots]
    diag_s = f"the bounds diagonal {diag:.6g}"
    leader = ctx.require(tbl, "leader", "formation.")
    if not isinstance(leader, str):
        raise ctx.err("formation.leader", f"expected a robot id string, got {_show(leader)}")
    if leader not in ids:
        raise ctx.err("formation.leader", f"names no robot: {leader!r} (robots: {sorted(ids)})")
    fl = ctx.require(tbl, "followers", "formation.")
    if not isinstance(fl, list) or not fl:
        got = "an empty list" if isinstance(fl, list) else _show(fl)
        raise ctx.err("formation.followers", f"expected at least one follower table "
                                             f"{{ id = ..., L = ..., phi = ... }}, got {got}")
    followers: list[Follower] = []
    for k, f in enumerate(fl):
        pre = f"formation.followers[{k}]."
        if not isinstance(f, dict):
            raise ctx.err(f"formation.followers[{k}]", f"expected a table, got {_show(f)}")
        ctx.check_keys(f, _FOLL_KEYS, pre)
        fid = ctx.require(f, "id", pre)
        if not isinstance(fid, str):
            raise ctx.err(f"{pre}id", f"expected a robot id string, got {_show(fid)}")
        if fid in {x.id for x in followers}:
            raise ctx.err(f"{pre}id", f"follower {fid!r} is listed twice")
        if fid not in ids:
            raise ctx.err(f"{pre}id", f"names no robot: {fid!r} (robots: {sorted(ids)})")
        if fid == leader:
            raise ctx.err(f"{pre}id", f"the leader {leader!r} cannot also be a follower")
        L = ctx.number(ctx.require(f, "L", pre), f"{pre}L", positive=True, hi=diag,
                       hi_what=diag_s)
        phi = ctx.number(ctx.require(f, "phi", pre), f"{pre}phi")
        if abs(phi) > math.pi:
            raise ctx.err(f"{pre}phi", f"must be in [-pi, pi] rad, got {phi}")
        followers.append(Follower(fid, L, phi))
    rmax = max(r.radius for r in robots)
    if "safety_distance" not in tbl and rmax == 0:
        raise ctx.err("formation.safety_distance", "missing: the default 2 x the largest "
                      "robot radius is 0 for point robots; give safety_distance > 0")
    sd = ctx.number(tbl.get("safety_distance", 2 * rmax), "formation.safety_distance",
                    positive=True, hi=diag, hi_what=diag_s)
    return Formation(leader, tuple(followers), sd)


def parse_problem(data: dict, where: str = "<problem>") -> Problem:
    """Build and validate a :class:`Problem` from a parsed TOML table.

    Raises
    ------
    ProblemError
        Naming ``where`` (the file) and the offending key.
    """
    ctx = _Ctx(where)
    if not isinstance(data, dict):
        raise ctx.err("<root>", f"expected a table, got {_show(data)}")
    try:
        return _parse(ctx, data)
    except RecursionError:  # defensive: nothing above recurses into the values
        raise ctx.err("<root>", "values nested too deeply") from None


def _parse_bounds(ctx: _Ctx, data: dict) -> tuple[tuple[float, ...], Any]:
    """The ``bounds`` key: (xmin, ymin, xmax, ymax) and the map's :class:`Frame`."""
    b = ctx.require(data, "bounds", "")
    if not isinstance(b, list) or len(b) != 4:
        raise ctx.err("bounds", f"expected [xmin, ymin, xmax, ymax], got {_show(b)}")
    bounds = tuple(ctx.number(v, f"bounds[{k}]") for k, v in enumerate(b))
    if bounds[0] >= bounds[2] or bounds[1] >= bounds[3]:
        raise ctx.err("bounds", f"need xmin < xmax and ymin < ymax, got {list(bounds)}")
    w, h = bounds[2] - bounds[0], bounds[3] - bounds[1]
    if max(w, h) > MAX_ASPECT * min(w, h):
        raise ctx.err("bounds", f"a {w:.3g} x {h:.3g} map: the longer side may be at most "
                                f"{MAX_ASPECT:g} x the shorter one")
    from optplan.geometry import Frame

    try:
        frame = Frame.from_bounds(bounds)
    except ValueError as e:
        raise ctx.err("bounds", str(e)) from None
    return bounds, frame


def _parse_robot(ctx: _Ctx, r: Any, i: int, robots: list[Robot], diag: float) -> Robot:
    """One ``[[robots]]`` table (``goal`` may be None: checked later, see
    :func:`_check_goals`)."""
    diag_s = f"the bounds diagonal {diag:.6g}"
    pre = f"robots[{i}]."
    if not isinstance(r, dict):
        raise ctx.err(f"robots[{i}]", f"expected a table, got {_show(r)}")
    ctx.check_keys(r, _ROBOT_KEYS, pre)
    rid = ctx.require(r, "id", pre)
    if not isinstance(rid, str) or not rid:
        raise ctx.err(f"{pre}id", f"expected a non-empty string, got {_show(rid)}")
    if rid in {x.id for x in robots}:
        raise ctx.err(f"{pre}id", f"duplicate robot id {rid!r}")
    start = ctx.point(ctx.require(r, "start", pre), f"{pre}start")
    goal = ctx.point(r["goal"], f"{pre}goal") if "goal" in r else None
    radius = ctx.number(ctx.require(r, "radius", pre), f"{pre}radius", nonneg=True,
                        hi=diag, hi_what=diag_s)
    vmax = ctx.number(r.get("max_speed", 1.0), f"{pre}max_speed", positive=True,
                      hi=MAX_REL_SPEED * diag,
                      hi_what=f"{MAX_REL_SPEED:g} x {diag_s} per second")
    if vmax < MIN_REL_SPEED * diag:
        raise ctx.err(f"{pre}max_speed", f"must be >= {MIN_REL_SPEED * diag:.6g} "
                      f"({MIN_REL_SPEED:g} x {diag_s} per second: crossing the map may "
                      f"take at most {1 / MIN_REL_SPEED:g} s), got {vmax:.6g}"
                      + (" (the default)" if "max_speed" not in r else ""))
    return Robot(rid, start, goal, radius, vmax)


def _parse_robots(ctx: _Ctx, data: dict, diag: float) -> list[Robot]:
    """The ``[[robots]]`` tables (at least one)."""
    raw_robots = ctx.require(data, "robots", "")
    if not isinstance(raw_robots, list) or not raw_robots:
        raise ctx.err("robots", "expected at least one [[robots]] table")
    robots: list[Robot] = []
    for i, r in enumerate(raw_robots):
        robots.append(_parse_robot(ctx, r, i, robots, diag))
    return robots


def _check_goals(ctx: _Ctx, robots: list[Robot], formation: Formation | None) -> None:
    """Every robot but a formation follower needs a goal (checked after the formation, so a
    broken formation is reported as such, not as a follower's missing goal)."""
    followers = {f.id for f in formation.followers} if formation else set()
    for i, r in enumerate(robots):
        if r.goal is None and r.id not in followers:
            why = (f"robot {r.id!r} is not a formation follower" if formation else
                   "only formation followers may omit it")
            raise ctx.err(f"robots[{i}].goal", f"missing required key ({why})")


def _check_periods(ctx: _Ctx, dyn: tuple[DynamicObstacle, ...], robots: list[Robot],
                   diag: float) -> None:
    """Periodic dynamic obstacles: not faster than the validator can follow
    (:data:`MIN_REL_PERIOD`)."""
    from optplan.geometry.motion import mover_period

    slow = min(robots, key=lambda r: r.max_speed)
    t_cross = diag / slow.max_speed
    for i, d in enumerate(dyn):
        period = mover_period(d)
        if period is not None and period < MIN_REL_PERIOD * t_cross:
            raise ctx.err(f"dynamic_obstacles[{i}].times", f"the {d.after} period {period:.6g} s "
                          f"is shorter than {MIN_REL_PERIOD:g} x the {t_cross:.6g} s robot "
                          f"{slow.id!r} needs to cross the map (bounds diagonal / its max_speed)")


def _parse_sensing(ctx: _Ctx, data: dict, diag: float) -> float | None:
    """The ``[sensing]`` table: its range, or None."""
    if "sensing" not in data:
        return None
    st = data["sensing"]
    if not isinstance(st, dict):
        raise ctx.err("sensing", f"expected a table, got {_show(st)}")
    ctx.check_keys(st, _SENS_KEYS, "sensing.")
    return ctx.number(ctx.require(st, "range", "sensing."), "sensing.range", positive=True,
                      hi=MAX_REL_SPEED * diag,
                      hi_what=f"{MAX_REL_SPEED:g} x the bounds diagonal {diag:.6g}")


def _parse_lengths(ctx: _Ctx, data: dict, diag: float) -> tuple[float | None, float | None]:
    """The ``goal_tolerance`` and ``length_scale`` keys (None when absent)."""
    diag_s = f"the bounds diagonal {diag:.6g}"
    gtol = None
    if "goal_tolerance" in data:
        gtol = ctx.number(data["goal_tolerance"], "goal_tolerance", positive=True, hi=diag,
                          hi_what=diag_s)
    lscale = None
    if "length_scale" in data:
        lscale = ctx.number(data["length_scale"], "length_scale", positive=True, hi=diag,
                            hi_what=diag_s)
        if lscale < 1e-6 * diag:
            raise ctx.err("length_scale", f"must be >= {1e-6 * diag:.6g} (1e-6 x {diag_s}), "
                          f"got {lscale:.6g}")
    return gtol, lscale


def _parse_tags(ctx: _Ctx, data: dict) -> tuple[str, ...]:
    """The ``tags`` key: a list of strings."""
    tags = data.get("tags", [])
    if not isinstance(tags, list):
        raise ctx.err("tags", f"expected a list of strings, got {_show(tags)}")
    for k, t in enumerate(tags):
        if not isinstance(t, str):
            raise ctx.err(f"tags[{k}]", f"expected a string, got {_show(t)}")
    return tuple(tags)


def _check_ends(ctx: _Ctx, prob: Problem) -> None:
    """Starts and goals: inside the bounds with the robot's disc (the bounds are a wall) and
    clear of every static obstacle (exact test)."""
    frame = prob.frame
    for i, r in enumerate(prob.robots):
        for key, p in (("start", r.start), ("goal", r.goal)):
            if p is None:
                continue
            if not frame.in_bounds(p)[0]:
                raise ctx.err(f"robots[{i}].{key}",
                              f"{p.tolist()} lies outside the bounds {list(prob.bounds)}")
            x0, y0, x1, y1 = prob.bounds
            edge = min(p[0] - x0, x1 - p[0], p[1] - y0, y1 - p[1])
            if edge < r.radius - frame.eps:
                raise ctx.err(f"robots[{i}].{key}",
                              f"{p.tolist()} is {edge:.6g} from the edge of the bounds "
                              f"{list(prob.bounds)}, less than the robot radius {r.radius:g} "
                              "(the bounds are a wall for the robot's disc)")
            try:
                hit = prob.blocking_obstacle(p, r.radius)
            except ValueError as e:  # the core's precision checks (normally caught above)
                raise ctx.err("obstacles", str(e)) from None
            if hit is not None:
                how = (f"inflated by the robot radius {r.radius:g}" if r.radius > 0
                       else "(a point robot, radius 0)")
                raise ctx.err(f"robots[{i}].{key}", f"{p.tolist()} lies inside obstacle "
                              f"{prob.obstacles[hit].name!r} (obstacles[{hit}]) {how}")


def _parse(ctx: _Ctx, data: dict) -> Problem:
    """Parse a scenario table, one parser per key or table, in the order the errors are
    reported."""
    where = ctx.where
    ctx.check_keys(data, _TOP_KEYS, "")
    name = ctx.string(data, "name", "")
    description = ctx.string(data, "description", "", "")
    source = ctx.string(data, "source", "", "")
    bounds, frame = _parse_bounds(ctx, data)
    diag = frame.length
    for key in ("obstacles", "dynamic_obstacles", "robots"):
        if key in data and not isinstance(data[key], list):
            raise ctx.err(key, f"expected an array of tables: write [[{key}]] for each entry")
    obstacles = tuple(_parse_obstacle(ctx, o, i) for i, o in enumerate(data.get("obstacles", [])))
    dyn = tuple(_parse_dynamic(ctx, o, i, frame)
                for i, o in enumerate(data.get("dynamic_obstacles", [])))
    robots = _parse_robots(ctx, data, diag)
    formation = None
    if "formation" in data:
        formation = _parse_formation(ctx, data["formation"], robots, diag)
    _check_goals(ctx, robots, formation)
    _check_periods(ctx, dyn, robots, diag)
    sensing = _parse_sensing(ctx, data, diag)
    gtol, lscale = _parse_lengths(ctx, data, diag)
    tags = _parse_tags(ctx, data)
    prob = Problem(
        name=name, bounds=bounds, robots=tuple(robots), obstacles=obstacles,
        dynamic_obstacles=dyn, formation=formation, sensing_range=sensing,
        goal_tolerance=gtol, scale=lscale, description=description, source=source,
        tags=tags,
        path=where if where != "<problem>" else None,
    )
    prob.memo(("frame",), lambda: frame)  # already built by the checks above
    # obstacles reaching into the working region must be resolvable in the map's frame
    margin = max(r.radius for r in robots) + frame.length
    raw_obst = data.get("obstacles", [])
    for i, o in enumerate(obstacles):
        _check_extent(ctx, frame, o, _extent_key(raw_obst[i], i), margin)
    _check_ends(ctx, prob)
    return prob


def read_problem(path: str | Path) -> Problem:
    """Read and validate a scenario TOML file."""
    p = Path(path)
    if p.is_dir():
        raise ProblemError(f"{p}: is a directory, not a scenario file")
    try:
        size = p.stat().st_size
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror or e})") from None
    if size > MAX_FILE_BYTES:
        raise ProblemError(f"{p}: file of {size / 2**20:.1f} MB is larger than the "
                           f"{MAX_FILE_BYTES // 2**20} MB a scenario may have")
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise ProblemError(f"{p}: not UTF-8 text ({e.reason} at byte {e.start}); TOML files "
                           "are UTF-8") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ProblemError(f"{p}: invalid TOML: {e}") from None
    except RecursionError:
        raise ProblemError(f"{p}: invalid TOML: arrays or inline tables nested too deeply "
                           "for the TOML reader") from None
    return parse_problem(data, str(p))


# --------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------


def ring_points(ring) -> list[list[float]]:
    """Vertices of a shapely ring as ``[[x, y], ...]`` without the closing repeat."""
    return [[float(x), float(y)] for x, y in list(ring.coords)[:-1]]


def _robot_to_dict(r: Robot) -> dict[str, Any]:
    """The ``[[robots]]`` table of ``r``."""
    t: dict[str, Any] = {"id": r.id, "start": [float(v) for v in r.start]}
    if r.goal is not None:
        t["goal"] = [float(v) for v in r.goal]
    t["radius"] = float(r.radius)
    t["max_speed"] = float(r.max_speed)
    return t


def _obstacle_to_dict(o: Obstacle) -> dict[str, Any]:
    """The ``[[obstacles]]`` table of ``o``."""
    t: dict[str, Any] = {"type": o.kind, "name": o.name}
    if o.is_circle:
        t["center"] = [float(v) for v in o.center]
        t["radius"] = float(o.radius)
    elif o.kind == "rectangle":
        x0, y0, x1, y1 = o.geometry.bounds
        t["min"], t["max"] = [x0, y0], [x1, y1]
    else:
        t["vertices"] = ring_points(o.geometry.exterior)
        if o.geometry.interiors:
            t["holes"] = [ring_points(h) for h in o.geometry.interiors]
    if not o.known:
        t["known"] = False
    return t


def _dynamic_to_dict(d: DynamicObstacle) -> dict[str, Any]:
    """The ``[[dynamic_obstacles]]`` table of ``d``."""
    t: dict[str, Any] = {"type": d.kind, "name": d.name}
    if d.kind == "circle":
        t["radius"] = float(d.radius)
    else:
        t["vertices"] = ring_points(d.local_geometry.exterior)
    t["waypoints"] = [[float(x), float(y)] for x, y in d.waypoints]
    t["times"] = [float(x) for x in d.times]
    if d.velocity is not None:
        t["velocity"] = [float(v) for v in d.velocity]
    else:
        t["after"] = d.after
    return t


def _header_to_dict(problem: Problem) -> dict[str, Any]:
    """The top-level keys of ``problem``'s scenario table (before ``[formation]``)."""
    out: dict[str, Any] = {"name": problem.name}
    if problem.description:
        out["description"] = problem.description
    if problem.source:
        out["source"] = problem.source
    if problem.tags:
        out["tags"] = list(problem.tags)
    out["bounds"] = [float(v) for v in problem.bounds]
    if problem.goal_tolerance is not None:
        out["goal_tolerance"] = float(problem.goal_tolerance)
    if problem.scale is not None:
        out["length_scale"] = float(problem.scale)
    if problem.sensing_range is not None:
        out["sensing"] = {"range": float(problem.sensing_range)}
    return out


def problem_to_dict(problem: Problem) -> dict[str, Any]:
    """The scenario table of ``problem``: what :func:`parse_problem` reads back into an equal
    problem (every key of the TOML format it uses; numbers as Python floats)."""
    out = _header_to_dict(problem)
    if problem.formation is not None:
        f = problem.formation
        out["formation"] = {
            "leader": f.leader, "safety_distance": float(f.safety_distance),
            "followers": [{"id": x.id, "L": float(x.L), "phi": float(x.phi)}
                          for x in f.followers]}
    out["robots"] = [_robot_to_dict(r) for r in problem.robots]
    obstacles = [_obstacle_to_dict(o) for o in problem.obstacles]
    if obstacles:
        out["obstacles"] = obstacles
    dyn = [_dynamic_to_dict(d) for d in problem.dynamic_obstacles]
    if dyn:
        out["dynamic_obstacles"] = dyn
    return out


def round_decimals(x, decimals: int) -> np.ndarray:
    """``x`` rounded to ``decimals`` decimal places: ``rint(x * 10**d) / 10**d``, so a value
    written with at most ``d`` decimals maps to itself exactly (the canonical frame)."""
    ten = 10.0 ** int(decimals)
    return np.rint(np.asarray(x, dtype=float) * ten) / ten


def transform_problem(problem: Problem, scale: float = 1.0, shift=(0.0, 0.0), *,
                      decimals: int | None = None) -> Problem:
    """``problem`` with every length scaled by ``scale`` about the origin, then shifted.

    Positions, sizes, radii, speeds, formation distances, tolerances and sensing range scale
    (times do not), so every answer of a scale- and translation-invariant method is the same up
    to the scale (the metamorphic tests use it).  With ``decimals``, every transformed coordinate
    and length is then rounded to that many decimal places (the canonical frame,
    :mod:`optplan.canonical`).  The caches of the copy are empty.
    """
    import dataclasses

    s = float(scale)
    if not (s > 0 and math.isfinite(s)):
        raise ValueError(f"scale must be a finite number > 0, got {scale!r}")
    off = np.asarray(shift, dtype=float).reshape(2)
    def rnd(x):
        return x if decimals is None else round_decimals(x, decimals)

    def length(v):
        return None if v is None else float(rnd(v * s))

    def vec(v):  # a displacement or velocity: scaled, not shifted
        return None if v is None else rnd(np.asarray(v, float) * s)

    def pt(p):
        return None if p is None else rnd(np.asarray(p, float) * s + off)

    def geom(g, shifted=True):
        if g is None:
            return None
        return shapely.transform(g, (lambda c: rnd(c * s + off)) if shifted
                                 else (lambda c: rnd(c * s)))

    robots = tuple(dataclasses.replace(r, start=pt(r.start), goal=pt(r.goal),
                                       radius=length(r.radius), max_speed=length(r.max_speed))
                   for r in problem.robots)
    obstacles = tuple(dataclasses.replace(
        o, geometry=geom(o.geometry), center=pt(o.center), radius=length(o.radius))
        for o in problem.obstacles)
    dyn = tuple(dataclasses.replace(
        d, local_geometry=geom(d.local_geometry, shifted=False), waypoints=pt(d.waypoints),
        velocity=vec(d.velocity), radius=length(d.radius)) for d in problem.dynamic_obstacles)
    form = problem.formation
    if form is not None:
        form = Formation(form.leader, tuple(Follower(f.id, length(f.L), f.phi)
                                            for f in form.followers),
                         length(form.safety_distance))
    lo, hi = pt(problem.bounds[:2]), pt(problem.bounds[2:])
    return dataclasses.replace(
        problem, bounds=(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])),
        robots=robots, obstacles=obstacles, dynamic_obstacles=dyn, formation=form,
        goal_tolerance=length(problem.goal_tolerance),
        sensing_range=length(problem.sensing_range), scale=length(problem.scale),
        _cache={})
