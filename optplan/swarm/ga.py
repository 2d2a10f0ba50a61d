"""The GA operators of IPSO (paper §III.B, eqs 25-29): selection, crossover, mutation.

Selection (:func:`ga_pairs`): per island the ``A / islands`` best particles, paired in rank
order; a pair crosses when it shares waypoints ("locally identical path information").
Crossover: the arithmetic blend of eqs 25-28 (:func:`crossover`, ``crossover = "blend"``) or
the fragment swap of the paper's text (:func:`shared_fragment`, :func:`swap_fragments`,
``crossover = "swap"``).  Mutation (eq 29): each child's candidate ``child + C_k``
(:func:`ga_children`); the better of the two is kept (:func:`greedy_mutation`; the compiled
iteration does it in :func:`optplan.swarm.ipso.absorb`).  The reading of each equation is
explained in :mod:`optplan.swarm.ipso`.  The loops are compiled with numba (the only
implementation; :func:`ga_children` is numpy around the one crossover a run uses, so the other
is never compiled); the random numbers are drawn by the caller.
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.compiled import F1, F2, FA2, I2, argsort_stable, b1, compiled, f8, i8, inlined

__all__ = [
    "crossover",
    "greedy_mutation",
    "shared_fragment",
    "swap_fragments",
    "ga_pairs",
    "ga_children",
]

#: Compiled with one signature each (optplan.geometry.compiled.jit; cached on disk after the first
#: run). Element loops, not array expressions, fancy indexing or slice assignments: those compile
#: several times slower (broadcasting and its error messages) for the same arithmetic.


@compiled(F2, F2, F2, F2, F1)
def crossover(x1, x2, v1, v2, pc):
    """Eqs 25-28 for a batch of pairs: ``pc`` has one value per pair (shape ``(m,)``).

    Returns ``(child1_x, child2_x, child1_v, child2_v)``::

        child_1 = p_c parent_1 + (1 - p_c) parent_2 = parent_2 + p_c (parent_1 - parent_2)
        child_2 = (1 - p_c) parent_1 + p_c parent_2 = parent_1 - p_c (parent_1 - parent_2)
    """
    m, D = x1.shape
    c1x, c2x = np.empty((m, D)), np.empty((m, D))
    c1v, c2v = np.empty((m, D)), np.empty((m, D))
    for r in range(m):
        p = pc[r]
        for d in range(D):
            dx = (x1[r, d] - x2[r, d]) * p
            dv = (v1[r, d] - v2[r, d]) * p
            c1x[r, d] = x2[r, d] + dx
            c2x[r, d] = x1[r, d] - dx
            c1v[r, d] = v2[r, d] + dv
            c2v[r, d] = v1[r, d] - dv
    return c1x, c2x, c1v, c2v


def greedy_mutation(cost_child: np.ndarray, cost_mutant: np.ndarray) -> np.ndarray:
    """Eq 29: True where the mutant ``child + C_k`` is kept (strictly better), else the child."""
    return np.asarray(cost_mutant) < np.asarray(cost_child)


@inlined  # one call site (ga_pairs)
def shared_fragment(xa, xb, tol2):
    """The fragment two particles exchange in the paper's crossover ("intercept the locally
    identical path information ... swapping each other"): waypoint indices ``[lo, hi)``.

    Waypoint ``j`` is *shared* when the two particles' ``j``-th waypoints are closer than
    ``sqrt(tol2)``; ``a`` is the first shared waypoint, ``b`` the next shared one after
    ``a + 1`` (else the goal, index ``n``, which every path shares).  The fragment is the
    waypoints strictly between them, ``[a + 1, b)``; ``(0, 0)`` (empty: no crossover) when no
    waypoint is shared or only the last one is.
    """
    n = xa.shape[0] // 2
    a = -1
    b = n
    for j in range(n):
        dx = xa[2 * j] - xb[2 * j]
        dy = xa[2 * j + 1] - xb[2 * j + 1]
        if dx * dx + dy * dy <= tol2:
            if a < 0:
                a = j
            elif j > a + 1:
                b = j
                break
    if a < 0 or a + 1 >= b:
        return 0, 0
    return a + 1, b


@compiled(F1, FA2, i8, i8, f8, b1)
def ga_pairs(F, X, n_islands, n_select, tol2, swap):
    """Selection of eqs 25-28: per island (blocks of consecutive particles) its ``n_select``
    best particles by cost, in stable rank order, paired 1st-2nd, 3rd-4th, ...; a pair is kept
    when some corresponding waypoints are closer than ``sqrt(tol2)`` ("locally identical path
    information"; ``tol2 = inf`` keeps every pair).  With ``swap`` (the fragment swap of
    ``crossover = "swap"``) a pair is kept when its :func:`shared_fragment` is not empty.

    Returns the kept pairs ``(h, 2)`` (particle indices, island by island), their islands and
    their fragments ``(h, 2)`` (waypoint index ranges ``[lo, hi)``; ``(0, 0)`` without
    ``swap``).
    """
    P, D = X.shape
    m_i = P // n_islands
    half = n_select // 2
    pairs = np.empty((n_islands * half, 2), np.int64)
    isl = np.empty(n_islands * half, np.int64)
    frag = np.zeros((n_islands * half, 2), np.int64)
    h = 0
    for i in range(n_islands):
        order = argsort_stable(F[i * m_i:(i + 1) * m_i]) + i * m_i
        for r in range(half):
            a = order[2 * r]
            b = order[2 * r + 1]
            lo = 0
            hi = 0
            if swap:
                lo, hi = shared_fragment(X[a], X[b], tol2)
                close = hi > lo
            else:
                close = tol2 == np.inf
                if not close:
                    for j in range(0, D, 2):
                        dx = X[a, j] - X[b, j]
                        dy = X[a, j + 1] - X[b, j + 1]
                        if dx * dx + dy * dy <= tol2:
                            close = True
                            break
            if close:
                pairs[h, 0] = a
                pairs[h, 1] = b
                isl[h] = i
                frag[h, 0] = lo
                frag[h, 1] = hi
                h += 1
    return pairs[:h], isl[:h], frag[:h]


@compiled(F2, F2, F2, F2, I2)
def swap_fragments(x1, x2, v1, v2, frag):
    """The paper's crossover text for a batch of pairs: child 1 is parent 1 with the fragment
    ``frag[r]`` (waypoints ``[lo, hi)``) of parent 2, child 2 the converse; velocities the
    same way.  Returns ``(child1_x, child2_x, child1_v, child2_v)``."""
    c1x, c2x, c1v, c2v = x1.copy(), x2.copy(), v1.copy(), v2.copy()
    for r in range(x1.shape[0]):
        for d in range(2 * frag[r, 0], 2 * frag[r, 1]):
            c1x[r, d] = x2[r, d]
            c2x[r, d] = x1[r, d]
            c1v[r, d] = v2[r, d]
            c2v[r, d] = v1[r, d]
    return c1x, c2x, c1v, c2v


def ga_children(X: np.ndarray, V: np.ndarray, pairs: np.ndarray, pc: np.ndarray,
                noise: np.ndarray, sigma: np.ndarray, out: np.ndarray, frag: np.ndarray,
                swap: bool) -> np.ndarray:
    """Eqs 25-28 (``swap``: :func:`swap_fragments` of ``frag``; ``pc`` unused) and the
    mutation candidates of eq 29 for the ``h`` crossed pairs.

    Children go to ``out[m:2m]`` (first children of every pair, then second children,
    ``m = 2h``) and the mutants ``child + C_k`` with ``C_k = noise * sigma`` to ``out[:m]``;
    returns the children's velocities ``(m, D)`` (eqs 27-28).  Numpy around the one compiled
    crossover the preset uses (the other is never compiled).
    """
    h = len(pairs)
    m = 2 * h
    a, b = pairs[:, 0], pairs[:, 1]
    x1, x2, v1, v2 = X[a], X[b], V[a], V[b]
    if swap:
        c1x, c2x, c1v, c2v = swap_fragments(x1, x2, v1, v2, frag)
    else:
        c1x, c2x, c1v, c2v = crossover(x1, x2, v1, v2, pc)
    out[m:m + h] = c1x
    out[m + h:2 * m] = c2x
    out[:m] = noise * sigma + out[m:2 * m]  # child + C_k
    return np.concatenate((c1v, c2v))
