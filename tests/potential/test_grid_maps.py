"""The local planners on grid-derived (MovingAI-type) maps: the defects found there and the
``sa-apf`` preset (docs/solvers/apf.md, "Grid maps").

Each defect test failed before its fix: a step through a thin obstacle was taken and the run
"reached the goal"; SA's candidate test accepted segments through obstacles for a point robot;
a step that started SA was recorded twice in the history.
"""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen
from optplan.potential.guide import Guide
from optplan.potential.swept import StepGuard, free_steps
from optplan.sim import ObstacleField


def _wall(width: float = 0.05, radius: float = 0.0) -> op.Problem:
    """A point robot (or a disc) in front of a wall thinner than one step."""
    return op.parse_problem({
        "name": "thin-wall", "bounds": [0, 0, 10, 10],
        "robots": [{"id": "r", "start": [2, 5], "goal": [8, 5], "radius": radius,
                    "max_speed": 1}],
        "obstacles": [{"type": "rectangle", "name": "wall",
                       "min": [5 - width / 2, 3], "max": [5 + width / 2, 7]}],
    })


def _lines(kind: str, size: int, seed: int, n: int, tmp_path, **kw) -> list[op.Problem]:
    g = movingai_benchmark(kind, size, tmp_path, rng=np.random.default_rng(seed), queries=n,
                           **kw)
    return read_scen(str(g.map_path) + ".scen")


def test_step_guard_sees_a_step_over_a_thin_wall_and_a_point_inside():
    prob = _wall()
    guard = StepGuard(prob, list(prob.robots))
    x = np.array([[4.9, 5.0]])
    assert "crosses 'wall'" in guard.check(x, np.array([[0.2, 0.0]]), 1.0, 0.0)  # over it
    assert guard.check(np.array([[4.9, 5.0]]), np.array([[0.09, 0.0]]), 1.0, 0.0)  # ends in it
    assert guard.check(np.array([[4.9, 5.0]]), np.array([[0.0, 0.2]]), 1.0, 0.0) == ""
    assert "bounds" in guard.check(np.array([[9.9, 5.0]]), np.array([[0.5, 0.0]]), 1.0, 0.0)


@pytest.mark.parametrize("preset", ["apf-paper", "sa-apf-paper"])
def test_a_step_through_an_obstacle_ends_the_run_as_a_collision(preset):
    """eta = 0: no repulsion, the robot drives straight at a wall thinner than its step.
    Before the fix the simulator's end-point test never saw it (a point robot inside an
    obstacle has distance 0, not below 0 - eps) and the run claimed "goal reached"."""
    res = op.solve(_wall(), preset, rng=0, eta=0.0, l=0.2)
    assert res.status is op.Status.failed
    assert res.message.startswith("collision: r's step from")
    assert "crosses 'wall'" in res.message
    assert res.extras["collision"]
    assert res.metrics["static_collisions"] == 0  # it stopped before the wall
    assert res.path[-1][0] < 5


def test_sa_candidates_through_an_obstacle_are_refused_for_a_point_robot():
    """SA's candidate test compared the sampled clearance with margin = 0.25 r = 0: a point
    robot's distance inside an obstacle is 0 >= 0, so every candidate passed."""
    prob = _wall()
    ctrl = op.get_solver("sa-apf-paper").controller(prob, "r", np.random.default_rng(0))
    fld = ObstacleField(prob)
    x = np.array([4.9, 5.0])
    cands = np.array([[5.1, 5.0], [5.0, 5.0], [4.9, 5.5], [4.5, 5.0]])
    np.testing.assert_array_equal(ctrl._segments_clear(x, cands, 0.0, fld),
                                  [False, False, True, True])


def test_history_has_one_row_per_step_also_when_sa_starts():
    res = op.solve("trap-u", "sa-apf-paper", rng=0)
    assert res.extras["local_minima_detected"] >= 1
    assert len(res.history) == res.extras["sim_steps"]


@pytest.mark.slow
def test_sa_apf_paper_never_claims_a_goal_reached_through_obstacles(tmp_path):
    """random-32-32-20 (seed 0), line 4: sa-apf-paper "reached the goal" with 4 static
    collisions before the SA segment test was exact."""
    q = _lines("random", 32, 0, 10, tmp_path, density=0.2)[2]
    res = op.solve(q, "sa-apf-paper", rng=1)
    assert res.metrics["static_collisions"] == 0
    assert res.status in (op.Status.solved, op.Status.approximate, op.Status.failed)
    if res.status is op.Status.solved:
        assert res.metrics["feasible"]


