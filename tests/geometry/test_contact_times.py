"""Closed-form contact intervals (optplan.geometry.timing.contact_times) against shapely
distances."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from optplan.geometry.timing.contact_times import ConvexShape, line_intervals, shape_pieces


def _shapely_interval(c, d, geom, r, n=6001, span=15.0):
    """Dense oracle: the parameters in [-span, span] where shapely's distance is < r."""
    t = np.linspace(-span, span, n)
    pts = shapely.points(c[0] + t * d[0], c[1] + t * d[1])
    inside = shapely.distance(geom, pts) < r if r > 0 else shapely.intersects(geom, pts)
    if not inside.any():
        return None
    return t[inside].min(), t[inside].max(), t[1] - t[0]


SHAPES = [
    (ConvexShape(radius=1.5), shapely.Point(0, 0).buffer(1.5, quad_segs=256)),
    (ConvexShape(vertices=np.array([[-1, -0.5], [2, -0.5], [2, 1], [-1, 1]], float)),
     shapely.box(-1, -0.5, 2, 1)),
    (ConvexShape(vertices=np.array([[0, 0], [3, 0], [0.5, 2]], float)),
     shapely.Polygon([(0, 0), (3, 0), (0.5, 2)])),
]


@pytest.mark.parametrize("k", range(len(SHAPES)))
@pytest.mark.parametrize("r", [0.0, 0.3, 1.0])
def test_intervals_match_shapely(k, r):
    shape, geom = SHAPES[k]
    rng = np.random.default_rng(7 + k)
    c = rng.uniform(-6, 6, (25, 2))
    d = rng.normal(size=(25, 2))
    d /= np.hypot(*d.T)[:, None]
    lo, hi = line_intervals(c, d, shape, r)
    circle_slack = 1.5 * (1 - np.cos(np.pi / 1024)) if shape.is_circle else 0.0
    for i in range(len(c)):
        ref = _shapely_interval(c[i], d[i], geom, r)
        if ref is None:
            # the oracle's grid may miss a grazing chord only: then the exact one is tiny
            assert np.isnan(lo[i]) or hi[i] - lo[i] < 0.05
            continue
        a, b, h = ref
        assert not np.isnan(lo[i])
        tol = 2 * h + 50 * circle_slack
        assert abs(lo[i] - a) <= tol and abs(hi[i] - b) <= tol


def test_analytic_circle_and_still_lines():
    shape = ConvexShape(radius=1.0)
    lo, hi = line_intervals([[-5.0, 0.0]], [[1.0, 0.0]], shape, 0.5)
    assert lo[0] == pytest.approx(3.5) and hi[0] == pytest.approx(6.5)
    lo, hi = line_intervals([[0.0, 2.0], [0.0, 1.2]], [[0.0, 0.0], [0.0, 0.0]], shape, 0.5)
    assert np.isnan(lo[0]) and lo[1] == -np.inf and hi[1] == np.inf
    # touching is not contact
    lo, hi = line_intervals([[-5.0, 1.5]], [[1.0, 0.0]], shape, 0.5)
    assert np.isnan(lo[0]) or hi[0] - lo[0] < 1e-6


def test_square_inflated_corner_is_round():
    sq = ConvexShape(vertices=np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float))
    # a line of slope -1 through (1 + a, 1 + a): passes the corner (1, 1) at distance a sqrt 2
    a = 0.3
    c = np.array([[1 + a - 5, 1 + a + 5]])
    d = np.array([[1.0, -1.0]])
    lo, hi = line_intervals(c, d, sq, 0.5)  # a sqrt 2 = 0.424 < 0.5: contact
    half = np.sqrt(0.5 ** 2 - 2 * a * a) / np.sqrt(2)
    assert hi[0] - lo[0] == pytest.approx(2 * half, rel=1e-12)
    lo, hi = line_intervals(c, d, sq, 0.4)  # 0.424 > 0.4: the sharp offset square would hit
    assert np.isnan(lo[0])


def test_pieces_of_a_nonconvex_mover():
    L = shapely.Polygon([(0, 0), (3, 0), (3, 1), (1, 1), (1, 3), (0, 3)])
    pieces = shape_pieces("polygon", None, L)
    assert len(pieces) >= 2
    assert sum(shapely.Polygon(p.vertices).area for p in pieces) == pytest.approx(L.area)
    assert shape_pieces("circle", 2.0, None)[0].radius == 2.0
    with pytest.raises(ValueError, match="radius"):
        shape_pieces("circle", None, None)
    with pytest.raises(ValueError, match=">= 0"):
        line_intervals([[0, 0]], [[1, 0]], pieces[0], -1.0)
