"""ORCA's velocity programs (optplan.formation.orca_lp) against RVO2 itself, and ``orca``
taking the whole avoidance of a moving obstacle (``mover_share``)."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.formation.orca_lp import full_share, orca_velocity
from optplan.problem import parse_problem

pyrvo = pytest.importorskip("pyrvo", reason="RVO2's Python bindings (extra [orca])")


def _world(rng: np.random.Generator, n: int, obstacle: bool):
    """An RVO2 world of ``n`` agents at random, with random velocities and preferences, and
    a square obstacle in the middle; stepped once."""
    sim = pyrvo.RVOSimulator(0.2, 8.0, 10, 2.0, 1.0, 0.5, 1.5)
    if obstacle:
        sim.add_obstacle([(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)])
        sim.process_obstacles()
    for _ in range(n):
        while True:  # agents start apart and outside the square (RVO2's assumption)
            p = rng.uniform(-6, 6, 2)
            if np.abs(p).max() > 1.6:
                break
        k = sim.add_agent((float(p[0]), float(p[1])))
        v, pref = rng.uniform(-1.5, 1.5, 2), rng.uniform(-2.0, 2.0, 2)
        sim.set_agent_velocity(k, (float(v[0]), float(v[1])))
        sim.set_agent_pref_velocity(k, (float(pref[0]), float(pref[1])))
    sim.do_step()
    return sim


@pytest.mark.parametrize("seed", range(6))
def test_the_program_on_rvo2s_lines_is_rvo2s_velocity(seed):
    """The independent oracle is RVO2: its lines, solved here, give its velocity (to single
    precision), infeasible programs (linearProgram3) included."""
    rng = np.random.default_rng(seed)
    sim = _world(rng, 12, obstacle=seed % 2 == 0)
    checked = 0
    for i in range(sim.get_num_agents()):
        n = sim.get_agent_num_orca_lines(i)
        if n == 0:
            continue
        lines = [sim.get_agent_orca_line(i, k) for k in range(n)]
        dirs = np.array([d for d, _ in lines])
        pts = np.array([q for _, q in lines])
        n_obst = n - sim.get_agent_num_agent_neighbors(i)
        pref = np.array(sim.get_agent_pref_velocity(i).to_tuple())
        got = orca_velocity(pts, dirs, n_obst, sim.get_agent_max_speed(i), pref)
        want = np.array(sim.get_agent_velocity(i).to_tuple())
        assert got == pytest.approx(want, abs=2e-4), (i, n, n_obst)
        checked += 1
    assert checked >= 6


def test_full_share_doubles_the_step_of_the_line():
    v, p = np.array([1.0, 0.0]), np.array([1.0, 0.5])  # u / 2 = (0, 0.5)
    assert full_share(p, v, 1.0) == pytest.approx([1.0, 1.0])
    assert full_share(p, v, 0.5) == pytest.approx(p)


def test_an_unfeasible_program_keeps_the_obstacle_lines():
    """Two agent lines that exclude each other and an obstacle line: the result keeps the
    obstacle's side and splits the agents' violation evenly (RVO2's linearProgram3)."""
    pts = np.array([[0.0, -0.5], [0.0, 0.2], [0.0, -0.2]])
    # permitted: left of each direction; the obstacle's y >= -0.5, the agents' y >= 0.2 and
    # y <= -0.2 (no velocity satisfies both)
    dirs = np.array([[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0]])
    v = orca_velocity(pts, dirs, 1, 2.0, np.array([0.0, 1.0]))
    assert v[1] >= -0.5 - 1e-12
    assert v[1] == pytest.approx(0.0, abs=1e-9)  # 0.2 below one line, 0.2 above the other


def _head_on(offset: float) -> op.Problem:
    """A robot and a disc driving at each other at the same speed."""
    return parse_problem({
        "name": "head-on", "bounds": [-5, -10, 25, 10],
        "robots": [{"id": "r", "start": [0, 0], "goal": [20, 0], "radius": 0.5,
                    "max_speed": 1.0}],
        "dynamic_obstacles": [{"type": "circle", "radius": 1.0,
                               "waypoints": [[20, offset], [0, offset]], "times": [0, 20]}]})


@pytest.mark.parametrize("offset", [0.0, 0.3, 1.0])
def test_a_robot_takes_the_whole_avoidance_of_a_mover(offset):
    """Against a disc that keeps its course, half the avoidance (RVO2's reciprocal rule) runs
    into it; the whole avoidance passes it and reaches the goal."""
    half = op.solve(_head_on(offset), "orca", mover_share=0.5, rng=0)
    whole = op.solve(_head_on(offset), "orca", rng=0)
    assert half.metrics["collisions"] >= 1 and half.status is op.Status.failed
    assert whole.metrics["collisions"] == 0 and whole.status is op.Status.solved
    assert whole.options["mover_share"] == 1.0
