"""``optplan report runs.sqlite --out report/``: a static HTML page of a results database.

Planner Arena's views, offline: for every problem, the outcome of each solver's runs (success
rate and status breakdown), box plots of length / certified optimum (successful runs only) and
of wall time, convergence curves from the ``progress`` table, and the summary table of
:func:`optplan.bench.summarise`.  The page (``index.html``) and its PNGs need no server and no
network; open the file in a browser.

>>> from optplan.report import write_report
>>> write_report("runs.sqlite", "report")  # doctest: +SKIP
PosixPath('report/index.html')

Figures are drawn on the Agg canvas (:func:`optplan.plot.new_figure`), never through pyplot.
"""

from __future__ import annotations

import html
import math
import re
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["write_report", "STATUS_COLOURS"]

#: bar colours of the outcome plot, in stacking order
STATUS_COLOURS = {
    "optimal": "#1b7837",
    "solved": "#7fbf7b",
    "approximate": "#fdb863",
    "infeasible": "#b2abd2",
    "failed": "#d73027",
    "time_limit": "#8073ac",
    "error": "#404040",
}
_SOLVER_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                   "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")


def _slug(s: str) -> str:
    if s.endswith(".toml"):
        s = Path(s).stem
    elif ".scen#" in s.lower():  # a .scen line's name: the file's name and the line
        s = Path(s.split("#")[0]).name + "-" + s.split("#", 1)[1]
    s = re.sub(r"[^A-Za-z0-9._-]+", "-", s)
    return s.strip("-") or "problem"


def _finite(v: Sequence[float]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a[np.isfinite(a)]


# --------------------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------------------


def _fig(n_solvers: int, wide: bool = False) -> Any:
    from optplan.plot import new_figure

    return new_figure((7.0 if wide else 6.0, max(2.6, 0.9 + 0.45 * n_solvers)), dpi=100)


def _plot_outcome(rows: Sequence[Mapping[str, Any]], solvers: Sequence[str]) -> Any:
    fig = _fig(len(solvers))
    ax = fig.add_subplot(1, 1, 1)
    y = np.arange(len(solvers))[::-1]
    left = np.zeros(len(solvers))
    for status, colour in STATUS_COLOURS.items():
        frac = np.array([np.mean([r["status"] == status for r in rows if r["solver"] == s])
                         for s in solvers])
        if not frac.any():
            continue
        ax.barh(y, 100 * frac, left=100 * left, color=colour, label=status, height=0.6)
        left += frac
    for yi, s in zip(y, solvers):
        rs = [r for r in rows if r["solver"] == s]
        ok = sum(bool(r["success"]) for r in rs)
        ax.text(101, yi, f"{100 * ok / len(rs):.0f} % ({ok}/{len(rs)})", va="center",
                fontsize=8)
    ax.set_yticks(y, solvers)
    ax.set_xlim(0, 125)
    ax.set_xticks([0, 25, 50, 75, 100])
    ax.set_xlabel("runs (%); success = optimal or solved")
    ax.set_title("Outcome per solver")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncols=4,
              frameon=False)
    return fig


def _box(ax: Any, data: list[np.ndarray], solvers: Sequence[str], colours: Sequence[str]
         ) -> None:
    y = np.arange(len(solvers))[::-1]
    present = [i for i, d in enumerate(data) if len(d)]
    if present:
        import matplotlib

        # matplotlib >= 3.10 says orientation=; vert= is deprecated from 3.11
        horiz = ({"orientation": "horizontal"} if tuple(
            int(x) for x in matplotlib.__version__.split(".")[:2]) >= (3, 10)
            else {"vert": False})
        bp = ax.boxplot([data[i] for i in present], positions=y[present], **horiz,
                        widths=0.55, patch_artist=True, showfliers=True,
                        flierprops={"markersize": 3, "alpha": 0.5},
                        medianprops={"color": "black"})
        for patch, i in zip(bp["boxes"], present):
            patch.set_facecolor(colours[i])
            patch.set_alpha(0.6)
    for i, d in enumerate(data):
        if not len(d):
            ax.text(0.02, y[i], "no run to show", va="center",
                    transform=ax.get_yaxis_transform(),
                    fontsize=8, color="#666666")
    ax.set_yticks(y, [f"{s} (n={len(d)})" for s, d in zip(solvers, data)])
    ax.set_ylim(-0.6, len(solvers) - 0.4)


