"""Motion of translating obstacles and exact continuous-time contact with moving discs.

**The motion model** (``problems/README.md``, ``[[dynamic_obstacles]]``).  A moving obstacle's
reference point follows a piecewise-linear *track*: knot times ``tk`` (non-decreasing) and knot
points ``pk``.  A time that appears twice is a *jump*: the first knot of the pair is the position
just before the jump time, the second the position from the jump time on.  Before the first
knot and after the last the point stands still.  :func:`mover_track` builds the track of an
obstacle over a time window; it is the only implementation of ``after = "hold" | "loop" |
"bounce"`` and of constant velocities: :func:`mover_position` (hence
:meth:`optplan.problem.DynamicObstacle.position`, the simulator and the plots) evaluates it.

**Contact.**  Between two consecutive times of the union of a robot's stamps and a track's knots,
the robot moves linearly from ``a0`` to ``a1`` and the obstacle from ``b0`` to ``b1``.  In the
obstacle's frame the robot moves along the straight segment from ``a0 - b0`` to ``a1 - b1``, so
contact during the interval is exactly the static question "does this segment come within ``r``
of the obstacle's shape placed at the origin?", answered by the exact engine
(:class:`~optplan.geometry.ObstacleSet`).  At a jump the two intervals meet at the jump time,
with the obstacle's position just before the jump at the end of the first and just after it at
the start of the second: the jump itself is never swept.  Two robots: the relative segment
against a disc of radius ``r_i`` seen by a disc of radius ``r_j``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optplan.geometry.collision import ObstacleSet

__all__ = ["Contact", "mover_period", "mover_track", "mover_pieces", "mover_position",
           "track_eval",
           "positions_at", "relative_segments", "polyline_segments", "relative_contact"]


@dataclass(frozen=True)
class Contact:
    """The first contact along a relative motion: the index of the first colliding segment and
    the time of first contact inside it."""

    index: int
    time: float


def mover_period(dyn) -> float | None:
    """Period (s) of a looping or bouncing waypoint track, ``None`` if it does not repeat.

    ``"loop"``: ``times[-1] - times[0]``; ``"bounce"``: twice that.  Constant velocities,
    ``"hold"``, a single waypoint (or a zero time span) do not repeat.
    """
    if dyn.velocity is not None or dyn.after == "hold" or len(dyn.times) < 2:
        return None
    span = float(dyn.times[-1] - dyn.times[0])
    if span <= 0:
        return None
    return 2.0 * span if dyn.after == "bounce" else span


def _one_period(dyn) -> tuple[np.ndarray, np.ndarray]:
    """Knot times (from 0) and points of one period of a repeating track: the waypoints
    (``loop``), or the waypoints forth and back (``bounce``)."""
    t = np.asarray(dyn.times, float)
    w = np.asarray(dyn.waypoints, float)
    base = t - t[0]
    if dyn.after == "bounce":
        return (np.concatenate([base, 2.0 * base[-1] - base[::-1][1:]]),
                np.concatenate([w, w[::-1][1:]]))
    return base, w


def mover_track(dyn, t_lo: float, t_hi: float) -> tuple[np.ndarray, np.ndarray]:
    """The track ``(tk, pk)`` of a dynamic obstacle's reference point, exact on ``[t_lo, t_hi]``.

    Parameters
    ----------
    dyn : DynamicObstacle
    t_lo, t_hi : float
        The time window the track must cover (knots outside it may be included).

    Returns
    -------
    tk : ndarray ``(K,)``
        Non-decreasing knot times; a repeated time is a jump (``loop``, at each period end).
    pk : ndarray ``(K, 2)``
        Knot points.  Between knots the point moves linearly, before the first knot and after
        the last it stands still (:func:`track_eval`).

    Notes
    -----
    * Constant ``velocity``: ``waypoints[0] + (t - times[0]) velocity`` for every ``t`` (two
      knots, ``t_lo`` and ``t_hi``).
    * Waypoints: before ``times[0]`` the first waypoint, then the waypoints in turn; after
      ``times[-1]``: ``"hold"`` the last waypoint; ``"loop"`` repeats the waypoints with period
      ``P = times[-1] - times[0]``: at ``times[0] + k P`` (``k >= 1``) the point jumps from the
      last waypoint back to the first; ``"bounce"`` runs them backwards, then forwards again
      (period ``2 P``, continuous).  A single waypoint is a parked obstacle.

    Period boundaries are computed once each (``times[0] + k period``), so both sides of a jump
    carry the same time stamp, bit for bit.
    """
    w = np.asarray(dyn.waypoints, float)
    t = np.asarray(dyn.times, float)
    if dyn.velocity is not None:
        tk = np.array([t_lo, t_hi], float) if t_hi > t_lo else np.array([float(t_lo)])
        return tk, w[0] + (tk - t[0])[:, None] * np.asarray(dyn.velocity, float)
    period = mover_period(dyn)
    if period is None:
        return t.copy(), w.copy()
    base_t, base_p = _one_period(dyn)
    t0 = float(t[0])
    k_lo = max(0, math.floor((t_lo - t0) / period))
    k_hi = max(k_lo + 1, math.ceil((t_hi - t0) / period))
    start = t0 + np.arange(k_lo, k_hi + 1, dtype=float) * period  # period boundaries
    tk = start[:-1, None] + base_t[None, :]
    tk[:, 0], tk[:, -1] = start[:-1], start[1:]
    tk = np.minimum(np.maximum.accumulate(tk, axis=1), start[1:, None])  # rounding-proof order
    return tk.ravel(), np.tile(base_p, (len(start) - 1, 1))


def mover_pieces(dyn, t_lo: float, t_hi: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The linear pieces of a dynamic obstacle's motion on ``[t_lo, t_hi]`` (the track of
    :func:`mover_track`), the last one open-ended where the motion is known for ever.

    Returns
    -------
    ta, tb : ndarray ``(P,)``
        Start and end time of each piece (``tb > ta``; ``tb = inf`` for the last piece of a
        ``hold`` track or a constant velocity: the motion goes on unchanged).  A repeating
        (``loop``/``bounce``) track ends at its last knot at or after ``t_hi``.
    b, w : ndarray ``(P, 2)``
        Position at ``ta`` and velocity on the piece: ``b + (t - ta) w``.  A jump of a ``loop``
        ends one piece and starts the next (it is never a piece).
    """
    if dyn.velocity is not None:
        p0 = mover_position(dyn, float(t_lo))
        return (np.array([float(t_lo)]), np.array([np.inf]), p0[None, :],
                np.asarray(dyn.velocity, float)[None, :])
    tk, pk = mover_track(dyn, t_lo, t_hi)
    forever = mover_period(dyn) is None
    ta = np.concatenate([[min(float(t_lo), float(tk[0]))], tk])
    tb = np.concatenate([tk, [np.inf if forever else float(tk[-1])]])
    b = np.concatenate([pk[:1], pk])
    e = np.concatenate([pk, pk[-1:]])
    keep = tb > ta
    ta, tb, b, e = ta[keep], tb[keep], b[keep], e[keep]
    dt = np.where(np.isfinite(tb), tb - ta, 1.0)
    w = np.where(np.isfinite(tb)[:, None], (e - b) / dt[:, None], 0.0)
    inside = (tb > t_lo) & (ta <= max(float(t_lo), float(t_hi)))
    return ta[inside], tb[inside], b[inside], w[inside]


