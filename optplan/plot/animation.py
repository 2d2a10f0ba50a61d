"""Animations of a result as a GIF: robots and dynamic obstacles in time."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from matplotlib.text import Text

from optplan.geometry.collision import cumulative_length, points_along
from optplan.plot.legend import _place_legend
from optplan.plot.result import _draw_global_path
from optplan.plot.scene import _problem_of, _robot_colour, plot_problem
from optplan.plot.shapes import _draw_poly, _draw_violations, _include_points, _poly_path, _polygons
from optplan.plot.style import DYN_COLOUR
from optplan.problem import Problem
from optplan.result import Result
from optplan.violations import violations


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
        s = cumulative_length(p)
        v = prob.robot(k).max_speed if k in prob.robot_ids else 1.0
        arr[k] = (s / v, p)
        t_end = max(t_end, float(s[-1] / v))
    t = np.linspace(0.0, t_end, 200) if t_end > 0 else np.zeros(1)
    out = {}
    for k, (tk, p) in arr.items():
        if len(p) == 1 or tk[-1] == 0:
            out[k] = np.repeat(p[:1], len(t), axis=0)
        else:
            out[k] = points_along(p, t, tk)
    return t, out


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
        self.clock: Text | None = None  # set by animate, before the first frame

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
        form = self.prob.formation
        if self.links and form is not None:  # links only with a formation (_add_links)
            pl = pos[form.leader][i]
            for fid, ln in self.links:
                ln.set_data([pl[0], pos[fid][i][0]], [pl[1], pos[fid][i][1]])
        for d, patches in self.dyn_patches:
            polys = _polygons(d.geometry_at(ti))
            for patch, poly in zip(patches, polys):
                patch.set_path(_poly_path(poly))
        if self.clock is None:
            raise RuntimeError("_Frames.clock must be set before the first frame")
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
    _draw_global_path(ax, result, lw=1.0)
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
