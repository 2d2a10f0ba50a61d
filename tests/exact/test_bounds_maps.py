"""The bounds are a wall, so the certified optimum exists wherever a path does.

A small version of ``benchmarks/bench_bounds.py``: a random MovingAI-type map *without* a
border of obstacles (start/goal cells on its border rows and columns included) read through
``optplan.maps.read_scen``, and a crop of a shipped occupancy map whose free space reaches the
crop's edge.  Every query has a path (grid-connected: the ``.scen`` octile length from the
benchmark's own Dijkstra, or a safe-cell route checked with shapely), so ``visgraph`` must be
``optimal`` with a certified optimum between the straight line and that independent length,
and its path must pass the validator.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import shapely

import optplan as op
from benchmarks import bench_bounds as bb
from optplan.catalog import map_files
from optplan.maps import read_ros_yaml, read_scen, scen_octile_length
from optplan.solver import reference_optimum

ROOT = Path(__file__).resolve().parents[2]

REL = 1e-9


def _grown(problem: op.Problem) -> op.Problem:
    """The same query on the map grown by its size on every side (the wall far away)."""
    import dataclasses

    x0, y0, x1, y1 = problem.bounds
    w, h = x1 - x0, y1 - y0
    return dataclasses.replace(problem, bounds=(x0 - w, y0 - h, x1 + w, y1 + h), _cache={})


def _check(problem: op.Problem, upper: float) -> tuple[float, bool]:
    """visgraph is optimal, the optimum certified and inside [straight line, upper]; returns
    the optimum and whether the wall binds (the grown map's optimum is shorter)."""
    res = op.solve(problem, "visgraph")
    st = res.status.value
    assert st in ("optimal", "infeasible"), f"{problem.name}: {st}: {res.message}"
    assert st == "optimal", f"{problem.name}: a path exists but visgraph says {res.message}"
    assert res.metrics["collisions"] == 0, res.message
    ref = reference_optimum(problem)
    assert ref["optimum"] is not None, f"{problem.name}: {ref['reference_error']}"
    opt = ref["optimum"]
    lead = problem.leader
    straight = math.hypot(*(lead.goal - lead.start))
    assert straight * (1 - REL) <= opt <= upper * (1 + REL), (problem.name, straight, opt, upper)
    assert math.isclose(res.metrics["optimum"], opt, rel_tol=REL)
    free = reference_optimum(_grown(problem))["optimum"]
    assert free is not None and free <= opt * (1 + REL)
    return opt, free < opt * (1 - REL)


def test_octile_oracle_applies_movingai_corner_rule():
    blocked_centre = np.ones((3, 3), dtype=bool)
    blocked_centre[1, 1] = False
    assert bb.octile_lengths(blocked_centre, [(0, 0)])[0][8] == 4.0  # no corner cutting
    open3 = np.ones((3, 3), dtype=bool)
    assert math.isclose(bb.octile_lengths(open3, [(0, 0)])[0][2 * 3 + 1], 1 + math.sqrt(2))
    assert math.isclose(bb.octile_lengths(open3, [(0, 0)])[0][8], 2 * math.sqrt(2))


def test_movingai_map_without_border(tmp_path: Path):
    rng = np.random.default_rng(3024)
    blocked = bb.random_movingai(rng, 24, 24, 0.3)
    assert not blocked[bb.border_mask(blocked.shape)].all()  # no border of obstacles
    bb.write_map(tmp_path / "rand.map", blocked)
    pairs = bb.pick_scen(rng, blocked, 15)
    scen = bb.write_scen(tmp_path / "rand.map.scen", "rand.map", blocked.shape, pairs)
    problems = read_scen(scen)
    assert len(problems) == 15
    on_border = sum(min(x, y, 23 - x, 23 - y) == 0 for (x, y), _, _ in pairs)
    assert on_border >= 7
    binds = 0
    for p, (_, _, length) in zip(problems, pairs, strict=True):
        assert scen_octile_length(p) == length
        opt, wall = _check(p, length)
        binds += wall
        # independently of optplan's predicates: the point robot's path stays in the map and
        # never enters an obstacle polygon's interior
        path = shapely.LineString(op.solve(p, "visgraph").paths[p.leader.id])
        tol = 1e-7 * p.extent
        assert shapely.box(*p.bounds).buffer(tol).covers(path)
        for o in p.obstacles:
            assert not o.geometry.buffer(-tol).intersects(path), o.name
    assert binds >= 1  # the wall changes some optimum: the check is not vacuous


def test_occupancy_crop_with_free_space_at_the_edge():
    name, path = sorted(map_files().items())[-1]
    grid = read_ros_yaml(path)
    sub = bb.crop(grid, np.random.default_rng([30, 0]))
    free = ~sub.obstacle_mask()
    assert all(side.any() for side in (free[0], free[-1], free[:, 0], free[:, -1]))
    queries = bb.map_queries(path, sub, np.random.default_rng([30, 1]), 5, f"{name}-crop")
    assert len(queries) == 5
    x0, y0, x1, y1 = sub.bounds
    near = 0
    for q in queries:
        assert math.isfinite(q.upper)  # the safe-cell route passed the shapely check
        _check(q.problem, q.upper)
        s = q.problem.leader.start
        near += min(s[0] - x0, x1 - s[0], s[1] - y0, y1 - s[1]) < 0.5  # m
    assert near >= 2
