"""optplan.plot: headless maps, results, convergence curves and GIFs."""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import optplan as op
from optplan import plot
from optplan.plot.convergence import _quartiles
from optplan.result import History, Result, Status
from tests import helpers

PIL = pytest.importorskip("PIL.Image")

SCENE = {
    "name": "plot-scene",
    "bounds": [0, 0, 100, 100],
    "robots": [
        {"id": "L", "start": [10, 10], "goal": [90, 90], "radius": 2.0, "max_speed": 5.0},
        {"id": "F1", "start": [3, 16], "radius": 2.0, "max_speed": 5.0},
        {"id": "F2", "start": [16, 3], "radius": 2.0, "max_speed": 5.0},
    ],
    "obstacles": [
        {"type": "rectangle", "min": [40, 15], "max": [60, 40]},
        {"type": "circle", "center": [25, 70], "radius": 8, "known": False},
        {"type": "polygon", "vertices": [[70, 55], [85, 55], [78, 68]]},
    ],
    "dynamic_obstacles": [
        {"type": "circle", "radius": 4, "waypoints": [[80, 20], [80, 50]], "times": [0, 10],
         "after": "bounce"},
        {"type": "polygon", "vertices": [[-3, -3], [3, -3], [0, 4]], "waypoints": [[20, 90]],
         "velocity": [2, -1]},
    ],
    "formation": {"leader": "L", "followers": [{"id": "F1", "L": 8, "phi": 0.7},
                                               {"id": "F2", "L": 8, "phi": -0.7}]},
}


@pytest.fixture(scope="module")
def scene() -> op.Problem:
    return op.parse_problem(SCENE)


@pytest.fixture(scope="module")
def team_result(scene: op.Problem) -> Result:
    n = 25
    t = np.linspace(0.0, 20.0, n)
    lead = np.stack([np.linspace(10, 90, n), np.linspace(10, 90, n)], axis=1)
    off = scene.formation.slot_offsets(np.full(n, np.pi / 4))
    paths = {"L": lead, "F1": lead + off[:, 0], "F2": lead + off[:, 1]}
    paths["F1"][0] = scene.robot("F1").start
    paths["F2"][0] = scene.robot("F2").start
    hist = History()
    for i in range(20):
        hist.append(iteration=i, best_cost=100.0 / (i + 1), best_length=130.0 - i)
    return Result(
        status=Status.solved, paths=paths, metrics=op.evaluate(scene, paths, t), solver="hand",
        backend="hand", options={}, seed=0, problem=scene.name, times=t, history=hist,
        extras={"global_path": np.array([[10, 10], [50, 50], [90, 90]]),
                "inflection_points": np.array([[50, 50]])},
    )


def _robot_discs(ax) -> list:
    """Circle patches that are not the circle obstacle (centre (25, 70)) or its outline."""
    return [p for p in ax.patches if type(p).__name__ == "Circle"
            and tuple(p.center) != (25.0, 70.0)]


def _png_ok(path) -> None:
    assert path.is_file() and path.stat().st_size > 1000
    with PIL.open(path) as im:
        assert im.format == "PNG" and im.size[0] > 100


def test_plot_problem_draws_everything(scene, tmp_path):
    fig = plot.plot_problem(scene)
    ax = fig.axes[0]
    # known + temporary obstacles (filled) and dynamic start shapes are patches
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert len(hatched) == 1  # the temporary circle
    labels = ax.get_legend_handles_labels()[1]
    assert "temporary obstacle" in labels and "moving obstacle track" in labels
    assert any(lab.startswith("inflated") for lab in labels)
    assert ax.get_xlim()[0] < 0 < 100 < ax.get_xlim()[1]
    # the circle obstacle is a true circle (exact centre and radius) and so is its inflated
    # outline (R + r), dashed and unfilled
    circles = [p for p in ax.patches if type(p).__name__ == "Circle"
               and tuple(p.center) == (25.0, 70.0)]
    assert sorted(c.radius for c in circles) == [8.0, 10.0]
    filled = next(c for c in circles if c.radius == 8.0)
    assert filled.get_hatch() == "//" and filled.get_fill()
    outline = next(c for c in circles if c.radius == 10.0)
    assert not outline.get_fill() and outline.get_linestyle() == "--"
    fig.savefig(tmp_path / "map.png")
    _png_ok(tmp_path / "map.png")


