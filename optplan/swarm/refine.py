"""Local refinement of collision-free polylines (beyond the paper): string pulling and corner
cutting.

:func:`tighten`: deterministic corner cutting and string pulling of collision-free paths with
the fitness kernel only (used by ``ipso``'s ``tighten_rounds``, :mod:`optplan.swarm.endgame`).
Backends add such post-iteration steps through
:meth:`optplan.swarm.backend.SwarmBackend._finish` (one history row each, not counted as
iterations).  :func:`shortcut`: greedy string pulling of one path.

The paths are handled together as *flat paths*: one point array and the start offsets of the
paths (:func:`_flat`), so that every round tests the segments of all paths in one call of the
collision kernel (:func:`optplan.swarm.core.pairs_free`).  The roadmap string-pulls its walks
with :func:`_pull` too.
"""

from __future__ import annotations

import math

import numpy as np

from optplan.geometry.compiled import (
    B1,
    F1,
    F2,
    F3,
    I1,
    I2,
    argsort_stable,
    compiled,
    f8,
    i8,
    leaf,
)
from optplan.swarm.core import SwarmSpace, pairs_free

__all__ = ["CUT_FRACTIONS", "CUT_STAGES", "shortcut", "tighten"]

def shortcut(path: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Greedy string pulling: from each kept vertex jump to the farthest visible later vertex."""
    return _shortcut_many([np.asarray(path, dtype=float)], space)[0]


def _shortcut_many(paths: list[np.ndarray], space: SwarmSpace) -> list[np.ndarray]:
    """:func:`shortcut` of several paths with one visibility test for all vertex pairs."""
    if not paths:
        return []
    pts, off = _flat(paths)
    pts, off = _pull(pts, off, space, 0)[:2]
    return [pts[off[i]:off[i + 1]] for i in range(len(paths))]


def _flat(paths: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Paths as one point array and the start offsets ``(n_paths + 1,)``."""
    off = np.zeros(len(paths) + 1, np.int64)
    off[1:] = np.cumsum([len(p) for p in paths])
    return np.ascontiguousarray(np.concatenate([np.asarray(p, float) for p in paths])), off


@compiled(I1, i8)
def _pairs(off, window):
    """Global index pairs ``(i, j)``, ``i < j`` in the same path and at most ``window`` apart
    (0: every pair), sorted by ``i`` then ``j``."""
    n = 0
    for p in range(off.shape[0] - 1):
        m = off[p + 1] - off[p]
        for i in range(m):
            k = m - 1 - i
            n += k if window <= 0 or k < window else window
    I = np.empty(n, np.int64)
    J = np.empty(n, np.int64)
    q = 0
    for p in range(off.shape[0] - 1):
        o, m = off[p], off[p + 1] - off[p]
        for i in range(m):
            top = m if window <= 0 or m < i + window + 1 else i + window + 1
            for j in range(i + 1, top):
                I[q] = o + i
                J[q] = o + j
                q += 1
    return I, J


@compiled(F2, I1, I1, I1, I1, B1)
def _pulled(pts, off, ids, I, J, free):
    """Greedy string pulling from the visibility of the pairs ``(I, J)`` (sorted by ``I``
    then ``J``, as :func:`_pairs` makes them): from each kept vertex the farthest visible
    later vertex (the next vertex when none is).  Returns the kept points, the new offsets
    and the kept ids."""
    N = off[-1]
    far = np.arange(N) + 1  # farthest visible later vertex per vertex
    for q in range(I.shape[0]):
        if free[q] and J[q] > far[I[q]]:
            far[I[q]] = J[q]
    keep = np.zeros(N, np.bool_)
    n = 0
    for p in range(off.shape[0] - 1):
        v = off[p]
        last = off[p + 1] - 1
        if v > last:
            continue
        keep[v] = True
        n += 1
        while v < last:
            v = far[v] if far[v] < last else last
            keep[v] = True
            n += 1
    new_pts = np.empty((n, 2))
    new_ids = np.empty(n, np.int64)
    new_off = np.empty_like(off)
    q = 0
    for p in range(off.shape[0] - 1):
        new_off[p] = q
        for v in range(off[p], off[p + 1]):
            if keep[v]:
                new_pts[q, 0] = pts[v, 0]
                new_pts[q, 1] = pts[v, 1]
                new_ids[q] = ids[v]
                q += 1
    new_off[off.shape[0] - 1] = q
    return new_pts, new_off, new_ids


def _pull(pts: np.ndarray, off: np.ndarray, space: SwarmSpace, window: int,
          ids: np.ndarray | None = None):
    """String pulling of flat paths (pairs at most ``window`` apart, 0: all): the kept
    points, offsets, ids (None without ``ids``) and the number of segments tested."""
    I, J = _pairs(off, window)
    kept_ids = ids if ids is not None else np.arange(len(pts), dtype=np.int64)
    new_pts, new_off, new_ids = _pulled(pts, off, kept_ids, I, J, pairs_free(pts, I, J, space))
    return new_pts, new_off, (new_ids if ids is not None else None), len(I)


@compiled(I1, I1, I2, B1, F1, f8)
def _dirty_rows(off, ids, settled, active, length, min_gain):
    """Interior vertices of the active paths not known to admit no cut with their current
    neighbours (global indices, ascending), and their cut thresholds ``min_gain`` x the
    length of their path.  ``settled[:, x]``: the ids of the previous and next vertex with
    which the vertex of id ``x`` admitted no cut (-1: none yet)."""
    out = np.empty(off[-1], np.int64)
    thr = np.empty(off[-1])
    n = 0
    for p in range(off.shape[0] - 1):
        if not active[p]:
            continue
        for v in range(off[p] + 1, off[p + 1] - 1):
            x = ids[v]
            if settled[0, x] != ids[v - 1] or settled[1, x] != ids[v + 1]:
                out[n] = v
                thr[n] = min_gain * length[p]
                n += 1
    return out[:n].copy(), thr[:n].copy()


@compiled(F2, I1, I1, I1, B1, F3, F3, I1, i8, I2)
def _apply_cuts(pts, off, ids, rows, cut, P, Q, choice, next_id, settled):
    """Replace every cut vertex ``rows[r]`` (ascending) by its two cut points
    ``P[r, choice[r] // F], Q[r, choice[r] % F]`` (new ids from ``next_id``, in vertex
    order); a tested vertex without a cut is recorded as settled with its neighbours
    (``settled``, as :func:`_dirty_rows` reads it).
    Returns the new points, offsets, ids and the next free id."""
    F = P.shape[1]
    N = pts.shape[0]
    which = np.full(N, -1, np.int64)
    n_cut = 0
    for r in range(rows.shape[0]):
        v = rows[r]
        if cut[r]:
            which[v] = r
            n_cut += 1
        else:
            settled[0, ids[v]] = ids[v - 1]
            settled[1, ids[v]] = ids[v + 1]
    new_pts = np.empty((N + n_cut, 2))
    new_ids = np.empty(N + n_cut, np.int64)
    new_off = np.empty_like(off)
    q = 0
    for p in range(off.shape[0] - 1):
        new_off[p] = q
        for v in range(off[p], off[p + 1]):
            r = which[v]
            if r < 0:
                new_pts[q, 0] = pts[v, 0]
                new_pts[q, 1] = pts[v, 1]
                new_ids[q] = ids[v]
                q += 1
            else:
                s = choice[r] // F
                t = choice[r] % F
                new_pts[q, 0] = P[r, s, 0]
                new_pts[q, 1] = P[r, s, 1]
                new_pts[q + 1, 0] = Q[r, t, 0]
                new_pts[q + 1, 1] = Q[r, t, 1]
                new_ids[q] = next_id
                new_ids[q + 1] = next_id + 1
                next_id += 2
                q += 2
    new_off[off.shape[0] - 1] = q
    return new_pts, new_off, new_ids, next_id


@compiled(F2, I1)
def _lengths(pts, off):
    """Length of each flat path."""
    out = np.zeros(off.shape[0] - 1)
    for p in range(off.shape[0] - 1):
        for v in range(off[p], off[p + 1] - 1):
            out[p] += math.hypot(pts[v + 1, 0] - pts[v, 0], pts[v + 1, 1] - pts[v, 1])
    return out


#: Corner-cut fractions of :func:`tighten` (how far along each adjacent segment).
CUT_FRACTIONS = 0.5 ** np.arange(1, 11)


#: Rank boundaries of the staged cut tests of :func:`tighten` (by decreasing gain).
CUT_STAGES = (8, 24)


@compiled(F2, I1, F1, F1)
def _cut_table(pts, rows, f, thr):
    """The corner cuts of :func:`tighten` for the vertices ``rows``: the cut points
    ``P[r, s] = v + f[s] (a - v)``, ``Q[r, t] = v + f[t] (b - v)``, the cuts ``(s, t)``
    (flat index ``s F + t``) in order of decreasing length gain (ties: the lower index
    first) and per vertex how many gain more than ``thr[r]``.  Compiled (once
    per round; numpy's broadcasts and row sorts cost several times the loop), with element
    copies and ``if``s rather than row assignment and ``min``/``max``, whose error texts and
    overloads would compile numba's string routines on a first run."""
    R = rows.shape[0]
    F = f.shape[0]
    P = np.empty((R, F, 2))
    Q = np.empty((R, F, 2))
    order = np.empty((R, F * F), np.int64)
    n_above = np.empty(R, np.int64)
    dp = np.empty(F)
    dq = np.empty(F)
    neg = np.empty(F * F)
    for r in range(R):
        v = rows[r]
        vx, vy = pts[v, 0], pts[v, 1]
        ax, ay = pts[v - 1, 0] - vx, pts[v - 1, 1] - vy
        bx, by = pts[v + 1, 0] - vx, pts[v + 1, 1] - vy
        for s in range(F):
            P[r, s, 0] = vx + f[s] * ax
            P[r, s, 1] = vy + f[s] * ay
            Q[r, s, 0] = vx + f[s] * bx
            Q[r, s, 1] = vy + f[s] * by
            dp[s] = math.hypot(P[r, s, 0] - vx, P[r, s, 1] - vy)
            dq[s] = math.hypot(Q[r, s, 0] - vx, Q[r, s, 1] - vy)
        n_above[r] = 0
        for s in range(F):
            for t in range(F):
                g = (dp[s] + dq[t]) - math.hypot(Q[r, t, 0] - P[r, s, 0],
                                                 Q[r, t, 1] - P[r, s, 1])
                neg[s * F + t] = -g
                if g > thr[r]:
                    n_above[r] += 1
        o = argsort_stable(neg)
        for q in range(F * F):
            order[r, q] = o[q]
    return P, Q, order, n_above


@compiled(F3, F3, I2, I1, B1, i8, i8)
def _stage_segments(P, Q, order, n_above, found, lo, hi):
    """The cuts of ranks ``lo .. hi - 1`` (among those above the threshold) of the vertices
    without a free cut yet, by vertex, then rank (compiled as :func:`_cut_table`, three
    times per round): their segments ``p -> q`` as end points ``ends`` (the ``n`` points
    ``p``, then the ``n`` points ``q``) and index pairs ``(I, J) = (k, n + k)`` (what
    :func:`optplan.swarm.core.segment_free` would stack), their vertex and flat cut index."""
    R = order.shape[0]
    F = P.shape[1]
    n = 0
    for r in range(R):
        top = n_above[r] if n_above[r] < hi else hi
        if not found[r] and top > lo:
            n += top - lo
    ends = np.empty((2 * n, 2))
    I = np.arange(n)
    J = I + n
    who = np.empty(n, np.int64)
    cid = np.empty(n, np.int64)
    q = 0
    for r in range(R):
        top = n_above[r] if n_above[r] < hi else hi
        if found[r]:
            continue
        for k in range(lo, top):
            c = order[r, k]
            ends[q, 0] = P[r, c // F, 0]
            ends[q, 1] = P[r, c // F, 1]
            ends[n + q, 0] = Q[r, c % F, 0]
            ends[n + q, 1] = Q[r, c % F, 1]
            who[q] = r
            cid[q] = c
            q += 1
    return ends, I, J, who, cid


@leaf(I1, I1, B1, B1, I1)
def _stage_pick(who, cid, free, found, choice):
    """Per vertex the first free cut ``cid`` of the stage (in rank order: the largest gain),
    in place in ``found`` and ``choice`` (the stage's cuts are sorted by vertex, then rank)."""
    for q in range(who.shape[0]):
        r = who[q]
        if free[q] and not found[r]:
            found[r] = True
            choice[r] = cid[q]


def _best_cuts(pts: np.ndarray, rows: np.ndarray, f: np.ndarray, thr: np.ndarray,
               space: SwarmSpace):
    """Per vertex ``rows[r]`` its collision-free corner cut with the largest gain, if that
    gain is above ``thr[r]``: the cut points ``P, Q`` (``(R, F, 2)``), the chosen flat index
    ``j`` and the mask ``cut``, and the number of segments tested.

    The same choice as testing all ``F x F`` cuts and taking the argmax of the gains of the
    free ones (the first on ties), with fewer tests: the cuts that gain at most ``thr[r]``
    cannot be taken and are not tested, and the others are tested in stages of decreasing
    gain (ranks below :data:`CUT_STAGES`, then the rest), each vertex only until it has a
    free cut."""
    P, Q, order, n_above = _cut_table(pts, rows, f, thr)
    R = len(rows)
    found = np.zeros(R, bool)
    choice = np.zeros(R, np.int64)
    n_eval = 0
    lo = 0
    for hi in (*CUT_STAGES, order.shape[1]):
        ends, I, J, who, cid = _stage_segments(P, Q, order, n_above, found, lo, hi)
        if len(I):
            _stage_pick(who, cid, pairs_free(ends, I, J, space), found, choice)
            n_eval += len(I)
        lo = hi
        if lo >= order.shape[1]:
            break
    return P, Q, choice, found, n_eval


def tighten(paths: list[np.ndarray], space: SwarmSpace, rounds: int = 30,
            rel_tol: float = 1e-7, min_gain: float = 1e-5,
            fractions: np.ndarray = CUT_FRACTIONS) -> tuple[list[np.ndarray], int]:
    """Deterministic corner cutting and string pulling of collision-free polylines (beyond
    the paper), all paths together (two visibility tests per round for all of them).

    First a greedy :func:`shortcut` of each path.  Then each round, for every interior vertex
    ``v`` with neighbours ``a``, ``b`` (skipping vertices that admitted no cut with the same
    neighbours in an earlier round), the cuts ``p = v + s (a - v)``, ``q = v + t (b - v)`` for
    ``s, t`` in ``fractions`` (default :data:`CUT_FRACTIONS`, 1/2 to 1/1024) are tested (one
    batch of segments ``p -> q``); each vertex takes its collision-free cut with the largest
    length gain.  Fractions are at most 1/2, so the cuts of neighbouring vertices do not
    overlap and ``a -> p``, ``q -> b`` are sub-segments of collision-free segments.  Then a
    greedy string pulling over vertices at most 6 apart drops the vertices that are no longer
    needed.  Visibility is tested with the margin of ``space.clear``.  A path stays
    collision-free for the fitness (hence for the validator), never gets longer, and contracts
    onto the obstacle corners it wraps (the locally shortest path of its homotopy class).  A
    cut must gain more than ``min_gain`` x the path length (this bounds the number of vertices
    spent on approximating the rounded corners of the disc robot's free space).  A path stops
    after ``rounds`` rounds, when a round gains less than ``rel_tol`` of its length or when no
    vertex admits a cut.  Returns ``(paths, number of segments tested)``.
    """
    if not paths:
        return [], 0
    pts, off = _flat(paths)
    pts, off, _, n_eval = _pull(pts, off, space, 0)
    ids = np.arange(len(pts), dtype=np.int64)
    next_id = len(pts)
    cap = max(4 * len(pts), 64)
    settled = np.full((2, cap), -1, np.int64)
    length = _lengths(pts, off)
    active = np.ones(len(paths), bool)  # (a path of 2 points has no vertex to cut)
    f = np.asarray(fractions, dtype=float)
    for _ in range(rounds):
        rows, thr = _dirty_rows(off, ids, settled, active, length, min_gain)
        if not len(rows):
            break
        P, Q, j, cut, n = _best_cuts(pts, rows, f, thr, space)
        n_eval += n
        need = next_id + 2 * int(cut.sum())
        if need > cap:  # room for the new ids
            cap = 2 * need
            settled = np.concatenate(
                [settled, np.full((2, cap - settled.shape[1]), -1, np.int64)], axis=1)
        pts, off, ids, next_id = _apply_cuts(pts, off, ids, rows, cut, P, Q, j, next_id,
                                             settled)
        pts, off, ids, n = _pull(pts, off, space, 6, ids)
        n_eval += n
        new = _lengths(pts, off)
        active &= new < length * (1.0 - rel_tol)
        length = new
    return [pts[off[i]:off[i + 1]] for i in range(len(paths))], int(n_eval)

