"""Shared swarm machinery: encoding, fitness, fast crossing kernel, bounds, bookkeeping."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely

import optplan as op
from optplan.geometry import PIECE_EDGES, convex_pieces, obstacle_set
from optplan.geometry.collision.polyline import resample_path
from optplan.swarm import backend as be
from optplan.swarm import core as sw
from optplan.swarm import operators as ops
from optplan.swarm import refine as rf
from optplan.swarm import roadmap as rm
from optplan.swarm import samples as smp
from optplan.swarm import signatures as sig


def _problem(obstacles=None, **kw) -> op.Problem:
    d = {
        "name": "swarm-test",
        "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 1.0,
                    "max_speed": 1.0}],
        "obstacles": obstacles if obstacles is not None else [
            {"type": "rectangle", "min": [40.0, 30.0], "max": [60.0, 70.0]},
            {"type": "circle", "center": [75.0, 20.0], "radius": 8.0},
            {"type": "polygon", "vertices": [[20.0, 75.0], [35.0, 95.0], [15.0, 95.0]]},
            # non-convex U shape (its inflation is non-convex too)
            {"type": "polygon", "vertices": [[60, 80], [90, 80], [90, 95], [85, 95], [85, 85],
                                             [65, 85], [65, 95], [60, 95]]},
            # two overlapping squares: merged into one part
            {"type": "rectangle", "min": [15.0, 10.0], "max": [25.0, 20.0]},
            {"type": "rectangle", "min": [22.0, 15.0], "max": [30.0, 25.0]},
        ],
    }
    d.update(kw)
    return op.parse_problem(d)


# ---------------------------------------------------------------------------------------
# the shared disc-robot kernel (optplan.geometry.ObstacleSet) against shapely
# ---------------------------------------------------------------------------------------


def _raw_distance(seg: np.ndarray, obstacle) -> float:
    line = shapely.LineString(seg) if np.any(seg[0] != seg[1]) else shapely.Point(seg[0])
    if obstacle.is_circle:
        return max(line.distance(shapely.Point(obstacle.center)) - obstacle.radius, 0.0)
    return line.distance(obstacle.geometry)


def _hexagon_problem() -> op.Problem:
    hexagon = [[50 + 8 * math.cos(a), 50 + 8 * math.sin(a)]
               for a in np.linspace(0, 2 * math.pi, 7)[:-1]]
    return _problem(obstacles=[
        {"type": "rectangle", "min": [40.0, 30.0], "max": [60.0, 40.0]},
        {"type": "polygon", "vertices": hexagon},  # convex, 6 edges: fan-split in 2 pieces
        {"type": "circle", "center": [75.0, 20.0], "radius": 8.0},
        {"type": "polygon", "vertices": [[60, 80], [90, 80], [90, 95], [85, 95], [85, 85],
                                         [65, 85], [65, 95], [60, 95]]},  # non-convex U
        {"type": "polygon", "vertices": [[20.0, 75.0], [35.0, 95.0], [15.0, 95.0]]},
    ])


@pytest.mark.parametrize("grid", [False, True])
@pytest.mark.parametrize("radius", [0.0, 1.5])
def test_obstacle_set_is_the_exact_disc_test(grid, radius):
    prob = _hexagon_problem()
    obs = obstacle_set(prob.obstacles, radius, prob.frame, grid=grid, walls=False)
    rng = np.random.default_rng(4)
    paths = rng.uniform(-5, 105, (300, 4, 2))
    paths[0] = [[10, 50], [10, 50], [50, 50], [50, 50]]  # degenerate segments, one inside
    paths[1] = [[30, 40 + radius], [70, 40 + radius], [70, 10], [30, 28.5 - radius]]  # along
    res = obs.crossings(paths, details=True)
    ref = np.zeros((len(paths), 3), int)
    tricky = np.zeros((len(paths), 3), bool)
    for k in range(len(paths)):
        for j in range(3):
            d = np.array([_raw_distance(paths[k, j:j + 2], o) for o in prob.obstacles])
            ref[k, j] = np.sum(d < radius) if radius > 0 else np.sum(d <= 0)
            tricky[k, j] = np.any(np.abs(d - radius) < 1e-7)
    np.testing.assert_array_equal(res.seg_count[~tricky], ref[~tricky])
    np.testing.assert_array_equal(res.count, res.seg_count.sum(axis=1))
    assert res.count.sum() > 100
    fast = obs.crossings(paths, penetration=False)
    np.testing.assert_array_equal(fast.count, res.count)
    # the pairs name (path, segment, obstacle)
    p_i, s_i, o_i = res.pairs
    assert len(p_i) == res.count.sum()
    for k, j, o in zip(p_i[:50], s_i[:50], o_i[:50]):
        assert _raw_distance(paths[k, j:j + 2], prob.obstacles[o]) < radius + 1e-7


def _many_obstacles(rng: np.random.Generator) -> op.Problem:
    """300 small obstacles (circles and rectangles) at random: a map with the grid screen."""
    obstacles = []
    for i, c in enumerate(rng.uniform(0, 100, (300, 2))):
        if i % 2:
            obstacles.append({"type": "circle", "center": c.tolist(), "radius": 1.0})
        else:
            obstacles.append({"type": "rectangle", "center": c.tolist(), "size": [2.0, 1.0]})
    return _problem(obstacles=obstacles)


def test_obstacle_set_grid_and_all_pairs_agree_on_many_obstacles():
    rng = np.random.default_rng(0)
    prob = _many_obstacles(rng)
    paths = rng.uniform(0, 100, (40, 6, 2))
    a = obstacle_set(prob.obstacles, 0.5, prob.frame, grid=False,
                     walls=False).crossings(paths, details=True)
    b = obstacle_set(prob.obstacles, 0.5, prob.frame, grid=True,
                     walls=False).crossings(paths, details=True)
    # default: a grid from 48 items on
    assert obstacle_set(prob.obstacles, 0.5, prob.frame).grid is not None
    np.testing.assert_array_equal(a.seg_count, b.seg_count)
    np.testing.assert_allclose(a.penetration, b.penetration)


def _free_space(obs) -> sw.SwarmSpace:
    """A space whose visibility tests (``space.clear``) use the obstacle set ``obs``."""
    lo, hi = np.zeros(2), np.full(2, 100.0)
    return sw.SwarmSpace(lo, hi, 1, lo, hi, obs, 1.0, 0.0, obs)


@pytest.mark.parametrize("grid", [False, True])
@pytest.mark.parametrize("radius", [0.0, 1.5])
def test_pairs_free_is_the_exact_disc_test(grid, radius):
    """The compiled any-hit kernel (early exit, last colliding item first, box screen) against
    shapely distances, and the same flags as the counting kernel on every segment."""
    prob = _hexagon_problem()
    obs = obstacle_set(prob.obstacles, radius, prob.frame, grid=grid, walls=False)
    rng = np.random.default_rng(5)
    pts = rng.uniform(-5, 105, (120, 2))
    pts[:3] = [[10, 50], [50, 50], [30, 40 + radius]]  # outside, inside the hexagon, grazing
    i, j = np.triu_indices(len(pts), 0)  # every pair by start point, with i == j points
    free = sw.pairs_free(pts, i, j, _free_space(obs))
    np.testing.assert_array_equal(free, obs.segment_free(pts[i], pts[j]))
    np.testing.assert_array_equal(sw.segment_free(pts[i], pts[j], _free_space(obs)), free)
    sub = rng.choice(len(i), 800, replace=False)
    checked = 0
    for q in sub:
        seg = pts[[i[q], j[q]]]
        d = np.array([_raw_distance(seg, o) for o in prob.obstacles])
        if radius > 0 and np.any(np.abs(d - radius) < 1e-7):
            continue
        if radius == 0 and (np.any((d > 0) & (d < 1e-7)) or 2 in (i[q], j[q])
                            or i[q] == j[q]):
            continue  # a point robot crosses by an inside length: not by touching (point 2)
            # or by a single point
        ref = not (np.any(d < radius) if radius > 0 else np.any(d <= 0))
        assert free[q] == ref, (seg, d)
        checked += 1
    assert checked > 700 and 0.2 < free[sub].mean() < 0.8
    assert sw.pairs_free(pts, i[:0], j[:0], _free_space(obs)).shape == (0,)
    assert sw.pairs_free(pts, i, j, _free_space(None)).all()


def test_near_item_screen_is_the_clamped_projection_test():
    """The bounding-circle screen divides only inside the segment: the same answers as
    ``clamp01(p / dd)`` (projections before, at and beyond the ends, point segments)."""
    from optplan.geometry.collision import kernel

    rng = np.random.default_rng(2)
    IC = rng.uniform(-10, 10, (60, 2))
    IC[:4] = [[0.0, 1.0], [3.0, 1.0], [4.0, 0.5], [-1.0, 0.0]]  # p = 0, p = dd, beyond
    IR = rng.uniform(0, 3, 60)
    segs = np.vstack([rng.uniform(-10, 10, (200, 4)), [[0, 0, 3, 0], [1, 1, 0, 0]]])
    for ax, ay, dx, dy in segs:
        dd = dx * dx + dy * dy
        for k in range(len(IC)):
            wx, wy = IC[k, 0] - ax, IC[k, 1] - ay
            t = min(max((wx * dx + wy * dy) / dd, 0.0), 1.0) if dd > 0 else 0.0
            fx, fy = wx - t * dx, wy - t * dy
            ref = fx * fx + fy * fy <= (IR[k] + 0.5) ** 2
            assert kernel._near_item(ax, ay, dx, dy, k, IC, IR, 0.5) == ref


def test_pairs_free_with_the_grid_on_many_obstacles():
    rng = np.random.default_rng(1)
    prob = _many_obstacles(rng)
    pts = rng.uniform(0, 100, (150, 2))
    i, j = np.triu_indices(len(pts), 1)
    keep = np.hypot(*(pts[i] - pts[j]).T) < 25.0  # short segments: some are free
    i, j = i[keep], j[keep]
    for grid in (False, True):
        obs = obstacle_set(prob.obstacles, 0.5, prob.frame, grid=grid, walls=False)
        free = sw.pairs_free(pts, i, j, _free_space(obs))
        np.testing.assert_array_equal(free, obs.segment_free(pts[i], pts[j]))
        assert 0.05 < free.mean() < 0.95
        for q in np.flatnonzero(free)[:40]:  # free: shapely finds every obstacle >= 0.5 away
            seg = pts[[i[q], j[q]]]
            assert min(_raw_distance(seg, o) for o in prob.obstacles) >= 0.5 - 1e-7


def test_fitness_kernel_decides_like_the_validator_at_rounded_corners():
    """The fitness uses the validator's exact disc test (on the known obstacles), so a
    fitness-feasible path is validator-feasible, also where the free space has rounded corners."""
    prob = _hexagon_problem()
    r = 2.0
    obs = sw.make_space(prob, dataclasses.replace(prob.robots[0], radius=r), 1).obstacles
    rng = np.random.default_rng(1)
    segs = rng.uniform(0, 100, (6000, 2, 2))
    # plus segments grazing the rounded corners
    corners = np.array([[40.0, 30.0], [60.0, 40.0], [90.0, 80.0]])
    ang = rng.uniform(0, 2 * np.pi, 3000)
    c = corners[rng.integers(0, 3, 3000)]
    dist = r * rng.uniform(0.97, 1.03, 3000)
    foot = c + dist[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    tang = np.stack([-np.sin(ang), np.cos(ang)], axis=1)
    near = np.stack([foot - 3 * tang, foot + 3 * tang], axis=1)
    segs = np.concatenate([segs, near])
    fit = obs.crossings(segs).count
    val = prob.obstacle_set(r, walls=False).crossings(segs).count  # the engine, no wall
    np.testing.assert_array_equal(fit, val)
    assert np.any(fit[6000:] > 0) and np.any(fit[6000:] == 0)
    # a pinned case: 1.995 from a raw corner (the disc touches the corner): a collision
    th = np.deg2rad(180 + 39.375)  # lower-left corner (40, 30), pointing away from it
    f = np.array([40.0, 30.0]) + 1.995 * np.array([np.cos(th), np.sin(th)])
    t = np.array([-np.sin(th), np.cos(th)])
    seg = np.array([[f - 0.2 * t, f + 0.2 * t]])
    assert obs.crossings(seg).count[0] == 1


def test_convex_pieces_and_penetration():
    sq = shapely.box(0, 0, 10, 10)
    assert [len(v) for v, _ in convex_pieces(sq, PIECE_EDGES)] == [4]
    hexagon = shapely.Point(0, 0).buffer(5, quad_segs=2).convex_hull  # 8 vertices
    pieces = [v for v, _ in convex_pieces(hexagon, PIECE_EDGES)]
    assert all(3 <= len(v) <= PIECE_EDGES for v in pieces)
    assert sum(shapely.Polygon(v).area for v in pieces) == pytest.approx(hexagon.area)
    u = shapely.Polygon([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]])
    pieces = [v for v, _ in convex_pieces(u, PIECE_EDGES)]
    assert sum(shapely.Polygon(v).area for v in pieces) == pytest.approx(u.area)
    assert all(shapely.Polygon(v).exterior.is_ccw for v in pieces)
    # penetration: r - distance outside, r + inside length through the raw obstacle
    prob = _problem(obstacles=[{"type": "rectangle", "min": [40.0, 30.0], "max": [60.0, 70.0]}])
    obs = obstacle_set(prob.obstacles, 2.0, prob.frame, walls=False)
    res = obs.crossings(np.array([[[30.0, 50.0], [70.0, 50.0]], [[30.0, 71.5], [70.0, 71.5]],
                                  [[30.0, 80.0], [70.0, 80.0]]]))
    assert res.count.tolist() == [1, 1, 0]
    np.testing.assert_allclose(res.penetration, [2.0 + 20.0, 0.5, 0.0])


def test_obstacle_set_empty_map_and_single_point():
    prob = _problem()
    obs = obstacle_set([], 1.0, prob.frame, walls=False)
    res = obs.crossings(np.zeros((3, 4, 2)), details=True)
    assert res.count.tolist() == [0, 0, 0] and res.seg_count.shape == (3, 3)
    one = obstacle_set(prob.obstacles, 1.0, prob.frame,
                       walls=False).crossings(np.array([[5.0, 5.0]]))
    assert one.count.tolist() == [0]


# ---------------------------------------------------------------------------------------
# fitness (eqs 31-33)
# ---------------------------------------------------------------------------------------


def test_fitness_is_length_plus_penalty_times_crossings():
    prob = _problem()
    space = sw.make_space(prob, prob.robots[0], 2, penalty_weight=100.0)
    X = np.array([[30.0, 50.0, 70.0, 50.0],      # straight through the rectangle: 1 crossing
                  [40.0, 80.0, 60.0, 78.0]])     # over the top (clear of the rectangle)
    ev = sw.evaluate_swarm(X, space)
    paths = sw.decode(X, space)
    L = np.hypot(*np.diff(paths, axis=1).transpose(2, 0, 1)).sum(axis=1)
    np.testing.assert_allclose(ev.length, L)
    assert ev.count.tolist() == [1, 0]
    np.testing.assert_allclose(ev.cost, L + 100.0 * ev.count)
    # the penetration term (beyond the paper) adds weight x inside length
    space2 = sw.make_space(prob, prob.robots[0], 2, penalty_weight=100.0, penetration_weight=2.0)
    ev2 = sw.evaluate_swarm(X, space2)
    np.testing.assert_allclose(ev2.cost, ev.cost + 2.0 * ev2.penetration)
    assert ev2.penetration[0] == pytest.approx(21.0)  # r + inside length of the raw obstacle


def test_fitness_calls_the_kernel_once_per_evaluation(monkeypatch):
    prob = _problem()
    space = sw.make_space(prob, prob.robots[0], 3)
    # the fitness kernel is the problem's (cached) obstacle set for the robot's radius
    assert space.obstacles is prob.obstacle_set(prob.robots[0].radius, known_only=True,
                                                walls=False)
    calls = []
    real = type(space.obstacles).crossings

    def spy(self, paths, *a, **k):
        calls.append((np.asarray(paths).shape, k))
        return real(self, paths, *a, **k)

    monkeypatch.setattr(type(space.obstacles), "crossings", spy)
    X = ops.initial_swarm(space, 50, "uniform", np.random.default_rng(0))
    ev = sw.evaluate_swarm(X, space)
    assert calls == [((50, 5, 2), {"penetration": False})]
    assert ev.count.sum() > 0  # uniform waypoints among six obstacles: some collide
    # the validator's test on the same paths gives the same counts
    val = prob.obstacle_set(1.0, walls=False).crossings(sw.decode(X, space),
                                                    penetration=False).count
    np.testing.assert_array_equal(ev.count, val)


def test_fitness_without_obstacles_counts_no_crossings():
    prob = _problem(obstacles=[])
    space = sw.make_space(prob, prob.robots[0], 2, penetration_weight=1.0)
    X = ops.initial_swarm(space, 8, "uniform", np.random.default_rng(0))
    ev = sw.evaluate_swarm(X, space)
    assert ev.count.tolist() == [0] * 8 and ev.penetration.tolist() == [0.0] * 8
    np.testing.assert_allclose(ev.cost, ev.length)
    # and the same with no obstacle set at all
    bare = sw.SwarmSpace(space.start, space.goal, 2, space.lo, space.hi, None,
                         space.penalty_weight, 1.0)
    ev2 = sw.evaluate_swarm(X, bare)
    np.testing.assert_array_equal(ev2.cost, ev.cost)
    assert ev2.count.tolist() == [0] * 8
    assert sw.segment_free(X[:, :2], X[:, 2:], bare).all()


def test_default_penalty_makes_every_feasible_path_win():
    prob = _problem()
    n = 3
    space = sw.make_space(prob, prob.robots[0], n)
    assert space.penalty_weight == pytest.approx((n + 1) * math.hypot(100, 100))
    rng = np.random.default_rng(1)
    X = ops.initial_swarm(space, 4000, "uniform", rng)
    # the worst case a feasible path can reach: zig-zag between opposite corners
    X[0] = [0, 0, 100, 100, 0, 0]
    ev = sw.evaluate_swarm(X, space)
    feas, coll = ev.count == 0, ev.count > 0
    assert feas.any() and coll.any()
    assert ev.cost[feas].max() < ev.cost[coll].min()


# ---------------------------------------------------------------------------------------
# particle operations
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ops.BOUNDS_MODES)
def test_bounds_handling_keeps_particles_inside(mode):
    lo, hi = np.zeros(4), np.array([10.0, 20.0, 10.0, 20.0])
    X = np.array([[-3.0, 5.0, 12.0, 45.0], [1.0, 2.0, 3.0, 4.0]])
    V = np.ones_like(X)
    Xn, Vn = ops.handle_bounds(X, V, lo, hi, mode, np.random.default_rng(0))
    assert np.all((Xn >= lo) & (Xn <= hi))
    np.testing.assert_array_equal(Xn[1], X[1])  # inside: untouched
    np.testing.assert_array_equal(Vn[1], V[1])
    if mode == "reflect":
        np.testing.assert_allclose(Xn[0], [3.0, 5.0, 8.0, 5.0])  # 45 -> 40-45 -> ... -> 5
        np.testing.assert_array_equal(Vn[0], [-1, 1, -1, -1])
    elif mode == "clip":
        np.testing.assert_allclose(Xn[0], [0.0, 5.0, 10.0, 20.0])
        np.testing.assert_array_equal(Vn[0], [0, 1, 0, 0])


@pytest.mark.parametrize("mode", ops.INIT_MODES)
def test_initial_swarm(mode):
    prob = _problem()
    space = sw.make_space(prob, prob.robots[0], 5)
    X = ops.initial_swarm(space, 30, mode, np.random.default_rng(0))
    assert X.shape == (30, 10)
    assert np.all((X >= space.lo) & (X <= space.hi))
    if mode == "sorted":
        W = X.reshape(30, 5, 2)
        proj = (W - space.start) @ (space.goal - space.start)
        assert np.all(np.diff(proj, axis=1) >= 0)


def test_resample_path_keeps_every_vertex_or_follows_the_arc_length():
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    q = resample_path(path, 5)
    assert q.shape == (6, 2)
    np.testing.assert_array_equal(q[[0, -1]], path[[0, -1]])
    assert np.hypot(*np.diff(q, axis=0).T).sum() == pytest.approx(20.0)
    assert any(np.allclose(p, [10.0, 0.0]) for p in q)  # the corner is kept
    # segments split in proportion to their length (largest remainder): 3 + 2 for 12 : 8
    q = resample_path(np.array([[0.0, 0.0], [12.0, 0.0], [12.0, 8.0]]), 5)
    np.testing.assert_allclose(q, [[0, 0], [4, 0], [8, 0], [12, 0], [12, 4], [12, 8]])
    # consecutive duplicates are dropped
    d = resample_path(np.array([[0.0, 0.0], [0.0, 0.0], [4.0, 0.0]]), 2)
    np.testing.assert_allclose(d, [[0, 0], [2, 0], [4, 0]])
    # more segments than asked: evenly spaced by arc length
    many = np.column_stack([np.linspace(0, 10, 20), np.zeros(20)])
    np.testing.assert_allclose(resample_path(many, 5)[:, 0], [0, 2, 4, 6, 8, 10])


def test_converged_iteration_definition():
    best = np.array([100.0, 50.0, 20.0, 10.005, 10.0, 10.0])
    assert be.converged_iteration(best) == 3  # first within 0.1 % of 10
    assert be.converged_iteration(np.array([5.0, 5.0])) == 0
    assert be.converged_iteration(np.array([])) == 0


# ---------------------------------------------------------------------------------------
# end-to-end through the shared driver
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", ["pso", "mpso", "ipso"])
def test_history_and_extras(backend):
    prob = _problem()
    res = op.solve(prob, backend, rng=1, n_particles=20, k_max=30, penetration_weight=1.0)
    h = res.history
    # the ipso preset adds one row for its final tightening (not an iteration)
    assert len(h) == 31 + ("tightened" in h)
    assert np.all(np.diff(h["best_cost"]) <= 1e-12)  # gbest never gets worse
    for col in ("iteration", "best_cost", "feasible_best_length", "n_eval", "time"):
        assert col in h
    assert h["n_eval"][-1] == res.n_eval
    # over the swarm iterations 0..k_max (not the final tightening row)
    assert res.extras["converged_iteration"] == be.converged_iteration(h["best_cost"][:31])
    assert res.n_iter == 30
    if res.success:
        assert res.metrics["length"] == pytest.approx(h["feasible_best_length"][-1])


def test_multi_robot_without_formation_plans_every_robot():
    prob = _problem(robots=[
        {"id": "a", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 1.0, "max_speed": 1},
        {"id": "b", "start": [10.0, 5.0], "goal": [90.0, 5.0], "radius": 1.0, "max_speed": 1},
    ])
    res = op.solve(prob, "pso", rng=0, n_particles=20, k_max=20)
    assert set(res.paths) == {"a", "b"}
    for rid, path in res.paths.items():
        np.testing.assert_allclose(path[0], prob.robot(rid).start)
    assert set(res.extras["per_robot"]) == {"a", "b"}


def test_path_buffer_particles_are_views_of_the_polylines():
    prob = _problem()
    space = sw.make_space(prob, prob.robots[0], 3)
    buf = sw.PathBuffer(space, 5)
    X = np.random.default_rng(0).random((5, 6)) * 10
    buf.X(7)[:] = X  # odd iteration -> batch 1; batch 0 untouched
    np.testing.assert_array_equal(buf.paths(1), sw.decode(X, space))
    assert not np.shares_memory(buf.X(0), buf.X(1))
    ev = sw.evaluate_paths(buf.paths(1), space)
    ref = sw.evaluate_swarm(X, space)
    np.testing.assert_array_equal(ev.cost, ref.cost)


@pytest.mark.parametrize("option", ["engine", "kernel", "snap", "redistribute", "local_trials"])
def test_removed_swarm_options_are_unknown(option):
    """One fitness kernel, one implementation: ``engine`` and ``kernel`` are not options; the
    beyond-the-paper moves ``snap``, ``redistribute`` and ``local_trials`` were removed."""
    with pytest.raises(ValueError, match=option):
        op.get_solver("ipso-paper", **{option: 1})
    res = op.solve("open-field", "ipso-paper", rng=0, k_max=3)
    assert "engine" not in res.extras["per_robot"]["r1"]


# ---------------------------------------------------------------------------------------
# homotopy signatures, the sparse roadmap and its corridors (beyond the paper)
# ---------------------------------------------------------------------------------------


def _wall() -> op.Problem:
    return _problem(obstacles=[{"type": "rectangle", "min": [45.0, 20.0], "max": [55.0, 70.0]}])


def test_signature_hashes_tell_the_sides_of_an_obstacle_apart():
    prob = _wall()
    space = sw.make_space(prob, prob.robots[0], 2)
    above = np.array([[10.0, 50.0], [40.0, 80.0], [60.0, 80.0], [90.0, 50.0]])
    above2 = np.array([[10.0, 50.0], [30.0, 90.0], [70.0, 75.0], [90.0, 50.0]])
    below = np.array([[10.0, 50.0], [40.0, 10.0], [60.0, 10.0], [90.0, 50.0]])
    h = sig.signature_hashes(np.stack([above, above2, below]), space)
    assert h[0] == h[1] != h[2]
    # a loop around the wall is a third class; the list variant pads unequal lengths
    loop = np.array([[10.0, 50.0], [40.0, 80.0], [60.0, 80.0], [60.0, 10.0], [40.0, 10.0],
                     [40.0, 80.0], [60.0, 80.0], [90.0, 50.0]])
    hl = sig.signature_hashes_list([above, below, loop], space)
    assert hl[0] == h[0] and hl[1] == h[2] and len(set(hl.tolist())) == 3


def test_k_classes_label_search_on_a_hand_graph():
    # start 0 -> goal 1 around a point obstacle at the origin: over (node 2) or under (3)
    nodes = np.array([[-2.0, 0.0], [2.0, 0.0], [0.0, 1.0], [0.0, -3.0]])
    edges = [(0, 2), (2, 1), (0, 3), (3, 1)]
    keys = np.array([7], np.int64)
    i = np.array([a for a, _ in edges])
    j = np.array([b for _, b in edges])
    eh = sig._segment_hashes(nodes[i], nodes[j], np.zeros((1, 2)), keys)
    src, dst = np.concatenate([i, j]), np.concatenate([j, i])
    order = np.argsort(src, kind="stable")
    indptr = np.searchsorted(src[order], np.arange(5)).astype(np.int64)
    w = np.hypot(*(nodes[src] - nodes[dst]).T)[order]
    h = np.concatenate([eh, -eh])[order]
    heur = np.hypot(*(nodes - nodes[1]).T)
    goals, lab_node, lab_par = rm._k_classes((indptr, dst[order], w, h), heur, 0, 1, 3, 3, np.inf)
    walks = []
    for g in goals:
        seq, lab = [], int(g)
        while lab >= 0:
            seq.append(int(lab_node[lab]))
            lab = int(lab_par[lab])
        walks.append(seq[::-1])
    assert walks[:2] == [[0, 2, 1], [0, 3, 1]]  # shortest first, both classes
    # the slack bound drops the longer class
    goals, *_ = rm._k_classes((indptr, dst[order], w, h), heur, 0, 1, 3, 3, 1.1)
    assert len(goals) == 1


def test_roadmap_corridors_are_distinct_collision_free_classes():
    prob = _wall()
    space = sw.make_space(prob, prob.robots[0], 4)
    cor = rm.roadmap_corridors(space, 6, np.random.default_rng(0), n_samples=20,
                               boundary=60, medial=20, slack=1.5)
    assert len(cor) >= 2
    h = sig.signature_hashes_list(cor, space)
    assert len(set(h.tolist())) == len(cor)
    for p in cor:
        np.testing.assert_allclose(p[[0, -1]], [space.start, space.goal])
        segs = np.stack([p[:-1], p[1:]], axis=1)
        assert space.clear.crossings(segs, penetration=False).count.sum() == 0
    # the wall is passed on both sides (over it, under it)
    over = [bool(np.any(p[:, 1] > 70.0)) for p in cor]
    under = [bool(np.any(p[:, 1] < 20.0)) for p in cor]
    assert any(o and not u for o, u in zip(over, under))
    assert any(u and not o for o, u in zip(over, under))
    # the default slack (1.1) keeps only classes at most 10 % longer than the shortest walk
    assert len(rm.roadmap_corridors(space, 6, np.random.default_rng(0), n_samples=20,
                                    boundary=60, medial=20)) < len(cor)


def test_roadmap_samples_lie_beside_the_obstacles_and_in_narrow_gaps():
    # two boxes 3.5 robot diameters apart: a narrow passage around x = 50
    prob = _problem(obstacles=[{"type": "rectangle", "min": [20.0, 40.0], "max": [46.5, 60.0]},
                               {"type": "rectangle", "min": [53.5, 40.0], "max": [80.0, 60.0]}])
    space = sw.make_space(prob, prob.robots[0], 4)
    rng = np.random.default_rng(1)
    b = smp.boundary_samples(space, 400, rng)
    d = space.obstacles.point_distances(b)
    # beside, not far from, the obstacles (a few land in the other box: filtered later)
    assert np.mean(d >= 1.0 - 1e-9) > 0.8 and np.median(d) < 5.0
    m = smp.medial_samples(space, 200, rng)
    assert len(m) and np.all(space.clear.segment_free(m, m))
    gap = (np.abs(m[:, 0] - 50.0) < 0.5) & (m[:, 1] > 40.0) & (m[:, 1] < 60.0)
    assert gap.sum() >= 3  # on the passage's centre line
    nodes, corner = smp.roadmap_nodes(space, 20, rng, 40, 20)
    assert corner[:2].all() and len(nodes) == len(corner)
    np.testing.assert_array_equal(nodes[:2], [space.start, space.goal])


def test_tighten_keeps_the_clearance_margin():
    prob = _wall()
    space = sw.make_space(prob, prob.robots[0], 2)
    detour = np.array([[10.0, 50.0], [10.0, 95.0], [90.0, 95.0], [90.0, 50.0]])
    (p,), _ = rf.tighten([detour], space, rounds=40)
    margin = sw.CLEAR_MARGIN * space.diag
    c = space.obstacles.clearance(np.stack([p[:-1], p[1:]], axis=1))
    assert c.min() >= margin * (1 - 1e-6)
    assert c.min() < 1e-3 * space.diag  # pressed onto the wall's corners


def test_roadmap_slack_pruning_skips_tests_but_not_walks(monkeypatch):
    """The corner pairs outside the start-goal ellipse of slack x the neighbour graph's
    shortest walk are not tested, and the class search returns the same corridors."""
    from optplan.generators import corridor_scene

    prob = corridor_scene("shelves", 1)
    space = sw.make_space(prob, prob.planned_robots[0], 8)
    tested = []
    real = sw.pairs_free

    def counting(pts, i, j, sp):
        tested.append(len(i))
        return real(pts, i, j, sp)

    monkeypatch.setattr(sw, "pairs_free", counting)  # node tests (segment_free)
    monkeypatch.setattr(rm, "pairs_free", counting)  # edge tests
    full = rm.build_roadmap(space, np.random.default_rng(3), 40, 25, 360, 200, None)
    n_full = sum(tested)
    tested.clear()
    pruned = rm.build_roadmap(space, np.random.default_rng(3), 40, 25, 360, 200, 1.1)
    assert sum(tested) < 0.9 * n_full  # long corner pairs far from the line are skipped
    assert len(pruned.target) < len(full.target)
    orig = rm.build_roadmap
    got = {}
    for slack in (1.1, None):
        monkeypatch.setattr(rm, "build_roadmap",
                            lambda *a, s=slack: orig(*a[:6], s))
        got[slack] = rm.roadmap_corridors(space, 30, np.random.default_rng(3), 40, 25, 360,
                                          200)
    assert len(got[1.1]) == len(got[None]) > 1
    for a, b in zip(got[1.1], got[None]):
        np.testing.assert_array_equal(a, b)
