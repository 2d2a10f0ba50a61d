"""The ``[roadmap]`` table of the scenario format: read, written, checked, transformed."""

from __future__ import annotations

import copy
import tomllib

import numpy as np
import pytest

from optplan.canonical import canonical_problem
from optplan.maps import to_toml
from optplan.problem import ProblemError, parse_problem, problem_to_dict, transform_problem

_BASE = {
    "name": "cross",
    "bounds": [0.0, 0.0, 10.0, 10.0],
    "robots": [{"id": "a", "start": [1.0, 1.0], "goal": [9.0, 9.0], "radius": 0.3},
               {"id": "b", "start": [9.0, 1.0], "goal": [1.0, 9.0], "radius": 0.3}],
    "roadmap": {"nodes": [[1.0, 1.0], [9.0, 1.0], [5.0, 5.0], [1.0, 9.0], [9.0, 9.0]],
                "edges": [[0, 2], [2, 1], [2, 3], [4, 2], [2, 0]]},
}


def _scene(**patch) -> dict:
    d = copy.deepcopy(_BASE)
    for k, v in patch.items():
        if k in ("nodes", "edges"):
            d["roadmap"][k] = v
        else:
            d[k] = v
    return d


def _reject(data: dict) -> str:
    with pytest.raises(ProblemError) as e:
        parse_problem(data, "scene.toml")
    return str(e.value)


def test_roadmap_is_read_sorted_and_unique() -> None:
    p = parse_problem(_scene(), "scene.toml")
    assert p.roadmap is not None
    assert p.roadmap.edges.tolist() == [[0, 2], [1, 2], [2, 3], [2, 4]]
    assert p.roadmap.neighbours(2).tolist() == [0, 1, 3, 4]
    assert parse_problem({k: v for k, v in _BASE.items() if k != "roadmap"}).roadmap is None
    assert "  roadmap: 5 nodes, 4 edges (the robots drive its edges" in p.summary()


def test_round_trip_through_toml() -> None:
    p = parse_problem(_scene(), "scene.toml")
    text = to_toml(p)
    assert "[roadmap]" in text
    q = parse_problem(tomllib.loads(text), "back.toml")
    assert problem_to_dict(q) == problem_to_dict(p)
    assert np.array_equal(q.roadmap.nodes, p.roadmap.nodes)
    assert np.array_equal(q.roadmap.edges, p.roadmap.edges)


def test_replaced_keeps_the_roadmap() -> None:
    p = parse_problem(_scene(), "scene.toml")
    q = p.replaced(name="other")
    assert q.roadmap is p.roadmap


@pytest.mark.parametrize("decimals", [None, 7])
def test_transform_and_canonical_carry_the_roadmap(decimals) -> None:
    p = parse_problem(_scene(), "scene.toml")
    t = transform_problem(p, 0.01, (3.0, -2.0), decimals=decimals)
    assert np.allclose(t.roadmap.nodes, p.roadmap.nodes * 0.01 + [3.0, -2.0])
    assert np.array_equal(t.roadmap.edges, p.roadmap.edges)
    parse_problem(problem_to_dict(t), "t.toml")  # the ends are still on nodes
    c = canonical_problem(p)
    assert c.roadmap is not None
    for r in c.robots:
        assert c.roadmap.node_at(r.start, c.frame.eps) is not None


@pytest.mark.parametrize(("patch", "key", "text"), [
    ({"roadmap": [1, 2]}, "roadmap", "expected a table"),
    ({"roadmap": {"nodes": [[1.0, 1.0]]}}, "roadmap.edges", "missing required key"),
    ({"roadmap": {"nodes": [[1.0, 1.0]], "edges": [], "weights": []}}, "roadmap.weights",
     "unknown key"),
    ({"nodes": [[1.0, 1.0], [9.0, 1.0], [5.0, "x"], [1.0, 9.0], [9.0, 9.0]]},
     "roadmap.nodes[2][1]", "expected a number"),
    ({"nodes": []}, "roadmap.nodes", "at least 1 points"),
    ({"nodes": [[1.0, 1.0], [9.0, 1.0], [5.0, 50.0], [1.0, 9.0], [9.0, 9.0]]},
     "roadmap.nodes[2]", "outside the bounds"),
    ({"nodes": [[1.0, 1.0], [9.0, 1.0], [1.0, 1.0], [1.0, 9.0], [9.0, 9.0]]},
     "roadmap.nodes", "roadmap nodes [0, 2] coincide at [1.0, 1.0]"),
    ({"edges": [[0, 2], [2, 5]]}, "roadmap.edges", "roadmap edge 1 [2, 5]: node index outside"),
    ({"edges": [[0, 2], [3, 3]]}, "roadmap.edges", "self-loop at node 3"),
    ({"edges": [[0, 2.0]]}, "roadmap.edges[0]", "expected a pair of node indices"),
    ({"edges": [[0, True]]}, "roadmap.edges[0]", "expected a pair of node indices"),
    ({"edges": [[0, 1, 2]]}, "roadmap.edges[0]", "expected a pair of node indices"),
    ({"edges": {"a": 1}}, "roadmap.edges", "expected a list of node-index pairs"),
    ({"edges": [[0, 2**70]]}, "roadmap.edges", "64-bit"),
])
def test_bad_roadmaps_name_the_key(patch, key, text) -> None:
    msg = _reject(_scene(**patch))
    assert msg.startswith(f"scene.toml: {key}: "), msg
    assert text in msg, msg


def test_ends_must_be_nodes() -> None:
    robots = copy.deepcopy(_BASE["robots"])
    robots[1]["goal"] = [1.0, 8.7]
    msg = _reject(_scene(robots=robots))
    assert msg.startswith("scene.toml: robots[1].goal: [1.0, 8.7] is not a node"), msg
    assert "roadmap.nodes[3] [1.0, 9.0], is 0.3 away" in msg
    robots[1]["goal"] = [1.0, 9.0 - 1e-12]  # within eps = 1e-9 x the diagonal
    assert parse_problem(_scene(robots=robots)).roadmap is not None


def test_robots_may_not_overlap_at_starts_or_goals() -> None:
    robots = copy.deepcopy(_BASE["robots"])
    robots[1]["start"] = [1.0, 1.0]
    msg = _reject(_scene(robots=robots))
    assert msg == ("scene.toml: robots[1].start: robot 'b' overlaps robot 'a' (robots[0]) at "
                   "their starts (the same node 0)"), msg
    robots = copy.deepcopy(_BASE["robots"])
    robots[0]["radius"] = robots[1]["radius"] = 3.0
    robots[1]["goal"] = [5.0, 5.0]
    msg = _reject(_scene(robots=robots, bounds=[-10.0, -10.0, 20.0, 20.0]))
    assert "robots[1].goal: robot 'b' overlaps robot 'a' (robots[0]) at their goals (nodes 4 " \
           "and 2, 5.65685 apart, radii 3 + 3)" in msg, msg
    # point robots on distinct nodes are fine; on one node they are not
    robots = copy.deepcopy(_BASE["robots"])
    for r in robots:
        r["radius"] = 0.0
    parse_problem(_scene(robots=robots))
    robots[1]["goal"] = [9.0, 9.0]
    assert "at their goals (the same node 4)" in _reject(_scene(robots=robots))
