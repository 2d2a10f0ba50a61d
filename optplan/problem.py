"""Problem model and the TOML scenario format (design §3).

A :class:`Problem` is an immutable description of a 2-D workspace: rectangular bounds,
disc robots with start/goal, static obstacles (polygons, rectangles, circles; each either
*known* to a global planner or *temporary*), dynamic obstacles moving along time-stamped
waypoints or with a constant velocity, an optional leader-follower formation and an optional
sensing range.  ``problems/README.md`` documents every key with its unit.

All parsing errors raise :class:`ProblemError` naming the file and the key.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
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
]

#: Segments per quarter circle used to polygonise circles (shapely ``quad_segs``).
CIRCLE_QUAD_SEGS = 16


class ProblemError(ValueError):
    """A scenario (or an option) is malformed; the message names the file and key."""


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
        Disc radius (map units); obstacles are inflated by it.
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

    ``kind`` is ``"polygon"``, ``"rectangle"`` or ``"circle"``.  ``geometry`` is the shapely
    polygon (circles polygonised with :data:`CIRCLE_QUAD_SEGS`); circles also keep their exact
    ``center`` and ``radius``.  ``known = False`` marks a temporary obstacle that global planners
    do not see but local planners and the validator do.
    """

    kind: str
    geometry: Polygon
    known: bool = True
    name: str = ""
    center: np.ndarray | None = None
    radius: float | None = None

    @property
    def is_circle(self) -> bool:
        return self.kind == "circle"


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
        """Reference position at time(s) ``t``; shape ``(2,)`` or ``(len(t), 2)``."""
        tt = np.asarray(t, dtype=float)
        scalar = tt.ndim == 0
        tt = np.atleast_1d(tt)
        if self.velocity is not None:
            out = self.waypoints[0][None, :] + (tt - self.times[0])[:, None] * self.velocity
        else:
            t0, t1 = self.times[0], self.times[-1]
            span = t1 - t0
            if span > 0 and self.after == "loop":
                tt = t0 + np.mod(tt - t0, span)
            elif span > 0 and self.after == "bounce":
                ph = np.mod(tt - t0, 2 * span)
                tt = t0 + np.where(ph > span, 2 * span - ph, ph)
            out = np.stack(
                [np.interp(tt, self.times, self.waypoints[:, k]) for k in range(2)], axis=1
            )
        return out[0] if scalar else out

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
    description: str = ""
    source: str = ""
    tags: tuple[str, ...] = ()
    path: str | None = None
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

    def known_view(self) -> Problem:
        """A copy without temporary (``known = false``) obstacles and without dynamic ones.

        This is the map a global planner is allowed to see (paper §V, step 3).
        """
        key = ("known_view",)
        if key not in self._cache:
            self._cache[key] = Problem(
                name=self.name,
                bounds=self.bounds,
                robots=self.robots,
                obstacles=self.static_obstacles(known_only=True),
                dynamic_obstacles=(),
                formation=self.formation,
                sensing_range=self.sensing_range,
                goal_tolerance=self.goal_tolerance,
                description=self.description,
                source=self.source,
                tags=self.tags,
                path=self.path,
            )
        return self._cache[key]

    def goal_tol(self, robot: Robot) -> float:
        """Goal tolerance for ``robot``: the scenario's ``goal_tolerance`` or the robot radius."""
        return float(self.goal_tolerance if self.goal_tolerance is not None else robot.radius)

    def inflated(self, radius: float, mode: str = "inscribed", known_only: bool = False):
        """Obstacles inflated by ``radius`` (cached); see :func:`optplan.geometry.inflate`."""
        from optplan.geometry_old import inflate

        key = ("inflated", round(float(radius), 12), mode, known_only)
        if key not in self._cache:
            self._cache[key] = inflate(
                self.static_obstacles(known_only), radius, mode=mode, bounds=self.bounds
            )
        return self._cache[key]

    def obstacle_set(self, radius: float, known_only: bool = False):
        """The exact collision/clearance engine for a disc of ``radius`` (cached).

        See :class:`optplan.geometry.ObstacleSet`: every solver, the validator and the
        simulator's sensing use it.
        """
        from optplan.geometry import obstacle_set

        key = ("obstacle_set", float(radius), known_only)
        if key not in self._cache:
            self._cache[key] = obstacle_set(self.static_obstacles(known_only), float(radius),
                                            self.frame)
        return self._cache[key]

    @property
    def frame(self):
        """The local frame and tolerance of this map (:class:`optplan.geometry.Frame`)."""
        from optplan.geometry import Frame

        if "frame" not in self._cache:
            self._cache["frame"] = Frame.from_bounds(self.bounds)
        return self._cache["frame"]

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
    "robots": "array of tables",
    "obstacles": "array of tables",
    "dynamic_obstacles": "array of tables",
    "formation": "table",
    "sensing": "table",
}
_ROBOT_KEYS = {"id", "start", "goal", "radius", "max_speed"}
_OBST_KEYS = {
    "polygon": {"type", "vertices", "known", "name"},
    "rectangle": {"type", "min", "max", "center", "size", "known", "name"},
    "circle": {"type", "center", "radius", "known", "name"},
}
_DYN_KEYS = {"type", "radius", "vertices", "waypoints", "times", "velocity", "after", "name"}
_FORM_KEYS = {"leader", "followers", "safety_distance"}
_FOLL_KEYS = {"id", "L", "phi"}
_SENS_KEYS = {"range"}


