"""Hybrid fidelity items (issue #17; docs/solvers/hybrid.md, "Fidelity notes")."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.experiments import hybrid_fidelity as hf
from optplan.generators import swap_scene


def test_leader_rho_0_is_explicit_and_reaches_the_leader():
    hyb = op.get_solver("hybrid-paper")
    assert hyb.leader_rho_0 == 20.0
    assert hyb.stages["local_solver"].rho_0 == 20.0
    assert op.get_solver("hybrid-paper", leader_rho_0=100.0).stages["local_solver"].rho_0 == 100
    assert op.get_solver("hybrid-paper", leader_rho_0=None).stages["local_solver"].rho_0 == 20
    res = op.solve("paper-hybrid", "hybrid-paper", rng=0, global_solver="visgraph",
                   leader_rho_0=100.0, max_steps=50)
    assert res.extras["leader_field"]["rho_0"] == pytest.approx(100.0)
    res = op.solve("paper-hybrid", "hybrid-paper", rng=0, global_solver="visgraph",
                   max_steps=50)
    assert res.extras["leader_field"]["rho_0"] == pytest.approx(20.0)


def test_leader_rho_0_must_fit_the_local_planner():
    with pytest.raises(ValueError, match="leader_rho_0"):
        op.get_solver("hybrid-paper", leader_rho_0=0.01)  # below sa-apf-paper's rho_min


@pytest.mark.parametrize("side", ["outer", "inner"])
@pytest.mark.parametrize("safety", [True, False])
@pytest.mark.parametrize("rho", [0.01, 0.04])
def test_eq52_below_one_twentieth_does_not_steer_into_the_obstacle(rho, side, safety):
    """Below rho = 1/c the code clamps eq 52 to phi_d = 0 (the literal formula flips the
    formation side); the follower's command still points away from the wall on either side."""
    r = hf.eq52_probe(rho, side, safety)
    assert r["ratio_code"] == 0.0 and r["ratio_literal"] < 0.0
    assert r["toward"] < 0.0


def test_hybrid_drivers_sense_each_other():
    swap = swap_scene(2.0)
    res = op.solve(swap, "hybrid-paper", rng=0, global_solver="visgraph", formation="")
    assert res.status is op.Status.solved, res.message
    assert res.metrics["min_separation"] > 6.0
    blind = op.solve(swap, "hybrid-paper", rng=0, global_solver="visgraph", formation="",
                     local_solver=op.get_solver("sa-apf-paper", sense_robots=False))
    assert "collision" in blind.message


def test_hybrid_distances_scale_with_the_problem():
    prob = op.load_problem("warehouse-grid")
    res = op.solve(prob, "hybrid-paper", rng=0, global_solver="visgraph", max_steps=20,
                   reach_tol=10.0)
    s = prob.length_scale
    assert res.extras["leader_field"]["rho_0"] == pytest.approx(20.0 * s)
    assert res.extras["leader_field"]["length_scale"] == pytest.approx(s)
    np.testing.assert_allclose(res.extras["subgoals"][-1], prob.leader.goal)
