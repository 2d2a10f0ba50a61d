"""Convergence plots: best cost (or length) against iterations, median and quartiles."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from optplan.plot.figure import _save, new_figure
from optplan.plot.legend import _place_legend
from optplan.plot.style import LENGTH_COLUMNS, ROBOT_COLOURS
from optplan.result import Result


def _curves(results: Sequence[Result], column: str) -> tuple[np.ndarray, np.ndarray] | None:
    """Stack ``column`` of every result's history on a common iteration axis.

    Shorter runs are padded with their last value (best-so-far curves are flat after a run
    stops).  Returns ``(iterations, values (n_runs, n_iter))`` or None when no run has it.
    """
    rows = []
    its = None
    for r in results:
        h = r.history
        if column not in h or len(h) == 0:
            continue
        v = np.asarray(h[column], dtype=float)
        rows.append(v)
        if "iteration" in h:
            it = np.asarray(h["iteration"], dtype=float)
            if its is None or len(it) > len(its):
                its = it
    if not rows:
        return None
    n = max(len(v) for v in rows)
    out = np.full((len(rows), n), np.nan)
    for i, v in enumerate(rows):
        out[i, : len(v)] = v
        if len(v) < n:
            out[i, len(v):] = v[-1]
    if its is None or len(its) != n or np.any(~np.isfinite(its)):
        its = np.arange(n, dtype=float)
    return its, out


def _quartiles(vals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Column-wise 25/50/75 % quantiles; ``nan`` ignored, ``+inf`` allowed.

    numpy's interpolation turns ``inf`` into ``nan`` (``inf * 0``), so ``+inf`` is replaced by
    a huge sentinel and any quantile above the column's largest finite value (it involved the
    sentinel, i.e. it is infinite) is returned as ``nan`` (not drawn).
    """
    big = 1e300
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=RuntimeWarning)
        fin = np.where(np.isfinite(vals), vals, -np.inf).max(axis=0)
        v = np.where(np.isposinf(vals), big, np.where(np.isneginf(vals), np.nan, vals))
        q = np.nanpercentile(v, [25, 50, 75], axis=0)
    q = np.where((q > fin[None, :]) | ~np.isfinite(q), np.nan, q)
    return q[0], q[1], q[2]


def plot_convergence(results: Result | Sequence[Result] | Mapping[str, Sequence[Result]],
                     out: str | Path | None = None, *, log: bool = False,
                     dpi: float | None = None) -> Figure:
    """Convergence curves from ``result.history``: median and inter-quartile band.

    Parameters
    ----------
    results : Result, list of Result or dict name -> list of Result
        One curve per group (e.g. per solver over seeds).
    out : path, optional
        Write the figure: PNG, SVG or PDF, from the suffix.
    log : bool
        Logarithmic y axis.
    dpi : float, optional
        Resolution of a PNG (default: the figure's, 100).

    Draws ``best_cost`` against ``iteration`` and, when some history has a ``best_length``
    (or ``feasible_best_length``) column, the length of the best *feasible* path so far, a
    second panel with it.  There, a run without a feasible path yet (``nan``) counts as
    ``+inf``: the median curve starts once half of the runs are feasible and is monotone.
    Elsewhere ``nan`` entries are ignored.  Quantiles use numpy's linear interpolation.  Each
    panel's legend is outside it, on its right.

    Returns
    -------
    matplotlib.figure.Figure
    """
    groups = _groups(results)
    cols = _columns(groups)
    fig = new_figure((7.2 * len(cols), 4.2), layout="constrained")
    axes = [fig.add_subplot(1, len(cols), i + 1) for i in range(len(cols))]
    titles = {"best_cost": "best cost", **{c: "best feasible length" for c in LENGTH_COLUMNS}}
    for ax, col in zip(axes, cols):
        for gi, (name, rs) in enumerate(groups.items()):
            _draw_group(ax, rs, col, name, ROBOT_COLOURS[gi % len(ROBOT_COLOURS)])
        if ax.lines and not any(np.isfinite(ln.get_ydata()).any() for ln in ax.lines):
            _say_no_median(ax, col)
        ax.set_xlabel("iteration")
        ax.set_ylabel(titles[col])
        ax.set_title(titles[col] + (" (median, IQR band)" if any(
            len(v) > 1 for v in groups.values()) else ""), fontsize=10)
        if log:
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
        _place_legend(ax, "outside", True)
    _save(fig, out, dpi)
    return fig


def _groups(results: Result | Sequence[Result] | Mapping[str, Sequence[Result]]
            ) -> dict[str, list[Result]]:
    """One group per name (a mapping's keys, else each result's solver), in order."""
    if isinstance(results, Result):
        return {results.solver: [results]}
    if isinstance(results, Mapping):
        return {str(k): list(v) for k, v in results.items()}
    groups: dict[str, list[Result]] = {}
    for r in list(results):
        groups.setdefault(r.solver, []).append(r)
    return groups


def _columns(groups: Mapping[str, Sequence[Result]]) -> list[str]:
    """``best_cost``, then the first length column some history has (a second panel)."""
    cols = ["best_cost"]
    for c in LENGTH_COLUMNS:
        if any(c in r.history for rs in groups.values() for r in rs):
            cols.append(c)
            break
    return cols


def _draw_group(ax: Axes, rs: Sequence[Result], col: str, name: str, c: str) -> None:
    """One group's median curve of ``col`` and, over several runs, its IQR band."""
    cur = _curves(rs, col)
    if cur is None:
        return
    it, vals = cur
    if col in LENGTH_COLUMNS:
        # "no feasible path yet" counts as +inf, so the median appears once half of
        # the runs are feasible and never increases
        vals = np.where(np.isnan(vals), np.inf, vals)
    lo, med, hi = _quartiles(vals)
    lab = f"{name} (n={len(vals)})" if len(vals) > 1 else name
    if np.all(np.isnan(med)):
        lab += ": " + ("fewer than half feasible" if col in LENGTH_COLUMNS
                       else "no finite values")
    ax.plot(it, med, color=c, lw=1.6, label=lab)
    if len(vals) > 1:
        ax.fill_between(it, lo, hi, color=c, alpha=0.2, lw=0)


def _say_no_median(ax: Axes, col: str) -> None:
    """No median is ever defined: say so instead of an empty, meaningless axis."""
    xs = np.concatenate([ln.get_xdata() for ln in ax.lines])
    ax.set_xlim(float(xs.min()), float(max(xs.max(), xs.min() + 1)))
    ax.set_yticks([])
    ax.text(0.5, 0.5, "no median to draw:\n" + (
        "fewer than half of each group's runs\nare ever feasible"
        if col in LENGTH_COLUMNS else "no finite values"), transform=ax.transAxes,
        ha="center", va="center", fontsize=9, color="#424242")
