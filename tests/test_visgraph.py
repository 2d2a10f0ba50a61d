"""The exact reference: visibility graph + Dijkstra (``optplan.backends.visgraph``).

The brute-force check builds the *full* visibility graph over start, goal and every vertex of
the inflated obstacles (convex and reflex, no bitangent pruning), decides visibility with
shapely's exact predicates (a segment is free when it does not meet any interior; touching is
allowed) and runs scipy's Dijkstra: an implementation independent of the backend's reduced graph
and of the vectorised crossing kernel.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

import optplan as op
from optplan.backends.visgraph import VisGraph, shortest_length, shortest_path
from optplan.problem import ProblemError, Robot, parse_problem

# ------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------


def make_problem(obstacles: list[dict], start, goal, radius: float = 2.0,
                 bounds=(0.0, 0.0, 200.0, 200.0), name: str = "t") -> op.Problem:
    return parse_problem({
        "name": name, "bounds": list(bounds),
        "robots": [{"id": "r1", "start": list(start), "goal": list(goal), "radius": radius}],
        "obstacles": obstacles,
    })


def random_map(seed: int, n: int = 8, size: float = 200.0) -> op.Problem:
    """Rectangles, triangles and non-convex star polygons (overlaps allowed)."""
    rng = np.random.default_rng(seed)
    while True:
        obs = []
        for _ in range(n):
            c = rng.uniform(0.15 * size, 0.85 * size, 2)
            kind = rng.choice(["rect", "tri", "star"])
            if kind == "rect":
                w, h = rng.uniform(0.03 * size, 0.15 * size, 2)
                obs.append({"type": "rectangle", "center": c.tolist(), "size": [w, h]})
                continue
            k = 3 if kind == "tri" else int(rng.integers(5, 9))
            ang = np.sort(rng.uniform(0, 2 * np.pi, k))
            rad = rng.uniform(0.03 * size, 0.1 * size, k)
            if kind == "star":
                rad[::2] *= 0.45  # alternate inner points: reflex vertices
            verts = c + np.c_[rad * np.cos(ang), rad * np.sin(ang)]
            if shapely.Polygon(verts).is_valid and shapely.Polygon(verts).area > 1.0:
                obs.append({"type": "polygon", "vertices": verts.tolist()})
        try:
            return make_problem(obs, (0.02 * size, 0.03 * size), (0.97 * size, 0.96 * size),
                                bounds=(0.0, 0.0, size, size), name=f"random-{seed}")
        except ProblemError:
            n = max(1, n - 1)  # start or goal covered: try a sparser map


def brute_force_length(problem: op.Problem, robot: Robot | None = None,
                       mode: str = "inscribed") -> float:
    robot = robot or problem.robots[0]
    imap = problem.inflated(robot.radius, mode=mode, known_only=True)
    verts = [np.asarray(r.coords)[:-1] for part in imap.parts
             for r in (part.exterior, *part.interiors)]
    allv = np.concatenate(verts) if verts else np.zeros((0, 2))
    x0, y0, x1, y1 = problem.bounds
    allv = allv[(allv[:, 0] >= x0) & (allv[:, 0] <= x1) & (allv[:, 1] >= y0) & (allv[:, 1] <= y1)]
    nodes = np.vstack([robot.start, robot.goal, allv])
    i, j = np.triu_indices(len(nodes), 1)
    lines = shapely.linestrings(np.stack([nodes[i], nodes[j]], axis=1))
    union = imap.union
    if union.is_empty:
        free = np.ones(len(i), bool)
    else:
        shapely.prepare(union)
        # free <=> the segment's interior misses the obstacles' interior (DE-9IM 'T********')
        free = ~shapely.relate_pattern(lines, union, "T********")
    i, j = i[free], j[free]
    w = np.hypot(*(nodes[i] - nodes[j]).T)
    g = csr_matrix((w, (i, j)), shape=(len(nodes), len(nodes)))
    dist = dijkstra(g, directed=False, indices=0)
    return float(dist[1])


def plength(path: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(path, axis=0).T)))


# ------------------------------------------------------------------------------------
# tests
# ------------------------------------------------------------------------------------


def test_open_field_is_the_straight_line() -> None:
    r = op.solve("open-field", "visgraph")
    prob = op.load_problem("open-field")
    rob = prob.robots[0]
    assert r.status is op.Status.optimal and r.success
    assert r.path.shape == (2, 2)
    np.testing.assert_array_equal(r.path[0], rob.start)
    np.testing.assert_array_equal(r.path[-1], rob.goal)
    assert r.metrics["length"] == pytest.approx(float(np.hypot(*(rob.goal - rob.start))))
    assert r.metrics["ratio_to_optimum"] == pytest.approx(1.0)
    assert r.metrics["length_inscribed"] == r.metrics["length_circumscribed"]


@pytest.mark.parametrize("seed", range(6))
def test_random_maps_match_brute_force(seed: int) -> None:
    prob = random_map(seed)
    res = op.solve(prob, "visgraph")
    ref = brute_force_length(prob)
    if not math.isfinite(ref):
        assert res.status is op.Status.infeasible
        return
    assert res.status is op.Status.optimal, res.message
    assert res.metrics["length"] == pytest.approx(ref, rel=1e-9)
    # the validator agrees: collision-free, in bounds, reaches the goal
    m = op.evaluate(prob, res.paths)
    assert m["feasible"] and m["collisions"] == 0 and m["reached"]
    assert m["length"] == pytest.approx(ref, rel=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_bracket_on_random_maps(seed: int) -> None:
    prob = random_map(100 + seed)
    res = op.solve(prob, "visgraph")
    if not math.isfinite(brute_force_length(prob)):
        pytest.skip("map happens to be disconnected")
    assert res.status is op.Status.optimal, res.message
    lo, hi = res.metrics["length_inscribed"], res.metrics["length_circumscribed"]
    assert lo == res.metrics["length"]
    if hi is not None:
        assert lo <= hi
        assert hi == pytest.approx(brute_force_length(prob, mode="circumscribed"), rel=1e-9)
    # the inflation only grows by 1 / cos(pi/32) - 1 ~ 0.5 %: the bracket is tight
    assert hi is None or hi <= lo * 1.01


def test_start_inside_an_obstacle_is_infeasible() -> None:
    prob = make_problem([{"type": "rectangle", "min": [50, 50], "max": [100, 100],
                          "name": "block"}], (10, 10), (190, 190))
    inside = Robot("r1", np.array([75.0, 75.0]), prob.robots[0].goal, 2.0, 1.0)
    bad = dataclasses.replace(prob, robots=(inside,), _cache={})
    res = VisGraph().solve(bad)
    assert res.status is op.Status.infeasible and not res.success
    assert "start" in res.message and "inside" in res.message and "block" in res.message
    # goal just inside the inflated margin (1 unit from the raw rectangle, radius 2)
    g_in = Robot("r1", np.array([10.0, 10.0]), np.array([101.0, 75.0]), 2.0, 1.0)
    res2 = VisGraph().solve(dataclasses.replace(prob, robots=(g_in,), _cache={}))
    assert res2.status is op.Status.infeasible and "goal" in res2.message


def test_disconnected_is_infeasible() -> None:
    walls = [  # a closed box around the goal
        {"type": "rectangle", "min": [140, 140], "max": [180, 145]},
        {"type": "rectangle", "min": [140, 175], "max": [180, 180]},
        {"type": "rectangle", "min": [140, 140], "max": [145, 180]},
        {"type": "rectangle", "min": [175, 140], "max": [180, 180]},
    ]
    prob = make_problem(walls, (10, 10), (160, 160))
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.infeasible
    assert "not reachable" in res.message
    assert res.path.shape[1] == 2 and np.allclose(res.path[0], prob.robots[0].start)
    assert shortest_length(prob, prob.robots[0]) is None
    # a gap too narrow for the robot (width 3 < diameter 4) also disconnects
    walls[0] = {"type": "rectangle", "min": [140, 140], "max": [158.5, 145]}
    walls.append({"type": "rectangle", "min": [161.5, 140], "max": [180, 145]})
    assert op.solve(make_problem(walls, (10, 10), (160, 160)), "visgraph").status is (
        op.Status.infeasible)


def test_collinear_tangents_along_aligned_obstacles() -> None:
    # three squares with top edges on y = 50; with r = 2 the inflated tops lie on y = 52 and
    # the straight line at y = 52 runs along all of them (pyvisgraph's collinear failure)
    obs = [{"type": "rectangle", "min": [x, 20], "max": [x + 20, 50]} for x in (40, 80, 120)]
    prob = make_problem(obs, (10, 52), (190, 52))
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.optimal, res.message
    assert res.metrics["length"] == pytest.approx(180.0, rel=1e-12)
    assert res.metrics["collisions"] == 0


def test_near_collinear_vertices() -> None:
    # triangles whose apexes sit 1e-9 above / below the line start-goal, and a row of
    # nearly aligned rectangles: the path must be the brute-force optimum, collision-free
    eps = 1e-9
    obs = [
        {"type": "polygon", "vertices": [[60, 60 + eps], [50, 40], [70, 40]]},
        {"type": "polygon", "vertices": [[100, 100 - eps], [90, 120], [110, 120]]},
        {"type": "rectangle", "min": [130, 100], "max": [150, 130.0 + eps]},
        {"type": "rectangle", "min": [155, 100], "max": [170, 130.0]},
    ]
    prob = make_problem(obs, (10, 10), (190, 190), radius=1e-3)
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.optimal, res.message
    assert res.metrics["collisions"] == 0
    assert res.metrics["length"] == pytest.approx(brute_force_length(prob), rel=1e-9)


@pytest.mark.parametrize("seed", [0, 3])
def test_large_coordinates(seed: int) -> None:
    base = random_map(seed)
    off = 1e6
    shifted = dataclasses.replace(
        base, bounds=tuple(b + off for b in base.bounds),
        robots=tuple(dataclasses.replace(r, start=r.start + off, goal=r.goal + off)
                     for r in base.robots),
        obstacles=tuple(dataclasses.replace(
            o, geometry=shapely.affinity.translate(o.geometry, off, off),
            center=None if o.center is None else o.center + off) for o in base.obstacles),
        _cache={})
    a = op.solve(base, "visgraph")
    b = op.solve(shifted, "visgraph")
    assert b.status is a.status is op.Status.optimal, b.message
    assert b.metrics["collisions"] == 0
    assert b.metrics["length"] == pytest.approx(a.metrics["length"], rel=1e-7)


def test_shortest_path_api_and_graph_info() -> None:
    prob = make_problem([{"type": "rectangle", "min": [80, 0], "max": [120, 150]}],
                        (10, 10), (190, 10))
    imap = prob.inflated(2.0)
    path, info = shortest_path(imap, prob.robots[0].start, prob.robots[0].goal, prob.bounds)
    assert path is not None and path.shape[1] == 2 and len(path) >= 4
    assert info["n_nodes"] >= 2 and info["n_edges"] >= 1
    # around the top of the wall: 2 tangents + the arc, bounded by the rectangle's detour
    direct = 2 * math.hypot(80 - 10, 152 - 10) + 40
    assert plength(path) == pytest.approx(brute_force_length(prob), rel=1e-9)
    assert plength(path) <= direct + 4 * 2.0


def test_temporary_obstacles_ignored_unless_asked() -> None:
    obs = [{"type": "rectangle", "min": [90, 0], "max": [110, 190], "known": False}]
    prob = make_problem(obs, (10, 100), (190, 100))
    blind = op.solve(prob, "visgraph")
    assert blind.metrics["length"] == pytest.approx(180.0)
    # the validator sees the temporary wall: the blind plan is not feasible
    assert blind.status is op.Status.approximate and blind.metrics["collisions"] > 0
    seeing = op.solve(prob, "visgraph", see_temporary=True)
    assert seeing.status is op.Status.optimal and seeing.metrics["length"] > 180.0


def test_options_are_validated() -> None:
    with pytest.raises(ValueError, match="bracket"):
        op.get_solver("visgraph", bracket="yes")
    with pytest.raises(ValueError, match="did you mean 'bracket'"):
        op.get_solver("visgraph", brackt=False)
    res = op.solve("open-field", "visgraph", bracket=False)
    assert "length_circumscribed" not in res.metrics
    assert res.options == {"see_temporary": False, "bracket": False}
