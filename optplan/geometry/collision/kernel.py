"""Compiled loops of the exact collision engine (numba; the only implementation).

Every function here is ``@compiled(signature)`` or, where it allocates nothing, ``@leaf``
(:mod:`optplan.geometry.compiled.jit`: no reference counting in the loops): compiled once,
with its one signature, on its first call (about 3 s of CPU for the whole module, once per
machine; the machine code is cached on disk) and tested against shapely in
``tests/geometry/test_geometry.py``.  Why compiled: the engine answers many small queries (a swarm's
fitness: tens of paths x a few segments x the obstacles near them, thousands of times per run);
per-query numpy overhead, not arithmetic, would dominate, and early exits per (segment, item)
pair are natural in loops.  The maths is in :mod:`optplan.geometry.collision.obstacles`' docstring.

Data layout (local frame, built by :func:`optplan.geometry.collision.obstacles.obstacle_set`):

* pieces ``k < K``: ``P[k, j]`` edge start, ``E[k, j]`` edge vector, ``N[k, j]`` outward unit
  normal, ``C[k, j] = N . P``, ``CE[k, j]`` the offset eroded by ``eps`` on boundary edges,
  ``B[k, j]`` boundary flag (4 edges; a triangle repeats its last edge);
* circles ``k >= K``: centre and radius ``CR[k - K]``;
* every item: bounding circle ``(IC[k], IR[k])``, owning obstacle ``OWN[k]``;
* optional uniform grid: cell size ``h``, origin, shape, CSR item lists.

Grouped arguments (no compiled function takes more than 10 parameters; these tuples are
passed whole, unpacked where they are read, and typed once below):

* ``items``, :data:`ITEMS`: ``(K, P, E, N, C, CE, B, IC, IR, CR, OWN)``, the obstacle set's
  items, exactly :attr:`optplan.geometry.collision.obstacles.ObstacleSet.arrays` (``K`` the
  number of pieces, ``B`` the boundary flags, ``IR`` the bounding radii);
* ``grid``, :data:`GRID`: ``(use_grid, h, x0, y0, nx, ny, start, count, items)``, the uniform
  grid (``ObstacleSet._grid_args()``; a dummy one-cell grid with ``use_grid`` False);
* ``work``, :data:`WORK`: the scratch arrays of a segment scan, ``(BB, mask, stamp, cand,
  touched, o_stamp, o_close, o_in, o_pen)``: the items' grown boxes (:func:`_item_boxes`),
  the box mask, the per-item stamp and candidate list (one entry per item), and per
  obstacle the touched list, stamp, closeness flag, summed ``inside`` and penetration (made
  uninitialised by the ``@compiled`` wrapper of each ``@leaf`` loop);
* ``seg``: a segment ``(ax, ay, dx, dy)``, start and vector (the ``@inlined`` helpers).

A function called once per segment or per (segment, item) pair takes only the arrays it
reads, as a smaller tuple made by its caller (:func:`pair`: :data:`SHAPES`, :func:`shapes`;
:func:`_candidates`: ``(IC, IR)`` and ``work[:4]``): every array passed to a compiled call is
a dozen machine-level arguments, and passing the whole ``items`` and ``work`` there made every
``ipso`` run slower (docs/solvers/pso.md, "Beside 0.4").
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from optplan.geometry.compiled import (
    B1,
    B2,
    F1,
    F2,
    F3,
    I1,
    I2,
    b1,
    compiled,
    f8,
    i8,
    inlined,
    leaf,
)

__all__ = ["pair", "crossings", "clearance"]

#: a segment ``ax, ay, dx, dy`` (scalar arguments of the ``@leaf`` screens)
_SEG = (f8, f8, f8, f8)
#: ``items``: ``K, P, E, N, C, CE, B, IC, IR, CR, OWN`` (module docstring)
ITEMS = types.Tuple((i8, F3, F3, F3, F2, F2, B2, F2, F1, F1, I1))
#: ``grid``: ``use_grid, h, x0, y0, nx, ny, start, count, items`` (module docstring)
GRID = types.Tuple((b1, f8, f8, f8, i8, i8, I1, I1, I1))
#: ``work``: ``BB, mask, stamp, cand, touched, o_stamp, o_close, o_in, o_pen`` (module docstring)
WORK = types.Tuple((F2, B1, I1, I1, I1, I1, B1, F1, F1))
#: ``shp`` of :func:`pair`: ``K, P, E, N, C, CE, IC, CR`` (:func:`shapes` of ``items``)
SHAPES = types.Tuple((i8, F3, F3, F3, F2, F2, F2, F1))
#: ``scan``: ``work[:4]``, the scratch arrays of :func:`_candidates` (``BB, mask, stamp, cand``)
SCAN = types.Tuple((F2, B1, I1, I1))


@leaf(f8)
def _clamp01(t):
    if t < 0.0:
        return 0.0
    if t > 1.0:
        return 1.0
    return t


@leaf(f8, f8, f8, f8, f8, f8)
def _pt_seg2(qx, qy, px, py, ex, ey):
    """Squared distance from point q to segment p -> p + e."""
    ee = ex * ex + ey * ey
    t = 0.0
    if ee > 0.0:
        t = _clamp01(((qx - px) * ex + (qy - py) * ey) / ee)
    dx = px + t * ex - qx
    dy = py + t * ey - qy
    return dx * dx + dy * dy


@leaf(*_SEG, i8, F3, F2)
def _clip(ax, ay, dx, dy, k, N, C):
    """Cyrus-Beck: parameter interval of A + tD, t in [0, 1], inside the half-planes
    ``N[k, j] . x <= C[k, j]``."""
    t_in = 0.0
    t_out = 1.0
    for j in range(4):
        nx = N[k, j, 0]
        ny = N[k, j, 1]
        g = nx * ax + ny * ay - C[k, j]
        den = nx * dx + ny * dy
        if den == 0.0:
            if g > 0.0:
                return 1.0, 0.0
            continue
        t = -g / den
        if den < 0.0:
            if t > t_in:
                t_in = t
        elif t < t_out:
            t_out = t
        if t_in > t_out:
            return t_in, t_out
    return t_in, t_out


@inlined  # one call site (pair)
def _pair_circle(ax, ay, dx, dy, dl, k, K, IC, CR, eps):
    """:func:`pair` for circle item ``k``: centre-to-segment distance minus the radius, and the
    chord length inside the circle shrunk by ``eps``."""
    cx = IC[k, 0]
    cy = IC[k, 1]
    R = CR[k - K]
    wx = cx - ax
    wy = cy - ay
    dd = dx * dx + dy * dy
    tl = 0.0
    if dd > 0.0:
        tl = (wx * dx + wy * dy) / dd
    t = _clamp01(tl)
    fx = wx - t * dx
    fy = wy - t * dy
    dist = math.sqrt(fx * fx + fy * fy) - R
    if dist < 0.0:
        dist = 0.0
    inside = 0.0
    re = R - eps
    if re > 0.0 and dd > 0.0:
        lx = wx - tl * dx
        ly = wy - tl * dy
        h2 = re * re - (lx * lx + ly * ly)
        if h2 > 0.0:
            half = math.sqrt(h2 / dd)
            a = tl - half
            b = tl + half
            if a < 0.0:
                a = 0.0
            if b > 1.0:
                b = 1.0
            if b > a:
                inside = (b - a) * dl
    return dist, inside


@inlined  # one call site (pair)
def _piece_distance(ax, ay, dx, dy, k, P, E):
    """Distance from segment ``A -> A + D`` to convex piece ``k`` when they do not meet: the
    smallest vertex-to-segment and endpoint-to-edge distance (disjoint convex sets)."""
    bx = ax + dx
    by = ay + dy
    d2 = math.inf
    for j in range(4):
        px = P[k, j, 0]
        py = P[k, j, 1]
        ex = E[k, j, 0]
        ey = E[k, j, 1]
        v = _pt_seg2(px, py, ax, ay, dx, dy)  # vertex -> segment
        if v < d2:
            d2 = v
        v = _pt_seg2(ax, ay, px, py, ex, ey)  # A -> edge
        if v < d2:
            d2 = v
        v = _pt_seg2(bx, by, px, py, ex, ey)  # B -> edge
        if v < d2:
            d2 = v
    return math.sqrt(d2)


@inlined
def shapes(items):
    """The arrays of ``items`` that :func:`pair` reads: ``(K, P, E, N, C, CE, IC, CR)``."""
    return (items[0], items[1], items[2], items[3], items[4], items[5], items[7], items[9])


@leaf(*_SEG, i8, SHAPES, f8)
def pair(ax, ay, dx, dy, k, shp, eps):
    """Exact ``(dist, inside)`` of segment ``A -> A + D`` and item ``k`` of the items'
    shapes ``shp`` (:func:`shapes` of ``items``; module docstring: it takes only the arrays
    it reads)."""
    K, P, E, N, C, CE, IC, CR = shp
    dl = math.sqrt(dx * dx + dy * dy)
    if k >= K:  # circle
        return _pair_circle(ax, ay, dx, dy, dl, k, K, IC, CR, eps)
    t_in, t_out = _clip(ax, ay, dx, dy, k, N, C)
    if t_in <= t_out:
        e_in, e_out = _clip(ax, ay, dx, dy, k, N, CE)
        inside = 0.0
        if e_out > e_in:
            inside = (e_out - e_in) * dl
        return 0.0, inside
    return _piece_distance(ax, ay, dx, dy, k, P, E), 0.0


@leaf(*_SEG, i8, F3, F2, f8)
def _apart(ax, ay, dx, dy, k, N, C, lim):
    """Both segment ends at least ``lim`` outside one edge line of piece ``k``: the segment is
    farther than ``lim`` from the piece (a separating axis), so the pair cannot collide."""
    bx = ax + dx
    by = ay + dy
    for j in range(4):
        nx = N[k, j, 0]
        ny = N[k, j, 1]
        if nx * ax + ny * ay - C[k, j] >= lim and nx * bx + ny * by - C[k, j] >= lim:
            return True
    return False


@leaf(*_SEG, i8, F2, F1, f8)
def _near_item(ax, ay, dx, dy, k, IC, IR, lim):
    """The item's bounding circle comes within ``lim`` of the segment."""
    wx = IC[k, 0] - ax
    wy = IC[k, 1] - ay
    dd = dx * dx + dy * dy
    p = wx * dx + wy * dy
    t = 0.0  # _clamp01(p / dd), dividing only when the projection falls inside the segment
    if dd > 0.0 and p > 0.0:
        t = 1.0 if p >= dd else p / dd
    fx = wx - t * dx
    fy = wy - t * dy
    r = IR[k] + lim
    return fx * fx + fy * fy <= r * r


