"""SA-APF (paper §IV.A-B): improved repulsion, eq 38 detection, simulated-annealing escape."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.experiments import traps
from optplan.potential.sa_apf import K_B, SAAPF


def _d(problem: str) -> float:
    r = op.load_problem(problem).robots[0]
    return float(np.hypot(*(r.goal - r.start)))


def test_env1_sa_apf_reaches_goal_avoiding_movers():
    res = op.solve("paper-apf-env1", "sa-apf-paper", rng=0)
    assert res.status is op.Status.solved, res.message
    m = res.metrics
    assert m["reached"] and m["collisions"] == 0 and m["dynamic_contacts"] == 0
    assert m["min_clearance_dynamic"] > 0 and m["min_clearance"] > 0
    assert res.extras["time_to_goal"] == pytest.approx(res.times[-1], abs=0.21)


def test_env1_fails_without_the_rho_n_factor():
    """Remove the improvement (n = 0, eta in the same units as n = 3 at the start): GNRON."""
    res = op.solve("paper-apf-env1", "sa-apf-paper", rng=0, n=0.0,
                   eta=3.7 * _d("paper-apf-env1") ** 3, sa_budget=300)
    assert not res.success
    assert not res.metrics["reached"]


def test_env2_sa_apf_escapes_the_trap_and_reaches():
    res = op.solve("paper-apf-env2", "sa-apf-paper", rng=0)
    assert res.status is op.Status.solved, res.message
    m, ex = res.metrics, res.extras
    assert ex["local_minima_detected"] >= 1 and ex["local_minima_escaped"] >= 1
    assert ex["sa_steps"] > 0
    assert sum(ex["detections"].values()) == ex["local_minima_detected"]
    assert m["collisions"] == 0 and m["min_clearance_dynamic"] > 0
    T = res.history["temperature"]
    assert np.any(np.isfinite(T))  # the SA phase is logged


def test_env2_fails_without_the_annealing_escape():
    res = op.solve("paper-apf-env2", "sa-apf-paper", rng=0, sa_budget=1)
    assert not res.success
    assert "SA budget" in res.message


def test_physical_boltzmann_constant_makes_acceptance_zero():
    """Why k_B = 1: with 1.380649e-23 every uphill move is rejected (exp underflows to 0)."""
    dU, T = 1.0, 1e6
    assert math.exp(-dU / (1.380649e-23 * T)) == 0.0
    assert K_B == 1.0
    assert 0.0 < math.exp(-dU / (K_B * T)) < 1.0


def test_cooling_eq16_and_perturbation_eq14():
    prob = op.load_problem("trap-u")
    b = SAAPF(theta=0.97, sa_batch=10)
    c = b.controller(prob, "r1", np.random.default_rng(0))
    x = np.array([120.0, 50.0])
    c._start_sa(x)
    T0 = c.T
    assert T0 == pytest.approx(b.tau_0 * 0.5 * b.k * 45.0**2)
    from optplan.sim import ObstacleField

    fld = ObstacleField(prob)
    acc = c._propose(x, 0.0, fld)
    used = c.escape_steps
    assert c.T == pytest.approx(T0 * 0.97**used)
    if acc is not None:  # an accepted candidate lies within the eq 14 box
        assert np.all(np.abs(acc - x) <= b.sa_step * 0.97 ** -used + 1e-9)


def test_determinism_same_seed_same_trajectory():
    a = op.solve("trap-u", "sa-apf-paper", rng=7)
    b = op.solve("trap-u", "sa-apf-paper", rng=7)
    np.testing.assert_array_equal(a.path, b.path)
    assert a.extras["sa_steps"] == b.extras["sa_steps"]


def test_sa_budget_gives_up_never_hangs():
    res = op.solve("trap-u", "sa-apf-paper", rng=0, sa_restarts=0, theta=0.5, sa_budget=5)
    assert res.status is op.Status.approximate
    assert res.extras["sim_steps"] < 3000


@pytest.mark.parametrize("bad", [{"theta": 1.0}, {"theta": 0.0}, {"tau_0": 0.0}, {"n": -1},
                                 {"sa_batch": 0}, {"sa_budget": 0}, {"rollout": -1}])
def test_option_validation(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        SAAPF(**bad)


def test_jitter_variants_are_seeded_and_valid():
    a = traps.variants("trap-u", 3, 0, 4.0)
    b = traps.variants("trap-u", 3, 0, 4.0)
    assert len(a) == 4
    for p, q in zip(a[1:], b[1:]):
        assert p.obstacles[0].geometry.equals(q.obstacles[0].geometry)
    assert not a[1].obstacles[0].geometry.equals(a[0].obstacles[0].geometry)


def test_jitter_moves_exact_circles():
    """A circle obstacle moves its exact centre and stays unpolygonised; starts stay clear."""
    base, *var = traps.variants("trap-gnron", 3, 0, 4.0)
    o0 = base.obstacles[0]
    assert o0.is_circle and o0.geometry is None
    for p in var:
        o = p.obstacles[0]
        assert o.is_circle and o.geometry is None and o.radius == o0.radius
        d = o.center - o0.center
        assert 0 < np.max(np.abs(d)) <= 4.0
        x0, y0, x1, y1 = p.bounds
        bx0, by0, bx1, by1 = o.bounds
        assert x0 <= bx0 and y0 <= by0 and bx1 <= x1 and by1 <= y1
        r = p.robots[0]
        dist = p.obstacle_set(r.radius).point_distances(np.array([r.start, r.goal]))
        assert np.all(dist >= r.radius - p.frame.eps)


def _check_stats(n_variants: int, min_rate: float):
    rows = traps.run(n_variants=n_variants, seed=0)
    for r in rows:  # never solved with a collision
        if r["success"]:
            assert r["collisions"] == 0
    summ = {(s["trap"], s["solver"]): s for s in traps.summarize(rows)}
    for t in traps.TRAPS:
        assert summ[t, "sa-apf-paper"]["success_rate"] >= min_rate, summ[t, "sa-apf-paper"]
    for t in ("trap-gnron", "trap-u"):
        assert summ[t, "sa-apf-paper"]["success_rate"] > summ[t, "apf-paper"]["success_rate"]
    return summ


def test_trap_suite_fast():
    _check_stats(2, 1.0)


@pytest.mark.slow
def test_trap_suite_statistics_30_variants():
    _check_stats(30, 0.95)
