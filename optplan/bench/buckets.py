"""A sweep over MovingAI ``.scen`` files, per bucket (difficulty): the success share and the
two ratios of each solver's length, to the certified Euclidean disc-robot optimum
(``ratio``) and to the file's octile optimum (``octile_ratio``), as a table and one figure.

A row is a ``.scen`` line's when its ``bucket`` is set (:func:`optplan.bench.scen.with_scen`);
other rows are left out.  As in :func:`optplan.bench.summarise`, the ratios are taken over
the successful runs only (status ``optimal`` or ``solved``), the success share over every run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from optplan.bench.rows import _num

__all__ = ["has_buckets", "summarise_buckets", "buckets_markdown", "plot_buckets"]


def _bucket(r: Mapping[str, Any]) -> int | None:
    b = r.get("bucket")
    if b is None or b == "":
        return None
    return int(b)


def has_buckets(rows: Sequence[Mapping[str, Any]]) -> bool:
    """Whether any row is a ``.scen`` line's (has a bucket)."""
    return any(_bucket(r) is not None for r in rows)


def _finite(values: Sequence[Any]) -> np.ndarray:
    v = np.asarray([_num(x) for x in values], dtype=float)
    return v[np.isfinite(v)]


def _median_worst(values: Sequence[Any]) -> tuple[float, float]:
    """Median and largest of the finite values; (nan, nan) when none."""
    v = _finite(values)
    return (float(np.median(v)), float(v.max())) if len(v) else (math.nan, math.nan)


def _ok(r: Mapping[str, Any]) -> bool:
    s = r.get("success")
    return s.strip().lower() in ("true", "1") if isinstance(s, str) else bool(s)


