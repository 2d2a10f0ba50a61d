"""Headless figures: maps, paths, formation snapshots, convergence curves and GIF animations.

Everything here draws on a :class:`matplotlib.figure.Figure` attached to the Agg canvas
directly, never through ``pyplot``: no display is needed, no global backend is switched and
no window is ever opened.  Every function returns the figure; those with an ``out`` argument
also write it (PNG, SVG or PDF chosen by the suffix, at ``dpi``; GIF with Pillow for
:func:`animate`; no ffmpeg needed).

>>> import optplan as op
>>> from optplan.plot import plot_result
>>> res = op.solve("open-field", "visgraph")
>>> fig = plot_result(res, out="/tmp/open-field.png")

Conventions: known static obstacles are filled grey, temporary ones (``known = false``,
unseen by global planners) orange and hatched; circles are drawn as true circles
(``matplotlib.patches.Circle``, the exact centre and radius); the inflated outlines (first
robot's radius) are dashed; dynamic obstacles show their start shape and their track dotted;
starts are circles, goals stars.  What the validator rejects is drawn in red on top: the
path segments that collide with a static obstacle (recomputed with the exact engine), each
robot's first static contact point, the contacts in time with moving obstacles or other robots
(from ``result.metrics``) and the path points outside the bounds.  Red is reserved for this; no
robot is drawn red.  Legends never sit on the data: outside the axes (the figures made here
use matplotlib's constrained layout to make room), or in the corner of the axes with the least
drawn data.  ``matplotlib`` is imported when this module is imported, so ``import optplan``
stays light as long as this module is not imported.
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
from optplan.violations import violations

__all__ = ["plot_problem", "plot_result", "plot_convergence", "animate", "new_figure"]

#: colours: one per robot (leader first; no red, which marks collisions), obstacles, temporary
#: obstacles, dynamic obstacles, the global path, collisions and excursions
ROBOT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2",
                 "#17becf", "#bcbd22")
KNOWN_FILL = "#9e9e9e"
TEMP_FILL = "#ffb74d"
DYN_COLOUR = "#6a1b9a"
GLOBAL_COLOUR = "#000000"
COLLISION_COLOUR = "#ff0000"
#: file formats of the static figures, by suffix
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: legend placements of :func:`plot_problem` / :func:`plot_result`
LEGEND_PLACES = ("auto", "outside", "corner")
#: history columns holding the best feasible length so far (first one present is drawn)
LENGTH_COLUMNS = ("best_length", "feasible_best_length")


# --------------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------------


def new_figure(size: tuple[float, float] = (6.0, 6.0), dpi: int = 100,
               layout: str | None = None) -> Figure:
    """A figure on the Agg canvas (headless, no pyplot state).

    ``layout="constrained"`` makes room for legends placed outside the axes (the default
    placement of :func:`plot_problem` and :func:`plot_result` in such a figure).
    """
    fig = Figure(figsize=size, dpi=dpi, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def _get_ax(ax: Axes | None, size: tuple[float, float] = (7.6, 6.0)) -> tuple[Figure, Axes]:
    if ax is not None:
        return ax.figure, ax
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
    return fig._get_renderer()  # a bare Figure (animate): a throw-away Agg renderer


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
            pts.append(path.vertices)
            wts.append(np.full(len(path.vertices), 0.5))
    pts.append(grid[covered])
    wts.append(np.full(int(covered.sum()), 0.25))
    return np.concatenate(pts), np.concatenate(wts)


def _corner_legend(ax: Axes, fontsize: float) -> Any:
    """A legend in the corner of ``ax`` covering the least drawn data (:func:`_data_samples`).

    Ties go to the first of upper right, upper left, lower left, lower right.
    """
    renderer = _renderer(ax.figure)
    ax.apply_aspect()  # the box the axes will be drawn in (equal aspect)
    pts, wts = _data_samples(ax, renderer)
    best = None
    for loc in ("upper right", "upper left", "lower left", "lower right"):
        leg = ax.legend(loc=loc, fontsize=fontsize, framealpha=0.9)
        b = leg.get_window_extent(renderer)
        inside = ((pts[:, 0] >= b.x0) & (pts[:, 0] <= b.x1) & (pts[:, 1] >= b.y0)
                  & (pts[:, 1] <= b.y1))
        score = float(wts[inside].sum())
        if best is None or score < best[0]:
            best = (score, loc)
    return ax.legend(loc=best[1], fontsize=fontsize, framealpha=0.9)


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
                ax.plot(c[:, 0], c[:, 1], label=label, gid="outline", **kw)
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
    """The problem to draw: ``problem`` if given, else the scenario embedded in the result (the
    map that was solved), else the catalogue scene of that name (results of older versions)."""
    if problem is not None:
        return problem
    embedded = result.scenario_problem()
    if embedded is not None:
        return embedded
    from optplan.catalog import load_problem

    return load_problem(result.problem)


def _draw_violations(ax: Axes, v: Mapping[str, list]) -> None:
    """Red marks for :func:`optplan.violations.violations`; legend entries "collision" and
    "outside the map"."""
    label = "collision"
    for seg in v["segments"]:
        # a wide red band under the path: the robot's colour stays visible along its middle
        ax.plot(seg[:, 0], seg[:, 1], "-", color=COLLISION_COLOUR, lw=6.0, alpha=0.75,
                solid_capstyle="round", zorder=6.9, gid="collision", label=label)
        label = None
    pts = [np.asarray(c["position"], dtype=float) for c in v["contacts"]] + list(v["entries"])
    if pts:
        q = np.asarray(pts).reshape(-1, 2)
        ax.plot(q[:, 0], q[:, 1], "X", color=COLLISION_COLOUR, mec="black", mew=0.6, ms=9,
                ls="none", zorder=10, gid="collision-point", label=label)
    if v["contacts"]:
        c = min(v["contacts"], key=lambda c: c["time"])
        ax.annotate(f"{c.get('other', 'contact')}, t={c['time']:.3g}", tuple(c["position"]),
                    textcoords="offset points", xytext=(6, 6), fontsize=7,
                    color=COLLISION_COLOUR, zorder=10)
    for c in v["moving"]:  # the moving obstacle where it was at the contact
        _draw_poly(ax, c, fc="none", ec=COLLISION_COLOUR, lw=1.0, ls="--", zorder=8.5)
    label = "outside the map"
    for run in v["outside"]:
        ax.plot(run[:, 0], run[:, 1], "--", color=COLLISION_COLOUR, lw=1.6, zorder=8.5,
                gid="outside", label=label)
        label = None
    if v["outside_points"]:
        q = np.concatenate(v["outside_points"])
        ax.plot(q[:, 0], q[:, 1], "o", color=COLLISION_COLOUR, ms=3.5, ls="none", zorder=8.5,
                gid="outside")


def _include_points(ax: Axes, prob: Problem, paths: Mapping[str, np.ndarray]) -> None:
    """Widen the limits so that points outside the bounds are in view."""
    pts = [np.asarray(p, dtype=float).reshape(-1, 2) for p in paths.values()]
    pts = np.concatenate(pts) if pts else np.zeros((0, 2))
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        return
    x0, y0, x1, y1 = prob.bounds
    lo = np.minimum(pts.min(axis=0), (x0, y0))
    hi = np.maximum(pts.max(axis=0), (x1, y1))
    if np.all(lo >= (x0, y0)) and np.all(hi <= (x1, y1)):
        return
    pad = 0.02 * float(max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)


# --------------------------------------------------------------------------------------
# maps
# --------------------------------------------------------------------------------------


def plot_problem(problem: Problem, ax: Axes | None = None, inflate: bool = True, *,
                 t_end: float | None = None, labels: bool = True,
                 legend: str | None = "auto", out: str | Path | None = None,
                 dpi: float | None = None) -> Figure:
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
    legend : {"auto", "outside", "corner"} or None
        Where the legend goes: ``"outside"`` the axes (right of them), ``"corner"``: the
        corner of the axes with the least drawn data; ``"auto"`` (default): outside when the
        figure is made here or uses the constrained layout
        (``new_figure(..., layout="constrained")``), the corner otherwise (an outside legend
        would run into neighbouring axes); ``None``: no legend.
    out : path, optional
        Write the figure: PNG, SVG or PDF, from the suffix.
    dpi : float, optional
        Resolution of a PNG (default: the figure's, 100).

    Returns
    -------
    matplotlib.figure.Figure
    """
    own = ax is None
    fig, ax = _get_ax(ax)
    x0, y0, x1, y1 = problem.bounds
    ax.add_patch(PathPatch(MplPath([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
                                   closed=True), fill=False, lw=1.2, ec="black", zorder=1,
                           gid="bounds"))
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
    if labels:
        _place_legend(ax, legend, own)
    _save(fig, out, dpi)
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
    m = result.metrics or {}
    paths = {k: np.asarray(v, dtype=float).reshape(-1, 2) for k, v in result.paths.items()}
    _draw_violations(ax, violations(prob, paths, m, times))
    _include_points(ax, prob, paths)
    bits = [f"{result.status.value}", f"length {m.get('length', float('nan')):.2f}"]
    if m.get("ratio_to_optimum") is not None:
        bits.append(f"ratio {m['ratio_to_optimum']:.3f}")
    bits.append(f"collisions {m.get('collisions', '?')}")
    if m.get("in_bounds") is False:
        bits.append("outside the map")
    ax.set_title(f"{prob.name} / {result.solver}\n" + ", ".join(bits), fontsize=10)
    _place_legend(ax, legend, own)
    _save(fig, out, dpi)
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
    fig = new_figure((7.2 * len(cols), 4.2), layout="constrained")
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
        if ax.lines and not any(np.isfinite(ln.get_ydata()).any() for ln in ax.lines):
            # no median is ever defined: say so instead of an empty, meaningless axis
            xs = np.concatenate([ln.get_xdata() for ln in ax.lines])
            ax.set_xlim(float(xs.min()), float(max(xs.max(), xs.min() + 1)))
            ax.set_yticks([])
            ax.text(0.5, 0.5, "no median to draw:\n" + (
                "fewer than half of each group's runs\nare ever feasible"
                if col in LENGTH_COLUMNS else "no finite values"), transform=ax.transAxes,
                ha="center", va="center", fontsize=9, color="#424242")
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


def _draw_global_path(ax: Axes, result: Result) -> None:
    """The global path of a hybrid run (``extras["global_path"]``), dashed."""
    gp = result.extras.get("global_path") if result.extras else None
    if gp is not None:
        g = np.asarray(gp, dtype=float).reshape(-1, 2)
        ax.plot(g[:, 0], g[:, 1], "--", color=GLOBAL_COLOUR, lw=1.0, zorder=6,
                label="global path")


class _Frames:
    """The artists of an animation and how one frame moves them (``FuncAnimation``'s
    update function)."""

    def __init__(self, ax: Axes, prob: Problem, pos: dict[str, np.ndarray], t: np.ndarray,
                 trail: bool):
        self.prob, self.pos, self.t, self.trail = prob, pos, t, trail
        self.ids = list(pos)
        self.discs: dict[str, Circle] = {}
        self.trails: dict[str, Any] = {}
        for k in self.ids:
            self._add_robot(ax, k)
        self.links = self._add_links(ax)
        self.dyn_patches = []
        for d in prob.dynamic_obstacles:
            patches = _draw_poly(ax, d.geometry_at(float(t[0])), fc=DYN_COLOUR, ec="black",
                                 lw=0.6, alpha=0.8, zorder=6)
            self.dyn_patches.append((d, patches))
        self.clock = None

    def _add_robot(self, ax: Axes, k: str) -> None:
        """Robot ``k``'s disc (at least 0.6 % of the map wide) and its trail."""
        prob = self.prob
        c = _robot_colour(prob, k) if k in prob.robot_ids else "black"
        rad = prob.robot(k).radius if k in prob.robot_ids else 1.0
        # keep tiny robots visible on big maps
        rad_draw = max(rad, 0.006 * prob.extent)
        self.discs[k] = Circle(tuple(self.pos[k][0]), rad_draw, fc=c, ec="black", lw=0.6,
                               zorder=9, label=None if self.trail else k)
        ax.add_patch(self.discs[k])
        if self.trail:
            (self.trails[k],) = ax.plot([], [], "-", color=c, lw=1.4, zorder=7, label=k)

    def _add_links(self, ax: Axes) -> list:
        """Leader-follower links of the formation: (follower id, line)."""
        prob, links = self.prob, []
        if prob.formation is not None and prob.formation.leader in self.pos:
            for f in prob.formation.followers:
                if f.id in self.pos:
                    (ln,) = ax.plot([], [], "-", color="#37474f", lw=0.8, zorder=8)
                    links.append((f.id, ln))
        return links

    def __call__(self, i: int) -> list:
        ti = float(self.t[i])
        pos = self.pos
        for k in self.ids:
            self.discs[k].center = tuple(pos[k][i])
            if self.trail:
                self.trails[k].set_data(pos[k][: i + 1, 0], pos[k][: i + 1, 1])
        if self.links:
            pl = pos[self.prob.formation.leader][i]
            for fid, ln in self.links:
                ln.set_data([pl[0], pos[fid][i][0]], [pl[1], pos[fid][i][1]])
        for d, patches in self.dyn_patches:
            polys = _polygons(d.geometry_at(ti))
            for patch, poly in zip(patches, polys):
                patch.set_path(_poly_path(poly))
        self.clock.set_text(f"t = {ti:.2f}")
        return []


def animate(result: Result, out: str | Path, problem: Problem | None = None, fps: int = 10,
            max_frames: int = 150, *, dpi: int = 80, trail: bool = True) -> Figure:
    """Write a GIF of a run: robots as discs, moving obstacles at time t, trails.

    Uses :class:`matplotlib.animation.FuncAnimation` with the Pillow writer: no display and
    no ffmpeg are needed.  The time samples are subsampled evenly to at most ``max_frames``
    frames (first and last always kept).  Results without ``times`` are animated by
    travelling each path at the robot's ``max_speed``.  The legend is outside the axes, on
    their right; the clock above them, on the right of the title, so nothing covers it.  The
    collisions and excursions of :func:`plot_result` are marked in red for the whole run.

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
        Resolution of the frames (the GIF is 7.2 x 5.5 inches at this resolution).
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
    if not dpi > 0:
        raise ValueError(f"dpi must be > 0, got {dpi}")
    fig = Figure(figsize=(7.2, 5.5), dpi=dpi, layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    plot_problem(prob, ax=ax, t_end=float(t[-1]) if n else None, legend=None)
    _draw_global_path(ax, result)
    paths = {k: np.asarray(v, dtype=float).reshape(-1, 2) for k, v in result.paths.items()}
    _draw_violations(ax, violations(prob, paths, result.metrics or {}, result.times))
    _include_points(ax, prob, paths)
    update = _Frames(ax, prob, pos, t, trail)
    # the clock: above the axes on the right, the title on the left, the legend outside on
    # the right of the axes, so neither the data nor the legend can hide it
    ax.set_title("")  # plot_problem's centred title
    ax.set_title(f"{prob.name} / {result.solver}", fontsize=10, loc="left")
    update.clock = ax.text(1.0, 1.0 + 0.02, "", transform=ax.transAxes, ha="right",
                           va="bottom", fontsize=10, family="monospace", gid="clock")
    _place_legend(ax, "outside", True)
    # lay the figure out once, with the widest clock, and keep it: no jitter between frames
    # and no layout cost per frame
    update.clock.set_text(f"t = {float(t[-1]) if n else 0.0:.2f}")
    fig.draw_without_rendering()
    fig.set_layout_engine("none")
    anim = FuncAnimation(fig, update, frames=[int(i) for i in frames], blit=False,
                         repeat=False, cache_frame_data=False)
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    anim.save(str(p), writer=PillowWriter(fps=fps), dpi=dpi)
    return fig
