"""Polyline utilities shared by every method (lengths, arc-length resampling)."""

from __future__ import annotations

import numpy as np

__all__ = ["path_lengths", "cumulative_length", "resample_path", "points_along",
           "resample_uniform"]


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