@compiled(i8, F3, F2, F1, f8)
def _item_boxes(K, P, IC, CR, lim):
    """Axis-aligned box of every item grown by ``lim``, rows ``x_lo, x_hi, y_lo, y_hi`` of a
    ``(4, n_items)`` array: a piece's vertices, a circle's centre +- radius."""
    n_items = IC.shape[0]
    bb = np.empty((4, n_items))
    for k in range(n_items):
        if k < K:
            bb[0, k] = min(P[k, 0, 0], P[k, 1, 0], P[k, 2, 0], P[k, 3, 0]) - lim
            bb[1, k] = max(P[k, 0, 0], P[k, 1, 0], P[k, 2, 0], P[k, 3, 0]) + lim
            bb[2, k] = min(P[k, 0, 1], P[k, 1, 1], P[k, 2, 1], P[k, 3, 1]) - lim
            bb[3, k] = max(P[k, 0, 1], P[k, 1, 1], P[k, 2, 1], P[k, 3, 1]) + lim
        else:
            R = CR[k - K] + lim
            bb[0, k] = IC[k, 0] - R
            bb[1, k] = IC[k, 0] + R
            bb[2, k] = IC[k, 1] - R
            bb[3, k] = IC[k, 1] + R
    return bb


@inlined
def _box_mask(ax, ay, dx, dy, BB, mask):
    """``mask[k]``: the box ``BB[:, k]`` meets the segment's box (one branch-free pass over
    the items, which the compiler vectorises)."""
    bx = ax + dx
    by = ay + dy
    lx = min(ax, bx)
    hx = max(ax, bx)
    ly = min(ay, by)
    hy = max(ay, by)
    for k in range(BB.shape[1]):
        mask[k] = (BB[0, k] <= hx) & (BB[1, k] >= lx) & (BB[2, k] <= hy) & (BB[3, k] >= ly)


