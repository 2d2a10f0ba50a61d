r"""Compiled exact arc test of the collision engine (numba; the only implementation): does an
arc of a circle keep the robot's disc off every obstacle?

A shortest path of a disc robot runs along circles (:mod:`optplan.geometry.tangent`); each arc
it follows, centre ``c``, radius ``rho``, counter-clockwise from the angle ``start`` over
``sweep``, must stay at least ``r - eps`` from every obstacle.  Every arc tested here starts
at a free point (the end of a free tangent, a query's start), so it comes within ``r`` of a
solid only where it comes within ``r`` of the solid's *boundary*: the arc is tested against
the boundary edges of the convex pieces (the edges flagged ``B``; the internal diagonals of a
solid's tiling never matter) and the circle obstacles, with exact distances in closed form:

* point ``q`` to the arc: ``| |q - c| - rho |`` when the direction of ``q - c`` lies in the
  arc (``ANGLE_TOL`` of slack), else the distance to the nearer arc end;
* segment ``P -> P + E`` to the arc: the minimum over the arc's ends to the segment, the
  segment's ends to the arc, the two arc points whose radius is normal to the segment (foot
  inside the segment) and ``0`` where the circle crosses the segment inside the arc;
* a circle obstacle (centre ``q``, radius ``R``): the point distance minus ``R``.

Only the items near the arc are tested: the arc lies within ``b = 2 rho sin(sweep / 4)`` of
its midpoint ``m``, so an item whose bounding circle is farther than ``b + r`` from ``m``
cannot block it (``b + r`` carries ``3 eps`` of slack).  Without the obstacle set's grid
every item's bounding circle is compared with ``m``; with it, the cells of the box of
half-width ``b + r`` round ``m`` are visited (an item is listed in every cell its box, grown by
``r + 4 eps``, covers, so every item that comes within ``b + r`` of ``m`` is listed in one of
them).  The work per arc is that of the items near the arc, not of those near its circle.

Tested against an independent numpy transcription of the closed forms and against shapely
(the arc sampled densely) in ``tests/geometry/test_arc_checker.py``.  The data layout is that
of :mod:`optplan.geometry.collision.kernel`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from optplan.geometry.collision.kernel import GRID, ITEMS
from optplan.geometry.compiled import B1, F1, F2, I1, compiled, f8, inlined, leaf

__all__ = ["TWO_PI", "ANGLE_TOL", "arcs_blocked", "arcs_free"]

TWO_PI = 2.0 * math.pi
#: Angular slack (rad) of "a direction lies in the arc" (the normal-cone tests' slack).
ANGLE_TOL = 1e-9


@leaf(f8, f8, f8)
def _in_arc(phi, start, sweep):
    """The direction ``phi`` lies in the counter-clockwise arc ``start .. start + sweep``."""
    return (phi - start) % TWO_PI <= sweep + ANGLE_TOL


@leaf(f8, f8, f8, f8, f8, f8, f8)
def _point_arc(qx, qy, cx, cy, rho, start, sweep):
    """Distance from the point ``q`` to the arc (module docstring)."""
    vx = qx - cx
    vy = qy - cy
    if _in_arc(math.atan2(vy, vx), start, sweep):
        return abs(math.sqrt(vx * vx + vy * vy) - rho)
    end = start + sweep
    d0 = math.hypot(qx - (cx + rho * math.cos(start)), qy - (cy + rho * math.sin(start)))
    d1 = math.hypot(qx - (cx + rho * math.cos(end)), qy - (cy + rho * math.sin(end)))
    return min(d0, d1)


@leaf(f8, f8, f8, f8, f8, f8)
def _point_segment(qx, qy, px, py, ex, ey):
    """Distance from the point ``q`` to the segment ``P -> P + E``."""
    ee = max(ex * ex + ey * ey, 1e-300)
    t = min(max(((qx - px) * ex + (qy - py) * ey) / ee, 0.0), 1.0)
    return math.hypot(qx - (px + t * ex), qy - (py + t * ey))


@inlined  # one call site (_blocks)
def _segment_arc(cx, cy, rho, start, sweep, px, py, ex, ey):
    """Exact distance between the arc and the segment ``P -> P + E`` (module docstring)."""
    end = start + sweep
    d = min(_point_segment(cx + rho * math.cos(start), cy + rho * math.sin(start),
                           px, py, ex, ey),
            _point_segment(cx + rho * math.cos(end), cy + rho * math.sin(end), px, py, ex, ey),
            _point_arc(px, py, cx, cy, rho, start, sweep),
            _point_arc(px + ex, py + ey, cx, cy, rho, start, sweep))
    L = math.sqrt(ex * ex + ey * ey)
    ux = ex / max(L, 1e-300)
    uy = ey / max(L, 1e-300)
    for sgn in (1.0, -1.0):  # arc points whose radius is normal to the segment
        nx = -sgn * uy
        ny = sgn * ux
        wx = cx + rho * nx - px
        wy = cy + rho * ny - py
        t = wx * ux + wy * uy
        if 0.0 <= t <= L and _in_arc(math.atan2(ny, nx), start, sweep):
            d = min(d, abs(wy * ux - wx * uy))
    wx = px - cx  # the circle crosses the segment's line at P + t u
    wy = py - cy
    b = wx * ux + wy * uy
    h2 = b * b - (wx * wx + wy * wy - rho * rho)
    if h2 >= 0.0:
        sq = math.sqrt(h2)
        for t in (-b - sq, -b + sq):
            if 0.0 <= t <= L and _in_arc(math.atan2(wy + t * uy, wx + t * ux), start, sweep):
                return 0.0
    return d


@inlined  # one call site (_arcs_loop)
def _blocks(k, cx, cy, rho, start, sweep, items, lim):
    """Item ``k`` comes closer than ``lim`` to the arc: a piece's boundary edges, a circle."""
    K, P, E = items[0], items[1], items[2]
    B, IC, CR = items[6], items[7], items[9]
    if k >= K:
        return _point_arc(IC[k, 0], IC[k, 1], cx, cy, rho, start, sweep) - CR[k - K] < lim
    for j in range(4):
        if B[k, j] and _segment_arc(cx, cy, rho, start, sweep, P[k, j, 0], P[k, j, 1],
                                    E[k, j, 0], E[k, j, 1]) < lim:
            return True
    return False


