"""Waypoint NLP (CasADi/IPOPT) backend, its geometry helpers and the validate workflow."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

import optplan as op
from optplan.exact.nlp import WaypointNLP
from optplan.exact.nlp_model import objective_function
from optplan.exact.nlp_pieces import (
    SAFETY_REL,
    init_hyperplanes,
    obstacle_pieces,
    pair_distances,
    piece_distances,
)
from optplan.exact.nlp_solve import NLPSettings, solve_waypoint_nlp
from optplan.experiments.validate import format_table, summarize, validate
from optplan.geometry import convex_decompose, path_lengths
from optplan.geometry.collision.homotopy import obstacle_points, same_homotopy, winding_numbers
from optplan.geometry.collision.polyline import resample_path
from optplan.geometry.tangent.tangent_graph import problem_shortest_path
from optplan.problem import transform_problem
from optplan.result import OPTIMAL_REL_TOL


def _scene(obstacles: list[dict], start=(5.0, 50.0), goal=(95.0, 50.0), radius=2.0,
           name="nlp-test", size=100.0) -> op.Problem:
    return op.parse_problem({
        "name": name,
        "bounds": [0.0, 0.0, size, size],
        "robots": [{"id": "r", "start": list(start), "goal": list(goal), "radius": radius,
                    "max_speed": 1.0}],
        "obstacles": obstacles,
    })


def _shifted(base: op.Problem, off) -> op.Problem:
    """``base`` translated by ``off``."""
    return transform_problem(base, shift=off)


BOX = {"type": "rectangle", "name": "box", "min": [40.0, 35.0], "max": [60.0, 60.0]}
DISC = {"type": "circle", "name": "disc", "center": [50.0, 48.0], "radius": 10.0}
ELL = {"type": "polygon", "name": "ell",
       "vertices": [[20, 10], [40, 10], [40, 15], [25, 15], [25, 30], [20, 30]]}
RING = {"type": "polygon", "name": "ring", "vertices": [[60, 70], [90, 70], [90, 95], [60, 95]],
        "holes": [[[70, 78], [70, 88], [80, 88], [80, 78]]]}


# -- geometry helpers ------------------------------------------------------------------


def test_pieces_are_the_core_decomposition_in_the_local_frame() -> None:
    prob = _scene([ELL, RING, {**DISC, "center": [20.0, 80.0], "radius": 5.0}])
    rob = prob.robots[0]
    pc = obstacle_pieces(prob, rob)
    o = prob.frame.origin
    safety = SAFETY_REL * prob.extent
    for k, ob in enumerate(prob.obstacles[:2]):
        mine = [v for v, i in zip(pc.verts, pc.obstacle) if i == k]
        core = convex_decompose(shapely.affinity.translate(ob.geometry, -o[0], -o[1]))
        assert len(mine) == len(core) >= 2
        for a, b in zip(mine, core):
            np.testing.assert_array_equal(a, b)
        polys = [Polygon(v) for v in mine]
        assert all(abs(q.convex_hull.area - q.area) < 1e-12 * q.area for q in polys)
        assert math.isclose(sum(q.area for q in polys), ob.geometry.area, rel_tol=1e-12)
    # the circle: one vertex at its local centre, clearance R + r (+ safety)
    j = int(np.flatnonzero(pc.obstacle == 2)[0])
    np.testing.assert_allclose(pc.verts[j], [[20.0 - o[0], 80.0 - o[1]]])
    assert pc.need[j] == 5.0 + 2.0 and pc.radius[j] == 5.0
    assert pc.clear[j] == pytest.approx(7.0 + safety, rel=1e-15)
    assert np.all(pc.clear[pc.obstacle < 2] == 2.0 + safety)


def test_pair_distances_are_the_exact_engine() -> None:
    """Per obstacle, the smallest piece distance is the validator's exact clearance; the disc
    distance is to its boundary (+ R); shapely agrees (an independent check)."""
    prob = _scene([ELL, RING, BOX, {**DISC, "center": [20.0, 80.0], "radius": 5.0}])
    rob = prob.robots[0]
    pc = obstacle_pieces(prob, rob)
    oset = prob.obstacle_set(rob.radius, known_only=True)
    rng = np.random.default_rng(3)
    pts = rng.uniform(0, 100, size=(400, 2))
    loc = prob.frame.local(pts)
    D = piece_distances(loc, pc)  # 399 segments
    assert D.shape == (399, pc.n)
    np.testing.assert_allclose(pair_distances(loc, pc), D - pc.clear)
    geoms = [shapely.Point(v[0]) if len(v) == 1 else Polygon(v) for v in pc.verts]
    for s in range(len(loc) - 1):
        seg = shapely.LineString(loc[s:s + 2])
        ref = np.array([seg.distance(g) for g in geoms])
        ref = np.where(pc.radius > 0, np.maximum(ref, pc.radius), ref)
        np.testing.assert_allclose(D[s], ref, atol=1e-9 * prob.extent)
        c = oset.clearance(pts[s:s + 2][None])[0]
        if c >= 0:  # the segment meets no obstacle: clearance = min over pieces
            assert c == pytest.approx(float(np.min(D[s] - pc.need)), abs=1e-12 * prob.extent)


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


def test_hyperplane_init_is_the_separating_direction() -> None:
    prob = _scene([BOX, {**DISC, "center": [20.0, 80.0], "radius": 5.0}])
    pc = obstacle_pieces(prob, prob.robots[0])
    fr = prob.frame
    path = fr.local(np.array([[5.0, 80.0], [95.0, 80.0]]))
    a, c = init_hyperplanes(path, pc, np.array([0]), np.array([0]))
    np.testing.assert_allclose(a[0], [0.0, 1.0], atol=1e-12)
    assert math.isclose(c[0], 60.0 - fr.origin[1])  # the box top, local
    # with clearances: c moves to the middle of the gap (80 - 2 - 60) / 2
    a, c = init_hyperplanes(path, pc, np.array([0]), np.array([0]), pc.clear)
    assert math.isclose(c[0], 60.0 - fr.origin[1] + (80.0 - pc.clear[0] - 60.0) / 2)
    # disjoint segment and piece: a . p - c is the exact distance (vertex-endpoint case)
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = fr.local(rng.uniform(0, 100, size=(2, 2)))
        d = piece_distances(q, pc)[0]
        for j in range(pc.n):
            if d[j] <= (pc.radius[j] + 1e-6):
                continue  # meets the piece
            a, c = init_hyperplanes(q, pc, np.array([0]), np.array([j]))
            assert np.hypot(*a[0]) == pytest.approx(1.0, abs=1e-12)
            sep = min(q[0] @ a[0], q[1] @ a[0]) - c[0]
            assert sep == pytest.approx(d[j], abs=1e-9 * prob.extent)
    # a segment through the box still gets a unit normal
    q = fr.local(np.array([[30.0, 50.0], [70.0, 45.0]]))
    a, _ = init_hyperplanes(q, pc, np.array([0]), np.array([0]))
    assert np.hypot(*a[0]) == pytest.approx(1.0, abs=1e-12)


# -- twin test -------------------------------------------------------------------------


def test_twin_numpy_fitness_and_casadi_objective_agree() -> None:
    """The swarm fitness's length part and the NLP objective score paths identically."""
    from optplan.swarm.core import evaluate_swarm, make_space

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


