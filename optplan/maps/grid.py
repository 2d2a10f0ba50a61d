"""The occupancy grid (:class:`Grid`) and its cell states (``FREE``, ``OCCUPIED``, ``UNKNOWN``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry import Polygon, box

from optplan.maps.checks import MAX_CELLS, check_extent, check_unknown, err, number, origin
from optplan.maps.polygons import exact_union

# MAX_CELLS, the readers' limit (optplan.maps.checks), is named here too: optplan.maps takes it
# from here
__all__ = ["FREE", "OCCUPIED", "UNKNOWN", "MAX_CELLS", "Grid"]

#: Cell states of a :class:`Grid`.
FREE, OCCUPIED, UNKNOWN = 0, 1, 2


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
        (:func:`check_extent`); errors name the source and the field."""
        where = self.source or "<grid>"
        cells = np.asarray(self.cells)
        if cells.ndim != 2 or 0 in cells.shape or cells.dtype.kind not in "iub":
            raise err(where, "cells", f"expected a 2-D integer array of at least 1 x 1 "
                                      f"cells, got shape {cells.shape}, dtype {cells.dtype}")
        if cells.dtype.kind != "b" and (cells.min() < FREE or cells.max() > UNKNOWN):
            raise err(where, "cells", f"values {int(cells.min())}..{int(cells.max())}: "
                                      f"expected FREE (0), OCCUPIED (1) or UNKNOWN (2)")
        res = number(self.resolution, where, "resolution", positive=True)
        org = origin(self.origin, where)
        check_extent(where, cells.shape[1], cells.shape[0], res, org)
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
        check_unknown(unknown, self.source or "<grid>")
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