def test_plot_problem_without_inflation_has_no_dashed_outline(scene):
    ax = plot.plot_problem(scene, inflate=False).axes[0]
    labels = ax.get_legend_handles_labels()[1]
    assert not any(lab.startswith("inflated") for lab in labels)
    assert [p.radius for p in ax.patches if type(p).__name__ == "Circle"
            and tuple(p.center) == (25.0, 70.0)] == [8.0]


def test_plot_problem_holes_and_point_robot():
    """A polygon with a hole is drawn with the hole; a point robot gets no inflated outline."""
    prob = op.parse_problem({
        "name": "holes", "bounds": [0, 0, 100, 100],
        "robots": [{"id": "p", "start": [50, 50], "goal": [90, 90], "radius": 0}],
        "obstacles": [{"type": "polygon", "vertices": [[30, 30], [70, 30], [70, 70], [30, 70]],
                       "holes": [[[40, 40], [60, 40], [60, 60], [40, 60]]]}]})
    ax = plot.plot_problem(prob).axes[0]
    assert not any(lab.startswith("inflated") for lab in ax.get_legend_handles_labels()[1])
    path = next(p for p in ax.patches if p.get_label() == "obstacle").get_path()
    assert list(path.codes).count(path.MOVETO) == 2  # outer ring and the hole


def test_plot_result_team_with_extras(scene, team_result, tmp_path):
    out = tmp_path / "sub" / "res.png"
    fig = plot.plot_result(team_result, problem=scene, out=out, snapshot_every=6)
    _png_ok(out)
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert {"global path", "inflection points", "L (leader)", "F1", "F2"} <= set(labels)
    # snapshots at steps 0, 6, 12, 18, 24: 3 robot discs each plus the 3 start circles
    assert len(_robot_discs(fig.axes[0])) == 3 + 5 * 3


def test_plot_result_snapshots_can_be_disabled(scene, team_result):
    fig = plot.plot_result(team_result, problem=scene, snapshot_every=0)
    assert len(_robot_discs(fig.axes[0])) == 3


def test_plot_result_loads_catalogue_problem(tmp_path):
    res = op.solve("open-field", "visgraph")
    fig = plot.plot_result(res, out=tmp_path / "of.png")
    assert "open-field" in fig.axes[0].get_title()
    _png_ok(tmp_path / "of.png")


def test_plot_convergence_median_and_band(team_result, tmp_path):
    fig = plot.plot_convergence({"a": [team_result, team_result], "b": [team_result]},
                                out=tmp_path / "conv.png")
    _png_ok(tmp_path / "conv.png")
    assert len(fig.axes) == 2  # best_cost and best_length panels
    ax = fig.axes[0]
    assert len(ax.lines) == 2 and len(ax.collections) == 1  # band only for the group of 2
    np.testing.assert_allclose(ax.lines[0].get_ydata(), team_result.history["best_cost"])


def test_plot_convergence_pads_shorter_runs():
    def run(n, final):
        h = History()
        for i in range(n):
            h.append(iteration=i, best_cost=final + (n - i))
        return Result(status=Status.solved, paths={"r1": np.zeros((2, 2))}, metrics={},
                      solver="s", backend="s", options={}, seed=0, history=h)

    fig = plot.plot_convergence([run(10, 1.0), run(5, 3.0), run(10, 2.0)])
    y = fig.axes[0].lines[0].get_ydata()
    assert len(y) == 10
    # last values: 1 + 1 = 2, 3 + 1 = 4 (held from iteration 4 on), 2 + 1 = 3 -> median 3
    assert y[-1] == pytest.approx(3.0)
    assert y[0] == pytest.approx(np.median([11.0, 8.0, 12.0]))


