"""A result drawn: robots' paths on the problem, snapshots, the global path, violations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from optplan.plot.figure import _get_ax, _save
from optplan.plot.legend import _place_legend
from optplan.plot.scene import _problem_of, _robot_colour, plot_problem
from optplan.plot.shapes import _draw_poly, _draw_violations, _include_points
from optplan.plot.style import DYN_COLOUR, GLOBAL_COLOUR
from optplan.problem import Problem
from optplan.result import Result
from optplan.violations import violations


def _snapshot_indices(n: int, every: int | None) -> np.ndarray:
    if n == 0:
        return np.zeros(0, int)
    if every is None:
        every = max(1, (n - 1) // 8)
    if every <= 0:
        return np.zeros(0, int)
    idx = np.arange(0, n, int(every))
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return idx


def plot_result(result: Result, problem: Problem | None = None, ax: Axes | None = None,
                out: str | Path | None = None, snapshot_every: int | None = None, *,
                legend: str | None = "auto", dpi: float | None = None) -> Figure:
    """Draw a result on its map.

    Paths of every robot (leader thicker); the global path and its inflection points when
    ``result.extras`` has ``global_path`` / ``inflection_points`` (hybrid planner); for
    time-stamped results (``result.times`` set) snapshots every ``snapshot_every`` steps: robots
    as discs, formation links leader -> followers and the moving obstacles where they were at
    that time.  In red: the segments that collide with a static obstacle and each robot's
    first contact point with one, the contacts in time with moving obstacles or other robots
    (the first one labelled with its time), and the excursions outside the bounds (dashed, the
    points outside as dots; the view is widened to show them).

    Parameters
    ----------
    result : Result
    problem : Problem, optional
        Defaults to ``optplan.load_problem(result.problem)``.
    ax : matplotlib Axes, optional
    out : path, optional
        Write the figure: PNG, SVG or PDF, from the suffix.
    snapshot_every : int, optional
        Steps between snapshots (default: about 8 snapshots per run; 0 disables them).
    legend : {"auto", "outside", "corner"} or None
        Where the legend goes (see :func:`plot_problem`).
    dpi : float, optional
        Resolution of a PNG (default: the figure's, 100).

    Returns
    -------
    matplotlib.figure.Figure
    """
    prob = _problem_of(result, problem)
    times = None if result.times is None else np.asarray(result.times, dtype=float)
    t_end = float(times[-1]) if times is not None and len(times) else None
    own = ax is None
    fig, ax = _get_ax(ax)
    plot_problem(prob, ax=ax, t_end=t_end, legend=None)
    _draw_hybrid_extras(ax, result)
    _draw_paths(ax, prob, result)
    if times is not None and len(times) > 1:
        _draw_snapshots(ax, prob, result, times, snapshot_every)
    m = result.metrics or {}
    paths = {k: np.asarray(v, dtype=float).reshape(-1, 2) for k, v in result.paths.items()}
    _draw_violations(ax, violations(prob, paths, m, times))
    _include_points(ax, prob, paths)
    ax.set_title(_result_title(prob, result), fontsize=10)
    _place_legend(ax, legend, own)
    _save(fig, out, dpi)
    return fig


def _draw_global_path(ax: Axes, result: Result, lw: float) -> None:
    """The global path of a hybrid run (``extras["global_path"]``), dashed, when present."""
    gp = result.extras.get("global_path") if result.extras else None
    if gp is not None:
        g = np.asarray(gp, dtype=float).reshape(-1, 2)
        ax.plot(g[:, 0], g[:, 1], "--", color=GLOBAL_COLOUR, lw=lw, zorder=6,
                label="global path")


def _draw_hybrid_extras(ax: Axes, result: Result) -> None:
    """The global path (dashed) and its inflection points of a hybrid run, when present."""
    _draw_global_path(ax, result, lw=1.3)
    ip = result.extras.get("inflection_points") if result.extras else None
    if ip is not None:
        q = np.asarray(ip, dtype=float).reshape(-1, 2)
        if len(q):
            ax.plot(q[:, 0], q[:, 1], "D", color="#ff6f00", mec="black", mew=0.5, ms=6,
                    zorder=8, ls="none", label="inflection points")


def _path_label(prob: Problem, rid: str, lead: str) -> str:
    """A robot's legend label: its id, ``(leader)`` added for a formation's unnamed leader."""
    return f"{rid}" + (" (leader)" if prob.formation and rid == lead
                       and "leader" not in rid.lower() else "")


def _draw_paths(ax: Axes, prob: Problem, result: Result) -> None:
    """Every robot's path in its colour, the leader's thicker."""
    lead = result.metrics.get("leader") or prob.leader.id
    for rid, path in result.paths.items():
        p = np.asarray(path, dtype=float).reshape(-1, 2)
        c = _robot_colour(prob, rid) if rid in prob.robot_ids else "black"
        ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=2.0 if rid == lead else 1.3, zorder=7,
                label=_path_label(prob, rid, lead))


def _draw_snapshots(ax: Axes, prob: Problem, result: Result, times: np.ndarray,
                    snapshot_every: int | None) -> None:
    """Snapshots of a time-stamped run, later ones more opaque."""
    n = min(len(times), *(len(np.asarray(p)) for p in result.paths.values()))
    idx = _snapshot_indices(n, snapshot_every)
    ids = [k for k in result.paths if k in prob.robot_ids]
    for j, i in enumerate(idx):
        alpha = 0.35 + 0.65 * (j + 1) / len(idx)
        pos = {k: np.asarray(result.paths[k], dtype=float)[i] for k in ids}
        _draw_snapshot(ax, prob, pos, ids, float(times[i]), times[i], alpha)


def _draw_snapshot(ax: Axes, prob: Problem, pos: dict[str, np.ndarray], ids: list[str],
                   t: float, t_label: float, alpha: float) -> None:
    """One snapshot at time ``t``: robots as discs, formation links, moving obstacles."""
    for k in ids:
        r = prob.robot(k)
        ax.add_patch(Circle(tuple(pos[k]), r.radius, fc=_robot_colour(prob, k),
                            ec="black", lw=0.4, alpha=alpha, zorder=8))
    if prob.formation is not None and prob.formation.leader in pos:
        pl = pos[prob.formation.leader]
        for f in prob.formation.followers:
            if f.id in pos:
                ax.plot([pl[0], pos[f.id][0]], [pl[1], pos[f.id][1]], "-",
                        color="#37474f", lw=0.8, alpha=alpha, zorder=8)
    for d in prob.dynamic_obstacles:
        _draw_poly(ax, d.geometry_at(t), fc="none", ec=DYN_COLOUR,
                   lw=0.8, alpha=alpha, zorder=4)
    if prob.dynamic_obstacles and ids:
        ax.annotate(f"t={t_label:.3g}", tuple(pos[ids[0]]), textcoords="offset points",
                    xytext=(5, -10), fontsize=6, color="#37474f", zorder=9)


def _result_title(prob: Problem, result: Result) -> str:
    """``name / solver`` over the status, length, ratio, collisions (and excursions)."""
    m = result.metrics or {}
    bits = [f"{result.status.value}", f"length {m.get('length', float('nan')):.2f}"]
    if m.get("ratio_to_optimum") is not None:
        bits.append(f"ratio {m['ratio_to_optimum']:.3f}")
    bits.append(f"collisions {m.get('collisions', '?')}")
    if m.get("in_bounds") is False:
        bits.append("outside the map")
    return f"{prob.name} / {result.solver}\n" + ", ".join(bits)
