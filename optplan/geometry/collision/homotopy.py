"""Homotopy classes of paths with common endpoints, by winding numbers.

Two paths from ``s`` to ``g`` are homotopic in the free space when the closed loop (one path,
then the other reversed) winds zero times around every obstacle.  One interior point per item of
the exact engine (the vertex mean of each convex piece, the centre of each circle) suffices for
feasible paths: a feasible path cannot pass between two points of one obstacle, nor between
obstacles less than ``2 r`` apart.  Among polygonal and circular obstacles each homotopy class
holds exactly one locally shortest path, so a locally optimal path in the class of the certified
optimum *is* the optimum (up to its discretisation).
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.collision.obstacles import ObstacleSet

__all__ = ["winding_numbers", "obstacle_points", "same_homotopy"]


def winding_numbers(loop: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Winding number of the closed polyline ``loop`` (``(m, 2)``) around each point."""
    loop = np.asarray(loop, float)
    pts = np.asarray(points, float).reshape(-1, 2)
    if len(pts) == 0:
        return np.zeros(0, int)
    a = loop[None, :, :] - pts[:, None, :]
    b = np.roll(a, -1, axis=1)
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    dot = np.sum(a * b, axis=-1)
    ang = np.arctan2(cross, dot).sum(axis=1)
    return np.rint(ang / (2 * np.pi)).astype(int)


def obstacle_points(oset: ObstacleSet) -> np.ndarray:
    """One interior point per item of ``oset`` (local frame), shape ``(K, 2)``."""
    z = oset.item_center
    return np.stack([z.real, z.imag], axis=1).reshape(-1, 2)


def same_homotopy(path_a: np.ndarray, path_b: np.ndarray, oset: ObstacleSet) -> bool:
    """True when two paths (world coordinates) with common endpoints wind the same way around
    every obstacle of ``oset`` (computed in its local frame)."""
    loop = np.vstack([np.asarray(path_a, float), np.asarray(path_b, float)[::-1]])
    return bool(np.all(winding_numbers(oset.frame.local(loop), obstacle_points(oset)) == 0))
