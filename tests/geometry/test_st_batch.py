"""The batched closed forms of ``geometry.timing.st_batch`` give the same bits as the
per-shape ones of ``st_regions`` (``region_extremes``, ``sections``), and ``sipp``'s
windows the same bits with the movers' tables kept as without.

The scenes mix what the per-shape code branches on: circles, rectangles, triangles, pentagons
and a non-convex L (two convex pieces), waypoint tracks (``loop``, ``bounce``, ``hold``),
constant velocities (one along a path's direction: no support point), stationary obstacles,
robot radii 0 and positive, paths with repeated points and axis-parallel segments, and
sub-boxes that shrink to a line (``sig_lo == sig_hi``).
"""

from __future__ import annotations

import numpy as np
import pytest

from optplan.exact.sipp_graph import MoverBoxes, _grouped, segment_windows
from optplan.geometry.timing import merge_open
from optplan.geometry.timing.st_batch import ShapeRows, batch_sections, region_ranges
from optplan.geometry.timing.st_regions import (
    mover_table,
    path_regions,
    region_extremes,
    sections,
)
from optplan.problem import parse_problem

SHAPES = {
    "rect": [[-3, -2], [3, -2], [3, 2], [-3, 2]],
    "tri": [[0, 0], [6, 1], [2, 5]],
    "pent": [[5 * np.cos(a), 5 * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 6)[:-1]],
    "L": [[0, 0], [10, 0], [10, 3], [3, 3], [3, 10], [0, 10]],
}


def _movers(seed: int) -> list:
    """Fourteen moving obstacles of every kind in a 100 x 100 square."""
    rng = np.random.default_rng(seed)
    tables = []
    for k in range(14):
        kind = ["circle", *SHAPES][k % 5]
        shape = ({"type": "circle", "radius": float(rng.uniform(1, 4))} if kind == "circle"
                 else {"type": "polygon", "vertices": [list(map(float, v))
                                                        for v in SHAPES[kind]]})
        a, b = rng.uniform(10, 90, 2).tolist(), rng.uniform(10, 90, 2).tolist()
        if k % 7 == 3:
            motion = {"waypoints": [a], "times": [0.0]}
        elif k % 7 == 5:
            motion = {"waypoints": [[0.0, 50.0]], "velocity": [2.0, 0.0]}
        else:
            motion = {"waypoints": [a, b], "times": [float(rng.uniform(0, 5)), 20.0],
                      "after": ["loop", "bounce", "hold"][k % 3]}
        tables.append({**shape, **motion, "name": f"m{k}"})
    return list(parse_problem({
        "name": "batch", "bounds": [0, 0, 100, 100], "obstacles": [],
        "robots": [{"id": "r", "start": [1, 1], "goal": [99, 99], "radius": 1.0}],
        "dynamic_obstacles": tables}, "<test>").dynamic_obstacles)


def _path(rng: np.random.Generator) -> np.ndarray:
    """A random walk with a repeated point and an axis-parallel stretch through y = 50."""
    p = np.cumsum(rng.normal(0, 12, (25, 2)), axis=0) + 50
    p[5] = p[4]
    p[10:14, 1] = 50.0
    return p


def _bits(x) -> np.ndarray:
    return np.ascontiguousarray(x, float).view(np.int64)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("radius", [0.0, 1.0])
def test_region_ranges_and_sections_are_the_per_shape_bits(seed, radius):
    rng = np.random.default_rng(seed)
    movers = _movers(seed)
    reg = path_regions(movers, _path(rng), radius, 60.0)
    assert len(reg) > 50 and len(reg.shapes) > 14  # the L has two pieces
    n = len(reg)
    lo = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0, 1, n) * reg.ell)
    hi = np.where(rng.random(n) < 0.2, lo, lo + rng.uniform(0, 1, n) * (reg.ell - lo))
    sh = ShapeRows.of(reg)
    for g in ([-0.1, 1.0], [1.0, 0.0], [-1 / 3.3, 1.0]):
        g = np.array(g)
        for a, b in ((np.zeros(n), reg.ell), (lo, hi)):
            top, bottom = region_ranges(reg, g, a, b, sh)
            np.testing.assert_array_equal(_bits(top), _bits(region_extremes(reg, g, a, b)[0]))
            np.testing.assert_array_equal(_bits(bottom),
                                          _bits(region_extremes(reg, -g, a, b)[0]))
    for sigma in (reg.ell, np.zeros(n), lo):
        for got, ref in zip(batch_sections(reg, sigma), sections(reg, sigma)):
            np.testing.assert_array_equal(_bits(got), _bits(ref))


def test_no_regions():
    reg = path_regions([], np.array([[0.0, 0.0], [1.0, 1.0]]), 1.0, 10.0)
    top, bottom = region_ranges(reg, np.array([1.0, 0.0]), np.zeros(0), np.zeros(0))
    assert top.shape == bottom.shape == (0,)
    assert [x.shape for x in batch_sections(reg, np.zeros(0))] == [(0,), (0,)]


def test_grouped_is_merge_open_per_group():
    rng = np.random.default_rng(3)
    k = rng.integers(0, 6, 300)
    lo = np.round(rng.uniform(0, 50, 300))  # ties in lo, touching and nested intervals
    hi = lo + np.round(rng.uniform(0, 8, 300))
    got = _grouped(k, lo, hi, 7)
    assert got == [merge_open(lo[k == g], hi[k == g]) for g in range(7)]
    assert got[6] == []


@pytest.mark.parametrize("seed", range(3))
def test_windows_with_kept_tables_are_the_same_bits(seed):
    rng = np.random.default_rng(seed)
    movers = _movers(seed)
    boxes = MoverBoxes.build(movers, 1.0, 60.0)
    p = _path(rng)
    a, b = p[:-1], p[1:]
    keep = np.hypot(*(b - a).T) > 0
    a, b = a[keep], b[keep]
    ref = segment_windows(boxes.near_segments(a, b), a, b, 1.0, 10.0, 60.0)
    for _ in range(2):  # computed, then from the kept tables
        assert boxes.segment_windows(a, b, 1.0, 10.0) == ref
    tables = [mover_table(d, 60.0) for d in movers]
    assert segment_windows(movers, a, b, 1.0, 10.0, 60.0, tables) == \
        segment_windows(movers, a, b, 1.0, 10.0, 60.0)
