"""Compiled (numba) twins of the per-iteration swarm arithmetic of :mod:`optplan.backends.ipso`.

One ``ipso-paper`` iteration is about a hundred numpy calls on arrays of a few hundred
numbers, so the per-call overhead, not the arithmetic, sets its cost.  With the optional
numba engine (``pip install optplan[fast]``, see :func:`optplan.geometry.kernel_engine`) the
elementwise parts run as three compiled loops instead:

* :func:`move_and_bound` -- eqs 22-24 (velocity, clamp, position) for the whole swarm, then the
  bounds handling (``reflect`` / ``clip``) of the swarm and the mutants, and the velocity
  bounce;
* :func:`select_pairs` -- the GA selection (the ``A`` best, per island) and the "locally
  identical path information" gate of the crossover;
* :func:`breed` -- crossover (eqs 25-28) and the mutation candidates ``child + C_k`` (eq 29);
* :func:`absorb` -- after the fitness call: personal bests, the greedy choice between child
  and mutant (eq 29) and the replacement of the worst particles by the children.

The random numbers are still drawn by numpy from the run's generator, in the same order and
with the same calls as the numpy path, and every result is computed with the same
floating-point operations in the same order (no fastmath, no reassociation): the two engines
give **bit-identical** runs (``tests/test_ipso_compiled.py`` checks whole runs).  Reductions
(the mean speed of eq 21, the fitness) stay in numpy.  Without numba the functions below are
plain Python (correct, slow) and :class:`~optplan.backends.ipso.IPSO` uses its numpy path.
"""

from __future__ import annotations

import numpy as np

from optplan.numba_kernel import jit

__all__ = ["move_and_bound", "select_pairs", "breed", "absorb"]


@jit
def move_and_bound(X, V, pbest, social, U, c1, c2, w, psi, vmax, step, lo, hi, clip, B, n_bound,
                   Vout):  # pragma: no cover - compiled
    """Eqs 22-24 and bounds handling, in place.

    Writes ``X^{k+1}`` into ``B[:P]`` and ``V^{k+1}`` into ``Vout``; ``social`` has one row (the
    global best) or ``P`` rows (island bests); ``vmax`` has zero length for no clamp; ``step``
    selects the ``"step"`` position update (else eq 24 as printed).  Then rows
    ``0 .. n_bound - 1`` of ``B`` (swarm and mutants) are brought into ``[lo, hi]``: mirrored
    as ``2 clip(x) - x`` (then a triangle wave when still out), or clipped when ``clip``; the
    velocity of a swarm coordinate that was out is reversed (mirror) or zeroed (clip).
    """
    P, D = X.shape
    one = social.shape[0] == 1
    has_vmax = vmax.shape[0] > 0
    for i in range(P):
        si = 0 if one else i
        for j in range(D):
            x = X[i, j]
            v = V[i, j] * w
            v += (pbest[i, j] - x) * (U[0, i, j] * c1)
            v += (social[si, j] - x) * (U[1, i, j] * c2)  # eq 22
            if has_vmax:
                v = min(v, vmax[j])
                v = max(v, -vmax[j])
            r = U[2, i, j] * psi  # psi(k) R, eq 23
            if step:
                B[i, j] = r * v + x
            else:
                B[i, j] = r * x + v  # eq 24 as printed
            Vout[i, j] = v
    for i in range(n_bound):
        for j in range(D):
            x = B[i, j]
            c = min(max(x, lo[j]), hi[j])
            if c == x:
                continue
            if clip:
                B[i, j] = c
                if i < P:
                    Vout[i, j] = 0.0
                continue
            y = 2.0 * c - x
            if min(max(y, lo[j]), hi[j]) != y:  # beyond a whole span: triangle wave
                span = hi[j] - lo[j]
                u = (y - lo[j]) % (2 * span)
                y = lo[j] + (2 * span - u if u > span else u)
            B[i, j] = y
            if i < P:
                Vout[i, j] = -Vout[i, j]


