"""The certified optimum: the arc-exact tangent visibility graph against independent oracles
(a plain shapely visibility graph for point robots, analytic tangent-arc lengths for circles, a
fine polygonal bracket for discs among polygons) and metamorphic tests."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

import optplan as op
from optplan.geometry import Frame, obstacle_set
from optplan.geometry.tangent.tangent_graph import shortest_path
from optplan.problem import Obstacle, parse_problem, transform_problem
from tests.geometry.oracles import plain_visibility_length, polygonal_bracket

BOUNDS = (0.0, 0.0, 100.0, 100.0)


def circle(cx, cy, r, name="c") -> Obstacle:
    return Obstacle("circle", None, name=name, center=np.array([cx, cy], float), radius=float(r))


def polygon(geom, name="p") -> Obstacle:
    return Obstacle("polygon", orient(geom, 1.0), name=name)


def random_polygons(rng, k: int) -> list[Polygon]:
    out: list[Polygon] = []
    while len(out) < k:
        c = rng.uniform(15, 85, 2)
        n = int(rng.integers(3, 7))
        ang = np.sort(rng.uniform(0, 2 * np.pi, n))
        rad = rng.uniform(3, 12, n)
        p = Polygon(c + np.c_[rad * np.cos(ang), rad * np.sin(ang)])
        if not p.is_valid or p.area < 5:
            continue
        if p.buffer(1.0).intersects(shapely.MultiPoint([(2, 2), (98, 98)])):
            continue
        out.append(orient(p, 1.0))
    return out


@pytest.mark.parametrize("seed", range(12))
def test_point_robot_matches_a_plain_visibility_graph(seed: int) -> None:
    rng = np.random.default_rng(seed)
    polys = random_polygons(rng, int(rng.integers(2, 7)))
    frame = Frame.from_bounds(BOUNDS)
    oset = obstacle_set([polygon(p) for p in polys], 0.0, frame)
    res = shortest_path(oset, (2.0, 2.0), (98.0, 98.0))
    want = plain_visibility_length(polys, (2.0, 2.0), (98.0, 98.0))
    assert res.length == pytest.approx(want, rel=1e-9)
    assert oset.crossings(res.polyline[None]).count[0] == 0


def tangent_arc_length(a, b, c, R) -> float:
    """Analytic shortest path from a to b around one disc (c, R) blocking the segment."""
    a, b, c = (np.asarray(x, float) for x in (a, b, c))
    da, db = np.hypot(*(a - c)), np.hypot(*(b - c))
    ta, tb = math.sqrt(da * da - R * R), math.sqrt(db * db - R * R)
    ang = math.acos(np.dot(a - c, b - c) / (da * db))
    return ta + tb + R * (ang - math.acos(R / da) - math.acos(R / db))


def test_circle_case_is_exact_and_clear() -> None:
    """Circle of radius 30 and a robot of radius 0.5: optimal, length = the analytic
    tangent-arc length (1e-9 relative), clearance never below -tol."""
    prob = parse_problem({
        "name": "circle", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 0.5}],
        "obstacles": [{"type": "circle", "center": [50.0, 50.0], "radius": 30.0}]})
    res = op.solve(prob, "visgraph")
    want = tangent_arc_length((10, 50), (90, 50), (50, 50), 30.5)
    assert want == pytest.approx(104.656, abs=1e-3)
    assert res.status is op.Status.optimal
    assert res.metrics["optimum"] == pytest.approx(want, rel=1e-9)
    assert res.metrics["min_clearance"] >= 0.0
    assert res.metrics["collisions"] == 0
    assert res.metrics["length"] >= res.metrics["optimum"]  # circumscribed polyline


@pytest.mark.parametrize("seed", range(6))
def test_random_discs_against_analytic_single_disc(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    c = rng.uniform(40, 60, 2)
    R = float(rng.uniform(5, 25))
    r = float(rng.uniform(0, 5))
    a = np.array([c[0] - R - r - rng.uniform(5, 30), c[1] + rng.uniform(-2, 2)])
    b = np.array([c[0] + R + r + rng.uniform(5, 30), c[1] + rng.uniform(-2, 2)])
    oset = obstacle_set([circle(*c, R)], r, Frame.from_bounds((-50.0, -50.0, 150.0, 150.0)))
    res = shortest_path(oset, a, b)
    assert res.length == pytest.approx(tangent_arc_length(a, b, c, R + r), rel=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_disc_among_polygons_lies_in_a_fine_polygonal_bracket(seed: int) -> None:
    """Independent bracket: shapely buffers of the polygons by r (inscribed, quad_segs 16) and
    by r / cos(3 pi / 128) (circumscribed), each solved by the plain visibility graph."""
    rng = np.random.default_rng(200 + seed)
    polys = random_polygons(rng, 3)
    r = float(rng.uniform(0.5, 2.0))
    frame = Frame.from_bounds(BOUNDS)
    oset = obstacle_set([polygon(p) for p in polys], r, frame)
    res = shortest_path(oset, (2.0, 2.0), (98.0, 98.0))

    lo, hi = polygonal_bracket(polys, r, (2.0, 2.0), (98.0, 98.0))
    assert lo - 1e-9 <= res.length <= hi + 1e-9


def test_radius_to_zero_on_paper_env1() -> None:
    base = op.load_problem("paper-env1")
    lengths = []
    for r in (1e-3, 1e-6, 1e-12, 0.0):
        rob = dataclasses.replace(base.robots[0], radius=r)
        prob = dataclasses.replace(base, robots=(rob,), goal_tolerance=1.0, _cache={})
        res = op.solve(prob, "visgraph")
        assert res.status is op.Status.optimal, (r, res.message)
        assert res.metrics["min_clearance"] >= 0.0
        lengths.append(res.metrics["optimum"])
    assert all(x >= y for x, y in zip(lengths, lengths[1:]))
    assert lengths[-2] == pytest.approx(lengths[-1], rel=1e-9)


def transformed(prob, s: float = 1.0, shift=(0.0, 0.0), far: bool = False):
    """``prob`` scaled by ``s`` about the origin and shifted, without its moving obstacles (the
    certified optimum does not see them), plus a far-away circle when ``far``."""
    out = transform_problem(dataclasses.replace(prob, dynamic_obstacles=()), s, shift)
    if far:
        out = dataclasses.replace(out, obstacles=(*out.obstacles, circle(1e11, 1e11, 1.0, "far")),
                                  _cache={})
    return out


@pytest.mark.parametrize("name", op.list_problems())
@pytest.mark.parametrize("s, shift, far", [(1.0, (5e5, 5e6), False), (1e-3, (0, 0), False),
                                           (1e3, (0, 0), False), (1.0, (0, 0), True)])
def test_metamorphic_catalogue(name: str, s: float, shift, far: bool) -> None:
    base = op.load_problem(name)
    a = op.solve(transformed(base), "visgraph")
    b = op.solve(transformed(base, s, shift, far), "visgraph")
    assert a.status == b.status
    assert a.metrics["feasible"] == b.metrics["feasible"]
    assert b.metrics["length_exact"] == pytest.approx(a.metrics["length_exact"] * s, rel=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_metamorphic_random_maps(seed: int) -> None:
    rng = np.random.default_rng(300 + seed)
    polys = random_polygons(rng, 5)
    obs = [polygon(p) for p in polys] + [circle(50, 50, 4)]
    for s, shift in ((1.0, (5e5, 5e6)), (1e-3, (0.0, 0.0)), (1e3, (1e6, -1e6))):
        shift = np.asarray(shift)
        fa = Frame.from_bounds(BOUNDS)
        fb = Frame.from_bounds((shift[0], shift[1], shift[0] + 100 * s, shift[1] + 100 * s))
        moved = [circle(*(o.center * s + shift), o.radius * s) if o.is_circle else
                 polygon(shapely.affinity.translate(
                     shapely.affinity.scale(o.geometry, s, s, origin=(0, 0)), *shift))
                 for o in obs] + [circle(1e11, 1e11, 1.0, "far")]
        ra = shortest_path(obstacle_set(obs, 1.5, fa), (2.0, 2.0), (98.0, 98.0))
        rb = shortest_path(obstacle_set(moved, 1.5 * s, fb), np.array([2.0, 2.0]) * s + shift,
                           np.array([98.0, 98.0]) * s + shift)
        assert rb.length == pytest.approx(ra.length * s, rel=1e-9)


def test_infeasible_start_and_disconnected_goal() -> None:
    frame = Frame.from_bounds(BOUNDS)
    oset = obstacle_set([circle(50, 50, 10)], 1.0, frame)
    res = shortest_path(oset, (50.0, 39.5), (90.0, 90.0))
    assert res.polyline is None and "start" in res.info["reason"]
    ring = polygon(shapely.box(30, 30, 70, 70).difference(shapely.box(40, 40, 60, 60)))
    res = shortest_path(obstacle_set([ring], 1.0, frame), (50.0, 50.0), (90.0, 90.0))
    assert res.polyline is None and "not reachable" in res.info["reason"]
    # the same ring: start and goal both in the courtyard is fine
    res = shortest_path(obstacle_set([ring], 1.0, frame), (45.0, 45.0), (55.0, 55.0))
    assert res.length == pytest.approx(math.hypot(10, 10), rel=1e-12)


def test_backend_statuses_and_options() -> None:
    prob = op.load_problem("paper-env1")
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.optimal
    assert res.metrics["optimum"] == res.metrics["length_exact"] <= res.metrics["length"]
    assert res.metrics["length"] <= res.metrics["optimum"] * (1 + 1e-3)
    assert res.metrics["min_clearance"] >= 0.0
    with pytest.raises(ValueError, match="arc_step"):
        op.solve(prob, "visgraph", arc_step=0.0)
    with pytest.raises(ValueError, match="see_temporary"):
        op.solve(prob, "visgraph", see_temporary=1)
    # a temporary obstacle is ignored unless asked for
    hyb = op.load_problem("paper-hybrid")
    seen = op.solve(hyb, "visgraph", see_temporary=True)
    assert seen.metrics["static_collisions"] == 0


def test_a_wall_to_the_edge_is_certified_or_infeasible() -> None:
    """The bounds are a wall: a wall drawn to the top edge (and beyond the bottom one) leaves
    no way round, a proof (infeasible); with a gap at the top the optimum runs along it."""
    def prob(ymax):
        return parse_problem({
            "name": "edge", "bounds": [0.0, 0.0, 100.0, 100.0],
            "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 1.0}],
            "obstacles": [{"type": "rectangle", "min": [45.0, -50.0], "max": [55.0, ymax]}]})

    for ymax in (99.5, 100.0, 150.0):
        assert op.solve(prob(ymax), "visgraph").status is op.Status.infeasible
    res = op.solve(prob(97.0), "visgraph")
    assert res.status is op.Status.optimal
    # analytic: the tangent from (10, 50) to the corner circle ((45, 97), r = 1), the arc over
    # it to heading 0, the 10 along the top side, and the mirror image
    d = math.hypot(35.0, 47.0)
    heading = math.atan2(47.0, 35.0) + math.asin(1.0 / d)
    assert res.metrics["optimum"] == pytest.approx(2 * (math.sqrt(d * d - 1) + heading) + 10,
                                                   rel=1e-12)


@pytest.mark.parametrize("seed, r", [(1, 0.0), (2, 0.0), (3, 1.0), (4, 1.0)])
def test_courtyard_with_a_door_and_obstacles_inside(seed: int, r: float) -> None:
    """A polygon with a hole (a walled courtyard with a door) and obstacles inside it: the
    plain visibility graph (r = 0) or the fine polygonal bracket (r > 0) agree."""
    rng = np.random.default_rng(seed)
    ring = shapely.box(10, 10, 90, 90).difference(shapely.box(20, 20, 80, 80))
    door = shapely.box(45, 5, 55, 25) if seed % 2 else shapely.box(75, 45, 95, 55)
    ring = orient(ring.difference(door), 1.0)
    inner = [p for p in random_polygons(rng, 3) if p.within(shapely.box(25, 25, 75, 75))
             and not p.buffer(r + 0.5).contains(shapely.Point(50.0, 50.0))]
    polys = [ring, *inner]
    oset = obstacle_set([polygon(p) for p in polys], r, Frame.from_bounds(BOUNDS))
    res = shortest_path(oset, (50.0, 50.0), (2.0, 2.0))
    assert oset.crossings(res.polyline[None]).count[0] == 0
    if r == 0:
        want = plain_visibility_length(polys, (50.0, 50.0), (2.0, 2.0))
        assert res.length == pytest.approx(want, rel=1e-9)
        return

    lo, hi = polygonal_bracket(polys, r, (50.0, 50.0), (2.0, 2.0))
    assert lo - 1e-9 <= res.length <= hi + 1e-9


def test_start_equal_to_goal_is_the_empty_path() -> None:
    prob = parse_problem({
        "name": "same", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [2.0, 2.0], "goal": [2.0, 2.0], "radius": 0.5}],
        "obstacles": [{"type": "circle", "center": [50.0, 50.0], "radius": 10.0}]})
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.optimal and res.metrics["optimum"] == 0.0
    assert op.solve(prob, "nlp-ipopt").success


def test_a_long_search_honours_the_time_limit() -> None:
    """Thousands of convex vertices: the search polls the callback, so a time limit stops it
    (the obstacle set is built first and is not interruptible)."""
    ang = np.linspace(0, 2 * np.pi, 6000, endpoint=False)
    rad = 30 + 5 * np.sin(37 * ang) + 3 * np.cos(91 * ang)
    star = orient(Polygon(np.c_[50 + rad * np.cos(ang), 50 + rad * np.sin(ang)]), 1.0)
    base = parse_problem({
        "name": "star", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [2.0, 2.0], "goal": [98.0, 98.0], "radius": 0.5}]})
    prob = dataclasses.replace(base, obstacles=(polygon(star, "star"),), _cache={})
    res = op.solve(prob, "visgraph", time_limit=0.05)
    assert res.stop_reason == "time_limit" and res.status is op.Status.approximate
    assert "stopped during the search" in res.message
    full = op.solve(prob, "visgraph")  # a stopped search is not cached
    assert full.status is op.Status.optimal
