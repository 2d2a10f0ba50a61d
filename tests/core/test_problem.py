"""Scenario format and catalogue: loading, validation errors, dynamic obstacles, formation slots.

Covers the TOML format, what validation rejects, and the catalogue.  Bad scenario fixtures
live in ``tests/data/bad/``; every fixture there must be listed in :data:`BAD_CASES` (or
:data:`KNOWN_PARSER_GAPS`) with the key its error must name.
"""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import shapely

import optplan as op
from optplan.problem import Follower, Formation
from optplan.problem.context import (
    _DYN_KEYS,
    _FOLL_KEYS,
    _FORM_KEYS,
    _OBST_KEYS,
    _ROBOT_KEYS,
    _SENS_KEYS,
    _TOP_KEYS,
)

ROOT = Path(__file__).resolve().parents[2]
BAD_DIR = Path(__file__).resolve().parents[1] / "data" / "bad"
README = ROOT / "problems" / "README.md"

# fixture file -> (key the message must name, further text the message must contain)
BAD_CASES: dict[str, tuple[str, str]] = {
    "unknown-top-key": ("descripton", "did you mean 'description'"),
    "unknown-robot-key": ("robots[0].radious", "did you mean 'radius'"),
    "unknown-obstacle-key": ("obstacles[0].vertexes", "did you mean 'vertices'"),
    "obstacle-type-misspelled": ("obstacles[0].type", "did you mean 'rectangle'"),
    "nan-radius": ("robots[0].radius", "finite"),
    "inf-vertex": ("obstacles[0].vertices[1][0]", "finite"),
    "nan-bounds": ("bounds[2]", "finite"),
    "empty-polygon": ("obstacles[0].vertices", "at least 3"),
    "two-vertex-polygon": ("obstacles[0].vertices", "3 distinct vertices"),
    "degenerate-polygon": ("obstacles[0].vertices", "degenerate"),
    "self-intersecting-polygon": ("obstacles[0].vertices", "self-intersecting"),
    "zero-circle-radius": ("obstacles[0].radius", "> 0"),
    "negative-robot-radius": ("robots[0].radius", ">= 0"),
    "zero-dynamic-radius": ("dynamic_obstacles[0].radius", "> 0"),
    "inverted-rectangle": ("obstacles[0].max", "min < max"),
    "bounds-min-ge-max": ("bounds", "xmin < xmax"),
    "start-outside-bounds": ("robots[0].start", "outside the bounds"),
    "goal-outside-bounds": ("robots[0].goal", "outside the bounds"),
    "start-in-inflated-obstacle": ("robots[0].start", "inflated"),
    "goal-in-inflated-obstacle": ("robots[0].goal", "inflated"),
    "formation-leader-unknown": ("formation.leader", "'pilot'"),
    "formation-follower-unknown": ("formation.followers[1].id", "'f9'"),
    "dynamic-times-decreasing": ("dynamic_obstacles[0].times", "increasing"),
    "dynamic-times-count": ("dynamic_obstacles[0].times", "3 time stamps"),
    "dynamic-after-misspelled": ("dynamic_obstacles[0].after", "bounce"),
    "missing-goal": ("robots[0].goal", "missing"),
    "phi-out-of-range": ("formation.followers[0].phi", "pi"),
}

# Inputs the first parser version crashed on or accepted silently (now rejected).
KNOWN_PARSER_GAPS: dict[str, tuple[str, str]] = {
    "dynamic-velocity-times-empty": ("dynamic_obstacles[0].times", "one start time"),
    "duplicate-follower": ("formation.followers[1].id", "twice"),
}

MY_SCENES = ("paper-env1", "paper-env2", "paper-hybrid", "paper-warehouse")


def _err(path: Path) -> str:
    with pytest.raises(op.ProblemError) as ei:
        op.read_problem(path)
    return str(ei.value)


# --------------------------------------------------------------------------------------
# the catalogue
# --------------------------------------------------------------------------------------


def test_catalogue_is_not_empty():
    names = op.list_problems()
    assert "open-field" in names
    for n in MY_SCENES:
        assert n in names


@pytest.mark.parametrize("name", op.list_problems())
def test_catalogue_file_loads(name):
    p = op.load_problem(name)
    assert p.name == name, "the file stem and the `name` key must agree"
    assert p.description and p.source and p.tags
    assert p.path is not None and Path(p.path).stem == name
    x0, y0, x1, y1 = p.bounds
    for r in p.robots:
        for q in (r.start, r.goal):
            if q is not None:
                assert x0 <= q[0] <= x1 and y0 <= q[1] <= y1
    if name.startswith("paper-"):
        assert "paper" in p.tags


@pytest.mark.parametrize("name", op.list_problems())
def test_catalogue_listed_in_readme(name):
    text = README.read_text(encoding="utf-8")
    assert f"`{name}`" in text, f"problems/README.md does not list {name}"


def test_readme_documents_every_key():
    text = README.read_text(encoding="utf-8")
    keys = set(_TOP_KEYS) | _ROBOT_KEYS | _DYN_KEYS | _FORM_KEYS | _FOLL_KEYS | _SENS_KEYS
    for ks in _OBST_KEYS.values():
        keys |= ks
    keys |= set(_OBST_KEYS)  # obstacle type names
    keys |= {"hold", "loop", "bounce"}
    missing = sorted(k for k in keys if f"`{k}`" not in text and f'`"{k}"`' not in text)
    assert not missing, f"problems/README.md does not document {missing}"


@pytest.mark.parametrize("name", MY_SCENES)
def test_reconstructions_say_so(name):
    p = op.load_problem(name)
    assert p.source.startswith("reconstruction of paper Fig")


# --------------------------------------------------------------------------------------
# properties of the paper scenes (visgraph = certified optimum on the known map)
# --------------------------------------------------------------------------------------


