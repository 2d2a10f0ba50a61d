"""Compiled nearest-point queries of the exact collision engine (numba; the only
implementation): per (point, obstacle) the nearest boundary point and the exact distance, 0
inside (:meth:`optplan.geometry.collision.obstacles.ObstacleSet.nearest`).

The data layout is that of :mod:`optplan.geometry.collision.kernel`; tested against shapely in
``tests/geometry/test_geometry.py``.
"""

from __future__ import annotations

import math

import numpy as np

from optplan.geometry.collision.kernel import ITEMS, _clamp01
from optplan.geometry.compiled import F2, compiled, f8, i8, inlined

__all__ = ["nearest"]


@inlined
def _near_circle(qx, qy, cx, cy, r):
    """Nearest boundary point of the circle (centre ``(cx, cy)``, radius ``r``) to q:
    (distance, 0 inside; x; y; q inside)."""
    vx = qx - cx
    vy = qy - cy
    nv = math.sqrt(vx * vx + vy * vy)
    ux, uy = 1.0, 0.0
    if nv > 0.0:
        ux = vx / nv
        uy = vy / nv
    d = nv - r
    ins = False
    if d < 0.0:
        d = 0.0
        ins = True
    return d, cx + ux * r, cy + uy * r, ins


@inlined
def _in_piece(qx, qy, k, N, C):
    """Whether q is inside (or on) convex piece ``k``."""
    for j in range(4):
        if N[k, j, 0] * qx + N[k, j, 1] * qy - C[k, j] > 0.0:
            return False
    return True


@inlined
def _near_piece(qx, qy, k, P, E, B):
    """Nearest point to q on the boundary edges of piece ``k``: (distance, x, y); (inf, nan,
    nan) when the piece has no boundary edge.  The first edge wins a tie."""
    best = math.inf
    bx = math.nan
    by = math.nan
    for j in range(4):
        if not B[k, j]:
            continue
        px = P[k, j, 0]
        py = P[k, j, 1]
        ex = E[k, j, 0]
        ey = E[k, j, 1]
        ee = ex * ex + ey * ey
        t = 0.0
        if ee > 0.0:
            t = _clamp01(((qx - px) * ex + (qy - py) * ey) / ee)
        x = px + t * ex
        y = py + t * ey
        d = math.sqrt((x - qx) ** 2 + (y - qy) ** 2)
        if d < best:
            best = d
            bx = x
            by = y
    return best, bx, by


@inlined
def _finish_nearest(near, dist, inside, max_range):
    """Distance 0 for a point inside an obstacle; (inf, nan) beyond ``max_range``."""
    for i in range(dist.shape[0]):
        for o in range(dist.shape[1]):
            if inside[i, o]:
                dist[i, o] = 0.0
            elif dist[i, o] > max_range:
                dist[i, o] = math.inf
                near[i, o, 0] = np.nan
                near[i, o, 1] = np.nan


@compiled(F2, ITEMS, i8, f8)
def nearest(Q, items, n_obs, max_range):
    """Nearest boundary point and exact distance (0 inside) per (point, obstacle) of
    ``items`` (:mod:`optplan.geometry.collision.kernel`); obstacles whose bounding circles are
    all farther than ``max_range`` are skipped (inf, nan)."""
    K, P, E, N, C, _, B, IC, IR, CR, OWN = items
    R = Q.shape[0]
    near = np.empty((R, n_obs, 2))  # np.empty and a loop: no np.full / np.zeros to compile
    dist = np.empty((R, n_obs))
    inside = np.empty((R, n_obs), np.bool_)
    for i in range(R):
        for o in range(n_obs):
            near[i, o, 0] = np.nan
            near[i, o, 1] = np.nan
            dist[i, o] = math.inf
            inside[i, o] = False
    n_items = IC.shape[0]
    for i in range(R):
        qx = Q[i, 0]
        qy = Q[i, 1]
        for k in range(n_items):
            wx = IC[k, 0] - qx
            wy = IC[k, 1] - qy
            if math.sqrt(wx * wx + wy * wy) - IR[k] > max_range:
                continue
            o = OWN[k]
            if k >= K:
                d, x, y, ins = _near_circle(qx, qy, IC[k, 0], IC[k, 1], CR[k - K])
            else:
                ins = _in_piece(qx, qy, k, N, C)
                d, x, y = _near_piece(qx, qy, k, P, E, B)
            if ins:
                inside[i, o] = True
            if d < dist[i, o]:
                dist[i, o] = d
                near[i, o, 0] = x
                near[i, o, 1] = y
    _finish_nearest(near, dist, inside, max_range)
    return near, dist