@leaf(*_SEG, types.Tuple((F2, F1)), GRID, f8, SCAN, i8)
def _candidates(ax, ay, dx, dy, reach, grid, lim, scan, sid):
    """Items whose bounding circle (``reach = (IC, IR)`` of ``items``) is within ``lim`` of
    the segment, written to ``cand`` of ``scan = work[:4]`` (de-duplicated with its
    ``stamp``; with a grid every listed item is stamped ``sid``); returns their number.
    Without a grid, the items' boxes grown by ``lim`` (``BB``, :func:`_item_boxes`) are first
    compared with the segment's box in one branch-free pass (into ``mask``): an item outside
    it is farther than ``lim`` from the segment, so neither a collision nor a penetration is
    lost.  It takes only the arrays it reads (module docstring)."""
    IC, IR = reach
    n_items = IC.shape[0]
    use_grid, gh, gx0, gy0, gnx, gny, gstart, gcount, gitems = grid
    BB, mask, stamp, out = scan
    m = 0
    if not use_grid:
        _box_mask(ax, ay, dx, dy, BB, mask)
        for k in range(n_items):
            if mask[k] and _near_item(ax, ay, dx, dy, k, IC, IR, lim):
                out[m] = k
                m += 1
        return m
    bx = ax + dx
    by = ay + dy
    xa, ya, xb, yb = ax, ay, bx, by
    if xb < xa:
        xa, ya, xb, yb = bx, by, ax, ay
    i0 = int(math.floor((xa - gx0) / gh))
    i1 = int(math.floor((xb - gx0) / gh))
    i0 = min(max(i0, 0), gnx - 1)
    i1 = min(max(i1, 0), gnx - 1)
    sx = xb - xa
    for col in range(i0, i1 + 1):
        lo = -math.inf if col == 0 else gx0 + col * gh
        hi = math.inf if col == gnx - 1 else gx0 + (col + 1) * gh
        xl = max(xa, lo)
        xr = min(xb, hi)
        if sx > 0.0:
            y1 = ya + (xl - xa) * (yb - ya) / sx
            y2 = ya + (xr - xa) * (yb - ya) / sx
        else:
            y1 = ya
            y2 = yb
        j0 = int(math.floor((min(y1, y2) - gy0) / gh))
        j1 = int(math.floor((max(y1, y2) - gy0) / gh))
        j0 = min(max(j0, 0), gny - 1)
        j1 = min(max(j1, 0), gny - 1)
        for row in range(j0, j1 + 1):
            cell = col * gny + row
            s = gstart[cell]
            for q in range(s, s + gcount[cell]):
                k = gitems[q]
                if stamp[k] == sid:
                    continue
                stamp[k] = sid
                if _near_item(ax, ay, dx, dy, k, IC, IR, lim):
                    out[m] = k
                    m += 1
    return m


