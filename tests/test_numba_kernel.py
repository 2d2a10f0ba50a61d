"""The optional compiled engine (optplan.numba_kernel) against the numpy kernel.

``ObstacleSet.crossings(engine="numba")`` must give the same counts as ``engine="numpy"`` and
the same penetration up to round-off, on catalogue scenes, random maps (all-pairs and grid
pre-filters) and crafted borderline cases; plus the engine-selection rules.
"""

from __future__ import annotations

import math
import subprocess
import sys
import zlib

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

import optplan as op
from optplan import geometry
from optplan.generators import random_obstacles
from optplan.geometry import kernel_engine, obstacle_set
from optplan.problem import Obstacle

pytest.importorskip("numba")

from optplan import numba_kernel  # noqa: E402  (after the skip)

RTOL = 1e-9


def _both(obs, paths: np.ndarray, penetration: bool = True):
    a = obs.crossings(paths, penetration=penetration, engine="numpy")
    b = obs.crossings(paths, penetration=penetration, engine="numba")
    return a, b


def _assert_same(obs, paths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Counts identical and penetration within RTOL, with and without penetration."""
    a, b = _both(obs, paths, penetration=True)
    np.testing.assert_array_equal(b.count, a.count)
    np.testing.assert_allclose(b.penetration, a.penetration, rtol=RTOL,
                               atol=RTOL * obs.scale * 1e-3)
    fa, fb = _both(obs, paths, penetration=False)
    np.testing.assert_array_equal(fb.count, fa.count)
    np.testing.assert_array_equal(fb.count, a.count)
    assert np.all(fb.penetration == 0) and b.count.dtype == np.int64
    return a.count, a.penetration


def _swarm(rng: np.random.Generator, bounds, start, goal, n_paths: int, n_way: int,
           local: float) -> np.ndarray:
    """Random paths start -> waypoints -> goal: half uniform, half small random walks."""
    x0, y0, x1, y1 = bounds
    paths = np.empty((n_paths, n_way + 2, 2))
    paths[:, 0], paths[:, -1] = start, goal
    paths[:, 1:-1] = rng.uniform([x0, y0], [x1, y1], (n_paths, n_way, 2))
    h = n_paths // 2
    steps = rng.normal(0.0, local, (h, n_way, 2))
    walk = rng.uniform([x0, y0], [x1, y1], (h, 1, 2)) + np.cumsum(steps, axis=1)
    paths[:h, 1:-1] = walk
    return paths


# ---------------------------------------------------------------------------------------
# (a) catalogue scenes
# ---------------------------------------------------------------------------------------


def _scenes() -> list[str]:
    return [n for n in op.list_problems() if op.load_problem(n).static_obstacles(True)]


@pytest.mark.parametrize("name", _scenes())
def test_engines_agree_on_catalogue_scenes(name):
    from optplan.backends.swarm import make_space

    prob = op.load_problem(name)
    robot = prob.planned_robots[0]
    obs = make_space(prob.known_view(), robot, 6).obstacles
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    span = max(prob.bounds[2] - prob.bounds[0], prob.bounds[3] - prob.bounds[1])
    paths = _swarm(rng, prob.bounds, robot.start, robot.goal, 200, 6, 0.05 * span)
    count, _ = _assert_same(obs, paths)
    assert count.sum() > 0
    # other radii on the same obstacles (0: touching counts), the grid pre-filter too
    for radius, grid in [(0.0, None), (3.0 * robot.radius, True)]:
        other = obstacle_set(prob.static_obstacles(True), radius, grid=grid)
        _assert_same(other, paths[:60])


# ---------------------------------------------------------------------------------------
# (b) random maps: 10 / 100 / 1000 polygons + circles (the grid pre-filter from 48 items)
# ---------------------------------------------------------------------------------------




@pytest.mark.parametrize("n", [10, 100, 1000])
def test_engines_agree_on_random_maps(n):
    obstacles = random_obstacles(n, seed=n)
    rng = np.random.default_rng(7 + n)
    paths = _swarm(rng, (0, 0, 500, 500), (5.0, 5.0), (495.0, 495.0), 120, 5, 25.0)
    obs = obstacle_set(obstacles, 2.0)
    assert (obs.grid is not None) == (obs.n_items >= 48)
    count, _ = _assert_same(obs, paths)
    assert count.sum() > 0
    # the other pre-filter of the numpy kernel, and the compiled grid walk on a small map
    other = obstacle_set(obstacles, 2.0, grid=obs.grid is None)
    _assert_same(other, paths[:40] if n == 1000 else paths)


def test_grid_engine_matches_on_segments_outside_and_along_the_grid():
    """Segments leaving the grid box, vertical, horizontal, zero-length and very long."""
    obstacles = random_obstacles(100, seed=3)
    obs = obstacle_set(obstacles, 1.0, grid=True)
    rng = np.random.default_rng(3)
    a = rng.uniform(-100, 600, (400, 2))
    b = rng.uniform(-100, 600, (400, 2))
    b[:100, 0] = a[:100, 0]  # vertical
    b[100:200, 1] = a[100:200, 1]  # horizontal
    b[200:250] = a[200:250]  # zero length
    segs = np.stack([a, b], axis=1)
    _assert_same(obs, segs)


# ---------------------------------------------------------------------------------------
# (c) crafted borderline cases (map scale ~ 10: tolerance 1e-9 x 10 = 1e-8 < 1e-7)
# ---------------------------------------------------------------------------------------


def _small_map() -> list[Obstacle]:
    rect = Polygon([(0, 0), (4, 0), (4, 6), (0, 6)])
    tri = Polygon([(8, 0), (11, 0), (9, 3)])
    u = Polygon([(0, 8), (3, 8), (3, 11), (2, 11), (2, 9), (1, 9), (1, 11), (0, 11)])
    c = np.array([8.0, 8.0])
    return [Obstacle("rectangle", rect, True, "rect"), Obstacle("polygon", tri, True, "tri"),
            Obstacle("polygon", u, True, "u"),
            Obstacle("circle", Point(c).buffer(1.5, quad_segs=16), True, "disc", center=c,
                     radius=1.5)]


@pytest.mark.parametrize("r", [0.0, 0.5])
def test_borderline_cases(r):
    obs = obstacle_set(_small_map(), r)
    assert 1e-9 * obs.scale < 2e-8
    eps = 1e-7
    cases = []  # (segment, expected count)
    for sgn, hit in [(-1, 1), (1, 0)]:
        g = r + sgn * eps
        if g < 0:
            continue
        cases.append(([[-1.0, 6 + g], [5.0, 6 + g]], hit))  # grazing the top edge
        cases.append(([[4 + g, -2.0], [4 + g, 3.0]], hit))  # grazing the right edge
        # tangent to the rounded corner (4, 6) at 45 degrees
        u = np.array([1.0, 1.0]) / math.sqrt(2)
        f = np.array([4.0, 6.0]) + g * u
        t = np.array([-u[1], u[0]])
        cases.append(([f - t, f + t], hit))
        cases.append(([f, f], hit))  # zero-length segment at the corner
        cases.append(([[2.0, 6 + g], [2.0, 6 + g]], hit))  # zero-length above the edge
        # tangent to the disc (center (8, 8), radius 1.5)
        cases.append(([[6.0, 8 + 1.5 + g], [10.0, 8 + 1.5 + g]], hit))
        # ending just short of the triangle's apex (9, 3), coming down vertically
        cases.append(([[9.0, 5.0], [9.0, 3 + g]], hit))
    cases.append(([[2.0, 3.0], [2.0, 3.0]], 1))  # zero-length inside
    cases.append(([[-1.0, 3.0], [0.0, 3.0]], 1))  # ending on the boundary (touching)
    cases.append(([[-1.0, 0.0], [5.0, 0.0]], 1))  # along the bottom edge
    cases.append(([[-1.0, 10.0], [4.0, 10.0]], 1))  # through both arms of the U: once
    cases.append(([[1.5, 9.5], [1.5, 12.0]], 1 if r > 0.5 - 1e-12 else 0))  # the U's notch
    cases.append(([[8.0, 8.0], [8.0, 8.0]], 1))  # zero-length at the disc center
    segs = np.array([c for c, _ in cases], dtype=float)
    want = np.array([h for _, h in cases])
    count, pen = _assert_same(obs, segs)
    np.testing.assert_array_equal(count, want)
    # penetration through the U (two arms of width 1 at height 10; its triangles tile it):
    # with r = 0 the inside lengths add up to 2
    if r == 0:
        assert pen[-3] == pytest.approx(2.0)


@pytest.mark.parametrize("r", [0.0, 0.5])
def test_tolerance_band_collides_in_both_engines_with_penetration(r):
    """A segment farther than r but closer than r + 1e-9 x scale collides (the definition);
    its penetration r - dist is slightly negative, and the compiled penetration branch must
    still count it (it once took a negative penetration for "no collision")."""
    obs = obstacle_set(_small_map(), r)
    g = r + 0.5e-9 * obs.scale  # inside the tolerance band
    segs = np.array([[[-1.0, 6 + g], [5.0, 6 + g]],  # parallel to the rectangle's top edge
                     [[6.0, 8 + 1.5 + g], [10.0, 8 + 1.5 + g]],  # tangent to the disc
                     [[-1.0, 6 + 2 * g + 1e-6], [5.0, 6 + 2 * g + 1e-6]]])  # outside: no
    count, pen = _assert_same(obs, segs)
    np.testing.assert_array_equal(count, [1, 1, 0])
    assert -1e-9 * obs.scale < pen[0] < 0 and -1e-9 * obs.scale < pen[1] < 0


def test_concave_polygon_counts_once_but_penetrates_per_piece():
    u = _small_map()[2]
    obs = obstacle_set([u], 0.25)
    assert obs.n_pieces > 1
    rng = np.random.default_rng(11)
    paths = rng.uniform(-1, 4, (300, 4, 2)) + [0.0, 8.0]
    count, _ = _assert_same(obs, paths)
    assert count.max() <= 3  # at most one per segment
    per_seg = obs.crossings(paths, details=True).seg_count
    np.testing.assert_array_equal(per_seg.sum(axis=1), count)


def test_single_path_empty_batch_and_determinism():
    obs = obstacle_set(_small_map(), 0.5)
    path = np.array([[-1.0, -1.0], [5.0, 7.0], [12.0, 12.0]])
    a = obs.crossings(path, engine="numba")
    b = obs.crossings(path, engine="numpy")
    assert a.count.tolist() == b.count.tolist() and a.count.shape == (1,)
    empty = obs.crossings(np.zeros((0, 3, 2)), engine="numba")
    assert empty.count.shape == (0,) and empty.penetration.shape == (0,)
    one_point = obs.crossings(np.array([[2.0, 3.0]]), engine="numba")
    assert one_point.count.tolist() == [0]
    rng = np.random.default_rng(0)
    paths = rng.uniform(-1, 12, (50, 5, 2))
    x, y = obs.crossings(paths, engine="numba"), obs.crossings(paths, engine="numba")
    np.testing.assert_array_equal(x.count, y.count)
    np.testing.assert_array_equal(x.penetration, y.penetration)
    # a non-contiguous float32 view is accepted
    view = paths.astype(np.float32)[:, ::-1]
    np.testing.assert_array_equal(obs.crossings(view, engine="numba").count,
                                  obs.crossings(view, engine="numpy").count)


# ---------------------------------------------------------------------------------------
# engine selection
# ---------------------------------------------------------------------------------------


def test_auto_uses_numba_and_env_var_forces_numpy(monkeypatch):
    monkeypatch.delenv("OPTPLAN_ENGINE", raising=False)
    assert kernel_engine() == "numba" and kernel_engine("numpy") == "numpy"
    obs = obstacle_set(_small_map(), 0.5)
    calls = []
    real = numba_kernel.crossings

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(numba_kernel, "crossings", spy)
    seg = np.array([[[-1.0, 3.0], [5.0, 3.0]]])
    assert obs.crossings(seg).count.tolist() == [1] and len(calls) == 1
    obs.crossings(seg, details=True)  # details: numpy
    assert len(calls) == 1
    monkeypatch.setenv("OPTPLAN_ENGINE", "numpy")
    assert kernel_engine() == "numpy"
    assert obs.crossings(seg).count.tolist() == [1] and len(calls) == 1
    assert obs.crossings(seg, engine="numba").count.tolist() == [1] and len(calls) == 2
    monkeypatch.setenv("OPTPLAN_ENGINE", "numba")
    assert kernel_engine() == "numba"
    monkeypatch.setenv("OPTPLAN_ENGINE", "fortran")
    with pytest.raises(ValueError, match="OPTPLAN_ENGINE"):
        kernel_engine()


def test_bad_engine_and_missing_numba(monkeypatch):
    monkeypatch.delenv("OPTPLAN_ENGINE", raising=False)
    obs = obstacle_set(_small_map(), 0.5)
    seg = np.array([[[-1.0, 3.0], [5.0, 3.0]]])
    with pytest.raises(ValueError, match="'auto', 'numpy', 'numba'"):
        obs.crossings(seg, engine="cuda")
    with pytest.raises(ValueError, match="details"):
        obs.crossings(seg, engine="numba", details=True)
    monkeypatch.setattr(numba_kernel, "AVAILABLE", False)
    assert kernel_engine() == "numpy"
    with pytest.raises(ValueError, match=r"optplan\[fast\]"):
        obs.crossings(seg, engine="numba")
    assert obs.crossings(seg).count.tolist() == [1]  # auto falls back to numpy
    assert geometry.kernel_engine("auto") == "numpy"


def test_import_optplan_does_not_import_numba():
    code = ("import sys, optplan, optplan.geometry, optplan.backends.swarm; "
            "print('numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
