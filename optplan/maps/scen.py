"""MovingAI ``.scen`` files -> Problems (one robot per entry) and their octile lengths."""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from optplan.maps.checks import err
from optplan.maps.grid import Grid
from optplan.maps.importer import _polygon_table, _world
from optplan.maps.movingai import read_movingai
from optplan.maps.options import PolygonOptions, checked
from optplan.maps.polygons import grid_polygons
from optplan.problem import Problem, ProblemError, parse_problem


@dataclass(frozen=True)
class ScenEntry:
    """One line of a MovingAI ``.scen`` file (cells: column ``x``, row ``y`` from the top)."""

    bucket: int
    map: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal_length: float
    line: int


def read_scen_entries(path: str | Path) -> list[ScenEntry]:
    """Parse a MovingAI ``.scen`` file (``version 1`` header, tab-separated lines
    ``bucket map width height start_x start_y goal_x goal_y optimal_length``).

    A leading UTF-8 byte order mark, blank lines (anywhere), white space around the fields
    and a line's trailing white space (a carriage return of a Windows line end included) are
    ignored.  The first line may be a version line: MovingAI defines ``version 1`` (also
    written ``version 1.0``); any other version is an error.  A line is an error naming the
    file and the line when it has not 9 fields (text after the optimal length is an error
    that shows it), a field is not a number, the map size is not positive, a start or goal
    cell lies outside the line's ``width x height`` map, or the optimal length is ``nan``,
    infinite or negative.
    """
    p = Path(path)
    try:
        lines = p.read_text(encoding="utf-8-sig").splitlines()
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise ProblemError(f"{p}: not UTF-8 text ({e.reason} at byte {e.start}): expected a "
                           "MovingAI .scen file") from None
    out = []
    first = True
    for k, ln in enumerate(lines, start=1):
        if not ln.strip():
            continue
        if first and ln.split()[0].lower() == "version":
            _check_version(p, k, ln)
            first = False
            continue
        first = False
        out.append(_scen_line(p, k, ln))
    if not out:
        raise err(p, "<file>", "no scenario lines")
    return out


#: the versions of the ``.scen`` format MovingAI defines (``version 1``; ``1.0`` is the same)
SCEN_VERSIONS = ("1", "1.0")


def _check_version(p: Path, k: int, ln: str) -> None:
    """A ``version`` line names a version MovingAI defines (:data:`SCEN_VERSIONS`)."""
    parts = ln.split()
    if len(parts) != 2 or parts[1] not in SCEN_VERSIONS:
        raise err(p, f"line {k}", f"unsupported version line {ln.strip()[:60]!r} (allowed: "
                                  f"'version 1' or 'version 1.0', the MovingAI .scen "
                                  f"format's)")


def _scen_fields(p: Path, k: int, ln: str) -> list[str]:
    """The 9 fields of a line: tab-separated (white space when the line has no tab), white
    space around them dropped; text after the 9th is an error that shows it."""
    parts = ln.split("\t") if "\t" in ln else ln.split()
    parts = [t.strip() for t in parts if t.strip() != ""]
    if len(parts) == 9:  # text after the optimal length, separated by a blank, not a tab
        parts = parts[:8] + parts[8].split()
    if len(parts) > 9:
        raise err(p, f"line {k}", f"text after the 9 fields (bucket map width height "
                                  f"start_x start_y goal_x goal_y optimal_length): "
                                  f"{' '.join(parts[9:])[:60]!r} (only trailing white space "
                                  f"is allowed)")
    if len(parts) != 9:
        raise err(p, f"line {k}", f"expected 9 fields (bucket map width height start_x "
                                  f"start_y goal_x goal_y optimal_length), got {len(parts)}")
    return parts


def _scen_line(p: Path, k: int, ln: str) -> ScenEntry:
    """One line of a ``.scen`` file, checked (see :func:`read_scen_entries`)."""
    parts = _scen_fields(p, k, ln)
    try:
        b, w, h, sx, sy, gx, gy = (int(parts[i]) for i in (0, 2, 3, 4, 5, 6, 7))
        opt = float(parts[8])
    except ValueError:
        raise err(p, f"line {k}", f"non-numeric field in {ln.strip()[:80]!r}") from None
    if w < 1 or h < 1:
        raise err(p, f"line {k}", f"map size {w} x {h}: expected positive integers")
    for what, (x, y) in (("start", (sx, sy)), ("goal", (gx, gy))):
        if not (0 <= x < w and 0 <= y < h):
            raise err(p, f"line {k}", f"{what} cell ({x}, {y}) lies outside the {w} x {h} map")
    if not (math.isfinite(opt) and opt >= 0):
        raise err(p, f"line {k}", f"optimal length {parts[8]!r}: expected a finite number "
                                  ">= 0")
    return ScenEntry(b, parts[1], w, h, (sx, sy), (gx, gy), opt, k)


