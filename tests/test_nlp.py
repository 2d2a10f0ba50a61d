"""Waypoint NLP (CasADi/IPOPT) backend, its geometry helpers and the validate workflow."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

import optplan as op
from optplan.backends.nlp import (
    WaypointNLP,
    convex_decompose,
    init_hyperplanes,
    objective_function,
    obstacle_pieces,
    resample_path,
)
from optplan.experiments.validate import (
    format_table,
    same_homotopy,
    summarize,
    validate,
    winding_numbers,
)
from optplan.geometry import path_lengths


def _scene(obstacles: list[dict], start=(5.0, 50.0), goal=(95.0, 50.0), radius=2.0,
           name="nlp-test") -> op.Problem:
    return op.parse_problem({
        "name": name,
        "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": list(start), "goal": list(goal), "radius": radius,
                    "max_speed": 1.0}],
        "obstacles": obstacles,
    })


BOX = {"type": "rectangle", "name": "box", "min": [40.0, 35.0], "max": [60.0, 60.0]}
DISC = {"type": "circle", "name": "disc", "center": [50.0, 48.0], "radius": 10.0}


# -- geometry helpers ------------------------------------------------------------------


def test_convex_decompose_l_shape_and_hole() -> None:
    ell = Polygon([(0, 0), (4, 0), (4, 1), (1, 1), (1, 4), (0, 4)])
    pieces = convex_decompose(ell)
    assert 2 <= len(pieces) <= 3
    polys = [Polygon(p) for p in pieces]
    assert all(abs(q.convex_hull.area - q.area) < 1e-12 for q in polys)
    assert math.isclose(sum(q.area for q in polys), ell.area, rel_tol=1e-12)
    assert shapely.unary_union(polys).symmetric_difference(ell).area < 1e-9
    ring = Polygon([(0, 0), (6, 0), (6, 6), (0, 6)], [[(2, 2), (2, 4), (4, 4), (4, 2)]])
    pieces = [Polygon(p) for p in convex_decompose(ring)]
    assert all(abs(q.convex_hull.area - q.area) < 1e-12 for q in pieces)
    assert math.isclose(sum(q.area for q in pieces), ring.area, rel_tol=1e-12)
    assert len(convex_decompose(Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]))) == 1


def test_resample_keeps_vertices_and_length() -> None:
    p = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0], [3.0, 1.0], [10.0, 1.0]])
    q = resample_path(p, 10)
    assert q.shape == (11, 2)
    for v in p:
        assert np.min(np.hypot(*(q - v).T)) < 1e-12
    assert math.isclose(path_lengths(q), path_lengths(p), rel_tol=1e-12)
    d = np.hypot(*np.diff(q, axis=0).T)
    assert np.all(d > 0)
    # more segments than asked: uniform arc-length resampling
    r = resample_path(np.c_[np.linspace(0, 1, 30), np.zeros(30)], 5)
    assert r.shape == (6, 2)
    np.testing.assert_allclose(np.diff(r[:, 0]), 0.2)


def test_hyperplane_init_is_unit_normal_and_support() -> None:
    prob = _scene([BOX])
    pieces = obstacle_pieces(prob, prob.robots[0], mode="exact")
    path = np.array([[5.0, 80.0], [95.0, 80.0]])
    a, c = init_hyperplanes(path, pieces, np.array([0]), np.array([0]))
    np.testing.assert_allclose(a[0], [0.0, 1.0], atol=1e-12)
    assert math.isclose(c[0], 60.0)
    # with clearances: c moves to the middle of the gap (80 - 2 - 60) / 2
    a, c = init_hyperplanes(path, pieces, np.array([0]), np.array([0]), pieces.clear)
    assert math.isclose(c[0], 60.0 + (80.0 - pieces.clear[0] - 60.0) / 2)


def test_pieces_modes_and_disc_is_native() -> None:
    prob = _scene([BOX, {**DISC, "center": [20.0, 80.0], "radius": 5.0}])
    ex = obstacle_pieces(prob, prob.robots[0], mode="exact")
    assert ex.n == 2 and len(ex.verts[1]) == 1
    assert ex.clear[1] == pytest.approx(5.0 + 2.0, abs=1e-3)
    ins = obstacle_pieces(prob, prob.robots[0], mode="inscribed")
    assert ins.n == 2 and min(len(v) for v in ins.verts) > 20
    assert np.all(ins.clear < 1e-3)


# -- twin test -------------------------------------------------------------------------


def test_twin_numpy_fitness_and_casadi_objective_agree() -> None:
    """The swarm fitness's length part and the NLP objective score paths identically."""
    from optplan.backends.swarm import evaluate_swarm, make_space

    prob = _scene([BOX])
    rob = prob.robots[0]
    rng = np.random.default_rng(7)
    S = prob.extent
    for n_wp in (1, 4, 11):
        space = make_space(prob, rob, n_wp)
        X = rng.uniform(0, 100, size=(25, 2 * n_wp))
        L_np = evaluate_swarm(X, space).length
        f = objective_function(n_wp + 2)
        for k in range(len(X)):
            P = np.vstack([rob.start, X[k].reshape(n_wp, 2), rob.goal])
            L_ca, reg = f(P / S, 0.0, 0.0)
            assert float(L_ca) * S == pytest.approx(L_np[k], rel=1e-13)
            assert float(reg) == 0.0
            assert float(L_ca) * S == pytest.approx(path_lengths(P), rel=1e-13)
            # the smoothing changes each segment by at most eps
            L_eps, _ = f(P / S, 1e-6, 0.0)
            assert 0.0 <= float(L_eps) - float(L_ca) <= (n_wp + 1) * 1e-6


