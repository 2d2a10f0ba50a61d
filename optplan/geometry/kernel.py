"""Compiled loops of the exact collision engine (numba; the only implementation).

Every function here is ``@njit(cache=True)``: compiled on first use (a few seconds once per
machine; the machine code is cached in ``__pycache__``) and tested against shapely in
``tests/geometry/test_geometry.py``.  Why compiled: the engine answers many small queries (a swarm's
fitness: tens of paths x a few segments x the obstacles near them, thousands of times per run);
per-query numpy overhead, not arithmetic, would dominate, and early exits per (segment, item)
pair are natural in loops.  The maths is in :mod:`optplan.geometry.obstacles`' docstring.

Data layout (local frame, built by :func:`optplan.geometry.obstacles.obstacle_set`):

* pieces ``k < K``: ``P[k, j]`` edge start, ``E[k, j]`` edge vector, ``N[k, j]`` outward unit
  normal, ``C[k, j] = N . P``, ``CE[k, j]`` the offset eroded by ``eps`` on boundary edges,
  ``B[k, j]`` boundary flag (4 edges; a triangle repeats its last edge);
* circles ``k >= K``: centre and radius ``CR[k - K]``;
* every item: bounding circle ``(IC[k], IR[k])``, owning obstacle ``OWN[k]``;
* optional uniform grid: cell size ``h``, origin, shape, CSR item lists.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["pair", "pairs", "crossings", "free_pairs", "clearance"]

_jit = numba.njit(cache=True, fastmath=False, nogil=True)
#: small helpers of a hot loop: inlined into their caller by numba (no call per item)
_jit_inline = numba.njit(cache=True, fastmath=False, nogil=True, inline="always")


@_jit
def _clamp01(t):
    if t < 0.0:
        return 0.0
    if t > 1.0:
        return 1.0
    return t


@_jit
def _pt_seg2(qx, qy, px, py, ex, ey):
    """Squared distance from point q to segment p -> p + e."""
    ee = ex * ex + ey * ey
    t = 0.0
    if ee > 0.0:
        t = _clamp01(((qx - px) * ex + (qy - py) * ey) / ee)
    dx = px + t * ex - qx
    dy = py + t * ey - qy
    return dx * dx + dy * dy


@_jit
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


@_jit
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


@_jit
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


@_jit
def pair(ax, ay, dx, dy, k, K, P, E, N, C, CE, IC, CR, eps):
    """Exact ``(dist, inside)`` of segment ``A -> A + D`` and item ``k`` (module docstring)."""
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


@_jit
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


@_jit
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


@_jit
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


@_jit_inline
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


@_jit
def _candidates(ax, ay, dx, dy, n_items, IC, IR, BB, mask, lim, use_grid, gh, gx0, gy0, gnx,
                gny, gstart, gcount, gitems, stamp, sid, out):
    """Items whose bounding circle is within ``lim`` of the segment, written to ``out``
    (de-duplicated with ``stamp``; with a grid every listed item is stamped ``sid``); returns
    their number.  Without a grid, the items' boxes grown by ``lim`` (``BB``,
    :func:`_item_boxes`) are first compared with the segment's box in one branch-free pass
    (into ``mask``): an item outside it is farther than ``lim`` from the segment, so neither
    a collision nor a penetration is lost."""
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


@_jit
def _segment_items(ax, ay, dx, dy, s, cand, m, K, P, E, N, C, CE, IC, CR, OWN, r, eps, lim,
                   want_pen, o_stamp, o_close, o_in, o_pen, touched):
    """One segment of :func:`crossings` against its ``m`` candidate items: per obstacle met
    (listed in ``touched``, stamped ``s``) whether an item is closer than ``r - eps``, the
    summed ``inside`` and the penetration; returns the number of obstacles met."""
    nt = 0
    for q in range(m):
        k = cand[q]
        if k < K and _apart(ax, ay, dx, dy, k, N, C, lim):
            continue
        dist, inside = pair(ax, ay, dx, dy, k, K, P, E, N, C, CE, IC, CR, eps)
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


@_jit
def crossings(A, D, S, K, P, E, N, C, CE, IC, IR, CR, OWN, n_obs, r, eps, want_pen,
              use_grid, gh, gx0, gy0, gnx, gny, gstart, gcount, gitems, hits):
    """Collision count (and penetration) per path for segments ``A[s] -> A[s] + D[s]``, ``S``
    segments per path; colliding (segment, obstacle) pairs into ``hits`` (rows ``(s, o)``).

    Returns ``(count per path, penetration per path, number of hits)``; when the number of
    hits exceeds ``len(hits)`` only the first ones are stored (the caller retries larger).
    """
    n_seg = A.shape[0]
    P_n = n_seg // S if S > 0 else 0
    count = np.zeros(P_n, np.int64)
    pen = np.zeros(P_n)
    n_items = IC.shape[0]
    stamp = np.full(n_items, -1, np.int64)
    cand = np.empty(n_items, np.int64)
    o_stamp = np.full(n_obs, -1, np.int64)
    o_close = np.zeros(n_obs, np.bool_)
    o_in = np.zeros(n_obs)
    o_pen = np.zeros(n_obs)
    touched = np.empty(n_items, np.int64)
    lim = r + 2.0 * eps
    BB = _item_boxes(K, P, IC, CR, lim)
    mask = np.empty(n_items, np.bool_)
    n_hits = 0
    for s in range(n_seg):
        ax = A[s, 0]
        ay = A[s, 1]
        dx = D[s, 0]
        dy = D[s, 1]
        m = _candidates(ax, ay, dx, dy, n_items, IC, IR, BB, mask, lim, use_grid, gh, gx0,
                        gy0, gnx, gny, gstart, gcount, gitems, stamp, s, cand)
        nt = _segment_items(ax, ay, dx, dy, s, cand, m, K, P, E, N, C, CE, IC, CR, OWN, r,
                            eps, lim, want_pen, o_stamp, o_close, o_in, o_pen, touched)
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
    return count, pen, n_hits


@_jit
def _passes_screens(ax, ay, dx, dy, x0, x1, y0, y1, k, bb, K, N, C, IC, IR, lim):
    """Item ``k`` may be within ``lim`` of the segment: its grown box meets the segment's box
    ``(x0, x1, y0, y1)``, its bounding circle is near, no edge line separates them."""
    if bb[0, k] > x1 or bb[1, k] < x0 or bb[2, k] > y1 or bb[3, k] < y0:
        return False
    if not _near_item(ax, ay, dx, dy, k, IC, IR, lim):
        return False
    return not (k < K and _apart(ax, ay, dx, dy, k, N, C, lim))


@_jit
def _first_blocker(ax, ay, dx, dy, box, q, last, cand, m, use_grid, stamp, bb, K, P, E, N, C,
                   CE, IC, IR, CR, OWN, r, eps, lim, o_stamp, o_in, touched):
    """One segment of :func:`free_pairs` (its box ``(x0, x1, y0, y1)``): the first item closer
    than ``r - eps`` (the item ``last`` tried first), ``-2`` when only an obstacle's summed
    ``inside`` exceeds ``eps``, ``-1`` when the segment is free."""
    x0, x1, y0, y1 = box
    nt = 0
    for c in range(-1, m):
        if c < 0:  # the last colliding item first (with a grid: if the segment lists it)
            k = last
            if k < 0 or (use_grid and stamp[k] != q):
                continue
        else:
            k = cand[c]
            if k == last:
                continue
        if not _passes_screens(ax, ay, dx, dy, x0, x1, y0, y1, k, bb, K, N, C, IC, IR, lim):
            continue
        dist, inside = pair(ax, ay, dx, dy, k, K, P, E, N, C, CE, IC, CR, eps)
        if dist < r - eps:
            return k
        o = OWN[k]
        if o_stamp[o] != q:
            o_stamp[o] = q
            o_in[o] = 0.0
            touched[nt] = o
            nt += 1
        o_in[o] += inside
    for c in range(nt):
        if o_in[touched[c]] > eps:
            return -2
    return -1


@_jit
def free_pairs(L, I, J, K, P, E, N, C, CE, IC, IR, CR, OWN, n_obs, r, eps, use_grid, gh, gx0,
               gy0, gnx, gny, gstart, gcount, gitems):
    """Collision-free flags of the segments ``L[I[q]] -> L[J[q]]`` (local points): the
    decision of :func:`crossings` (``count == 0``: no item with ``dist < r - eps`` and no
    obstacle whose summed ``inside`` exceeds ``eps``), with the same screens and the same
    :func:`pair`, answered with less work.

    * A segment stops at its first colliding item (no count is needed).
    * The item that stopped the previous segment is tried first (consecutive segments of a
      roadmap share an end and are often stopped by the same obstacle).
    * Before the bounding-circle screen, each item's axis-aligned box grown by ``r + 2 eps``
      is compared with the segment's box (no division; an item outside it is farther than
      ``r + 2 eps``, which the screens of :func:`crossings` skip as well).

    Tested against shapely and against :func:`crossings` in ``tests/swarm/test_swarm.py`` (its
    caller is :func:`optplan.swarm.core.pairs_free`).
    """
    n = I.shape[0]
    free = np.ones(n, np.bool_)
    n_items = IC.shape[0]
    lim = r + 2.0 * eps
    bb = _item_boxes(K, P, IC, CR, lim)
    mask = np.empty(n_items, np.bool_)  # scratch of _candidates
    stamp = np.full(n_items, -1, np.int64)
    cand = np.arange(n_items)
    o_stamp = np.full(n_obs, -1, np.int64)
    o_in = np.zeros(n_obs)
    touched = np.empty(n_items, np.int64)
    last = -1
    for q in range(n):
        ax = L[I[q], 0]
        ay = L[I[q], 1]
        bx = L[J[q], 0]
        by = L[J[q], 1]
        dx = bx - ax
        dy = by - ay
        box = (min(ax, bx), max(ax, bx), min(ay, by), max(ay, by))
        m = n_items
        if use_grid:
            m = _candidates(ax, ay, dx, dy, n_items, IC, IR, bb, mask, lim, use_grid, gh, gx0,
                            gy0, gnx, gny, gstart, gcount, gitems, stamp, q, cand)
        blocker = _first_blocker(ax, ay, dx, dy, box, q, last, cand, m, use_grid, stamp, bb, K,
                                 P, E, N, C, CE, IC, IR, CR, OWN, r, eps, lim, o_stamp, o_in,
                                 touched)
        if blocker >= 0:
            last = blocker
        free[q] = blocker == -1
    return free


@_jit
def clearance(A, D, K, P, E, N, C, CE, IC, IR, CR, eps, max_dist):
    """Per segment the exact minimum of ``dist - inside / 2`` over all items (``inf`` with no
    item within ``max_dist``); bounding circles prune items that cannot beat the best bound."""
    n_seg = A.shape[0]
    n_items = IC.shape[0]
    out = np.full(n_seg, math.inf)
    cd = np.empty(n_items)
    for s in range(n_seg):
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
            dist, inside = pair(ax, ay, dx, dy, k, K, P, E, N, C, CE, IC, CR, eps)
            v = dist - 0.5 * inside
            if v < best:
                best = v
        out[s] = best
    return out


@_jit
def pairs(SI, IT, A, D, K, P, E, N, C, CE, IC, CR, eps):
    """:func:`pair` for explicit (segment ``SI[q]``, item ``IT[q]``) pairs."""
    n = SI.shape[0]
    dist = np.empty(n)
    inside = np.empty(n)
    for q in range(n):
        s = SI[q]
        dist[q], inside[q] = pair(A[s, 0], A[s, 1], D[s, 0], D[s, 1], IT[q], K, P, E, N, C,
                                  CE, IC, CR, eps)
    return dist, inside
