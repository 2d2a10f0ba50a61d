"""The TOML scenario format (problems/README.md): :func:`parse_problem`, :func:`read_problem`.

Every key is checked with its unit and range; every error raises :class:`ProblemError` naming
the file and the key.

The formation's parsers share their parameters' names: ``ctx`` the parsing context (file
name, error messages), ``tbl`` the ``[formation]`` table, ``robots`` the parsed robots and
``ids`` their ids, ``diag`` the bounds diagonal (the upper bound of ``L`` and
``safety_distance``) and ``diag_s`` how messages name it, ``f`` a ``formation.followers``
table, ``k`` its index, ``pre`` its key prefix (``formation.followers[k].``), ``followers``
the followers parsed before it and ``leader`` the leader's id.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

from optplan.problem.context import _FOLL_KEYS, _FORM_KEYS, _ROBOT_KEYS, _SENS_KEYS, _TOP_KEYS, _Ctx
from optplan.problem.model import (
    MAX_ASPECT,
    MAX_FILE_BYTES,
    MAX_REL_SPEED,
    MIN_REL_PERIOD,
    MIN_REL_SPEED,
    DynamicObstacle,
    Follower,
    Formation,
    Problem,
    ProblemError,
    Robot,
    _show,
)
from optplan.problem.parse_obstacles import (
    _check_extent,
    _extent_key,
    _parse_dynamic,
    _parse_obstacle,
)
from optplan.problem.parse_roadmap import _check_roadmap_ends, _parse_roadmap


def _parse_formation(ctx: _Ctx, tbl: Any, robots: list[Robot], diag: float) -> Formation:
    """The ``[formation]`` table: leader, followers and safety distance."""
    if not isinstance(tbl, dict):
        raise ctx.err("formation", f"expected a table, got {_show(tbl)}")
    ctx.check_keys(tbl, _FORM_KEYS, "formation.")
    ids = [r.id for r in robots]
    diag_s = f"the bounds diagonal {diag:.6g}"
    leader = _formation_leader(ctx, tbl, ids)
    fl = ctx.require(tbl, "followers", "formation.")
    if not isinstance(fl, list) or not fl:
        got = "an empty list" if isinstance(fl, list) else _show(fl)
        raise ctx.err("formation.followers", f"expected at least one follower table "
                                             f"{{ id = ..., L = ..., phi = ... }}, got {got}")
    followers: list[Follower] = []
    for k, f in enumerate(fl):
        followers.append(_parse_follower(ctx, f, k, followers, ids, leader, diag, diag_s))
    sd = _safety_distance(ctx, tbl, robots, diag, diag_s)
    return Formation(leader, tuple(followers), sd)


def _formation_leader(ctx: _Ctx, tbl: dict, ids: list[str]) -> str:
    """The checked ``formation.leader``: the id of a robot."""
    leader = ctx.require(tbl, "leader", "formation.")
    if not isinstance(leader, str):
        raise ctx.err("formation.leader", f"expected a robot id string, got {_show(leader)}")
    if leader not in ids:
        raise ctx.err("formation.leader", f"names no robot: {leader!r} (robots: {sorted(ids)})")
    return leader


def _parse_follower(ctx: _Ctx, f: Any, k: int, followers: list[Follower], ids: list[str],
                    leader: str, diag: float, diag_s: str) -> Follower:
    """One ``formation.followers`` table: ``id``, ``L`` and ``phi``."""
    pre = f"formation.followers[{k}]."
    if not isinstance(f, dict):
        raise ctx.err(f"formation.followers[{k}]", f"expected a table, got {_show(f)}")
    ctx.check_keys(f, _FOLL_KEYS, pre)
    fid = _follower_id(ctx, f, pre, followers, ids, leader)
    L = ctx.number(ctx.require(f, "L", pre), f"{pre}L", positive=True, hi=diag,
                   hi_what=diag_s)
    phi = ctx.number(ctx.require(f, "phi", pre), f"{pre}phi")
    if abs(phi) > math.pi:
        raise ctx.err(f"{pre}phi", f"must be in [-pi, pi] rad, got {phi}")
    return Follower(fid, L, phi)


def _follower_id(ctx: _Ctx, f: dict, pre: str, followers: list[Follower], ids: list[str],
                 leader: str) -> str:
    """The checked ``id`` of a follower: a robot, listed once, not the leader."""
    fid = ctx.require(f, "id", pre)
    if not isinstance(fid, str):
        raise ctx.err(f"{pre}id", f"expected a robot id string, got {_show(fid)}")
    if fid in {x.id for x in followers}:
        raise ctx.err(f"{pre}id", f"follower {fid!r} is listed twice")
    if fid not in ids:
        raise ctx.err(f"{pre}id", f"names no robot: {fid!r} (robots: {sorted(ids)})")
    if fid == leader:
        raise ctx.err(f"{pre}id", f"the leader {leader!r} cannot also be a follower")
    return fid


def _safety_distance(ctx: _Ctx, tbl: dict, robots: list[Robot], diag: float,
                     diag_s: str) -> float:
    """The checked ``formation.safety_distance`` (default: 2 x the largest robot radius)."""
    rmax = max(r.radius for r in robots)
    if "safety_distance" not in tbl and rmax == 0:
        raise ctx.err("formation.safety_distance", "missing: the default 2 x the largest "
                      "robot radius is 0 for point robots; give safety_distance > 0")
    return ctx.number(tbl.get("safety_distance", 2 * rmax), "formation.safety_distance",
                      positive=True, hi=diag, hi_what=diag_s)


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


def _parse_bounds(ctx: _Ctx, data: dict) -> tuple[tuple[float, float, float, float], Any]:
    """The ``bounds`` key: (xmin, ymin, xmax, ymax) and the map's :class:`Frame`."""
    b = ctx.require(data, "bounds", "")
    if not isinstance(b, list) or len(b) != 4:
        raise ctx.err("bounds", f"expected [xmin, ymin, xmax, ymax], got {_show(b)}")
    bx0, by0, bx1, by1 = (ctx.number(v, f"bounds[{k}]") for k, v in enumerate(b))
    bounds = (bx0, by0, bx1, by1)
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
    from optplan.geometry.timing.motion import mover_period

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
    roadmap = _parse_roadmap(ctx, data["roadmap"], frame) if "roadmap" in data else None
    prob = Problem(
        name=name, bounds=bounds, robots=tuple(robots), obstacles=obstacles,
        dynamic_obstacles=dyn, formation=formation, sensing_range=sensing,
        goal_tolerance=gtol, scale=lscale, description=description, source=source,
        tags=tags, roadmap=roadmap,
        path=where if where != "<problem>" else None,
    )
    prob.memo(("frame",), lambda: frame)  # already built by the checks above
    # obstacles reaching into the working region must be resolvable in the map's frame
    margin = max(r.radius for r in robots) + frame.length
    raw_obst = data.get("obstacles", [])
    for i, o in enumerate(obstacles):
        _check_extent(ctx, frame, o, _extent_key(raw_obst[i], i), margin)
    _check_ends(ctx, prob)
    _check_roadmap_ends(ctx, prob)
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
