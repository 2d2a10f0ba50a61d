"""Shared swarm machinery: encoding, fitness, fast crossing kernel, bounds, bookkeeping."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.backends import swarm as sw
from optplan.geometry import batch_crossings, inflate


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
# fast kernel == geometry.batch_crossings (twin test)
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("n_copies", [1, 400])  # 400 copies force the bounding-box branch
def test_fast_crossings_matches_batch_crossings(n_copies):
    prob = _problem()
    imap = prob.inflated(1.0)
    kern = sw.make_kernel(imap)
    rng = np.random.default_rng(3)
    paths = rng.uniform(-5, 105, (60, 5, 2))
    # special cases: along an inflated edge, through vertices, inside, degenerate segments
    verts = np.asarray(imap.parts[0].exterior.coords)
    paths[0, :] = verts[:5]
    paths[1, :] = np.array([[10, 50], [50, 50], [50, 50], [90, 50], [90, 50]])
    paths[2, :] = np.array([[41, 31], [59, 69], [41, 69], [59, 31], [50, 50]])
    paths[3, :] = np.array([[10, 71 + 1e-12], [90, 71], [90, 71], [90, 29], [10, 29]])
    batch = np.repeat(paths, n_copies, axis=0)
    ref = batch_crossings(batch, imap)
    count, pen = sw.fast_crossings(batch, kern)
    np.testing.assert_array_equal(count, ref.count)
    np.testing.assert_allclose(pen, ref.penetration, rtol=1e-9, atol=1e-9)


def test_fast_crossings_empty_map_and_single_point():
    prob = _problem(obstacles=[])
    kern = sw.make_kernel(prob.inflated(1.0))
    c, p = sw.fast_crossings(np.zeros((3, 4, 2)), kern)
    assert c.tolist() == [0, 0, 0] and p.tolist() == [0, 0, 0]


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
    np.testing.assert_allclose(ev2.cost, ev.cost + 2.0 * ev.penetration)
    assert ev.penetration[0] == pytest.approx(22.0, abs=0.05)  # 20 + 2 x radius


def test_geometry_kernel_calls_batch_crossings_once(monkeypatch):
    prob = _problem()
    space = sw.make_space(prob, prob.robots[0], 3, kernel="geometry")
    calls = []
    real = sw.batch_crossings

    def spy(paths, imap, *a, **k):
        calls.append(np.asarray(paths).shape)
        return real(paths, imap, *a, **k)

    monkeypatch.setattr(sw, "batch_crossings", spy)
    X = sw.initial_swarm(space, 50, "uniform", np.random.default_rng(0))
    ev = sw.evaluate_swarm(X, space)
    assert calls == [(50, 5, 2)]
    fast = sw.evaluate_swarm(X, sw.make_space(prob, prob.robots[0], 3, kernel="fast"))
    np.testing.assert_array_equal(ev.count, fast.count)
    np.testing.assert_allclose(ev.cost, fast.cost)


def test_default_penalty_makes_every_feasible_path_win():
    prob = _problem()
    n = 3
    space = sw.make_space(prob, prob.robots[0], n)
    assert space.penalty_weight == pytest.approx((n + 1) * math.hypot(100, 100))
    rng = np.random.default_rng(1)
    X = sw.initial_swarm(space, 4000, "uniform", rng)
    # the worst case a feasible path can reach: zig-zag between opposite corners
    X[0] = [0, 0, 100, 100, 0, 0]
    ev = sw.evaluate_swarm(X, space)
    feas, coll = ev.count == 0, ev.count > 0
    assert feas.any() and coll.any()
    assert ev.cost[feas].max() < ev.cost[coll].min()


def test_coarse_map_contains_the_validator_map():
    prob = _problem()
    exact = sw.make_space(prob, prob.robots[0], 3)
    coarse = sw.make_space(prob, prob.robots[0], 3, map_quad_segs=2)
    X = sw.initial_swarm(exact, 3000, "uniform", np.random.default_rng(2))
    e, c = sw.evaluate_swarm(X, exact), sw.evaluate_swarm(X, coarse)
    # collision-free on the coarse map => collision-free on the validator's map
    assert np.all(e.count[c.count == 0] == 0)
    assert coarse.imap.edge_mask.sum() < exact.imap.edge_mask.sum()
    assert inflate(prob.obstacles, 1.0).n == exact.imap.n


# ---------------------------------------------------------------------------------------
# particle operations
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", sw.BOUNDS_MODES)
def test_bounds_handling_keeps_particles_inside(mode):
    lo, hi = np.zeros(4), np.array([10.0, 20.0, 10.0, 20.0])
    X = np.array([[-3.0, 5.0, 12.0, 45.0], [1.0, 2.0, 3.0, 4.0]])
    V = np.ones_like(X)
    Xn, Vn = sw.handle_bounds(X, V, lo, hi, mode, np.random.default_rng(0))
    assert np.all((Xn >= lo) & (Xn <= hi))
    np.testing.assert_array_equal(Xn[1], X[1])  # inside: untouched
    np.testing.assert_array_equal(Vn[1], V[1])
    if mode == "reflect":
        np.testing.assert_allclose(Xn[0], [3.0, 5.0, 8.0, 5.0])  # 45 -> 40-45 -> ... -> 5
        np.testing.assert_array_equal(Vn[0], [-1, 1, -1, -1])
    elif mode == "clip":
        np.testing.assert_allclose(Xn[0], [0.0, 5.0, 10.0, 20.0])
        np.testing.assert_array_equal(Vn[0], [0, 1, 0, 0])


@pytest.mark.parametrize("mode", sw.INIT_MODES)
def test_initial_swarm(mode):
    prob = _problem()
    space = sw.make_space(prob, prob.robots[0], 5)
    X = sw.initial_swarm(space, 30, mode, np.random.default_rng(0))
    assert X.shape == (30, 10)
    assert np.all((X >= space.lo) & (X <= space.hi))
    if mode == "sorted":
        W = X.reshape(30, 5, 2)
        proj = (W - space.start) @ (space.goal - space.start)
        assert np.all(np.diff(proj, axis=1) >= 0)


def test_resample_path_keeps_a_path_with_few_bends_exactly():
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    w = sw.resample_path(path, 4)
    assert w.shape == (4, 2)
    full = np.vstack([path[0], w, path[-1]])
    assert np.hypot(*np.diff(full, axis=0).T).sum() == pytest.approx(20.0)
    assert any(np.allclose(p, [10.0, 0.0]) for p in w)  # the corner is kept
    many = np.column_stack([np.linspace(0, 10, 20), np.zeros(20)])
    np.testing.assert_allclose(sw.resample_path(many, 4)[:, 0], [2, 4, 6, 8])


def test_converged_iteration_definition():
    best = np.array([100.0, 50.0, 20.0, 10.005, 10.0, 10.0])
    assert sw.converged_iteration(best) == 3  # first within 0.1 % of 10
    assert sw.converged_iteration(np.array([5.0, 5.0])) == 0
    assert sw.converged_iteration(np.array([])) == 0


# ---------------------------------------------------------------------------------------
# end-to-end through the shared driver
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", ["pso", "mpso", "ipso"])
def test_history_and_extras(backend):
    prob = _problem()
    res = op.solve(prob, backend, rng=1, n_particles=20, k_max=30, penetration_weight=1.0)
    h = res.history
    assert len(h) == 31
    assert np.all(np.diff(h["best_cost"]) <= 1e-12)  # gbest never gets worse
    for col in ("iteration", "best_cost", "feasible_best_length", "n_eval", "time"):
        assert col in h
    assert h["n_eval"][-1] == res.n_eval
    assert res.extras["converged_iteration"] == sw.converged_iteration(h["best_cost"])
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