def track_eval(tk: np.ndarray, pk: np.ndarray, t, side: str = "right") -> np.ndarray:
    """Positions on a track ``(tk, pk)`` (:func:`mover_track`) at times ``t``.

    Parameters
    ----------
    tk, pk : ndarray ``(K,)``, ``(K, 2)``
        Non-decreasing knot times (a repeated time is a jump) and knot points.
    t : array_like ``(n,)``
    side : ``"right"`` or ``"left"``
        At a jump time: the position from the jump on (``"right"``, right-continuous: what
        the obstacle *is* at that time) or just before it (``"left"``, the left limit).

    Returns
    -------
    ndarray ``(n, 2)``
        Linear between knots (the formula of ``np.interp``; knots are reproduced exactly),
        constant before the first knot and after the last.
    """
    t = np.atleast_1d(np.asarray(t, float))
    tk = np.asarray(tk, float)
    pk = np.asarray(pk, float)
    if len(tk) == 1:
        return np.repeat(pk[:1], len(t), axis=0)
    raw = np.searchsorted(tk, t, side="right" if side == "right" else "left") - 1
    i = np.clip(raw, 0, len(tk) - 2)
    dt = tk[i + 1] - tk[i]  # > 0 inside the track: tk[i] <= t < tk[i + 1] (left: < and <=)
    slope = (pk[i + 1] - pk[i]) / np.where(dt > 0, dt, 1.0)[:, None]
    out = slope * (t - tk[i])[:, None] + pk[i]  # np.interp's formula
    at_start = (raw < 0) | (t == tk[i])
    at_end = (raw > len(tk) - 2) | (t == tk[i + 1])
    out = np.where(at_start[:, None], pk[i], out)
    return np.where(at_end[:, None] & ~(raw < 0)[:, None], pk[i + 1], out)


