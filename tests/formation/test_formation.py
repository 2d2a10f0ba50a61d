"""Formation control: L-phi convention, paper formulas, leader-follower and formation-qp runs."""

from __future__ import annotations

import math

import cvxpy as cp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import optplan as op
from optplan.formation.formation_qp import FormationQP, QPData, QPLayout, QPModel, QPSolver
from optplan.formation.leader_follower import (
    LPhiFollowers,
    adapted_angle,
    lphi_gradient,
    lphi_potential,
)
from optplan.formation.pilot import pilot_force
from optplan.formation.safety import project_halfplanes
from optplan.formation.slots import relative_polar, slot_positions
from optplan.generators import formation_scene, jitter_phases
from optplan.interfaces import FollowerController, FormationBackend
from optplan.metrics import formation_errors
from optplan.problem import parse_problem
from optplan.sim import ObstacleField, SimState

FAST = {"path_solver": "visgraph"}


# ---------------------------------------------------------------- convention -----------


def test_convention_matches_paper_start():
    """Paper Fig. 31 start: leader (60, 60) heading pi/4, L = 60: phi = +pi/4 -> (0, 60)."""
    prob = op.load_problem("paper-formation")
    lead = prob.leader
    th = math.atan2(*(lead.goal - lead.start)[::-1])
    slots = slot_positions(lead.start, th, [60, 60], [math.pi / 4, -math.pi / 4])
    np.testing.assert_allclose(slots, [[0, 60], [60, 0]], atol=1e-9)
    # the scene starts the followers one radius inside the map's edge (the bounds are a wall)
    np.testing.assert_allclose(lead.start + prob.formation.slot_offsets(th) + [[4, 0], [0, 4]],
                               [prob.robot("f1").start, prob.robot("f2").start], atol=1e-9)
    r, phi = relative_polar(lead.start, th, slots)
    np.testing.assert_allclose(r, 60)
    np.testing.assert_allclose(phi, [math.pi / 4, -math.pi / 4])
    # phi = 0 is directly behind; positive phi is on the leader's left
    behind = slot_positions(np.zeros(2), 0.0, [1.0], [0.0])[0]
    np.testing.assert_allclose(behind, [-1, 0], atol=1e-12)
    assert slot_positions(np.zeros(2), 0.0, [1.0], [0.3])[0][1] > 0
    # the validator agrees: a formation error of exactly the 4 inward at the start
    paths = {k: np.vstack([prob.robot(k).start, prob.robot(k).start]) for k in prob.robot_ids}
    paths["leader"] = np.vstack([lead.start, lead.start + [1, 1]])
    np.testing.assert_allclose(formation_errors(prob, paths)["position"][0], 4.0, atol=1e-9)


# ---------------------------------------------------------------- formulas -------------


def test_lphi_gradient_matches_finite_differences_and_minimum():
    r, phi, L, Phi = 47.0, 0.6, 60.0, math.pi / 4
    dr, dphi = lphi_gradient(r, phi, L, Phi)
    h = 1e-6
    fd_r = (lphi_potential(r + h, phi, L, Phi) - lphi_potential(r - h, phi, L, Phi)) / (2 * h)
    fd_p = (lphi_potential(r, phi + h, L, Phi) - lphi_potential(r, phi - h, L, Phi)) / (2 * h)
    assert dr == pytest.approx(fd_r, rel=1e-6)
    assert dphi == pytest.approx(fd_p, rel=1e-6)
    z = lphi_gradient(L, Phi, L, Phi)
    assert abs(z[0]) < 1e-15 and abs(z[1]) < 1e-12
    # hand value, eq 47 with L^2: A(-2 L^2/r^3 + 2/r) at r = 30, L = 60, A = 0.5
    assert lphi_gradient(30.0, 1.0, 60.0, 1.0)[0] == pytest.approx(0.5 * (-2 * 3600 / 27000
                                                                          + 2 / 30))


def test_adapted_angle_eq52():
    Phi = math.pi / 4
    assert adapted_angle(Phi, 100.0, 100.0) == pytest.approx(Phi)
    assert adapted_angle(Phi, 500.0, 100.0) == pytest.approx(Phi)
    assert adapted_angle(Phi, 0.05, 100.0) == pytest.approx(0.0, abs=1e-15)
    assert adapted_angle(Phi, 0.001, 100.0) == pytest.approx(0.0, abs=1e-15)  # clamp
    assert adapted_angle(-Phi, 10.0, 100.0) == pytest.approx(-Phi * math.log(200) /
                                                             math.log(2000))


