r"""Candidate sight lines: the circles a point may see, found without testing every pair.

The tangent graph (:mod:`optplan.geometry.tangent_graph`) joins its circles by common
tangents; testing the tangents from one circle to all ``n`` others costs ``O(n)`` per circle
and ``O(n^2)`` for the graph, although on a map of many obstacles a circle sees only a few
others.  This module lists, per *source* point and angular *window*, a superset of the circle
centres visible from it, in time that grows with the visible region rather than with the map.

Mathematics
-----------
A segment from the source ``s`` to a centre ``w`` that crosses a boundary edge ``e`` of a solid
at an interior point of ``e`` enters the solid there and is blocked.  Seen from ``s``, ``e``
covers an angular interval (its *shadow*), and every ray in it meets ``e`` at a distance of at
most ``dmax(e) = max(|p_1 - s|, |p_2 - s|)``; so a centre ``w`` with ``|w - s| > dmax(e)``
whose direction lies in the shadow is not visible.  The shadow is shrunk by
``asin(kappa eps / |p - s|)`` (``kappa = 4``) at an end that is a convex corner of its solid,
and by a slack of ``1e-9`` rad at any other end: a segment passing within a few ``eps`` of a
convex corner (grazing it, running along a wall, crossing the pinch between two solids) is
never excluded, since the exact predicate may accept it, while a segment through a reflex or
straight vertex enters the solid.

*Flood.*  The plane is cut into square buckets listing the centres and edges that meet them.
Buckets are visited best-first by their distance ``dmin`` from ``s`` (a heap), starting from
the source's bucket and spreading to the eight neighbours whose angular extent still meets the
*open set* (the window minus the shadows applied so far).  When a bucket is visited, every
shadow of an edge with ``dmax < dmin`` is applied first (all points of the bucket lie beyond
such an edge), then each centre in the bucket whose direction is in the open set is a
candidate, and the bucket's edges add their shadows to the pending list.  A visible centre is
always found: the buckets along its sight line form a chain of neighbours whose directions
stay open.  The open set is a sorted list of disjoint intervals of angles measured from the
window's start; when it would outgrow its capacity a shadow is skipped (more candidates, never
fewer).

The candidates are a *superset*: each is still tested with the exact predicates of
:class:`~optplan.geometry.obstacles.ObstacleSet` by its user.  Circle obstacles cast no shadow
here (their tangents are never filtered: :mod:`~optplan.geometry.tangent_graph`).

Why by hand: the flood is the one output-sensitive visibility query the exact graph needs, and
neither shapely nor scipy offers visibility from a point (a visibility polygon per source from
a constrained triangulation would cost seconds per map to set up).  Compiled with numba
(:mod:`optplan.geometry.jit`); tested against the all-pairs exact segment tests in
``tests/geometry/test_sightlines.py``.
"""

from __future__ import annotations

import math

import numpy as np

from optplan.geometry.grid import box_cells, cell_lists
from optplan.geometry.jit import F1, F2, I1, compiled, f8, heap_pop, heap_push, i8, inlined

__all__ = ["Sightlines", "visible_candidates", "KAPPA"]

TWO_PI = 2.0 * math.pi
#: Shrink of a shadow at an edge's end, in units of ``eps`` at the end's distance.
KAPPA = 4.0
#: Intervals the open set may hold (a shadow that would exceed it is skipped).
OPEN_CAP = 512
#: Angular slack (rad) of the bucket and candidate tests.
SLACK = 1e-9


@inlined
def _wrap(a):
    """``a`` mod ``2 pi`` in ``[0, 2 pi)``."""
    a -= TWO_PI * math.floor(a / TWO_PI)
    if a >= TWO_PI or a < 0.0:
        a = 0.0
    return a


@inlined
def _first_hi(ohi, no, a):
    """Index of the first open interval whose end is ``>= a`` (``no`` if none): the
    intervals are sorted and disjoint, so their ends increase."""
    lo = 0
    hi = no
    while lo < hi:
        mid = (lo + hi) >> 1
        if ohi[mid] < a:
            lo = mid + 1
        else:
            hi = mid
    return lo