def test_free_step_is_always_free(tmp_path):
    """The safe step never leaves the free space, wherever the robot is and whatever the
    field asks (random free positions of a 16 x 16 random map, random steps)."""
    q = _lines("random", 16, 3, 2, tmp_path, density=0.3)[0]
    ctrl = op.get_solver("sa-apf").controller(q, "r1", np.random.default_rng(0))
    fld = ObstacleField(q)
    rng = np.random.default_rng(1)
    oset = q.obstacle_set(0.0)
    n = 0
    while n < 60:
        x = rng.uniform(0, 16, 2)
        if oset.point_distances(x[None])[0] <= 0:
            continue
        n += 1
        ev = {k: v for k, v in zip(("near", "dist"), fld.nearest(x[None]), strict=True)}
        step = rng.normal(size=2) * 0.5
        s = ctrl.free_step(x, step, fld, ev)
        assert float(np.hypot(*s)) <= float(np.hypot(*step)) + 1e-12
        assert free_steps(q, q.robots[0], x, (x + s)[None])[0]


def test_guide_subgoal_is_visible_and_replans_when_lost(tmp_path):
    q = _lines("maze", 16, 0, 3, tmp_path)[0]
    r = q.robots[0]
    g = Guide(q, r, r.start, r.goal)
    assert g.path is not None and len(g.path) > 2
    sub = g.subgoal(r.start, 0.2)
    assert g.visible and free_steps(q, r, r.start, sub[None])[0]
    g.i = len(g.path) - 1  # as if the robot were near the goal but it is at the start
    assert not free_steps(q, r, r.start, r.goal[None])[0]
    g._calls += 100
    sub = g.subgoal(r.start, 0.2)
    assert g.replans == 1 and g.visible and free_steps(q, r, r.start, sub[None])[0]


@pytest.mark.parametrize("kind,size,kw", [
    ("random", 16, {"density": 0.1}), ("random", 32, {"density": 0.2}),
    ("random", 24, {"density": 0.3}), ("room", 32, {}), ("maze", 16, {}), ("street", 32, {}),
])
def test_sa_apf_reaches_the_goal_validator_accepted(kind, size, kw, tmp_path):
    for k, q in enumerate(_lines(kind, size, 7, 3, tmp_path, **kw)):
        res = op.solve(q, "sa-apf", rng=k)
        assert res.status in (op.Status.solved, op.Status.optimal), (q.name, res.message)
        assert res.metrics["static_collisions"] == 0 and res.metrics["feasible"]


def test_paper_presets_keep_the_paper_model():
    """The fixes are checks of the motion, not of the field: the paper presets run the
    paper's field (no guide) with the paper's step (no slide)."""
    for name in ("apf-paper", "sa-apf-paper"):
        s = op.get_solver(name)
        assert s.safe_step is False and s.guide == "none"
    s = op.get_solver("sa-apf")
    assert s.safe_step is True and s.guide == "visgraph"
    for k in ("k", "eta", "rho_0", "n", "theta", "tau_0", "k_B", "sa_step"):
        assert getattr(s, k) == getattr(op.get_solver("sa-apf-paper"), k)


@pytest.mark.parametrize("scene,preset,digest,n", [
    ("paper-apf-env1", "apf-paper", "c1d069a3c63c46b0", 148),
    ("paper-apf-env1", "sa-apf-paper", "ac22311904fdf854", 108),
    ("trap-u", "sa-apf-paper", "e99583da4aaf92c6", 465),
])
def test_paper_scene_trajectories_are_those_before_the_fixes(scene, preset, digest, n):
    """Where the paper's scenes never step through an obstacle, the fixes change nothing:
    the trajectories (rounded to 1e-4) are bit-identical to those of the code before them
    (also paper-apf-env2 and paper-hybrid with hybrid-paper, checked once by hand)."""
    import hashlib

    res = op.solve(scene, preset, rng=0)
    assert len(res.path) == n
    assert hashlib.sha256(np.round(res.path, 4).tobytes()).hexdigest()[:16] == digest
