"""The uniform grid of the collision engine's items (the candidate screen of many items).

Each item (a convex piece or a circle of :class:`~optplan.geometry.collision.obstacles.ObstacleSet`)
is listed in every cell its bounding square, grown by the collision reach ``r + 4 eps``, covers;
a segment visits the cells it crosses (column by column, :mod:`optplan.geometry.collision.kernel`),
so the work per segment grows with the items near it.  The cells at the grid's border are
unbounded outwards, so an item or a segment beyond the grid is still found.

Items of the solid that holds the bounds wall are large pieces around the bounds: they are
listed by their boxes (not their bounding squares) and left out of the grid's extent and cell
size, so the rest of the grid is the one the same map without the wall has.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["GRID_FROM", "item_grid", "box_cells", "cell_lists"]

#: Number of items (outside the wall's solid) from which the grid replaces the all-pairs screen.
GRID_FROM = 48


def item_grid(centers: np.ndarray, reach: np.ndarray, V: np.ndarray, in_wall: np.ndarray,
              radius: float, eps: float, grid: bool | None) -> dict | None:
    """The grid as CSR lists, or None for the all-pairs screen.

    Parameters
    ----------
    centers, reach : arrays ``(n, 2)``, ``(n,)``
        Bounding circles of the items (pieces first, then circles; local frame).
    V : array ``(K, 4, 2)``
        Padded vertices of the ``K`` pieces.
    in_wall : bool array ``(n,)``
        Items of the solid that holds the bounds wall.
    radius, eps : float
        Robot radius and tolerance (the reach of a collision).
    grid : bool or None
        Force the grid on or off; None decides by :data:`GRID_FROM`.
    """
    n_items = len(reach)
    plain = ~in_wall if (~in_wall).any() else np.ones(n_items, bool)
    use_grid = int(plain.sum()) >= GRID_FROM if grid is None else bool(grid)
    if not (use_grid and n_items):
        return None
    ext = reach + radius + 4 * eps
    lo = (centers - ext[:, None])[plain].min(axis=0)
    hi = (centers + ext[:, None])[plain].max(axis=0)
    span = float(np.max(hi - lo))
    h = max(2.0 * float(np.median(ext[plain])), span / 256.0, eps)
    nx = int(math.floor((hi[0] - lo[0]) / h)) + 1
    ny = int(math.floor((hi[1] - lo[1]) / h)) + 1
    blo = centers - ext[:, None]
    bhi = centers + ext[:, None]
    if in_wall.any():  # boxes of the wall's pieces, grown by the collision reach
        g = radius + 4 * eps
        wk = np.flatnonzero(in_wall[:len(V)])  # circles are never part of the wall's solid
        blo[wk] = V[wk].min(axis=1) - g
        bhi[wk] = V[wk].max(axis=1) + g
    i0 = np.clip(np.floor((blo[:, 0] - lo[0]) / h), 0, nx - 1).astype(np.int64)
    i1 = np.clip(np.floor((bhi[:, 0] - lo[0]) / h), 0, nx - 1).astype(np.int64)
    j0 = np.clip(np.floor((blo[:, 1] - lo[1]) / h), 0, ny - 1).astype(np.int64)
    j1 = np.clip(np.floor((bhi[:, 1] - lo[1]) / h), 0, ny - 1).astype(np.int64)
    ii, jj, kk = box_cells(i0, i1, j0, j1)
    start, count, items = cell_lists(ii * ny + jj, kk, nx * ny)
    return {"h": h, "x0": float(lo[0]), "y0": float(lo[1]), "nx": nx, "ny": ny,
            "items": items, "count": count, "reach": radius + 4 * eps, "start": start[:-1]}


def box_cells(i0: np.ndarray, i1: np.ndarray, j0: np.ndarray, j1: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every cell of every box: item ``k`` covers the cells ``i0[k]..i1[k]`` x
    ``j0[k]..j1[k]`` (inclusive integer indices).  Returns the cells' ``i``, ``j`` and the item
    of each, items in order."""
    w = (i1 - i0 + 1).astype(np.int64)
    cnt = w * (j1 - j0 + 1)
    kk = np.repeat(np.arange(len(cnt)), cnt)
    off = np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    wk = w[kk]
    return i0[kk] + off % wk, j0[kk] + off // wk, kk


def cell_lists(cell: np.ndarray, items: np.ndarray, n_cells: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR lists of ``items`` by ``cell`` index: ``start`` (``n_cells + 1`` offsets),
    ``count`` per cell, and the items sorted by cell (stable: in their given order within a
    cell)."""
    order = np.argsort(cell, kind="stable")
    count = np.bincount(cell, minlength=n_cells)
    start = np.zeros(n_cells + 1, np.int64)
    np.cumsum(count, out=start[1:])
    return start, count, np.ascontiguousarray(items[order], np.int64)
