"""Optional compiled engine (numba) for :meth:`optplan.geometry.ObstacleSet.crossings`.

The numpy kernel spends most of its time building ``(4, pairs)`` temporaries; for the small
batches of a swarm (tens of paths x a few segments x a few obstacles) plain compiled loops with
early exits are several times faster.  This module is optional: ``numba`` is an extra
(``pip install optplan[fast]``); without it :data:`AVAILABLE` is False and optplan uses numpy.

What it computes is exactly what ``ObstacleSet.crossings(..., details=False)`` computes with
numpy (per path: the number of distinct colliding (segment, obstacle) pairs and, optionally,
the penetration sum); only the candidate pre-filter and the loop order differ:

* candidates: every item when the set has no grid (few items), each rejected at once when its
  bounding box is farther than ``radius + tol`` from the segment's box; with a grid, the
  segment walks the same cells as the numpy supercover (column by column) and the items listed
  there are de-duplicated with a stamp array, so the work per segment grows with the obstacles
  near it, not with all of them;
* per (segment, piece) pair the decision uses the same floating-point expressions as the numpy
  path (separating axes then the vertex/endpoint distances for ``penetration=False``;
  Cyrus-Beck clipping then squared distances for ``penetration=True``; the exact circle
  distance), so decisions agree on borderline cases up to the rounding of numpy's own
  (possibly fused) complex products;
* an obstacle split into several pieces counts once per segment (a per-obstacle stamp); in
  the count-only mode the remaining pieces of an obstacle already counted are skipped.

The compiled functions are ``@njit(cache=True)`` (serial, no fastmath, deterministic) and are
compiled on their first call (never at ``import optplan``); the machine code is cached in
``__pycache__`` so later processes only load it.
"""

from __future__ import annotations

import math
import weakref
from typing import Any

import numpy as np

try:  # numba is optional: optplan must import and work without it
    import numba as _numba
except Exception:  # pragma: no cover - depends on the environment  # noqa: BLE001
    _numba = None

#: True when numba can be imported (the compiled engine is usable).
AVAILABLE: bool = _numba is not None

__all__ = ["AVAILABLE", "jit", "crossings", "prepare"]

# per-ObstacleSet flat arrays for the compiled loops (built once, dropped with the set)
_PREPARED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


#: "No collision" from the penetration tests (a colliding pair can have a slightly negative
#: penetration ``r - dist`` when ``r < dist < r_eff``, so a negative value is not a sentinel).
_NO_HIT = -math.inf

#: Relative band around a squared threshold inside which the exact ``hypot`` decides.
_BAND = 1e-10


def jit(fn):
    """``numba.njit(cache=True)`` when numba is present, else the plain Python function."""
    if _numba is None:
        return fn
    return _numba.njit(cache=True, fastmath=False, nogil=True)(fn)


# --------------------------------------------------------------------------------------
# per-pair tests (same expressions as the numpy path in optplan.geometry.ObstacleSet)
# --------------------------------------------------------------------------------------


@jit
def _clamp01(t):
    """``t`` clipped to ``[0, 1]``."""
    if t < 0.0:
        return 0.0
    if t > 1.0:
        return 1.0
    return t


@jit
def _edge_d2(wx, wy, ex, ey, eex, eey):
    """Squared distance from a point to an edge, ``w`` = edge start - point, ``e`` = edge
    vector, ``(eex, eey)`` = ``-conj(e) / |e|^2`` (the numpy path's ``ee``)."""
    s = _clamp01(wx * eex - wy * eey)
    xx = wx + s * ex
    xy = wy + s * ey
    return xx * xx + xy * xy


@jit
def _closer(x, y, r, r2lo, r2hi):
    """``hypot(x, y) < r`` (numpy's ``abs(complex) < r``), deciding by ``x^2 + y^2`` when it is
    clearly inside ``r2lo`` / outside ``r2hi`` (a relative band far wider than its round-off)
    and calling the slower ``hypot`` only in the band."""
    d2 = x * x + y * y
    if d2 < r2lo:
        return True
    if d2 > r2hi:
        return False
    return math.hypot(x, y) < r


