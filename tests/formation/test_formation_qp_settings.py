"""Clarabel settings of the formation QP: refinement off, retried with it on trouble."""

from __future__ import annotations

import numpy as np

import optplan as op
import optplan.formation.formation_qp as fq

FAST = {"path_solver": "visgraph"}


def test_settings_allow_in_place_updates_and_skip_refinement():
    st = fq.qp_settings(op.get_solver("formation-qp", tol=1e-6, max_iter=40))
    assert st["presolve_enable"] is False and st["chordal_decomposition_enable"] is False
    assert st["iterative_refinement_enable"] is False
    assert st["max_iter"] == 40 and st["tol_gap_abs"] == st["tol_gap_rel"] == st["tol_feas"] == 1e-6


def _model() -> fq.QPModel:
    layout = fq.QPLayout(3, np.array([[0, 1], [0, 2], [1, 2]]), 2, 0, np.array([[1, 0], [2, 0]]),
                         np.array([10.0, 1.0, 1.0]), np.array([4.0, 4.0, 4.0]))
    opts = op.get_solver("formation-qp")
    return fq.QPModel(layout, 0.5, 4.0, 1e4, fq.qp_settings(opts))


def test_numerical_failure_is_retried_with_refinement():
    m = _model()
    c = m.compiled
    assert c is not None  # the map was read off cvxpy and verified with these settings
    theta = m.feasible_theta(np.random.default_rng(1))
    good = c.solve(theta)
    assert good.status == "Solved" and not good.retried and good.iterations > 0
    cs = c.clarabel  # the Clarabel adapter (optplan.formation.clarabel)
    cs.settings = {**cs.settings, "max_iter": 1}  # a numerical stop, not an infeasibility
    cs.reset()
    bad = c.solve(theta)
    assert bad.retried and bad.U is None and bad.status == "MaxIterations"
    assert cs.retries == 1
    cs.settings = {**cs.settings, "max_iter": 50}
    again = c.solve(theta)  # the next step builds the solver afresh and solves
    assert again.status == "Solved" and not again.retried
    np.testing.assert_allclose(again.U, good.U, atol=1e-5)  # both to tol 1e-7


def test_retries_and_iterations_are_reported():
    ok = op.solve("formation-open-field", "formation-qp", rng=0, max_steps=20, **FAST)
    assert ok.extras["qp_retries"] == 0 and ok.extras["qp_failures"] == 0
    assert "qp_retries" not in ok.metrics
    assert np.all(ok.history["qp_iterations"] > 0)


def test_refinement_does_not_change_the_trajectories(monkeypatch):
    a = op.solve("paper-formation", "formation-qp", rng=0, max_steps=120, **FAST)
    shipped = fq.qp_settings
    monkeypatch.setattr(fq, "qp_settings",
                        lambda o: {**shipped(o), "iterative_refinement_enable": True})
    b = op.solve("paper-formation", "formation-qp", rng=0, max_steps=120, **FAST)
    for k in a.paths:  # the same to rounding, which the obstacle contacts amplify late on
        np.testing.assert_allclose(a.paths[k][:80], b.paths[k][:80], atol=1e-8)
        np.testing.assert_allclose(a.paths[k], b.paths[k], atol=1e-3)
