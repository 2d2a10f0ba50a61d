"""The hybrid planner on grid-derived (MovingAI-type) maps (docs/solvers/hybrid.md, "Grid
maps"): its steps are tested exactly, and ``hybrid-guided`` reaches the goal."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen


def test_a_leader_step_through_a_thin_wall_ends_the_run_as_a_collision():
    """Before the step guard the simulator's end-point test missed a point robot stepping
    over a wall thinner than its step, and the hybrid completed its sub-goals through it."""
    prob = op.parse_problem({
        "name": "thin-wall", "bounds": [0, 0, 10, 10],
        "robots": [{"id": "r", "start": [2, 5], "goal": [8, 5], "radius": 0.0,
                    "max_speed": 2}],
        "obstacles": [{"type": "rectangle", "name": "wall", "min": [4.97, 3],
                       "max": [5.03, 7]}],
    })
    local = op.get_solver("sa-apf-paper", eta=0.0)
    res = op.solve(prob, "hybrid-paper", rng=0, local_solver=local,
                   init={"r": np.array([[2.0, 5.0], [8.0, 5.0]])})
    assert res.message.startswith("collision: r's step from"), res.message
    assert "crosses 'wall'" in res.message
    assert res.metrics["static_collisions"] == 0
    assert res.status is not op.Status.solved


@pytest.mark.parametrize("kind,size,kw", [("random", 24, {"density": 0.3}), ("maze", 16, {}),
                                          ("room", 32, {})])
def test_hybrid_guided_reaches_the_goal_validator_accepted(kind, size, kw, tmp_path):
    g = movingai_benchmark(kind, size, tmp_path, rng=np.random.default_rng(5), queries=2,
                           **kw)
    for k, q in enumerate(read_scen(str(g.map_path) + ".scen")):
        res = op.solve(q, "hybrid-guided", rng=k)
        assert res.status in (op.Status.solved, op.Status.optimal), (q.name, res.message)
        assert res.metrics["static_collisions"] == 0