def _shape(o, grow: float = 0.0, quad_segs: int = 64):
    """Shapely region of obstacle ``o`` grown by ``grow``, inscribed in the exact one (a circle's
    or a rounded corner's polygon has its vertices on the true arc): any length inside it is a
    true overlap."""
    if o.is_circle:
        return shapely.Point(o.center).buffer(o.radius + grow, quad_segs=quad_segs)
    return o.geometry.buffer(grow, quad_segs=quad_segs) if grow > 0 else o.geometry


def _interior_overlap(path: np.ndarray, problem: op.Problem, robot, known_only: bool) -> float:
    """Length of ``path`` strictly inside the obstacles inflated by the robot radius, by shapely
    (independent of the geometry core)."""
    line = shapely.LineString(path)
    return float(sum(line.intersection(_shape(o, robot.radius).buffer(-1e-6)).length
                     for o in problem.static_obstacles(known_only)))


@pytest.mark.parametrize("name, lo, hi", [("paper-env1", 725.0, 750.0),
                                          ("paper-env2", 740.0, 765.0)])
def test_pso_maps_optimum_in_paper_range(name, lo, hi):
    p = op.load_problem(name)
    r = op.solve(p, "visgraph")
    rob = p.robots[0]
    straight = float(np.hypot(*(rob.goal - rob.start)))
    length = r.metrics["length"]
    assert lo <= length <= hi
    # the exact optimum (segments + arcs) is below the returned circumscribed polyline
    assert r.metrics["length_exact"] <= length + 1e-9
    assert length - r.metrics["length_exact"] < 0.5
    # the straight line is blocked, and the returned path is really collision-free
    assert _interior_overlap(np.vstack([rob.start, rob.goal]), p, rob, True) > 0
    assert _interior_overlap(r.paths[rob.id], p, rob, True) == pytest.approx(0.0, abs=1e-6)
    assert length > straight + 20.0


# centres (diagonal coordinate s along (1, 1)/sqrt2, offset d along (-1, 1)/sqrt2) and radii of
# discs that close the gap the optimum uses at each staggered barrier of the PSO maps
_GAPS = {
    "paper-env1": [(182.5, 58.0, 26.0), (352.5, -58.0, 26.0), (522.5, 58.0, 26.0)],
    "paper-env2": [(145.0, 49.0, 22.0), (277.5, -49.0, 22.0), (415.0, 49.0, 22.0),
                   (562.5, -49.0, 22.0)],
}


@pytest.mark.parametrize("name", sorted(_GAPS))
def test_pso_maps_have_several_homotopy_classes(name):
    """Closing the gap the optimum uses at any barrier leaves a longer, feasible local optimum."""
    path = Path(op.load_problem(name).path)
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    best = op.solve(op.parse_problem(data), "visgraph").metrics["length"]
    others = []
    for s, d, rad in _GAPS[name]:
        centre = [(s - d) / math.sqrt(2.0), (s + d) / math.sqrt(2.0)]
        closed = dict(data, obstacles=data["obstacles"] + [
            {"type": "circle", "center": centre, "radius": rad}])
        p = op.parse_problem(closed)
        r = op.solve(p, "visgraph")
        rob = p.robots[0]
        assert _interior_overlap(r.paths[rob.id], p, rob, True) == pytest.approx(0.0, abs=1e-6)
        others.append(r.metrics["length"])
    others = np.array(others)
    assert np.all(others > best + 5.0), others  # each gap matters: distinct local optima
    assert len(np.unique(np.round(others))) >= 2  # of different lengths
    assert np.all(others < 1.25 * best)  # and competitive (traps for a swarm)


def test_hybrid_scene_temporary_obstacles_block_known_optimum():
    p = op.load_problem("paper-hybrid")
    assert p.sensing_range is not None and p.sensing_range > 0
    assert 2 <= sum(not o.known for o in p.obstacles) <= 3
    assert 1 <= len(p.dynamic_obstacles) <= 2
    assert all(d.after == "bounce" for d in p.dynamic_obstacles)
    r = op.solve(p, "visgraph")
    rob = p.robots[0]
    assert r.status is op.Status.approximate
    assert r.metrics["static_collisions"] > 0
    assert _interior_overlap(r.paths[rob.id], p, rob, True) == pytest.approx(0.0, abs=1e-6)
    assert _interior_overlap(r.paths[rob.id], p, rob, False) > 10.0
    # every temporary obstacle sits on the known-map optimum
    line = shapely.LineString(r.paths[rob.id])
    for o in p.obstacles:
        if not o.known:
            assert line.intersects(_shape(o)), o.name
    # avoidable: planning around them too is feasible and a little longer
    full = op.get_solver("visgraph", see_temporary=True).solve(p)
    assert full.metrics["length"] > r.metrics["length"]
    assert _interior_overlap(full.paths[rob.id], p, rob, False) == pytest.approx(0.0, abs=1e-6)
    # slow movers: well under the robot's speed
    for d in p.dynamic_obstacles:
        v = np.hypot(*np.diff(d.waypoints, axis=0).T) / np.diff(d.times)
        assert np.all(v < 0.5 * rob.max_speed)


def test_warehouse_scene():
    p = op.load_problem("paper-warehouse")
    f = p.formation
    assert f is not None and f.leader == "leader"
    assert [x.id for x in f.followers] == ["f1", "f2"]
    lead = p.leader
    np.testing.assert_allclose(lead.start, [45, 560])
    np.testing.assert_allclose(lead.goal, [568, 33])
    np.testing.assert_allclose(p.robot("f1").start, [26, 569])
    np.testing.assert_allclose(p.robot("f2").start, [36, 579])
    assert p.robot("f1").goal is None and p.robot("f2").goal is None
    # the paper's start positions are (close to) the formation slots for the initial heading
    heading = math.atan2(*(lead.goal - lead.start)[::-1])
    slots = lead.start + f.slot_offsets(heading)
    starts = np.array([p.robot(x.id).start for x in f.followers])
    assert np.max(np.hypot(*(slots - starts).T)) < 0.5
    assert f.safety_distance == pytest.approx(2.5 * lead.radius)
    assert 2 <= sum(not o.known for o in p.obstacles) <= 4
    assert all(o.is_circle for o in p.obstacles if not o.known)
    r = op.solve(p, "visgraph")
    path = r.paths["leader"]
    assert _interior_overlap(path, p, lead, True) == pytest.approx(0.0, abs=1e-6)
    assert _interior_overlap(path, p, lead, False) > 10.0
    assert r.metrics["static_collisions"] > 0
    full = op.get_solver("visgraph", see_temporary=True).solve(p)
    assert _interior_overlap(full.paths["leader"], p, lead, False) == pytest.approx(0, abs=1e-6)


