"""Compiled decisions and distances of many given segments at once (numba; the only
implementation): :func:`free_pairs`, the collision-free flags of index pairs of points (the
swarm's roadmap and string pulling), and :func:`pairs`, the exact ``(dist, inside)`` of explicit
(segment, item) pairs (the NLP's pair distances).

The loops of :mod:`optplan.geometry.collision.kernel` (its data layout, screens and :func:`pair`),
in a module of their own: only the planners that ask these questions import it (through
:meth:`optplan.geometry.collision.obstacles.ObstacleSet.pairs_free` and ``pair_geometry``), so a
process that never does, e.g. one ``visgraph`` solve, never compiles them.
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.collision.kernel import (
    GRID,
    ITEMS,
    WORK,
    _apart,
    _candidates,
    _item_boxes,
    _near_item,
    pair,
    shapes,
)
from optplan.geometry.compiled import B1, F1, F2, I1, compiled, f8, i8, inlined, leaf

__all__ = ["free_pairs", "pairs"]


@inlined  # one call site (_first_blocker)
def _passes_screens(seg, box, k, bb, items, lim):
    """Item ``k`` may be within ``lim`` of the segment ``seg``: its grown box meets the
    segment's box ``(x0, x1, y0, y1)``, its bounding circle is near, no edge line separates
    them."""
    ax, ay, dx, dy = seg
    x0, x1, y0, y1 = box
    if bb[0, k] > x1 or bb[1, k] < x0 or bb[2, k] > y1 or bb[3, k] < y0:
        return False
    if not _near_item(ax, ay, dx, dy, k, items[7], items[8], lim):
        return False
    return not (k < items[0] and _apart(ax, ay, dx, dy, k, items[3], items[4], lim))


@inlined  # one call site (_free_pairs_loop)
def _first_blocker(seg, box, q, last, m, use_grid, items, r, eps, work):
    """One segment ``seg`` of :func:`free_pairs` (its box ``(x0, x1, y0, y1)``): the first
    item closer than ``r - eps`` (the item ``last`` tried first), ``-2`` when only an
    obstacle's summed ``inside`` exceeds ``eps``, ``-1`` when the segment is free (``work``:
    the scratch arrays, :mod:`optplan.geometry.collision.kernel`)."""
    ax, ay, dx, dy = seg
    OWN = items[10]
    bb, _, stamp, cand, touched, o_stamp, _, o_in, _ = work
    lim = r + 2.0 * eps
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
        if not _passes_screens(seg, box, k, bb, items, lim):
            continue
        dist, inside = pair(ax, ay, dx, dy, k, shapes(items), eps)
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


@compiled(F2, I1, I1, ITEMS, i8, GRID, f8, f8)
def free_pairs(L, I, J, items, n_obs, grid, r, eps):
    """Collision-free flags of the segments ``L[I[q]] -> L[J[q]]`` (local points) against
    ``items`` (``n_obs`` obstacles, ``grid``: :mod:`optplan.geometry.collision.kernel`): the
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
    K, P, _, _, _, _, _, IC, _, CR, _ = items
    n_items = IC.shape[0]
    lim = r + 2.0 * eps
    free = np.empty(I.shape[0], np.bool_)
    work = (_item_boxes(K, P, IC, CR, lim), np.empty(n_items, np.bool_),
            np.empty(n_items, np.int64), np.empty(n_items, np.int64),
            np.empty(n_items, np.int64), np.empty(n_obs, np.int64), np.empty(0, np.bool_),
            np.empty(n_obs), np.empty(0))
    _free_pairs_loop(L, I, J, items, grid, r, eps, free, work)
    return free


@leaf(F2, I1, I1, ITEMS, GRID, f8, f8, B1, WORK)
def _free_pairs_loop(L, I, J, items, grid, r, eps, free, work):
    """The loop of :func:`free_pairs` over its ``work`` arrays (uninitialised: set here; it
    uses no ``o_close``, ``o_pen``)."""
    use_grid = grid[0]
    stamp = work[2]
    cand = work[3]
    o_stamp = work[5]
    lim = r + 2.0 * eps
    n_items = items[7].shape[0]
    for k in range(n_items):
        stamp[k] = -1
        cand[k] = k
    for o in range(o_stamp.shape[0]):
        o_stamp[o] = -1
    last = -1
    for q in range(I.shape[0]):
        ax = L[I[q], 0]
        ay = L[I[q], 1]
        bx = L[J[q], 0]
        by = L[J[q], 1]
        dx = bx - ax
        dy = by - ay
        box = (min(ax, bx), max(ax, bx), min(ay, by), max(ay, by))
        m = n_items
        if use_grid:
            m = _candidates(ax, ay, dx, dy, (items[7], items[8]), grid, lim, work[:4], q)
        blocker = _first_blocker((ax, ay, dx, dy), box, q, last, m, use_grid, items, r, eps,
                                 work)
        if blocker >= 0:
            last = blocker
        free[q] = blocker == -1


@compiled(I1, I1, F2, F2, ITEMS, f8)
def pairs(SI, IT, A, D, items, eps):
    """:func:`pair` for explicit (segment ``SI[q]``, item ``IT[q]``) pairs of ``items``."""
    dist = np.empty(SI.shape[0])
    inside = np.empty(SI.shape[0])
    _pairs_loop(SI, IT, A, D, items, eps, dist, inside)
    return dist, inside


@leaf(I1, I1, F2, F2, ITEMS, f8, F1, F1)
def _pairs_loop(SI, IT, A, D, items, eps, dist, inside):
    """The loop of :func:`pairs` (into ``dist``, ``inside``)."""
    for q in range(SI.shape[0]):
        s = SI[q]
        dist[q], inside[q] = pair(A[s, 0], A[s, 1], D[s, 0], D[s, 1], IT[q], shapes(items),
                                  eps)