@jit
def _piece_hit_count(pt, k, ax, ay, dx, dy, slen, inv, r_eff, reject, r2lo, r2hi):
    """Collision of segment ``A + t D`` with convex piece ``k`` (count-only test).

    Mirrors ``ObstacleSet._piece_hits``: the pair collides unless a separating axis exists
    (the segment's line has every vertex strictly on one side, or both endpoints lie strictly
    outside one edge line), or, if one exists, when the smallest vertex-to-segment or
    endpoint-to-edge distance is below ``r_eff``.  ``reject`` (slightly above ``r_eff``) gives
    two early exits: both endpoints farther than that outside one edge line, or every vertex
    farther than that from the segment's line (``slen = |D|``), on one side.
    """
    cmin = math.inf
    cmax = -math.inf
    hmin = math.inf
    for j in range(4):
        wx = pt[k, j, 0] - ax
        wy = pt[k, j, 1] - ay
        cr = wy * dx - wx * dy  # d x (p - A)
        if cr < cmin:
            cmin = cr
        if cr > cmax:
            cmax = cr
        nx = pt[k, j, 4]
        ny = pt[k, j, 5]
        ha = wx * nx + wy * ny  # n . (p - A): < 0 when A is strictly outside edge j
        hb = (wx - dx) * nx + (wy - dy) * ny
        h = ha if ha > hb else hb
        if h < hmin:
            hmin = h
    if not (cmin * cmax > 0.0 or hmin < 0.0):
        return True  # no separating axis: the segment meets the closed piece
    if hmin < -reject:
        return False  # both endpoints well beyond one edge line
    if cmin > reject * slen or cmax < -reject * slen:
        return False  # every vertex well beyond the segment's line, on one side
    for j in range(4):
        px = pt[k, j, 0]
        py = pt[k, j, 1]
        wx = px - ax
        wy = py - ay
        t = (wx * dx + wy * dy) * inv  # vertex -> segment
        t = _clamp01(t)
        if _closer(wx - t * dx, wy - t * dy, r_eff, r2lo, r2hi):
            return True
        ex = pt[k, j, 2]
        ey = pt[k, j, 3]
        eex = pt[k, j, 6]
        eey = pt[k, j, 7]
        s = wx * eex - wy * eey  # A -> edge j
        s = _clamp01(s)
        if _closer(wx + s * ex, wy + s * ey, r_eff, r2lo, r2hi):
            return True
        wx -= dx  # vertex - B
        wy -= dy
        s = wx * eex - wy * eey  # B -> edge j
        s = _clamp01(s)
        if _closer(wx + s * ex, wy + s * ey, r_eff, r2lo, r2hi):
            return True
    return False


@jit
def _piece_pen(pt, k, ax, ay, dx, dy, dd, inv, radius, r_eff):
    """Penetration of segment ``A + t D`` into piece ``k``, or ``_NO_HIT`` when they do not collide.

    Mirrors the penetration branch of ``ObstacleSet.crossings``: Cyrus-Beck clipping against
    the piece's half-planes gives ``meets`` and the inside length; a pair at least ``r_eff``
    outside one half-plane is apart; otherwise the squared exact distance decides.
    """
    apart = False
    t_in = -math.inf
    t_out = math.inf
    for j in range(4):
        nx = pt[k, j, 4]
        ny = pt[k, j, 5]
        ga = (nx * ax + ny * ay) - pt[k, j, 8]  # n . A - c
        den = nx * dx + ny * dy  # n . D
        gb = ga + den
        if (ga if ga < gb else gb) >= r_eff:
            apart = True
        if den == 0.0:
            den = -1e-200  # parallel: outside (ga > 0) -> t = +huge, never meets
        tt = ga / -den
        if den < 0.0:
            if tt > t_in:
                t_in = tt
        elif tt < t_out:
            t_out = tt
    if t_in < 0.0:
        t_in = 0.0
    if t_out > 1.0:
        t_out = 1.0
    if t_in <= t_out:
        return radius + (t_out - t_in) * math.sqrt(dd)
    if apart:
        return _NO_HIT
    d2 = math.inf
    for j in range(4):
        wx = pt[k, j, 0] - ax
        wy = pt[k, j, 1] - ay
        ex = pt[k, j, 2]
        ey = pt[k, j, 3]
        eex = pt[k, j, 6]
        eey = pt[k, j, 7]
        t = (wx * dx + wy * dy) * inv
        t = _clamp01(t)
        xx = wx - t * dx
        xy = wy - t * dy
        v = xx * xx + xy * xy
        if v < d2:
            d2 = v
        v = _edge_d2(wx, wy, ex, ey, eex, eey)
        if v < d2:
            d2 = v
        wx -= dx
        wy -= dy
        v = _edge_d2(wx, wy, ex, ey, eex, eey)
        if v < d2:
            d2 = v
    if d2 < r_eff * r_eff:
        return radius - math.sqrt(d2)
    return _NO_HIT