@pytest.mark.parametrize("name", ["paper-env1", "paper-env2", "paper-warehouse"])
def test_visgraph_optimal_on_known_map(name):
    r = op.solve(op.load_problem(name).known_view(), "visgraph")
    assert r.status is op.Status.optimal
    assert r.metrics["static_collisions"] == 0


# --------------------------------------------------------------------------------------
# validation errors
# --------------------------------------------------------------------------------------


def test_every_bad_fixture_is_covered():
    files = {p.stem for p in BAD_DIR.glob("*.toml")}
    assert files == set(BAD_CASES) | set(KNOWN_PARSER_GAPS)


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_scenario_rejected(case):
    path = BAD_DIR / f"{case}.toml"
    key, extra = BAD_CASES[case]
    msg = _err(path)
    assert "\n" not in msg, "the error must be one line"
    assert str(path) in msg, "the error must name the file"
    assert re.search(rf"(^|: ){re.escape(key)}: ", msg), f"the error must name key {key!r}: {msg}"
    assert extra in msg


@pytest.mark.parametrize("case", sorted(KNOWN_PARSER_GAPS))
def test_bad_scenario_former_gap(case):
    path = BAD_DIR / f"{case}.toml"
    key, extra = KNOWN_PARSER_GAPS[case]
    msg = _err(path)
    assert str(path) in msg and f"{key}: " in msg and extra in msg


def test_bad_scenario_via_load_problem_names_file():
    path = BAD_DIR / "nan-radius.toml"
    with pytest.raises(op.ProblemError, match=r"nan-radius\.toml: robots\[0\]\.radius: "):
        op.load_problem(str(path))


def test_unknown_catalogue_name_suggests():
    with pytest.raises(op.ProblemError, match="paper-env1"):
        op.load_problem("paper-envl")


def test_invalid_toml_is_a_problem_error(tmp_path):
    f = tmp_path / "broken.toml"
    f.write_text('name = "x"\nbounds = [0, 0, 1\n', encoding="utf-8")
    msg = _err(f)
    assert str(f) in msg and "invalid TOML" in msg


# --------------------------------------------------------------------------------------
# dynamic obstacles: position(t)
# --------------------------------------------------------------------------------------

_BASE = """
name = "dyn"
bounds = [0.0, 0.0, 100.0, 100.0]
[[robots]]
id = "r"
start = [90.0, 90.0]
goal = [95.0, 95.0]
radius = 1.0
"""


def _dyn(body: str):
    p = op.parse_problem(tomllib.loads(_BASE + "[[dynamic_obstacles]]\n" + body))
    return p.dynamic_obstacles[0]


_WP = 'type = "circle"\nradius = 2.0\nwaypoints = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]\n' \
      "times = [0.0, 10.0, 20.0]\n"


def test_dynamic_waypoint_interpolation_and_hold():
    d = _dyn(_WP)
    assert d.after == "hold"
    np.testing.assert_allclose(d.position(5.0), [5.0, 0.0])
    np.testing.assert_allclose(d.position(10.0), [10.0, 0.0])
    np.testing.assert_allclose(d.position(15.0), [10.0, 5.0])
    np.testing.assert_allclose(d.position(-3.0), [0.0, 0.0])  # before: first waypoint
    np.testing.assert_allclose(d.position(99.0), [10.0, 10.0])  # hold the last
    out = d.position(np.array([0.0, 2.5, 12.5]))
    assert out.shape == (3, 2)
    np.testing.assert_allclose(out, [[0, 0], [2.5, 0], [10, 2.5]])


def test_dynamic_loop():
    d = _dyn(_WP + 'after = "loop"\n')
    np.testing.assert_allclose(d.position(25.0), [5.0, 0.0])
    np.testing.assert_allclose(d.position(35.0), [10.0, 5.0])
    np.testing.assert_allclose(d.position(40.0), [0.0, 0.0])


def test_dynamic_bounce():
    d = _dyn(_WP + 'after = "bounce"\n')
    np.testing.assert_allclose(d.position(20.0), [10.0, 10.0])
    np.testing.assert_allclose(d.position(25.0), [10.0, 5.0])  # back along the last leg
    np.testing.assert_allclose(d.position(35.0), [5.0, 0.0])
    np.testing.assert_allclose(d.position(40.0), [0.0, 0.0])
    np.testing.assert_allclose(d.position(45.0), [5.0, 0.0])  # and forward again


def test_dynamic_constant_velocity():
    d = _dyn('type = "circle"\nradius = 2.0\nwaypoints = [[1.0, 2.0]]\nvelocity = [3.0, -1.0]\n')
    np.testing.assert_allclose(d.position(0.0), [1.0, 2.0])
    np.testing.assert_allclose(d.position(2.0), [7.0, 0.0])
    d4 = _dyn('type = "circle"\nradius = 2.0\nwaypoints = [[1.0, 2.0]]\nvelocity = [3.0, -1.0]\n'
              "times = [4.0]\n")
    np.testing.assert_allclose(d4.position(4.0), [1.0, 2.0])
    np.testing.assert_allclose(d4.position(6.0), [7.0, 0.0])