def _graded(res: op.Result, optimum: float) -> float:
    """The one meaning of ``optimal``: a KKT point is ``optimal`` exactly when the certified
    optimum confirms its length within OPTIMAL_REL_TOL, else ``solved`` and "locally optimal"
    with the gap.  Returns the gap."""
    gap = res.metrics["length"] / optimum - 1
    assert res.success, res.message
    if gap <= OPTIMAL_REL_TOL:
        assert res.status is op.Status.optimal, res.message
    else:
        assert res.status is op.Status.solved, res.message
        assert "locally optimal (KKT)" in res.message and "% above the certified" in res.message
    return gap


@pytest.mark.parametrize("init_from", ["visgraph", "straight"])
def test_open_field_is_the_straight_line(init_from: str) -> None:
    prob = op.load_problem("open-field")
    res = op.solve(prob, "nlp-ipopt", init_from=init_from)
    assert res.status is op.Status.optimal
    opt = problem_shortest_path(prob, prob.leader).length
    assert res.metrics["length"] == pytest.approx(opt, rel=1e-12)
    assert res.metrics["collisions"] == 0


def test_box_matches_the_exact_optimum() -> None:
    prob = _scene([BOX])
    vg = op.solve(prob, "visgraph")
    res = op.solve(prob, "nlp-ipopt")
    assert res.metrics["collisions"] == 0
    gap = _graded(res, vg.metrics["length_exact"])
    assert 0.0 <= gap < 1e-3
    assert res.metrics["min_clearance"] >= 0.0
    assert "clearance_mode" not in res.options