def test_animate_writes_multiframe_gif(scene, team_result, tmp_path):
    out = tmp_path / "run.gif"
    plot.animate(team_result, out, problem=scene, fps=8, max_frames=12)
    with PIL.open(out) as im:
        assert im.format == "GIF"
        assert 1 < im.n_frames <= 12
        im.seek(0)
        first = np.asarray(im.convert("RGB")).copy()
        im.seek(im.n_frames - 1)
        last = np.asarray(im.convert("RGB"))
    assert np.any(first != last)  # robots move


def test_animate_geometric_path(tmp_path):
    res = op.solve("open-field", "visgraph")
    plot.animate(res, tmp_path / "of.gif", max_frames=6)
    with PIL.open(tmp_path / "of.gif") as im:
        assert im.n_frames > 1


def test_plot_module_is_headless_and_never_uses_pyplot(tmp_path):
    code = (
        "import sys, optplan as op\n"
        "from optplan import plot\n"
        "r = op.solve('open-field', 'visgraph')\n"
        f"plot.plot_result(r, out={str(tmp_path / 'a.png')!r})\n"
        f"plot.animate(r, {str(tmp_path / 'a.gif')!r}, max_frames=2)\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
        "import matplotlib; print(matplotlib.get_backend())\n"
    )
    env = {**os.environ, "DISPLAY": "", "MPLBACKEND": ""}
    env.pop("MPLBACKEND")
    out = helpers.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "a.png").is_file() and (tmp_path / "a.gif").is_file()
    for f in Path(plot.__file__).parent.glob("*.py"):
        assert ".show(" not in f.read_text(encoding="utf-8")


def test_quartiles_treat_inf_as_infinite_and_ignore_nan():
    v = np.array([[1.0, np.inf, np.inf], [2.0, 3.0, np.inf], [3.0, 4.0, 5.0],
                  [np.nan, np.nan, np.nan]]).T
    lo, med, hi = _quartiles(v)
    # column 0: {1, inf, inf} -> all quartiles infinite -> not drawn
    assert np.isnan(lo[0]) and np.isnan(med[0]) and np.isnan(hi[0])
    # column 1: {2, 3, inf}: q25 = 2.5, median 3, q75 infinite
    assert lo[1] == 2.5 and med[1] == 3.0 and np.isnan(hi[1])
    np.testing.assert_allclose([lo[2], med[2], hi[2]], [3.5, 4.0, 4.5])
    assert np.isnan(med[3])


def test_feasible_length_median_starts_when_half_are_feasible():
    def run(first_feasible):
        h = History()
        for i in range(6):
            h.append(iteration=i, best_cost=10.0 - i,
                     feasible_best_length=np.nan if i < first_feasible else 20.0 - i)
        return Result(status=Status.solved, paths={"r1": np.zeros((2, 2))}, metrics={},
                      solver="s", backend="s", options={}, seed=0, history=h)

    fig = plot.plot_convergence({"s": [run(1), run(3), run(5)]})
    assert len(fig.axes) == 2 and fig.axes[1].get_ylabel() == "best feasible length"
    y = fig.axes[1].lines[0].get_ydata()
    assert np.all(np.isnan(y[:3]))  # fewer than 2 of 3 runs feasible
    np.testing.assert_allclose(y[3:], [17.0, 16.0, 15.0])


# -- legends, clock, collisions, formats ---------------------------------------------------