def test_pilot_force_hand_computed():
    x, g = np.array([0.0, 0.0]), np.array([10.0, 0.0])
    near, clear = np.array([[0.0, -5.0]]), np.array([5.0])
    F = pilot_force(x, g, near, clear, k=15, eta=3.7, rho_0=100, n=3)
    diff = 1 / 5 - 1 / 100
    f1 = 3.7 * diff * 1000 / 25  # eq 44, away from the obstacle (+y)
    f2 = 1.5 * 3.7 * diff**2 * 100  # eq 45, toward the goal (+x)
    np.testing.assert_allclose(F, [150 + f2, f1])
    # beyond rho_0: attraction only
    np.testing.assert_allclose(pilot_force(x, g, near, np.array([150.0]), 15, 3.7, 100, 3),
                               [150, 0])


# ---------------------------------------------------------------- QP model -------------


def _layout(K: int = 2) -> QPLayout:
    return QPLayout(3, np.array([[0, 1], [0, 2], [1, 2]]), K, 0, np.array([[1, 0], [2, 0]]),
                    np.array([10.0, 1.0, 1.0]), np.array([4.0, 4.0, 4.0]))


_SETTINGS = {"presolve_enable": False, "chordal_decomposition_enable": False,
             "verbose": False}


def _data(rng, K: int = 2) -> QPData:
    n = 3
    return QPData(unom=rng.normal(size=(n, 2)), r=rng.normal(size=(2, 2)),
                  G=rng.normal(size=(3, 2)), bp=rng.uniform(0.5, 2, 3),
                  N=rng.normal(size=(n * K, 2)), bo=rng.uniform(0.2, 1, n * K),
                  Ne=np.zeros((0, 2)), be=np.zeros(0), lo=-np.full((n, 2), 3.0),
                  hi=np.full((n, 2), 3.0))


