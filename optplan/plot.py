"""Headless figures: maps, paths, formation snapshots, convergence curves and GIF animations.

Everything here draws on a :class:`matplotlib.figure.Figure` attached to the Agg canvas
directly, never through ``pyplot``: no display is needed, no global backend is switched and
no window is ever opened.  Every function returns the figure; those with an ``out`` argument
also write it (PNG, or GIF with Pillow for :func:`animate`; no ffmpeg needed).

>>> import optplan as op
>>> from optplan.plot import plot_result
>>> res = op.solve("open-field", "visgraph")
>>> fig = plot_result(res, out="/tmp/open-field.png")

Conventions: known static obstacles are filled grey, temporary ones (``known = false``,
unseen by global planners) orange and hatched; circles are drawn as true circles
(``matplotlib.patches.Circle``, the exact centre and radius); the inflated outlines (first
robot's radius) are dashed; dynamic obstacles show their start shape and their track dotted;
starts are circles, goals stars.  ``matplotlib`` is imported when this module is imported, so
``import optplan`` stays light as long as this module is not imported.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, PathPatch
from matplotlib.path import Path as MplPath

from optplan.problem import Problem
from optplan.result import Result

__all__ = ["plot_problem", "plot_result", "plot_convergence", "animate", "new_figure"]

#: colours: one per robot (leader first), obstacles, temporary obstacles, dynamic obstacles
ROBOT_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2",
                 "#17becf", "#bcbd22")
KNOWN_FILL = "#9e9e9e"
TEMP_FILL = "#ffb74d"
DYN_COLOUR = "#6a1b9a"
GLOBAL_COLOUR = "#000000"
#: history columns holding the best feasible length so far (first one present is drawn)
LENGTH_COLUMNS = ("best_length", "feasible_best_length")


# --------------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------------


def new_figure(size: tuple[float, float] = (6.0, 6.0), dpi: int = 100) -> Figure:
    """A figure on the Agg canvas (headless, no pyplot state)."""
    fig = Figure(figsize=size, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def _get_ax(ax: Axes | None, size: tuple[float, float] = (6.0, 6.0)) -> tuple[Figure, Axes]:
    if ax is not None:
        return ax.figure, ax
    fig = new_figure(size)
    return fig, fig.add_subplot(1, 1, 1)


def _save(fig: Figure, out: str | Path | None, dpi: int | None = None) -> None:
    if out is None:
        return
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=dpi or fig.dpi, bbox_inches="tight")


def _polygons(geom: Any) -> list:
    """Polygons of a shapely Polygon / MultiPolygon / collection (empty -> [])."""
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    if hasattr(geom, "geoms"):
        out = []
        for g in geom.geoms:
            out += _polygons(g)
        return out
    return []


def _poly_path(poly: Any) -> MplPath:
    """A matplotlib path of a shapely polygon including its holes."""
    verts, codes = [], []
    for ring in (poly.exterior, *poly.interiors):
        c = np.asarray(ring.coords)[:, :2]
        verts.append(c)
        codes += [MplPath.MOVETO] + [MplPath.LINETO] * (len(c) - 2) + [MplPath.CLOSEPOLY]
    return MplPath(np.concatenate(verts), codes)


def _draw_poly(ax: Axes, geom: Any, **kw: Any) -> list[PathPatch]:
    patches = []
    for poly in _polygons(geom):
        patch = PathPatch(_poly_path(poly), **kw)
        ax.add_patch(patch)
        patches.append(patch)
    return patches


def _draw_obstacle(ax: Axes, o: Any, **kw: Any) -> list:
    """Draw a static obstacle: a true circle for circles, its polygon (holes included) else."""
    if o.is_circle:
        patch = Circle((float(o.center[0]), float(o.center[1])), float(o.radius), **kw)
        ax.add_patch(patch)
        return [patch]
    return _draw_poly(ax, o.geometry, **kw)


def _draw_inflated(ax: Axes, obstacles: Sequence, r: float, **kw: Any) -> None:
    """Dashed outlines of the obstacles grown by ``r``, from the exact model.

    Circles: true circles of radius ``R + r``.  Polygons: shapely ``buffer(r)`` of the exact
    polygon, FOR DRAWING ONLY (a polygonised rounding of the corners; no collision decision
    anywhere uses it, those go to :meth:`optplan.problem.Problem.obstacle_set`).  Overlapping
    polygon outlines are merged.
    """
    import shapely

    label = kw.pop("label", None)
    polys = [o.geometry.buffer(r, quad_segs=16) for o in obstacles if not o.is_circle]
    for g in ([shapely.union_all(polys)] if polys else []):
        for poly in _polygons(g):
            for ring in (poly.exterior, *poly.interiors):
                c = np.asarray(ring.coords)
                ax.plot(c[:, 0], c[:, 1], label=label, **kw)
                label = None
    for o in obstacles:
        if o.is_circle:
            ax.add_patch(Circle((float(o.center[0]), float(o.center[1])),
                                float(o.radius) + r, fill=False, ec=kw.get("color"),
                                ls=kw.get("ls"), lw=kw.get("lw"), zorder=kw.get("zorder"),
                                label=label))
            label = None


def _robot_colour(problem: Problem, rid: str) -> str:
    order = [problem.leader.id] + [r.id for r in problem.robots if r.id != problem.leader.id]
    i = order.index(rid) if rid in order else len(order)
    return ROBOT_COLOURS[i % len(ROBOT_COLOURS)]


def _dyn_horizon(problem: Problem, t_end: float | None) -> float:
    """Time span over which to draw dynamic tracks."""
    if t_end is not None and math.isfinite(t_end) and t_end > 0:
        return float(t_end)
    spans = [float(d.times[-1] - d.times[0]) for d in problem.dynamic_obstacles
             if d.velocity is None]
    spans = [s for s in spans if s > 0]
    if spans:
        return max(spans)
    # constant-velocity obstacles only: long enough to cross the map
    speeds = [float(np.hypot(*d.velocity)) for d in problem.dynamic_obstacles
              if d.velocity is not None]
    vmax = max([s for s in speeds if s > 0], default=1.0)
    return problem.extent / vmax


def _problem_of(result: Result, problem: Problem | None) -> Problem:
    if problem is not None:
        return problem
    from optplan.catalog import load_problem

    return load_problem(result.problem)


# --------------------------------------------------------------------------------------
# maps
# --------------------------------------------------------------------------------------


def plot_problem(problem: Problem, ax: Axes | None = None, inflate: bool = True, *,
                 t_end: float | None = None, labels: bool = True) -> Figure:
    """Draw a scenario: bounds, obstacles, inflated outlines, dynamic tracks, starts and goals.

    Parameters
    ----------
    problem : Problem
    ax : matplotlib Axes, optional
        Draw into it; a new headless figure otherwise.
    inflate : bool
        Draw the obstacles inflated by the first robot's radius (dashed outlines).
    t_end : float, optional
        Time up to which the tracks of dynamic obstacles are drawn (their own time span by
        default; constant-velocity ones long enough to cross the map, clipped to the bounds).
    labels : bool
        Annotate robots with their ids and add a legend.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _get_ax(ax)
    x0, y0, x1, y1 = problem.bounds
    ax.add_patch(PathPatch(MplPath([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
                                   closed=True), fill=False, lw=1.2, ec="black", zorder=1))
    first_known = first_temp = True
    for o in problem.obstacles:
        if o.known:
            _draw_obstacle(ax, o, fc=KNOWN_FILL, ec="#424242", lw=0.8, zorder=2,
                           label="obstacle" if first_known else None)
            first_known = False
        else:
            _draw_obstacle(ax, o, fc=TEMP_FILL, ec="#e65100", lw=0.8, hatch="//",
                           zorder=2, label="temporary obstacle" if first_temp else None)
            first_temp = False
    r0 = problem.robots[0].radius
    if inflate and problem.obstacles and r0 > 0:  # a point robot: nothing to grow
        _draw_inflated(ax, problem.obstacles, r0, color="#616161", ls="--", lw=0.7, zorder=2,
                       label=f"inflated (r = {r0:g})")
    if problem.dynamic_obstacles:
        horizon = _dyn_horizon(problem, t_end)
        for k, d in enumerate(problem.dynamic_obstacles):
            t0 = float(d.times[0])
            if d.velocity is None:
                ts = np.concatenate([d.times, np.linspace(t0, t0 + horizon, 200)])
                ts = np.unique(ts[ts <= t0 + horizon])
            else:
                ts = np.linspace(t0, t0 + horizon, 200)
            track = d.position(ts)
            ax.plot(track[:, 0], track[:, 1], ls=":", color=DYN_COLOUR, lw=1.2, zorder=3,
                    label="moving obstacle track" if k == 0 else None)
            _draw_poly(ax, d.geometry_at(t0), fc=DYN_COLOUR, alpha=0.35, ec=DYN_COLOUR,
                       lw=0.8, zorder=3)
            if d.velocity is not None:
                ax.annotate("", xy=track[min(20, len(track) - 1)], xytext=track[0],
                            arrowprops={"arrowstyle": "->", "color": DYN_COLOUR}, zorder=3)
    for r in problem.robots:
        c = _robot_colour(problem, r.id)
        ax.add_patch(Circle(tuple(r.start), r.radius, fc="none", ec=c, lw=1.0, zorder=5))
        ax.plot(*r.start, "o", color=c, ms=5, zorder=5)
        if r.goal is not None:
            ax.plot(*r.goal, "*", color=c, ms=11, mec="black", mew=0.5, zorder=5)
        if labels:
            ax.annotate(r.id, r.start, textcoords="offset points", xytext=(4, 4), fontsize=8,
                        color=c, zorder=6)
    pad = 0.02 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if not ax.get_title():
        ax.set_title(problem.name)
    if labels and ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=7, framealpha=0.8)
    return fig