def test_dynamic_geometry_and_distance():
    d = _dyn(_WP)
    g = d.geometry_at(5.0)
    assert g.centroid.distance(shapely.Point(5.0, 0.0)) < 1e-9
    assert g.area == pytest.approx(math.pi * 4.0, rel=0.01)
    np.testing.assert_allclose(d.distance(np.array([[5.0, 10.0]]), 5.0), [8.0])
    np.testing.assert_allclose(d.distance(np.array([[5.0, 1.0]]), 5.0), [0.0])
    sq = _dyn('type = "polygon"\nvertices = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]\n'
              "waypoints = [[0.0, 0.0], [10.0, 0.0]]\ntimes = [0.0, 10.0]\n")
    np.testing.assert_allclose(sq.distance(np.array([[5.0, 4.0]]), 5.0), [3.0])


# --------------------------------------------------------------------------------------
# formation slot convention
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("phi, expected", [
    (math.pi / 4, (-60.0, 0.0)),
    (-math.pi / 4, (0.0, -60.0)),
    (0.0, (-60.0 / math.sqrt(2), -60.0 / math.sqrt(2))),
])
def test_slot_offsets_convention(phi, expected):
    f = Formation("L", (Follower("f", 60.0, phi),), 10.0)
    np.testing.assert_allclose(f.slot_offsets(math.pi / 4)[0], expected, atol=1e-12)


def test_slot_offsets_paper_formation_start():
    """Leader (60, 60) heading to (450, 450); followers (0, 60), (60, 0) with L = 60."""
    f = Formation("r1", (Follower("r2", 60.0, math.pi / 4), Follower("r3", 60.0, -math.pi / 4)),
                  10.0)
    heading = math.atan2(450 - 60, 450 - 60)
    slots = np.array([60.0, 60.0]) + f.slot_offsets(heading)
    np.testing.assert_allclose(slots, [[0.0, 60.0], [60.0, 0.0]], atol=1e-9)
    # batched headings broadcast
    assert f.slot_offsets(np.array([0.0, 1.0, 2.0])).shape == (3, 2, 2)


def test_formation_safety_distance_default():
    text = _BASE + """
[[robots]]
id = "f"
start = [80.0, 90.0]
radius = 1.5
[formation]
leader = "r"
followers = [{ id = "f", L = 10.0, phi = 0.0 }]
"""
    p = op.parse_problem(tomllib.loads(text))
    assert p.formation.safety_distance == pytest.approx(3.0)  # 2 x the largest radius
    assert p.robot("f").goal is None
    assert p.planned_robots == [p.robot("r")]


# --------------------------------------------------------------------------------------
# exact obstacle model: closing vertex, circles, point robots, holes, precision limits
# --------------------------------------------------------------------------------------


def _scene(obstacles, robot=None, bounds=(0.0, 0.0, 100.0, 100.0), **top):
    rob = {"id": "r", "start": [5.0, 5.0], "goal": [95.0, 95.0], "radius": 1.0}
    rob.update(robot or {})
    return {"name": "t", "bounds": list(bounds), "robots": [rob], "obstacles": obstacles, **top}


def _parse(data):
    return op.parse_problem(data, "scene.toml")


def _reject(data) -> str:
    with pytest.raises(op.ProblemError) as ei:
        _parse(data)
    msg = str(ei.value)
    assert msg.startswith("scene.toml: ") and "\n" not in msg
    return msg


def _n_vertices(o) -> int:
    return len(o.geometry.exterior.coords) - 1


_SQ = [[40.0, 40.0], [50.0, 40.0], [50.0, 50.0], [40.0, 50.0]]


def test_closing_vertex_exact_repeat_is_dropped():
    p = _parse(_scene([{"type": "polygon", "vertices": _SQ + [_SQ[0]]}]))
    assert _n_vertices(p.obstacles[0]) == 4


def test_closing_vertex_near_repeat_relative_to_size():
    size = math.hypot(10.0, 10.0)
    near = [[40.0 + 0.5e-12 * size, 40.0]]  # within 1e-12 x size of the first: a repeat
    p = _parse(_scene([{"type": "polygon", "vertices": _SQ + near}]))
    assert _n_vertices(p.obstacles[0]) == 4
    far = [[40.0, 40.0 + 1e-6]]  # a real (short) edge: kept
    p = _parse(_scene([{"type": "polygon", "vertices": _SQ + far}]))
    assert _n_vertices(p.obstacles[0]) == 5
    # relative to the polygon's own size, not to the coordinates: a tiny polygon keeps a
    # vertex 1e-9 from its first one (np.allclose would have dropped it)
    tiny = [[50.0, 50.0], [50.0 + 1e-8, 50.0], [50.0 + 1e-8, 50.0 + 1e-8], [50.0, 50.0 + 1e-8],
            [50.0, 50.0 + 5e-9]]
    p = _parse(_scene([{"type": "polygon", "vertices": tiny}]))
    assert _n_vertices(p.obstacles[0]) == 5


def test_utm_rectangles_keep_four_vertices():
    y0 = 5.0e6
    bounds = (0.0, y0 - 50.0, 100.0, y0 + 50.0)
    robot = {"start": [5.0, y0 - 45.0], "goal": [95.0, y0 + 45.0]}
    obst = [{"type": "polygon", "vertices": [[20.0, y0], [30.0, y0], [30.0, y0 + 10.0],
                                             [20.0, y0 + 10.0]]},
            {"type": "rectangle", "min": [60.0, y0], "max": [70.0, y0 + 10.0]},
            {"type": "rectangle", "center": [45.0, y0 - 20.0], "size": [10.0, 10.0]}]
    p = _parse(_scene(obst, robot, bounds))
    for o in p.obstacles:
        assert _n_vertices(o) == 4
        assert o.geometry.area == pytest.approx(100.0)
    # the exact start check works there too: 0.5 from the polygon with radius 1 is rejected
    bad = dict(robot, start=[19.5, y0 + 5.0])
    assert "robots[0].start: " in _reject(_scene(obst, bad, bounds))


