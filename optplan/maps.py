"""Occupancy grids and benchmark maps as optplan problems (``docs/maps.md``).

Readers
-------
* **ROS** ``map_server`` **YAML** (:func:`read_ros_yaml`): ``image`` (relative to the YAML
  file), ``resolution`` (m / cell), ``origin`` ``[x, y, yaw]`` (the pose of the lower-left
  corner of the image), ``negate``, ``occupied_thresh``, ``free_thresh`` and ``mode``
  (``trinary``, ``scale``, ``raw``), classified as ROS ``map_server`` does.
* **bare images** (PNG, PGM, ...; :func:`read_image`) with a given ``resolution`` and
  ``origin`` and the same classification options.
* **MovingAI** ``.map`` grids (:func:`read_movingai`) and their ``.scen`` start/goal pairs
  (:func:`read_scen`: one :class:`~optplan.Problem` per line, a batch for ``bench``).

Every reader returns a :class:`Grid` (cells ``FREE``, ``OCCUPIED`` or ``UNKNOWN``; row 0 is
the *top* of the map).  :func:`grid_polygons` turns its obstacle cells (occupied, and unknown
unless ``unknown="free"``) into polygons with holes, **conservatively**: every obstacle cell
square lies inside the polygons.  The construction, in cell units:

1. the exact union ``U`` of the obstacle cell squares, one 8-connected component at a time
   (``skimage.measure.label``; each component is the union of the maximal rectangles of its
   row runs, integer coordinates, so the union is exact);
2. ``U`` grown by ``grow`` cells (Minkowski sum with a disc, ``shapely.buffer``);
3. simplified (Douglas-Peucker, topology preserved) with the tolerance ``simplify`` cells;
4. verified: the simplified polygon must cover ``U`` (``shapely.covers``, exact for the
   integer squares); if not, step 3 is repeated with 0.9, 0.75, 0.5 and 0.25 times the
   tolerance, and finally without simplification.  The result ``S`` satisfies
   ``U <= S <= U + disc(grow + simplify)`` (Minkowski sums).

:func:`import_map` adds robots and returns a validated :class:`~optplan.Problem` (its errors
are :class:`~optplan.ProblemError` naming the file and key); :func:`write_toml` writes any
problem as a scenario file.  World coordinates: cell ``(row, col)`` of an image with ``H``
rows covers ``origin + R(yaw) @ resolution * ([col, col + 1] x [H - 1 - row, H - row])``.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from optplan.problem import Problem, ProblemError, parse_problem, problem_to_dict, ring_points

__all__ = [
    "FREE",
    "OCCUPIED",
    "UNKNOWN",
    "Grid",
    "ScenEntry",
    "read_grid",
    "read_ros_yaml",
    "read_image",
    "read_movingai",
    "read_scen_entries",
    "read_scen",
    "scen_octile_length",
    "exact_union",
    "grid_polygons",
    "import_map",
    "to_toml",
    "write_toml",
    "write_batch",
]

#: Cell states of a :class:`Grid`.
FREE, OCCUPIED, UNKNOWN = 0, 1, 2

#: ROS ``map_server`` defaults for the optional YAML keys.
ROS_DEFAULTS = {"negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary"}
_ROS_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
_MODES = ("trinary", "scale", "raw")
_IMAGE_SUFFIXES = (".png", ".pgm", ".ppm", ".pbm", ".pnm", ".bmp", ".tif", ".tiff", ".gif",
                   ".jpg", ".jpeg")
#: MovingAI terrain: passable characters (``.`` ground, ``G`` ground, ``S`` swamp); ``@`` and
#: ``O`` (out of bounds), ``T`` (trees) and ``W`` (water) are obstacles.
MOVINGAI_PASSABLE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")


def _err(where: Any, key: str, msg: str) -> ProblemError:
    return ProblemError(f"{where}: {key}: {msg}")


# --------------------------------------------------------------------------------------
# the grid
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Grid:
    """An occupancy grid: ``cells[row, col]`` in ``FREE``/``OCCUPIED``/``UNKNOWN``.

    Row 0 is the **top** row of the map (image order).  ``resolution`` is the side of a cell
    in map units (metres for ROS maps); ``origin = (x, y, yaw)`` is the world pose of the
    lower-left corner of the grid (ROS convention; yaw in radians, counter-clockwise).
    """

    cells: np.ndarray
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = ""

    @property
    def height(self) -> int:
        return int(self.cells.shape[0])

    @property
    def width(self) -> int:
        return int(self.cells.shape[1])

    def obstacle_mask(self, unknown: str = "occupied") -> np.ndarray:
        """Boolean ``(H, W)`` mask of the cells that become obstacles."""
        _check_unknown(unknown, self.source or "<grid>")
        if unknown == "occupied":
            return self.cells != FREE
        return self.cells == OCCUPIED

    # -- frames --------------------------------------------------------------------
    def affine(self) -> list[float]:
        """shapely ``affine_transform`` matrix ``[a, b, d, e, xoff, yoff]`` from cell units
        (``x = col``, ``y = H - row``, i.e. y up) to world coordinates."""
        ox, oy, yaw = self.origin
        res = float(self.resolution)
        if yaw == 0.0:
            c, s = 1.0, 0.0
        else:
            c, s = math.cos(yaw), math.sin(yaw)
        return [res * c, -res * s, res * s, res * c, float(ox), float(oy)]

    def to_world(self, geom: Any) -> Any:
        """A shapely geometry in cell units mapped to world coordinates."""
        return shapely.affinity.affine_transform(geom, self.affine())

    def cell_to_world(self, xy: np.ndarray) -> np.ndarray:
        """Points ``(n, 2)`` in cell units (``x = col``, ``y = H - row``) to world."""
        a, b, d, e, xo, yo = self.affine()
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        return np.column_stack([a * p[:, 0] + b * p[:, 1] + xo, d * p[:, 0] + e * p[:, 1] + yo])

    def world_to_cell(self, points: np.ndarray) -> np.ndarray:
        """World points ``(n, 2)`` to cell units (``x = col``, ``y = H - row``)."""
        ox, oy, yaw = self.origin
        p = np.asarray(points, dtype=float).reshape(-1, 2) - [ox, oy]
        c, s = (1.0, 0.0) if yaw == 0.0 else (math.cos(yaw), math.sin(yaw))
        return np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]]) \
            / float(self.resolution)

    def cell_of(self, point: Sequence[float]) -> tuple[int, int] | None:
        """``(row, col)`` of the cell containing a world point (``None`` outside the grid)."""
        x, y = self.world_to_cell(np.asarray(point, dtype=float))[0]
        tol = 1e-9 * max(self.width, self.height)  # points on the outline belong to the grid
        if not (-tol <= x <= self.width + tol and -tol <= y <= self.height + tol):
            return None
        col = min(max(int(math.floor(x)), 0), self.width - 1)
        row = min(max(int(math.floor(self.height - y)), 0), self.height - 1)
        return row, col

    def cell_centre(self, row: int, col: int) -> np.ndarray:
        """World position of the centre of cell ``(row, col)``."""
        return self.cell_to_world([col + 0.5, self.height - row - 0.5])[0]

    @property
    def outline(self) -> Polygon:
        """The grid's rectangle in world coordinates."""
        return self.to_world(box(0.0, 0.0, float(self.width), float(self.height)))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """World axis-aligned bounds of the grid (of its rotated rectangle when yaw != 0)."""
        ox, oy, yaw = self.origin
        if yaw == 0.0:
            r = float(self.resolution)
            return (float(ox), float(oy), float(ox) + self.width * r, float(oy) + self.height * r)
        return tuple(float(v) for v in self.outline.bounds)

    def squares(self, mask: np.ndarray | None = None) -> Any:
        """Exact union of the cell squares of ``mask`` (default: occupied or unknown), world."""
        m = self.obstacle_mask() if mask is None else np.asarray(mask, dtype=bool)
        return self.to_world(exact_union(m))


