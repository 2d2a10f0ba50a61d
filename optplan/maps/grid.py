"""The occupancy grid (:class:`Grid`) and the checks of its inputs."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry import Polygon, box

from optplan.geometry.collision import MAX_REL_COORD
from optplan.maps.polygons import exact_union
from optplan.problem import ProblemError

#: Cell states of a :class:`Grid`.
FREE, OCCUPIED, UNKNOWN = 0, 1, 2

#: The largest map the readers accept, in cells (pixels of an image): 8192 x 8192.  A size
#: above it is an error before anything of that size is allocated or decoded (the readers'
#: ``max_cells=`` raises it); decoding works in float64 channels, about 1.6 GB for an RGB
#: image of this size.
MAX_CELLS = 8192 * 8192


#: The supported size of a map: its diagonal ``hypot(width, height) x resolution`` lies in
#: ``[MAP_MIN_LENGTH, MAP_MAX_LENGTH]`` = ``[1e-30, 1e30]`` map units, and the centre of the
#: map lies within ``MAX_REL_COORD`` (1e6) diagonals of the coordinate origin (the rule of
#: the geometry core, :mod:`optplan.geometry.collision.frame`: the double format resolves the
#: tolerance ``1e-9 x`` the diagonal there).  Why these bounds: the geometry core accepts diagonals
#: in ``[1e-100, 1e100]``, but the exact obstacle engine squares and multiplies lengths, and an
#: imported map runs clean (no overflow, underflow or nan) only for diagonals between about
#: ``1e-60`` and ``1e70``; 30 decades inside that on each side still cover every unit a map
#: is drawn in.  Outside these bounds the world coordinates of the cells underflow, overflow
#: or cannot be rounded (``resolution: 1e-300`` was a raw ``GEOSException``);
#: ``docs/maps.md``, "Accepted ranges".
MAP_MIN_LENGTH, MAP_MAX_LENGTH = 1e-30, 1e30


def _err(where: Any, key: str, msg: str) -> ProblemError:
    return ProblemError(f"{where}: {key}: {msg}")


def _is_real(v: Any) -> bool:
    """A real number: ``int``, ``float`` or a numpy integer or floating scalar (not a bool,
    not ``numpy.bool_``)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(
        v, (bool, np.bool_))


def _check_extent(where: Any, width: int, height: int, res: float,
                  origin: tuple[float, float, float], key: str = "resolution",
                  origin_key: str = "origin") -> None:
    """A ``width x height`` grid of cells of side ``res`` at ``origin`` has a diagonal in
    ``[MAP_MIN_LENGTH, MAP_MAX_LENGTH]`` and its centre within ``MAX_REL_COORD`` diagonals of
    the coordinate origin (the geometry core's limits, checked before any geometry)."""
    cells = math.hypot(width, height)
    diag = cells * res
    if not MAP_MIN_LENGTH <= diag <= MAP_MAX_LENGTH:
        raise _err(where, key, f"{res!r} makes the {width} x {height} cell map {diag:.3g} map "
                               f"units across (its diagonal), outside the supported range "
                               f"[{MAP_MIN_LENGTH:g}, {MAP_MAX_LENGTH:g}]; for this map the "
                               f"resolution must lie in [{MAP_MIN_LENGTH / cells:.3g}, "
                               f"{MAP_MAX_LENGTH / cells:.3g}]")
    ox, oy, yaw = origin
    c, s = math.cos(yaw), math.sin(yaw)
    cx = ox + 0.5 * res * (c * width - s * height)
    cy = oy + 0.5 * res * (s * width + c * height)
    far = max(abs(cx), abs(cy))
    if not far <= MAX_REL_COORD * diag:
        raise _err(where, origin_key, f"{[ox, oy, yaw]} puts the centre of the map "
                                      f"{far:.3g} from the coordinate origin, more than "
                                      f"{MAX_REL_COORD:g} x its diagonal {diag:.3g} (allowed: "
                                      f"at most {MAX_REL_COORD * diag:.3g}): double precision "
                                      f"cannot resolve the map's cells there; shift the "
                                      f"origin")



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

    def __post_init__(self) -> None:
        """Check (and normalise) the fields: ``cells`` a 2-D integer array of ``FREE``,
        ``OCCUPIED`` and ``UNKNOWN``, ``resolution`` a real number > 0 (numpy scalars too),
        ``origin`` ``(x, y[, yaw])`` finite, and the map's size and place representable
        (:func:`_check_extent`); errors name the source and the field."""
        where = self.source or "<grid>"
        cells = np.asarray(self.cells)
        if cells.ndim != 2 or 0 in cells.shape or cells.dtype.kind not in "iub":
            raise _err(where, "cells", f"expected a 2-D integer array of at least 1 x 1 "
                                       f"cells, got shape {cells.shape}, dtype {cells.dtype}")
        if cells.dtype.kind != "b" and (cells.min() < FREE or cells.max() > UNKNOWN):
            raise _err(where, "cells", f"values {int(cells.min())}..{int(cells.max())}: "
                                       f"expected FREE (0), OCCUPIED (1) or UNKNOWN (2)")
        res = _number(self.resolution, where, "resolution", positive=True)
        org = _origin(self.origin, where)
        _check_extent(where, cells.shape[1], cells.shape[0], res, org)
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "resolution", res)
        object.__setattr__(self, "origin", org)

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

    def cell_to_world(self, xy: npt.ArrayLike) -> np.ndarray:
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
        x0, y0, x1, y1 = self.outline.bounds
        return (float(x0), float(y0), float(x1), float(y1))

    def squares(self, mask: np.ndarray | None = None) -> Any:
        """Exact union of the cell squares of ``mask`` (default: occupied or unknown), world."""
        m = self.obstacle_mask() if mask is None else np.asarray(mask, dtype=bool)
        return self.to_world(exact_union(m))


def _check_cells(where: Any, key: str, height: int, width: int, max_cells: int,
                 what: str = "") -> None:
    """A map of ``height x width`` cells is at most ``max_cells`` (checked before allocating);
    ``what`` starts the message (``"image 'x.png': "``)."""
    if not (_is_real(max_cells) and isinstance(max_cells, (int, np.integer))) \
            or max_cells < 1:
        raise _err(where, "max_cells", f"expected a positive integer (cells), got "
                                       f"{max_cells!r}")
    if height * width > max_cells:
        raise _err(where, key, f"{what}{width} x {height} = {width * height:,} cells, more "
                               f"than the limit of {max_cells:,} (max_cells; {MAX_CELLS:,} = "
                               "8192 x 8192 by default): too large to read safely")


def _check_unknown(unknown: str, where: Any) -> None:
    if unknown not in ("occupied", "free"):
        raise _err(where, "unknown", f"expected 'occupied' or 'free', got {unknown!r}")




def _number(v: Any, where: Any, key: str, *, positive: bool = False) -> float:
    """``v`` as a finite float: an ``int``, ``float`` or numpy real scalar (not a bool)."""
    if not _is_real(v):
        raise _err(where, key, f"expected a number, got {v!r} ({type(v).__name__})")
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
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
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if not isinstance(v, (list, tuple)) or len(v) not in (2, 3):
        raise _err(where, key, f"expected [x, y] or [x, y, yaw], got {v!r}")
    xs = [_number(t, where, f"{key}[{k}]") for k, t in enumerate(v)]
    return (xs[0], xs[1], xs[2] if len(xs) == 3 else 0.0)
