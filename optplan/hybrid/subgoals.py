r"""Sub-goals of the hybrid planner (paper §V step 4): the global path's inflection points.

Inflection point (definition used here)
---------------------------------------
Let the global path be the polyline :math:`p_0, \dots, p_n` (consecutive duplicates removed)
and :math:`q` the last kept point (initially :math:`p_0`).  Vertex :math:`p_i`,
:math:`0 < i < n`, is an inflection (turning) point when the angle between the chord
:math:`p_i - q` and the outgoing segment :math:`p_{i+1} - p_i` exceeds ``angle_tol``:

.. math::

   \theta_i = \left|\operatorname{atan2}\big(c \times d,\; c \cdot d\big)\right| > \theta_{tol},
   \qquad c = p_i - q,\; d = p_{i+1} - p_i;

then :math:`q \leftarrow p_i`.  For a polyline with sharp corners this is exactly the set of
corners whose turning angle exceeds the tolerance; measuring against the chord from the last
kept point (rather than the incoming segment) also places sub-goals along gently curving, densely
sampled paths (a circular arc yields one sub-goal every :math:`\approx 2\theta_{tol}` of arc),
which a vertex-by-vertex test would skip entirely.

:func:`subgoals` is the sequence the leader is driven through: the inflection points, then the
final goal (optionally with every leg split, ``subgoal_spacing``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["inflection_points", "subgoals", "turning_angles"]


def _dedupe(path: np.ndarray, eps: float) -> np.ndarray:
    """Drop consecutive points closer than ``eps`` (keeps the first and the last point)."""
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        return p
    step = np.hypot(*np.diff(p, axis=0).T)
    keep = np.r_[True, step > eps]
    out = p[keep]
    if not np.array_equal(out[-1], p[-1]):
        out[-1] = p[-1]
    return out


def turning_angles(path: np.ndarray) -> np.ndarray:
    """Absolute turning angle (degrees) at every interior vertex, shape ``(n - 2,)``.

    The angle between the incoming and the outgoing segment directions: 0 for collinear
    points, 90 for a right-angle corner, 180 for a reversal.  Zero-length segments must have
    been removed (see :func:`inflection_points`).
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return np.zeros(0)
    a = p[1:-1] - p[:-2]
    b = p[2:] - p[1:-1]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.sum(a * b, axis=1)
    return np.degrees(np.abs(np.arctan2(cross, dot)))


def inflection_points(path: np.ndarray, angle_tol: float = 10.0, *,
                      return_index: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    r"""Inflection (turning) points of a polyline, paper §V step 4.

    Parameters
    ----------
    path : array, shape ``(n, 2)``
        The global path, first point = start, last point = goal.
    angle_tol : float
        Turning-angle tolerance :math:`\theta_{tol}` in degrees, ``0 <= angle_tol < 180``.
        A vertex is kept when the angle between the chord from the last kept point and the
        outgoing segment exceeds it (module docstring).
    return_index : bool
        Also return the indices of the kept vertices in the de-duplicated path.

    Returns
    -------
    points : array, shape ``(k, 2)``
        The inflection points in path order, excluding start and goal (``k`` may be 0).
    index : array of int, shape ``(k,)``
        Only with ``return_index``.

    Examples
    --------
    >>> inflection_points([[0, 0], [1, 0], [2, 0], [2, 1]], 10.0)
    array([[2., 0.]])
    """
    if not 0.0 <= float(angle_tol) < 180.0:
        raise ValueError(f"angle_tol must be in [0, 180) degrees, got {angle_tol!r}")
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    scale = max(1.0, float(np.abs(p).max())) if len(p) else 1.0
    p = _dedupe(p, 1e-9 * scale)
    kept: list[int] = []
    if len(p) >= 3:
        tol = math.radians(float(angle_tol))
        out_dir = np.diff(p, axis=0)  # outgoing segment of vertex i is out_dir[i]
        q = p[0]
        # a sequential scan: each decision depends on the last kept point (paths are short)
        for i in range(1, len(p) - 1):
            c = p[i] - q
            d = out_dir[i]
            ang = abs(math.atan2(c[0] * d[1] - c[1] * d[0], c[0] * d[0] + c[1] * d[1]))
            if ang > tol:
                kept.append(i)
                q = p[i]
    idx = np.asarray(kept, dtype=int)
    pts = p[idx] if len(idx) else np.zeros((0, 2))
    return (pts, idx) if return_index else pts


def subgoals(path: np.ndarray, goal: np.ndarray, angle_tol: float = 10.0,
             spacing: float = 0.0) -> np.ndarray:
    """The sub-goal sequence of step 4: the inflection points of ``path``, then ``goal``.

    With ``spacing > 0`` (an option beyond the paper) every leg of the polyline
    start -> inflection points -> goal is also split into equal pieces no longer than
    ``spacing`` (map units); the inflection points are kept.
    """
    pts = inflection_points(path, angle_tol)
    g = np.asarray(goal, dtype=float).reshape(1, 2)
    seq = np.vstack([pts, g])
    if spacing <= 0:
        return seq
    start = np.asarray(path, dtype=float).reshape(-1, 2)[0]
    prev = np.vstack([start[None], seq[:-1]])
    out = []
    for a, b in zip(prev, seq):
        # at most 100,000 pieces per leg: a tiny spacing cannot exhaust memory
        n = max(1, min(100_000, int(math.ceil(math.hypot(*(b - a)) / spacing))))
        f = np.arange(1, n + 1)[:, None] / n
        out.append(a + f * (b - a))
    return np.vstack(out)
