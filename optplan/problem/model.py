"""The problem model: robots, static and moving obstacles, formations, the :class:`Problem`.

A :class:`Problem` is an immutable description of a 2-D workspace: rectangular bounds,
disc robots (radius ``>= 0``; ``0`` is a point robot) with start/goal, static obstacles
(polygons with optional holes, rectangles, circles; each either *known* to a global planner or
*temporary*), dynamic obstacles moving along time-stamped waypoints or with a constant velocity,
an optional leader-follower formation and an optional sensing range.

Static obstacles are kept exactly: polygons as the vertices the user wrote (shapely
``Polygon``), circles as centre and radius (never polygonised).  Collision and clearance
questions go to the one exact engine, :meth:`Problem.obstacle_set`
(:class:`optplan.geometry.ObstacleSet`).  The scenario format that builds them is
:mod:`optplan.problem.scenario`.
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Polygon

from optplan.problem.roadmap import RoadmapGraph

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

    def disc(self) -> tuple[np.ndarray, float]:
        """``(center, radius)`` of a circle (``ValueError`` for a polygon or rectangle)."""
        if not self.is_circle or self.center is None or self.radius is None:
            raise ValueError(f"obstacle {self.name!r} ({self.kind}) is not a circle with a "
                             "center and a radius")
        return self.center, self.radius

    def polygon(self) -> Polygon:
        """The shapely ``geometry`` of a polygon or rectangle (``ValueError`` for a circle)."""
        if self.geometry is None:
            raise ValueError(f"obstacle {self.name!r} ({self.kind}) has no polygon geometry")
        return self.geometry

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """Exact axis-aligned bounding box ``(xmin, ymin, xmax, ymax)`` (world coordinates)."""
        if self.is_circle:
            center, radius = self.disc()
            cx, cy = (float(v) for v in center)
            r = float(radius)
            return (cx - r, cy - r, cx + r, cy + r)
        x0, y0, x1, y1 = (float(v) for v in self.polygon().bounds)
        return (x0, y0, x1, y1)


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

    def circle_radius(self) -> float:
        """The ``radius`` of a circle (``ValueError`` for a polygon)."""
        if self.kind != "circle" or self.radius is None:
            raise ValueError(f"dynamic obstacle {self.name!r} ({self.kind}) is not a circle "
                             "with a radius")
        return float(self.radius)

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Reference position at time(s) ``t``; shape ``(2,)`` or ``(len(t), 2)``.

        The motion model of ``problems/README.md``, evaluated on the one track of
        :func:`optplan.geometry.timing.motion.mover_track` (right-continuous: at a ``loop`` period
        boundary the obstacle is at its first waypoint).
        """
        from optplan.geometry.timing.motion import mover_position

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
            return np.maximum(np.hypot(rel[:, 0], rel[:, 1]) - self.circle_radius(), 0.0)
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
    roadmap: RoadmapGraph | None = None
    """The graph that confines the robots of a multi-agent path-finding instance
    (:mod:`optplan.problem.roadmap`), else ``None``: the robots move in the plane."""
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
        only way modules read or write the cache (:meth:`replaced` copies part of it).
        """
        if key not in self._cache:
            self._cache[key] = build()
        return self._cache[key]

    def replaced(self, keep: tuple[str, ...] = (), **changes: Any) -> Problem:
        """A copy with ``changes`` (:func:`dataclasses.replace`) that shares only the cached
        values named in ``keep`` (the first item of a :meth:`memo` key, e.g. ``"frame"``):
        the rest may depend on what changed, and is built again when asked for."""
        import dataclasses

        shared = {k: v for k, v in self._cache.items() if k[0] in keep}
        return dataclasses.replace(self, _cache=shared, **changes)

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
        only (``walls=False``).  Problems with the same static map (obstacles and bounds, by
        digest) share one set per process, and with it the map's tangent graph
        (:mod:`optplan.problem.shared`: bounded, least recently used dropped).
        """
        from optplan.geometry import obstacle_set
        from optplan.problem.shared import problem_digest, shared_set

        # without temporary obstacles the known map is the whole map: one set serves both
        known_only = known_only and any(not o.known for o in self.obstacles)
        key = ("obstacle_set", float(radius), known_only) + (() if walls else ("no walls",))

        def make():
            digest = problem_digest(self.obstacles, known_only, self.bounds)
            return shared_set((digest, float(radius), known_only, bool(walls)),
                              lambda: obstacle_set(self.static_obstacles(known_only),
                                                   float(radius), self.frame, walls=walls))

        return self.memo(key, make)

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
        if self.roadmap is not None:
            lines.append(f"  roadmap: {len(self.roadmap)} nodes, {len(self.roadmap.edges)} "
                         "edges (the robots drive its edges and wait at its nodes)")
        if self.source:
            lines.append(f"  source: {self.source}")
        return "\n".join(lines)


#: Bounds diagonal whose derived :attr:`Problem.length_scale` is 1 (the paper's 500 x 500 maps).
REFERENCE_DIAGONAL = 500.0 * math.sqrt(2.0)

#: Default goal tolerance of a point robot, relative to the bounds diagonal (:meth:`goal_tol`).
POINT_GOAL_TOL_REL = 1e-6
