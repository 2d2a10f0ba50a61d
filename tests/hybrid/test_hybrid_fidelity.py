"""Hybrid fidelity items (docs/solvers/hybrid.md, "Fidelity notes")."""

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


def test_reach_visible_waits_until_the_next_subgoal_is_in_sight():
    """Beyond the paper (off in the presets): on paper-env1 (seed 0) switching at the first
    sub-goal within reach_tol turns the leader into the corner of the triangle and it wanders
    through SA walks; waiting until the next sub-goal is in sight avoids them."""
    off = op.solve("paper-env1", "hybrid-paper", rng=0)
    on = op.solve("paper-env1", "hybrid-paper", rng=0, reach_visible=True)
    assert off.success and on.success
    assert on.extras["local_stats"]["r1"]["escapes"] == 0
    assert off.extras["local_stats"]["r1"]["escapes"] > 0
    assert on.metrics["length"] < 0.2 * off.metrics["length"]
    assert op.get_solver("hybrid-paper").reach_visible is False


def test_next_visible_checks_the_segment_to_the_next_subgoal():
    from optplan.hybrid.tracker import Driver, SubgoalTracker
    from optplan.sim import ObstacleField, SimState

    prob = op.parse_problem({
        "name": "corner", "bounds": [0, 0, 100, 100], "length_scale": 1.0,
        "robots": [{"id": "r", "start": [10, 10], "goal": [90, 90], "radius": 2.0,
                    "max_speed": 5.0}],
        "obstacles": [{"type": "polygon", "vertices": [[40, 0], [60, 0], [60, 60], [40, 60]]}]})
    goals = np.array([[30.0, 70.0], [70.0, 70.0], [90.0, 90.0]])
    d = Driver(0, prob.robots[0], goals, controller=None, reach_tol=10.0, goal_tol=1.0)
    tr = SubgoalTracker([d], skip_blocked=True, stall_steps=0, sensing=None,
                        reach_visible=True)
    fld = ObstacleField(prob)

    def state(x):
        return SimState(1, 0.1, ["r"], np.array([x], float), np.zeros((1, 2)), fld, dt=0.1)

    assert not tr.next_visible(d, state([30.0, 55.0]))  # the block hides (70, 70)
    assert tr.next_visible(d, state([30.0, 66.0]))


def test_leader_rho_0_with_a_planner_without_rho_0():
    from dataclasses import dataclass
    from typing import ClassVar

    from optplan.interfaces import LocalPlanner
    from optplan.solver import Backend

    @dataclass(frozen=True, kw_only=True)
    class NoRho(Backend, LocalPlanner):
        name: ClassVar[str] = "no-rho"

        def controller(self, problem, robot_id, rng):
            raise NotImplementedError

    with pytest.raises(ValueError, match="leader_rho_0 = None"):
        op.get_solver("hybrid-paper", local_solver=NoRho())
    hyb = op.get_solver("hybrid-paper", local_solver=NoRho(), leader_rho_0=None)
    assert isinstance(hyb.stages["local_solver"], NoRho)