# --------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------


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
                out: str | Path | None = None, snapshot_every: int | None = None) -> Figure:
    """Draw a result on its map.

    Paths of every robot (leader thicker); the global path and its inflection points when
    ``result.extras`` has ``global_path`` / ``inflection_points`` (hybrid planner); for
    time-stamped results (``result.times`` set) snapshots every ``snapshot_every`` steps: robots
    as discs, formation links leader -> followers and the moving obstacles where they were at
    that time.

    Parameters
    ----------
    result : Result
    problem : Problem, optional
        Defaults to ``optplan.load_problem(result.problem)``.
    ax : matplotlib Axes, optional
    out : path, optional
        Write a PNG.
    snapshot_every : int, optional
        Steps between snapshots (default: about 8 snapshots per run; 0 disables them).

    Returns
    -------
    matplotlib.figure.Figure
    """
    prob = _problem_of(result, problem)
    times = None if result.times is None else np.asarray(result.times, dtype=float)
    t_end = float(times[-1]) if times is not None and len(times) else None
    fig, ax = _get_ax(ax)
    plot_problem(prob, ax=ax, t_end=t_end)
    lead = result.metrics.get("leader") or prob.leader.id
    gp = result.extras.get("global_path") if result.extras else None
    if gp is not None:
        g = np.asarray(gp, dtype=float).reshape(-1, 2)
        ax.plot(g[:, 0], g[:, 1], "--", color=GLOBAL_COLOUR, lw=1.3, zorder=6,
                label="global path")
    ip = result.extras.get("inflection_points") if result.extras else None
    if ip is not None:
        q = np.asarray(ip, dtype=float).reshape(-1, 2)
        if len(q):
            ax.plot(q[:, 0], q[:, 1], "D", color="#ff6f00", mec="black", mew=0.5, ms=6,
                    zorder=8, ls="none", label="inflection points")
    for rid, path in result.paths.items():
        p = np.asarray(path, dtype=float).reshape(-1, 2)
        c = _robot_colour(prob, rid) if rid in prob.robot_ids else "black"
        ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=2.0 if rid == lead else 1.3, zorder=7,
                label=f"{rid}" + (" (leader)" if prob.formation and rid == lead
                                  and "leader" not in rid.lower() else ""))
    if times is not None and len(times) > 1:
        n = min(len(times), *(len(np.asarray(p)) for p in result.paths.values()))
        idx = _snapshot_indices(n, snapshot_every)
        ids = [k for k in result.paths if k in prob.robot_ids]
        for j, i in enumerate(idx):
            alpha = 0.35 + 0.65 * (j + 1) / len(idx)
            pos = {k: np.asarray(result.paths[k], dtype=float)[i] for k in ids}
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
                _draw_poly(ax, d.geometry_at(float(times[i])), fc="none", ec=DYN_COLOUR,
                           lw=0.8, alpha=alpha, zorder=4)
            if prob.dynamic_obstacles and ids:
                ax.annotate(f"t={times[i]:.3g}", pos[ids[0]], textcoords="offset points",
                            xytext=(5, -10), fontsize=6, color="#37474f", zorder=9)
    m = result.metrics
    bits = [f"{result.status.value}", f"length {m.get('length', float('nan')):.2f}"]
    if m.get("ratio_to_optimum") is not None:
        bits.append(f"ratio {m['ratio_to_optimum']:.3f}")
    bits.append(f"collisions {m.get('collisions', '?')}")
    ax.set_title(f"{prob.name} / {result.solver}\n" + ", ".join(bits), fontsize=10)
    ax.legend(loc="best", fontsize=7, framealpha=0.8)
    _save(fig, out)
    return fig