def test_circles_are_exact_not_polygonised():
    p = _parse(_scene([{"type": "circle", "center": [50.0, 50.0], "radius": 10.0}]))
    o = p.obstacles[0]
    assert o.is_circle and o.geometry is None
    np.testing.assert_array_equal(o.center, [50.0, 50.0])
    assert o.radius == 10.0 and o.bounds == (40.0, 40.0, 60.0, 60.0)
    # a start at distance exactly r from the true circle is allowed (a 16-segment polygon
    # would have been off by ~0.2 % of the radius in either direction)
    d = 11.0 / math.sqrt(2.0)
    ok = _parse(_scene([{"type": "circle", "center": [50.0, 50.0], "radius": 10.0}],
                       {"start": [50.0 + d, 50.0 + d]}))
    assert ok.blocking_obstacle(ok.robots[0].start, 1.0) is None
    msg = _reject(_scene([{"type": "circle", "center": [50.0, 50.0], "radius": 10.0,
                           "name": "disc"}], {"start": [50.0 + 0.99 * d, 50.0 + 0.99 * d]}))
    assert "robots[0].start: " in msg and "'disc'" in msg and "obstacles[0]" in msg
    assert "radius 1" in msg


def test_point_robot_radius_zero_and_goal_tol():
    obst = [{"type": "rectangle", "min": [40.0, 40.0], "max": [60.0, 60.0]}]
    p = _parse(_scene(obst, {"radius": 0, "start": [40.0, 50.0]}))  # on the boundary
    r = p.robots[0]
    assert r.radius == 0.0
    assert p.goal_tol(r) == pytest.approx(1e-6 * p.extent)
    assert p.goal_tol(r) == pytest.approx(1e-6 * math.hypot(100.0, 100.0))
    # a given goal_tolerance wins; robots with a radius default to it
    assert _parse(_scene(obst, {"radius": 0}, goal_tolerance=0.5)).goal_tol(r) == 0.5
    q = _parse(_scene(obst, {"radius": 2.5}))
    assert q.goal_tol(q.robots[0]) == 2.5
    msg = _reject(_scene(obst, {"radius": 0, "start": [40.5, 50.0]}))
    assert "robots[0].start: " in msg and "point robot" in msg
    assert "robots[0].radius: " in _reject(_scene(obst, {"radius": -1.0}))


def test_point_robot_formation_needs_safety_distance():
    data = _scene([], {"radius": 0})
    data["robots"].append({"id": "f", "start": [5.0, 20.0], "radius": 0})
    data["formation"] = {"leader": "r", "followers": [{"id": "f", "L": 10.0, "phi": 0.0}]}
    assert "formation.safety_distance: " in _reject(data)
    data["formation"]["safety_distance"] = 1.0
    assert _parse(data).formation.safety_distance == 1.0


_RING = {"type": "polygon", "name": "ring",
         "vertices": [[30.0, 30.0], [70.0, 30.0], [70.0, 70.0], [30.0, 70.0]],
         "holes": [[[40.0, 40.0], [60.0, 40.0], [60.0, 60.0], [40.0, 60.0]]]}


def test_polygon_holes_parse_and_start_checks():
    p = _parse(_scene([_RING], {"start": [50.0, 50.0]}))  # in the hole's free area
    g = p.obstacles[0].geometry
    assert len(g.interiors) == 1 and g.area == pytest.approx(1600.0 - 400.0)
    assert p.obstacle_set(1.0).point_distances(np.array([[50.0, 50.0]]))[0] == pytest.approx(10)
    # near the hole's wall (closer than the radius) and inside the solid ring: rejected
    assert "robots[0].start: " in _reject(_scene([_RING], {"start": [40.5, 50.0]}))
    msg = _reject(_scene([_RING], {"start": [35.0, 50.0]}))
    assert "robots[0].start: " in msg and "'ring'" in msg
    # a closing vertex in a hole follows the same rule
    h = dict(_RING, holes=[_RING["holes"][0] + [[40.0, 40.0]]])
    assert len(_parse(_scene([h])).obstacles[0].geometry.interiors[0].coords) == 5


@pytest.mark.parametrize("holes, key, text", [
    ([[[10.0, 10.0], [20.0, 10.0], [20.0, 20.0]]], "obstacles[0].holes[0]", "inside"),
    ([[[40.0, 40.0], [80.0, 40.0], [80.0, 60.0], [40.0, 60.0]]], "obstacles[0].holes[0]",
     "inside"),
    ([[[40.0, 40.0], [60.0, 60.0], [60.0, 40.0], [40.0, 60.0]]], "obstacles[0].holes[0]",
     "self-intersecting"),
    ([[[40.0, 40.0], [50.0, 50.0], [60.0, 60.0]]], "obstacles[0].holes[0]", "degenerate"),
    ([[[40.0, 40.0], [60.0, 40.0]]], "obstacles[0].holes[0]", "at least 3"),
    ([[[40.0, 40.0], [60.0, 40.0], [60.0, 60.0], [40.0, 60.0]],
      [[50.0, 50.0], [65.0, 50.0], [65.0, 65.0], [50.0, 65.0]]], "obstacles[0].holes", "overlap"),
    ("square", "obstacles[0].holes", "list of rings"),
])
def test_bad_holes_rejected(holes, key, text):
    msg = _reject(_scene([dict(_RING, holes=holes)]))
    assert f": {key}: " in msg and text in msg, msg


def test_degenerate_polygons_rejected():
    rep = [[40.0, 40.0], [50.0, 40.0], [50.0, 40.0], [40.0, 40.0]]  # repeats: 2 distinct
    msg = _reject(_scene([{"type": "polygon", "vertices": rep}]))
    assert ": obstacles[0].vertices: " in msg and "3 distinct" in msg
    flat = [[40.0, 40.0], [50.0, 40.0 + 1e-14], [60.0, 40.0]]  # area 1e-13 x size^2
    msg = _reject(_scene([{"type": "polygon", "vertices": flat}]))
    assert ": obstacles[0].vertices: " in msg and ("zero area" in msg or "degenerate" in msg)
    # an exact consecutive repeat in an otherwise fine polygon is dropped (a zero-length edge
    # made the exact geometry core ignore the whole obstacle; found by the input fuzz)
    ok = _SQ[:2] + [_SQ[1]] + _SQ[2:]
    o = _parse(_scene([{"type": "polygon", "vertices": ok}])).obstacles[0]
    assert o.geometry.area == pytest.approx(100.0) and _n_vertices(o) == 4


