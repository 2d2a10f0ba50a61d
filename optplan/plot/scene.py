"""A problem drawn: its map, robots' starts and goals, dynamic obstacles' tracks."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Circle, PathPatch
from matplotlib.path import Path as MplPath

from optplan.plot.figure import _get_ax, _save
from optplan.plot.legend import _place_legend
from optplan.plot.shapes import _draw_inflated, _draw_obstacle, _draw_poly
from optplan.plot.style import DYN_COLOUR, KNOWN_FILL, ROBOT_COLOURS, TEMP_FILL
from optplan.problem import Problem
from optplan.result import Result


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
    _draw_obstacles(ax, problem)
    r0 = problem.robots[0].radius
    if inflate and problem.obstacles and r0 > 0:  # a point robot: nothing to grow
        _draw_inflated(ax, problem.obstacles, r0, color="#616161", ls="--", lw=0.7, zorder=2,
                       label=f"inflated (r = {r0:g})")
    if problem.dynamic_obstacles:
        horizon = _dyn_horizon(problem, t_end)
        for k, d in enumerate(problem.dynamic_obstacles):
            _draw_track(ax, d, horizon, first=k == 0)
    _draw_robots(ax, problem, labels)
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


def _draw_obstacles(ax: Axes, problem: Problem) -> None:
    """Known obstacles grey, temporary ones orange and hatched (one legend entry each)."""
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


def _draw_track(ax: Axes, d: Any, horizon: float, first: bool) -> None:
    """A dynamic obstacle's track up to ``horizon`` after its start, its shape at the start
    and, for a constant-velocity one, an arrow along its motion."""
    t0 = float(d.times[0])
    if d.velocity is None:
        ts = np.concatenate([d.times, np.linspace(t0, t0 + horizon, 200)])
        ts = np.unique(ts[ts <= t0 + horizon])
    else:
        ts = np.linspace(t0, t0 + horizon, 200)
    track = d.position(ts)
    ax.plot(track[:, 0], track[:, 1], ls=":", color=DYN_COLOUR, lw=1.2, zorder=3,
            label="moving obstacle track" if first else None)
    _draw_poly(ax, d.geometry_at(t0), fc=DYN_COLOUR, alpha=0.35, ec=DYN_COLOUR,
               lw=0.8, zorder=3)
    if d.velocity is not None:
        ax.annotate("", xy=track[min(20, len(track) - 1)], xytext=track[0],
                    arrowprops={"arrowstyle": "->", "color": DYN_COLOUR}, zorder=3)


def _draw_robots(ax: Axes, problem: Problem, labels: bool) -> None:
    """Each robot's start (its disc and a dot), its goal (a star) and, with labels, its id."""
    for r in problem.robots:
        c = _robot_colour(problem, r.id)
        ax.add_patch(Circle(tuple(r.start), r.radius, fc="none", ec=c, lw=1.0, zorder=5))
        ax.plot(*r.start, "o", color=c, ms=5, zorder=5)
        if r.goal is not None:
            ax.plot(*r.goal, "*", color=c, ms=11, mec="black", mew=0.5, zorder=5)
        if labels:
            ax.annotate(r.id, tuple(r.start), textcoords="offset points", xytext=(4, 4), fontsize=8,
                        color=c, zorder=6)