# --------------------------------------------------------------------------------------
# convergence
# --------------------------------------------------------------------------------------


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
                     out: str | Path | None = None, *, log: bool = False) -> Figure:
    """Convergence curves from ``result.history``: median and inter-quartile band.

    Parameters
    ----------
    results : Result, list of Result or dict name -> list of Result
        One curve per group (e.g. per solver over seeds).
    out : path, optional
        Write a PNG.
    log : bool
        Logarithmic y axis.

    Draws ``best_cost`` against ``iteration`` and, when some history has a ``best_length``
    (or ``feasible_best_length``) column, the length of the best *feasible* path so far, a
    second panel with it.  There, a run without a feasible path yet (``nan``) counts as
    ``+inf``: the median curve starts once half of the runs are feasible and is monotone.
    Elsewhere ``nan`` entries are ignored.  Quantiles use numpy's linear interpolation.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if isinstance(results, Result):
        groups: dict[str, list[Result]] = {results.solver: [results]}
    elif isinstance(results, Mapping):
        groups = {str(k): list(v) for k, v in results.items()}
    else:
        lst = list(results)
        groups = {}
        for r in lst:
            groups.setdefault(r.solver, []).append(r)
    cols = ["best_cost"]
    for c in LENGTH_COLUMNS:
        if any(c in r.history for rs in groups.values() for r in rs):
            cols.append(c)
            break
    fig = new_figure((6.0 * len(cols), 4.2))
    axes = [fig.add_subplot(1, len(cols), i + 1) for i in range(len(cols))]
    titles = {"best_cost": "best cost", **{c: "best feasible length" for c in LENGTH_COLUMNS}}
    for ax, col in zip(axes, cols):
        for gi, (name, rs) in enumerate(groups.items()):
            cur = _curves(rs, col)
            if cur is None:
                continue
            it, vals = cur
            c = ROBOT_COLOURS[gi % len(ROBOT_COLOURS)]
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
        ax.set_xlabel("iteration")
        ax.set_ylabel(titles[col])
        ax.set_title(titles[col] + (" (median, IQR band)" if any(
            len(v) > 1 for v in groups.values()) else ""), fontsize=10)
        if log:
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, out)
    return fig


# --------------------------------------------------------------------------------------
# animation
# --------------------------------------------------------------------------------------


def _timed_paths(result: Result, prob: Problem) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Common time grid and positions for every robot.

    Simulated results carry ``times``.  Geometric paths (``times is None``) are timed by
    travelling them at each robot's ``max_speed`` and resampled on a common grid.
    """
    paths = {k: np.asarray(v, dtype=float).reshape(-1, 2) for k, v in result.paths.items()}
    if result.times is not None:
        t = np.asarray(result.times, dtype=float)
        n = min(len(t), *(len(p) for p in paths.values()))
        return t[:n], {k: p[:n] for k, p in paths.items()}
    arr = {}
    t_end = 0.0
    for k, p in paths.items():
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        v = prob.robot(k).max_speed if k in prob.robot_ids else 1.0
        arr[k] = (s / v, p)
        t_end = max(t_end, float(s[-1] / v))
    t = np.linspace(0.0, t_end, 200) if t_end > 0 else np.zeros(1)
    out = {}
    for k, (tk, p) in arr.items():
        if len(p) == 1 or tk[-1] == 0:
            out[k] = np.repeat(p[:1], len(t), axis=0)
        else:
            out[k] = np.stack([np.interp(t, tk, p[:, 0]), np.interp(t, tk, p[:, 1])], axis=1)
    return t, out