def _check_unknown(unknown: str, where: Any) -> None:
    if unknown not in ("occupied", "free"):
        raise _err(where, "unknown", f"expected 'occupied' or 'free', got {unknown!r}")


# --------------------------------------------------------------------------------------
# readers
# --------------------------------------------------------------------------------------


def _number(v: Any, where: Any, key: str, *, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _err(where, key, f"expected a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise _err(where, key, f"must be finite, got {v!r}")
    if positive and x <= 0:
        raise _err(where, key, f"must be > 0, got {v!r}")
    return x


def _origin(v: Any, where: Any, key: str = "origin") -> tuple[float, float, float]:
    if isinstance(v, str):
        try:
            v = [float(t) for t in v.replace(",", " ").split()]
        except ValueError:
            raise _err(where, key, f"expected [x, y] or [x, y, yaw], got {v!r}") from None
    if not isinstance(v, (list, tuple)) or len(v) not in (2, 3):
        raise _err(where, key, f"expected [x, y] or [x, y, yaw], got {v!r}")
    xs = [_number(t, where, f"{key}[{k}]") for k, t in enumerate(v)]
    return (xs[0], xs[1], xs[2] if len(xs) == 3 else 0.0)


def _read_pixels(path: Path, where: Any, key: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Colour channels ``(H, W, n)`` on the 0..255 scale and the alpha channel (or None)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            im.load()
            mode = im.mode
            if mode == "P":
                im = im.convert("RGBA" if "transparency" in im.info else "RGB")
            elif mode in ("1", "CMYK", "YCbCr", "LAB", "HSV"):
                im = im.convert("L" if mode == "1" else "RGB")
            mode = im.mode
            arr = np.asarray(im)
    except FileNotFoundError:
        raise _err(where, key, f"no such image file {str(path)!r}") from None
    except (UnidentifiedImageError, OSError) as e:
        raise _err(where, key, f"cannot read image {str(path)!r} ({e})") from None
    arr = np.asarray(arr, dtype=float)
    if mode.startswith("I;16") or (mode == "I" and arr.max(initial=0) > 255):
        arr = arr * (255.0 / 65535.0)
    elif mode == "F" and arr.max(initial=0) <= 1.0:
        arr = arr * 255.0
    if arr.ndim == 2:
        return arr[:, :, None], None
    if mode in ("LA", "RGBA", "La", "RGBa", "PA"):
        return arr[:, :, :-1], arr[:, :, -1]
    return arr, None


def classify(colour: np.ndarray, alpha: np.ndarray | None, *, negate: bool = False,
             occupied_thresh: float = 0.65, free_thresh: float = 0.196,
             mode: str = "trinary") -> np.ndarray:
    """ROS ``map_server`` classification of pixels into ``FREE``/``OCCUPIED``/``UNKNOWN``.

    ``colour`` is ``(H, W, n)`` on 0..255, ``alpha`` ``(H, W)`` or None.  As ``map_server``:
    the channels are averaged (in ``trinary`` mode the alpha channel is averaged in too),
    ``negate`` replaces the average ``a`` by ``255 - a``, and the occupancy probability is
    ``p = (255 - a) / 255``: occupied when ``p > occupied_thresh``, free when
    ``p < free_thresh``, unknown otherwise.  ``scale`` mode: the same thresholds (the
    intermediate values ``map_server`` scales to 1..99 are uncertain: unknown here).
    ``raw`` mode: the average *is* the occupancy value ``v`` (0..100 percent, larger values
    unknown, as ``-1``/255 in ROS); ``v / 100`` is compared with the thresholds.
    """
    colour = np.asarray(colour, dtype=float)
    if colour.ndim == 2:
        colour = colour[:, :, None]
    if mode == "trinary" and alpha is not None:
        avg = (colour.sum(axis=2) + alpha) / (colour.shape[2] + 1)
    else:
        avg = colour.mean(axis=2)
    if negate:
        avg = 255.0 - avg
    out = np.full(avg.shape, UNKNOWN, dtype=np.uint8)
    if mode == "raw":
        v = np.trunc(avg)  # map_server stores the double into an int8
        known = v <= 100
        p = v / 100.0
        out[known & (p > occupied_thresh)] = OCCUPIED
        out[known & (p < free_thresh)] = FREE
        return out
    p = (255.0 - avg) / 255.0
    out[p > occupied_thresh] = OCCUPIED
    out[p < free_thresh] = FREE
    return out


def _thresholds(where: Any, occupied_thresh: Any, free_thresh: Any, mode: Any,
                negate: Any) -> tuple[float, float, str, bool]:
    occ = _number(occupied_thresh, where, "occupied_thresh")
    free = _number(free_thresh, where, "free_thresh")
    for k, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= v <= 1.0:
            raise _err(where, k, f"must be in [0, 1], got {v!r}")
    if free > occ:
        raise _err(where, "free_thresh", f"must be <= occupied_thresh ({occ!r}), got {free!r}")
    if not isinstance(mode, str) or mode not in _MODES:
        close = difflib.get_close_matches(str(mode), _MODES, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise _err(where, "mode", f"unknown mode {mode!r}{hint} (allowed: {', '.join(_MODES)})")
    if isinstance(negate, bool):
        neg = negate
    elif isinstance(negate, int) and negate in (0, 1):
        neg = bool(negate)
    else:
        raise _err(where, "negate", f"expected 0 or 1, got {negate!r}")
    return occ, free, mode, neg


def read_image(path: str | Path, *, resolution: float, origin: Sequence[float] = (0.0, 0.0),
               negate: bool = False, occupied_thresh: float = 0.65, free_thresh: float = 0.196,
               mode: str = "trinary") -> Grid:
    """Read a bare image (PNG, PGM, ...) as a :class:`Grid` (ROS ``map_server`` classification,
    :func:`classify`).  ``resolution``: cell side in map units; ``origin``: ``(x, y[, yaw])`` of
    the lower-left corner."""
    p = Path(path)
    res = _number(resolution, p, "resolution", positive=True)
    org = _origin(list(origin), p)
    occ, free, mode, neg = _thresholds(p, occupied_thresh, free_thresh, mode, negate)
    if not p.is_file():
        raise _err(p, "image", "no such file")
    colour, alpha = _read_pixels(p, p, "image")
    cells = classify(colour, alpha, negate=neg, occupied_thresh=occ, free_thresh=free, mode=mode)
    return Grid(cells, res, org, str(p))


def read_ros_yaml(path: str | Path) -> Grid:
    """Read a ROS ``map_server`` map (YAML + image) as a :class:`Grid`.

    Required keys: ``image``, ``resolution``, ``origin``; optional ``negate`` (0),
    ``occupied_thresh`` (0.65), ``free_thresh`` (0.196), ``mode`` (``trinary``).  Unknown keys
    are rejected with a suggestion.
    """
    import yaml

    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ProblemError(f"{p}: invalid YAML{at}: {getattr(e, 'problem', e)}") from None
    if not isinstance(data, dict):
        raise _err(p, "<root>", "expected a mapping of map_server keys")
    for k in data:
        if k not in _ROS_KEYS:
            close = difflib.get_close_matches(str(k), _ROS_KEYS, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise _err(p, str(k), f"unknown key{hint} (allowed: {', '.join(_ROS_KEYS)})")
    for k in ("image", "resolution", "origin"):
        if k not in data:
            raise _err(p, k, "missing required key")
    res = _number(data["resolution"], p, "resolution", positive=True)
    org = _origin(data["origin"], p)
    opts = {k: data.get(k, v) for k, v in ROS_DEFAULTS.items()}
    occ, free, mode, neg = _thresholds(p, opts["occupied_thresh"], opts["free_thresh"],
                                       opts["mode"], opts["negate"])
    img = data["image"]
    if not isinstance(img, str) or not img:
        raise _err(p, "image", f"expected a file name, got {img!r}")
    ip = Path(img)
    if not ip.is_absolute():
        ip = p.parent / ip
    if not ip.is_file():
        raise _err(p, "image", f"no such file {str(ip)!r}")
    colour, alpha = _read_pixels(ip, p, "image")
    cells = classify(colour, alpha, negate=neg, occupied_thresh=occ, free_thresh=free, mode=mode)
    return Grid(cells, res, org, str(p))


def read_movingai(path: str | Path, *, resolution: float = 1.0,
                  origin: Sequence[float] = (0.0, 0.0)) -> Grid:
    """Read a MovingAI ``.map`` (``type``, ``height``, ``width``, ``map``, then the rows).

    ``.``, ``G`` and ``S`` are free; ``@``, ``O``, ``T`` and ``W`` are obstacles.  MovingAI
    cell ``(x, y)`` (column ``x``, row ``y`` from the top) is grid cell ``(row y, col x)``; with
    the default ``resolution = 1`` and ``origin = (0, 0)`` its centre is
    ``(x + 0.5, height - y - 0.5)``.
    """
    p = Path(path)
    res = _number(resolution, p, "resolution", positive=True)
    org = _origin(list(origin), p)
    try:
        lines = p.read_text(encoding="ascii", errors="strict").splitlines()
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    except UnicodeDecodeError:
        raise ProblemError(f"{p}: not a MovingAI map (non-ASCII content)") from None
    head: dict[str, str] = {}
    k = 0
    while k < len(lines) and lines[k].strip() != "map":
        parts = lines[k].split()
        k += 1
        if not parts:
            continue
        if len(parts) != 2 or parts[0] not in ("type", "height", "width"):
            raise _err(p, f"line {k}", f"expected 'type T', 'height H', 'width W' or 'map', "
                                       f"got {lines[k - 1]!r}")
        head[parts[0]] = parts[1]
    for key in ("height", "width"):
        if key not in head:
            raise _err(p, key, "missing header line")
        if not head[key].isdigit() or int(head[key]) < 1:
            raise _err(p, key, f"expected a positive integer, got {head[key]!r}")
    if k >= len(lines):
        raise _err(p, "map", "missing 'map' line before the grid")
    h, w = int(head["height"]), int(head["width"])
    rows = [ln.rstrip("\r\n") for ln in lines[k + 1:k + 1 + h]]
    if len(rows) < h:
        raise _err(p, "height", f"header says {h} rows, the file has {len(rows)}")
    cells = np.empty((h, w), dtype=np.uint8)
    for r, row in enumerate(rows):
        if len(row) != w:
            raise _err(p, f"line {k + 2 + r}", f"expected {w} cells, got {len(row)}")
        bad = set(row) - MOVINGAI_PASSABLE - MOVINGAI_BLOCKED
        if bad:
            c = min(row.index(b) for b in bad)
            raise _err(p, f"line {k + 2 + r}", f"unknown terrain {row[c]!r} at column {c + 1} "
                                               "(expected one of . G S @ O T W)")
        cells[r] = [FREE if ch in MOVINGAI_PASSABLE else OCCUPIED for ch in row]
    return Grid(cells, res, org, str(p))


def read_grid(path: str | Path, *, resolution: float | None = None,
              origin: Sequence[float] | None = None, **classify_opts: Any) -> Grid:
    """Read any supported map by its suffix: ``.yaml``/``.yml`` (ROS), ``.map`` (MovingAI) or
    an image (``resolution`` required; ``origin`` default ``(0, 0)``)."""
    p = Path(path)
    suf = p.suffix.lower()
    if not p.exists():
        raise ProblemError(f"{p}: no such map file")
    if suf in (".yaml", ".yml"):
        for k, v in (("resolution", resolution), ("origin", origin), *classify_opts.items()):
            if v is not None:
                raise _err(p, k, "given by the YAML file; do not pass it for a ROS map")
        return read_ros_yaml(p)
    if suf == ".map":
        if classify_opts:
            raise _err(p, next(iter(classify_opts)), "not an option of MovingAI maps")
        return read_movingai(p, resolution=1.0 if resolution is None else resolution,
                             origin=(0.0, 0.0) if origin is None else origin)
    if suf in _IMAGE_SUFFIXES:
        if resolution is None:
            raise _err(p, "resolution", "required for a bare image (map units per cell, e.g. "
                                        "--resolution 0.05)")
        opts = {k: v for k, v in classify_opts.items() if v is not None}
        return read_image(p, resolution=resolution,
                          origin=(0.0, 0.0) if origin is None else origin, **opts)
    raise ProblemError(f"{p}: unknown map format {suf or '(no suffix)'!r} (expected .yaml/.yml, "
                       f".map or an image: {', '.join(_IMAGE_SUFFIXES)})")


# --------------------------------------------------------------------------------------
# conservative polygons
# --------------------------------------------------------------------------------------


def _rectangles(mask: np.ndarray, row0: int, col0: int, height: int) -> list[Polygon]:
    """Maximal vertical stacks of identical row runs of ``mask`` as boxes in cell units
    (``x = col``, ``y = height - row``); ``mask`` is a window at ``(row0, col0)``."""
    h, w = mask.shape
    pad = np.zeros((h, w + 2), dtype=np.int8)
    pad[:, 1:-1] = mask
    d = np.diff(pad, axis=1)
    rs, cs = np.nonzero(d == 1)
    _, ce = np.nonzero(d == -1)
    runs_by_row: dict[int, list[tuple[int, int]]] = {}
    for r, a, b in zip(rs.tolist(), cs.tolist(), ce.tolist()):
        runs_by_row.setdefault(r, []).append((a, b))
    out: list[Polygon] = []

    def close(run: tuple[int, int], top: int, bottom: int) -> None:
        a, b = run
        out.append(box(col0 + a, height - (row0 + bottom), col0 + b, height - (row0 + top)))

    active: dict[tuple[int, int], int] = {}
    for r in range(h + 1):
        nxt: dict[tuple[int, int], int] = {}
        for run in runs_by_row.get(r, ()):
            nxt[run] = active.pop(run, r)
        for run, top in active.items():
            close(run, top, r)
        active = nxt
    return out


def exact_union(mask: np.ndarray) -> Any:
    """Exact union of the cell squares of a boolean ``(H, W)`` mask, in cell units
    (``x = col``, ``y = H - row``): a (Multi)Polygon with integer vertices, empty if none."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return Polygon()
    return shapely.union_all(_rectangles(m, 0, 0, m.shape[0]))


def _polys(g: Any) -> list[Polygon]:
    if g.is_empty:
        return []
    if isinstance(g, Polygon):
        return [g]
    return [q for q in getattr(g, "geoms", []) if isinstance(q, Polygon) and not q.is_empty]


#: Fractions of the simplification tolerance tried in turn until the simplified polygon covers
#: its cells (the last, no simplification, always does).
_FALLBACK = (1.0, 0.9, 0.75, 0.5, 0.25, 0.0)


@dataclass
class _Stats:
    components: int = 0
    fallbacks: int = 0
    tolerance_min: float = math.inf


def _conservative(u: Any, grow: float, simplify: float, join: str, stats: _Stats) -> list[Polygon]:
    """``S`` with ``U <= S <= U + disc(grow + simplify)`` for one component ``u`` (cells)."""
    if grow > 0:
        g = shapely.buffer(u, grow, quad_segs=4, join_style=join, mitre_limit=2.0)
    else:
        g = u
    for k, f in enumerate(_FALLBACK):
        tol = simplify * f
        s = shapely.simplify(g, tol, preserve_topology=True) if tol > 0 else g
        if not s.is_valid:
            s = shapely.make_valid(s)
        if tol <= 0 or shapely.covers(s, u):
            stats.fallbacks += k
            break
    stats.tolerance_min = min(stats.tolerance_min, tol)
    return [shapely.geometry.polygon.orient(q, 1.0) for q in _polys(s)]


def grid_polygons(mask: np.ndarray, *, grow: float = 0.5, simplify: float = 0.5,
                  join: str = "round", stats: dict | None = None) -> list[Polygon]:
    """Conservative polygons (cell units, ``x = col``, ``y = H - row``) of a boolean mask.

    Each 8-connected component of ``mask`` (``skimage.measure.label``) becomes the exact union
    ``U`` of its cell squares, grown by ``grow`` cells (``join``: ``"round"``, the Euclidean
    Minkowski sum, or ``"mitre"``, the square grown by ``grow`` in every axis), simplified with
    the tolerance ``simplify`` cells and checked to cover ``U`` (with a smaller tolerance
    until it does).  Every result covers its component; with ``join = "round"`` it lies inside
    ``U + disc(grow + simplify)`` (``"mitre"``: ``U + disc(sqrt(2) grow + simplify)``).

    ``stats``, if given, receives ``components``, ``fallbacks`` (tolerance reductions) and
    ``tolerance_min`` (the smallest tolerance used).
    """
    from skimage import measure

    m = np.asarray(mask, dtype=bool)
    if grow < 0 or simplify < 0 or not (math.isfinite(grow) and math.isfinite(simplify)):
        raise ValueError(f"grow and simplify must be finite and >= 0, got {grow}, {simplify}")
    if simplify > 0 and grow == 0:
        raise ValueError("simplify > 0 needs grow > 0: without growth the simplified polygon "
                         "cannot cover every cell")
    if join not in ("round", "mitre"):
        raise ValueError(f"join must be 'round' or 'mitre', got {join!r}")
    st = _Stats()
    out: list[Polygon] = []
    if m.any():
        labels = measure.label(m, connectivity=2)
        for region in measure.regionprops(labels):
            r0, c0, _, _ = region.bbox
            u = shapely.union_all(_rectangles(region.image, r0, c0, m.shape[0]))
            st.components += 1
            out += _conservative(u, grow, simplify, join, st)
    if stats is not None:
        stats.update(components=st.components, fallbacks=st.fallbacks,
                     tolerance_min=st.tolerance_min if st.components else simplify)
    return out


#: World coordinates of imported polygons are rounded to this fraction of the map's size
#: (decimal digits; far below the geometric tolerance ``1e-9 x`` the bounds diagonal).
ROUND_REL = 1e-12


def _world(grid: Grid, q: Polygon) -> Polygon:
    """A polygon in cell units in world coordinates, rounded to ``ROUND_REL x`` the map size
    (``20.025`` rather than ``20.025000000000006`` in the written scenario)."""
    size = max(grid.width, grid.height) * grid.resolution
    digits = max(0, -math.floor(math.log10(ROUND_REL * size)))
    w = grid.to_world(q)
    return shapely.transform(w, lambda xy: np.round(xy, digits))


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


# --------------------------------------------------------------------------------------
# problems
# --------------------------------------------------------------------------------------


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
        raise _err(where, key, f"expected a point (x, y) or a list of points, got {v!r}") from None
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2 or a.shape[1] != 2 or not np.all(np.isfinite(a)):
        raise _err(where, key, f"expected a point (x, y) or a list of points, got {v!r}")
    return a


def _check_vector_args(where: str, grow: Any, simplify: Any, join: str, radius: Any) -> float:
    """Validate the polygon-conversion arguments of :func:`import_map`; the radius."""
    for key, v in (("grow", grow), ("simplify", simplify)):
        x = _number(v, where, key)
        if x < 0:
            raise _err(where, key, f"must be >= 0 (cells), got {v!r}")
        if x > 4:
            raise _err(where, key, f"{v!r} cells is coarser than the map; use at most 4")
    if simplify > 0 and grow == 0:
        raise _err(where, "simplify", "needs grow > 0 (a simplified polygon without growth "
                                      "cannot cover every cell); pass simplify=0")
    if join not in ("round", "mitre"):
        raise _err(where, "join", f"expected 'round' or 'mitre', got {join!r}")
    r = _number(radius, where, "radius")
    if r < 0:
        raise _err(where, "radius", f"must be >= 0, got {radius!r}")
    return r


def _robot_ends(where: str, start: Any, goal: Any,
                robot_id: str | Sequence[str] | None) -> tuple[np.ndarray, np.ndarray, list]:
    """Starts, goals and robot ids of :func:`import_map` (one robot per start/goal pair)."""
    starts, goals = _points(start, where, "start"), _points(goal, where, "goal")
    if len(starts) != len(goals):
        raise _err(where, "goal", f"{len(starts)} start(s) but {len(goals)} goal(s)")
    if robot_id is None:
        ids = ["r1"] if len(starts) == 1 else [f"r{k + 1}" for k in range(len(starts))]
    else:
        ids = [robot_id] if isinstance(robot_id, str) else list(robot_id)
    if len(ids) != len(starts):
        raise _err(where, "robot", f"{len(ids)} robot id(s) for {len(starts)} start(s)")
    return starts, goals, ids


def _check_ends_free(where: str, grid: Grid, mask: np.ndarray, starts: np.ndarray,
                     goals: np.ndarray) -> None:
    """Every start and goal lies in a free cell of the map (the radius check is the parser's
    exact test)."""
    for k in range(len(starts)):
        for key, q in (("start", starts[k]), ("goal", goals[k])):
            cell = grid.cell_of(q)
            if cell is None:
                raise _err(where, f"robots[{k}].{key}", f"{q.tolist()} lies outside the map "
                                                         f"{list(grid.bounds)}")
            if mask[cell]:
                state = "unknown" if grid.cells[cell] == UNKNOWN else "occupied"
                raise _err(where, f"robots[{k}].{key}",
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


def _optional_keys(data: dict[str, Any], goal_tolerance: float | None,
                   dynamic_obstacles: Sequence[dict], sensing_range: float | None) -> None:
    """Add the optional scenario keys that were given."""
    if goal_tolerance is not None:
        data["goal_tolerance"] = goal_tolerance
    if dynamic_obstacles:
        data["dynamic_obstacles"] = [dict(d) for d in dynamic_obstacles]
    if sensing_range is not None:
        data["sensing"] = {"range": sensing_range}


def _import_info(grid: Grid, stats: dict, polys: list, holes_filled: int,
                 obstacles: list[dict]) -> dict[str, Any]:
    """What ``import_map(info=...)`` receives."""
    return dict(stats, polygons=len(polys), holes_filled=holes_filled,
                vertices=sum(len(o["vertices"]) + sum(len(h) for h in o.get("holes", ()))
                             for o in obstacles),
                cells={"occupied": int(np.sum(grid.cells == OCCUPIED)),
                       "unknown": int(np.sum(grid.cells == UNKNOWN)),
                       "free": int(np.sum(grid.cells == FREE))})


def import_map(path: str | Path, *, radius: float, start: Any, goal: Any,
               robot_id: str | Sequence[str] | None = None, max_speed: float = 1.0,
               resolution: float | None = None, origin: Sequence[float] | None = None,
               negate: bool | None = None, occupied_thresh: float | None = None,
               free_thresh: float | None = None, mode: str | None = None,
               unknown: str = "occupied", grow: float = 0.5, simplify: float = 0.5,
               join: str = "round", fill_unreachable: bool = True, name: str | None = None,
               description: str | None = None, source: str | None = None,
               tags: Iterable[str] = ("map",), goal_tolerance: float | None = None,
               dynamic_obstacles: Sequence[dict] = (), sensing_range: float | None = None,
               grid: Grid | None = None, info: dict | None = None) -> Problem:
    """Import an occupancy map as a validated :class:`~optplan.Problem`.

    Parameters
    ----------
    path : path
        ``.yaml``/``.yml`` (ROS ``map_server``), ``.map`` (MovingAI) or an image (PNG, PGM...;
        then ``resolution`` is required and ``origin`` defaults to ``(0, 0)``).
    radius : float
        Robot radius (map units).
    start, goal : point or list of points
        One robot per start/goal pair (world coordinates, map units).
    robot_id : str or list of str, optional
        Default ``"r1"`` (``"r1", "r2", ...`` for several robots).
    max_speed : float
        Every robot's speed limit (map units / s).
    resolution, origin, negate, occupied_thresh, free_thresh, mode
        For bare images (:func:`read_image`); for MovingAI maps ``resolution`` and ``origin``
        only; ROS maps take them from their YAML file.
    unknown : ``"occupied"`` (default) or ``"free"``
        What unknown cells are.
    grow, simplify : float
        Growth and Douglas-Peucker tolerance in **cells** (:func:`grid_polygons`).
    join : ``"round"`` or ``"mitre"``
        Growth join style (:func:`grid_polygons`).
    fill_unreachable : bool
        Fill the holes of obstacles that contain no start or goal (free regions no robot can
        reach: closed rooms, voids in walls) and drop the obstacles inside them.  Still
        conservative; fewer vertices.
    name, description, source, tags, goal_tolerance, sensing_range, dynamic_obstacles
        Scenario keys (``dynamic_obstacles``: tables as in the TOML format).
    grid : Grid, optional
        An already read grid (``path`` then only names the source in messages).
    info : dict, optional
        Receives ``components``, ``polygons``, ``vertices``, ``holes_filled``, ``fallbacks``,
        ``tolerance_min`` and ``cells`` (occupied, unknown, free counts).

    Raises
    ------
    ProblemError
        For every bad input, naming the file and the key (a start or goal in an obstacle:
        ``robots[i].start``).
    """
    p = Path(path)
    where = str(p)
    _check_unknown(unknown, where)
    if grid is None:
        extra = {"negate": negate, "occupied_thresh": occupied_thresh,
                 "free_thresh": free_thresh, "mode": mode}
        extra = {k: v for k, v in extra.items() if v is not None}
        grid = read_grid(p, resolution=resolution, origin=origin, **extra)
    r = _check_vector_args(where, grow, simplify, join, radius)
    starts, goals, ids = _robot_ends(where, start, goal, robot_id)
    mask = grid.obstacle_mask(unknown)
    _check_ends_free(where, grid, mask, starts, goals)
    stats: dict[str, Any] = {}
    polys = [_world(grid, q) for q in grid_polygons(mask, grow=grow, simplify=simplify,
                                                     join=join, stats=stats)]
    holes_filled = 0
    if fill_unreachable:
        polys, holes_filled = _fill_unreachable(polys, np.vstack([starts, goals]))
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "-", p.stem) or "map"
    name = name or stem
    obstacles = _map_obstacles(grid, polys, stem, unknown)
    res = grid.resolution
    data: dict[str, Any] = {
        "name": name,
        "description": description or f"imported from {p.name} ({grid.width} x "
                                      f"{grid.height} cells of {res:g})",
        "source": source or f"optplan.maps.import_map({p.name!r}, grow={grow:g} cells, "
                            f"simplify={simplify:g} cells, unknown={unknown!r})",
        "tags": list(tags),
        "bounds": list(grid.bounds),
        "robots": [{"id": ids[k], "start": starts[k].tolist(), "goal": goals[k].tolist(),
                    "radius": r, "max_speed": max_speed} for k in range(len(starts))],
        "obstacles": obstacles,
    }
    _optional_keys(data, goal_tolerance, dynamic_obstacles, sensing_range)
    prob = parse_problem(data, where)
    if info is not None:
        info.update(_import_info(grid, stats, polys, holes_filled, obstacles))
    return prob


# --------------------------------------------------------------------------------------
# MovingAI scenarios
# --------------------------------------------------------------------------------------


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
    ``bucket map width height start_x start_y goal_x goal_y optimal_length``)."""
    p = Path(path)
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    out = []
    for k, ln in enumerate(lines, start=1):
        if not ln.strip() or (k == 1 and ln.split()[0].lower() == "version"):
            continue
        parts = ln.split("\t") if "\t" in ln else ln.split()
        parts = [t.strip() for t in parts if t.strip() != ""]
        if len(parts) != 9:
            raise _err(p, f"line {k}", f"expected 9 fields (bucket map width height start_x "
                                       f"start_y goal_x goal_y optimal_length), got {len(parts)}")
        try:
            b, w, h, sx, sy, gx, gy = (int(parts[i]) for i in (0, 2, 3, 4, 5, 6, 7))
            opt = float(parts[8])
        except ValueError:
            raise _err(p, f"line {k}", f"non-numeric field in {ln!r}") from None
        out.append(ScenEntry(b, parts[1], w, h, (sx, sy), (gx, gy), opt, k))
    if not out:
        raise _err(p, "<file>", "no scenario lines")
    return out


_OCTILE_RE = re.compile(r"octile length ([0-9.eE+-]+)")


def scen_octile_length(problem: Problem) -> float | None:
    """The ``.scen`` optimal (octile, 8-connected grid) length of a problem made by
    :func:`read_scen`, in map units (kept in its description), or ``None``."""
    m = _OCTILE_RE.search(problem.description)
    return float(m.group(1)) if m else None


def read_scen(path: str | Path, *, map_path: str | Path | None = None, radius: float = 0.0,
              grow: float = 0.25, simplify: float = 0.2, join: str = "round",
              max_speed: float = 1.0, resolution: float = 1.0,
              origin: Sequence[float] = (0.0, 0.0), buckets: Iterable[int] | None = None,
              limit: int | None = None) -> list[Problem]:
    """A MovingAI ``.scen`` as a list of problems, one per line (a batch for ``bench``:
    :func:`write_batch` writes them as scenario files).

    Each problem has one robot (radius ``radius``, a point by default) from the centre of the
    start cell to the centre of the goal cell, the map's obstacles imported once
    (:func:`grid_polygons`; the defaults ``grow = 0.25``, ``simplify = 0.2`` cells keep every
    cell-centre path of the 8-connected grid free for a point robot, since
    ``grow + simplify < 0.5``), the name ``<scen stem>-<line>`` and the description
    ``"... octile length L ..."`` with the ``.scen`` optimum in map units
    (:func:`scen_octile_length`).  The map is ``map_path`` or the ``.scen`` file's ``map``
    field, looked up next to the ``.scen`` file (as written, then by its base name).
    """
    p = Path(path)
    entries = read_scen_entries(p)
    if buckets is not None:
        bs = set(buckets)
        entries = [e for e in entries if e.bucket in bs]
    if limit is not None:
        entries = entries[:limit]
    if not entries:
        return []
    if map_path is None:
        cands = [p.parent / entries[0].map, p.parent / Path(entries[0].map).name]
        found = next((c for c in cands if c.is_file()), None)
        if found is None:
            raise _err(p, "map", f"cannot find the map {entries[0].map!r} (looked for "
                                 f"{', '.join(str(c) for c in cands)}); pass map_path")
        map_path = found
    grid = read_movingai(map_path, resolution=resolution, origin=origin)
    mask = grid.obstacle_mask()
    polys = [_world(grid, q) for q in grid_polygons(mask, grow=grow, simplify=simplify,
                                                     join=join)]
    obstacles = [_polygon_table(q, f"{Path(map_path).stem}-{k}") for k, q in enumerate(polys)]
    res = grid.resolution
    stem = re.sub(r"(\.map)?\.scen$", "", p.name) or p.stem
    out: list[Problem] = []
    template: Problem | None = None
    for e in entries:
        key = f"line {e.line}"
        if (e.width, e.height) != (grid.width, grid.height):
            raise _err(p, key, f"the scenario is for a {e.width} x {e.height} map, "
                               f"{map_path} is {grid.width} x {grid.height}")
        for what, (x, y) in (("start", e.start), ("goal", e.goal)):
            if not (0 <= x < grid.width and 0 <= y < grid.height):
                raise _err(p, key, f"{what} cell ({x}, {y}) lies outside the map")
            if mask[y, x]:
                raise _err(p, key, f"{what} cell ({x}, {y}) is blocked in {map_path}")
        s = grid.cell_centre(e.start[1], e.start[0])
        g = grid.cell_centre(e.goal[1], e.goal[0])
        keys = {
            "name": f"{stem}-{e.line}",
            "description": f"MovingAI {p.name} line {e.line}: bucket {e.bucket}, cell "
                           f"({e.start[0]}, {e.start[1]}) -> ({e.goal[0]}, {e.goal[1]}), "
                           f"octile length {e.optimal_length * res!r} (map units)",
            "tags": ("movingai", f"bucket-{e.bucket}"),
        }
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
            continue
        # ... the others share its validated obstacles and exact engine (same checks)
        for k, q in (("start", s), ("goal", g)):
            hit = template.blocking_obstacle(q, template.robots[0].radius)
            if hit is not None:
                raise _err(where, f"robots[0].{k}", f"{q.tolist()} lies inside obstacle "
                           f"{template.obstacles[hit].name!r} (obstacles[{hit}]) inflated by "
                           f"the robot radius {template.robots[0].radius:g}")
        shared = {k: v for k, v in template._cache.items()
                  if k[0] in ("frame", "obstacle_set")}
        robot = dataclasses.replace(template.robots[0], start=s, goal=g)
        out.append(dataclasses.replace(template, robots=(robot,), path=where, _cache=shared,
                                       **keys))
    return out


# --------------------------------------------------------------------------------------
# writing scenarios
# --------------------------------------------------------------------------------------


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if not math.isfinite(x):
            raise ValueError(f"cannot write the non-finite number {x!r} to TOML")
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def _toml_points(pts: Sequence, indent: str = "  ", per_line: int = 4) -> str:
    items = [_toml_value([float(x), float(y)]) for x, y in pts]
    if len(items) <= per_line:
        return "[" + ", ".join(items) + "]"
    lines = [indent + ", ".join(items[i:i + per_line]) + ","
             for i in range(0, len(items), per_line)]
    return "[\n" + "\n".join(lines) + "\n]"


def _problem_tables(problem: Problem) -> tuple[dict, list[tuple[str, dict]]]:
    """Top-level keys and the ``[[array]]``/``[table]`` sections of a problem
    (:func:`optplan.problem.problem_to_dict`, laid out for TOML)."""
    d = problem_to_dict(problem)
    top = {k: v for k, v in d.items()
           if k not in ("sensing", "formation", "robots", "obstacles", "dynamic_obstacles")}
    sections: list[tuple[str, dict]] = []
    if "sensing" in d:
        sections.append(("[sensing]", d["sensing"]))
    if "formation" in d:
        sections.append(("[formation]", d["formation"]))
    for key in ("robots", "obstacles", "dynamic_obstacles"):
        sections += [(f"[[{key}]]", t) for t in d.get(key, [])]
    return top, sections


def to_toml(problem: Problem, header: str | None = None) -> str:
    """The scenario file of ``problem`` (every key of the TOML format it uses; numbers written
    with ``repr`` so that reading the file back gives the same doubles)."""
    top, sections = _problem_tables(problem)
    lines = [f"# {ln}".rstrip() for ln in (header or "").splitlines()]
    for k, v in top.items():
        lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for head, t in sections:
        lines += ["", head]
        for k, v in t.items():
            if k in ("vertices", "waypoints"):
                lines.append(f"{k} = {_toml_points(v)}")
            elif k == "holes":
                rings = ",\n".join("  " + _toml_points(h, indent="    ") for h in v)
                lines.append(f"holes = [\n{rings},\n]")
            else:
                lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    return "\n".join(lines) + "\n"


def write_toml(problem: Problem, path: str | Path, header: str | None = None) -> Path:
    """Write ``problem`` as a scenario TOML file (:func:`to_toml`); returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(to_toml(problem, header), encoding="utf-8")
    return p


def write_batch(problems: Iterable[Problem], directory: str | Path) -> list[Path]:
    """Write problems (e.g. :func:`read_scen`) as ``<directory>/<name>.toml``; the paths are
    a batch for :func:`optplan.bench.run_grid`."""
    d = Path(directory)
    return [write_toml(q, d / f"{q.name}.toml") for q in problems]

