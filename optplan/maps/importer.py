"""An occupancy map -> a Problem (:func:`import_map`): world polygons, robots' ends, the
import's record."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from optplan.maps.checks import check_cells, check_unknown, err, number
from optplan.maps.grid import FREE, OCCUPIED, UNKNOWN, Grid
from optplan.maps.occupancy import read_grid
from optplan.maps.options import PolygonOptions, ReadOptions, Robots, SceneOptions, checked
from optplan.maps.polygons import _polys, grid_polygons
from optplan.problem import Problem, parse_problem, ring_points

#: World coordinates of imported polygons are rounded to this fraction of the map's size
#: (decimal digits; far below the geometric tolerance ``1e-9 x`` the bounds diagonal).
ROUND_REL = 1e-12

#: ``crop="auto"`` crops a map whose cells outside the bounding box of its known (free or
#: occupied) cells, all unknown, are more than this share of the image.
CROP_MARGIN = 0.25

#: File stems that say nothing of the map (``map_saver`` writes ``map.yaml`` and ``map.pgm``):
#: the scene is named after the nearest directory that says more.
_GENERIC_STEMS = frozenset({"map", "maps", "image", "occupancy", "grid"})


def _digits(grid: Grid) -> int:
    """Decimal digits of ``ROUND_REL x`` the map size."""
    size = max(grid.width, grid.height) * grid.resolution
    return max(0, -math.floor(math.log10(ROUND_REL * size)))


def _world(grid: Grid, q: Polygon) -> Polygon:
    """A polygon in cell units in world coordinates, rounded to ``ROUND_REL x`` the map size
    (``20.025`` rather than ``20.025000000000006`` in the written scenario)."""
    digits = _digits(grid)
    w = grid.to_world(q)
    return shapely.transform(w, lambda xy: np.round(xy, digits))


def _clean(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-.")


def scene_name(path: str | Path) -> str:
    """The default name of a scene imported from ``path``: the file's stem, or, when the stem
    says nothing of the map (``map.yaml`` as ``map_saver`` writes it, ``image``, ``grid``...),
    the name of the nearest directory above it that does (``turtlebot3_world/map.yaml`` ->
    ``turtlebot3_world``); characters other than letters, digits, ``_ . -`` become ``-``."""
    p = Path(path)
    stem = _clean(p.stem)
    if stem and stem.lower() not in _GENERIC_STEMS:
        return stem
    for part in reversed(p.absolute().parent.parts):
        d = _clean(part)
        if d and d.lower() not in _GENERIC_STEMS:
            return d
    return stem or "map"


def _crop_switch(where: str, crop: Any) -> bool | str:
    """``crop`` as ``"auto"``, True or False: a bool (``numpy.bool_`` too) or ``"auto"``;
    anything else, a number such as 0 or 1 included (a margin? a switch?), is an error."""
    if isinstance(crop, (bool, np.bool_)):
        return bool(crop)
    if isinstance(crop, str) and crop == "auto":
        return "auto"
    why = "; a number is not accepted: crop is a switch, not a margin" if isinstance(
        crop, (int, float, np.number)) else ""
    raise err(where, "crop", f"expected 'auto', True or False, got {crop!r} "
                             f"({type(crop).__name__}{why})")


def _crop(where: str, grid: Grid, crop: Any, unknown: str) -> tuple[Grid, dict[str, Any]]:
    """The grid cropped to the bounding box of its known cells (``crop=True``; ``"auto"``:
    when the unknown margin outside it is more than ``CROP_MARGIN`` of the image and unknown
    cells are obstacles) and what was measured."""
    crop = _crop_switch(where, crop)
    known = grid.cells != UNKNOWN
    rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
    if not len(rows):
        return grid, {"cropped": False, "margin": 1.0}
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    margin = 1.0 - (r1 - r0) * (c1 - c0) / (grid.height * grid.width)
    info: dict[str, Any] = {"cropped": False, "margin": margin, "rows": [r0, r1],
                            "cols": [c0, c1], "shape": [grid.height, grid.width]}
    auto_no = crop == "auto" and (unknown == "free" or margin <= CROP_MARGIN)
    if crop is False or auto_no or margin == 0.0:
        return grid, info
    x, y = np.round(grid.cell_to_world([c0, grid.height - r1])[0], _digits(grid))
    cut = dataclasses.replace(grid, cells=grid.cells[r0:r1, c0:c1].copy(),
                              origin=(float(x), float(y), grid.origin[2]))
    info["cropped"] = True
    return cut, info


def _check_ends_inside(where: str, grid: Grid, starts: np.ndarray, goals: np.ndarray) -> None:
    """Every start and goal lies in the cropped grid (only fails with ``unknown="free"``)."""
    for k in range(len(starts)):
        for key, q in (("start", starts[k]), ("goal", goals[k])):
            if grid.cell_of(q) is None:
                raise err(where, f"robots[{k}].{key}", f"{q.tolist()} lies outside the known "
                          f"part of the map {list(grid.bounds)}; pass crop=False")


def _fill_unreachable(polys: list[Polygon], points: np.ndarray) -> tuple[list[Polygon], int]:
    """Fill the holes that contain none of ``points`` and drop polygons then covered."""
    pts = shapely.points(points) if len(points) else []
    filled = 0
    out = []
    for q in polys:
        keep = []
        for ring in q.interiors:
            hole = Polygon(ring)
            if len(pts) and np.any(shapely.covers(hole, pts)):
                keep.append(ring)
            else:
                filled += 1
        out.append(Polygon(q.exterior, keep) if len(keep) != len(q.interiors) else q)
    if filled:
        tree = shapely.STRtree(out)
        drop = set()
        for i, q in enumerate(out):
            for j in tree.query(q, predicate="covered_by"):
                if j != i and j not in drop and out[j].area >= q.area:
                    drop.add(i)
                    break
        out = [q for i, q in enumerate(out) if i not in drop]
    return out, filled


def _polygon_table(q: Polygon, name: str) -> dict[str, Any]:
    t: dict[str, Any] = {"type": "polygon", "name": name, "vertices": ring_points(q.exterior)}
    if q.interiors:
        t["holes"] = [ring_points(h) for h in q.interiors]
    return t


def _points(v: Any, where: Any, key: str) -> np.ndarray:
    """One point ``(x, y)`` or a list of points -> ``(n, 2)``."""
    if isinstance(v, str):
        v = [float(t) for t in v.replace(",", " ").split()]
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise err(where, key, f"expected a point (x, y) or a list of points, got {v!r}") from None
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2 or a.shape[1] != 2 or not np.all(np.isfinite(a)):
        raise err(where, key, f"expected a point (x, y) or a list of points, got {v!r}")
    return a


def _check_vector_args(where: str, polygons: PolygonOptions, radius: Any) -> float:
    """Validate the polygon options of :func:`import_map`; the radius."""
    grow, simplify, join = polygons.grow, polygons.simplify, polygons.join
    for key, v in (("grow", grow), ("simplify", simplify)):
        x = number(v, where, key)
        if x < 0:
            raise err(where, key, f"must be >= 0 (cells), got {v!r}")
        if x > 4:
            raise err(where, key, f"{v!r} cells is coarser than the map; use at most 4")
    if simplify > 0 and grow == 0:
        raise err(where, "simplify", "needs grow > 0 (a simplified polygon without growth "
                                     "cannot cover every cell); pass simplify=0")
    if join not in ("round", "mitre"):
        raise err(where, "join", f"expected 'round' or 'mitre', got {join!r}")
    r = number(radius, where, "radius")
    if r < 0:
        raise err(where, "radius", f"must be >= 0, got {radius!r}")
    return r


def _robot_ends(where: str, robots: Robots) -> tuple[np.ndarray, np.ndarray, list]:
    """Starts, goals and robot ids of :func:`import_map` (one robot per start/goal pair)."""
    starts, goals = _points(robots.start, where, "start"), _points(robots.goal, where, "goal")
    if len(starts) != len(goals):
        raise err(where, "goal", f"{len(starts)} start(s) but {len(goals)} goal(s)")
    if robots.ids is None:
        ids = ["r1"] if len(starts) == 1 else [f"r{k + 1}" for k in range(len(starts))]
    else:
        ids = [robots.ids] if isinstance(robots.ids, str) else list(robots.ids)
    if len(ids) != len(starts):
        raise err(where, "robot", f"{len(ids)} robot id(s) for {len(starts)} start(s)")
    return starts, goals, ids


def _check_ends_free(where: str, grid: Grid, mask: np.ndarray, starts: np.ndarray,
                     goals: np.ndarray) -> None:
    """Every start and goal lies in a free cell of the map (the radius check is the parser's
    exact test)."""
    for k in range(len(starts)):
        for key, q in (("start", starts[k]), ("goal", goals[k])):
            cell = grid.cell_of(q)
            if cell is None:
                raise err(where, f"robots[{k}].{key}", f"{q.tolist()} lies outside the map "
                                                         f"{list(grid.bounds)}")
            if mask[cell]:
                state = "unknown" if grid.cells[cell] == UNKNOWN else "occupied"
                raise err(where, f"robots[{k}].{key}",
                          f"{q.tolist()} lies in an {state} cell (row {cell[0]}, column "
                          f"{cell[1]}) of the map")


def _map_obstacles(grid: Grid, polys: list, stem: str, unknown: str) -> list[dict]:
    """Obstacle tables of the polygons, plus the unknown corners of a rotated map."""
    obstacles = [_polygon_table(q, f"{stem}-{k}") for k, q in enumerate(polys)]
    if grid.origin[2] != 0.0 and unknown == "occupied":
        # the corners of the bounding box outside the rotated image are unknown
        outside = box(*grid.bounds).difference(grid.outline)
        obstacles += [_polygon_table(q, f"{stem}-outside-{k}") for k, q in
                      enumerate(_polys(outside)) if q.area > 1e-12 * grid.outline.area]
    return obstacles


def _optional_keys(data: dict[str, Any], scene: SceneOptions) -> None:
    """Add the optional scenario keys that were given."""
    if scene.goal_tolerance is not None:
        data["goal_tolerance"] = scene.goal_tolerance
    if scene.dynamic_obstacles:
        data["dynamic_obstacles"] = [dict(d) for d in scene.dynamic_obstacles]
    if scene.sensing_range is not None:
        data["sensing"] = {"range": scene.sensing_range}


def _import_info(grid: Grid, stats: dict, polys: list, holes_filled: int,
                 obstacles: list[dict]) -> dict[str, Any]:
    """What ``import_map(info=...)`` receives."""
    return dict(stats, polygons=len(polys), holes_filled=holes_filled,
                vertices=sum(len(o["vertices"]) + sum(len(h) for h in o.get("holes", ()))
                             for o in obstacles),
                cells={"occupied": int(np.sum(grid.cells == OCCUPIED)),
                       "unknown": int(np.sum(grid.cells == UNKNOWN)),
                       "free": int(np.sum(grid.cells == FREE))})


def import_map(path: str | Path, robots: Robots, *, read: ReadOptions | None = None,
               polygons: PolygonOptions | None = None, scene: SceneOptions | None = None,
               fill_unreachable: bool = True, grid: Grid | None = None,
               info: dict | None = None) -> Problem:
    """Import an occupancy map as a validated :class:`~optplan.Problem`.

    Parameters
    ----------
    path : path
        ``.yaml``/``.yml`` (ROS ``map_server``), ``.map`` (MovingAI) or an image (PNG, PGM...;
        then ``read.resolution`` is required and ``read.origin`` defaults to ``(0, 0)``).
    robots : Robots
        The robots: ``start``, ``goal`` (one robot per pair), ``radius``, ``ids``,
        ``max_speed``.
    read : ReadOptions, optional
        How the map is read and which cells count: the image options (``resolution``,
        ``origin``, ``negate``, ``occupied_thresh``, ``free_thresh``, ``mode``), ``unknown``
        (what unknown cells are, default ``"occupied"``), ``crop`` (default ``"auto"``:
        crop to the known cells when the unknown margin is more than ``CROP_MARGIN`` of the
        image) and ``max_cells``; default ``ReadOptions()``.
    polygons : PolygonOptions, optional
        ``grow``, ``simplify`` (cells) and ``join`` (:func:`grid_polygons`); default
        ``PolygonOptions()`` (0.5, 0.5, ``"round"``).
    scene : SceneOptions, optional
        The scenario's ``name`` (default :func:`scene_name` of ``path``), ``description``,
        ``source``, ``tags``, ``goal_tolerance``, ``sensing_range`` and
        ``dynamic_obstacles``; default ``SceneOptions()``.
    fill_unreachable : bool
        Fill the holes of obstacles that contain no start or goal (free regions no robot can
        reach: closed rooms, voids in walls) and drop the obstacles inside them.  Still
        conservative; fewer vertices.
    grid : Grid, optional
        An already read grid (``path`` then only names the source in messages); at most
        ``read.max_cells`` cells, as a map read from a file.
    info : dict, optional
        Receives ``components``, ``polygons``, ``vertices``, ``holes_filled``, ``fallbacks``,
        ``tolerance_min``, ``cells`` (occupied, unknown, free counts, of the cropped map)
        and ``crop`` (``cropped``, ``margin``: the share of the image outside the known
        cells' box, ``rows``, ``cols``: that box, ``shape``: the image's rows and columns).

    Raises
    ------
    ProblemError
        For every bad input, naming the file and the option (a start or goal in an
        obstacle: ``robots[i].start``).
    """
    p = Path(path)
    where = str(p)
    robots = checked(where, "robots", robots, Robots)
    read = checked(where, "read", read, ReadOptions, ReadOptions())
    polygons = checked(where, "polygons", polygons, PolygonOptions, PolygonOptions())
    scene = checked(where, "scene", scene, SceneOptions, SceneOptions())
    unknown, max_cells = read.unknown, read.max_cells
    check_unknown(unknown, where)
    if grid is None:
        extra = {"negate": read.negate, "occupied_thresh": read.occupied_thresh,
                 "free_thresh": read.free_thresh, "mode": read.mode}
        extra = {k: v for k, v in extra.items() if v is not None}
        grid = read_grid(p, resolution=read.resolution, origin=read.origin,
                         max_cells=max_cells, **extra)
    else:  # the limit of the readers, for an in-memory grid too
        grid = checked(where, "grid", grid, Grid)
        check_cells(where, "grid", grid.height, grid.width, max_cells, "the grid: ")
    r = _check_vector_args(where, polygons, robots.radius)
    starts, goals, ids = _robot_ends(where, robots)
    _check_ends_free(where, grid, grid.obstacle_mask(unknown), starts, goals)
    full = (grid.width, grid.height)
    grid, crop_info = _crop(where, grid, read.crop, unknown)
    _check_ends_inside(where, grid, starts, goals)
    mask = grid.obstacle_mask(unknown)
    stats: dict[str, Any] = {}
    grow, simplify = polygons.grow, polygons.simplify
    polys = [_world(grid, q) for q in grid_polygons(mask, grow=grow, simplify=simplify,
                                                     join=polygons.join, stats=stats)]
    holes_filled = 0
    if fill_unreachable:
        polys, holes_filled = _fill_unreachable(polys, np.vstack([starts, goals]))
    stem = scene_name(p)
    name = scene.name or stem
    obstacles = _map_obstacles(grid, polys, stem, unknown)
    res = grid.resolution
    cut = f", cropped from {full[0]} x {full[1]}" if crop_info["cropped"] else ""
    data: dict[str, Any] = {
        "name": name,
        "description": scene.description or f"imported from {p.name} ({grid.width} x "
                                            f"{grid.height} cells of {res:g}{cut})",
        "source": scene.source or f"optplan.maps.import_map({p.name!r}, grow={grow:g} cells, "
                                  f"simplify={simplify:g} cells, unknown={unknown!r})",
        "tags": list(scene.tags),
        "bounds": list(grid.bounds),
        "robots": [{"id": ids[k], "start": starts[k].tolist(), "goal": goals[k].tolist(),
                    "radius": r, "max_speed": robots.max_speed} for k in range(len(starts))],
        "obstacles": obstacles,
    }
    _optional_keys(data, scene)
    prob = parse_problem(data, where)
    if info is not None:
        info.update(_import_info(grid, stats, polys, holes_filled, obstacles), crop=crop_info)
    return prob
