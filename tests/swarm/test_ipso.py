"""IPSO formulas (eqs 17-29) pinned by hand, PSO/MPSO operators, determinism, behaviour."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.geometry.collision.polyline import resample_path
from optplan.swarm import backend as be
from optplan.swarm import core as sw
from optplan.swarm import ga
from optplan.swarm import ipso as ip
from optplan.swarm import operators as ops
from optplan.swarm import refine as rf
from optplan.swarm import signatures as sig
from optplan.swarm.mpso import MPSO, mutate_one_coordinate, refine_trials
from optplan.swarm.pso import PSO, pso_step

# ---------------------------------------------------------------------------------------
# eqs 17-21: adaptive inertia weight
# ---------------------------------------------------------------------------------------


def test_eq18_alpha():
    assert ip.inertia_alpha(0.9) == pytest.approx(math.log(0.1 / 0.9))
    assert ip.inertia_alpha(0.5) == 0.0


def test_eq17_inertia_weight_pins():
    # dw = 1 -> w_max; dw = 0 -> 0.5
    assert ip.inertia_weight(1.0, 0.9) == pytest.approx(0.9)
    assert ip.inertia_weight(0.0, 0.9) == pytest.approx(0.5)
    # hand computation: alpha = ln(1/9), dw = 0.5 -> 1 / (1 + 9^-0.5) = 1 / (1 + 1/3) = 0.75
    assert ip.inertia_weight(0.5, 0.9) == pytest.approx(0.75)
    # monotone increasing in dw for w_max > 0.5
    ws = [ip.inertia_weight(d, 0.9) for d in np.linspace(0, 1, 11)]
    assert np.all(np.diff(ws) > 0)


def test_eq19_to_21():
    delta = ip.inertia_delta(0.9, 0.2, 200)
    assert delta == pytest.approx(0.7 / 200)  # eq 20
    assert ip.velocity_ratio(2.0, 4.0) == pytest.approx(1.5)  # eq 21: (2 + 4) / (2 * 2)
    assert ip.velocity_ratio(4.0, 2.0) == pytest.approx(0.75)
    assert ip.velocity_ratio(3.0, 3.0) == 1.0  # constant speed: dw = delta (eq 19)
    assert ip.velocity_ratio(0.0, 3.0) == 1.0  # undefined -> 1
    # literal reading: with the paper's settings w stays ~0.5 (documented ambiguity)
    assert ip.inertia_weight(delta * 1.0, 0.9) == pytest.approx(0.5019, abs=1e-4)


def test_linear_inertia_reading_goes_from_wmax_to_wmin():
    prob = _corridor()
    res = op.solve(prob, "ipso", rng=0, inertia="linear", k_max=40, n_particles=10)
    w = res.history["w"][1:41]  # (a final tightening row, if any, has no w)
    assert w[0] == pytest.approx(0.9)
    assert w.min() >= 0.2 - 1e-12 and np.all(np.diff(w) <= 1e-12)
    res2 = op.solve(prob, "ipso", rng=0, inertia="paper", k_max=40, n_particles=10)
    w2 = res2.history["w"][1:41]
    assert np.all(w2 >= 0.5) and np.all(w2 <= 0.9)


# ---------------------------------------------------------------------------------------
# eq 23: position factor
# ---------------------------------------------------------------------------------------


def test_eq23_position_factor():
    assert ip.position_factor(0, 200) == 1.0
    assert ip.position_factor(200, 200) == pytest.approx(1 - math.tanh(200 / 201))
    assert ip.position_factor(200, 200) == pytest.approx(0.24050, abs=1e-5)
    k = np.arange(201)
    assert np.all(np.diff(ip.position_factor(k, 200)) < 0)


# ---------------------------------------------------------------------------------------
# eqs 25-29: crossover and greedy mutation
# ---------------------------------------------------------------------------------------


def _pair_sharing_waypoints_1_and_4():
    """Two hand-made 6-waypoint particles: waypoints 1 and 4 (0-based) coincide, the rest
    differ (parent 1 above the x axis, parent 2 below)."""
    xs = np.arange(1.0, 7.0) * 10
    p1 = np.c_[xs, np.full(6, 5.0)]
    p2 = np.c_[xs, np.full(6, -5.0)]
    p2[1] = p1[1]
    p2[4] = p1[4] + 0.01  # near-identical
    return p1.ravel(), p2.ravel()


def test_swap_crossover_exchanges_the_fragment_between_shared_waypoints():
    x1, x2 = _pair_sharing_waypoints_1_and_4()
    tol2 = 0.1 ** 2
    assert ga.shared_fragment(x1, x2, tol2) == (2, 4)  # waypoints 2, 3 lie between 1 and 4
    v1, v2 = np.ones(12), -np.ones(12)
    frag = np.array([[2, 4]])
    c1x, c2x, c1v, c2v = ga.swap_fragments(x1[None], x2[None], v1[None], v2[None], frag)
    inside = np.zeros(12, bool)
    inside[4:8] = True  # coordinates of waypoints 2 and 3
    np.testing.assert_array_equal(c1x[0][inside], x2[inside])  # fragment from parent 2
    np.testing.assert_array_equal(c1x[0][~inside], x1[~inside])  # the rest from parent 1
    np.testing.assert_array_equal(c2x[0][inside], x1[inside])
    np.testing.assert_array_equal(c2x[0][~inside], x2[~inside])
    np.testing.assert_array_equal(c1v[0], np.where(inside, -1.0, 1.0))
    np.testing.assert_array_equal(c2v[0], np.where(inside, 1.0, -1.0))
    # the two children hold exactly the parents' waypoints between them (nothing blended)
    np.testing.assert_array_equal(np.sort(np.r_[c1x[0], c2x[0]]), np.sort(np.r_[x1, x2]))


def test_swap_fragment_runs_to_the_goal_after_a_single_shared_waypoint():
    x1, x2 = _pair_sharing_waypoints_1_and_4()
    x2 = x2.copy()
    x2[8:10] += 3.0  # waypoint 4 no longer shared: only waypoint 1 is
    assert ga.shared_fragment(x1, x2, 0.1 ** 2) == (2, 6)  # the tail after waypoint 1
    x3 = x1.copy()
    x3[:10] -= 7.0  # only the last waypoint shared: nothing between it and the goal
    assert ga.shared_fragment(x1, x3, 0.1 ** 2) == (0, 0)
    assert ga.shared_fragment(x1, x1 + 1.0, 0.1 ** 2) == (0, 0)  # nothing shared


def test_swap_mode_pairs_only_particles_with_a_fragment_and_swaps_it():
    x1, x2 = _pair_sharing_waypoints_1_and_4()
    far = x1 + 100.0
    X = np.vstack([x1, x2, far, far + 50.0])
    F = np.array([1.0, 2.0, 3.0, 4.0])
    pairs, isl, frag = ga.ga_pairs(F, X, 1, 4, 0.1 ** 2, True)
    np.testing.assert_array_equal(pairs, [[0, 1]])  # the far pair shares nothing
    np.testing.assert_array_equal(frag, [[2, 4]])
    V = np.zeros_like(X)
    out = np.zeros((4, 12))
    ga.ga_children(X, V, pairs, np.zeros(0), np.zeros((2, 12)), np.zeros(12), out, frag, True)
    c1, c2 = out[2], out[3]  # children after the m = 2 mutant rows (noise 0: mutants = children)
    np.testing.assert_array_equal(c1[4:8], x2[4:8])
    np.testing.assert_array_equal(c2[4:8], x1[4:8])
    np.testing.assert_array_equal(out[0], c1)


def test_ipso_paper_uses_the_swap_and_crosses():
    s = op.get_solver("ipso-paper")
    assert s.crossover == "swap"
    res = op.solve("paper-env1", "ipso-paper", rng=0, k_max=20)
    assert next(iter(res.extras["per_robot"].values()))["crossovers"] > 0


def test_eq25_28_children_are_the_stated_convex_combinations():
    x1, x2 = np.array([[0.0, 10.0, 4.0]]), np.array([[10.0, 0.0, 4.0]])
    v1, v2 = np.array([[1.0, 2.0, 3.0]]), np.array([[-1.0, 0.0, 1.0]])
    c1x, c2x, c1v, c2v = ga.crossover(x1, x2, v1, v2, np.array([0.3]))
    np.testing.assert_allclose(c1x, [[7.0, 3.0, 4.0]])   # 0.3 x1 + 0.7 x2
    np.testing.assert_allclose(c2x, [[3.0, 7.0, 4.0]])   # 0.7 x1 + 0.3 x2
    np.testing.assert_allclose(c1v, [[-0.4, 0.6, 1.6]])
    np.testing.assert_allclose(c2v, [[0.4, 1.4, 2.4]])
    # batch of pairs with different p_c; children sum to the parents' sum
    rng = np.random.default_rng(0)
    X1, X2, V1, V2 = (rng.normal(size=(5, 4)) for _ in range(4))
    pc = rng.random(5)
    a, b, c, d = ga.crossover(X1, X2, V1, V2, pc)
    np.testing.assert_allclose(a + b, X1 + X2)
    np.testing.assert_allclose(c + d, V1 + V2)
    np.testing.assert_allclose(a, pc[:, None] * X1 + (1 - pc[:, None]) * X2)


def test_eq29_greedy_mutation_keeps_the_better():
    keep = ga.greedy_mutation(np.array([5.0, 5.0, 5.0]), np.array([4.0, 6.0, 5.0]))
    assert keep.tolist() == [True, False, False]


# ---------------------------------------------------------------------------------------
# PSO (eqs 1-2) and MPSO operators
# ---------------------------------------------------------------------------------------


def test_eq1_2_pso_step():
    st = be.SwarmState(X=np.array([[1.0, 2.0]]), V=np.array([[0.5, -0.5]]), F=np.zeros(1),
                       pbest=np.array([[3.0, 2.0]]), pbest_f=np.zeros(1),
                       gbest=np.array([0.0, 0.0]), gbest_f=0.0, gbest_count=0)
    X, V = pso_step(st, 0.5, 1.5, 1.5, np.full(2, np.inf), np.random.default_rng(7))
    r = np.random.default_rng(7)
    eps, eta = r.random((1, 2)), r.random((1, 2))
    v = 0.5 * st.V + 1.5 * eps * (st.pbest - st.X) + 1.5 * eta * (st.gbest - st.X)
    np.testing.assert_allclose(V, v)
    np.testing.assert_allclose(X, st.X + v)


def test_mpso_mutation_and_refinement():
    rng = np.random.default_rng(0)
    X = np.zeros((20000, 6))
    lo, hi = -np.ones(6), np.ones(6) * 3
    Xn, hit = mutate_one_coordinate(X, lo, hi, 0.8, rng)
    assert abs(hit.mean() - 0.2) < 0.01  # probability 1 - p_t
    changed = (Xn != 0).sum(axis=1)
    assert np.all(changed[~hit] == 0) and np.all(changed[hit] <= 1)
    assert np.all((Xn >= lo) & (Xn <= hi))
    T = refine_trials(np.ones(4), np.full(4, 100.0), 0.056, 500, rng)
    assert np.all(np.abs(T - 1) <= 5.6 + 1e-12) and np.abs(T - 1).max() > 5.0


# ---------------------------------------------------------------------------------------
# behaviour, determinism, contract bits
# ---------------------------------------------------------------------------------------


def _corridor() -> op.Problem:
    return op.parse_problem({
        "name": "ipso-wall",
        "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 1.0,
                    "max_speed": 1.0}],
        "obstacles": [{"type": "rectangle", "min": [45.0, 20.0], "max": [55.0, 80.0]}],
    })


@pytest.mark.parametrize("solver", ["ipso-paper", "ipso", "pso-paper", "mpso-paper"])
def test_presets_find_a_collision_free_path_on_a_wall_map(solver):
    prob = _corridor()
    ref = op.solve(prob, "visgraph").metrics["length"]
    res = op.solve(prob, solver, rng=2, k_max=60)
    assert res.success, res.message
    assert res.metrics["collisions"] == 0
    # the literal eq 24 drags waypoints toward the origin: a looser bound (documented)
    assert res.metrics["length"] <= (1.5 if solver == "ipso-paper" else 1.2) * ref


@pytest.mark.parametrize("backend", [PSO, MPSO, ip.IPSO])
def test_same_seed_same_result_and_global_state_untouched(backend):
    prob = _corridor()
    b = backend(n_particles=12, k_max=15)
    np.random.seed(123)  # noqa: NPY002 - checking the legacy global state
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    r1 = op.solve(prob, b, rng=5)
    r2 = op.solve(prob, b, rng=5)
    after = np.random.get_state()[1]  # noqa: NPY002
    np.testing.assert_array_equal(before, after)
    np.testing.assert_array_equal(r1.path, r2.path)
    np.testing.assert_array_equal(r1.history["best_cost"], r2.history["best_cost"])
    r3 = op.solve(prob, b, rng=6)
    assert not np.array_equal(r1.history["best_cost"], r3.history["best_cost"])


def test_callback_stop_is_honoured():
    seen = []

    def cb(p):
        seen.append(p.iteration)
        if p.iteration >= 3:
            raise StopIteration

    res = op.solve(_corridor(), "ipso", rng=0, callback=cb, k_max=50, n_particles=10)
    assert seen == [0, 1, 2, 3]
    assert res.n_iter == 3 and res.extras["stopped_early"]


def test_init_path_seeds_a_particle():
    prob = _corridor()
    # over the wall with two bends: representable exactly by 6 waypoints (vertices kept)
    init = np.array([[10.0, 50.0], [43.0, 82.0], [57.0, 82.0], [90.0, 50.0]])
    L = float(np.hypot(*np.diff(init, axis=0).T).sum())
    res = op.solve(prob, "ipso", rng=0, init={"r": init}, k_max=0, n_particles=5,
                   n_waypoints=6, init_mode="sorted", tighten_rounds=0)
    # with no iterations the answer is the best initial particle: the seeded path (or a
    # random particle that is at least as short)
    assert res.success
    assert res.metrics["length"] <= L + 1e-9


@pytest.mark.parametrize("bad", [{"A": 3}, {"w_min": 0.95}, {"inertia": "cubic"},
                                 {"position_update": "x"}, {"n_waypoints": 0},
                                 {"bounds_mode": "wrap"}, {"c1": -1.0}])
def test_invalid_options_name_the_option(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        op.get_solver("ipso", **bad)


def test_paper_position_update_pulls_toward_the_origin():
    """Eq 24 as printed multiplies absolute coordinates by psi R < 1 (documented)."""
    prob = _corridor()
    space = sw.make_space(prob, prob.robots[0], 2)
    X0 = ops.initial_swarm(space, 30, "uniform", np.random.default_rng(0))
    V0 = np.zeros_like(X0)
    U = np.random.default_rng(1).random((3, 30, 4))
    lead = np.zeros(30, np.int64)
    Xn, Vn = np.empty_like(X0), np.empty_like(X0)
    # almost no velocity (v_max ~ 0): the pure pull of eq 24
    ip.move((X0, V0, X0), X0[:1], lead, (0.5, 1.5, 1.5), U, np.full(4, 1e-9),
            (1.0, 0, space.start, space.goal), (Xn, Vn))
    assert np.linalg.norm(Xn, axis=1).mean() < 0.6 * np.linalg.norm(X0, axis=1).mean()
    np.testing.assert_allclose(Xn, U[2] * X0, atol=1e-8)
    # on the step (mode 1): x + psi R v; in the start-goal frame (mode 2): lateral pull only
    ip.move((X0, V0, X0), X0[:1], lead, (0.5, 1.5, 1.5), U, np.full(4, 1e-9),
            (1.0, 1, space.start, space.goal), (Xn, Vn))
    np.testing.assert_allclose(Xn, X0, atol=1e-8)
    ip.move((X0, V0, X0), X0[:1], lead, (0.5, 1.5, 1.5), U, np.full(4, 1e-9),
            (1.0, 2, space.start, space.goal), (Xn, Vn))
    # the corridor's start-goal line is y = 50: x is kept, the offset from 50 is scaled
    np.testing.assert_allclose(Xn[:, 0::2], X0[:, 0::2], atol=1e-8)
    np.testing.assert_allclose(Xn[:, 1::2] - 50.0, U[2][:, 1::2] * (X0[:, 1::2] - 50.0),
                               atol=1e-8)


def test_velocity_update_is_eq_1_with_a_guide_per_particle():
    rng = np.random.default_rng(3)
    X, V, Pb = rng.random((4, 6)), rng.random((4, 6)), rng.random((4, 6))
    G = rng.random((2, 6))
    lead = np.array([0, 0, 1, 1])
    eps, eta = rng.random((4, 6)), rng.random((4, 6))
    vmax = np.full(6, 0.3)
    out = ops.velocity_update(V, X, Pb, G, lead, (0.7, 1.5, 2.0), eps, eta, vmax,
                              np.empty((4, 6)))
    ref = 0.7 * V + 1.5 * eps * (Pb - X) + 2.0 * eta * (G[lead] - X)
    np.testing.assert_array_equal(out, np.clip(ref, -vmax, vmax))


# ---------------------------------------------------------------------------------------
# beyond the paper: islands and the final tightening
# ---------------------------------------------------------------------------------------


def test_tighten_contracts_a_detour_onto_the_optimum():
    prob = _corridor()
    view = prob.known_view()
    space = sw.make_space(view, view.robots[0], 2)
    detour = np.array([[10.0, 50.0], [10.0, 95.0], [90.0, 95.0], [90.0, 50.0]])
    below = detour * [1.0, -1.0] + [0.0, 100.0]
    assert sw.evaluate_swarm(detour[1:-1].reshape(1, -1), space).count[0] == 0
    (path, other), n = rf.tighten([detour, below], space, rounds=40)
    L = float(np.hypot(*np.diff(path, axis=0).T).sum())
    ref = op.solve(prob, "visgraph").metrics["length"]
    assert n > 0
    assert L < float(np.hypot(*np.diff(detour, axis=0).T).sum())
    assert ref - 1e-6 <= L <= ref * 1.001  # the disc optimum is a hair above the polygon's
    assert op.evaluate(prob, {"r": path})["collisions"] == 0
    assert space.obstacles.crossings(path).count[0] == 0
    # the two sides of the wall: mirror images, tightened alike in one batch, each in its class
    assert float(np.hypot(*np.diff(other, axis=0).T).sum()) == pytest.approx(L, rel=1e-6)
    assert np.all(path[1:-1, 1] > 50) and np.all(other[1:-1, 1] < 50)
    h = sig.signature_hashes(np.stack([resample_path(path, 9),
                                      resample_path(other, 9)]), space)
    assert h[0] != h[1]


def test_island_worst_slots_and_sizes():
    F = np.array([5, 9, 1, 7, 3, 8, 2, 6, 4, 0, 11, 10], dtype=float)
    # island 0 = particles 0-3 (worst: 1, 3), island 2 = 8-11 (worst: 10, 11)
    slots = ip._worst_slots(F, np.array([0, 0, 2]), 3)
    assert slots.tolist() == [1, 3, 10]
    assert ip.IPSO(n_particles=10, islands=4).n_islands == 2  # largest divisor <= 4
    assert ip.IPSO(n_particles=5, islands=5).n_islands == 1
    assert ip.IPSO(n_particles=50, islands=1).n_islands == 1


def test_islands_follow_their_own_best_and_stay_deterministic():
    prob = _corridor()
    b = ip.IPSO(n_particles=20, k_max=15, islands=4, A=8, inertia="linear",
                position_update="step", tighten_rounds=10, n_waypoints=3)
    r1, r2 = op.solve(prob, b, rng=3), op.solve(prob, b, rng=3)
    np.testing.assert_array_equal(r1.path, r2.path)
    assert r1.success and r1.n_iter == 15 and len(r1.history) == 17
    space = sw.make_space(prob.known_view(), prob.robots[0], 3)
    X = ops.initial_swarm(space, 20, "uniform", np.random.default_rng(0))
    st = be.new_state(X, np.zeros_like(X), sw.evaluate_swarm(X, space))
    run = b._start(space, st, [], np.random.default_rng(0))
    for i in range(4):
        assert run.island_idx[i] == 5 * i + int(np.argmin(st.pbest_f[5 * i:5 * i + 5]))
    np.testing.assert_array_equal(run.leader, np.repeat(np.arange(4), 5))


def test_compiled_step_follows_eqs_22_to_29():
    """One iteration of the compiled step against the equations written out in numpy."""
    rng = np.random.default_rng(11)
    P, D = 8, 4
    X, V = rng.random((P, D)) * 10, rng.normal(0, 1, (P, D))
    pbest = X + rng.normal(0, 1, (P, D))
    F = rng.random(P)
    gbest = pbest[0]
    lo, hi = np.zeros(D), np.full(D, 10.0)
    pairs, isl, frag = ga.ga_pairs(F, X, 1, 4, np.inf, False)
    order = np.argsort(F, kind="stable")[:4]
    np.testing.assert_array_equal(pairs, order.reshape(2, 2))  # rank-order pairs
    h = len(pairs)
    pc, noise, U = rng.random(h), rng.standard_normal((2 * h, D)), rng.random((3, P, D))
    w, c1, c2, psi = 0.7, 1.5, 1.5, 0.8
    vmax, sigma = np.full(D, 2.0), np.full(D, 0.3)
    B = np.zeros((P + 2 * 2 * h, D))
    Vn = np.empty_like(V)
    cv = ga.ga_children(X, V, pairs, pc, noise, sigma, B[P:], frag, False)
    out, anyout = ip.advance((X, V, pbest), gbest[None], np.zeros(P, np.int64), (w, c1, c2),
                             U, vmax, (psi, 0, np.zeros(2), np.ones(2)), 2 * h, (lo, hi, 1),
                             (B, Vn))
    # eqs 25-28
    a, b = X[pairs[:, 0]], X[pairs[:, 1]]
    p = pc[:, None]
    kids = np.vstack([p * a + (1 - p) * b, (1 - p) * a + p * b])
    np.testing.assert_allclose(B[P + 2 * h:P + 4 * h], kids, rtol=1e-12)
    va, vb = V[pairs[:, 0]], V[pairs[:, 1]]
    np.testing.assert_allclose(cv, np.vstack([p * va + (1 - p) * vb, (1 - p) * va + p * vb]))
    # eq 29's candidates: child + C_k (then bounds)
    mut = np.clip(kids + noise * sigma, -np.inf, np.inf)
    inside = (mut >= lo) & (mut <= hi)
    np.testing.assert_allclose(B[P:P + 2 * h][inside], mut[inside], rtol=1e-12)
    # eq 22 (clamped) and eq 24 as printed, then the reflection
    v = np.clip(w * V + c1 * U[0] * (pbest - X) + c2 * U[1] * (gbest - X), -vmax, vmax)
    x = psi * U[2] * X + v
    ok = (x >= lo) & (x <= hi)
    np.testing.assert_allclose(B[:P][ok], x[ok], rtol=1e-12)
    np.testing.assert_allclose(B[:P][~ok], (2 * np.clip(x, lo, hi) - x)[~ok], rtol=1e-12)
    np.testing.assert_allclose(Vn, np.where(ok, v, -v), rtol=1e-12)
    assert anyout == bool((~ok).any() or (~inside).any())
    # absorb: personal bests, eq 29 (the better of mutant and child), the worst replaced
    cost = rng.random(P + 4 * h)
    count = np.zeros(P + 4 * h, np.int64)
    pb, pbf = pbest.copy(), F + 0.5
    Xs, Vs = B[:P].copy(), Vn.copy()
    F2, kept, jb, bx, jf, fx = ip.absorb((Xs, Vs, pb), pbf, (cost, cost, count), B, 2 * h, cv,
                                         np.zeros(2 * h, np.int64), 1)
    m = 2 * h
    use = cost[P:P + m] < cost[P + m:P + 2 * m]
    assert kept == use.sum() and jb == np.argmin(cost) and jf == np.argmin(cost)
    np.testing.assert_array_equal(bx, B[jb])
    worst = np.argsort(cost[:P], kind="stable")[::-1][:m]
    for r, s_ in enumerate(worst):
        row = P + r if use[r] else P + m + r
        np.testing.assert_array_equal(Xs[s_], B[row])
        assert F2[s_] == cost[row] and pbf[s_] == cost[row]
    rest = np.setdiff1d(np.arange(P), worst)
    np.testing.assert_array_equal(pbf[rest], np.minimum(F + 0.5, cost[:P])[rest])


def test_run_constants_are_not_reported_as_statistics():
    res = op.solve(_corridor(), "ipso", rng=0, k_max=5, n_particles=10)
    stats = res.extras["per_robot"]["r"]
    assert not [k for k in stats if k.startswith("_")]
    for k in ("w", "crossovers", "mutations_kept", "endgame_candidates"):
        assert k in stats


def test_endgame_compares_the_classes():
    # an off-centre wall: over it is shorter than under it
    prob = op.parse_problem({
        "name": "ipso-offset-wall", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 1.0,
                    "max_speed": 1.0}],
        "obstacles": [{"type": "rectangle", "min": [45.0, 25.0], "max": [55.0, 62.0]}]})
    ref = op.solve(prob, "visgraph").metrics["length"]
    res = op.solve(prob, "ipso", rng=1, k_max=0)  # roadmap classes + end-game only
    assert res.success and res.metrics["length"] <= 1.001 * ref
    r2 = op.solve(prob, "ipso", rng=1, k_max=30)
    assert r2.success and r2.metrics["length"] <= 1.001 * ref
    assert r2.extras["per_robot"]["r"]["endgame_candidates"] >= 1
    # the end-game on the island bests only stays in the classes the islands hold
    r3 = op.solve(prob, "ipso", rng=1, k_max=30, endgame="islands")
    assert r3.success and r3.metrics["length"] >= r2.metrics["length"] - 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-env1", "paper-env2"])
def test_ipso_variant_worst_within_one_percent_of_the_optimum(name):
    prob = op.load_problem(name)
    ref = op.solve(prob, "visgraph").metrics["length"]
    res = [op.solve(prob, "ipso", rng=s) for s in range(30)]
    assert all(r.success for r in res)
    assert max(r.metrics["length"] for r in res) <= 1.01 * ref


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", [("doors", 0), ("shelves", 1)])
def test_ipso_variant_worst_ratio_on_generated_corridor_maps(kind, seed):
    """On generated maps with narrow corridors and shelf rows, 30 seeds, every run
    collision-free and within 1 % of the certified optimum."""
    from optplan.generators import corridor_scene
    from optplan.geometry.tangent.tangent_graph import problem_shortest_path

    prob = corridor_scene(kind, seed)
    ref = problem_shortest_path(prob, prob.robots[0]).length
    res = [op.solve(prob, "ipso", rng=s) for s in range(30)]
    assert all(r.success for r in res), [r.message for r in res if not r.success]
    worst = max(r.metrics["length"] for r in res) / ref
    assert worst <= 1.01, worst
