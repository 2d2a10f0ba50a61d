"""Interval arithmetic in time: the one place for unions, complements and first free times.

A busy or forbidden set of times is a sorted list of disjoint *open* intervals ``(lo, hi)``
(touching ones merged: touching a moving obstacle is allowed); a safe set is its closed
complement.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

__all__ = ["Intervals", "merge_open", "free_intervals", "first_free"]

#: A sorted list of disjoint intervals ``(lo, hi)`` (open when busy or forbidden, closed when
#: safe).
Intervals = list[tuple[float, float]]


def merge_open(lo: np.ndarray, hi: np.ndarray) -> Intervals:
    """Union of open intervals ``(lo_i, hi_i)``, touching ones merged, sorted."""
    out: Intervals = []
    order = np.argsort(lo, kind="stable")
    for x, y in zip(np.asarray(lo)[order].tolist(), np.asarray(hi)[order].tolist()):
        if out and x <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], y))
        else:
            out.append((x, y))
    return out


def free_intervals(busy: Intervals, horizon: float) -> Intervals:
    """The safe intervals in ``[0, horizon]``: the closed complement of the open ``busy``
    intervals (sorted, disjoint; touching a moving obstacle is allowed)."""
    out: Intervals = []
    t = 0.0
    for lo, hi in busy:
        if hi <= t:
            continue
        if lo >= horizon:
            break
        if lo >= t:
            out.append((t, lo))
        t = hi
        if t > horizon:
            return out
    out.append((t, horizon))
    return out


def first_free(forbidden: Intervals, t: float) -> float:
    """The earliest time ``>= t`` outside the open intervals ``forbidden`` (sorted, disjoint,
    touching ones merged)."""
    k = bisect.bisect_left(forbidden, (t, -math.inf)) - 1
    if k >= 0 and forbidden[k][1] > t:
        return forbidden[k][1]
    return t
