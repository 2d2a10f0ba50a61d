"""The small pure functions of the tangent graph: a cone offset (``cone_off``, with the circles'
cached ``reach`` and ``cap``), both senses of a circle list and the world polyline of a path.

``cone_off`` is checked against its definition written out per angle in plain Python (the
offset from the cone start modulo a full turn, ``ANGLE_TOL`` of slack at both ends, clamped
to the cone's width, nan outside), on random cones and on angles placed at the cone's ends.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from optplan.geometry import Frame
from optplan.geometry.tangent.arc_lines import world_polyline
from optplan.geometry.tangent.circles import ANGLE_TOL, TWO_PI, Circles
from optplan.geometry.tangent.tangent_edges import both_senses, cone_off


def _offset(th: float, lo: float, width: float, full: bool) -> float:
    """The definition: the offset of ``th`` from ``lo`` in [0, 2 pi), 0 just below ``lo``;
    on a circle obstacle every offset, on a vertex circle up to ``width`` (clamped), with
    ``ANGLE_TOL`` of slack, else nan."""
    off = math.fmod(th - lo, TWO_PI)
    off = off + TWO_PI if off < 0 else off
    if off > TWO_PI - ANGLE_TOL:
        off = 0.0
    if full:
        return off
    return min(off, width) if off <= width + ANGLE_TOL else math.nan


def _circles(rng: np.random.Generator, n: int) -> Circles:
    full = rng.random(n) < 0.3
    return Circles(rng.normal(size=n) + 1j * rng.normal(size=n), rng.uniform(0, 2, n),
                   rng.uniform(-4, 4, n), np.where(full, TWO_PI, rng.uniform(0, math.pi, n)),
                   full)


def test_cone_off_is_its_definition():
    rng = np.random.default_rng(0)
    C = _circles(rng, 40)
    k = rng.integers(0, 40, 4000)
    th = rng.uniform(-8, 8, 4000)
    # angles at the ends of the cones: inside and outside the slack, and just below lo
    end = C.lo[k] + C.width[k]
    th[:1000] = end[:1000] + rng.choice([-2, -0.5, 0.5, 2], 1000) * ANGLE_TOL
    th[1000:1500] = C.lo[k[1000:1500]] - rng.uniform(0, 2, 500) * ANGLE_TOL
    got = cone_off(C, k, th)
    want = np.array([_offset(t, C.lo[i], C.width[i], C.full[i]) for i, t in zip(k, th)])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    assert 0 < np.isnan(got).sum() < len(got)  # both cases occur
    # one circle and one angle: the same values
    for i, t in zip(k[:50], th[:50]):
        np.testing.assert_array_equal(cone_off(C, int(i), float(t)), cone_off(C, k[:1] * 0 + i,
                                                                              np.array([t]))[0])


def test_the_cached_cone_bounds():
    C = _circles(np.random.default_rng(1), 30)
    np.testing.assert_array_equal(C.cap, np.where(C.full, np.inf, C.width))
    np.testing.assert_array_equal(C.reach, np.where(C.full, np.inf, C.width + ANGLE_TOL))
    assert C.reach is C.reach  # made once


def test_both_senses():
    circles, senses = both_senses(np.array([4, 7, 2]))
    assert circles.tolist() == [4, 4, 7, 7, 2, 2]
    assert senses.tolist() == [1, -1, 1, -1, 1, -1]
    assert [len(x) for x in both_senses(np.zeros(0, np.int64))] == [0, 0]


@pytest.mark.parametrize("origin", [(0.0, 0.0), (1e6, -3e5)])
def test_world_polyline(origin):
    x0, y0 = origin
    frame = Frame.from_bounds((x0, y0, x0 + 10.0, y0 + 10.0))
    start, goal = (x0 + 1.0, y0 + 1.0), (x0 + 9.0, y0 + 8.0)
    s, g = frame.local(np.array(start)), frame.local(np.array(goal))
    z = np.array([complex(*s), complex(*s), 0.5 + 0.5j, 0.5 + 0.5j, 0.5 + 2j, complex(*g)])
    poly = world_polyline(frame, z, start, goal)
    # repeated points dropped (the one after it kept), the ends exactly the given ones
    assert poly.shape == (4, 2)
    assert tuple(poly[0]) == start and tuple(poly[-1]) == goal
    np.testing.assert_array_equal(poly[1:3], frame.world(np.array([[0.5, 0.5], [0.5, 2.0]])))
    assert np.all(np.any(np.diff(poly, axis=0) != 0, axis=1))
