"""Polyline utilities shared by every method (lengths, arc-length resampling)."""

from __future__ import annotations

import numpy as np

__all__ = ["path_lengths", "cumulative_length"]


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
