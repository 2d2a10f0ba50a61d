"""Polyline utilities shared by every method (lengths, arc-length resampling, the farthest
vertex in clear sight)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["path_lengths", "cumulative_length", "resample_path", "points_along",
           "resample_uniform", "farthest_clear"]


def path_lengths(paths) -> np.ndarray | float:
    """Polyline lengths; ``(P, M, 2) -> (P,)`` or ``(M, 2) -> float``."""
    pts = np.asarray(paths, dtype=float)
    d = np.diff(pts, axis=-2)
    out = np.sum(np.hypot(d[..., 0], d[..., 1]), axis=-1)
    return float(out) if pts.ndim == 2 else out


def cumulative_length(path) -> np.ndarray:
    """Arc length at each vertex of a polyline ``(M, 2)``, starting at 0."""
    p = np.asarray(path, dtype=float)
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])


def points_along(path, at, knots=None) -> np.ndarray:
    """Points of the polyline ``path (M, 2)`` at parameters ``at``, linear between vertices
    (``np.interp``: clamped to the ends).

    ``knots`` is the parameter of each vertex, non-decreasing: the arc length
    (:func:`cumulative_length`, the default) or, e.g., the time a robot reaches it.
    Returns ``(len(at), 2)`` points.
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    s = cumulative_length(p) if knots is None else np.asarray(knots, dtype=float)
    return np.stack([np.interp(at, s, p[:, 0]), np.interp(at, s, p[:, 1])], axis=1)


def resample_uniform(path, n_points: int) -> np.ndarray:
    """``n_points`` points evenly spaced by arc length along ``path (M, 2)``, first and last
    the path's ends (the arc-length variant of :func:`resample_path`)."""
    s = cumulative_length(np.asarray(path, dtype=float).reshape(-1, 2))
    return points_along(path, np.linspace(0.0, s[-1], n_points), s)


def resample_path(path, n_segments: int) -> np.ndarray:
    """Polyline with exactly ``n_segments`` segments through every vertex of ``path``.

    Consecutive duplicates are dropped; each remaining segment is split into ``m_s >= 1``
    equal parts with ``m_s`` proportional to its length (largest remainder).  With more
    segments than ``n_segments`` the path is resampled uniformly by arc length instead (the
    arc-length variant, :func:`resample_uniform`: ``n_segments + 1`` points evenly spaced
    along the path).  Returns ``(n_segments + 1, 2)`` points, first and last the path's ends.
    With :func:`resample_uniform` and :func:`points_along`, the one resampler of optplan (the
    swarm's particle seeding, the NLP's initial guess, the formation pilot's reference, the
    animation's common time grid).
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) > 1:
        d = np.hypot(*np.diff(p, axis=0).T)
        p = np.vstack([p[0], p[1:][d > 0]]) if np.any(d > 0) else p[:1]
    if len(p) == 1:
        p = np.vstack([p, p])
    seg = np.hypot(*np.diff(p, axis=0).T)
    S = len(seg)
    if S > n_segments:
        return resample_uniform(p, n_segments + 1)
    extra = n_segments - S
    tot = seg.sum()
    share = extra * seg / tot if tot > 0 else np.full(S, extra / S)
    m = 1 + np.floor(share).astype(int)
    rem = n_segments - m.sum()
    if rem > 0:
        order = np.argsort(-(share - np.floor(share)), kind="stable")
        m[order[:rem]] += 1
    out = [p[0]]
    for k in range(S):
        f = np.arange(1, m[k] + 1)[:, None] / m[k]
        out.extend(p[k] + f * (p[k + 1] - p[k]))
    return np.asarray(out)


def farthest_clear(p: np.ndarray, points: np.ndarray,
                   clear: Callable[[np.ndarray, np.ndarray], np.ndarray | Sequence[bool]],
                   candidates: Sequence[int] | np.ndarray | None = None, *,
                   chunk: int | None = None) -> int | None:
    """The farthest vertex along a polyline that a straight segment from ``p`` reaches clear.

    The step of every "follow the farthest visible waypoint" tracker: the potential field's
    guide (:class:`optplan.potential.guide.Guide`), ORCA's sub-goals and its followers' walk
    along the leader's track (:mod:`optplan.formation.orca`) and the lost follower's walk along
    the pilot's path (:class:`optplan.formation.safety.SafetyLayer`).  What "clear" means is
    the caller's: the exact disc test on the known map, RVO2's visibility query, a sampled
    clearance from the static obstacles at time ``t``.  A tracker whose index never moves
    backwards passes the window ahead of its current index as ``candidates``.

    Parameters
    ----------
    p : (2,)
        Where the segments start (the robot).
    points : (M, 2)
        The polyline's vertices, in order along it.
    clear : callable
        ``clear(p, Q)`` with ``Q`` a ``(k, 2)`` array of vertices: per vertex, whether the
        segment ``p -> Q[j]`` is clear (a ``(k,)`` bool array or sequence).
    candidates : increasing int indices into ``points``, optional
        The vertices considered, the last one the farthest (default: every vertex).
    chunk : int >= 1, optional
        Vertices handed to ``clear`` per call, farthest first, stopping at the first call that
        finds a clear one: 1 for a costly test taken one segment at a time, ``None`` (the
        default) for a vectorised test of every candidate in one call.

    Returns
    -------
    int or None
        The index into ``points`` of the farthest candidate in clear sight; ``None`` when no
        candidate is.
    """
    cand = np.arange(len(points)) if candidates is None else np.asarray(candidates, dtype=int)
    n = len(cand)
    size = max(1, n if chunk is None else chunk)
    for stop in range(n, 0, -size):
        part = cand[max(0, stop - size):stop]
        ok = np.asarray(clear(p, points[part]), dtype=bool)
        if ok.any():
            return int(part[np.flatnonzero(ok)[-1]])
    return None