def _reference_solution(L: QPLayout, d: QPData, tau: float, w_f: float) -> np.ndarray:
    """The QP written out as in the module doc (sum of squares, a fresh cvxpy problem)."""
    U = cp.Variable((L.n, 2))
    obj = sum(L.weights[i] * cp.sum_squares(U[i] - d.unom[i]) for i in range(L.n))
    obj += w_f * sum(cp.sum_squares(d.r[k] + tau * (U[f] - (U[l] if l >= 0 else 0)))
                     for k, (f, l) in enumerate(L.edges))
    cons = [U >= d.lo, U <= d.hi] + [cp.norm(U[i]) <= L.vmax[i] for i in range(L.n)]
    cons += [d.G[k] @ (U[i] - U[j]) <= d.bp[k] for k, (i, j) in enumerate(L.pairs)]
    cons += [d.N[k] @ U[k // L.K] <= d.bo[k] for k in range(L.nK)]
    cp.Problem(cp.Minimize(obj), cons).solve(solver=cp.CLARABEL)
    return U.value


def test_qp_is_dpp_and_matches_the_written_out_model():
    """One implementation: the expanded DPP model (u'Qu + q'u, one Parameter vector) gives
    the solution of the QP as written in the docs, through cvxpy's re-solve pipeline and
    through the compiled map (cvxpy out of the loop) alike."""
    m = QPModel(_layout(), 0.5, 4.0, 1e4, _SETTINGS)
    assert m.problem.is_dpp() and m.problem.parameters() == [m.theta]
    assert m.compiled is not None  # the affine map was read off cvxpy and verified
    rng = np.random.default_rng(3)
    for _ in range(4):
        d = _data(rng)
        ref = _reference_solution(m.layout, d, 0.5, 4.0)
        sol = m.solve(d)
        assert sol.status in ("Solved", "AlmostSolved") and not sol.fallback
        np.testing.assert_allclose(sol.U, ref, atol=2e-5)
        via_cvxpy, _ = m.solve_cvxpy(d.theta(m.linear_term(d)))
        np.testing.assert_allclose(via_cvxpy.U, ref, atol=2e-5)
    data = m.problem.get_problem_data(cp.CLARABEL)[0]
    assert data["dims"].zero == 0  # no auxiliary equality rows: Q goes to Clarabel as is
    assert data["c"].size == 2 * m.layout.n  # and no auxiliary variables


@pytest.mark.parametrize("soft", [False, True])
def test_the_one_qp_path_matches_the_cvxpy_oracle_on_random_instances(soft):
    """The compiled map is the only run-time path; cvxpy's re-solve pipeline is its
    oracle.  Random layouts (robots, pair patterns, obstacle and external rows) and random
    feasible instances: the same status, the same objective to 10 x tol and the same
    velocities to 1e-3 (two solves to tol 1e-7 on a speed-cone boundary differ by about
    sqrt(tol))."""
    rng = np.random.default_rng(24)
    for _ in range(12):
        n, K, ne = int(rng.integers(1, 9)), int(rng.integers(0, 4)), int(rng.integers(0, 2))
        iu, ju = np.triu_indices(n, 1)
        sel = rng.random(len(iu)) < 0.5
        li = -1 if ne else 0
        edges = np.array([(k, li) for k in range(n) if k != 0 or li < 0], int).reshape(-1, 2)
        layout = QPLayout(n, np.stack([iu[sel], ju[sel]], 1).reshape(-1, 2), K, ne, edges,
                          np.ones(n), rng.uniform(0.5, 2.0, n))
        m = QPModel(layout, 0.5, 4.0, 1e4, _SETTINGS, soft=soft)
        for _ in range(3):
            theta = m.feasible_theta(rng)
            got = m.compiled.solve(theta, soft)
            ref, _ = m.solve_cvxpy(theta)
            assert got.status in ("Solved", "AlmostSolved") and ref.status == got.status
            assert got.objective == pytest.approx(ref.objective, rel=1e-6, abs=1e-6)
            np.testing.assert_allclose(got.U, ref.U, atol=1e-3)
            assert got.slack == pytest.approx(ref.slack, abs=1e-3)


def test_every_native_clarabel_status_has_a_meaning():
    import clarabel

    from optplan.formation import clarabel as cl

    native = {s for s in dir(clarabel.SolverStatus) if not s.startswith("_")}
    assert native <= set(cl.STATUS), native - set(cl.STATUS)
    assert {s for s, v in cl.STATUS.items() if v == cl.ACCEPTED} == {"Solved", "AlmostSolved"}
    assert all(cl.meaning(s) == cl.CERTIFICATE for s in cl.STATUS if "Infeasible" in s)
    assert cl.meaning("SomeFutureStatus") == cl.NUMERICAL and not cl.accepted("Unsolved")


def test_rows_implied_by_the_speed_cones_are_dropped():
    m = QPModel(_layout(), 0.5, 4.0, 1e4, _SETTINGS)
    c = m.compiled
    d = QPData.inactive(m.layout)  # every row padded, bounds at the speed limits
    vals = c.c0 + c.c1 * np.append(d.theta(m.linear_term(d)), 0.0)[c.j]
    keep = c.rows_needed(vals[c.nx: c.nx + c.nnz], vals[c.nx + c.nnz:])
    assert keep.sum() == 3 * len(m.layout.vmax)  # only the speed cones (3 rows each) remain
    d.G[0], d.bp[0] = [1.0, 0.0], 7.9  # |G| (4 + 4) > 7.9: the pair row can bind, kept
    d.N[0], d.bo[0] = [0.0, 1.0], 4.0  # |N| 4 <= 4: implied, dropped
    vals = c.c0 + c.c1 * np.append(d.theta(m.linear_term(d)), 0.0)[c.j]
    keep2 = c.rows_needed(vals[c.nx: c.nx + c.nnz], vals[c.nx + c.nnz:])
    assert keep2.sum() == keep.sum() + 1


def test_infeasible_obstacle_rows_use_the_reported_slack_fallback():
    L = _layout()
    d = _data(np.random.default_rng(4))
    d.N[:] = 0.0
    d.N[0] = [1.0, 0.0]  # robot 0: u_x <= -10 cannot hold with u_x >= lo = -3
    d.bo[0] = -10.0
    solver = QPSolver(L, 0.5, 4.0, 1e4, _SETTINGS)
    sol = solver.solve(d)
    assert sol.U is not None and sol.fallback
    assert sol.slack == pytest.approx(7.0, abs=1e-4)  # the exact penalty: the least slack
    assert sol.U[0, 0] == pytest.approx(-3.0, abs=1e-4)
    d.bo[0] = 10.0  # feasible again: the hard model, no slack
    sol = solver.solve(d)
    assert not sol.fallback and sol.slack == 0.0


def test_qp_history_row_and_statistics_are_no_metrics():
    res = op.solve("formation-open-field", "formation-qp", rng=0, max_steps=30, **FAST)
    for col in ("qp_status", "qp_ok", "qp_time", "qp_solve_time", "qp_slack", "qp_pairs",
                "qp_fallback"):
        assert len(res.history[col]) == len(res.history)
    for k in ("qp_failures", "qp_solves", "slack_steps", "max_slack", "rebuilds", "qp_compiled",
              "qp_median_ms"):
        assert k in res.extras and k not in res.metrics
    assert res.extras["qp_compiled"]
    assert res.extras["qp_solves"] == len(res.history)
    assert np.all(res.history["qp_solve_time"] <= res.history["qp_time"])


# ---------------------------------------------------------------- behaviour ------------


@pytest.mark.parametrize("solver", ["leader-follower-paper", "formation-qp"])
def test_open_field_converges_to_L_phi(solver):
    res = op.solve("formation-open-field", solver, rng=0, **FAST)
    assert res.success, res.message
    L = 30.0
    assert res.metrics["formation_final_error"] < 0.01 * L
    fe = res.history["formation_error"]
    assert fe[0] > 0.3 * L  # started well off the slots
    prob = op.load_problem("formation-open-field")
    err = formation_errors(prob, res.paths)
    assert np.all(np.abs(err["distance"][-1]) < 0.01 * L)
    assert np.all(np.abs(err["angle"][-1]) < 0.01)


def test_leader_follower_paper_formation_deflects_and_reforms():
    prob = op.load_problem("paper-formation")
    res = op.solve(prob, "leader-follower-paper", rng=0, **FAST)
    assert res.success, res.message
    m = res.metrics
    assert m["collisions"] == 0 and m["reached"]
    # f1 turned in behind the leader at the block (eq 52 shrank its angle) ...
    assert res.extras["follower_stats"]["min_phi_ratio"] < 0.6
    err = formation_errors(prob, res.paths)
    assert np.max(np.abs(err["angle"][:, 0])) > 0.3
    # ... and the team re-formed at the goal
    assert m["formation_final_error"] < 0.05 * 60


@pytest.mark.parametrize("scene", ["paper-formation", "paper-warehouse"])
def test_formation_qp_paper_scenes_safe_and_reach(scene):
    prob = op.load_problem(scene)
    res = op.solve(prob, "formation-qp", rng=0, **FAST)
    m = res.metrics
    assert res.success, res.message
    assert m["reached"] and m["collisions"] == 0
    assert res.extras["qp_failures"] == 0
    ok = res.history["qp_ok"].astype(bool)
    P = np.stack([res.paths[k] for k in res.paths], axis=1)
    d = np.hypot(*(P[:, :, None, :] - P[:, None, :, :]).transpose(3, 0, 1, 2))
    iu = np.triu_indices(P.shape[1], 1)
    sep = d[:, iu[0], iu[1]].min(axis=1)
    # the state after step k is row k + 1; the start is safe too
    after_ok = sep[1:][ok[: len(sep) - 1]]
    assert after_ok.min() >= prob.formation.safety_distance - 1e-6
    assert m["min_clearance"] >= 0


def test_solver_failure_is_a_safe_stop():
    res = op.solve("formation-open-field", "formation-qp", rng=0, max_iter=1, max_steps=6,
                   **FAST)
    assert res.extras["qp_failures"] == 6
    assert "6 QP failure(s) -> safe stop" in res.message
    for p in res.paths.values():
        np.testing.assert_allclose(p, np.repeat(p[:1], len(p), axis=0))  # nobody moved
    assert not res.success


def test_determinism_and_global_state():
    np.random.seed(123)  # noqa: NPY002 - checking the legacy global state is untouched
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    a = op.solve("formation-open-field", "formation-qp", rng=5, max_steps=40, **FAST)
    b = op.solve("formation-open-field", "formation-qp", rng=5, max_steps=40, **FAST)
    for k in a.paths:
        np.testing.assert_array_equal(a.paths[k], b.paths[k])
    np.testing.assert_array_equal(np.random.get_state()[1], before)  # noqa: NPY002


def test_followers_controller_interface():
    prob = op.load_problem("formation-open-field")
    for name in ("leader-follower-paper", "formation-qp"):
        fc = op.get_solver(name).followers_controller(prob, np.random.default_rng(0))
        ids = ["leader", "f1", "f2"]
        pos = np.array([prob.robot(i).start for i in ids], float)
        state = SimState(0, 0.0, ids, pos, np.zeros_like(pos), ObstacleField(prob), dt=0.5,
                         leader_velocity=np.array([2.0, 1.0]))
        u = fc.velocities(state, 0, [1, 2], 0.5)
        assert u.shape == (2, 2) and np.all(np.isfinite(u))
        assert isinstance(fc.stats, dict)
        assert isinstance(fc, FollowerController)
        assert isinstance(op.get_solver(name), FormationBackend)


def test_pilot_and_path_solver_are_resolved_when_built():
    assert op.get_solver("leader-follower-paper").stages["pilot"] is None  # "builtin"
    assert op.get_solver("formation-qp").pilot == "builtin"
    with pytest.raises(ValueError, match=r"option 'pilot' of backend 'leader-follower' must be a "
                       r"local planner .*'visgraph'"):
        op.get_solver("leader-follower", pilot="visgraph")
    with pytest.raises(ValueError, match=r"option 'pilot' .* no solver named 'sa-apff'; "
                       r"did you mean 'sa-apf'"):
        op.get_solver("leader-follower-paper", pilot="sa-apff")
    with pytest.raises(ValueError, match=r"option 'path_solver' of backend 'formation-qp' .* "
                       r"no solver named 'visgrap'; did you mean 'visgraph'"):
        op.get_solver("formation-qp", path_solver="visgrap")
    # a local planner as the pilot gets the pilot's gains (those it has as options)
    lf = op.get_solver("leader-follower", pilot="sa-apf", rho_0=80.0)
    p = lf.stages["pilot"]
    assert p.name == "sa-apf" and (p.k, p.eta, p.rho_0, p.n) == (15.0, 3.7, 80.0, 3.0)
    # "apf-paper" is no longer a magic value: it names the basic APF preset
    b = op.get_solver("leader-follower", pilot="apf-paper").stages["pilot"]
    assert b.name == "apf" and b.rho_0 == 100.0 and b.eta_match_n == 3.0
    res = op.solve("formation-open-field", "leader-follower-paper", rng=0, pilot="sa-apf",
                   max_steps=60, **FAST)
    assert res.extras["pilot"] == "sa-apf" and "pilot sa-apf" in res.message


def test_options_validated():
    with pytest.raises(ValueError, match="gamma"):
        FormationQP(gamma=3.0, dt=0.5)
    with pytest.raises(ValueError, match="unknown option 'qp_interface'"):
        op.get_solver("formation-qp", qp_interface="direct")  # one implementation only
    with pytest.raises(ValueError, match="k_f"):
        op.get_solver("leader-follower", k_f=5.0, dt=0.5)


# ---------------------------------------------------------------- property -------------


@st.composite
def _starts(draw):
    n = draw(st.integers(3, 5))
    pts = draw(st.lists(st.tuples(st.floats(20, 100), st.floats(20, 100)), min_size=n,
                        max_size=n))
    return np.array(pts)


@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(_starts(), st.floats(0.0, 2 * math.pi))
def test_property_cbf_rows_hold_after_every_step(starts, heading):
    Ds = 6.0
    d = np.hypot(*(starts[:, None] - starts[None]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    if d.min() < Ds + 0.1:
        starts = starts + np.arange(len(starts))[:, None] * np.array([7.0, 0.0])
        d = np.hypot(*(starts[:, None] - starts[None]).transpose(2, 0, 1))
        np.fill_diagonal(d, np.inf)
        if d.min() < Ds + 0.1:
            return
    n = len(starts)
    goal = starts[0] + 50 * np.array([math.cos(heading), math.sin(heading)])
    goal = np.clip(goal, 5, 195)
    data = {"name": "prop", "bounds": [0, 0, 200, 200],
            "robots": [{"id": "leader", "start": starts[0].tolist(), "goal": goal.tolist(),
                        "radius": 2.0, "max_speed": 4.0}]
            + [{"id": f"f{k}", "start": starts[k].tolist(), "radius": 2.0, "max_speed": 4.0}
               for k in range(1, n)],
            "obstacles": [{"type": "circle", "center": [150.0, 150.0], "radius": 10.0}],
            "formation": {"leader": "leader", "safety_distance": Ds,
                          "followers": [{"id": f"f{k}", "L": 15.0,
                                         "phi": float(np.linspace(-1.2, 1.2, n - 1)[k - 1])}
                                        for k in range(1, n)]}}
    prob = parse_problem(data)
    res = op.solve(prob, "formation-qp", rng=0, max_steps=25, **FAST)
    P = np.stack([res.paths[k] for k in prob.robot_ids], axis=1)
    ok = res.history["qp_ok"].astype(bool)
    iu = np.triu_indices(n, 1)
    for k in range(len(P) - 1):
        if ok[k]:
            dd = np.hypot(*(P[k + 1, iu[0]] - P[k + 1, iu[1]]).T)
            assert dd.min() >= Ds - 1e-6


# ---------------------------------------------------------------- generators -----------


@pytest.mark.parametrize("shape", ["line", "wedge", "grid"])
@pytest.mark.parametrize("n", [3, 10, 30, 100])
def test_generator_scenes(shape, n):
    prob = formation_scene(n, shape)
    assert len(prob.robots) == n and len(prob.formation.followers) == n - 1
    starts = np.array([r.start for r in prob.robots])
    d = np.hypot(*(starts[:, None] - starts[None]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    assert d.min() >= prob.formation.safety_distance
    # followers start exactly in their slots (heading 0)
    off = prob.formation.slot_offsets(0.0)
    np.testing.assert_allclose(prob.leader.start + off, starts[1:], atol=1e-9)


def test_jitter_phases_seeded():
    prob = op.load_problem("paper-formation")
    a = jitter_phases(prob, np.random.default_rng(1))
    b = jitter_phases(prob, np.random.default_rng(1))
    c = jitter_phases(prob, np.random.default_rng(2))
    t = 10.0
    pa = a.dynamic_obstacles[0].position(t)
    np.testing.assert_array_equal(pa, b.dynamic_obstacles[0].position(t))
    assert not np.allclose(pa, c.dynamic_obstacles[0].position(t))
    assert a.obstacles == prob.obstacles


# ---------------------------------------------------------------- safety layer ---------


def test_project_halfplanes_hand_cases_and_qp_twin():
    u0 = np.array([[2.0, 2.0], [2.0, 2.0], [0.5, 0.0], [0.0, 0.0]])
    A = np.zeros((4, 2, 2))
    b = np.full((4, 2), -np.inf)
    A[0, 0], b[0, 0] = [-1, 0], -1.0  # x <= 1: projection (1, 2)
    A[1, 0], b[1, 0] = [-1, 0], -1.0  # x <= 1 and y <= 0.5: corner (1, 0.5)
    A[1, 1], b[1, 1] = [0, -1], -0.5
    A[2, 0], b[2, 0] = [1, 0], 1.0  # x >= 1 (already feasible from u0? no: 0.5)
    A[3, 0], b[3, 0] = [1, 0], 1.0  # x >= 1 and x <= -1: infeasible -> compromise x = 0
    A[3, 1], b[3, 1] = [-1, 0], 1.0
    u, bad = project_halfplanes(u0, A, b)
    np.testing.assert_allclose(u, [[1, 2], [1, 0.5], [1, 0], [0, 0]], atol=1e-12)
    np.testing.assert_array_equal(bad, [False, False, False, True])
    # random polygons (all containing the origin) against a brute-force QP over a fine grid
    rng = np.random.default_rng(7)
    n, K = 30, 6
    ang = rng.uniform(0, 2 * np.pi, (n, K))
    A = np.stack([np.cos(ang), np.sin(ang)], -1)
    b = -rng.uniform(0.2, 2.0, (n, K))
    u0 = rng.normal(scale=3.0, size=(n, 2))
    u, bad = project_halfplanes(u0, A, b)
    assert not bad.any()
    assert np.all(np.einsum("nkd,nd->nk", A, u) - b >= -1e-9)
    g = np.linspace(-4, 4, 321)
    G = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    for i in range(n):
        ok = np.all(G @ A[i].T >= b[i], axis=1)
        best = np.min(np.sum((G[ok] - u0[i]) ** 2, axis=1))
        assert np.sum((u[i] - u0[i]) ** 2) <= best + 1e-9  # never worse than any grid point


def test_safety_filter_keeps_gaps_after_one_step():
    """Random crowded configurations: every filtered step keeps D_s and obstacle clearance."""
    prob = op.load_problem("paper-warehouse")
    lf = op.get_solver("leader-follower-paper")
    assert lf.safety and lf.recovery  # the preset turns the safety layer on
    Ds = prob.formation.safety_distance
    rng = np.random.default_rng(11)
    fld = ObstacleField(prob)
    dt = 0.5
    checked = 0
    for _ in range(200):
        c = np.array([rng.uniform(100, 220), rng.uniform(425, 480)])  # shelf-4a, temporary-1
        pos = c + rng.uniform(-12, 12, (3, 2))
        d = np.hypot(*(pos[:, None] - pos[None]).transpose(2, 0, 1))
        np.fill_diagonal(d, np.inf)
        _, od = fld.nearest(pos, 0.0)
        if d.min() < Ds + lf.sep_margin or od.min() < 3.0 + lf.clear_margin:
            continue
        fc = LPhiFollowers(prob, lf)
        a = rng.uniform(-np.pi, np.pi)
        ul = rng.uniform(0, 7.5) * np.array([math.cos(a), math.sin(a)])
        state = SimState(0, 0.0, ["leader", "f1", "f2"], pos, np.zeros_like(pos), fld, dt=dt,
                         leader_velocity=ul)
        u = fc.velocities(state, 0, [1, 2], float(rng.uniform(-np.pi, np.pi)))
        assert np.all(np.hypot(*u.T) <= 10.0 + 1e-9)
        if fc.stats["infeasible"]:
            continue
        new = pos + dt * np.vstack([ul, u])
        dn = np.hypot(*(new[:, None] - new[None]).transpose(2, 0, 1))
        np.fill_diagonal(dn, np.inf)
        assert dn.min() >= Ds - 1e-9
        _, odn = fld.nearest(new[1:], dt)
        assert odn.min() >= 3.0 - 1e-9
        checked += 1
    assert checked >= 30


def test_recovery_returns_followers_to_their_own_side():
    """Followers starting on the wrong side: the bare law settles in the mirrored slots."""
    d = {"name": "swapped", "bounds": [0, 0, 300, 300], "goal_tolerance": 1.0,
         "robots": [{"id": "leader", "start": [60.0, 60.0], "goal": [240.0, 220.0],
                     "radius": 2.0, "max_speed": 4.0},
                    {"id": "f1", "start": [20.0, 80.0], "radius": 2.0, "max_speed": 4.0},
                    {"id": "f2", "start": [75.0, 20.0], "radius": 2.0, "max_speed": 4.0}],
         "formation": {"leader": "leader", "safety_distance": 6.0,
                       "followers": [{"id": "f1", "L": 30.0, "phi": -math.pi / 4},
                                     {"id": "f2", "L": 30.0, "phi": math.pi / 4}]}}
    prob = parse_problem(d)
    bare = op.solve(prob, "leader-follower-paper", rng=0, safety=False, recovery=False, **FAST)
    assert bare.metrics["formation_final_error"] > 40  # mirrored: 2 L sin(pi/4) = 42.4
    res = op.solve(prob, "leader-follower-paper", rng=0, **FAST)
    assert res.success, res.message
    assert res.metrics["formation_final_error"] < 0.01 * 30
    assert res.metrics["min_separation"] >= 6.0
    assert res.extras["follower_stats"]["lost"] >= 2


def test_leader_follower_paper_warehouse_safe():
    """The small formation keeps D_s through the pilot's swerve (a regression test)."""
    prob = op.load_problem("paper-warehouse")
    res = op.solve(prob, "leader-follower-paper", rng=0, **FAST)
    m = res.metrics
    assert res.success, res.message
    assert m["reached"] and m["collisions"] == 0
    assert m["min_separation"] >= prob.formation.safety_distance
    assert m["min_clearance"] >= 0 and m["min_clearance_dynamic"] >= 0
    # the bare eqs 46-52 law (no safety layer) fails there: f1 and f2 touch
    bare = op.solve(prob, "leader-follower-paper", rng=0, safety=False, recovery=False,
                    **FAST)
    assert bare.metrics["collisions"] > 0


def test_safety_options_validated():
    with pytest.raises(ValueError, match="gamma_s"):
        op.get_solver("leader-follower", gamma_s=1.5)
    with pytest.raises(ValueError, match="safety"):
        op.get_solver("leader-follower", safety="yes")