@inlined
def _meets(olo, ohi, no, a, b):
    """The relative interval ``[a, b]`` (``0 <= a < 2 pi``, ``b`` may pass ``2 pi``) meets
    the open set."""
    if no == 0:
        return False
    k = _first_hi(ohi, no, a)
    if k < no and olo[k] <= b:
        return True
    return b > TWO_PI and olo[0] <= b - TWO_PI


@inlined
def _cut(olo, ohi, no, a, b):
    """Remove ``[a, b]`` (``b <= 2 pi``) from the open set (in place); the new count, or
    ``-1`` (unchanged) when the result would exceed the capacity."""
    k0 = _first_hi(ohi, no, a)
    k1 = k0
    while k1 < no and olo[k1] < b:
        k1 += 1
    if k0 >= k1:
        return no
    left = olo[k0] < a
    right = ohi[k1 - 1] > b
    keep = int(left) + int(right)
    m = no - (k1 - k0) + keep
    if m > olo.shape[0]:
        return -1
    rlo = b
    rhi = ohi[k1 - 1]
    shift = keep - (k1 - k0)
    if shift < 0:
        for t in range(k1, no):
            olo[t + shift] = olo[t]
            ohi[t + shift] = ohi[t]
    elif shift > 0:
        for t in range(no - 1, k1 - 1, -1):
            olo[t + shift] = olo[t]
            ohi[t + shift] = ohi[t]
    w = k0
    if left:
        ohi[w] = a  # olo[w] is the old start
        w += 1
    if right:
        olo[w] = rlo
        ohi[w] = rhi
    return m


@inlined
def _bucket_dist(sx, sy, x0, y0, h, bx, by):
    """Distance from ``(sx, sy)`` to bucket ``(bx, by)``."""
    dx = max(x0 + bx * h - sx, 0.0, sx - (x0 + (bx + 1) * h))
    dy = max(y0 + by * h - sy, 0.0, sy - (y0 + (by + 1) * h))
    return math.hypot(dx, dy)


@inlined
def _bucket_open(sx, sy, lo, x0, y0, h, bx, by, dmin, olo, ohi, no):
    """The angular extent of bucket ``(bx, by)`` seen from the source meets the open set."""
    if dmin <= 0.0:
        return True
    cx = x0 + (bx + 0.5) * h - sx
    cy = y0 + (by + 0.5) * h - sy
    ac = math.atan2(cy, cx)
    mn = math.pi
    mx = -math.pi
    for q in range(4):
        px = x0 + (bx + (q & 1)) * h - sx
        py = y0 + (by + (q >> 1)) * h - sy
        d = math.atan2(cx * py - cy * px, cx * px + cy * py)
        mn = min(mn, d)
        mx = max(mx, d)
    a = _wrap(ac + mn - lo - SLACK)
    return _meets(olo, ohi, no, a, a + (mx - mn) + 2.0 * SLACK)


@inlined
def _apply_shadows(pd, pa, pb, np_, dmin, olo, ohi, no):
    """Cut the pending shadows of the edges nearer than ``dmin`` out of the open set;
    returns ``(pending count, open count)``."""
    t = 0
    while t < np_:
        if pd[t] >= dmin:
            t += 1
            continue
        a0 = pa[t]
        a1 = pb[t]
        np_ -= 1
        pd[t] = pd[np_]
        pa[t] = pa[np_]
        pb[t] = pb[np_]
        if a1 > TWO_PI:  # wraps: two pieces
            r = _cut(olo, ohi, no, a0, TWO_PI)
            if r >= 0:
                no = r
            a0 = 0.0
            a1 = a1 - TWO_PI
        r = _cut(olo, ohi, no, a0, a1)
        if r >= 0:
            no = r
    return np_, no


