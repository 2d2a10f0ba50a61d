r"""Forbidden regions of the (arc length, time) plane, in closed form.

A disc robot of radius ``r`` follows a fixed polyline path; ``s`` is the arc length and ``t``
the time.  The robot at ``s`` at time ``t`` overlaps a moving obstacle exactly on a set of
``(s, t)`` points: the *forbidden region*.  It is cut into convex **regions**, one per

* path segment ``k`` (from ``A`` in the unit direction ``u``, of length ``l``; local arc length
  ``sigma = s - s_k`` in ``[0, l]``),
* linear piece of the obstacle's motion (:func:`~optplan.geometry.timing.motion.mover_pieces`: from
  ``B`` at time ``ta`` with velocity ``w``, for ``t' = t - ta`` in ``[0, T]``),
* convex piece ``K`` of the obstacle's shape,

namely :math:`R = \{(\sigma, t') \in [0, l] \times [0, T] : x(\sigma, t') \in K \oplus D_r\}`
with the relative position :math:`x = (A - B) + \sigma u - t' w`.  ``x`` is affine in
``(sigma, t')`` and ``K + D_r`` is convex, so ``R`` is convex.

Everything the references in time need is computed in closed form:

* the **section** at a given ``s`` (the times of contact there): the disc on the line
  ``t' -> x(sigma, t')`` against ``K``
  (:func:`~optplan.geometry.timing.contact_times.line_intervals`, roots of quadratics), clipped to
  ``[0, T]``;
* the **extremes of a linear function** ``g . (sigma, t')`` over ``R`` intersected with a
  sub-box (:func:`region_extremes`): a linear function on a convex set peaks at a corner of the
  box inside ``K + D_r``, where an edge of the box crosses the boundary of ``K + D_r`` (again
  :func:`line_intervals`), or at the support point of ``K + D_r`` in the direction
  ``M^{-T} g`` (a vertex of ``K`` plus ``r`` along that direction; ``M = [u, -w]``) when
  ``M`` is invertible.  With ``g = (1, 0)`` this is the region's extent in ``s``; with the
  delay ``tau = t - s / v`` (``g = (-1/v, 1)``) it is the set of departure times at which a
  robot crossing the segment at full speed ``v`` meets the obstacle.

Contact is strict (touching is allowed), so the regions are open and every extreme here is a
supremum or infimum over the closure.  Coordinates are taken relative to each region's own
points, so round-off scales with the map, not with where it sits.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from optplan.geometry.timing.contact_times import ConvexShape, line_intervals, shape_pieces
from optplan.geometry.timing.intervals import merge_open
from optplan.geometry.timing.motion import mover_pieces

if TYPE_CHECKING:
    from optplan.problem import DynamicObstacle

__all__ = ["Regions", "MoverTable", "mover_table", "path_regions", "region_extremes", "sections",
           "forbidden_departures"]


@dataclass(frozen=True)
class Regions:
    """Convex forbidden regions of a path (module docstring); arrays of length ``n``.

    Attributes
    ----------
    seg : ndarray of int
        Path segment of each region.
    s0, ell : ndarray
        Arc length at the segment's start and the segment's length.
    c0, u : ndarray ``(n, 2)``
        ``A - B`` (robot's segment start minus the obstacle's piece start) and ``u``.
    ta, T, w : ndarray
        Start time and duration of the obstacle's piece (``T`` clipped to the horizon), its
        velocity ``(n, 2)``.
    shape : ndarray of int
        Index into ``shapes``.
    mover : ndarray of int
        Index of the moving obstacle.
    shapes : list of ConvexShape
    radius : float
        The robot's radius.
    """

    seg: np.ndarray
    s0: np.ndarray
    ell: np.ndarray
    c0: np.ndarray
    u: np.ndarray
    ta: np.ndarray
    T: np.ndarray
    w: np.ndarray
    shape: np.ndarray
    mover: np.ndarray
    shapes: list[ConvexShape]
    radius: float

    def __len__(self) -> int:
        return len(self.seg)

    def take(self, idx: np.ndarray) -> Regions:
        """The regions ``idx`` (same shapes)."""
        return Regions(self.seg[idx], self.s0[idx], self.ell[idx], self.c0[idx], self.u[idx],
                       self.ta[idx], self.T[idx], self.w[idx], self.shape[idx],
                       self.mover[idx], self.shapes, self.radius)


#: The motion of one moving obstacle on a time window as :func:`path_regions` uses it: the
#: start times, end times (cut at the window's end), start points and velocities of its linear
#: pieces, and its convex shape pieces.
MoverTable = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[ConvexShape]]


def mover_table(dyn: DynamicObstacle, horizon: float) -> MoverTable:
    """The linear pieces of ``dyn`` on ``[0, horizon]`` that start before ``horizon`` (their
    ends cut at ``horizon``) and its convex shape pieces: what :func:`path_regions` computes
    per obstacle (a caller with many paths and one window computes it once)."""
    ta, tb, b, w = mover_pieces(dyn, 0.0, float(horizon))
    live = ta < horizon
    return (ta[live], np.minimum(tb[live], horizon), b[live], w[live],
            shape_pieces(dyn.kind, dyn.radius, dyn.local_geometry))


def path_regions(movers: list[DynamicObstacle], path: np.ndarray, radius: float,
                 horizon: float, tables: list[MoverTable] | None = None) -> Regions:
    """The convex forbidden regions of the polyline ``path`` against ``movers`` on the time
    window ``[0, horizon]`` (pieces ending after ``horizon`` are cut there; the ones starting
    after it are left out).  Zero-length segments are skipped.  ``tables``: the movers'
    :func:`mover_table` on this window, when the caller has them."""
    p = np.asarray(path, float)
    d = np.diff(p, axis=0)
    ell = np.hypot(d[:, 0], d[:, 1])
    s0 = np.concatenate([[0.0], np.cumsum(ell)])[:-1]
    keep = np.flatnonzero(ell > 0)
    u = d[keep] / ell[keep, None]
    cols: dict[str, list[np.ndarray]] = {k: [] for k in (
        "seg", "s0", "ell", "c0", "u", "ta", "T", "w", "shape", "mover")}
    shapes: list[ConvexShape] = []
    for j, dyn in enumerate(movers):
        ta, tb, b, w, pieces = (mover_table(dyn, horizon) if tables is None else tables[j])
        for shp in pieces:
            q = len(shapes)
            shapes.append(shp)
            kk, pp = _near_pairs(p[keep], p[keep + 1], b, b + (tb - ta)[:, None] * w,
                                 _reach(shp) + float(radius))
            cols["seg"].append(keep[kk])
            cols["s0"].append(s0[keep][kk])
            cols["ell"].append(ell[keep][kk])
            cols["c0"].append(p[keep][kk] - b[pp])
            cols["u"].append(u[kk])
            cols["ta"].append(ta[pp])
            cols["T"].append(np.maximum(tb[pp] - ta[pp], 0.0))
            cols["w"].append(w[pp])
            cols["shape"].append(np.full(len(kk), q))
            cols["mover"].append(np.full(len(kk), j))
    if not shapes:
        z = np.zeros(0)
        return Regions(z.astype(int), z, z, z.reshape(0, 2), z.reshape(0, 2), z, z,
                       z.reshape(0, 2), z.astype(int), z.astype(int), [], float(radius))
    cat = {k: np.concatenate(v) for k, v in cols.items()}
    return Regions(cat["seg"], cat["s0"], cat["ell"], cat["c0"], cat["u"], cat["ta"],
                   cat["T"], cat["w"], cat["shape"], cat["mover"], shapes, float(radius))


def _reach(shp: ConvexShape) -> float:
    """The largest distance of the shape from its reference point."""
    if shp.is_circle:
        return float(shp.radius or 0.0)
    return float(np.max(np.hypot(*np.asarray(shp.vertices).T)))


def _near_pairs(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray, reach: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """The (segment, piece) index pairs whose bounding boxes come within ``reach``: the path
    segments ``a0 -> a1`` and the swept reference points ``b0 -> b1`` (every other pair is
    farther apart than the robot's and the shape's extent: no region)."""
    lo_a, hi_a = np.minimum(a0, a1), np.maximum(a0, a1)
    lo_b, hi_b = np.minimum(b0, b1), np.maximum(b0, b1)
    near = np.all((lo_a[:, None, :] <= hi_b[None, :, :] + reach)
                  & (lo_b[None, :, :] <= hi_a[:, None, :] + reach), axis=2)
    kk, pp = np.nonzero(near)
    return kk, pp


def _by_shape(reg: Regions):
    """``(shape, indices)`` for every shape used by ``reg``."""
    for q in np.unique(reg.shape):
        yield reg.shapes[int(q)], np.flatnonzero(reg.shape == q)


def sections(reg: Regions, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The times of contact ``t'`` (relative to each piece's start) at local arc length
    ``sigma`` (one per region): the open interval ``(lo, hi)`` within ``[0, T]``, NaN where
    there is none (a stationary piece gives ``[0, T]`` or nothing)."""
    sigma = np.asarray(sigma, float)
    lo = np.full(len(reg), np.nan)
    hi = np.full(len(reg), np.nan)
    for shp, i in _by_shape(reg):
        a, b = line_intervals(reg.c0[i] + sigma[i, None] * reg.u[i], -reg.w[i], shp, reg.radius)
        lo[i], hi[i] = a, b
    lo, hi = np.maximum(lo, 0.0), np.minimum(hi, reg.T)
    empty = ~(lo < hi)
    return np.where(empty, np.nan, lo), np.where(empty, np.nan, hi)