def _plot_quality(rows: Sequence[Mapping[str, Any]], solvers: Sequence[str],
                  colours: Sequence[str]) -> Any:
    ok = [r for r in rows if r["success"]]
    use_ratio = any(math.isfinite(r["ratio"]) for r in ok) or (
        not ok and any(math.isfinite(r["ratio"]) for r in rows))
    key = "ratio" if use_ratio else "length"
    data = [_finite([r[key] for r in ok if r["solver"] == s]) for s in solvers]
    fig = _fig(len(solvers))
    ax = fig.add_subplot(1, 1, 1)
    _box(ax, data, solvers, colours)
    if use_ratio:
        ax.axvline(1.0, color="#444444", lw=0.8, ls="--")
        ax.set_xlabel("length / certified optimum (successful runs)")
    else:
        ax.set_xlabel("length (successful runs; no certified optimum)")
    ax.set_title("Path quality")
    return fig


def _plot_time(rows: Sequence[Mapping[str, Any]], solvers: Sequence[str],
               colours: Sequence[str]) -> Any:
    data = [_finite([r["wall_time"] for r in rows if r["solver"] == s and r["status"] != "error"])
            for s in solvers]
    fig = _fig(len(solvers))
    ax = fig.add_subplot(1, 1, 1)
    data = [d[d > 0] for d in data]
    _box(ax, data, solvers, colours)
    if any(len(d) for d in data):
        ax.set_xscale("log")
    ax.set_xlabel("wall time per run (s, log scale; every run that did not raise)")
    ax.set_title("Computation time")
    return fig


def _step_on_grid(t: np.ndarray, c: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Best-so-far cost of one run at each grid time (nan before its first record)."""
    best = np.minimum.accumulate(np.where(np.isfinite(c), c, np.inf))
    idx = np.searchsorted(t, grid, side="right") - 1
    out = np.where(idx >= 0, best[np.clip(idx, 0, None)], np.nan)
    return np.where(np.isinf(out), np.nan, out)


def _cost_is_length(rows: Sequence[Mapping[str, Any]], progress: Mapping[int, Mapping],
                    solver: str) -> bool:
    """True when the solver's final best cost is its path length (so cost / optimum is a
    length ratio): judged on its successful runs, else on every run with a length."""
    rs = [r for r in rows if r["solver"] == solver and r.get("id") in progress
          and progress[r["id"]]["best_cost"] and math.isfinite(r["length"]) and r["length"] > 0]
    good = [r for r in rs if r["success"]] or rs
    if not good:
        return False
    rel = [abs(progress[r["id"]]["best_cost"][-1] / r["length"] - 1.0) for r in good]
    rel = [x for x in rel if math.isfinite(x)]
    return bool(rel) and float(np.median(rel)) < 1e-3


def _traces(rows: Sequence[Mapping[str, Any]], progress: Mapping[int, Mapping], solver: str,
            norm: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """The recorded progress of one solver's runs, costs divided by the optimum."""
    recs = [progress[r["id"]] for r in rows if r["solver"] == solver and r.get("id") in progress]
    return [(np.asarray(p["time"], float), np.asarray(p["best_cost"], float) / norm)
            for p in recs if len(p["time"])]


def _draw_end_points(ax: Any, traces: Sequence[tuple[np.ndarray, np.ndarray]], solver: str,
                     colour: str) -> None:
    """Mark the median end point of runs that recorded one step each (exact solvers)."""
    tt = np.array([tc[0][-1] for tc in traces])
    cc = _finite([tc[1][-1] for tc in traces])
    if len(cc):
        ax.plot([max(float(np.median(tt)), 1e-6)], [float(np.median(cc))], "o",
                color=colour, label=f"{solver} (one step, n={len(traces)})")


def _draw_band(ax: Any, multi: Sequence[tuple[np.ndarray, np.ndarray]], solver: str,
               colour: str) -> None:
    """Draw the median best cost so far of several runs and its inter-quartile band.

    The curves start from the time every run has recorded a first value; nothing is drawn
    when there is no such time on the grid.
    """
    t_lo = min(max(float(tc[0][0]), 1e-6) for tc in multi)
    t_hi = max(float(tc[0][-1]) for tc in multi)
    grid = np.geomspace(t_lo, max(t_hi, t_lo * 1.01), 200)
    vals = np.vstack([_step_on_grid(*tc, grid) for tc in multi])
    alive = np.sum(np.isfinite(vals), axis=0)
    keep = alive == len(multi)  # from the time every run has recorded a first value
    if not keep.any():
        return
    with np.errstate(all="ignore"):
        q25, q50, q75 = (np.nanpercentile(vals[:, keep], q, axis=0) for q in (25, 50, 75))
    ax.plot(grid[keep], q50, color=colour, label=f"{solver} (median, n={len(multi)})")
    ax.fill_between(grid[keep], q25, q75, color=colour, alpha=0.2, lw=0)