@inlined
def _in_open(olo, ohi, no, a, tol):
    """Direction ``a`` (relative, in ``[0, 2 pi)``) within ``tol`` of the open set."""
    a0 = a - tol
    if a0 < 0.0:  # [a0, a0 + 2 tol] taken round: _meets handles an end past 2 pi
        a0 += TWO_PI
    return _meets(olo, ohi, no, a0, a0 + 2.0 * tol)


@inlined
def _shadow(EP, e, sx, sy, tiny):
    """Shadow of edge ``e`` seen from ``(sx, sy)``: ``(dmax, start angle, width)``, width
    ``<= 0`` when it casts none (an edge at the source, or seen edge-on)."""
    ux = EP[e, 0] - sx
    uy = EP[e, 1] - sy
    vx = EP[e, 2] - sx
    vy = EP[e, 3] - sy
    d1 = math.hypot(ux, uy)
    d2 = math.hypot(vx, vy)
    if d1 <= tiny or d2 <= tiny:
        return 0.0, 0.0, -1.0
    sw = math.atan2(ux * vy - uy * vx, ux * vx + uy * vy)
    if sw < 0.0:  # from the second end, counter-clockwise
        ux, uy, d1, d2, sw = vx, vy, d2, d1, -sw
        f1, f2 = EP[e, 5], EP[e, 4]
    else:
        f1, f2 = EP[e, 4], EP[e, 5]
    s1 = f1 * math.asin(min(1.0, tiny / d1)) + SLACK
    s2 = f2 * math.asin(min(1.0, tiny / d2)) + SLACK
    return max(d1, d2), math.atan2(uy, ux) + s1, sw - s1 - s2


@inlined
def _append(out, n, j):
    """``out`` with ``j`` at index ``n`` (grown twofold when full; element copies, no slice
    assignment, whose shape check would compile numba's string routines)."""
    if n >= out.shape[0]:
        grown = np.empty(2 * out.shape[0], np.int64)
        for t in range(n):
            grown[t] = out[t]
        out = grown
    out[n] = j
    return out


@inlined
def _visible_in(b, q, sx, sy, lo, tiny, CX, cstart, citems, cstamp, olo, ohi, no, out, n_out):
    """Append the centres of bucket ``b`` whose direction is open (once per source ``q``);
    returns ``(out, new count)``."""
    for c in range(cstart[b], cstart[b + 1]):
        j = citems[c]
        if cstamp[j] == q:
            continue
        dist = math.hypot(CX[j, 0] - sx, CX[j, 1] - sy)
        if dist > tiny and not _in_open(
                olo, ohi, no, _wrap(math.atan2(CX[j, 1] - sy, CX[j, 0] - sx) - lo),
                SLACK + math.asin(min(1.0, tiny / dist))):
            continue
        cstamp[j] = q
        out = _append(out, n_out, j)
        n_out += 1
    return out, n_out


@inlined
def _add_shadows(b, q, sx, sy, lo, tiny, EP, estart, eitems, estamp, pd, pa, pb, np_):
    """Add the shadows of the edges of bucket ``b`` (once per source ``q``) to the pending
    list; returns its new length."""
    for c in range(estart[b], estart[b + 1]):
        e = eitems[c]
        if estamp[e] == q:
            continue
        estamp[e] = q
        dmax, a0, width = _shadow(EP, e, sx, sy, tiny)
        if width > 0.0:
            pd[np_] = dmax
            pa[np_] = _wrap(a0 - lo)
            pb[np_] = pa[np_] + width
            np_ += 1
    return np_