@jit
def select_pairs(F, X, A, n_islands, thr):  # pragma: no cover - compiled
    """GA selection and crossover gate: ``(pairs (h, 2), island of each pair (h,))``.

    Per island (``n_islands`` equal blocks of consecutive particles), the ``A`` lowest
    fitness values in stable rank order are paired 1st-2nd, 3rd-4th, ...; a pair is kept when
    some corresponding waypoints are at squared distance ``<= thr`` (``inf``: always).
    """
    P, D = X.shape
    m_i = P // n_islands
    pairs = np.empty((n_islands * (A // 2), 2), np.int64)
    isl = np.empty(n_islands * (A // 2), np.int64)
    h = 0
    gate = thr < np.inf
    for b in range(n_islands):
        order = np.argsort(F[b * m_i:(b + 1) * m_i], kind="mergesort")
        for q in range(A // 2):
            i1 = order[2 * q] + b * m_i
            i2 = order[2 * q + 1] + b * m_i
            keep = not gate
            if gate:
                for j in range(D // 2):
                    d0 = X[i1, 2 * j] - X[i2, 2 * j]
                    d1 = X[i1, 2 * j + 1] - X[i2, 2 * j + 1]
                    if d0 * d0 + d1 * d1 <= thr:
                        keep = True
                        break
            if keep:
                pairs[h, 0] = i1
                pairs[h, 1] = i2
                isl[h] = b
                h += 1
    return pairs[:h], isl[:h]


@jit
def breed(X, V, pairs, pc, Z, sigma, out, CV):  # pragma: no cover - compiled
    """Crossover (eqs 25-28) and mutation candidates (eq 29), in place.

    For pair ``q`` with parents ``(x1, x2)`` and ``p = pc[q]``: children
    ``x2 + p (x1 - x2)`` (row ``q``) and ``x1 - p (x1 - x2)`` (row ``h + q``) go to
    ``out[m:2m]``, their velocities likewise to ``CV``, and the mutants
    ``Z sigma + child`` to ``out[:m]`` (``m = 2h``).
    """
    h = pairs.shape[0]
    m = 2 * h
    D = X.shape[1]
    for q in range(h):
        a = pairs[q, 0]
        b = pairs[q, 1]
        p = pc[q]
        for j in range(D):
            dx = (X[a, j] - X[b, j]) * p
            dv = (V[a, j] - V[b, j]) * p
            out[m + q, j] = X[b, j] + dx
            out[m + h + q, j] = X[a, j] - dx
            CV[q, j] = V[b, j] + dv
            CV[h + q, j] = V[a, j] - dv
    for r in range(m):
        for j in range(D):
            out[r, j] = Z[r, j] * sigma[j] + out[m + r, j]


@jit
def absorb(X, V, F, pbest, pbest_f, cost, B, CV, isl, m, n_islands):  # pragma: no cover
    """Personal bests, eq 29 and the replacement of the worst particles, in place.

    ``F[:] = cost[:P]``; ``pbest`` takes the rows of ``X`` that improved, ``pbest_f`` the
    minimum.  Child ``r`` (row ``P + m + r`` of ``B`` / ``cost``) is replaced by its mutant
    (row ``P + r``) when that is strictly better; the children, in stable island order, take
    the slots of the worst particles of their island (the r-th child of island b the r-th
    worst, ties broken as by a reversed stable sort) in ``X``, ``V``, ``F``, ``pbest`` and
    ``pbest_f``.  Returns the number of mutants kept.
    """
    P, D = X.shape
    for i in range(P):
        f = cost[i]
        F[i] = f
        if f < pbest_f[i]:
            for j in range(D):
                pbest[i, j] = X[i, j]
        pbest_f[i] = min(pbest_f[i], f)
    if m == 0:
        return 0
    m_i = P // n_islands
    worst = np.empty((n_islands, m_i), np.int64)  # from F before any replacement
    for b in range(n_islands):
        order = np.argsort(F[b * m_i:(b + 1) * m_i], kind="mergesort")
        for r in range(m_i):
            worst[b, r] = order[m_i - 1 - r] + b * m_i
    o = np.argsort(isl, kind="mergesort") if n_islands > 1 else np.arange(m)
    kept = 0
    rank = 0
    prev = -1
    for q in range(m):
        r = o[q]
        b = isl[r] if n_islands > 1 else 0
        rank = rank + 1 if b == prev else 0
        prev = b
        cm = cost[P + r]
        cc = cost[P + m + r]
        row = P + r if cm < cc else P + m + r  # eq 29, greedy
        if cm < cc:
            kept += 1
        slot = worst[b, min(rank, m_i - 1)]
        for j in range(D):
            X[slot, j] = B[row, j]
            pbest[slot, j] = B[row, j]
            V[slot, j] = CV[r, j]
        F[slot] = cost[row]
        pbest_f[slot] = cost[row]
    return kept