@jit
def _circle_pen(cx, cy, ro, ax, ay, dx, dy, dd, inv, radius, r_eff, penetration):
    """Circle test (exact center-segment distance): penetration, 0 (count only) or
    :data:`_NO_HIT`."""
    wx = cx - ax
    wy = cy - ay
    tl = (wx * dx + wy * dy) * inv  # foot of the center on the line
    t = tl
    t = _clamp01(t)
    xx = wx - t * dx
    xy = wy - t * dy
    lim = ro + r_eff  # decide by the squared distance unless it is within round-off of lim
    d2 = xx * xx + xy * xy
    if d2 > lim * lim * (1.0 + _BAND):
        return _NO_HIT
    if not penetration and d2 < lim * lim * (1.0 - _BAND):
        return 0.0
    gap = math.hypot(xx, xy) - ro
    if not gap < r_eff:
        return _NO_HIT
    if not penetration:
        return 0.0
    if gap > 0.0:
        return radius - gap
    q = math.hypot(wx - tl * dx, wy - tl * dy)
    v = ro * ro - q ** 2
    if v < 0.0:
        v = 0.0
    half = math.sqrt(v * inv)
    hi = tl + half
    if hi > 1.0:
        hi = 1.0
    lo = tl - half
    if lo < 0.0:
        lo = 0.0
    chord = hi - lo
    if chord < 0.0:
        chord = 0.0
    return radius + chord * math.sqrt(dd)


# --------------------------------------------------------------------------------------
# candidates
# --------------------------------------------------------------------------------------


@jit
def _grid_candidates(ax, ay, bx, by, h, gx0, gy0, nx, ny, start, count, items, stamp, tag,
                     buf):
    """Items listed in the grid cells the segment crosses (numpy's supercover walk).

    Fills ``buf`` with distinct items (``stamp[item] == tag`` marks the ones seen) and returns
    their number.
    """
    if bx < ax:
        xa, ya, xb, yb = bx, by, ax, ay
    else:
        xa, ya, xb, yb = ax, ay, bx, by
    top_x = nx - 1.0
    top_y = ny - 1.0
    i0 = int(min(max(math.floor((xa - gx0) / h), 0.0), top_x))
    i1 = int(min(max(math.floor((xb - gx0) / h), 0.0), top_x))
    dx = xb - xa
    flat = not dx > 0.0
    slope = 0.0 if flat else (yb - ya) / dx
    n = 0
    for col in range(i0, i1 + 1):
        lo = -math.inf if col == 0 else gx0 + col * h
        hi = math.inf if col == nx - 1 else gx0 + (col + 1) * h
        if flat:
            y1 = ya
            y2 = yb
        else:
            y1 = ya + (max(xa, lo) - xa) * slope
            y2 = ya + (min(xb, hi) - xa) * slope
        j0 = int(min(max(math.floor((min(y1, y2) - gy0) / h), 0.0), top_y))
        j1 = int(min(max(math.floor((max(y1, y2) - gy0) / h), 0.0), top_y))
        for j in range(j0, j1 + 1):
            cell = col * ny + j
            s0 = start[cell]
            for m in range(s0, s0 + count[cell]):
                it = items[m]
                if stamp[it] != tag:
                    stamp[it] = tag
                    buf[n] = it
                    n += 1
    return n


