"""Closed-form contact intervals of a disc moving on a line against a convex shape.

The building block of the references in time (the forbidden regions of the (arc length, time)
plane and safe intervals): a disc of radius ``r`` whose centre moves as ``c + tau d`` overlaps a
convex shape ``K`` (a circle of radius ``R`` around the origin, or a convex polygon) exactly
for the ``tau`` with ``dist(c + tau d, K) < r``.  ``K`` inflated by ``r`` is convex, so this set
is one open interval, and it is computed in closed form:

* circle: ``|c + tau d|^2 < (R + r)^2``, a quadratic in ``tau``;
* convex polygon: ``K + D_r`` is the union of the discs of radius ``r`` around the vertices and
  the rectangles of half-width ``r`` along the edges (a line through the polygon's interior
  crosses an edge, hence meets that edge's rectangle), so the interval runs from the smallest
  to the largest parameter at which the line meets one of these pieces (a quadratic per vertex,
  a four-sided clip per edge).

No bisection, no sampling: the endpoints are the roots of the quadratics and the clip
parameters.  Touching (distance exactly ``r``) is not contact; a line that only touches gives an
empty (zero-length) interval.  :func:`shape_pieces` gives the convex pieces of a moving
obstacle's local shape (the one convex decomposition, :func:`optplan.geometry.convex_decompose`),
so a non-convex mover is the union of the intervals of its pieces.
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.collision import convex_decompose

__all__ = ["ConvexShape", "shape_pieces", "line_intervals"]


class ConvexShape:
    """A convex shape in a local frame: a circle of ``radius`` around the origin, or a convex
    polygon with counter-clockwise ``vertices`` ``(m, 2)``."""

    def __init__(self, radius: float | None = None, vertices: np.ndarray | None = None):
        if (radius is None) == (vertices is None):
            raise ValueError("a ConvexShape is a circle (radius) or a polygon (vertices)")
        self.radius = None if radius is None else float(radius)
        self.vertices = None if vertices is None else np.asarray(vertices, float)

    @property
    def is_circle(self) -> bool:
        """Whether the shape is a circle."""
        return self.radius is not None


def shape_pieces(kind: str, radius: float | None, local_geometry) -> list[ConvexShape]:
    """The convex pieces of a moving obstacle's local shape (``kind`` ``"circle"`` with its
    ``radius``, else the shapely polygon ``local_geometry``)."""
    if kind == "circle":
        if radius is None:
            raise ValueError("a moving circle needs a radius")
        return [ConvexShape(radius=float(radius))]
    return [ConvexShape(vertices=v) for v in convex_decompose(local_geometry)]


def _quadratic_below(a: np.ndarray, b: np.ndarray, c: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Roots of ``a t^2 + 2 b t + c = 0`` (``a > 0``) bounding where it is negative; NaN where
    it never is.  The stable form: ``q = -(b + sign(b) sqrt(disc))``, roots ``q / a``, ``c / q``.
    """
    disc = b * b - a * c
    ok = (disc > 0) & (a > 0)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    q = -(b + np.where(b >= 0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = q / np.where(ok, a, 1.0)
        r2 = np.where(q != 0, c / np.where(q != 0, q, 1.0), -r1)
    lo, hi = np.minimum(r1, r2), np.maximum(r1, r2)
    return np.where(ok, lo, np.nan), np.where(ok, hi, np.nan)


def _clip(alpha: np.ndarray, beta: np.ndarray, lo: np.ndarray, hi: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """Intersect ``[lo, hi]`` with ``{t : alpha + t beta <= 0}`` (elementwise)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -alpha / beta
    lo = np.where(beta < 0, np.maximum(lo, t), lo)
    hi = np.where(beta > 0, np.minimum(hi, t), hi)
    empty = (beta == 0) & (alpha > 0)
    return np.where(empty, np.inf, lo), np.where(empty, -np.inf, hi)


def _edge_frame(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edge lengths, unit tangents and outward normals of the convex polygon ``v`` (CCW,
    ``(m, 2)``; or ``(n, m, 2)``, one polygon per row)."""
    e = np.roll(v, -1, axis=-2) - v
    ln = np.hypot(e[..., 0], e[..., 1])
    tu = e / ln[..., None]
    nu = np.stack([tu[..., 1], -tu[..., 0]], axis=-1)  # outward normal of a CCW ring
    return ln, tu, nu


def _polygon(c: np.ndarray, d: np.ndarray, v: np.ndarray, r: float,
             frame: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
    """Parameter interval of the line ``c + t d`` within ``r`` of the convex polygon ``v``:
    ``(m, 2)`` for every line, or ``(n, m, 2)`` one per line (``frame``: its
    :func:`_edge_frame`, when the caller has it)."""
    ln, tu, nu = _edge_frame(v) if frame is None else frame
    s = "mk" if v.ndim == 2 else "nmk"
    rel = c[:, None, :] - v  # (n, m, 2)
    dd = np.einsum("nk,nk->n", d, d)[:, None]
    # vertex discs
    lo_v, hi_v = _quadratic_below(np.broadcast_to(dd, rel.shape[:2]),
                                  np.einsum("nmk,nk->nm", rel, d),
                                  np.einsum("nmk,nmk->nm", rel, rel) - r * r)
    # edge rectangles: 0 <= (x - v).tu <= ln and |(x - v).nu| <= r
    pa = np.einsum(f"nmk,{s}->nm", rel, tu)
    pb = np.einsum(f"nk,{s}->nm", d, tu)
    qa = np.einsum(f"nmk,{s}->nm", rel, nu)
    qb = np.einsum(f"nk,{s}->nm", d, nu)
    lo_e = np.full(pa.shape, -np.inf)
    hi_e = np.full(pa.shape, np.inf)
    for alpha, beta in ((-pa, -pb), (pa - ln, pb), (qa - r, qb), (-qa - r, -qb)):
        lo_e, hi_e = _clip(alpha, beta, lo_e, hi_e)
    lo_e = np.where(lo_e <= hi_e, lo_e, np.nan)
    hi_e = np.where(np.isnan(lo_e), np.nan, hi_e)
    lo = np.minimum(np.where(np.isnan(lo_v), np.inf, lo_v).min(axis=1),
                    np.where(np.isnan(lo_e), np.inf, lo_e).min(axis=1))
    hi = np.maximum(np.where(np.isnan(hi_v), -np.inf, hi_v).max(axis=1),
                    np.where(np.isnan(hi_e), -np.inf, hi_e).max(axis=1))
    empty = ~(lo < hi) if r > 0 else ~(lo <= hi)
    return np.where(empty, np.nan, lo), np.where(empty, np.nan, hi)


def line_intervals(c, d, shape: ConvexShape, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Where a disc of radius ``r`` centred on ``c + t d`` overlaps ``shape``: ``t`` in
    ``(lo, hi)``.

    Parameters
    ----------
    c, d : array_like ``(n, 2)``
        Points and directions of ``n`` lines, in the shape's local frame.
    shape : ConvexShape
    r : float
        Disc radius, ``>= 0``.

    Returns
    -------
    lo, hi : ndarray ``(n,)``
        The open interval of contact (distance ``< r``; for ``r = 0``, the closed chord through
        the polygon), NaN where there is none.  A line with ``d = 0`` is in contact for every
        ``t`` (``-inf, inf``) or never.
    """
    c = np.atleast_2d(np.asarray(c, float))
    d = np.broadcast_to(np.atleast_2d(np.asarray(d, float)), c.shape)
    if r < 0:
        raise ValueError(f"r = {r!r}: a disc radius is >= 0")
    still = np.einsum("nk,nk->n", d, d) == 0
    dm = np.where(still[:, None], np.array([1.0, 0.0]), d)  # a probe direction through c
    if shape.is_circle:
        rho = float(shape.radius or 0.0) + r
        lo, hi = _quadratic_below(np.einsum("nk,nk->n", dm, dm), np.einsum("nk,nk->n", c, dm),
                                  np.einsum("nk,nk->n", c, c) - rho * rho)
    else:
        assert shape.vertices is not None
        lo, hi = _polygon(c, dm, shape.vertices, r)
    inside = still & (lo < 0) & (hi > 0) if r > 0 else still & (lo <= 0) & (hi >= 0)
    lo = np.where(still, np.where(inside, -np.inf, np.nan), lo)
    hi = np.where(still, np.where(inside, np.inf, np.nan), hi)
    return lo, hi