@inlined  # one call site (crossings)
def _segment_items(seg, s, m, items, r, eps, lim, want_pen, work):
    """One segment ``seg`` of :func:`crossings` against its ``m`` candidate items (``cand`` of
    ``work``): per obstacle met (listed in ``touched``, stamped ``s``) whether an item is
    closer than ``r - eps``, the summed ``inside`` and the penetration; returns the number of
    obstacles met."""
    ax, ay, dx, dy = seg
    K = items[0]
    N = items[3]
    C = items[4]
    OWN = items[10]
    _, _, _, cand, touched, o_stamp, o_close, o_in, o_pen = work
    nt = 0
    for q in range(m):
        k = cand[q]
        if k < K and _apart(ax, ay, dx, dy, k, N, C, lim):
            continue
        dist, inside = pair(ax, ay, dx, dy, k, shapes(items), eps)
        o = OWN[k]
        if o_stamp[o] != s:
            o_stamp[o] = s
            o_close[o] = False
            o_in[o] = 0.0
            o_pen[o] = 0.0
            touched[nt] = o
            nt += 1
        if dist < r - eps:
            o_close[o] = True
        o_in[o] += inside
        if want_pen and (dist < r or inside > 0.0):
            v = r - dist
            if v < 0.0:
                v = 0.0
            o_pen[o] += v + inside
    return nt