def test_far_obstacles_are_allowed_and_ignored():
    far = [{"type": "circle", "center": [1e11, 1e11], "radius": 1.0},
           {"type": "polygon", "vertices": [[-1e12, 0.0], [-1e12 + 5.0, 0.0], [-1e12, 5.0]]}]
    p = _parse(_scene(far))
    assert len(p.obstacles) == 2
    assert p.obstacle_set(1.0, walls=False).n_items == 0
    assert np.isinf(p.obstacle_set(1.0, walls=False).point_distances(np.array([[50.0, 50.0]]))[0])
    # with the bounds wall: only the wall remains (50 from the centre of a 100 x 100 map)
    walled = p.obstacle_set(1.0)
    assert walled.members == {} and walled.names[-1] == "bounds"
    assert walled.point_distances(np.array([[50.0, 50.0]]))[0] == pytest.approx(50.0)


def _precision_case(tmp_path, text: str) -> str:
    f = tmp_path / "precision.toml"
    f.write_text(text, encoding="utf-8")
    msg = _err(f)
    assert msg.startswith(f"{f}: ") and "\n" not in msg
    return msg


_PREC = 'name = "p"\nbounds = [0.0, 0.0, 100.0, 100.0]\n' \
        '[[robots]]\nid = "r"\nstart = [5.0, 5.0]\ngoal = [95.0, 95.0]\nradius = 1.0\n'


def test_precision_bounds_too_large(tmp_path):
    msg = _precision_case(tmp_path, _PREC.replace("100.0, 100.0]", "1e155, 1e155]"))
    assert ": bounds: " in msg and "supported range" in msg


def test_precision_bounds_far_from_origin(tmp_path):
    msg = _precision_case(tmp_path, _PREC.replace(
        "bounds = [0.0, 0.0, 100.0, 100.0]", "bounds = [1e12, 0.0, 1.00000000001e12, 100.0]"))
    assert ": bounds: " in msg


def test_precision_polygon_vertex_at_1e15_crossing_the_map(tmp_path):
    msg = _precision_case(tmp_path, _PREC + '[[obstacles]]\ntype = "polygon"\nname = "wedge"\n'
                          "vertices = [[40.0, 40.0], [60.0, 40.0], [1e15, 1e15], [40.0, 1e15]]\n")
    assert ": obstacles[0].vertices: " in msg and "'wedge'" in msg
    assert "double precision" in msg
    # a sliver (width 20, length 1.4e15) is degenerate relative to its own size
    msg = _precision_case(tmp_path, _PREC + '[[obstacles]]\ntype = "polygon"\n'
                          "vertices = [[40.0, 40.0], [60.0, 40.0], [1e15, 1e15]]\n")
    assert ": obstacles[0].vertices: " in msg and "zero area" in msg


def test_precision_circle_centre_minus_1e300(tmp_path):
    msg = _precision_case(tmp_path, _PREC + '[[obstacles]]\ntype = "circle"\n'
                          "center = [-1e300, 50.0]\nradius = 1.0\n")
    assert ": obstacles[0].center[0]: " in msg and "1e+300" in msg


def test_precision_huge_circle_reaching_in(tmp_path):
    msg = _precision_case(tmp_path, _PREC + '[[obstacles]]\ntype = "circle"\n'
                          "center = [-1e20, 50.0]\nradius = 1.00000000001e20\n")
    assert ": obstacles[0].center: " in msg and "double precision" in msg


def test_precision_rectangle_reaching_in(tmp_path):
    msg = _precision_case(tmp_path, _PREC + '[[obstacles]]\ntype = "rectangle"\n'
                          "center = [50.0, 50.0]\nsize = [1e12, 10.0]\n")
    assert ": obstacles[0].center: " in msg


@pytest.mark.parametrize("patch, key", [
    ({"name": 3}, "name"),
    ({"description": 1.5}, "description"),
    ({"source": ["paper"]}, "source"),
    ({"obstacles": [{"type": "circle", "center": [50, 50], "radius": 2, "name": 7}]},
     "obstacles[0].name"),
    ({"dynamic_obstacles": [{"type": "circle", "radius": 2, "waypoints": [[50, 50]],
                             "times": [0], "name": True}]}, "dynamic_obstacles[0].name"),
])
def test_strings_must_be_strings(patch, key):
    data = _scene([])
    data.update(patch)
    msg = _reject(data)
    assert f"scene.toml: {key}: expected a string" in msg, msg


# -- wrong types, misattributed errors, files, documented ranges ---------------------------------


def _team(**formation):
    """A leader and two followers; ``formation`` updates the [formation] table."""
    robots = [{"id": "lead", "start": [10.0, 10.0], "goal": [90.0, 90.0], "radius": 1.0},
              {"id": "f1", "start": [5.0, 10.0], "radius": 1.0},
              {"id": "f2", "start": [10.0, 5.0], "radius": 1.0}]
    form = {"leader": "lead", "followers": [{"id": "f1", "L": 5.0, "phi": 0.5},
                                            {"id": "f2", "L": 5.0, "phi": -0.5}]}
    form.update(formation)
    return {"name": "t", "bounds": [0.0, 0.0, 100.0, 100.0], "robots": robots,
            "formation": form}


@pytest.mark.parametrize("value", [["polygon"], {"kind": "polygon"}, 3, True])
def test_obstacle_type_of_wrong_type(value):
    msg = _reject(_scene([{"type": value, "vertices": _SQ}]))
    assert "scene.toml: obstacles[0].type: expected a string" in msg


@pytest.mark.parametrize("value", [["circle"], {"t": 1}, 2.0])
def test_dynamic_type_and_after_of_wrong_type(value):
    dyn = {"type": value, "radius": 1.0, "waypoints": [[50.0, 50.0]], "times": [0.0]}
    assert "scene.toml: dynamic_obstacles[0].type: " in _reject(
        _scene([], dynamic_obstacles=[dyn]))
    dyn = {"type": "circle", "radius": 1.0, "waypoints": [[50.0, 50.0]], "times": [0.0],
           "after": value}
    assert "scene.toml: dynamic_obstacles[0].after: expected 'hold'" in _reject(
        _scene([], dynamic_obstacles=[dyn]))


