r"""Closed-form contact between two discs on timed straight motions (the conflicts of ``ccbs``).

A *timed action* is a disc centre moving linearly from ``a`` (at ``t0``) to ``b`` (at ``t1``):
a move along a segment at constant speed, or a wait at a point (``a = b``), possibly for ever
(``t1 = inf``: a robot holding its goal).  Two discs whose centres are closer than the contact
distance ``R`` (``r_i + r_j``) *overlap*: a conflict; touching (distance exactly ``R``) is
allowed, as in the validator (:func:`optplan.metrics.time_checks`, which accepts a distance
``>= R - eps``).

**Contact of two actions** (:func:`contact_interval`).  On the common time window both centres
move linearly, so their difference is ``c + tau d`` and the squared distance a quadratic in
``tau``: the contact set is one open interval, the roots of ``|c + tau d|^2 = R^2``
(:func:`~optplan.geometry.timing.contact_times.line_intervals`, the one closed form of a disc on
a line against a circle), clipped to the window.

**Unsafe start times** (:func:`unsafe_interval`).  Action ``i`` (a motion of duration ``D``,
``D = inf`` for a hold) started at ``s`` against action ``j`` fixed in time.  In the
(start ``s``, time ``t``) plane the relative position ``c + t w + s u`` is linear, so the pairs
in contact form a convex set: the *ellipse* ``|c + t w + s u| < R`` cut by the polygon
``s <= t <= s + D``, ``t0_j <= t <= t1_j``.  Its projection on ``s`` is one open interval whose
ends are attained either on an edge of the polygon (``t = s``: ``i`` at its start point;
``t = s + D``: at its end point; ``t = t0_j`` or ``t = t1_j``: ``j`` at an end; each a quadratic
in ``s`` clipped to an interval) or inside it, where the ellipse has a tangent parallel to the
``t`` axis (the distance minimised over ``t`` is the distance to the line of direction ``w``: a
quadratic in ``s``, kept where the minimiser ``t*(s)`` lies in the polygon).  Each of these five
pieces is a subset of the projection and together they reach both of its ends, so the interval
is the hull of the pieces: exact up to round-off, no bisection.  The contact set in the
``(s, t)`` plane is convex because both bodies are convex in space-time (a disc swept linearly
over a time interval), so the start times in contact are one interval.

Every tolerance is relative: the callers pass a contact distance already shrunk by a relative
margin of ``R`` (``ccbs``: :data:`CONTACT_REL_TOL`); nothing here is absolute in coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optplan.geometry.timing.contact_times import ConvexShape, line_intervals

__all__ = ["TimedMotion", "TimedMotions", "contact_interval", "contact_intervals",
           "unsafe_interval", "CONTACT_REL_TOL"]

#: Relative margin of the contact distance: ``ccbs`` plans with the contact distance
#: ``(r_i + r_j) (1 - CONTACT_REL_TOL)`` (what its constraints exclude) and reports a conflict
#: when two discs come closer than ``(r_i + r_j) (1 - 2 CONTACT_REL_TOL)`` (round-off of a
#: departure placed exactly at the end of a constraint is far below it).  Both stay within the
#: validator's tolerance (``1e-9`` of the map diagonal) for discs smaller than the map.
CONTACT_REL_TOL = 1e-10

_POINT = ConvexShape(radius=0.0)


def _velocities(a: np.ndarray, b: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Per row ``(b - a) / (t1 - t0)``, zero for a wait (``a = b``, ``t1 = inf``, ``t1 <= t0``)."""
    moving = np.isfinite(t1) & (t1 > t0) & (a != b).any(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = (b - a) / (t1 - t0)[:, None]
    return np.where(moving[:, None], v, 0.0)


@dataclass(frozen=True)
class TimedMotion:
    """A disc centre moving linearly from ``a`` at time ``t0`` to ``b`` at time ``t1``.

    Attributes
    ----------
    a, b : tuple of float
        Start and end point (map units); equal for a wait.
    t0, t1 : float
        Start and end time (s), ``t1 > t0``; ``t1 = inf`` is a wait for ever (``a = b``).
    """

    a: tuple[float, float]
    b: tuple[float, float]
    t0: float
    t1: float

    @property
    def velocity(self) -> np.ndarray:
        """``(b - a) / (t1 - t0)`` (zero for a wait)."""
        return TimedMotions.of([self]).velocity[0]


@dataclass(frozen=True)
class TimedMotions:
    """Timed motions, one a row: the arrays of :class:`TimedMotion` (``a``, ``b``,
    ``velocity`` ``(n, 2)``; ``t0``, ``t1`` ``(n,)``); :meth:`build` computes the velocities."""

    a: np.ndarray
    b: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    velocity: np.ndarray

    @classmethod
    def build(cls, a: np.ndarray, b: np.ndarray, t0: np.ndarray, t1: np.ndarray
              ) -> TimedMotions:
        """The motions ``a[k] -> b[k]`` over ``[t0[k], t1[k]]``."""
        a, b = np.asarray(a, float).reshape(-1, 2), np.asarray(b, float).reshape(-1, 2)
        t0, t1 = np.asarray(t0, float), np.asarray(t1, float)
        return cls(a, b, t0, t1, _velocities(a, b, t0, t1))

    @classmethod
    def of(cls, motions: list[TimedMotion]) -> TimedMotions:
        """The rows of ``motions``."""
        return cls.build(np.array([m.a for m in motions], float),
                         np.array([m.b for m in motions], float),
                         np.array([m.t0 for m in motions], float),
                         np.array([m.t1 for m in motions], float))

    def take(self, rows: np.ndarray) -> TimedMotions:
        """The motions of ``rows`` (indices)."""
        return TimedMotions(self.a[rows], self.b[rows], self.t0[rows], self.t1[rows],
                            self.velocity[rows])

    def at(self, t: np.ndarray) -> np.ndarray:
        """Row ``k``'s centre at time ``t[k]`` (clamped to its window)."""
        tt = np.minimum(np.maximum(t, self.t0), self.t1)
        moves = (self.velocity != 0).any(axis=1)
        with np.errstate(invalid="ignore"):
            step = np.where(moves, tt - self.t0, 0.0)
        return np.where(moves[:, None], self.a + step[:, None] * self.velocity, self.a)


def _below(c: np.ndarray, d: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the open ``tau`` interval where ``|c + tau d| < radius`` (NaN: none)."""
    return line_intervals(c, d, _POINT, radius)


def contact_intervals(p: TimedMotions, q: TimedMotions, radius: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """When two discs on timed motions overlap, row by row (``p[k]`` against ``q[k]``).

    Parameters
    ----------
    p, q : TimedMotions
        The same number of rows.
    radius : float
        The contact distance (the sum of the radii, possibly shrunk by a relative margin).

    Returns
    -------
    start, end : ndarray ``(n,)``
        The open interval ``(first contact, last contact)`` of times in the common window of
        row ``k`` at which the centres are closer than ``radius``; NaN when they never are
        (touching is not contact).  The first contact is the first time of the conflict.
    """
    lo, hi = np.maximum(p.t0, q.t0), np.minimum(p.t1, q.t1)
    if radius <= 0 or not len(lo):
        return np.full(len(lo), np.nan), np.full(len(lo), np.nan)
    a, b = _below(p.at(lo) - q.at(lo), p.velocity - q.velocity, radius)
    with np.errstate(invalid="ignore"):
        start, end = lo + np.maximum(a, 0.0), lo + np.minimum(b, hi - lo)
    hit = (hi > lo) & ~np.isnan(a) & (end > start)
    return np.where(hit, start, np.nan), np.where(hit, end, np.nan)


def contact_interval(p: TimedMotion, q: TimedMotion, radius: float
                     ) -> tuple[float, float] | None:
    """When two discs on timed motions overlap: :func:`contact_intervals` of one row.

    Parameters
    ----------
    p, q : TimedMotion
    radius : float
        The contact distance.

    Returns
    -------
    tuple of float or None
        The open interval ``(first contact, last contact)``; ``None`` when they never overlap.
    """
    start, end = contact_intervals(TimedMotions.of([p]), TimedMotions.of([q]), radius)
    return None if np.isnan(start[0]) else (float(start[0]), float(end[0]))


def _edge_pieces(c: np.ndarray, vi: np.ndarray, vj: np.ndarray, dur: float, span: float
                 ) -> tuple[list[np.ndarray], list[np.ndarray], list[tuple[float, float]]]:
    """The four polygon-edge pieces of :func:`unsafe_interval`: their lines (point, direction
    in ``s``) and their ``s`` ranges (closed)."""
    rows, dirs, box = [c, c, c], [-vj, -vi, -vj], [(0.0, span), (-dur, 0.0), (-dur, span)]
    if math.isfinite(dur):  # t = s + D: i at its end point
        rows[2] = c + dur * (vi - vj)
        box[2] = (-dur, span - dur)
    else:
        rows.pop()
        dirs.pop()
        box.pop()
    if math.isfinite(span):  # t = T: j at its end point
        rows.append(c + span * (vi - vj))
        dirs.append(-vi)
        box.append((span - dur, span))
    return rows, dirs, box


def _inside_range(c: np.ndarray, vi: np.ndarray, vj: np.ndarray, dur: float, span: float
                  ) -> tuple[np.ndarray, np.ndarray, tuple[float, float]] | None:
    """The interior piece of :func:`unsafe_interval`: the line of the distance to the line of
    direction ``w = vi - vj`` and the ``s`` range where the minimiser ``t*(s)`` lies in the
    polygon (``None`` when ``w = 0``: the edge pieces then cover everything)."""
    w = vi - vj
    ww = float(w @ w)
    if ww == 0.0:
        return None
    u = -vi
    alpha, beta = -float(c @ w) / ww, -float(u @ w) / ww  # t*(s) = alpha + beta s
    perp = np.eye(2) - np.outer(w, w) / ww
    lo, hi = -math.inf, math.inf
    # t* >= s, t* <= s + D, t* >= 0, t* <= T: each  k0 + k1 s >= 0
    for k0, k1 in ((alpha, beta - 1.0), (dur - alpha, 1.0 - beta), (alpha, beta),
                   (span - alpha, -beta)):
        if not math.isfinite(k0):
            continue
        if k1 > 0:
            lo = max(lo, -k0 / k1)
        elif k1 < 0:
            hi = min(hi, -k0 / k1)
        elif k0 < 0:
            return None
    return perp @ c, perp @ u, (lo, hi)


def unsafe_interval(moving: TimedMotion, fixed: TimedMotion, radius: float
                    ) -> tuple[float, float] | None:
    """The start times of ``moving`` at which it overlaps ``fixed``.

    Parameters
    ----------
    moving : TimedMotion
        The action whose start is shifted: the same points and duration (``t1 - t0``, ``inf``
        for a hold), started at ``s`` instead of ``t0``.
    fixed : TimedMotion
        The other action, at its own times.
    radius : float
        The contact distance.

    Returns
    -------
    tuple of float or None
        The open interval of start times ``s`` for which the two overlap (the module
        docstring: a single interval, exact up to round-off), ``None`` when no start time
        overlaps.  Its end is the earliest start at or after it that is free of ``fixed``.
    """
    if radius <= 0:
        return None
    dur = moving.t1 - moving.t0
    span = fixed.t1 - fixed.t0
    vi, vj = moving.velocity, fixed.velocity
    c = np.asarray(moving.a, float) - np.asarray(fixed.a, float)
    rows, dirs, box = _edge_pieces(c, vi, vj, dur, span)
    inner = _inside_range(c, vi, vj, dur, span)
    if inner is not None:
        rows.append(inner[0])
        dirs.append(inner[1])
        box.append(inner[2])
    a, b = _below(np.array(rows), np.array(dirs), radius)
    bx = np.array(box, dtype=float)
    lo, hi = np.maximum(a, bx[:, 0]), np.minimum(b, bx[:, 1])
    ok = ~np.isnan(a) & (hi > lo)
    if not ok.any():
        return None
    return fixed.t0 + float(lo[ok].min()), fixed.t0 + float(hi[ok].max())