def _support(shp: ConvexShape, d: np.ndarray, r: float) -> np.ndarray:
    """The point of ``shp`` inflated by ``r`` farthest in each direction ``d`` ``(n, 2)``."""
    n = np.hypot(d[:, 0], d[:, 1])
    unit = d / np.where(n > 0, n, 1.0)[:, None]
    if shp.is_circle:
        return (float(shp.radius or 0.0) + r) * unit
    v = np.asarray(shp.vertices)
    return v[np.argmax(d @ v.T, axis=1)] + r * unit


def _inside(shp: ConvexShape, x: np.ndarray, r: float) -> np.ndarray:
    """Whether each point ``x`` is within ``r`` of ``shp`` (closed: touching counts)."""
    if shp.is_circle:
        return np.hypot(x[:, 0], x[:, 1]) <= float(shp.radius or 0.0) + r
    lo, hi = line_intervals(x, np.array([[1.0, 0.0]]), shp, r)
    return (lo <= 0) & (hi >= 0)


def region_extremes(reg: Regions, g: np.ndarray, sig_lo: np.ndarray, sig_hi: np.ndarray,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The largest value of ``g . (sigma, t')`` over each region within
    ``sigma in [sig_lo, sig_hi]`` (a sub-box of the region's box; module docstring).

    Parameters
    ----------
    reg : Regions
    g : ndarray ``(2,)`` or ``(n, 2)``
        The linear function's coefficients (per region or shared).
    sig_lo, sig_hi : ndarray ``(n,)``
        The sub-box's extent in ``sigma`` (``0 <= sig_lo <= sig_hi <= ell``).

    Returns
    -------
    value, sigma, tp : ndarray ``(n,)``
        The supremum over the closure of the region in the sub-box and a point attaining it;
        ``-inf`` (NaN point) where the region does not meet the sub-box.
    """
    n = len(reg)
    g = np.broadcast_to(np.asarray(g, float), (n, 2))
    best = np.full(n, -np.inf)
    arg = np.full((n, 2), np.nan)
    corners = [(sig_lo, 0.0), (sig_hi, 0.0), (sig_hi, reg.T), (sig_lo, reg.T)]

    def offer(i: np.ndarray, sg: np.ndarray, tp: np.ndarray, ok: np.ndarray) -> None:
        val = np.where(ok, g[i, 0] * sg + g[i, 1] * tp, -np.inf)
        better = val > best[i]
        best[i] = np.where(better, val, best[i])
        arg[i] = np.where(better[:, None], np.stack([sg, tp], axis=1), arg[i])

    for shp, i in _by_shape(reg):
        c0, u, w = reg.c0[i], reg.u[i], reg.w[i]
        pts = [(np.broadcast_to(np.asarray(a, float), (n,))[i],
                np.broadcast_to(np.asarray(b, float), (n,))[i]) for a, b in corners]
        xs = [c0 + sg[:, None] * u - tp[:, None] * w for sg, tp in pts]
        for (sg, tp), x in zip(pts, xs):  # the box's corners
            offer(i, sg, tp, _inside(shp, x, reg.radius))
        for e in range(4):  # where the box's edges cross the boundary of K + D_r
            (sa, ta), (sb, tb) = pts[e], pts[(e + 1) % 4]
            lo, hi = line_intervals(xs[e], xs[(e + 1) % 4] - xs[e], shp, reg.radius)
            for lam in (lo, hi):
                ok = np.isfinite(lam) & (lam >= 0) & (lam <= 1)
                lam = np.where(ok, lam, 0.0)
                offer(i, sa + lam * (sb - sa), ta + lam * (tb - ta), ok)
        det = -u[:, 0] * w[:, 1] + u[:, 1] * w[:, 0]  # det [u, -w]
        inv = np.abs(det) > 1e-12 * np.hypot(*u.T) * np.maximum(np.hypot(*w.T), 1e-300)
        if inv.any():  # the support point of K + D_r, when it lies in the box
            dt = np.where(inv, det, 1.0)
            # M^{-1} = [[-w_y, w_x], [-u_y, u_x]] / det
            d = np.stack([(-w[:, 1] * g[i, 0] - u[:, 1] * g[i, 1]) / dt,
                          (w[:, 0] * g[i, 0] + u[:, 0] * g[i, 1]) / dt], axis=1)
            x = _support(shp, np.where(inv[:, None], d, 1.0), reg.radius) - c0
            sg = (-w[:, 1] * x[:, 0] + w[:, 0] * x[:, 1]) / dt
            tp = (-u[:, 1] * x[:, 0] + u[:, 0] * x[:, 1]) / dt
            ok = inv & (sg >= pts[0][0]) & (sg <= pts[1][0]) & (tp >= 0) & (tp <= reg.T[i])
            offer(i, sg, tp, ok)
    return best, arg[:, 0], arg[:, 1]


def forbidden_departures(movers: list[DynamicObstacle], a, b, radius: float, speed: float,
                         horizon: float) -> list[tuple[float, float]]:
    """The departure times at which a disc of ``radius`` crossing the segment ``a -> b`` at
    ``speed`` overlaps a moving obstacle: sorted disjoint open intervals (touching ones
    merged), for the motions known on ``[0, horizon]``.

    A departure at ``t0`` puts the robot at ``sigma`` at time ``t0 + sigma / speed``, so the
    forbidden departures of a region are ``ta + t' - sigma / speed`` over it: between the
    minimum and the maximum of a linear function (:func:`region_extremes`).  Exact in closed
    form; a departure whose crossing ends after ``horizon`` is judged on the known motion only.
    """
    path = np.array([a, b], float)
    reg = path_regions(movers, path, radius, horizon)
    if len(reg) == 0:
        return []
    g = np.array([-1.0 / speed, 1.0])
    zero, full = np.zeros(len(reg)), reg.ell
    hi, _, _ = region_extremes(reg, g, zero, full)
    lo, _, _ = region_extremes(reg, -g, zero, full)
    ok = np.isfinite(hi) & (hi > -lo)
    return merge_open(reg.ta[ok] - lo[ok], reg.ta[ok] + hi[ok])