# --------------------------------------------------------------------------------------
# the batch kernel
# --------------------------------------------------------------------------------------


@jit
def _crossings(pts, penetration, count_out, pen_out, pt, box, circ, item_obstacle, fpar,
               ipar, start, count, items):
    """Per-path collision counts (and penetration) of polylines ``pts`` ``(P, M, 2)``.

    ``fpar = (radius, r_eff, reject, h, gx0, gy0)``, ``ipar = (n_pieces, n_obstacles,
    use_grid, nx, ny)`` (packed: fewer arguments, cheaper dispatch).
    """
    radius, r_eff, reject, h, gx0, gy0 = fpar[0], fpar[1], fpar[2], fpar[3], fpar[4], fpar[5]
    n_pieces, n_obstacles, nx, ny = ipar[0], ipar[1], ipar[3], ipar[4]
    use_grid = ipar[2] != 0
    P = pts.shape[0]
    S = pts.shape[1] - 1
    n_items = item_obstacle.shape[0]
    seen = np.full(n_obstacles, -1, np.int64)  # segment that last counted each obstacle
    stamp = np.full(n_items, -1, np.int64)  # segment that last listed each item (grid)
    buf = np.empty(n_items, np.int64)
    r2lo = r_eff * r_eff * (1.0 - _BAND)
    r2hi = r_eff * r_eff * (1.0 + _BAND)
    for p in range(P):
        c = 0
        pen = 0.0
        for s in range(S):
            tag = p * S + s
            ax = pts[p, s, 0]
            ay = pts[p, s, 1]
            bx = pts[p, s + 1, 0]
            by = pts[p, s + 1, 1]
            dx = bx - ax
            dy = by - ay
            dd = dx * dx + dy * dy
            inv = 1.0 / (dd if dd > 1e-300 else 1e-300)  # degenerate segments: t = 0
            slen = math.sqrt(dd)
            xlo = (ax if ax < bx else bx) - reject
            xhi = (ax if ax > bx else bx) + reject
            ylo = (ay if ay < by else by) - reject
            yhi = (ay if ay > by else by) + reject
            if use_grid:
                n = _grid_candidates(ax, ay, bx, by, h, gx0, gy0, nx, ny, start, count, items,
                                     stamp, tag, buf)
                # keep the listed items whose box is near the segment's box
                m = 0
                for i in range(n):
                    k = buf[i]
                    buf[m] = k
                    m += ((box[0, k] <= xhi) & (box[1, k] >= xlo)
                          & (box[2, k] <= yhi) & (box[3, k] >= ylo))
                n = m
            else:
                n = n_items
            for m in range(n):
                if use_grid:
                    k = buf[m]
                else:  # all items: skip those whose box is far from the segment's box
                    k = m
                    if not ((box[0, k] <= xhi) & (box[1, k] >= xlo)
                            & (box[2, k] <= yhi) & (box[3, k] >= ylo)):
                        continue
                o = item_obstacle[k]
                if not penetration and seen[o] == tag:
                    continue  # obstacle already counted for this segment
                if k >= n_pieces:
                    i = k - n_pieces
                    v = _circle_pen(circ[i, 0], circ[i, 1], circ[i, 2], ax, ay, dx, dy, dd,
                                    inv, radius, r_eff, penetration)
                    hit = v != _NO_HIT
                elif penetration:
                    v = _piece_pen(pt, k, ax, ay, dx, dy, dd, inv, radius, r_eff)
                    hit = v != _NO_HIT
                else:
                    v = 0.0
                    hit = _piece_hit_count(pt, k, ax, ay, dx, dy, slen, inv, r_eff, reject,
                                           r2lo, r2hi)
                if hit:
                    pen += v
                    if seen[o] != tag:
                        seen[o] = tag
                        c += 1
        count_out[p] = c
        pen_out[p] = pen
    return 0