def test_disc_handled_natively_against_the_analytic_optimum() -> None:
    """Around a disc of radius R (clearance r) the optimum is two tangents plus an arc."""
    prob = _scene([DISC], start=(5.0, 48.0), goal=(95.0, 48.0), radius=2.0)
    res = op.solve(prob, "nlp-ipopt", init_from="visgraph", n_segments=40)
    R, d = 12.0, 45.0
    t = math.sqrt(d * d - R * R)
    arc = R * (math.pi - 2 * math.acos(R / d))
    exact = 2 * t + arc
    assert problem_shortest_path(prob, prob.robots[0]).length == pytest.approx(exact,
                                                                               rel=1e-12)
    L = res.metrics["length"]
    assert exact <= L <= exact * (1 + 5e-4)
    _graded(res, exact)
    assert res.metrics["min_clearance"] >= 0.0


def test_circle_exact_clearance_and_the_tangent_arc_optimum() -> None:
    """A circle of radius 30 and a robot of radius 0.5: the NLP keeps the exact clearance
    ``||x - c|| >= R + r`` (to the validator's tolerance) and, on a path that wraps a short arc,
    its length is the tangent-arc optimum to 1e-6."""
    circ = {"type": "circle", "name": "c30", "center": [100.0, 100.0], "radius": 30.0}
    prob = _scene([circ], start=(5.0, 129.5), goal=(195.0, 129.5), radius=0.5, size=200.0)
    rob = prob.robots[0]
    assert prob.obstacles[0].is_circle
    res = op.solve(prob, "nlp-ipopt")
    _graded(res, problem_shortest_path(prob, rob).length)
    path = res.paths["r"]
    eps = prob.frame.eps
    clear = prob.obstacle_set(rob.radius).clearance(path[None])[0]
    assert clear >= -eps
    # the same from the centre: every segment stays R + r - eps away
    c = np.array([100.0, 100.0])
    a, b = path[:-1], path[1:]
    t = np.clip(np.sum((c - a) * (b - a), 1) / np.sum((b - a) ** 2, 1), 0, 1)
    assert np.min(np.hypot(*(a + t[:, None] * (b - a) - c).T)) >= 30.5 - eps
    opt = problem_shortest_path(prob, rob).length
    assert res.metrics["length"] >= opt
    assert res.metrics["length"] == pytest.approx(opt, rel=1e-6)


def test_translation_to_utm_coordinates_changes_nothing() -> None:
    """paper-env1 moved by (5e5, 5e6) solves like paper-env1 (local frame)."""
    base = op.load_problem("paper-env1")
    far = _shifted(base, (5e5, 5e6))
    a = op.solve(base, "nlp-ipopt")
    b = op.solve(far, "nlp-ipopt")
    assert b.status is a.status and a.success, b.message
    # the answer is the same; IPOPT's iteration count may differ by round-off (the start is
    # near the bounds wall, whose constraints are nearly active there)
    assert abs(b.n_iter - a.n_iter) <= 2
    assert b.metrics["collisions"] == 0
    assert b.metrics["length"] == pytest.approx(a.metrics["length"], rel=1e-6)
    np.testing.assert_allclose(b.paths["r1"] - (5e5, 5e6), a.paths["r1"], atol=1e-6)


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
    assert res.metrics["length"] / vg.metrics["length_exact"] - 1 < 1e-3
    # the certified optimum's polyline as init: the NLP is not shorter (the safety margin,
    # the regulariser) -> the initial guess is kept
    res2 = op.solve(prob, "nlp-ipopt", init=vg.paths)
    assert res2.metrics["length"] <= vg.metrics["length"] * (1 + 1e-12)
    assert res2.success and res2.metrics["collisions"] == 0