@pytest.mark.parametrize("value", [["lead"], {"id": "lead"}, 1])
def test_leader_of_wrong_type(value):
    assert "scene.toml: formation.leader: expected a robot id string" in _reject(
        _team(leader=value))


@pytest.mark.parametrize(("formation", "key", "text"), [
    ({"followers": []}, "formation.followers", "got an empty list"),
    ({"followers": 3}, "formation.followers", "expected at least one follower"),
    ({"followers": [3]}, "formation.followers[0]", "expected a table"),
    ({"followers": [{"id": "nobody", "L": 5.0, "phi": 0.5}]}, "formation.followers[0].id",
     "names no robot: 'nobody'"),
    ({"followers": [{"id": "lead", "L": 5.0, "phi": 0.5}]}, "formation.followers[0].id",
     "the leader 'lead' cannot also be a follower"),
    ({"followers": [{"id": 5, "L": 5.0, "phi": 0.5}]}, "formation.followers[0].id",
     "expected a robot id string"),
    ({"followers": [{"L": 5.0, "phi": 0.5}]}, "formation.followers[0].id", "missing"),
])
def test_formation_errors_are_not_reported_as_missing_goals(formation, key, text):
    msg = _reject(_team(**formation))
    assert f"scene.toml: {key}: " in msg and text in msg, msg
    assert ".goal" not in msg


def test_missing_followers_key_and_a_non_follower_without_goal():
    d = _team()
    del d["formation"]["followers"]
    assert "scene.toml: formation.followers: missing required key" in _reject(d)
    d = _team(followers=[{"id": "f1", "L": 5.0, "phi": 0.5}])  # f2 is no follower
    msg = _reject(d)
    assert "scene.toml: robots[2].goal: missing required key (robot 'f2' is not a formation " \
           "follower)" in msg
    d = _team()
    del d["formation"]
    assert "scene.toml: robots[1].goal: missing required key (only formation followers" \
           in _reject(d)


def test_non_utf8_file_names_the_file(tmp_path):
    f = tmp_path / "latin1.toml"
    f.write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
    for load in (op.read_problem, op.load_problem):
        with pytest.raises(op.ProblemError) as ei:
            load(f)
        assert str(f) in str(ei.value) and "not UTF-8 text" in str(ei.value)


def test_deeply_nested_toml_names_the_file(tmp_path):
    f = tmp_path / "deep.toml"
    f.write_text("x = " + "[" * 3000 + "]" * 3000 + "\n", encoding="utf-8")
    msg = _err(f)
    assert msg.startswith(f"{f}: invalid TOML:") and "nested too deeply" in msg


def test_deeply_nested_values_through_the_api():
    deep: list = []
    for _ in range(3000):
        deep = [deep]
    msg = _reject(_scene([], robot={"start": [deep, 5.0]}))
    assert msg.startswith("scene.toml: robots[0].start[0]: expected a number") and len(msg) < 200
    msg = _reject(_scene([{"type": "polygon", "vertices": [deep, [0, 0], [1, 0]]}]))
    assert "obstacles[0].vertices[0]: expected a point" in msg and len(msg) < 200


def test_directories_and_missing_files(tmp_path):
    d = tmp_path / "scene.toml"
    d.mkdir()
    for load in (op.read_problem, op.load_problem):
        with pytest.raises(op.ProblemError, match="is a directory"):
            load(d)
    with pytest.raises(op.ProblemError, match="no such scenario file"):
        op.load_problem(tmp_path / "none.toml")


def test_messages_stay_short_for_huge_values():
    big = [[float(k), 0.0] for k in range(20000)]
    msg = _reject(_scene([], robot={"start": big}))
    assert "robots[0].start: expected a point [x, y]" in msg and len(msg) < 200
    msg = _reject(_scene([], robot={"radius": 10**400}))
    assert "robots[0].radius: must be finite, got an integer of 401 digits" in msg


def test_tag_elements_named():
    assert "scene.toml: tags[1]: expected a string, got 3" in _reject(_scene([], tags=["a", 3]))


def test_dynamic_keys_per_type_and_rectangle_size():
    dyn = {"type": "circle", "radius": 1.0, "vertices": _SQ, "waypoints": [[50.0, 50.0]],
           "times": [0.0]}
    assert "dynamic_obstacles[0].vertices: unknown key" in _reject(
        _scene([], dynamic_obstacles=[dyn]))
    msg = _reject(_scene([{"type": "rectangle", "center": [50.0, 50.0], "size": [-1.0, 2.0]}]))
    assert "scene.toml: obstacles[0].size: rectangle needs a size > 0" in msg


_DIAG = math.hypot(100.0, 100.0)


@pytest.mark.parametrize(("patch", "key", "text"), [
    ({"robot": {"radius": 1e300}}, "robots[0].radius", "must be <= 141.421 (the bounds diagonal"),
    ({"robot": {"radius": 2 * _DIAG}}, "robots[0].radius", "must be <= 141.421"),
    ({"robot": {"max_speed": 1e300}}, "robots[0].max_speed", "must be <= 1.41421e+08"),
    ({"robot": {"max_speed": 1e-300}}, "robots[0].max_speed", "must be >= 0.000141421"),
    ({"bounds": (0.0, 0.0, 1e7, 1e7)}, "robots[0].max_speed", "got 1 (the default)"),
    ({"goal_tolerance": 1e300}, "goal_tolerance", "must be <= 141.421"),
    ({"sensing": {"range": 1e300}}, "sensing.range", "must be <= 1.41421e+08"),
    ({"sensing": {"range": math.inf}}, "sensing.range", "must be finite"),
    ({"bounds": (0.0, 0.0, 100.0, 1e-5)}, "bounds", "the longer side may be at most 1e+06"),
])
def test_documented_ranges(patch, key, text):
    patch = dict(patch)
    robot = patch.pop("robot", None)
    bounds = patch.pop("bounds", (0.0, 0.0, 100.0, 100.0))
    if robot is None and bounds[2] > 1e6:
        robot = {"start": [5.0, 5.0], "goal": [9e6, 9e6]}
    msg = _reject(_scene([], robot, bounds, **patch))
    assert f"scene.toml: {key}: " in msg and text in msg, msg


