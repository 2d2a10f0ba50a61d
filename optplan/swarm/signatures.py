"""Homotopy signatures of paths (beyond the paper): an int64 hash per path.

Homotopy classes (beyond the paper)
    A path's class is summarised by an integer *signature*: for every item of the fitness
    kernel (convex piece or circle) a reference point inside it and the upward vertical ray from
    it; each segment crossing a ray adds ``+1`` (left to right) or ``-1`` to that item's count,
    and the signature hashes the count vector (:func:`signature_hashes`).  Two paths with
    common endpoints have the same signature iff their loop winds zero times around every
    item (see :mod:`optplan.geometry.collision.homotopy`); the counts add over concatenated
    segments, so a roadmap search can carry them along its edges.

The per-item keys are :attr:`optplan.swarm.core.SwarmSpace.signature_keys`, the reference
points :attr:`optplan.swarm.core.SwarmSpace.signature_points`.
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.compiled import F2, I1, compiled
from optplan.swarm.core import SwarmSpace

__all__ = ["signature_hashes", "signature_hashes_list"]

@compiled(F2, F2, F2, I1)
def _segment_hashes(A, B, Z, keys):
    """Per segment ``A[s] -> B[s]`` the sum of ``keys[o]`` times its signed crossing of the
    upward ray from ``Z[o]`` (wrapping int64 arithmetic)."""
    n = A.shape[0]
    out = np.zeros(n, np.int64)
    for s in range(n):
        ax, ay, bx, by = A[s, 0], A[s, 1], B[s, 0], B[s, 1]
        h = np.int64(0)
        for o in range(Z.shape[0]):
            zx = Z[o, 0]
            ra = ax > zx
            rb = bx > zx
            if ra == rb:
                continue
            y = ay + (zx - ax) * (by - ay) / (bx - ax)
            if y > Z[o, 1]:
                if rb:
                    h += keys[o]
                else:
                    h -= keys[o]
        out[s] = h
    return out


def signature_hashes(paths: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Homotopy signature (an int64 hash, module docstring) of each polyline ``(P, M, 2)``;
    equal for two paths with common endpoints iff they wind alike around every item."""
    p = np.asarray(paths, dtype=float)
    if p.ndim == 2:
        p = p[None]
    P, M, _ = p.shape
    if M < 2:
        return np.zeros(P, np.int64)
    A = np.ascontiguousarray(p[:, :-1].reshape(-1, 2))
    B = np.ascontiguousarray(p[:, 1:].reshape(-1, 2))
    h = _segment_hashes(A, B, space.signature_points, space.signature_keys)
    return h.reshape(P, M - 1).sum(axis=1)


def signature_hashes_list(paths: list[np.ndarray], space: SwarmSpace) -> np.ndarray:
    """:func:`signature_hashes` of polylines of different lengths."""
    if not paths:
        return np.zeros(0, np.int64)
    M = max(len(p) for p in paths)
    return signature_hashes(np.array([np.vstack([p, np.repeat(p[-1:], M - len(p), axis=0)])
                                      for p in paths]), space)
