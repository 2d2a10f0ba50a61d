"""Basic APF (paper eqs 3-13) and the shared potential-field maths (eqs 34-37)."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.generators import swap_scene
from optplan.interfaces import LocalController, LocalPlanner
from optplan.potential.apf import APF
from optplan.potential.backend import oscillation_index
from optplan.potential.field import (
    FieldParams,
    attractive_force,
    attractive_potential,
    evaluate_field,
    repulsive_force,
    repulsive_potential,
)
from optplan.sim import ObstacleField, simulate

C = np.array([50.0, 40.0])  # circle obstacle centre
R = 5.0
GOAL = np.array([80.0, 55.0])


def _circle_geom(x: np.ndarray) -> tuple[np.ndarray, float]:
    v = x - C
    d = np.hypot(*v)
    return C + R * v / d, d - R


def _u_rep(x: np.ndarray, n: float, eta=3.7, rho_0=20.0) -> float:
    _, rho = _circle_geom(x)
    return float(repulsive_potential(rho, np.hypot(*(x - GOAL)), eta, rho_0, n))


@pytest.mark.parametrize("n", [0.0, 0.5, 1.0, 2.0, 3.0])
@pytest.mark.parametrize("x", [[58.0, 47.0], [40.0, 30.0], [50.0, 52.0], [62.0, 38.0]])
def test_improved_repulsion_is_minus_numerical_gradient_of_eq34(n, x):
    x = np.array(x)
    near, rho = _circle_geom(x)
    assert rho < 20.0
    F = repulsive_force(x, near, rho, GOAL, 3.7, 20.0, n)
    h = 1e-6
    grad = np.array([(_u_rep(x + h * e, n) - _u_rep(x - h * e, n)) / (2 * h) for e in np.eye(2)])
    np.testing.assert_allclose(F, -grad, rtol=1e-6, atol=1e-9 * max(1.0, np.abs(grad).max()))


def test_n_zero_reduces_to_eq6():
    x = np.array([57.0, 46.0])
    near, rho = _circle_geom(x)
    F = repulsive_force(x, near, rho, GOAL, 3.7, 20.0, 0.0)
    mag = 3.7 * (1 / rho - 1 / 20.0) / rho**2  # eq 6
    unit = (x - near) / np.hypot(*(x - near))
    np.testing.assert_allclose(F, mag * unit, rtol=1e-12)
    # and eq 34 with n = 0 is eq 5
    assert repulsive_potential(rho, 123.0, 3.7, 20.0, 0.0) == pytest.approx(
        0.5 * 3.7 * (1 / rho - 1 / 20.0) ** 2)


def test_eq36_eq37_components_and_directions():
    x = np.array([57.0, 46.0])
    near, rho = _circle_geom(x)
    rg = np.hypot(*(GOAL - x))
    n = 3.0
    F = repulsive_force(x, near, rho, GOAL, 3.7, 20.0, n)
    f1 = 3.7 * (1 / rho - 1 / 20) * rg**n / rho**2 * (x - near) / np.hypot(*(x - near))
    f2 = n / 2 * 3.7 * (1 / rho - 1 / 20) ** 2 * rg ** (n - 1) * (GOAL - x) / rg
    np.testing.assert_allclose(F, f1 + f2, rtol=1e-12)


def test_outside_influence_is_zero_and_attraction_eq4():
    x = np.array([10.0, 10.0])
    assert np.all(repulsive_force(x, np.array([40.0, 40.0]), 30.0, GOAL, 3.7, 20.0, 3) == 0)
    assert repulsive_potential(30.0, 50.0, 3.7, 20.0, 3) == 0
    np.testing.assert_allclose(attractive_force(x, GOAL, 15.0), 15.0 * (GOAL - x))
    h = 1e-6
    g = [(attractive_potential(x + h * e, GOAL, 15) - attractive_potential(x - h * e, GOAL, 15))
         / (2 * h) for e in np.eye(2)]
    np.testing.assert_allclose(attractive_force(x, GOAL, 15.0), -np.array(g), rtol=1e-6)


def test_forces_stay_finite_at_and_inside_obstacles():
    prob = op.load_problem("trap-saddle")
    fld = ObstacleField(prob)
    p = FieldParams(15, 3.7, 20, 3, 0.05, 2.0, 22.0)
    pts = np.array([[133.0, 50.0], [135.0, 50.0], [145.0, 50.0], [137.0 - 1e-13, 50.0]])
    ev = evaluate_field(pts, prob.robots[0].goal, fld, 0.0, p)
    assert np.all(np.isfinite(ev["F"])) and np.all(np.isfinite(ev["U"]))


def test_oscillation_index():
    assert oscillation_index(np.array([[0, 0], [1, 0], [2, 0]])) == 0
    zig = np.array([[0, 0], [1, 0], [0, 0], [1, 0]], float)
    assert oscillation_index(zig) == pytest.approx(2 * np.pi / 3)


# -- behaviour -----------------------------------------------------------------------------


def test_env1_basic_apf_oscillates_short_of_the_goal_gnron():
    res = op.solve("paper-apf-env1", "apf-paper", rng=0)
    assert res.status is op.Status.approximate
    assert "GNRON" in res.message
    assert not res.metrics["reached"]
    assert res.metrics["collisions"] == 0 and res.metrics["min_clearance_dynamic"] > 0
    assert res.extras["local_minima_detected"] >= 1
    assert "local_minima_detected" not in res.metrics  # backend statistics live in extras
    assert res.times is not None and len(res.times) == len(res.path)


def test_env2_basic_apf_is_trapped():
    res = op.solve("paper-apf-env2", "apf-paper", rng=0)
    assert res.status is op.Status.approximate
    assert "trapped in a local minimum" in res.message
    assert res.metrics["collisions"] == 0 and res.metrics["min_clearance_dynamic"] > 0
    # it stopped inside the cup
    x = res.path[-1]
    assert 110 < x[0] < 140 and 88 < x[1] < 118


def test_literal_eq6_scale_drives_into_obstacles():
    """Documented scaling pitfall: with the literal eta = 3.7 of eq 6 on map-scale scenes the
    repulsion is negligible, so the basic robot hits the obstacle (status failed)."""
    res = op.solve("trap-saddle", "apf-paper", rng=0, eta_match_n=0.0)
    assert res.status is op.Status.failed
    assert "collision" in res.message


def test_budget_never_hangs_and_is_not_success():
    res = op.solve("paper-apf-env1", "apf-paper", rng=0, max_steps=20)
    assert res.status is op.Status.approximate and "budget" in res.message
    assert len(res.path) == 21


def test_collision_with_fast_mover_is_failed_never_solved():
    prob = op.parse_problem({
        "name": "ram", "bounds": [0, 0, 100, 100],
        "robots": [{"id": "r", "start": [10, 50], "goal": [90, 50], "radius": 2,
                    "max_speed": 5}],
        "dynamic_obstacles": [{"type": "circle", "radius": 6, "waypoints": [[90, 50]],
                               "velocity": [-60.0, 0.0]}],
    })
    for s in ("apf-paper", "sa-apf-paper"):
        res = op.solve(prob, s, rng=0)
        assert res.status is op.Status.failed
        assert res.metrics["dynamic_contacts"] > 0


def test_determinism_and_global_state_untouched():
    np.random.seed(123)  # noqa: NPY002 - checking the legacy global state is untouched
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    a = op.solve("paper-apf-env2", "apf-paper", rng=3)
    b = op.solve("paper-apf-env2", "apf-paper", rng=3)
    np.testing.assert_array_equal(a.path, b.path)
    np.testing.assert_array_equal(np.random.get_state()[1], before)  # noqa: NPY002


def test_history_columns_and_callback_stop():
    res = op.solve("trap-gnron", "apf-paper", rng=0)
    for col in ("force", "potential", "temperature"):
        assert col in res.history.keys()
    assert np.all(np.isfinite(res.history["force"]))
    calls = []

    def cb(p):
        calls.append(p.iteration)
        if len(calls) == 5:
            raise StopIteration

    res = op.solve("trap-gnron", "apf-paper", rng=0, callback=cb)
    assert len(calls) == 5 and "callback" in res.message
    assert res.status is op.Status.approximate


@pytest.mark.parametrize("bad", [{"k": 0}, {"rho_0": -1}, {"dt": 0}, {"window": 2},
                                 {"max_steps": 0}, {"stall_ratio": 2.0}, {"eta_match_n": -1}])
def test_option_validation(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        APF(**bad)


def test_controller_protocol_with_simulate():
    prob = op.load_problem("trap-gnron")
    ctrl = op.get_solver("apf-paper").controller(prob, "r1", np.random.default_rng(0))
    sub = np.array([100.0, 50.0])
    ctrl.reset(sub)

    def policy(state):
        v = ctrl.velocity(state, 0)
        return None if v is None else v[None]

    assert isinstance(op.get_solver("apf-paper"), LocalPlanner)
    assert isinstance(op.get_solver("sa-apf-paper"), LocalPlanner)
    assert isinstance(ctrl, LocalController)
    out = simulate(prob, policy, ids=["r1"], dt=0.2, max_steps=200,
                   done=lambda s: np.hypot(*(s.positions[0] - sub)) <= 2.0)
    assert out.reason == "done"
    assert isinstance(ctrl.stats, dict) and "local_minima_detected" in ctrl.stats


# ---------------------------------------------------------------------------------------
# several independently planned robots (beyond the paper: option sense_robots)
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("solver", ["apf-paper", "sa-apf-paper"])
def test_robots_sense_each_other(solver):
    offset = swap_scene(2.0)
    blind = op.solve(offset, solver, rng=0, sense_robots=False)
    assert blind.status == op.Status.failed and "collision" in blind.message
    seen = op.solve(offset, solver, rng=0)  # default: sense_robots = true
    assert seen.status == op.Status.solved
    assert seen.metrics["collisions"] == 0
    assert seen.metrics["min_separation"] > 6.0  # the two radii


def test_head_on_swap_is_a_saddle_for_apf_and_an_escape_for_sa_apf():
    head_on = swap_scene(0.0)
    apf = op.solve(head_on, "apf-paper", rng=0)
    assert apf.metrics["collisions"] == 0
    assert apf.status == op.Status.approximate and "local minimum" in apf.message
    sa = op.solve(head_on, "sa-apf-paper", rng=0)
    assert sa.status == op.Status.solved and sa.metrics["collisions"] == 0


def test_sense_robots_changes_nothing_for_one_robot():
    a = op.solve("trap-saddle", "sa-apf-paper", rng=1)
    b = op.solve("trap-saddle", "sa-apf-paper", rng=1, sense_robots=False)
    np.testing.assert_array_equal(a.paths["r1"], b.paths["r1"])


def test_robots_as_obstacles_field():
    from optplan.potential.backend import RobotsAsObstacles

    prob = op.load_problem("trap-saddle")
    base = ObstacleField(prob)
    f = RobotsAsObstacles(base, np.array([[10.0, 10.0], [90.0, 10.0]]), np.array([2.0, 3.0]))
    assert f.n == base.n + 2 and f.n_static == base.n_static
    near, dist = f.nearest(np.array([[10.0, 15.0]]), 0.0, max_range=20.0)
    np.testing.assert_allclose(near[0, base.n], [10.0, 12.0])
    assert dist[0, base.n] == pytest.approx(3.0)
    assert np.isinf(dist[0, base.n + 1]) and np.isnan(near[0, base.n + 1]).all()  # out of range