def test_spacing_regulariser_formula() -> None:
    P = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0], [3.0, 1.0]])
    _, reg = objective_function(4)(P, 0.0, 0.5)
    D = np.diff(P, axis=0)
    expected = 0.5 * 3 * np.sum(np.diff(D, axis=0) ** 2)
    assert float(reg) == pytest.approx(expected)


# -- the backend -----------------------------------------------------------------------


@pytest.mark.parametrize("init_from", ["visgraph", "straight"])
def test_open_field_is_the_straight_line(init_from: str) -> None:
    res = op.solve("open-field", "nlp-ipopt", init_from=init_from)
    assert res.status is op.Status.optimal
    assert f"{res.metrics['ratio_to_optimum']:.6f}" == "1.000000"
    assert res.metrics["collisions"] == 0


@pytest.mark.parametrize("mode", ["exact", "inscribed"])
def test_box_matches_visgraph(mode: str) -> None:
    prob = _scene([BOX])
    vg = op.solve(prob, "visgraph")
    res = op.solve(prob, "nlp-ipopt", clearance_mode=mode)
    assert res.status is op.Status.optimal, res.message
    assert res.metrics["collisions"] == 0
    gap = res.metrics["length"] / vg.metrics["length"] - 1
    assert -1e-9 <= gap < 1e-3
    if mode == "exact":
        assert res.metrics["min_clearance"] >= -1e-6


def test_disc_handled_natively_against_the_analytic_optimum() -> None:
    """Around a disc of radius R (clearance r) the optimum is two tangents plus an arc."""
    prob = _scene([DISC], start=(5.0, 48.0), goal=(95.0, 48.0), radius=2.0)
    res = op.solve(prob, "nlp-ipopt", init_from="visgraph", n_segments=40)
    assert res.status is op.Status.optimal, res.message
    R, d = 12.0, 45.0
    t = math.sqrt(d * d - R * R)
    arc = R * (math.pi - 2 * math.acos(R / d))
    exact = 2 * t + arc
    L = res.metrics["length"]
    assert exact - 1e-6 <= L <= exact * (1 + 5e-4)
    assert res.metrics["min_clearance"] >= -1e-6


def test_pruned_pairs_are_added_back_when_violated() -> None:
    """With no pairs kept initially, the exact post-check adds the violated ones and
    re-solves; the result is collision-free."""
    prob = _scene([BOX, {"type": "rectangle", "name": "b2", "min": [70.0, 20.0],
                         "max": [80.0, 70.0]}])
    init = np.array([[5.0, 50.0], [50.0, 85.0], [95.0, 50.0]])
    res = op.solve(prob, "nlp-ipopt", init=init, prune_distance=0.0, guard=False)
    info = res.extras["ipopt"]["r"]
    assert len(info["rounds"]) >= 2
    assert res.metrics["collisions"] == 0 and res.success
    assert info["max_violation"] < 1e-3


def test_guard_never_returns_a_longer_path_and_polishes_a_heuristic() -> None:
    prob = _scene([BOX])
    vg = op.solve(prob, "visgraph")
    # a feasible, longer path in the same homotopy class
    detour = np.array([[5.0, 50.0], [30.0, 75.0], [70.0, 75.0], [95.0, 50.0]])
    assert op.evaluate(prob, {"r": detour})["feasible"]
    res = op.solve(prob, "nlp-ipopt", init=detour)
    assert res.metrics["length"] < path_lengths(detour)
    assert res.metrics["length"] / vg.metrics["length"] - 1 < 1e-3
    # the certified optimum as init: the NLP (exact clearance) is slightly longer -> kept
    res2 = op.solve(prob, "nlp-ipopt", init=vg.paths)
    assert res2.metrics["length"] <= vg.metrics["length"] * (1 + 1e-12)
    assert res2.success and res2.metrics["collisions"] == 0


