r"""The closed forms of :mod:`.st_regions` over regions of many shapes in one pass.

:func:`~optplan.geometry.timing.st_regions.region_extremes` and
:func:`~optplan.geometry.timing.st_regions.sections` loop over the convex shapes of the moving
obstacles and, inside, over the corners and edges of the region's box, with a handful of small
array operations each; with a few hundred regions spread over a dozen shapes the time goes
into that loop, not into the arithmetic.  Here the same formulas run once over all regions:

* the circles together, each region with its own inflated radius ``R + r``;
* the polygons together per vertex count, each region with its own vertices and edge frames
  (:func:`~optplan.geometry.timing.contact_times.line_intervals`'s polygon case, a polygon
  per row);
* the four corners, and the four edges, of the box in one call each;
* the two signs of the linear function together (:func:`region_ranges`: the corners and the
  edges' crossings do not depend on it, only the support point does).

Every value is the same elementwise expression, in the same order of operations, as in
:mod:`.st_regions` and :mod:`.contact_times` (the support point of a polygon is still taken
per shape, on the same rows), and the candidates are offered to the running maximum in the
same order (the first of equal values is kept), so the results are the same to the last bit;
``tests/geometry/test_st_batch.py`` compares them on random regions of circles and polygons.
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.timing.contact_times import _edge_frame, _polygon, _quadratic_below
from optplan.geometry.timing.st_regions import Regions, _support

__all__ = ["ShapeRows", "region_ranges", "batch_sections"]


class ShapeRows:
    """Per-row shape data of a set of regions: the rows that are circles (and their
    ``R + r``), and per vertex count the polygon rows with their vertices and edge frames."""

    circ_idx: np.ndarray
    rho: np.ndarray
    poly: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]

    @classmethod
    def of(cls, reg: Regions) -> ShapeRows:
        """The shape data of the regions ``reg`` (one row per region)."""
        out = cls()
        q = reg.shape
        used = np.unique(q).tolist()
        circ = [k for k in used if reg.shapes[k].is_circle]
        out.circ_idx = np.flatnonzero(np.isin(q, circ))
        rho = np.zeros(len(reg.shapes))
        rho[circ] = [float(reg.shapes[k].radius or 0.0) + reg.radius for k in circ]
        out.rho = rho[q[out.circ_idx]]
        by_m: dict[int, list[int]] = {}
        for k in used:
            if not reg.shapes[k].is_circle:
                by_m.setdefault(len(reg.shapes[k].vertices), []).append(k)
        out.poly = []
        for _, ks in sorted(by_m.items()):
            idx = np.flatnonzero(np.isin(q, ks))
            pos = np.zeros(len(reg.shapes), int)
            pos[ks] = np.arange(len(ks))
            verts = [np.asarray(reg.shapes[k].vertices) for k in ks]
            frames = [(v, *_edge_frame(v)) for v in verts]
            at = pos[q[idx]]
            v, ln, tu, nu = (np.stack([f[j] for f in frames])[at] for j in range(4))
            out.poly.append((idx, v, ln, tu, nu))
        return out

    def rows(self, n: int, n_rep: int, circles: bool = True) -> ShapeRows:
        """The same data for ``n_rep`` stacked copies of the ``n`` rows (row ``k n + i`` is
        row ``i``); without the circles when ``circles`` is false."""
        out = ShapeRows()
        out.circ_idx = (np.concatenate([self.circ_idx + k * n for k in range(n_rep)])
                        if circles else np.zeros(0, int))
        out.rho = np.tile(self.rho, n_rep) if circles else np.zeros(0)
        out.poly = [(np.concatenate([idx + k * n for k in range(n_rep)]),
                     np.concatenate([v] * n_rep), np.concatenate([ln] * n_rep),
                     np.concatenate([tu] * n_rep), np.concatenate([nu] * n_rep))
                    for idx, v, ln, tu, nu in self.poly]
        return out


def _line_intervals(c: np.ndarray, d: np.ndarray, sh: ShapeRows, r: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~optplan.geometry.timing.contact_times.line_intervals` with the shape of each
    row from ``sh`` (``c`` ``(n, 2)``, ``d`` ``(n, 2)`` or ``(1, 2)``)."""
    d = np.broadcast_to(d, c.shape)
    still = np.einsum("nk,nk->n", d, d) == 0
    dm = np.where(still[:, None], np.array([1.0, 0.0]), d)
    lo = np.full(len(c), np.nan)
    hi = np.full(len(c), np.nan)
    i = sh.circ_idx
    if len(i):
        ci, di = c[i], dm[i]
        lo[i], hi[i] = _quadratic_below(np.einsum("nk,nk->n", di, di),
                                        np.einsum("nk,nk->n", ci, di),
                                        np.einsum("nk,nk->n", ci, ci) - sh.rho * sh.rho)
    for i, v, ln, tu, nu in sh.poly:
        lo[i], hi[i] = _polygon(c[i], dm[i], v, r, (ln, tu, nu))
    inside = still & (lo < 0) & (hi > 0) if r > 0 else still & (lo <= 0) & (hi >= 0)
    lo = np.where(still, np.where(inside, -np.inf, np.nan), lo)
    hi = np.where(still, np.where(inside, np.inf, np.nan), hi)
    return lo, hi