def animate(result: Result, out: str | Path, problem: Problem | None = None, fps: int = 10,
            max_frames: int = 150, *, dpi: int = 80, trail: bool = True) -> Figure:
    """Write a GIF of a run: robots as discs, moving obstacles at time t, trails.

    Uses :class:`matplotlib.animation.FuncAnimation` with the Pillow writer: no display and
    no ffmpeg are needed.  The time samples are subsampled evenly to at most ``max_frames``
    frames (first and last always kept).  Results without ``times`` are animated by
    travelling each path at the robot's ``max_speed``.

    Parameters
    ----------
    result : Result
    out : path
        The ``.gif`` to write.
    problem : Problem, optional
        Defaults to ``optplan.load_problem(result.problem)``.
    fps : int
        Frames per second of the GIF.
    max_frames : int
        Upper bound on the number of frames.
    dpi : int
        Resolution of the frames.
    trail : bool
        Draw each robot's trajectory so far.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.animation import FuncAnimation, PillowWriter

    if fps <= 0 or max_frames < 1:
        raise ValueError(f"fps must be > 0 and max_frames >= 1, got fps={fps}, "
                         f"max_frames={max_frames}")
    prob = _problem_of(result, problem)
    t, pos = _timed_paths(result, prob)
    n = len(t)
    frames = np.unique(np.linspace(0, n - 1, min(n, int(max_frames))).round().astype(int))
    # a bare Figure (base canvas): FuncAnimation's per-frame draw_idle is then a no-op and
    # each frame is rendered once, by the writer's savefig (which uses Agg).
    fig = Figure(figsize=(5.5, 5.5), dpi=dpi)
    ax = fig.add_subplot(1, 1, 1)
    plot_problem(prob, ax=ax, t_end=float(t[-1]) if n else None)
    gp = result.extras.get("global_path") if result.extras else None
    if gp is not None:
        g = np.asarray(gp, dtype=float).reshape(-1, 2)
        ax.plot(g[:, 0], g[:, 1], "--", color=GLOBAL_COLOUR, lw=1.0, zorder=6)
    ids = list(pos)
    discs, trails = {}, {}
    for k in ids:
        c = _robot_colour(prob, k) if k in prob.robot_ids else "black"
        rad = prob.robot(k).radius if k in prob.robot_ids else 1.0
        # keep tiny robots visible on big maps
        rad_draw = max(rad, 0.006 * prob.extent)
        discs[k] = Circle(tuple(pos[k][0]), rad_draw, fc=c, ec="black", lw=0.6, zorder=9)
        ax.add_patch(discs[k])
        if trail:
            (trails[k],) = ax.plot([], [], "-", color=c, lw=1.4, zorder=7)
    links = []
    if prob.formation is not None and prob.formation.leader in pos:
        for f in prob.formation.followers:
            if f.id in pos:
                (ln,) = ax.plot([], [], "-", color="#37474f", lw=0.8, zorder=8)
                links.append((f.id, ln))
    dyn_patches = []
    for d in prob.dynamic_obstacles:
        patches = _draw_poly(ax, d.geometry_at(float(t[0])), fc=DYN_COLOUR, ec="black",
                             lw=0.6, alpha=0.8, zorder=6)
        dyn_patches.append((d, patches))
    label = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9,
                    bbox={"fc": "white", "alpha": 0.7, "lw": 0})
    ax.set_title(f"{prob.name} / {result.solver}", fontsize=10)

    def update(i: int) -> list:
        ti = float(t[i])
        for k in ids:
            discs[k].center = tuple(pos[k][i])
            if trail:
                trails[k].set_data(pos[k][: i + 1, 0], pos[k][: i + 1, 1])
        if links:
            pl = pos[prob.formation.leader][i]
            for fid, ln in links:
                ln.set_data([pl[0], pos[fid][i][0]], [pl[1], pos[fid][i][1]])
        for d, patches in dyn_patches:
            polys = _polygons(d.geometry_at(ti))
            for patch, poly in zip(patches, polys):
                patch.set_path(_poly_path(poly))
        label.set_text(f"t = {ti:.2f}")
        return []

    anim = FuncAnimation(fig, update, frames=[int(i) for i in frames], blit=False,
                         repeat=False, cache_frame_data=False)
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    anim.save(str(p), writer=PillowWriter(fps=fps), dpi=dpi)
    return fig