class _Ctx:
    """Carries the file name for error messages."""

    def __init__(self, where: str):
        self.where = where

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

    def number(self, v: Any, key: str, *, positive: bool = False, nonneg: bool = False) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(key, f"expected a number, got {v!r}")
        x = float(v)
        if not math.isfinite(x):
            raise self.err(key, f"must be finite, got {v!r}")
        if positive and x <= 0:
            raise self.err(key, f"must be > 0, got {v!r}")
        if nonneg and x < 0:
            raise self.err(key, f"must be >= 0, got {v!r}")
        return x

    def point(self, v: Any, key: str) -> np.ndarray:
        if not isinstance(v, list) or len(v) != 2:
            raise self.err(key, f"expected a point [x, y], got {v!r}")
        return np.array([self.number(v[0], f"{key}[0]"), self.number(v[1], f"{key}[1]")])

    def points(self, v: Any, key: str, min_len: int) -> np.ndarray:
        if not isinstance(v, list) or len(v) < min_len:
            raise self.err(key, f"expected a list of at least {min_len} points [x, y]")
        return np.array([self.point(p, f"{key}[{i}]") for i, p in enumerate(v)])

    def polygon(self, verts: np.ndarray, key: str) -> Polygon:
        if len(verts) >= 2 and np.allclose(verts[0], verts[-1]):
            verts = verts[:-1]
        if len(verts) < 3:
            raise self.err(key, "a polygon needs at least 3 distinct vertices")
        poly = Polygon(verts)
        if not poly.is_valid:
            reason = shapely.is_valid_reason(poly)
            raise self.err(key, f"polygon is degenerate or self-intersecting ({reason})")
        if poly.area <= 0:
            raise self.err(key, "polygon has zero area")
        return shapely.geometry.polygon.orient(poly, 1.0)