def _drawn(fig):
    """Attach an Agg canvas if needed, draw, return the renderer."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _path_display_points(ax, paths, per_segment=50):
    """Display coordinates of points densely spaced along every path."""
    pts = []
    for p in paths.values():
        p = np.asarray(p, dtype=float)
        for a, b in zip(p[:-1], p[1:]):
            u = np.linspace(0.0, 1.0, per_segment)[:, None]
            pts.append(a + u * (b - a))
    return ax.transData.transform(np.concatenate(pts))


def _inside(bbox, pts, pad=0.0):
    return ((pts[:, 0] >= bbox.x0 - pad) & (pts[:, 0] <= bbox.x1 + pad)
            & (pts[:, 1] >= bbox.y0 - pad) & (pts[:, 1] <= bbox.y1 + pad))


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _red_lines(ax, gid="collision"):
    return [ln for ln in ax.lines if ln.get_gid() == gid
            and ln.get_color() == plot.COLLISION_COLOUR]


def test_legend_is_outside_the_axes_and_inside_the_figure(scene, team_result):
    for fig in (plot.plot_result(team_result, problem=scene), plot.plot_problem(scene)):
        r = _drawn(fig)
        ax = fig.axes[0]
        leg = ax.get_legend().get_window_extent(r)
        box = ax.get_window_extent(r)
        assert leg.x0 >= box.x1  # right of the axes: it covers no data
        # the constrained layout made room: a plain savefig (no bbox_inches) keeps it whole
        assert fig.bbox.x0 <= leg.x0 and leg.x1 <= fig.bbox.x1
        assert fig.bbox.y0 <= leg.y0 and leg.y1 <= fig.bbox.y1


def test_corner_legend_covers_no_path(scene, team_result):
    """In a figure without a layout engine (neighbouring axes possible) the legend goes into
    the corner with the least data: none of the paths' points is under it."""
    fig = plot.new_figure((12, 6))
    a, b = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    for ax in (a, b):
        plot.plot_result(team_result, problem=scene, ax=ax, snapshot_every=0)
    r = _drawn(fig)
    for ax in (a, b):
        leg = ax.get_legend().get_window_extent(r)
        assert _overlap(leg, ax.get_window_extent(r))  # inside the axes ...
        assert not _inside(leg, _path_display_points(ax, team_result.paths)).any()  # ... free
        assert not _overlap(leg, (b if ax is a else a).get_window_extent(r))


def test_legend_choices(scene, team_result):
    fig = plot.plot_result(team_result, problem=scene, legend="corner")
    r = _drawn(fig)
    ax = fig.axes[0]
    leg = ax.get_legend().get_window_extent(r)
    assert not _inside(leg, _path_display_points(ax, team_result.paths)).any()
    assert plot.plot_result(team_result, problem=scene, legend=None).axes[0].get_legend() is None
    with pytest.raises(ValueError, match="legend must be one of"):
        plot.plot_problem(scene, legend="best")


def test_animation_clock_is_visible_and_not_under_the_legend(scene, team_result, tmp_path):
    fig = plot.animate(team_result, tmp_path / "c.gif", problem=scene, max_frames=5, dpi=60)
    ax = fig.axes[0]
    clock = next(t for t in ax.texts if t.get_gid() == "clock")
    assert re.fullmatch(r"t = \d+\.\d\d", clock.get_text())
    clock.set_text(f"t = {team_result.times[-1]:.2f}")  # the widest clock, the last frame's
    r = _drawn(fig)
    cb = clock.get_window_extent(r)
    assert fig.bbox.x0 <= cb.x0 and cb.x1 <= fig.bbox.x1
    assert fig.bbox.y0 <= cb.y0 and cb.y1 <= fig.bbox.y1
    leg = ax.get_legend().get_window_extent(r)
    assert not _overlap(cb, leg)
    assert not _overlap(cb, ax.get_window_extent(r))  # above the axes: no robot passes it
    title = ax._left_title.get_window_extent(r)
    assert not _overlap(cb, title)
    # the legend is outside the axes and whole in the frame
    assert leg.x0 >= ax.get_window_extent(r).x1 and leg.x1 <= fig.bbox.x1
    with PIL.open(tmp_path / "c.gif") as im:
        assert im.size == (round(7.2 * 60), round(5.5 * 60))


def _hand(prob, paths, times=None):
    return Result(status=Status.approximate, paths=paths,
                  metrics=op.evaluate(prob, paths, times), solver="hand", backend="hand",
                  options={}, seed=0, problem=prob.name, times=times)


