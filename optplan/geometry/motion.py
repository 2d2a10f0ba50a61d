"""Exact continuous-time contact between moving discs and translating obstacles.

Between two time stamps let a robot move linearly from ``a0`` to ``a1`` and a translating
obstacle's reference point from ``b0`` to ``b1``.  In the obstacle's frame the robot moves along
the straight segment from ``a0 - b0`` to ``a1 - b1``, so contact during the interval is exactly
the static question "does this segment come within ``r`` of the obstacle's shape placed at the
origin?", answered by the exact engine (:class:`~optplan.geometry.ObstacleSet`).  Two robots: the
relative segment against a disc of radius ``r_i`` seen by a disc of radius ``r_j``.

Piecewise-linear tracks are merged on the union of their time stamps (the robot's stamps and the
obstacle's velocity breakpoints), so every interval is one relative segment.  A robot holds its
last position after its last stamp.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optplan.geometry.frame import Frame
from optplan.geometry.obstacles import ObstacleSet, obstacle_set

__all__ = ["Contact", "track_breakpoints", "positions_at", "relative_contact", "shape_set"]


@dataclass(frozen=True)
class Contact:
    """The first contact along a relative motion: interval index, time and the point where the
    robot is (world coordinates of the robot, not of the relative motion)."""

    index: int
    time: float


def track_breakpoints(dyn, t_end: float) -> np.ndarray:
    """Times in ``[0, t_end]`` where a dynamic obstacle's velocity may change.

    Waypoint tracks: their time stamps, repeated with the period for ``after = "loop"``
    (period = span) and ``"bounce"`` (period = 2 x span, reversed on the way back).  A constant
    velocity has none.
    """
    if dyn.velocity is not None or len(dyn.times) < 2:
        return np.zeros(0)
    t = np.asarray(dyn.times, float)
    t0, span = t[0], t[-1] - t[0]
    if dyn.after == "hold" or span <= 0:
        out = t
    else:
        base = t - t0
        if dyn.after == "bounce":
            base = np.concatenate([base, 2 * span - base[::-1][1:]])
            period = 2 * span
        else:
            period = span
        k = np.arange(0, max(1, math.ceil((t_end - t0) / period)) + 1)
        out = t0 + (k[:, None] * period + base[None, :]).ravel()
    return out[(out > 0) & (out < t_end)]


def positions_at(times: np.ndarray, path: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Positions of a piecewise-linear track ``(times, path)`` at times ``t`` (held after the
    last stamp and before the first)."""
    return np.stack([np.interp(t, times, path[:, 0]), np.interp(t, times, path[:, 1])], axis=1)


def shape_set(kind: str, radius: float | None, local_geometry, robot_radius: float,
              length: float) -> ObstacleSet:
    """Exact engine for a shape placed at the origin (a translating obstacle in its own frame),
    with the tolerance of a map of diagonal ``length``."""
    from optplan.problem import Obstacle

    h = length / (2.0 * math.sqrt(2.0))
    frame = Frame.from_bounds((-h, -h, h, h))
    if kind == "circle":
        o = Obstacle("circle", None, name="moving", center=np.zeros(2), radius=float(radius))
    else:
        o = Obstacle("polygon", local_geometry, name="moving")
    return obstacle_set([o], robot_radius, frame)


def relative_contact(rel: np.ndarray, times: np.ndarray, oset: ObstacleSet) -> Contact | None:
    """First contact of the relative motion ``rel`` (``(m, 2)`` at ``times``) with ``oset``.

    The first colliding interval is found with the exact segment test; the contact time inside
    it by bisection on the prefix of the segment (40 halvings: far below any time resolution).
    """
    if len(rel) < 2:
        rel = np.vstack([rel, rel])
        times = np.r_[times, times]
    cr = oset.crossings(rel[None], details=True, penetration=False)
    if cr.count[0] == 0:
        return None
    k = int(np.flatnonzero(cr.seg_count[0])[0])
    a, b = rel[k], rel[k + 1]
    lo, hi = 0.0, 1.0
    if oset.crossings(np.stack([a, a])[None], penetration=False).count[0]:
        hi = 0.0
    else:
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if oset.crossings(np.stack([a, a + mid * (b - a)])[None],
                              penetration=False).count[0]:
                hi = mid
            else:
                lo = mid
    return Contact(k, float(times[k] + hi * (times[k + 1] - times[k])))