def test_infeasible_statuses() -> None:
    ring = {"type": "polygon", "name": "moat",
            "vertices": [[70, 30], [99, 30], [99, 70], [70, 70]],
            "holes": [[[75, 35], [75, 65], [97, 65], [97, 35]]]}
    prob = _scene([ring], goal=(86.0, 50.0))
    res = op.solve(prob, "nlp-ipopt")  # the tangent graph proves the goal unreachable
    assert res.status is op.Status.infeasible
    assert "not reachable" in res.message
    wall = {"type": "rectangle", "name": "wall", "min": [45.0, -1.0], "max": [55.0, 101.0]}
    prob = _scene([wall])
    res = op.solve(prob, "nlp-ipopt")  # a wall across the map (the bounds are a wall): proven
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


@pytest.mark.parametrize("bad", [{"n_segments": 0}, {"init_from": "inflated"},
                                 {"prune_distance": -1.0}, {"mu_strategy": "x"},
                                 {"guard": 1}, {"eps": 1.0}])
def test_option_validation(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        WaypointNLP(**bad)


@pytest.mark.parametrize(("bad", "allowed"), [
    ({"n_segments": 0}, "an integer >= 1"), ({"max_rounds": True}, "an integer >= 1"),
    ({"segment_bucket": 2.0}, "an integer >= 1"),
    ({"prune_distance": math.nan}, "a number >= 0 or inf"),
    ({"eps": math.inf}, "a finite number >= 0"), ({"spacing_weight": -1.0}, "a finite number"),
    ({"resolve_from": "first"}, "one of 'last', 'init'"), ({"ipopt_options": None}, "a mapping")])
def test_nlp_settings_name_the_setting_its_value_and_range(bad: dict, allowed: str) -> None:
    (name, value), = bad.items()
    with pytest.raises(ValueError, match=rf"NLPSettings\.{name} must be {allowed}.*got "
                                         rf"{re.escape(repr(value))}"):
        NLPSettings(**bad)


def test_nlp_settings_defaults_are_the_backend_defaults() -> None:
    backend = WaypointNLP()
    assert backend._nlp_settings(1) == NLPSettings(ipopt_options=backend.ipopt_options())
    assert NLPSettings(prune_distance=math.inf).prune_distance == math.inf  # no pruning
    prob = _scene([])
    with pytest.raises(TypeError, match="settings must be an NLPSettings, got dict"):
        solve_waypoint_nlp(prob, prob.robots[0], np.zeros((2, 2)), {"n_segments": 5})


def test_clearance_mode_is_gone() -> None:
    with pytest.raises(ValueError, match="clearance_mode"):
        op.get_solver("nlp-ipopt", clearance_mode="exact")


@pytest.mark.parametrize("name", ["paper-env1", "paper-env2", "paper-warehouse"])
def test_visgraph_warm_start_on_paper_maps(name: str) -> None:
    prob = op.load_problem(name)
    vg = op.solve(prob, "visgraph", see_temporary=True)
    res = op.solve(prob, "nlp-ipopt", see_temporary=True)
    assert vg.status is op.Status.optimal
    assert res.metrics["collisions"] == 0
    assert 0.0 <= _graded(res, vg.metrics["length_exact"]) < 1e-3


# -- validate --------------------------------------------------------------------------


def test_winding_and_homotopy() -> None:
    sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    assert winding_numbers(sq, [[1, 1], [3, 3]]).tolist() == [1, 0]
    assert winding_numbers(sq[::-1], [[1, 1]]).tolist() == [-1]
    above = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, 0.0]])
    below = np.array([[0.0, 0.0], [1.0, -2.0], [2.0, 0.0]])
    loop = np.vstack([above, below[::-1]])
    assert winding_numbers(loop, [[1.0, 0.0]]).tolist() != [0]
    assert winding_numbers(loop, [[5.0, 5.0]]).tolist() == [0]
    prob = _scene([{**DISC, "center": [50.0, 50.0], "radius": 5.0}])
    oset = prob.obstacle_set(1.0)
    over = np.array([[5.0, 50.0], [50.0, 70.0], [95.0, 50.0]])
    under = np.array([[5.0, 50.0], [50.0, 30.0], [95.0, 50.0]])
    assert not same_homotopy(over, under, oset)
    assert same_homotopy(over, over + [0.0, 5.0] * np.array([[0], [1], [0]]), oset)


