"""Polyline utilities shared by every method (lengths, arc-length resampling)."""

from __future__ import annotations

import numpy as np

__all__ = ["path_lengths", "cumulative_length", "resample_path"]


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


def resample_path(path, n_segments: int) -> np.ndarray:
    """Polyline with exactly ``n_segments`` segments through every vertex of ``path``.

    Consecutive duplicates are dropped; each remaining segment is split into ``m_s >= 1``
    equal parts with ``m_s`` proportional to its length (largest remainder).  With more
    segments than ``n_segments`` the path is resampled uniformly by arc length instead (the
    arc-length variant: ``n_segments + 1`` points evenly spaced along the path).  Returns
    ``(n_segments + 1, 2)`` points, first and last the path's ends.  The one resampler of
    optplan (the swarm's particle seeding, the NLP's initial guess).
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
        s = np.r_[0.0, np.cumsum(seg)]
        t = np.linspace(0.0, s[-1], n_segments + 1)
        return np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], axis=1)
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