@inlined
def _push_open(b, q, sx, sy, lo, x0, y0, h, nx, ny, bstamp, hk, hv, nh, olo, ohi, no):
    """Push the neighbours of bucket ``b`` whose directions are still open (once per source
    ``q``); returns the heap's new size."""
    for nb in range(9):
        qx = b % nx + nb % 3 - 1
        qy = b // nx + nb // 3 - 1
        if qx < 0 or qy < 0 or qx >= nx or qy >= ny or bstamp[qy * nx + qx] == q:
            continue
        dn = _bucket_dist(sx, sy, x0, y0, h, qx, qy)
        if _bucket_open(sx, sy, lo, x0, y0, h, qx, qy, dn, olo, ohi, no):
            bstamp[qy * nx + qx] = q
            nh = heap_push(hk, hv, nh, dn, qy * nx + qx)
    return nh


@compiled(F2, F1, F1, F2, F2, f8, f8, f8, i8, i8, I1, I1, I1, I1, f8)
def visible_candidates(S, LO, WID, CX, EP, x0, y0, h, nx, ny, cstart, citems, estart, eitems,
                       eps):  # pragma: no cover - compiled
    """Candidate visible centres per source (module docstring).

    Parameters
    ----------
    S : (k, 2) sources; LO, WID : (k,) window start and width (rad, ``WID >= 2 pi``: all
        directions); CX : (n, 2) centres; EP : (m, 6) edges ``x1, y1, x2, y2`` and whether
        each end is a convex corner (1.0) or not (0.0);
    x0, y0, h, nx, ny : the bucket grid; cstart, citems, estart, eitems : CSR lists of the
        centres and edges per bucket (``bucket = by * nx + bx``); eps : tolerance.

    Returns
    -------
    counts : (k,) int64
        Candidates per source.
    flat : int64 array
        The candidates of source 0, then of source 1, ...
    """
    n_b = nx * ny
    m = EP.shape[0]
    bstamp = np.full(n_b, -1, np.int64)
    cstamp = np.full(CX.shape[0], -1, np.int64)
    estamp = np.full(m, -1, np.int64)
    hk = np.empty(n_b)
    hv = np.empty(n_b, np.int64)
    pd = np.empty(m)
    pa = np.empty(m)
    pb = np.empty(m)
    olo = np.empty(OPEN_CAP)
    ohi = np.empty(OPEN_CAP)
    counts = np.zeros(S.shape[0], np.int64)
    out = np.empty(max(16, 16 * S.shape[0]), np.int64)
    n_out = 0
    tiny = KAPPA * eps
    for q in range(S.shape[0]):
        sx = S[q, 0]
        sy = S[q, 1]
        lo = LO[q]
        no = 1
        olo[0] = 0.0
        ohi[0] = min(WID[q], TWO_PI)
        np_ = 0
        b = (min(max(int(math.floor((sy - y0) / h)), 0), ny - 1) * nx
             + min(max(int(math.floor((sx - x0) / h)), 0), nx - 1))
        hk[0] = 0.0  # the heap holds the source's bucket
        hv[0] = b
        nh = 1
        bstamp[b] = q
        while nh > 0 and no > 0:
            dmin, b, nh = heap_pop(hk, hv, nh)
            np_, no = _apply_shadows(pd, pa, pb, np_, dmin, olo, ohi, no)
            if no == 0:
                break
            out, n_new = _visible_in(b, q, sx, sy, lo, tiny, CX, cstart, citems, cstamp, olo,
                                     ohi, no, out, n_out)
            counts[q] += n_new - n_out
            n_out = n_new
            np_ = _add_shadows(b, q, sx, sy, lo, tiny, EP, estart, eitems, estamp, pd, pa, pb,
                               np_)
            nh = _push_open(b, q, sx, sy, lo, x0, y0, h, nx, ny, bstamp, hk, hv, nh, olo, ohi,
                            no)
    flat = np.empty(n_out, np.int64)
    for t in range(n_out):
        flat[t] = out[t]
    return counts, flat