def mover_position(dyn, t) -> np.ndarray:
    """Reference position of a dynamic obstacle at time(s) ``t``, ``(2,)`` or ``(n, 2)``.

    Right-continuous: at a ``loop`` period boundary the position is the first waypoint.
    """
    tt = np.asarray(t, dtype=float)
    flat = np.atleast_1d(tt).ravel()
    if len(flat) == 0:
        return np.zeros((0, 2))
    if dyn.velocity is not None:  # the closed form of the two-knot track
        out = dyn.waypoints[0][None, :] + (flat - dyn.times[0])[:, None] * dyn.velocity
    else:
        tk, pk = mover_track(dyn, float(flat.min()), float(flat.max()))
        out = track_eval(tk, pk, flat, "right")
    return out[0] if tt.ndim == 0 else out


def positions_at(times: np.ndarray, path: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Positions of a robot's piecewise-linear trajectory ``(times, path)`` at times ``t``
    (held after the last stamp and before the first; :func:`track_eval`, right-continuous)."""
    return track_eval(times, path, t, "right")


def relative_segments(stamps: np.ndarray, path: np.ndarray, tk: np.ndarray, pk: np.ndarray,
                      t_lo: float, t_hi: float) -> tuple[np.ndarray, np.ndarray]:
    """A robot's motion relative to a track, as one segment per interval of ``[t_lo, t_hi]``.

    The intervals are cut at the union of the robot's ``stamps`` and the track's knots ``tk``.
    Each interval starts with the track's right value and ends with its left value, so a jump of
    the track ends one interval and starts the next and is never swept.

    Returns
    -------
    rel : ndarray ``(S, 2, 2)``
        Robot minus track position at the start and end of each interval.
    times : ndarray ``(S, 2)``
        Start and end time of each interval (a single instant when ``t_hi <= t_lo``).
    """
    T = np.unique(np.concatenate([stamps, tk, [t_lo, t_hi]]))
    T = T[(T >= t_lo) & (T <= max(t_lo, t_hi))]
    if len(T) == 1:
        T = np.r_[T, T]
    a, b = T[:-1], T[1:]
    rel = np.stack([positions_at(stamps, path, a) - track_eval(tk, pk, a, "right"),
                    positions_at(stamps, path, b) - track_eval(tk, pk, b, "left")], axis=1)
    return rel, np.stack([a, b], axis=1)


def polyline_segments(rel: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The segments ``(S, 2, 2)`` and their times ``(S, 2)`` of a continuous relative motion
    given at ``times`` (a single point gives one zero-length segment)."""
    if len(rel) < 2:
        rel, times = np.vstack([rel, rel]), np.r_[times, times]
    return (np.stack([rel[:-1], rel[1:]], axis=1),
            np.stack([times[:-1], times[1:]], axis=1))


def relative_contact(rel: np.ndarray, times: np.ndarray, oset: ObstacleSet) -> Contact | None:
    """First contact of the relative motion ``rel`` (segments ``(S, 2, 2)`` in time order, at
    ``times`` ``(S, 2)``) with ``oset``, ``None`` if there is none.

    The first colliding segment is found with the exact segment test; the contact time inside
    it by bisection on the prefix of the segment (40 halvings: far below any time resolution).
    """
    hit = np.flatnonzero(oset.crossings(rel, penetration=False).count)
    if len(hit) == 0:
        return None
    k = int(hit[0])
    a, b = rel[k]
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
    t0, t1 = times[k]
    return Contact(k, float(t0 + hi * (t1 - t0)))