# --------------------------------------------------------------------------------------
# Python entry points
# --------------------------------------------------------------------------------------


def prepare(obs: Any) -> tuple:
    """The arguments of the compiled kernel for an :class:`~optplan.geometry.ObstacleSet`.

    Flat float64/int64 arrays, built once per set (cached while the set lives).
    """
    got = _PREPARED.get(obs)
    if got is not None:
        return got
    K = obs.n_pieces
    tab = obs.table  # (5, 4, K) complex: p, e, n, -conj(e)/|e|^2, c
    pt = np.empty((K, 4, 9))
    for f, (row, part) in enumerate([(0, "r"), (0, "i"), (1, "r"), (1, "i"), (2, "r"),
                                     (2, "i"), (3, "r"), (3, "i"), (4, "r")]):
        pt[:, :, f] = (tab[row].real if part == "r" else tab[row].imag).T
    n_items = obs.n_items
    cen = np.asarray(obs.item_center)
    circ = np.empty((n_items - K, 3))
    circ[:, 0] = cen[K:].real
    circ[:, 1] = cen[K:].imag
    circ[:, 2] = obs.circle_radius
    box = np.empty((4, n_items))  # rows xmin, xmax, ymin, ymax of each raw item
    if K:
        box[0, :K] = pt[:, :, 0].min(axis=1)
        box[1, :K] = pt[:, :, 0].max(axis=1)
        box[2, :K] = pt[:, :, 1].min(axis=1)
        box[3, :K] = pt[:, :, 1].max(axis=1)
    box[0, K:] = circ[:, 0] - circ[:, 2]
    box[1, K:] = circ[:, 0] + circ[:, 2]
    box[2, K:] = circ[:, 1] - circ[:, 2]
    box[3, K:] = circ[:, 1] + circ[:, 2]
    g = obs.grid
    r_eff = obs.radius + 1e-9 * obs.scale
    # early-reject margin: r_eff plus far more than the rounding of the distances
    reject = r_eff + 1e-12 * obs.scale
    if g is None:
        fpar = [obs.radius, r_eff, reject, 1.0, 0.0, 0.0]
        ipar = [K, obs.n_obstacles, 0, 1, 1]
        cells = (np.zeros(1, np.int64),) * 3
    else:
        fpar = [obs.radius, r_eff, reject, g["h"], g["x0"], g["y0"]]
        ipar = [K, obs.n_obstacles, 1, g["nx"], g["ny"]]
        cells = tuple(np.ascontiguousarray(g[key], np.int64)
                      for key in ("start", "count", "items"))
    got = (np.ascontiguousarray(pt), box, circ,
           np.ascontiguousarray(obs.item_obstacle, np.int64),
           np.array(fpar, np.float64), np.array(ipar, np.int64), *cells)
    _PREPARED[obs] = got
    return got


def crossings(obs: Any, pts: np.ndarray, penetration: bool = True) -> tuple[np.ndarray,
                                                                           np.ndarray]:
    """``(count, penetration)`` per path of ``pts`` ``(P, M, 2)`` (M >= 2) against ``obs``.

    The compiled counterpart of ``obs.crossings(pts, details=False, engine="numpy")``;
    penetration is zeros when ``penetration`` is False.
    """
    if not AVAILABLE:
        raise ImportError("numba is not installed: install optplan[fast]")
    q = prepare(obs)
    if pts.dtype != np.float64 or not pts.flags.c_contiguous:
        pts = np.ascontiguousarray(pts, dtype=np.float64)
    P = pts.shape[0]
    count = np.zeros(P, np.int64)
    pen = np.zeros(P)
    _crossings(pts, bool(penetration), count, pen, *q)
    return count, pen