def test_colliding_path_gets_red_segments_and_its_first_contact(scene):
    # L (radius 2) enters the rectangle [40, 60] x [15, 40] and leaves it: one red span
    path = np.array([[10.0, 10.0], [50.0, 28.0], [50.0, 90.0]])
    res = _hand(scene, {"L": path})
    assert res.metrics["static_collisions"] == 2 and len(res.metrics["crossed"]) == 1
    ax = plot.plot_result(res, problem=scene).axes[0]
    red = _red_lines(ax)
    assert len(red) == 1
    xy = red[0].get_xydata()
    # trimmed to the contact: from the entry (x = 40 - r) to the exit (y = 40 + r)
    np.testing.assert_allclose(xy[0], [38.0, 10 + 0.7 * 18], atol=0.05)
    np.testing.assert_allclose(xy[1], [50.0, 28.0])
    np.testing.assert_allclose(xy[2], [50.0, 42.0], atol=0.05)
    assert len(xy) == 3
    mark = next(ln for ln in ax.lines if ln.get_gid() == "collision-point")
    # the static entry (x = 38 on the first segment) among the marks (this path also meets
    # the moving triangle, whose contact is marked too)
    assert np.min(np.hypot(*(mark.get_xydata() - [38.0, 22.6]).T)) < 0.05
    assert "collision" in ax.get_legend_handles_labels()[1]


def test_red_spans_per_obstacle_and_none_for_a_free_path(scene):
    # one segment through the rectangle and, further on, the triangle: two red spans
    path = np.array([[30.0, 20.0], [90.0, 70.0]])
    res = _hand(scene, {"L": path})
    ax = plot.plot_result(res, problem=scene).axes[0]
    assert len(_red_lines(ax)) == res.metrics["static_collisions"] == 2
    free = np.array([[10.0, 10.0], [10.0, 90.0], [90.0, 90.0]])
    ax = plot.plot_result(_hand(scene, {"L": free}), problem=scene).axes[0]
    assert _red_lines(ax) == [] and "collision" not in ax.get_legend_handles_labels()[1]


def test_contact_with_a_moving_obstacle_is_marked_where_and_when(scene):
    # the moving circle (radius 4) goes (80, 20) -> (80, 50) in 10 s; L crosses x = 80 at
    # y = 35 at t = 5, when the circle is there
    t = np.linspace(0.0, 10.0, 41)
    path = np.stack([np.linspace(60.0, 100.0, 41), np.full(41, 35.0)], axis=1)
    path[:, 0] = np.clip(path[:, 0], 0, 99)
    res = _hand(scene, {"L": path}, t)
    fc = res.metrics["first_contact"]
    assert fc is not None and fc["kind"] == "moving obstacle"
    ax = plot.plot_result(res, problem=scene, snapshot_every=0).axes[0]
    mark = next(ln for ln in ax.lines if ln.get_gid() == "collision-point")
    np.testing.assert_allclose(mark.get_xydata()[0], fc["position"])
    assert any(fc["other"] in t.get_text() and f"t={fc['time']:.3g}" in t.get_text()
               for t in ax.texts)
    red_outline = [p for p in ax.patches if p.get_edgecolor()[:3] == (1.0, 0.0, 0.0)]
    assert len(red_outline) == 1  # the moving obstacle where it was at the contact


def test_excursion_outside_the_map_is_red_and_in_view(scene):
    path = np.array([[10.0, 10.0], [30.0, -12.0], [35.0, 5.0], [90.0, 90.0]])
    res = _hand(scene, {"L": path})
    assert res.metrics["in_bounds"] is False
    ax = plot.plot_result(res, problem=scene).axes[0]
    assert "outside the map" in ax.get_legend_handles_labels()[1]
    assert "outside the map" in ax.get_title()
    dots = [ln for ln in ax.lines if ln.get_gid() == "outside" and ln.get_linestyle() == "None"]
    np.testing.assert_allclose(dots[0].get_xydata(), [[30.0, -12.0]])
    excursion = [ln for ln in _red_lines(ax, "outside") if ln.get_linestyle() == "--"]
    np.testing.assert_allclose(excursion[0].get_xydata(), path[:3])
    assert ax.get_ylim()[0] < -12.0