def test_infeasible_statuses() -> None:
    wall = {"type": "rectangle", "name": "wall", "min": [45.0, -1.0], "max": [55.0, 101.0]}
    prob = _scene([wall])
    res = op.solve(prob, "nlp-ipopt")  # visgraph finds no path: proven infeasible
    assert res.status is op.Status.infeasible
    res = op.solve(prob, "nlp-ipopt", init_from="straight", max_iter=200)
    assert res.status is op.Status.approximate and not res.metrics["feasible"]
    assert "IPOPT" in res.message
    with pytest.raises(op.ProblemError):  # rejected before any solver runs
        _scene([BOX], start=(50.0, 50.0))


def test_deterministic_and_global_state_untouched() -> None:
    prob = _scene([BOX])
    state = np.random.get_state()  # noqa: NPY002
    a = op.solve(prob, "nlp-ipopt", rng=1)
    b = op.solve(prob, "nlp-ipopt", rng=2)
    np.testing.assert_array_equal(a.path, b.path)
    after = np.random.get_state()  # noqa: NPY002
    assert all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
               for x, y in zip(state, after))


def test_callback_and_stop() -> None:
    prob = _scene([BOX])
    calls = []
    full = op.solve(prob, "nlp-ipopt", callback=calls.append)
    assert len(calls) >= full.n_iter > 0

    def stop(_p):
        raise StopIteration

    res = op.solve(prob, "nlp-ipopt", callback=stop)
    assert res.n_iter < full.n_iter
    assert res.status is not op.Status.optimal


@pytest.mark.parametrize("bad", [{"n_segments": 0}, {"clearance_mode": "round"},
                                 {"prune_distance": -1.0}, {"mu_strategy": "x"},
                                 {"guard": 1}, {"eps": 1.0}])
def test_option_validation(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        WaypointNLP(**bad)


@pytest.mark.parametrize("name", ["paper-env1", "paper-env2", "paper-warehouse"])
def test_visgraph_warm_start_on_paper_maps(name: str) -> None:
    prob = op.load_problem(name)
    vg = op.solve(prob, "visgraph", see_temporary=True)
    res = op.solve(prob, "nlp-ipopt", see_temporary=True)
    assert vg.status is op.Status.optimal
    assert res.status is op.Status.optimal, res.message
    assert res.metrics["collisions"] == 0
    assert abs(res.metrics["length"] / vg.metrics["length"] - 1) < 1e-3


# -- validate --------------------------------------------------------------------------


def test_winding_and_homotopy() -> None:
    sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    assert winding_numbers(sq, [[1, 1], [3, 3]]).tolist() == [1, 0]
    assert winding_numbers(sq[::-1], [[1, 1]]).tolist() == [-1]
    above = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, 0.0]])
    below = np.array([[0.0, 0.0], [1.0, -2.0], [2.0, 0.0]])
    assert not same_homotopy(above, below, [[1.0, 0.0]])
    assert same_homotopy(above, below, [[5.0, 5.0]])


def test_validate_rows_and_table() -> None:
    prob = _scene([BOX])
    rows = validate(prob, "visgraph", seeds=2)
    assert [r["seed"] for r in rows] == [0, 1]
    for r in rows:
        assert r["optimal_class"] and r["nlp_optimal_class"]
        assert abs(r["total_gap_pct"]) < 1e-9
        assert r["L_nlp"] <= r["L_heuristic"] * (1 + 1e-12)
    s = summarize(rows)
    assert s["n_optimal_class"] == 2
    table = format_table(rows, "t")
    assert "| **median** |" in table and "within-homotopy gap %" in table


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-env1", "paper-env2"])
def test_polishing_ipso_paper_closes_the_gap(name: str) -> None:
    """Issue 4: never longer than the initial guess; median gap <= 0.1 % in the optimal class."""
    rows = validate(name, "ipso-paper", seeds=10)
    s = summarize(rows)
    for r in rows:
        if r["heuristic_feasible"]:
            assert r["L_nlp"] <= r["L_heuristic"] * (1 + 1e-12)
    assert s["n_optimal_class"] >= 3
    assert s["median_nlp_gap_pct_optimal_class"] <= 0.1