def _draw_solver(ax: Any, traces: Sequence[tuple[np.ndarray, np.ndarray]], solver: str,
                 colour: str) -> None:
    """Draw one solver's convergence: a band over its multi-record runs, else an end point."""
    multi = [tc for tc in traces if len(tc[0]) > 1]
    if multi:
        _draw_band(ax, multi, solver, colour)
    else:  # one record per run (exact solvers): their median end point
        _draw_end_points(ax, traces, solver, colour)


def _finish_convergence(ax: Any, drew: bool, skipped: Sequence[str], has_optimum: bool
                        ) -> None:
    """Scales, legend, notes, labels and title of the convergence axes."""
    if drew:
        ax.set_xscale("log")
        lo, hi = ax.get_ylim()
        if lo > 0 and hi / lo > 20:
            ax.set_yscale("log")
        ax.legend(fontsize=7, loc="upper right")
    else:
        ax.text(0.5, 0.5, "no progress recorded", ha="center", va="center",
                transform=ax.transAxes)
    if skipped:
        ax.text(0.01, 0.01, "not drawn (their best cost is not the path length): "
                + ", ".join(skipped), transform=ax.transAxes, fontsize=7, color="#555555",
                va="bottom")
    ax.set_xlabel("wall time since the run started (s, log scale)")
    ax.set_ylabel("best cost / optimum" if has_optimum else "best cost")
    ax.set_title("Convergence (best cost so far: median and IQR band over runs)", fontsize=11)


def _plot_convergence(rows: Sequence[Mapping[str, Any]], progress: Mapping[int, Mapping],
                      solvers: Sequence[str], colours: Sequence[str]) -> Any:
    """The convergence figure of one problem: best cost so far against wall time."""
    fig = _fig(len(solvers), wide=True)
    fig.set_size_inches(7.0, 4.2)
    ax = fig.add_subplot(1, 1, 1)
    opts = _finite([r["optimum"] for r in rows])
    norm = float(np.median(opts)) if len(opts) else 1.0
    drew, skipped = False, []
    for s, colour in zip(solvers, colours):
        if not _cost_is_length(rows, progress, s):
            skipped.append(s)
            continue
        traces = _traces(rows, progress, s, norm)
        if traces:
            drew = True
            _draw_solver(ax, traces, s, colour)
    _finish_convergence(ax, drew, skipped, bool(len(opts)))
    return fig


# --------------------------------------------------------------------------------------
# the page
# --------------------------------------------------------------------------------------

_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1250px;
       color: #222; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.86em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.55em; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; }
.grid { display: grid; grid-template-columns: repeat(auto-fill, minmax(560px, 1fr));
        gap: 0.8em; }