def _check_one_map(p: Path, entries: list[ScenEntry]) -> None:
    """Every line names the map the first line names (compared by file name)."""
    name = Path(entries[0].map).name
    for e in entries:
        if Path(e.map).name != name:
            raise err(p, f"line {e.line}", f"names the map {e.map!r}, line {entries[0].line} "
                                           f"names {entries[0].map!r}: one .scen file is for "
                                           "one map")


_OCTILE_RE = re.compile(r"octile length ([0-9.eE+-]+)")
_LINE_RE = re.compile(r"^MovingAI (.+) line (\d+): bucket (-?\d+),")


def scen_line_of(problem: Problem) -> tuple[str, int, int] | None:
    """``(.scen file name, line, bucket)`` of a problem made by :func:`read_scen` (kept in
    its description, :func:`_entry_keys`), or ``None``."""
    m = _LINE_RE.match(problem.description or "")
    return (m.group(1), int(m.group(2)), int(m.group(3))) if m else None


def scen_octile_length(problem: Problem) -> float | None:
    """The ``.scen`` optimal (octile, 8-connected grid) length of a problem made by
    :func:`read_scen`, in map units (kept in its description), or ``None``."""
    m = _OCTILE_RE.search(problem.description)
    return float(m.group(1)) if m else None


#: :func:`read_scen`'s polygon options: ``grow = 0.25``, ``simplify = 0.2`` cells keep every
#: cell-centre path of the 8-connected grid free for a point robot (``grow + simplify < 0.5``)
SCEN_POLYGONS = PolygonOptions(grow=0.25, simplify=0.2)


def read_scen(path: str | Path, *, map_path: str | Path | None = None, radius: float = 0.0,
              max_speed: float = 1.0, resolution: float = 1.0,
              origin: Sequence[float] = (0.0, 0.0), polygons: PolygonOptions = SCEN_POLYGONS,
              buckets: Iterable[int] | None = None, limit: int | None = None) -> list[Problem]:
    """A MovingAI ``.scen`` as a list of problems, one per line (a batch for ``bench``:
    :func:`write_batch` writes them as scenario files).

    Each problem has one robot (radius ``radius``, a point by default; ``max_speed``) from the
    centre of the start cell to the centre of the goal cell, the map's obstacles imported once
    (:func:`grid_polygons` with ``polygons``, default :data:`SCEN_POLYGONS`: ``grow = 0.25``,
    ``simplify = 0.2`` cells keep every cell-centre path of the 8-connected grid free for a
    point robot, since ``grow + simplify < 0.5``), the name ``<scen stem>-<line>`` and the
    description ``"... octile length L ..."`` with the ``.scen`` optimum in map units
    (:func:`scen_octile_length`).  The map is ``map_path`` or the ``.scen`` file's ``map``
    field, looked up next to the ``.scen`` file (as written, then by its base name), read with
    ``resolution`` and ``origin`` (:func:`read_movingai`); ``buckets`` and ``limit`` select
    lines.
    """
    p = Path(path)
    polygons = checked(p, "polygons", polygons, PolygonOptions)
    grow, simplify = polygons.grow, polygons.simplify
    every = read_scen_entries(p)
    _check_one_map(p, every)
    entries = _select(every, buckets, limit)
    if not entries:
        return []
    if map_path is None:
        map_path = _find_map(p, entries[0])
    grid = read_movingai(map_path, resolution=resolution, origin=origin)
    mask = grid.obstacle_mask()
    polys = [_world(grid, q) for q in grid_polygons(mask, grow=grow, simplify=simplify,
                                                     join=polygons.join)]
    obstacles = [_polygon_table(q, f"{Path(map_path).stem}-{k}") for k, q in enumerate(polys)]
    res = grid.resolution
    stem = re.sub(r"(\.map)?\.scen$", "", p.name) or p.stem
    out: list[Problem] = []
    template: Problem | None = None
    clear: np.ndarray | None = None  # per entry: start and goal surely free
    for k, e in enumerate(entries):
        _check_entry(p, e, grid, mask, map_path)
        s = grid.cell_centre(e.start[1], e.start[0])
        g = grid.cell_centre(e.goal[1], e.goal[0])
        keys = _entry_keys(p, stem, e, res)
        where = f"{p}:{e.line}"
        if template is None:  # the first line goes through the parser ...
            data = {
                **keys, "tags": list(keys["tags"]),
                "source": f"MovingAI benchmark {p.name} on {Path(map_path).name} "
                          f"(optplan.maps.read_scen, grow={grow:g}, simplify={simplify:g} "
                          "cells)",
                "bounds": list(grid.bounds),
                "robots": [{"id": "r1", "start": s.tolist(), "goal": g.tolist(),
                            "radius": radius, "max_speed": max_speed}],
                "obstacles": obstacles,
            }
            template = parse_problem(data, where)
            out.append(template)
            clear = _surely_free(template, grid, entries)
            continue
        # ... the others share its validated obstacles and exact engine (same checks)
        out.append(_like(template, where, s, g, keys, bool(clear is not None and clear[k])))
    return out