def _bucket_row(key: tuple[str, int, str], rs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The summary of one (scen, bucket, solver)'s rows (see :func:`summarise_buckets`)."""
    good = [r for r in rs if _ok(r)]
    returned = [r for r in rs if r.get("status") not in ("error", "time_limit")]
    ratio = _median_worst([r["ratio"] for r in good])
    octile = _median_worst([r["octile_ratio"] for r in good])
    times = _finite([r["wall_time"] for r in rs if r.get("status") != "error"])
    return {
        "scen": key[0], "bucket": key[1], "solver": key[2], "runs": len(rs),
        "lines": len({r["problem"] for r in rs}),
        "success": len(good) / len(rs), "n_success": len(good),
        "collided": sum(_num(r.get("collisions")) > 0 for r in returned) / len(rs),
        "ratio_median": ratio[0], "ratio_worst": ratio[1],
        "octile_ratio_median": octile[0], "octile_ratio_worst": octile[1],
        "time_median": float(np.median(times)) if len(times) else math.nan,
    }


def summarise_buckets(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One summary per (``.scen`` file, bucket, solver) of the ``.scen`` lines' rows.

    Returns
    -------
    list of dict
        Sorted by file, bucket, then the solvers' first appearance: ``scen``, ``bucket``,
        ``solver``, ``runs``, ``lines`` (distinct lines), ``success`` (share of the runs with
        status ``optimal`` or ``solved``), ``n_success``, ``collided`` (share of the runs that
        returned with a collision), ``ratio_median`` / ``ratio_worst`` (length / certified
        Euclidean optimum) and ``octile_ratio_median`` / ``octile_ratio_worst`` (length /
        the file's octile optimum) over the successful runs (nan when none), ``time_median``
        (seconds, every run that did not raise).
    """
    order: dict[str, int] = {}
    groups: dict[tuple[str, int, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        b = _bucket(r)
        if b is None:
            continue
        order.setdefault(str(r["solver"]), len(order))
        groups.setdefault((str(r.get("scen") or ""), b, str(r["solver"])), []).append(r)
    keys = sorted(groups, key=lambda k: (k[0], k[1], order[k[2]]))
    return [_bucket_row(k, groups[k]) for k in keys]


def _fmt(x: Any, digits: int) -> str:
    v = _num(x)
    return f"{v:.{digits}f}" if math.isfinite(v) else "-"


def buckets_markdown(summary: Sequence[Mapping[str, Any]]) -> str:
    """A markdown table of :func:`summarise_buckets` (times in milliseconds; ratios over the
    successful runs, "-" when none succeeded)."""
    head = ["scen", "bucket", "solver", "lines", "runs", "success", "collided",
            "ratio median", "ratio worst", "octile ratio median", "octile ratio worst",
            "time median (ms)"]
    lines = ["| " + " | ".join(head) + " |",
             "|" + "|".join(["---"] * 3 + ["---:"] * (len(head) - 3)) + "|"]
    for s in summary:
        cells = [str(s["scen"]), str(s["bucket"]), str(s["solver"]), str(s["lines"]),
                 str(s["runs"]), f"{100 * s['success']:.0f} %", f"{100 * s['collided']:.0f} %",
                 _fmt(s["ratio_median"], 4), _fmt(s["ratio_worst"], 4),
                 _fmt(s["octile_ratio_median"], 4), _fmt(s["octile_ratio_worst"], 4),
                 _fmt(1e3 * _num(s["time_median"]), 1)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


#: the panels of :func:`plot_buckets`: (summary key, y label)
PANELS = (("success", "success share (all runs)"),
          ("ratio_median", "length / Euclidean optimum"),
          ("octile_ratio_median", "length / octile optimum"))


def plot_buckets(rows: Sequence[Mapping[str, Any]], colours: Mapping[str, str] | None = None,
                 title: str = "") -> Any:
    """One figure of a ``.scen`` sweep per bucket: three panels side by side, the success
    share, the median length / certified Euclidean optimum and the median length / octile
    optimum (both over the successful runs; log scale when a median is above 3), each solver a
    line over the buckets (a bucket where it never succeeded is a gap in the ratio panels).

    Parameters
    ----------
    rows
        Tidy rows of one ``.scen`` file (other rows are left out).
    colours
        Solver -> colour (default: matplotlib's cycle).
    title
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        On the Agg canvas (:func:`optplan.plot.new_figure`); each panel's line of a solver is
        labelled with the solver's name, its data the buckets and the panel's values.
    """
    from optplan.plot import new_figure

    summary = summarise_buckets(rows)
    solvers = list(dict.fromkeys(s["solver"] for s in summary))
    buckets = sorted({s["bucket"] for s in summary})
    fig = new_figure((12.0, 4.2), dpi=100, layout="constrained")
    axes = fig.subplots(1, len(PANELS))
    for ax, (key, label) in zip(axes, PANELS):
        for solver in solvers:
            mine = {s["bucket"]: s[key] for s in summary if s["solver"] == solver}
            y = [_num(mine.get(b, math.nan)) for b in buckets]
            kw = {"color": colours[solver]} if colours and solver in colours else {}
            ax.plot(buckets, y, marker="o", ms=3.5, lw=1.3, label=solver, **kw)
        _style_panel(ax, key, label, [_num(s[key]) for s in summary])
    axes[0].set_ylim(-0.03, 1.03)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center",
               ncols=min(len(solvers), 6), fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def _style_panel(ax: Any, key: str, label: str, values: Sequence[float]) -> None:
    """Labels, integer bucket ticks and grid of a panel; for a ratio panel the line at 1 and a
    log scale when a value is above 3 (a few long detours would flatten the rest)."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator, MaxNLocator, NullFormatter

    if key != "success":
        ax.axhline(1.0, color="#444444", lw=0.8, ls="--")
        if max((v for v in values if math.isfinite(v)), default=1.0) > 3.0:
            ax.set_yscale("log")
            ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
            ax.yaxis.set_minor_formatter(NullFormatter())
    if ax.get_yscale() == "linear":
        ax.ticklabel_format(axis="y", useOffset=False)
    ax.set_xlabel("bucket (difficulty: octile length / 4)")
    ax.set_ylabel(label)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.grid(alpha=0.3)