@compiled(F2, F1, F1, F1, ITEMS, GRID, f8, f8)
def arcs_blocked(CXY, RHO, START, SWEEP, items, grid, r, eps):
    """Per arc (centre ``CXY[a]``, radius ``RHO[a]``, counter-clockwise from ``START[a]`` over
    ``SWEEP[a] >= 0``; local frame): it comes closer than ``r - eps`` to an obstacle (module
    docstring).  An arc of radius 0 is a point: never blocked here (its point is free)."""
    n_items = items[7].shape[0]
    out = np.empty(CXY.shape[0], np.bool_)
    _arcs_loop(CXY, RHO, START, SWEEP, items, grid, r, eps, out,
               (np.empty(n_items, np.int64), np.empty(n_items, np.int64)))
    return out


@leaf(F2, F1, F1, F1, ITEMS, GRID, f8, f8, B1, types.Tuple((I1, I1)))
def _arcs_loop(CXY, RHO, START, SWEEP, items, grid, r, eps, out, work):
    """The loop of :func:`arcs_blocked` (``work``: scratch, per item the last arc that listed
    it and the candidate list)."""
    stamp, cand = work
    IC, IR = items[7], items[8]
    n_items = IC.shape[0]
    use_grid, gh, gx0, gy0, gnx, gny, gstart, gcount, gitems = grid
    lim = r - eps
    for k in range(n_items):
        stamp[k] = -1
    for a in range(CXY.shape[0]):
        out[a] = False
        rho = RHO[a]
        if not rho > 0.0:
            continue
        cx = CXY[a, 0]
        cy = CXY[a, 1]
        start = START[a]
        sweep = SWEEP[a]
        mid = start + 0.5 * sweep
        mx = cx + rho * math.cos(mid)
        my = cy + rho * math.sin(mid)
        reach = 2.0 * rho * math.sin(0.25 * min(sweep, TWO_PI)) + lim + 4.0 * eps
        m = 0
        if use_grid:  # the cells of the box of half-width reach round m
            i0 = min(max(int(math.floor((mx - reach - gx0) / gh)), 0), gnx - 1)
            i1 = min(max(int(math.floor((mx + reach - gx0) / gh)), 0), gnx - 1)
            j0 = min(max(int(math.floor((my - reach - gy0) / gh)), 0), gny - 1)
            j1 = min(max(int(math.floor((my + reach - gy0) / gh)), 0), gny - 1)
            for col in range(i0, i1 + 1):
                for row in range(j0, j1 + 1):
                    cell = col * gny + row
                    s = gstart[cell]
                    for q in range(s, s + gcount[cell]):
                        k = gitems[q]
                        if stamp[k] != a:
                            stamp[k] = a
                            cand[m] = k
                            m += 1
        else:
            for k in range(n_items):
                cand[k] = k
            m = n_items
        for q in range(m):
            k = cand[q]
            rr = IR[k] + reach
            if ((IC[k, 0] - mx) ** 2 + (IC[k, 1] - my) ** 2 <= rr * rr
                    and _blocks(k, cx, cy, rho, start, sweep, items, lim)):
                out[a] = True
                break


def arcs_free(oset, center: np.ndarray, rho: np.ndarray, start: np.ndarray,
              sweep: np.ndarray) -> np.ndarray:
    """Per arc (local frame: complex centres ``center``, radii ``rho``, counter-clockwise from
    ``start`` over ``sweep >= 0``) of a disc of ``oset.radius``: it keeps ``r - eps`` from every
    obstacle of the obstacle set ``oset`` (:func:`arcs_blocked`).  An arc must start at a free
    point (module docstring)."""
    center = np.asarray(center, complex).ravel()
    if oset.n_items == 0 or len(center) == 0:
        return np.ones(len(center), bool)
    xy = np.ascontiguousarray(np.stack([center.real, center.imag], axis=1))
    rho, start, sweep = (np.array(x, dtype=float).ravel() for x in (rho, start, sweep))
    return ~arcs_blocked(xy, rho, start, sweep, oset.arrays, oset._grid_args(),
                         float(oset.radius), float(oset.eps))