def test_vector_formats_are_written(scene, team_result, tmp_path):
    plot.plot_result(team_result, problem=scene, out=tmp_path / "r.svg")
    plot.plot_problem(scene, out=tmp_path / "m.pdf")
    plot.plot_convergence(team_result, out=tmp_path / "c.pdf")
    svg = (tmp_path / "r.svg").read_text(encoding="utf-8")
    assert len(svg) > 10_000 and "<svg" in svg[:1000]
    for name in ("m.pdf", "c.pdf"):
        data = (tmp_path / name).read_bytes()
        assert data.startswith(b"%PDF") and len(data) > 5_000
    with pytest.raises(ValueError, match="unsupported figure format"):
        plot.plot_problem(scene, out=tmp_path / "m.jpg")


def test_dpi_sets_the_png_size(scene, team_result, tmp_path):
    sizes = {}
    for dpi in (50, 100):
        plot.plot_result(team_result, problem=scene, out=tmp_path / f"r{dpi}.png", dpi=dpi)
        with PIL.open(tmp_path / f"r{dpi}.png") as im:
            sizes[dpi] = im.size
    # bbox_inches="tight" crops to the drawn extent, which text hinting moves by a few pixels
    assert sizes[100][0] == pytest.approx(2 * sizes[50][0], rel=0.02)
    assert sizes[100][1] == pytest.approx(2 * sizes[50][1], rel=0.02)
    with pytest.raises(ValueError, match="dpi must be > 0"):
        plot.plot_problem(scene, out=tmp_path / "x.png", dpi=0)


def test_cli_plot_svg_and_dpi(tmp_path):
    from optplan import cli

    js = tmp_path / "r.json"
    assert cli.main(["solve", "open-field", "visgraph", "--json", str(js)]) == 0
    assert cli.main(["plot", str(js), "--out", str(tmp_path / "r.svg")]) == 0
    assert "<svg" in (tmp_path / "r.svg").read_text(encoding="utf-8")[:1000]
    for dpi in ("40", "80"):
        assert cli.main(["plot", str(js), "--out", str(tmp_path / f"r{dpi}.png"),
                         "--dpi", dpi]) == 0
    with PIL.open(tmp_path / "r40.png") as a, PIL.open(tmp_path / "r80.png") as b:
        assert b.size[0] == pytest.approx(2 * a.size[0], rel=0.02)
    assert cli.main(["animate", str(js), "--out", str(tmp_path / "r.gif"), "--dpi", "40",
                     "--max-frames", "3"]) == 0
    with PIL.open(tmp_path / "r.gif") as im:
        assert im.size == (round(7.2 * 40), round(5.5 * 40))


def test_plot_draws_the_embedded_map_not_the_catalogue_one(tmp_path) -> None:
    """An edited copy named like a catalogue scene: the saved result redraws its own map."""
    from optplan.plot.scene import _problem_of

    prob = op.parse_problem({
        "name": "paper-env1", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r1", "start": [5.0, 5.0], "goal": [95.0, 95.0], "radius": 1.0}],
        "obstacles": [{"type": "circle", "center": [50.0, 50.0], "radius": 10.0}]})
    res = op.solve(prob, "visgraph")
    res.save(tmp_path / "r.json")
    drawn = _problem_of(op.Result.load(tmp_path / "r.json"), None)
    assert drawn.bounds == (0.0, 0.0, 100.0, 100.0) and len(drawn.obstacles) == 1


def _data_bbox(ax, r):
    """Display bbox of everything drawn in data coordinates (lines, patches, collections and
    texts), clipped to the axes: the data's bbox."""
    from matplotlib.transforms import Bbox

    boxes = []
    for art in [*ax.lines, *ax.patches, *ax.collections, *ax.texts]:
        if not art.get_visible() or art.get_gid() in ("clock",):
            continue
        b = art.get_window_extent(r)
        if np.all(np.isfinite(b.get_points())) and b.width >= 0 and b.height >= 0:
            boxes.append(b)
    return Bbox.intersection(Bbox.union(boxes), ax.get_window_extent(r))