.grid img { max-width: 100%; border: 1px solid #ddd; }
.note { color: #555; font-size: 0.9em; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


def _f(x: Any, digits: int = 3, scale: float = 1.0) -> str:
    try:
        v = float(x) * scale
    except (TypeError, ValueError):
        return "-"
    return f"{v:.{digits}f}" if math.isfinite(v) else "-"


def _summary_table(summary: Sequence[Mapping[str, Any]]) -> str:
    head = ["solver", "runs", "success", "errors", "at time limit", "length median (IQR)",
            "ratio median (IQR)", "min clearance median", "time median (IQR), ms",
            "evals median"]
    out = ["<table><tr>" + "".join(f'<th class="{"l" if i == 0 else ""}">{h}</th>'
                                   for i, h in enumerate(head)) + "</tr>"]
    for s in summary:
        cells = [html.escape(str(s["solver"])), str(s["runs"]),
                 f"{100 * s['success']:.0f} % ({s['n_success']})", str(s["errors"]),
                 str(s["timeouts"]),
                 f"{_f(s['length_median'], 2)} ({_f(s['length_iqr'], 2)})",
                 f"{_f(s['ratio_median'], 4)} ({_f(s['ratio_iqr'], 4)})",
                 _f(s["min_clearance_median"], 3),
                 f"{_f(s['time_median'], 1, 1e3)} ({_f(s['time_iqr'], 1, 1e3)})",
                 _f(s["n_eval_median"], 0)]
        out.append("<tr>" + "".join(f'<td class="{"l" if i == 0 else ""}">{c}</td>'
                                    for i, c in enumerate(cells)) + "</tr>")
    return "\n".join(out) + "</table>"


def _experiments_table(exps: Sequence[Mapping[str, Any]]) -> str:
    head = ["#", "started (UTC)", "outcome", "runs done / skipped / planned", "optplan", "git",
            "python", "machine", "command line"]
    out = ["<table><tr>" + "".join(f'<th class="l">{h}</th>' for h in head) + "</tr>"]
    for e in exps:
        m = e.get("machine") or {}
        mach = f"{m.get('host', '?')}, {m.get('cpu_count', '?')} CPUs, {m.get('platform', '')}"
        cells = [str(e["id"]), str(e.get("started", ""))[:19].replace("T", " "),
                 str(e.get("outcome") or "running or crashed"),
                 f"{e.get('runs_done')} / {e.get('runs_skipped')} / {e.get('runs_planned')}",
                 str(e.get("optplan_version")), str(e.get("git_revision") or "-")[:18],
                 str(e.get("python")), mach, f"<code>{html.escape(str(e.get('command_line')))}"
                                             "</code>"]
        out.append("<tr>" + "".join(
            f'<td class="l">{c if i == len(cells) - 1 else html.escape(c)}</td>'
            for i, c in enumerate(cells)) + "</tr>")
    out.append("</table>")
    if exps:
        pk = exps[-1].get("packages") or {}
        vers = ", ".join(f"{k} {v}" for k, v in sorted(pk.items()) if v)
        out.append(f'<p class="note">Packages (last invocation): {html.escape(vers)}</p>')
    return "\n".join(out)


def _groups(rows: Sequence[Mapping[str, Any]]
            ) -> list[tuple[str, list[Mapping[str, Any]], bool]]:
    """The report's sections: (title, rows, is a ``.scen`` file), one per problem that is not
    a ``.scen`` line and one per ``.scen`` file (its lines together), in first-appearance
    order."""
    out: dict[tuple[str, bool], list[Mapping[str, Any]]] = {}
    for r in rows:
        is_scen = r.get("bucket") is not None
        out.setdefault((str(r["scen"]) if is_scen else str(r["problem"]), is_scen),
                       []).append(r)
    return [(k[0], v, k[1]) for k, v in out.items()]


def _save(figs: Mapping[str, Any], outdir: Path, slug: str, title: str, dpi: int) -> str:
    """Save the figures as ``<slug>-<name>.png``: their ``<img>`` tags in a grid."""
    imgs = []
    for name, fig in figs.items():
        fn = f"{slug}-{name}.png"
        fig.savefig(outdir / fn, dpi=dpi, bbox_inches="tight")
        imgs.append(f'<img src="{html.escape(fn)}" alt="{html.escape(title)}: {name}">')
    return '\n<div class="grid">' + "\n".join(imgs) + "</div>"


def _problem_section(p: str, prow: Sequence[Mapping[str, Any]], progress: Mapping[int, Mapping],
                     colour_of: Mapping[str, str], outdir: Path, slug: str, dpi: int) -> str:
    """The section of one problem: its summary table and four figures."""
    from optplan.bench import summarise

    solvers = list(dict.fromkeys(r["solver"] for r in prow))
    colours = [colour_of[s] for s in solvers]
    figs = {"outcome": _plot_outcome(prow, solvers),
            "quality": _plot_quality(prow, solvers, colours),
            "time": _plot_time(prow, solvers, colours),
            "convergence": _plot_convergence(prow, progress, solvers, colours)}
    opts = _finite([r["optimum"] for r in prow])
    opt_txt = (f"certified optimum {float(np.median(opts)):.4f}" if len(opts)
               else "no certified optimum")
    return (f'<h2 id="{html.escape(slug)}">{html.escape(p)}</h2>\n'
            f'<p class="note">{len(prow)} runs, {len(solvers)} solver(s); {opt_txt}.</p>\n'
            + _summary_table(summarise(prow)) + _save(figs, outdir, slug, p, dpi))


def _bucket_table(summary: Sequence[Mapping[str, Any]]) -> str:
    """The HTML table of :func:`optplan.bench.buckets.summarise_buckets`."""
    head = ["bucket", "solver", "lines", "runs", "success", "collided",
            "length / Euclidean optimum: median, worst", "length / octile optimum: median, "
            "worst", "time median, ms"]
    out = ["<table><tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>"]
    for s in summary:
        cells = [str(s["bucket"]), html.escape(str(s["solver"])), str(s["lines"]),
                 str(s["runs"]), f"{100 * s['success']:.0f} % ({s['n_success']})",
                 f"{100 * s['collided']:.0f} %",
                 f"{_f(s['ratio_median'], 4)}, {_f(s['ratio_worst'], 4)}",
                 f"{_f(s['octile_ratio_median'], 4)}, {_f(s['octile_ratio_worst'], 4)}",
                 _f(s["time_median"], 1, 1e3)]
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return "\n".join(out) + "</table>"


def _scen_section(scen: str, prow: Sequence[Mapping[str, Any]], colour_of: Mapping[str, str],
                  outdir: Path, slug: str, dpi: int) -> str:
    """The section of one ``.scen`` file: both ratios per bucket (figure and table), then the
    outcome, quality and time figures over all its lines."""
    from optplan.bench.buckets import plot_buckets, summarise_buckets

    solvers = list(dict.fromkeys(r["solver"] for r in prow))
    colours = [colour_of[s] for s in solvers]
    figs = {"buckets": plot_buckets(prow, colour_of, title=scen),
            "outcome": _plot_outcome(prow, solvers),
            "quality": _plot_quality(prow, solvers, colours),
            "time": _plot_time(prow, solvers, colours)}
    lines = len({r["problem"] for r in prow})
    return (f'<h2 id="{html.escape(slug)}">{html.escape(scen)}</h2>\n'
            f'<p class="note">{len(prow)} runs on {lines} line(s) of the MovingAI scenario '
            f'file, {len(solvers)} solver(s). Per bucket: the success share, and the length '
            f'over the certified Euclidean disc-robot optimum and over the file\'s octile '
            f'(8-connected grid) optimum, over the successful runs.</p>\n'
            + _bucket_table(summarise_buckets(prow)) + _save(figs, outdir, slug, scen, dpi))


def write_report(db: str | Path, out: str | Path = "report", dpi: int = 100) -> Path:
    """Write ``out/index.html`` and its PNGs from a results database: four per problem (one
    section each), and for the lines of a MovingAI ``.scen`` file one section per file with
    the per-bucket figure of both ratios (:func:`optplan.bench.buckets.plot_buckets`), its
    table, and the outcome, quality and time figures over its lines.

    Returns the path of ``index.html``.
    """
    from optplan.benchdb import read_experiments, read_progress, read_runs

    t0 = time.perf_counter()
    rows = read_runs(db)
    if not rows:
        raise ValueError(f"{db}: the results database holds no runs")
    progress = read_progress(db)
    exps = read_experiments(db)
    outdir = Path(out)
    outdir.mkdir(parents=True, exist_ok=True)
    solvers_all = list(dict.fromkeys(r["solver"] for r in rows))
    colour_of = {s: _SOLVER_COLOURS[i % len(_SOLVER_COLOURS)] for i, s in enumerate(solvers_all)}
    groups = _groups(rows)
    problems = list(dict.fromkeys(r["problem"] for r in rows))
    sections, used, toc_items = [], set(), []
    for title, prow, is_scen in groups:
        slug = _slug(title)
        while slug in used:
            slug += "_"
        used.add(slug)
        toc_items.append(f'<a href="#{html.escape(slug)}">{html.escape(title)}</a>')
        if is_scen:
            sections.append(_scen_section(title, prow, colour_of, outdir, slug, dpi))
        else:
            sections.append(_problem_section(title, prow, progress, colour_of, outdir, slug,
                                             dpi))
    toc = " · ".join(toc_items)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>optplan report: {html.escape(Path(db).name)}</title>
<style>{_CSS}</style></head><body>
<h1>optplan benchmark report</h1>
<p>Database <code>{html.escape(str(db))}</code>: {len(rows)} runs, {len(problems)} problem(s),
{len(solvers_all)} solver(s). Problems: {toc}</p>
<p class="note">Success = status <code>optimal</code> or <code>solved</code> (the shared
validator: collision-free, goal reached). Length, ratio (length / certified optimum of the
known static map) and clearance are medians and inter-quartile ranges over the
<b>successful</b> runs only; time over every run that did not raise (a run stopped at its time
limit counts with its time). Every run solved a fresh copy of its problem (no cache from an
earlier run). Convergence curves show the best cost so far (each backend's own objective, as
passed to its callback, divided by the optimum), against wall time since the run started;
solvers whose best cost is not their path length (e.g. a potential field) are not drawn.</p>
<h2>Experiments</h2>
{_experiments_table(exps)}
{chr(10).join(sections)}
<p class="note">Written by <code>optplan report</code> in {time.perf_counter() - t0:.1f} s.</p>
</body></html>
"""
    index = outdir / "index.html"
    index.write_text(page, encoding="utf-8")
    return index
