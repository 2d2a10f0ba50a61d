"""The speed-ups of the SA-APF step (issue 46 item 4) change no answer: the kernels give,
bit for bit, what the formulas they replace give (those formulas are the oracles here).

* SA's candidate test (:meth:`SAAPFController._segments_clear`) samples each segment only
  when a sample can fail (``radius + margin > 0``; a distance is never negative) and only for
  the candidates the exact segment test passes, with the sample count of all candidates;
* :func:`repulsive_force` computes the masked entries without the placeholder arrays.

The whole runs are pinned by ``benchmarks/bench_sa_apf_grid.py --against REV`` (docs/solvers/
apf.md, "Speed on grid maps") and by the trajectory digests of ``test_grid_maps.py``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import optplan as op
from optplan.generators import movingai_benchmark
from optplan.maps import read_scen
from optplan.potential.field import repulsive_force
from optplan.potential.swept import free_steps
from optplan.sim import ObstacleField


def _sampled(ctrl, x, cands, t, fld):
    """The candidate test as it was: every segment sampled, then the exact test."""
    d = cands - x
    L = np.hypot(d[:, 0], d[:, 1])
    h = max(0.5 * ctrl.robot.radius, 1e-3 * ctrl.params.unit)
    S = int(min(max(np.ceil(L.max() / h), 1), 400)) if len(L) else 1
    s = np.linspace(0.0, 1.0, S + 1)[1:]
    pts = x + s[None, :, None] * d[:, None, :]
    _, dist = fld.nearest(pts.reshape(-1, 2), t, max_range=ctrl.params.sense_range)
    cl = (dist.min(axis=1) if dist.shape[1] else np.full(len(pts.reshape(-1, 2)), np.inf))
    cl = cl.reshape(len(cands), S) - ctrl.robot.radius
    return (cl.min(axis=1) >= ctrl.margin) & free_steps(ctrl.problem, ctrl.robot, x, cands)


@pytest.mark.parametrize("radius", [0.0, 0.05, 0.3])
def test_candidate_test_is_the_sampled_one(radius, tmp_path):
    """Random candidates around free points of a 32 x 32 random map (20 % blocked), a point
    robot and two discs, with a moving disc near the robot: the same verdicts."""
    g = movingai_benchmark("random", 32, tmp_path, rng=np.random.default_rng(7), queries=2)
    q = read_scen(str(g.map_path) + ".scen")[0]
    r = q.robots[0]
    mover = op.parse_problem({  # a moving disc crossing the robot's start
        "name": "mover", "bounds": list(q.bounds),
        "robots": [{"id": "m", "start": [1, 1], "goal": [2, 2], "radius": 0}],
        "dynamic_obstacles": [{"type": "circle", "name": "mover", "radius": 0.4,
                               "waypoints": [list(r.start), [r.start[0] + 3, r.start[1] + 1]],
                               "times": [0.0, 10.0]}],
    }).dynamic_obstacles
    prob = q.replaced(robots=(dataclasses.replace(r, radius=radius),), dynamic_obstacles=mover)
    rid = prob.robots[0].id
    ctrl = op.get_solver("sa-apf-paper").controller(prob, rid, np.random.default_rng(0))
    fld = ObstacleField(prob)
    rng = np.random.default_rng(1)
    x0, y0, x1, y1 = prob.bounds
    seen = by_samples = 0
    for _ in range(60):
        x = rng.uniform([x0 + 1, y0 + 1], [x1 - 1, y1 - 1])
        if not free_steps(prob, prob.robots[0], x, x[None])[0]:
            continue
        cands = x + rng.uniform(-3, 3, size=(int(rng.integers(1, 9)), 2))
        t = float(rng.uniform(0, 5))
        want = _sampled(ctrl, x, cands, t, fld)
        np.testing.assert_array_equal(ctrl._segments_clear(x, cands, t, fld), want)
        by_samples += int(np.sum(free_steps(prob, prob.robots[0], x, cands) & ~want))
        seen += 1
    assert seen >= 20
    assert by_samples > 0 if radius == 0.3 else by_samples == 0  # the samples were tested


def _force_before(x, near, rho, goal, eta, rho_0, n=0.0):
    """:func:`repulsive_force` as it was (placeholder arrays under the masks)."""
    x = np.asarray(x, dtype=float)
    rho = np.asarray(rho, dtype=float)
    inside = rho <= rho_0
    v = x - near
    nv = np.hypot(v[..., 0], v[..., 1])
    ok = inside & (nv > 1e-12)
    with np.errstate(divide="ignore", invalid="ignore"):
        n_or = np.where(ok[..., None], v / np.where(ok, nv, 1.0)[..., None], 0.0)
        a = np.where(inside, 1.0 / rho - 1.0 / rho_0, 0.0)
        g = np.asarray(goal, dtype=float) - x
        rg = np.hypot(g[..., 0], g[..., 1])
        f1 = np.where(inside, eta * a / np.where(inside, rho, 1.0) ** 2, 0.0)
        if n != 0:
            f1 = f1 * rg ** n
    F = f1[..., None] * n_or
    if n != 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            n_rg = np.where((rg > 1e-12)[..., None], g / np.where(rg > 1e-12, rg, 1.0)[..., None],
                            0.0)
            f2 = np.where(inside & (rg > 1e-12), 0.5 * n * eta * a * a
                          * np.power(np.where(rg > 1e-12, rg, 1.0), n - 1.0), 0.0)
        F = F + f2[..., None] * n_rg
    return F


@pytest.mark.parametrize("n", [0.0, 0.5, 1.0, 2.0, 3.0])
@pytest.mark.parametrize("size", [1, 7, 64])
def test_repulsive_force_is_the_formula_before(n, size):
    """Bit for bit on random pairs, with the edge cases: beyond rho_0, the robot on the
    nearest point (nv = 0), at the goal (rg = 0), unseen (nan nearest point, inf clearance)."""
    rng = np.random.default_rng(size)
    x = rng.uniform(0, 50, (size, 2))
    near = x + rng.normal(0, 3, (size, 2))
    rho = rng.uniform(0.01, 30.0, size)
    goal = rng.uniform(0, 50, 2)
    if size > 4:
        near[0] = x[0]
        x[1] = goal
        near[2], rho[2] = np.nan, np.inf
        rho[3] = 20.0
    got = repulsive_force(x, near, rho, goal, 3.7, 20.0, n)
    want = _force_before(x, near, rho, goal, 3.7, 20.0, n)
    assert got.tobytes() == want.tobytes()