def test_obstacle_points_lie_inside_the_obstacles() -> None:
    prob = _scene([ELL, RING, BOX, {**DISC, "center": [20.0, 80.0], "radius": 5.0}])
    pts = prob.frame.world(obstacle_points(prob.obstacle_set(2.0)))
    assert len(pts) >= 4
    assert prob.obstacle_set(0.0).point_distances(pts).max() == 0.0
    # inside an obstacle or the bounds wall (outside the bounds)
    inside = [any(o.geometry.contains(shapely.Point(p)) for o in prob.obstacles[:3])
              or np.hypot(*(p - (20.0, 80.0))) < 5.0 or not prob.frame.in_bounds(p)[0]
              for p in pts]
    assert all(inside)


def test_validate_rows_and_table() -> None:
    prob = _scene([BOX])
    rows = validate(prob, "visgraph", seeds=2)
    assert [r["seed"] for r in rows] == [0, 1]
    vg = op.solve(prob, "visgraph")
    for r in rows:
        assert r["optimal_class"] and r["nlp_optimal_class"]
        assert r["L_opt"] == vg.metrics["length_exact"]
        # the heuristic is the visgraph polyline: its gap is the circumscribed arcs' excess
        assert r["total_gap_pct"] == pytest.approx(
            100 * (vg.metrics["length"] / vg.metrics["length_exact"] - 1), rel=1e-9)
        assert 0.0 <= r["total_gap_pct"] < 0.05
        assert r["L_nlp"] <= r["L_heuristic"] * (1 + 1e-12)
    s = summarize(rows)
    assert s["n_optimal_class"] == 2
    table = format_table(rows, "t")
    assert "| **median** |" in table and "within-homotopy gap %" in table


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-env1", "paper-env2"])
def test_polishing_ipso_paper_closes_the_gap(name: str) -> None:
    """Never longer than the initial guess; median gap <= 0.1 % in the optimal class."""
    rows = validate(name, "ipso-paper", seeds=30)  # ~1 in 3 ipso-paper runs is in the class
    s = summarize(rows)
    for r in rows:
        if r["heuristic_feasible"]:
            assert r["L_nlp"] <= r["L_heuristic"] * (1 + 1e-12)
    assert s["n_optimal_class"] >= 3
    assert s["median_nlp_gap_pct_optimal_class"] <= 0.1


def test_the_own_time_limit_stops_ipopt_and_keeps_the_guarded_path(monkeypatch):
    """``time_limit`` (default 60 s, in ``show-solver``) is polled at IPOPT's iterations: a
    clock past it stops the run at the first one, with a valid path no shorter than the full
    run's (load-independent: the clock is replaced)."""
    from optplan import solver

    assert op.get_solver("nlp-ipopt").time_limit == 60.0
    ticks = iter(range(10**6))
    monkeypatch.setattr(solver, "clock", lambda: 100.0 * next(ticks))
    res = op.get_solver("nlp-ipopt", time_limit=50.0).solve(op.load_problem("paper-env1"))
    assert res.stop_reason == "time_limit" and "time limit (50 s) reached" in res.message
    assert res.metrics["feasible"] and res.metrics["reached"]
    full = op.solve("paper-env1", "nlp-ipopt")
    assert res.metrics["length"] >= full.metrics["length"] - 1e-9