def test_legend_bbox_misses_the_data_bbox_and_the_clock(scene, team_result, tmp_path):
    """Static figures and the animation: the legend's box overlaps neither the box of all the
    drawn data (paths, obstacles, tracks, labels, red marks) nor the clock."""
    collide = _hand(scene, {"L": np.array([[10.0, 10.0], [30.0, -12.0], [50.0, 28.0],
                                           [50.0, 90.0]])})
    figs = [plot.plot_result(team_result, problem=scene), plot.plot_result(collide,
                                                                           problem=scene),
            plot.plot_problem(scene)]
    for fig in figs:
        r = _drawn(fig)
        ax = fig.axes[0]
        leg = ax.get_legend().get_window_extent(r)
        assert not _overlap(leg, _data_bbox(ax, r))
    fig = plot.animate(team_result, tmp_path / "a.gif", problem=scene, max_frames=4, dpi=60)
    ax = fig.axes[0]
    clock = next(t for t in ax.texts if t.get_gid() == "clock")
    r = _drawn(fig)
    leg = ax.get_legend().get_window_extent(r)
    assert not _overlap(leg, _data_bbox(ax, r))
    assert not _overlap(leg, clock.get_window_extent(r))
    assert not _overlap(clock.get_window_extent(r), _data_bbox(ax, r))


def test_colliding_result_has_red_collision_markers_in_plot_and_animation(scene, tmp_path):
    path = np.array([[10.0, 10.0], [50.0, 28.0], [50.0, 90.0]])  # through the rectangle
    res = _hand(scene, {"L": path})
    assert res.metrics["collisions"] > 0
    fig_static = plot.plot_result(res, problem=scene)
    fig_anim = plot.animate(res, tmp_path / "c.gif", problem=scene, max_frames=3, dpi=40)
    for fig in (fig_static, fig_anim):
        ax = fig.axes[0]
        marks = [ln for ln in ax.lines if ln.get_gid() == "collision-point"]
        assert marks and all(ln.get_color() == plot.COLLISION_COLOUR for ln in marks)
        assert _red_lines(ax)  # the colliding span
    # a free result gets no red mark at all
    free = _hand(scene, {"L": np.array([[10.0, 10.0], [10.0, 90.0], [90.0, 90.0]])})
    ax = plot.plot_result(free, problem=scene).axes[0]
    assert not [ln for ln in ax.lines if ln.get_color() == plot.COLLISION_COLOUR]


def test_cli_plot_draws_the_solved_copy_of_a_catalogue_scene(tmp_path, monkeypatch):
    """`optplan plot` on the result of an edited copy of paper-env1 (same name, one obstacle
    removed, another robot start) draws the edited map, even once the copy is deleted."""
    import tomllib

    from optplan import cli
    from optplan.catalog import problem_files
    from optplan.maps import write_toml

    data = tomllib.loads(problem_files()["paper-env1"].read_text(encoding="utf-8"))
    orig = op.load_problem("paper-env1")
    data["obstacles"] = data["obstacles"][1:]
    data["robots"][0]["start"] = [20.0, 30.0]
    edited = op.parse_problem(data, "edited")
    assert edited.name == "paper-env1" and len(edited.obstacles) == len(orig.obstacles) - 1
    toml = write_toml(edited, tmp_path / "env1-edited.toml")
    js = tmp_path / "r.json"
    assert cli.main(["solve", str(toml), "visgraph", "--json", str(js)]) == 0
    toml.unlink()
    drawn = []
    real = plot.plot_result

    def spy(res, problem=None, **kw):
        drawn.append(problem)
        return real(res, problem=problem, **kw)

    monkeypatch.setattr(plot, "plot_result", spy)
    assert cli.main(["plot", str(js), "--out", str(tmp_path / "r.svg"), "--dpi", "50"]) == 0
    (prob,) = drawn
    assert prob.name == "paper-env1"
    assert len(prob.obstacles) == len(edited.obstacles)
    assert [o.name for o in prob.obstacles] == [o.name for o in edited.obstacles]
    np.testing.assert_allclose(prob.robots[0].start, [20.0, 30.0])
    svg = (tmp_path / "r.svg").read_text(encoding="utf-8")
    assert "<svg" in svg[:1000]
