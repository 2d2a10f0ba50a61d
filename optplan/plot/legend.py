"""Legend placement: outside the axes, or in the emptiest corner of the data."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from matplotlib.axes import Axes

from optplan.plot.figure import _renderer
from optplan.plot.style import LEGEND_PLACES

_Corner = Literal["upper right", "upper left", "lower left", "lower right"]
_CORNERS: tuple[_Corner, ...] = ("upper right", "upper left", "lower left", "lower right")


def _data_samples(ax: Axes, renderer: Any) -> tuple[np.ndarray, np.ndarray]:
    """Display coordinates of what is drawn in ``ax`` and a weight per sample.

    Lines are sampled every few pixels along their segments (markers at their points), with
    weight 1 (0.25 for the inflated outlines of obstacles); annotations by the corners and
    centre of their box (weight 1); filled patches (obstacles) by the points of a 48 x 48 grid
    over the axes that they contain (weight 0.25); unfilled patches by their outline (weight
    0.5).  The map's frame is not data.
    """
    pts, wts = [], []
    for ln in ax.lines:
        if not ln.get_visible():
            continue
        xy = np.asarray(ln.get_xydata(), dtype=float).reshape(-1, 2)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if not len(xy):
            continue
        d = ln.get_transform().transform(xy)
        if ln.get_linestyle() not in ("None", "none", " ", "") and len(d) > 1:
            seg = np.diff(d, axis=0)
            n = np.maximum(1, np.ceil(np.hypot(*seg.T) / 3.0)).astype(int)
            u = [np.arange(k) / k for k in n]
            d = np.concatenate([d[:-1].repeat(n, axis=0)
                                + np.concatenate(u)[:, None] * seg.repeat(n, axis=0), d[-1:]])
        pts.append(d)
        wts.append(np.full(len(d), 0.25 if ln.get_gid() == "outline" else 1.0))
    for t in ax.texts:
        if t.get_visible() and t.get_text():
            b = t.get_window_extent(renderer)
            pts.append(np.array([[b.x0, b.y0], [b.x1, b.y0], [b.x0, b.y1], [b.x1, b.y1],
                                 [(b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2]]))
            wts.append(np.ones(5))
    box = ax.get_window_extent(renderer)
    gx, gy = np.meshgrid(np.linspace(box.x0, box.x1, 48), np.linspace(box.y0, box.y1, 48))
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    covered = np.zeros(len(grid), bool)
    for patch in ax.patches:
        if not patch.get_visible() or patch.get_gid() == "bounds":
            continue
        if patch.get_fill():
            path = patch.get_transform().transform_path(patch.get_path())
            covered |= path.contains_points(grid)
        else:
            path = patch.get_transform().transform_path(patch.get_path().interpolated(8))
            v = np.asarray(path.vertices)  # an ndarray already (typed ArrayLike)
            pts.append(v)
            wts.append(np.full(len(v), 0.5))
    pts.append(grid[covered])
    wts.append(np.full(int(covered.sum()), 0.25))
    return np.concatenate(pts), np.concatenate(wts)


def _corner_legend(ax: Axes, fontsize: float) -> Any:
    """A legend in the corner of ``ax`` covering the least drawn data (:func:`_data_samples`).

    Ties go to the first of upper right, upper left, lower left, lower right.
    """
    renderer = _renderer(ax.figure.figure)  # the root Figure (the same canvas)
    ax.apply_aspect()  # the box the axes will be drawn in (equal aspect)
    pts, wts = _data_samples(ax, renderer)

    def covered(loc: _Corner) -> float:
        """The weight of the data samples under the legend drawn at ``loc``."""
        b = ax.legend(loc=loc, fontsize=fontsize, framealpha=0.9).get_window_extent(renderer)
        inside = ((pts[:, 0] >= b.x0) & (pts[:, 0] <= b.x1) & (pts[:, 1] >= b.y0)
                  & (pts[:, 1] <= b.y1))
        return float(wts[inside].sum())

    # min keeps the first of equal scores (the corners in order, each drawn once)
    return ax.legend(loc=min(_CORNERS, key=covered), fontsize=fontsize, framealpha=0.9)


def _place_legend(ax: Axes, where: str | None, own_figure: bool, fontsize: float = 8) -> Any:
    """Put the legend of ``ax`` where it covers no data; returns it (None without entries).

    ``where``: ``"outside"`` (right of the axes, top-aligned), ``"corner"`` (the corner with
    the least drawn data), ``"auto"`` (outside when this module made the figure or the figure
    uses the constrained layout, which makes room for it; the corner otherwise, since an
    outside legend would run into neighbouring axes), ``None`` (no legend).
    """
    if where is not None and where not in LEGEND_PLACES:
        raise ValueError(f"legend must be one of {LEGEND_PLACES} or None, got {where!r}")
    old = ax.get_legend()
    if old is not None:
        old.remove()
    if where is None or not ax.get_legend_handles_labels()[0]:
        return None
    if where == "auto":
        eng = ax.figure.get_layout_engine()
        constrained = type(eng).__name__ == "ConstrainedLayoutEngine"
        where = "outside" if own_figure or constrained else "corner"
    if where == "corner":
        return _corner_legend(ax, fontsize)
    return ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                     fontsize=fontsize, framealpha=0.9)