def _parse_obstacle(ctx: _Ctx, o: Any, i: int) -> Obstacle:
    pre = f"obstacles[{i}]."
    if not isinstance(o, dict):
        raise ctx.err(f"obstacles[{i}]", "expected a table")
    kind = ctx.require(o, "type", pre)
    if kind not in _OBST_KEYS:
        close = difflib.get_close_matches(str(kind), list(_OBST_KEYS), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ctx.err(f"{pre}type", f"unknown obstacle type {kind!r}{hint} "
                      f"(allowed: {', '.join(_OBST_KEYS)})")
    ctx.check_keys(o, _OBST_KEYS[kind], pre)
    known = o.get("known", True)
    if not isinstance(known, bool):
        raise ctx.err(f"{pre}known", f"expected true or false, got {known!r}")
    name = str(o.get("name", f"obstacle{i}"))
    if kind == "circle":
        c = ctx.point(ctx.require(o, "center", pre), f"{pre}center")
        r = ctx.number(ctx.require(o, "radius", pre), f"{pre}radius", positive=True)
        geom = Point(c).buffer(r, quad_segs=CIRCLE_QUAD_SEGS)
        return Obstacle("circle", geom, known, name, center=c, radius=r)
    if kind == "rectangle":
        if ("min" in o or "max" in o) and ("center" in o or "size" in o):
            raise ctx.err(f"{pre}center", "give either min/max or center/size, not both")
        if "min" in o or "max" in o:
            lo = ctx.point(ctx.require(o, "min", pre), f"{pre}min")
            hi = ctx.point(ctx.require(o, "max", pre), f"{pre}max")
        else:
            c = ctx.point(ctx.require(o, "center", pre), f"{pre}center")
            s = ctx.point(ctx.require(o, "size", pre), f"{pre}size")
            lo, hi = c - s / 2, c + s / 2
        if np.any(hi <= lo):
            raise ctx.err(f"{pre}max", "rectangle needs min < max in both axes, got "
                          f"{lo.tolist()} {hi.tolist()}")
        verts = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        return Obstacle("rectangle", ctx.polygon(verts, pre + "min"), known, name)
    verts = ctx.points(ctx.require(o, "vertices", pre), f"{pre}vertices", 3)
    return Obstacle("polygon", ctx.polygon(verts, f"{pre}vertices"), known, name)


def _parse_dynamic(ctx: _Ctx, o: Any, i: int) -> DynamicObstacle:
    pre = f"dynamic_obstacles[{i}]."
    if not isinstance(o, dict):
        raise ctx.err(f"dynamic_obstacles[{i}]", "expected a table")
    ctx.check_keys(o, _DYN_KEYS, pre)
    kind = ctx.require(o, "type", pre)
    radius = None
    if kind == "circle":
        radius = ctx.number(ctx.require(o, "radius", pre), f"{pre}radius", positive=True)
        local = Point(0.0, 0.0).buffer(radius, quad_segs=CIRCLE_QUAD_SEGS)
    elif kind == "polygon":
        verts = ctx.points(ctx.require(o, "vertices", pre), f"{pre}vertices", 3)
        local = ctx.polygon(verts, f"{pre}vertices")
    else:
        raise ctx.err(f"{pre}type", f"dynamic obstacles are 'circle' or 'polygon', got {kind!r}")
    wps = ctx.points(ctx.require(o, "waypoints", pre), f"{pre}waypoints", 1)
    velocity = None
    if "velocity" in o:
        velocity = ctx.point(o["velocity"], f"{pre}velocity")
        if len(wps) != 1:
            raise ctx.err(f"{pre}waypoints", "with 'velocity' give exactly one start waypoint")
        raw_t = o.get("times", [0.0])
        if not isinstance(raw_t, list) or len(raw_t) != 1:
            raise ctx.err(f"{pre}times", "with 'velocity' give one start time, e.g. times = [0.0]")
        times = np.array([ctx.number(raw_t[0], f"{pre}times[0]")])
    else:
        raw_t = ctx.require(o, "times", pre)
        if not isinstance(raw_t, list) or len(raw_t) != len(wps):
            raise ctx.err(f"{pre}times", f"expected {len(wps)} time stamps (one per waypoint)")
        times = np.array([ctx.number(t, f"{pre}times[{k}]") for k, t in enumerate(raw_t)])
        if np.any(np.diff(times) <= 0):
            raise ctx.err(f"{pre}times", "time stamps must be strictly increasing")
    after = o.get("after", "hold")
    if after not in ("hold", "loop", "bounce"):
        raise ctx.err(f"{pre}after", f"expected 'hold', 'loop' or 'bounce', got {after!r}")
    return DynamicObstacle(kind, local, times, wps, velocity, after,
                           str(o.get("name", f"dynamic{i}")), radius)


def parse_problem(data: dict, where: str = "<problem>") -> Problem:
    """Build and validate a :class:`Problem` from a parsed TOML table.

    Raises
    ------
    ProblemError
        Naming ``where`` (the file) and the offending key.
    """
    ctx = _Ctx(where)
    if not isinstance(data, dict):
        raise ctx.err("<root>", "expected a table")
    ctx.check_keys(data, _TOP_KEYS, "")
    name = str(ctx.require(data, "name", ""))
    b = ctx.require(data, "bounds", "")
    if not isinstance(b, list) or len(b) != 4:
        raise ctx.err("bounds", "expected [xmin, ymin, xmax, ymax]")
    bounds = tuple(ctx.number(v, f"bounds[{k}]") for k, v in enumerate(b))
    if bounds[0] >= bounds[2] or bounds[1] >= bounds[3]:
        raise ctx.err("bounds", f"need xmin < xmax and ymin < ymax, got {list(bounds)}")
    box = shapely.box(*bounds)

    for key in ("obstacles", "dynamic_obstacles", "robots"):
        if key in data and not isinstance(data[key], list):
            raise ctx.err(key, f"expected an array of tables: write [[{key}]] for each entry")
    obstacles = tuple(_parse_obstacle(ctx, o, i) for i, o in enumerate(data.get("obstacles", [])))
    dyn = tuple(_parse_dynamic(ctx, o, i) for i, o in enumerate(data.get("dynamic_obstacles", [])))

    raw_robots = ctx.require(data, "robots", "")
    if not isinstance(raw_robots, list) or not raw_robots:
        raise ctx.err("robots", "expected at least one [[robots]] table")
    formation_tbl = data.get("formation")
    follower_ids: set[str] = set()
    if isinstance(formation_tbl, dict):
        fl_raw = formation_tbl.get("followers", [])
        follower_ids = {f.get("id") for f in (fl_raw if isinstance(fl_raw, list) else [])
                        if isinstance(f, dict) and isinstance(f.get("id"), str)}
    robots: list[Robot] = []
    for i, r in enumerate(raw_robots):
        pre = f"robots[{i}]."
        if not isinstance(r, dict):
            raise ctx.err(f"robots[{i}]", "expected a table")
        ctx.check_keys(r, _ROBOT_KEYS, pre)
        rid = ctx.require(r, "id", pre)
        if not isinstance(rid, str) or not rid:
            raise ctx.err(f"{pre}id", f"expected a non-empty string, got {rid!r}")
        if rid in {x.id for x in robots}:
            raise ctx.err(f"{pre}id", f"duplicate robot id {rid!r}")
        start = ctx.point(ctx.require(r, "start", pre), f"{pre}start")
        goal = None
        if "goal" in r or rid not in follower_ids:
            goal = ctx.point(ctx.require(r, "goal", pre), f"{pre}goal")
        radius = ctx.number(ctx.require(r, "radius", pre), f"{pre}radius", positive=True)
        vmax = ctx.number(r.get("max_speed", 1.0), f"{pre}max_speed", positive=True)
        robots.append(Robot(rid, start, goal, radius, vmax))

    formation = None
    if formation_tbl is not None:
        if not isinstance(formation_tbl, dict):
            raise ctx.err("formation", "expected a table")
        ctx.check_keys(formation_tbl, _FORM_KEYS, "formation.")
        ids = {r.id for r in robots}
        leader = ctx.require(formation_tbl, "leader", "formation.")
        if leader not in ids:
            raise ctx.err("formation.leader", f"names no robot: {leader!r} (robots: {sorted(ids)})")
        fl = ctx.require(formation_tbl, "followers", "formation.")
        if not isinstance(fl, list) or not fl:
            raise ctx.err("formation.followers", "expected at least one follower table")
        followers = []
        for k, f in enumerate(fl):
            pre = f"formation.followers[{k}]."
            if not isinstance(f, dict):
                raise ctx.err(f"formation.followers[{k}]", "expected a table")
            ctx.check_keys(f, _FOLL_KEYS, pre)
            fid = ctx.require(f, "id", pre)
            if not isinstance(fid, str):
                raise ctx.err(f"{pre}id", f"expected a robot id string, got {fid!r}")
            if fid in {x.id for x in followers}:
                raise ctx.err(f"{pre}id", f"follower {fid!r} is listed twice")
            if fid not in ids:
                raise ctx.err(f"{pre}id", f"names no robot: {fid!r} (robots: {sorted(ids)})")
            if fid == leader:
                raise ctx.err(f"{pre}id", "the leader cannot also be a follower")
            L = ctx.number(ctx.require(f, "L", pre), f"{pre}L", positive=True)
            phi = ctx.number(ctx.require(f, "phi", pre), f"{pre}phi")
            if abs(phi) > math.pi:
                raise ctx.err(f"{pre}phi", f"must be in [-pi, pi] rad, got {phi}")
            followers.append(Follower(fid, L, phi))
        rmax = max(r.radius for r in robots)
        sd = ctx.number(formation_tbl.get("safety_distance", 2 * rmax),
                        "formation.safety_distance", positive=True)
        formation = Formation(leader, tuple(followers), sd)

    sensing = None
    if "sensing" in data:
        st = data["sensing"]
        if not isinstance(st, dict):
            raise ctx.err("sensing", "expected a table")
        ctx.check_keys(st, _SENS_KEYS, "sensing.")
        sensing = ctx.number(ctx.require(st, "range", "sensing."), "sensing.range", positive=True)
    gtol = None
    if "goal_tolerance" in data:
        gtol = ctx.number(data["goal_tolerance"], "goal_tolerance", positive=True)
    tags = data.get("tags", [])
    if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
        raise ctx.err("tags", "expected a list of strings")

    prob = Problem(
        name=name, bounds=bounds, robots=tuple(robots), obstacles=obstacles,
        dynamic_obstacles=dyn, formation=formation, sensing_range=sensing,
        goal_tolerance=gtol, description=str(data.get("description", "")),
        source=str(data.get("source", "")), tags=tuple(tags),
        path=where if where != "<problem>" else None,
    )
    # starts and goals: inside bounds and outside the inflated static obstacles
    for i, r in enumerate(robots):
        infl = prob.inflated(r.radius)
        for key, p in (("start", r.start), ("goal", r.goal)):
            if p is None:
                continue
            if not box.covers(Point(p)):
                raise ctx.err(f"robots[{i}].{key}",
                              f"{p.tolist()} lies outside the bounds {list(bounds)}")
            hit = infl.containing(p)
            if hit is not None:
                raise ctx.err(
                    f"robots[{i}].{key}",
                    f"{p.tolist()} lies inside obstacle {hit!r} inflated by the robot radius "
                    f"{r.radius:g}",
                )
    return prob


def read_problem(path: str | Path) -> Problem:
    """Read and validate a scenario TOML file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ProblemError(f"{p}: invalid TOML: {e}") from None
    return parse_problem(data, str(p))
