"""Headless figures (Agg canvas, never pyplot) and saving them."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optplan.plot.style import FORMATS


def new_figure(size: tuple[float, float] = (6.0, 6.0), dpi: int = 100,
               layout: Literal["constrained", "compressed", "tight"] | None = None) -> Figure:
    """A figure on the Agg canvas (headless, no pyplot state).

    ``layout="constrained"`` makes room for legends placed outside the axes (the default
    placement of :func:`plot_problem` and :func:`plot_result` in such a figure).
    """
    fig = Figure(figsize=size, dpi=dpi, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def _get_ax(ax: Axes | None, size: tuple[float, float] = (7.6, 6.0)) -> tuple[Figure, Axes]:
    if ax is not None:
        # the root Figure (ax.figure itself, or the Figure holding the SubFigure of ax: a
        # SubFigure has no savefig)
        return ax.figure.figure, ax
    fig = new_figure(size, layout="constrained")
    return fig, fig.add_subplot(1, 1, 1)


def _save(fig: Figure, out: str | Path | None, dpi: float | None = None) -> None:
    """Write ``fig`` to ``out`` (PNG, SVG or PDF by its suffix) at ``dpi`` (raster)."""
    if out is None:
        return
    p = Path(out)
    fmt = FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise ValueError(f"{p}: unsupported figure format {p.suffix!r}; use one of "
                         + ", ".join(FORMATS))
    if dpi is not None and not dpi > 0:
        raise ValueError(f"dpi must be > 0, got {dpi}")
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, format=fmt, dpi=dpi or fig.dpi, bbox_inches="tight")


def _renderer(fig: Figure) -> Any:
    canvas = fig.canvas
    if hasattr(canvas, "get_renderer"):
        return canvas.get_renderer()
    # a bare Figure (animate): a throw-away Agg renderer (private, not in matplotlib's stubs)
    return fig._get_renderer()  # type: ignore[attr-defined]