def _surely_free(template: Problem, grid: Grid, entries: list[ScenEntry]) -> np.ndarray:
    """Per entry, whether its start and goal are both farther than ``radius + eps`` from
    every obstacle (one exact distance query for all of them): such ends pass
    :meth:`Problem.blocking_obstacle`, which :func:`_like` then need not call (it decides
    the others, exactly as for the first line)."""
    pts = np.array([grid.cell_centre(y, x) for e in entries for (x, y) in (e.start, e.goal)])
    r = template.robots[0].radius
    d = template.obstacle_set(r).point_distances(pts).reshape(-1, 2)
    return (d > r + template.frame.eps).all(axis=1)


def _select(entries: list[ScenEntry], buckets: Iterable[int] | None,
            limit: int | None) -> list[ScenEntry]:
    """The entries of the given buckets, the first ``limit`` of them."""
    if buckets is not None:
        bs = set(buckets)
        entries = [e for e in entries if e.bucket in bs]
    if limit is not None:
        entries = entries[:limit]
    return entries


def _find_map(p: Path, first: ScenEntry) -> Path:
    """The ``.scen`` file's map next to it: as written, then by its base name."""
    cands = [p.parent / first.map, p.parent / Path(first.map).name]
    found = next((c for c in cands if c.is_file()), None)
    if found is None:
        raise err(p, "map", f"cannot find the map {first.map!r} (looked for "
                            f"{', '.join(str(c) for c in cands)}); pass map_path")
    return found


def _check_entry(p: Path, e: ScenEntry, grid: Grid, mask: np.ndarray,
                 map_path: str | Path) -> None:
    """The entry's map size is the map's; its start and goal cells are free cells of it."""
    key = f"line {e.line}"
    if (e.width, e.height) != (grid.width, grid.height):
        raise err(p, key, f"the scenario is for a {e.width} x {e.height} map, "
                          f"{map_path} is {grid.width} x {grid.height}")
    for what, (x, y) in (("start", e.start), ("goal", e.goal)):
        if not (0 <= x < grid.width and 0 <= y < grid.height):
            raise err(p, key, f"{what} cell ({x}, {y}) lies outside the map")
        if mask[y, x]:
            raise err(p, key, f"{what} cell ({x}, {y}) is blocked in {map_path}")


def _entry_keys(p: Path, stem: str, e: ScenEntry, res: float) -> dict[str, Any]:
    """The entry's name, description (with its octile length) and tags."""
    return {
        "name": f"{stem}-{e.line}",
        "description": f"MovingAI {p.name} line {e.line}: bucket {e.bucket}, cell "
                       f"({e.start[0]}, {e.start[1]}) -> ({e.goal[0]}, {e.goal[1]}), "
                       f"octile length {e.optimal_length * res!r} (map units)",
        "tags": ("movingai", f"bucket-{e.bucket}"),
    }


def _like(template: Problem, where: str, s: np.ndarray, g: np.ndarray,
          keys: dict[str, Any], clear: bool = False) -> Problem:
    """A copy of the first problem with another start and goal (checked free, unless
    ``clear``: both known farther than the radius from every obstacle), sharing its
    validated obstacles and exact engine."""
    for k, q in () if clear else (("start", s), ("goal", g)):
        hit = template.blocking_obstacle(q, template.robots[0].radius)
        if hit is not None:
            raise err(where, f"robots[0].{k}", f"{q.tolist()} lies inside obstacle "
                      f"{template.obstacles[hit].name!r} (obstacles[{hit}]) inflated by "
                      f"the robot radius {template.robots[0].radius:g}")
    robot = dataclasses.replace(template.robots[0], start=s, goal=g)
    return template.replaced(keep=("frame", "obstacle_set"), robots=(robot,), path=where,
                             **keys)