@pytest.mark.parametrize(("formation", "key"), [
    ({"safety_distance": 1e300}, "formation.safety_distance"),
    ({"followers": [{"id": "f1", "L": 1e300, "phi": 0.5}, {"id": "f2", "L": 5.0, "phi": 0.1}]},
     "formation.followers[0].L"),
])
def test_formation_lengths_at_most_the_diagonal(formation, key):
    msg = _reject(_team(**formation))
    assert f"scene.toml: {key}: must be <= 141.421" in msg


def _dyn_scene(**kw):
    d = {"type": "circle", "radius": 2.0, "waypoints": [[50.0, 20.0], [50.0, 80.0]],
         "times": [0.0, 10.0]}
    d.update(kw)
    return _scene([], dynamic_obstacles=[d])


@pytest.mark.parametrize(("kw", "key", "text"), [
    ({"times": [0.0, 1e300]}, "dynamic_obstacles[0].times[1]", "beyond 1e+12 s"),
    ({"times": [-1e300, 0.0]}, "dynamic_obstacles[0].times[0]", "beyond 1e+12 s"),
    ({"times": [0.0, 1e-300]}, "dynamic_obstacles[0].times", "imply a speed of"),
    ({"velocity": [1e12, 0.0], "waypoints": [[50.0, 20.0]], "times": [0.0]},
     "dynamic_obstacles[0].velocity", "speed 1e+12 is above 1.41421e+08"),
    ({"radius": 1e100}, "dynamic_obstacles[0].radius", "double precision cannot resolve"),
    ({"waypoints": [[50.0, 20.0], [1e140, 0.0]]}, "dynamic_obstacles[0].waypoints[1]",
     "double precision cannot resolve"),
    ({"times": [0.0, 1e-6], "after": "bounce"}, "dynamic_obstacles[0].times",
     "the bounce period 2e-06 s is shorter"),
    ({"waypoints": [[50.0, 20.0], [50.0, 20.0 + 1e-9]], "times": [0.0, 1e-6], "after": "loop"},
     "dynamic_obstacles[0].times", "the loop period 1e-06 s is shorter than 1e-05 x"),
])
def test_dynamic_obstacle_ranges(kw, key, text):
    msg = _reject(_dyn_scene(**kw))
    assert f"scene.toml: {key}: " in msg and text in msg, msg


def test_point_and_file_size_limits(tmp_path):
    n = 100_001
    ring = [[50.0 + 10 * math.cos(2 * math.pi * k / n), 50.0 + 10 * math.sin(2 * math.pi * k / n)]
            for k in range(n)]
    msg = _reject(_scene([{"type": "polygon", "vertices": ring}]))
    assert "obstacles[0].vertices: too many points" in msg
    f = tmp_path / "big.toml"
    f.write_text("# " + "x" * (9 * 2**20) + "\n", encoding="utf-8")
    assert "is larger than the 8 MB a scenario may have" in _err(f)


def test_known_view_keeps_everything_but_the_hidden_obstacles() -> None:
    """The global planner's map has the scene's length unit, robots and formation (it once
    lost ``length_scale``: a 600 x 600 paper scene's known view had 1.2 instead of 1)."""
    import dataclasses

    p = op.load_problem("paper-warehouse")
    k = p.known_view()
    assert k.length_scale == p.length_scale == 1.0
    assert k.dynamic_obstacles == () and all(o.known for o in k.obstacles)
    assert len(k.obstacles) == sum(o.known for o in p.obstacles) < len(p.obstacles)
    same = {f.name for f in dataclasses.fields(p)} - {"obstacles", "dynamic_obstacles", "_cache"}
    assert all(getattr(k, n) is getattr(p, n) for n in same)
    assert p.known_view() is k  # memoised


def test_memo_builds_once() -> None:
    p = op.load_problem("open-field")
    calls = []
    assert p.memo(("test", 1), lambda: calls.append(1) or 42) == 42
    assert p.memo(("test", 1), lambda: calls.append(1) or 43) == 42
    assert calls == [1]


@pytest.mark.parametrize(("bad", "text"), [
    (True, "obstacles[0].vertices[1][0]: expected a number"),
    ("3", "obstacles[0].vertices[1][0]: expected a number"),
    (math.nan, "obstacles[0].vertices[1][0]: must be finite"),
    (10**400, "obstacles[0].vertices[1][0]: must be finite, got an integer of 401 digits"),
    (1e300, "obstacles[0].vertices[1][0]: magnitude"),
])
def test_polygon_vertices_are_checked_one_by_one_when_not_plain(bad, text):
    """Plain vertices (lists of two ints or floats) are converted at once; anything else
    goes through the point-by-point checks, which name the offending value."""
    verts = [[10.0, 10.0], [bad, 10.0], [20.0, 20.0]]
    assert text in _reject(_scene([{"type": "polygon", "vertices": verts}]))


def test_plain_and_numpy_vertices_give_the_same_polygon():
    plain = _parse(_scene([{"type": "polygon", "vertices": _SQ}]))
    wrapped = [[np.float64(x), np.float64(y)] for x, y in _SQ]  # float subclasses: slow path
    other = _parse(_scene([{"type": "polygon", "vertices": wrapped}]))
    ints = _parse(_scene([{"type": "polygon", "vertices": [[int(x), int(y)] for x, y in _SQ]}]))
    g = plain.obstacles[0].geometry
    assert g.equals_exact(other.obstacles[0].geometry, 0.0)
    assert g.equals_exact(ints.obstacles[0].geometry, 0.0)
