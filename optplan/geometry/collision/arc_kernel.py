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

Only the entries near the arc are tested: the *entries* are the boundary edges of the pieces
and the circle obstacles.  The arc lies within ``b = 2 rho sin(sweep / 4)`` of its midpoint
``m``, so an entry farther than ``b + r`` from ``m`` cannot block it (``b + r`` carries
``3 eps`` of slack): each entry is screened by its exact distance to ``m`` (a point-to-segment
or point-to-circle distance) before the exact distance to the arc.  From
:data:`ARC_GRID_FROM` entries on, a uniform grid of the entries (:func:`arc_grid`, made once
per obstacle set) lists each in every cell its box (``4 eps`` of slack) covers; an arc visits
the cells of the box of half-width ``b + r`` round ``m``, which hold every entry that comes
within ``b + r`` of ``m``.  The work per arc is then that of the boundary edges near the arc:
not of the pieces near it (a piece's bounding circle may reach far beyond its boundary edges
near the arc: a large convex piece, the inner fan of a peeled polygon), nor of those near its
circle.

Tested against an independent numpy transcription of the closed forms and against shapely
(the arc sampled densely) in ``tests/geometry/test_arc_checker.py``.  The data layout is that
of :mod:`optplan.geometry.collision.kernel`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from optplan.geometry.collision.grid import box_cells, cell_lists
from optplan.geometry.collision.kernel import GRID, ITEMS
from optplan.geometry.compiled import B1, F1, F2, I1, compiled, f8, inlined, leaf

__all__ = ["TWO_PI", "ANGLE_TOL", "ARC_GRID_FROM", "arc_grid", "arcs_blocked", "arcs_free"]

TWO_PI = 2.0 * math.pi
#: Angular slack (rad) of "a direction lies in the arc" (the normal-cone tests' slack).
ANGLE_TOL = 1e-9
#: Entries (boundary edges and circle obstacles) from which the arc test has its own grid.
ARC_GRID_FROM = 1024


@leaf(f8, f8, f8)
def _in_arc(phi, start, sweep):
    """The direction ``phi`` lies in the counter-clockwise arc ``start .. start + sweep``."""
    return (phi - start) % TWO_PI <= sweep + ANGLE_TOL


@leaf(f8, f8, f8, f8, f8, f8, f8, types.UniTuple(f8, 4))
def _point_arc(qx, qy, cx, cy, rho, start, sweep, ends):
    """Distance from the point ``q`` to the arc (module docstring; ``ends``: the arc's end
    points ``x0, y0, x1, y1``)."""
    vx = qx - cx
    vy = qy - cy
    if _in_arc(math.atan2(vy, vx), start, sweep):
        return abs(math.sqrt(vx * vx + vy * vy) - rho)
    return min(math.hypot(qx - ends[0], qy - ends[1]), math.hypot(qx - ends[2], qy - ends[3]))


@leaf(f8, f8, f8, f8, f8, f8)
def _point_segment(qx, qy, px, py, ex, ey):
    """Distance from the point ``q`` to the segment ``P -> P + E``."""
    ee = max(ex * ex + ey * ey, 1e-300)
    t = min(max(((qx - px) * ex + (qy - py) * ey) / ee, 0.0), 1.0)
    return math.hypot(qx - (px + t * ex), qy - (py + t * ey))


@inlined  # one call site (_blocked)
def _segment_arc(cx, cy, rho, start, sweep, ends, px, py, ex, ey):
    """Exact distance between the arc (end points ``ends``) and the segment ``P -> P + E``
    (module docstring)."""
    d = min(_point_segment(ends[0], ends[1], px, py, ex, ey),
            _point_segment(ends[2], ends[3], px, py, ex, ey),
            _point_arc(px, py, cx, cy, rho, start, sweep, ends),
            _point_arc(px + ex, py + ey, cx, cy, rho, start, sweep, ends))
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
def _blocked(e, arc, ends, mid, items, lim):
    """Entry ``e`` comes closer than ``lim`` to the arc ``arc = (cx, cy, rho, start, sweep)``
    (end points ``ends``, ``mid = (mx, my, reach)``: its midpoint and the screen's radius):
    edge ``e % 4`` of piece ``e // 4`` when ``e < 4 K`` (a boundary edge; an internal one never
    blocks), else the circle item ``K + e - 4 K``; screened by its distance to ``m``."""
    cx, cy, rho, start, sweep = arc
    mx, my, reach = mid
    K, P, E = items[0], items[1], items[2]
    B, IC, CR = items[6], items[7], items[9]
    if e < 4 * K:
        k = e // 4
        j = e - 4 * k
        if not B[k, j]:
            return False
        px, py, ex, ey = P[k, j, 0], P[k, j, 1], E[k, j, 0], E[k, j, 1]
        return (_point_segment(mx, my, px, py, ex, ey) <= reach
                and _segment_arc(cx, cy, rho, start, sweep, ends, px, py, ex, ey) < lim)
    c = e - 4 * K
    qx, qy, R = IC[K + c, 0], IC[K + c, 1], CR[c]
    return (math.hypot(qx - mx, qy - my) - R <= reach
            and _point_arc(qx, qy, cx, cy, rho, start, sweep, ends) - R < lim)