class Sightlines:
    """The bucket grid of one obstacle set's boundary edges and a set of centres, and the
    candidate query of :func:`visible_candidates` over it.

    Parameters
    ----------
    edges : (m, 4) array
        Boundary edges ``x1, y1, x2, y2`` of the solids (local frame).
    centres : (n, 2) array
        The points to find (local frame).
    corners : (c, 2) array
        The convex vertices of the solids (local frame): a shadow is shrunk at an edge's end
        only there (a segment can pass a convex corner, but not a reflex or straight vertex
        of a solid without entering it).
    eps : float
        The obstacle set's tolerance.
    extent : tuple
        ``(x0, y0, x1, y1)`` that the sources lie in (the local bounds).
    """

    def __init__(self, edges: np.ndarray, centres: np.ndarray, corners: np.ndarray,
                 eps: float, extent: tuple[float, float, float, float]):
        e4 = np.asarray(edges, float).reshape(-1, 4)
        cz = np.asarray(corners, float).reshape(-1, 2) @ np.array([1.0, 1j])
        flags = [np.isin(e4[:, k] + 1j * e4[:, k + 1], cz).astype(float) for k in (0, 2)]
        self.edges = np.ascontiguousarray(np.column_stack([e4, *flags]))
        self.centres = np.ascontiguousarray(np.asarray(centres, float).reshape(-1, 2))
        self.eps = float(eps)
        pts = np.concatenate([self.centres, e4[:, :2], e4[:, 2:],
                              np.asarray(extent, float).reshape(2, 2)])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-12))
        # about one centre or edge per bucket (fewer candidates than coarser buckets, as fast on
        # the 1024 x 1024 street map of benchmarks/bench_maps_scale.py), 32 to 2048 a side
        per = max(1.0, float(len(self.centres) + len(self.edges)))
        h = math.sqrt(max((hi[0] - lo[0]) * (hi[1] - lo[1]), span * span * 1e-6) / per)
        h = min(max(h, span / 2048.0), span / 32.0)
        self.x0, self.y0, self.h = float(lo[0]) - 1e-9 * span, float(lo[1]) - 1e-9 * span, h
        self.nx = int((hi[0] - self.x0) // h) + 1
        self.ny = int((hi[1] - self.y0) // h) + 1
        nb = self.nx * self.ny
        bx, by = self._index(self.centres[:, 0], self.centres[:, 1])
        self.cstart, _, self.citems = cell_lists(by * self.nx + bx,
                                                 np.arange(len(self.centres)), nb)
        # an edge in every bucket of its bounding box
        e = self.edges
        bx0, by0 = self._index(np.minimum(e[:, 0], e[:, 2]), np.minimum(e[:, 1], e[:, 3]))
        bx1, by1 = self._index(np.maximum(e[:, 0], e[:, 2]), np.maximum(e[:, 1], e[:, 3]))
        ex, ey, eid = box_cells(bx0, bx1, by0, by1)
        self.estart, _, self.eitems = cell_lists(ey * self.nx + ex, eid, nb)

    def _index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        bx = np.clip(np.floor((x - self.x0) / self.h), 0, self.nx - 1).astype(np.int64)
        by = np.clip(np.floor((y - self.y0) / self.h), 0, self.ny - 1).astype(np.int64)
        return bx, by

    def candidates(self, sources, lo, width) -> list[np.ndarray]:
        """Per source (local ``(k, 2)``), the indices of the centres it may see in the window
        ``lo .. lo + width`` (rad, counter-clockwise; ``width >= 2 pi``: all directions)."""
        S = np.ascontiguousarray(np.asarray(sources, float).reshape(-1, 2))
        k = len(S)
        LO = np.broadcast_to(np.asarray(lo, float), (k,)).copy()
        W = np.broadcast_to(np.asarray(width, float), (k,)).copy()
        if k == 0:
            return []
        if len(self.centres) == 0:
            return [np.zeros(0, np.int64) for _ in range(k)]
        counts, flat = visible_candidates(S, LO, W, self.centres, self.edges, self.x0,
                                          self.y0, self.h, self.nx, self.ny, self.cstart,
                                          self.citems, self.estart, self.eitems, self.eps)
        return np.split(flat, np.cumsum(counts)[:-1])