def batch_sections(reg: Regions, sigma: np.ndarray, sh: ShapeRows | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~optplan.geometry.timing.st_regions.sections` (the same values) in one pass
    over all shapes (``sh``: ``ShapeRows.of(reg)``, when the caller has it)."""
    sigma = np.asarray(sigma, float)
    if len(reg) == 0:
        return np.zeros(0), np.zeros(0)
    sh = ShapeRows.of(reg) if sh is None else sh
    lo, hi = _line_intervals(reg.c0 + sigma[:, None] * reg.u, -reg.w, sh, reg.radius)
    lo, hi = np.maximum(lo, 0.0), np.minimum(hi, reg.T)
    empty = ~(lo < hi)
    return np.where(empty, np.nan, lo), np.where(empty, np.nan, hi)


def region_ranges(reg: Regions, g: np.ndarray, sig_lo: np.ndarray, sig_hi: np.ndarray,
                  sh: ShapeRows | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The largest values of ``g . (sigma, t')`` and of ``-g . (sigma, t')`` over each region
    within ``sigma in [sig_lo, sig_hi]``: ``region_extremes(reg, g, ...)[0]`` and
    ``region_extremes(reg, -g, ...)[0]`` (the same values), in one pass.

    Parameters
    ----------
    reg : Regions
    g : ndarray ``(2,)``
        The linear function's coefficients (shared by all regions).
    sig_lo, sig_hi : ndarray ``(n,)``
        The sub-box's extent in ``sigma`` (``0 <= sig_lo <= sig_hi <= ell``).
    sh : ShapeRows, optional
        ``ShapeRows.of(reg)``, when the caller has it.

    Returns
    -------
    top, bottom : ndarray ``(n,)``
        The suprema of ``g .`` and of ``-g .`` over the closure of each region in the sub-box,
        ``-inf`` where the region does not meet it.
    """
    n = len(reg)
    gp = np.broadcast_to(np.asarray(g, float), (n, 2))
    gm = np.broadcast_to(-np.asarray(g, float), (n, 2))
    top = np.full(n, -np.inf)
    bot = np.full(n, -np.inf)
    if n == 0:
        return top, bot
    r = reg.radius
    sh = ShapeRows.of(reg) if sh is None else sh
    zero = np.zeros(n)
    c0, u, w, T = reg.c0, reg.u, reg.w, reg.T
    pts = [(np.asarray(sig_lo, float), zero), (np.asarray(sig_hi, float), zero),
           (np.asarray(sig_hi, float), T), (np.asarray(sig_lo, float), T)]
    xs = [c0 + sg[:, None] * u - tp[:, None] * w for sg, tp in pts]

    def offer(sg: np.ndarray, tp: np.ndarray, ok: np.ndarray, both: bool = True) -> None:
        nonlocal top, bot
        val = np.where(ok, gp[:, 0] * sg + gp[:, 1] * tp, -np.inf)
        top = np.where(val > top, val, top)
        if both:
            val = np.where(ok, gm[:, 0] * sg + gm[:, 1] * tp, -np.inf)
            bot = np.where(val > bot, val, bot)

    inside = _inside_all(np.concatenate(xs), sh.rows(n, 4), sh.rows(n, 4, False), r
                         ).reshape(4, n)
    for (sg, tp), ok in zip(pts, inside):  # the box's corners
        offer(sg, tp, ok)
    a = np.concatenate(xs)
    b = np.concatenate(xs[1:] + xs[:1])
    lo4, hi4 = _line_intervals(a, b - a, sh.rows(n, 4), r)
    for e in range(4):  # where the box's edges cross the boundary of K + D_r
        (sa, ta), (sb, tb) = pts[e], pts[(e + 1) % 4]
        for lam in (lo4[e * n:(e + 1) * n], hi4[e * n:(e + 1) * n]):
            ok = np.isfinite(lam) & (lam >= 0) & (lam <= 1)
            lam = np.where(ok, lam, 0.0)
            offer(sa + lam * (sb - sa), ta + lam * (tb - ta), ok)
    det = -u[:, 0] * w[:, 1] + u[:, 1] * w[:, 0]  # det [u, -w]
    inv = np.abs(det) > 1e-12 * np.hypot(*u.T) * np.maximum(np.hypot(*w.T), 1e-300)
    if inv.any():  # the support point of K + D_r, when it lies in the box
        dt = np.where(inv, det, 1.0)
        for gg, up in ((gp, True), (gm, False)):
            d = np.stack([(-w[:, 1] * gg[:, 0] - u[:, 1] * gg[:, 1]) / dt,
                          (w[:, 0] * gg[:, 0] + u[:, 0] * gg[:, 1]) / dt], axis=1)
            x = _supports(reg, sh, np.where(inv[:, None], d, 1.0)) - c0
            sg = (-w[:, 1] * x[:, 0] + w[:, 0] * x[:, 1]) / dt
            tp = (-u[:, 1] * x[:, 0] + u[:, 0] * x[:, 1]) / dt
            ok = inv & (sg >= pts[0][0]) & (sg <= pts[1][0]) & (tp >= 0) & (tp <= T)
            val = np.where(ok, gg[:, 0] * sg + gg[:, 1] * tp, -np.inf)
            if up:
                top = np.where(val > top, val, top)
            else:
                bot = np.where(val > bot, val, bot)
    return top, bot


def _inside_all(x: np.ndarray, sh: ShapeRows, polys: ShapeRows, r: float) -> np.ndarray:
    """:func:`~optplan.geometry.timing.st_regions._inside` of the points ``x`` (one per row of
    ``sh``; ``polys`` the same rows without the circles)."""
    out = np.zeros(len(x), bool)
    i = sh.circ_idx
    if len(i):
        out[i] = np.hypot(x[i, 0], x[i, 1]) <= sh.rho
    if polys.poly:
        lo, hi = _line_intervals(x, np.array([[1.0, 0.0]]), polys, r)
        p = np.concatenate([idx for idx, *_ in polys.poly])
        out[p] = (lo[p] <= 0) & (hi[p] >= 0)
    return out


def _supports(reg: Regions, sh: ShapeRows, d: np.ndarray) -> np.ndarray:
    """:func:`~optplan.geometry.timing.st_regions._support` of every region's shape in the
    directions ``d`` ``(n, 2)``: the circles together, a polygon per shape (on the rows of
    that shape, in their order, as ``region_extremes`` takes it)."""
    r = reg.radius
    nrm = np.hypot(d[:, 0], d[:, 1])
    unit = d / np.where(nrm > 0, nrm, 1.0)[:, None]
    out = np.empty_like(d)
    i = sh.circ_idx
    out[i] = sh.rho[:, None] * unit[i]
    for q in np.unique(np.delete(reg.shape, sh.circ_idx)):
        rows = np.flatnonzero(reg.shape == q)
        out[rows] = _support(reg.shapes[int(q)], d[rows], r)
    return out
