"""optplan.plot: headless maps, results, convergence curves and GIFs."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import optplan as op
from optplan import plot
from optplan.result import History, Result, Status

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
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "a.png").is_file() and (tmp_path / "a.gif").is_file()
    assert ".show(" not in open(plot.__file__, encoding="utf-8").read()


def test_quartiles_treat_inf_as_infinite_and_ignore_nan():
    v = np.array([[1.0, np.inf, np.inf], [2.0, 3.0, np.inf], [3.0, 4.0, 5.0],
                  [np.nan, np.nan, np.nan]]).T
    lo, med, hi = plot._quartiles(v)
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