@compiled(F2, F2, i8, ITEMS, i8, GRID, f8, f8, b1, I2)
def crossings(A, D, S, items, n_obs, grid, r, eps, want_pen, hits):
    """Collision count (and penetration) per path for segments ``A[s] -> A[s] + D[s]``, ``S``
    segments per path, against ``items`` (``n_obs`` obstacles, ``grid``: module docstring);
    colliding (segment, obstacle) pairs into ``hits`` (rows ``(s, o)``).

    Returns ``(count per path, penetration per path, number of hits)``; when the number of
    hits exceeds ``len(hits)`` only the first ones are stored (the caller retries larger).
    The scratch arrays are made here, the loop is :func:`_crossings_loop` (a ``@leaf``).
    """
    K, P, _, _, _, _, _, IC, _, CR, _ = items
    P_n = A.shape[0] // S if S > 0 else 0
    # np.empty, not np.zeros / np.full: each allocation routine is one more compilation;
    # the loop initialises what it reads
    count = np.empty(P_n, np.int64)
    pen = np.empty(P_n)
    n_items = IC.shape[0]
    lim = r + 2.0 * eps
    mask, stamp, cand, touched, o_stamp, o_close, o_in, o_pen = (
        np.empty(n_items, np.bool_), np.empty(n_items, np.int64), np.empty(n_items, np.int64),
        np.empty(n_items, np.int64), np.empty(n_obs, np.int64), np.empty(n_obs, np.bool_),
        np.empty(n_obs), np.empty(n_obs))
    work = (_item_boxes(K, P, IC, CR, lim), mask, stamp, cand, touched, o_stamp, o_close,
            o_in, o_pen)
    n_hits = _crossings_loop(A, D, S, items, grid, r, eps, want_pen, (count, pen, hits), work)
    return count, pen, n_hits


@leaf(F2, F2, i8, ITEMS, GRID, f8, f8, b1, types.Tuple((I1, F1, I2)), WORK)
def _crossings_loop(A, D, S, items, grid, r, eps, want_pen, out, work):
    """The loop of :func:`crossings` over its ``work`` arrays (uninitialised: set here) into
    ``out = (count, pen, hits)``; returns the number of hits."""
    count, pen, hits = out
    stamp = work[2]
    touched = work[4]
    o_stamp = work[5]
    o_close = work[6]
    o_in = work[7]
    o_pen = work[8]
    lim = r + 2.0 * eps
    n_seg = A.shape[0]
    for p in range(count.shape[0]):
        count[p] = 0
        pen[p] = 0.0
    for k in range(stamp.shape[0]):
        stamp[k] = -1
    for o in range(o_stamp.shape[0]):  # o_close, o_in, o_pen: set when o is first met
        o_stamp[o] = -1
    n_hits = 0
    for s in range(n_seg):
        ax = A[s, 0]
        ay = A[s, 1]
        dx = D[s, 0]
        dy = D[s, 1]
        m = _candidates(ax, ay, dx, dy, (items[7], items[8]), grid, lim, work[:4], s)
        nt = _segment_items((ax, ay, dx, dy), s, m, items, r, eps, lim, want_pen, work)
        path = s // S
        for q in range(nt):
            o = touched[q]
            if o_close[o] or o_in[o] > eps:
                count[path] += 1
                pen[path] += o_pen[o]
                if n_hits < hits.shape[0]:
                    hits[n_hits, 0] = s
                    hits[n_hits, 1] = o
                n_hits += 1
    return n_hits


@compiled(F2, F2, ITEMS, f8, f8)
def clearance(A, D, items, eps, max_dist):
    """Per segment the exact minimum of ``dist - inside / 2`` over all items (``inf`` with no
    item within ``max_dist``); bounding circles prune items that cannot beat the best bound
    (the loop is :func:`_clearance_loop`, a ``@leaf``)."""
    out = np.empty(A.shape[0])  # every entry is set by the loop
    _clearance_loop(A, D, items, eps, max_dist, out, np.empty(items[7].shape[0]))
    return out


@leaf(F2, F2, ITEMS, f8, f8, F1, F1)
def _clearance_loop(A, D, items, eps, max_dist, out, cd):
    """The loop of :func:`clearance` (``cd``: scratch, one distance per item)."""
    IC = items[7]
    IR = items[8]
    n_items = IC.shape[0]
    for s in range(A.shape[0]):
        ax = A[s, 0]
        ay = A[s, 1]
        dx = D[s, 0]
        dy = D[s, 1]
        dd = dx * dx + dy * dy
        ub = math.inf
        for k in range(n_items):
            wx = IC[k, 0] - ax
            wy = IC[k, 1] - ay
            t = 0.0
            if dd > 0.0:
                t = _clamp01((wx * dx + wy * dy) / dd)
            fx = wx - t * dx
            fy = wy - t * dy
            cd[k] = math.sqrt(fx * fx + fy * fy)
            if cd[k] + IR[k] < ub:
                ub = cd[k] + IR[k]
        best = math.inf
        for k in range(n_items):
            lb = cd[k] - IR[k]
            if lb > ub or lb > max_dist or lb > best:
                continue
            dist, inside = pair(ax, ay, dx, dy, k, shapes(items), eps)
            v = dist - 0.5 * inside
            if v < best:
                best = v
        out[s] = best
