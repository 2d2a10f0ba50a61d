"""The canonical frame (optplan.canonical): the image is the same scene for every drawing scale,
it moves nothing by more than half the geometric tolerance, and what the hybrid plans in it is
reported in world units."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

import optplan as op
from optplan.canonical import DIGITS, canonical_problem, to_canonical
from optplan.problem import transform_problem


def _coords(p: op.Problem) -> np.ndarray:
    """Every coordinate and length of a problem, flattened in a fixed order."""
    parts: list[np.ndarray] = [np.asarray(p.bounds, float)]
    for r in p.robots:
        parts += [r.start, np.atleast_1d(np.nan if r.goal is None else r.goal),
                  np.array([r.radius, r.max_speed])]
    for o in p.obstacles:
        parts.append(shapely.get_coordinates(o.geometry).ravel() if o.geometry is not None
                     else np.r_[o.center, o.radius])
    for d in p.dynamic_obstacles:
        shape = (np.array([d.radius]) if d.kind == "circle"  # the polygon only draws it
                 else shapely.get_coordinates(d.local_geometry).ravel())
        parts += [d.waypoints.ravel(), shape]
    if p.formation is not None:
        parts.append(np.array([f.L for f in p.formation.followers]
                              + [p.formation.safety_distance]))
    return np.concatenate([np.ravel(x) for x in parts])


@pytest.mark.parametrize("scene", ["office-floor", "warehouse-grid", "warehouse-team",
                                   "paper-hybrid"])
def test_image_is_bitwise_the_same_for_every_drawing_scale(scene: str) -> None:
    base = canonical_problem(op.load_problem(scene))
    for k in (0.01, 0.3, 7.0, 100.0, 1e4):
        im = canonical_problem(transform_problem(op.load_problem(scene), k))
        assert np.array_equal(_coords(im), _coords(base), equal_nan=True), (scene, k)
        assert im.length_scale == 1.0
        assert im.world_unit == pytest.approx(base.world_unit * k, rel=1e-12)


def test_a_paper_scene_is_its_own_image() -> None:
    """length_scale 1 and coordinates with few decimals: nothing moves at all."""
    for scene in ("paper-env1", "paper-env2", "paper-hybrid", "trap-u", "trap-saddle"):
        p = op.load_problem(scene)
        assert np.array_equal(_coords(canonical_problem(p)), _coords(p), equal_nan=True)


@pytest.mark.parametrize("scene", ["office-floor", "warehouse-grid", "paper-env2"])
def test_rounding_moves_nothing_by_more_than_half_the_tolerance(scene: str) -> None:
    p = op.load_problem(scene)
    im = canonical_problem(p)
    moved = np.nanmax(np.abs(_coords(im) * im.world_unit - _coords(p)))
    diag_image = math.hypot(im.bounds[2] - im.bounds[0], im.bounds[3] - im.bounds[1])
    decimals = DIGITS - math.floor(math.log10(diag_image))
    assert moved <= 0.5 * 10.0 ** -decimals * im.world_unit * (1 + 1e-9)
    assert moved <= 0.5 * p.frame.eps


def test_to_canonical_matches_the_image() -> None:
    p = op.load_problem("office-floor")
    im = canonical_problem(p)
    starts = np.array([r.start for r in p.robots])
    assert np.array_equal(to_canonical(im, starts), np.array([r.start for r in im.robots]))


def test_hybrid_reports_in_world_units() -> None:
    """Paths, history, extras and callbacks of a hybrid run on a metre-scale scene are in metres."""
    p = op.load_problem("warehouse-team")
    seen: list[float] = []
    found: list[float] = []

    def cb(pr: op.Progress) -> None:
        seen.append(pr.best_cost)
        if "feasible_best_length" in pr.info:
            found.append(pr.info["feasible_best_length"])

    res = op.solve(p, "hybrid-paper", rng=0, callback=cb)
    assert res.status in (op.Status.solved, op.Status.optimal)
    lead = p.leader
    path = res.paths[lead.id]
    assert np.array_equal(path[0], lead.start)  # exact, not the image's rounded start
    assert np.hypot(*(path[-1] - lead.goal)) <= p.goal_tol(lead) * (1 + 1e-9)
    x0, y0, x1, y1 = p.bounds
    gp = res.extras["global_path"]
    assert np.all((gp[:, 0] >= x0) & (gp[:, 0] <= x1) & (gp[:, 1] >= y0) & (gp[:, 1] <= y1))
    assert res.extras["global_length"] == pytest.approx(
        float(np.sum(np.hypot(*np.diff(gp, axis=0).T))), rel=1e-12)
    assert res.extras["leader_field"]["length_scale"] == pytest.approx(p.length_scale)
    assert res.extras["canonical_unit"] == pytest.approx(p.length_scale)
    d_goal = np.hypot(*(path - lead.goal).T)
    assert np.allclose(res.history["dist_to_goal"], d_goal, rtol=1e-9, atol=1e-9 * p.frame.length)
    assert seen and seen[-1] == pytest.approx(d_goal[-1], rel=1e-6, abs=1e-6)
    # the global stage's best collision-free length, in metres like the global path
    assert np.nanmin(found) == pytest.approx(res.extras["global_length"], rel=1e-3)
    assert res.cost == pytest.approx(res.metrics["lengths"][lead.id], rel=1e-9)


def test_hybrid_init_path_is_taken_in_world_units() -> None:
    p = op.load_problem("paper-hybrid")
    small = transform_problem(p, 0.01)
    g1 = op.solve(p, "hybrid-paper", rng=3)
    init = g1.extras["global_path"]
    r1 = op.solve(p, "hybrid-paper", rng=3, init=init)
    r2 = op.solve(small, "hybrid-paper", rng=3, init=init * 0.01)
    assert r1.status == r2.status
    assert np.allclose(r2.paths[p.leader.id] / 0.01, r1.paths[p.leader.id], rtol=1e-9,
                       atol=1e-9 * p.frame.length)
