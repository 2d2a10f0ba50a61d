"""Node sampling of the sparse roadmap (beyond the paper; probabilistic-roadmap techniques).

Nodes (:func:`roadmap_nodes`): uniform samples, obstacle-based samples beside the boundary
edges and around the corners of the kernel's convex pieces (:func:`boundary_samples`) and
medial-axis retractions, which land in narrow passages (:func:`medial_samples`).  The edges and
the corridor search are :mod:`optplan.swarm.roadmap`.
"""

from __future__ import annotations

import numpy as np

from optplan.swarm.core import SwarmSpace, segment_free

__all__ = ["boundary_samples", "medial_samples", "roadmap_nodes"]


def boundary_samples(space: SwarmSpace, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` random points beside the obstacles (world coordinates), moved out from the
    obstacle by the robot radius plus an exponential margin (mean ``0.5 r + diag / 200``):
    half of them from a point drawn uniformly by length over the kernel's boundary edges and
    circle perimeters (along the outward normal), half around a random corner of a convex
    piece (in a random direction between the normals of its two edges).  Obstacle-based
    sampling (a PRM technique): it puts roadmap nodes in narrow passages and around the
    corners that shortest paths wrap."""
    os_ = space.obstacles
    if os_ is None or os_.n_items == 0 or n <= 0:
        return np.zeros((0, 2))
    K = os_.n_pieces
    p, e, nrm = os_.table[0], os_.table[1], os_.table[2]  # (4, K) complex, local frame
    w_edge = np.where(os_.boundary, np.abs(e), 0.0).T.reshape(-1)  # (K * 4,)
    cen = os_.item_center[K:]
    rad = os_.circle_radius
    w = np.concatenate([w_edge, 2 * np.pi * rad])
    if w.sum() <= 0:
        return np.zeros((0, 2))
    off = os_.radius + rng.exponential(0.5 * os_.radius + space.diag / 200.0, n)
    n_corner = n // 2 if K else 0
    z = np.empty(n, complex)
    # along edges and circles
    m = n - n_corner
    pick = rng.choice(len(w), size=m, p=w / w.sum())
    u = rng.random(m)
    edge = pick < len(w_edge)
    k, j = pick[edge] // 4, pick[edge] % 4
    ze = np.empty(m, complex)
    ze[edge] = p[j, k] + u[edge] * e[j, k] + off[:m][edge] * nrm[j, k]
    c = pick[~edge] - len(w_edge)
    ze[~edge] = cen[c] + (rad[c] + off[:m][~edge]) * np.exp(2j * np.pi * u[~edge])
    z[:m] = ze
    # around piece corners: vertex j of piece k lies between edges j - 1 and j
    if n_corner:
        # corners without replacement (every corner once before any twice)
        order = np.concatenate([rng.permutation(4 * K) for _ in range(-(-n_corner // (4 * K)))])
        k, j = order[:n_corner] // 4, order[:n_corner] % 4
        a0 = np.angle(nrm[(j - 1) % 4, k])
        sweep = np.mod(np.angle(nrm[j, k]) - a0, 2 * np.pi)
        sweep = np.where(sweep > np.pi, 0.0, sweep)  # a reflex join: along the first normal
        z[m:] = p[j, k] + off[m:] * np.exp(1j * (a0 + rng.random(n_corner) * sweep))
    return np.stack([z.real, z.imag], axis=1) + os_.frame.origin


def medial_samples(space: SwarmSpace, n: int, rng: np.random.Generator) -> np.ndarray:
    """Samples retracted toward the medial axis (a PRM technique for narrow passages): for
    each of ``n`` points (half uniform in the bounds, half :func:`boundary_samples`, which
    start beside an obstacle and so find the obstacles close to it), the midpoint of its
    nearest boundary points on its two nearest obstacles (searched within ``diag / 4``), kept
    when free.  In a passage between two obstacles the midpoint lies on its centre line,
    however narrow it is."""
    os_ = space.obstacles
    if os_ is None or os_.n_obstacles < 2 or n <= 0:
        return np.zeros((0, 2))
    lo, hi = space.lo[:2], space.hi[:2]
    x = np.vstack([lo + (hi - lo) * rng.random((n - n // 2, 2)),
                   boundary_samples(space, n // 2, rng)])
    n = len(x)
    near, dist = os_.nearest(x, max_range=space.diag / 4.0)
    two = np.argsort(dist, axis=1)[:, :2]
    r = np.arange(n)
    ok = np.isfinite(dist[r, two[:, 1]])
    m = 0.5 * (near[r, two[:, 0]] + near[r, two[:, 1]])[ok]
    m = m[np.all((m >= lo) & (m <= hi), axis=1)]
    return m[segment_free(m, m, space)]


def roadmap_nodes(space: SwarmSpace, n_samples: int, rng: np.random.Generator,
                  boundary: int | None = None, medial: int | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Start, goal and the collision-free ones among ``n_samples`` uniform draws in the bounds
    and ``boundary`` (default ``n_samples``) :func:`boundary_samples`, plus the
    :func:`medial_samples` of ``medial`` (default ``n_samples``) points.  Returns the nodes and a
    mask of the *corner* nodes (the corner samples, start and goal)."""
    lo, hi = space.lo[:2], space.hi[:2]
    nb = n_samples if boundary is None else boundary
    pts = np.vstack([lo + (hi - lo) * rng.random((n_samples, 2)),
                     boundary_samples(space, nb, rng)])
    corner = np.zeros(len(pts), bool)
    corner[n_samples + nb - (nb // 2 if space.obstacles is not None
                              and space.obstacles.n_pieces else 0):] = True
    keep = np.all((pts >= lo) & (pts <= hi), axis=1)
    pts, corner = pts[keep], corner[keep]
    free = segment_free(pts, pts, space)
    mids = medial_samples(space, n_samples if medial is None else medial, rng)
    return (np.vstack([space.start, space.goal, pts[free], mids]),
            np.concatenate([[True, True], corner[free], np.ones(len(mids), bool)]))