@compiled(F2, F1, F1, F1, ITEMS, GRID, f8, f8)
def arcs_blocked(CXY, RHO, START, SWEEP, items, grid, r, eps):
    """Per arc (centre ``CXY[a]``, radius ``RHO[a]``, counter-clockwise from ``START[a]`` over
    ``SWEEP[a] >= 0``; local frame): it comes closer than ``r - eps`` to a boundary edge of a
    piece or a circle obstacle of ``items`` (the obstacle set's kernel arrays), screened by
    ``grid`` (:func:`arc_grid`; module docstring).  An arc of radius 0 is a point: never
    blocked here (its point is free)."""
    n = 4 * items[0] + items[9].shape[0]
    out = np.empty(CXY.shape[0], np.bool_)
    _arcs_loop(CXY, RHO, START, SWEEP, items, grid, r, eps, out,
               (np.empty(n, np.int64), np.empty(n, np.int64)))
    return out


@leaf(F2, F1, F1, F1, ITEMS, GRID, f8, f8, B1, types.Tuple((I1, I1)))
def _arcs_loop(CXY, RHO, START, SWEEP, items, grid, r, eps, out, work):
    """The loop of :func:`arcs_blocked` (``work``: scratch, per entry the last arc that listed
    it and the candidate list)."""
    stamp, cand = work
    n = 4 * items[0] + items[9].shape[0]
    use_grid, gh, gx0, gy0, gnx, gny, gstart, gcount, gitems = grid
    lim = r - eps
    for k in range(n):
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
        end = start + sweep
        ends = (cx + rho * math.cos(start), cy + rho * math.sin(start),
                cx + rho * math.cos(end), cy + rho * math.sin(end))
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
            for k in range(n):
                cand[k] = k
            m = n
        for q in range(m):
            if _blocked(cand[q], (cx, cy, rho, start, sweep), ends, (mx, my, reach), items,
                        lim):
                out[a] = True
                break


def arc_grid(oset) -> tuple:
    """The screen of the arc test of the obstacle set ``oset`` (the ``grid`` argument of
    :func:`arcs_blocked`; module docstring), made once and kept with the set.  Its entries are
    the boundary edges of the pieces (``4 k + j``: edge ``j`` of piece ``k``) and the circle
    obstacles (``4 K + c``).  Below :data:`ARC_GRID_FROM` of them every entry is screened
    against every arc (no grid); from there on a uniform grid over the local bounds (cells at
    its border unbounded outwards), of cell size the median side of the entries' boxes (at
    least 1/256 of the bounds' larger side), lists each entry in every cell its box covers."""
    got = oset._cache.get("arc_grid")
    if got is not None:
        return got
    K, P, E, B, IC, CR = (oset.arrays[i] for i in (0, 1, 2, 6, 7, 9))
    z = np.zeros(1, np.int64)
    got = (False, 1.0, 0.0, 0.0, 1, 1, z, z, z)
    k, j = np.nonzero(B)
    if len(k) + len(CR) >= ARC_GRID_FROM:
        a, b = P[k, j], P[k, j] + E[k, j]
        pad = 4.0 * oset.eps  # the boxes' slack
        lo = np.concatenate([np.minimum(a, b), IC[K:] - CR[:, None]]) - pad
        hi = np.concatenate([np.maximum(a, b), IC[K:] + CR[:, None]]) + pad
        ids = np.concatenate([4 * k + j, 4 * K + np.arange(len(CR))])
        x0, y0, x1, y1 = oset.frame.local_bounds
        h = max(float(np.median(np.max(hi - lo, axis=1))), max(x1 - x0, y1 - y0) / 256.0,
                oset.eps)
        nx, ny = int((x1 - x0) // h) + 1, int((y1 - y0) // h) + 1
        ij = [np.clip(np.floor((v[:, d] - o) / h), 0, m - 1).astype(np.int64)
              for v in (lo, hi) for d, o, m in ((0, x0, nx), (1, y0, ny))]
        ii, jj, ee = box_cells(ij[0], ij[2], ij[1], ij[3])
        start, count, entries = cell_lists(ii * ny + jj, ids[ee], nx * ny)
        got = (True, h, x0, y0, nx, ny, start[:-1], count, entries)
    oset._cache["arc_grid"] = got
    return got


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
    return ~arcs_blocked(xy, rho, start, sweep, oset.arrays, arc_grid(oset),
                         float(oset.radius), float(oset.eps))
