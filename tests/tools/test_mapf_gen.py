"""Seeded MAPF instances (optplan.maps.mapf_gen): roadmaps and grids, their agents, and the
GraphML writer's round trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from optplan.maps import read_roadmap_mapf, write_roadmap_mapf
from optplan.maps.mapf_gen import (
    ROADMAP_KINDS,
    grid_instance,
    grid_terrain,
    pick_agents,
    random_roadmap,
    roadmap_instance,
)
from optplan.problem import Problem


def _check_agents(p: Problem) -> None:
    """Distinct starts, distinct goals, every start and goal a node, goal != start."""
    g = p.roadmap
    assert g is not None
    s = [g.node_at(r.start, p.frame.eps) for r in p.robots]
    t = [g.node_at(r.goal, p.frame.eps) for r in p.robots]
    assert None not in s and None not in t
    assert len(set(s)) == len(s) and len(set(t)) == len(t)
    assert all(a != b for a, b in zip(s, t))


def _reachable(p: Problem, a: int) -> set[int]:
    g = p.roadmap
    seen, todo = {a}, [a]
    while todo:
        for v in g.neighbours(todo.pop()).tolist():
            if v not in seen:
                seen.add(v)
                todo.append(v)
    return seen


@pytest.mark.parametrize("kind", list(ROADMAP_KINDS))
def test_roadmap_instances(kind: str) -> None:
    p = roadmap_instance(kind, 12, np.random.default_rng(3))
    q = roadmap_instance(kind, 12, np.random.default_rng(3))
    assert np.array_equal(p.roadmap.nodes, q.roadmap.nodes)
    assert [r.goal.tolist() for r in p.robots] == [r.goal.tolist() for r in q.robots]
    n, _ = ROADMAP_KINDS[kind]
    assert len(p.roadmap) == n and len(p.robots) == 12 and p.obstacles == ()
    assert _reachable(p, 0) == set(range(n))  # connected (the spanning tree)
    degree = 2 * len(p.roadmap.edges) / n
    assert (3.5 < degree < 4.5) if kind == "sparse" else (16 < degree < 18)
    _check_agents(p)
    d = np.hypot(*(p.roadmap.nodes[:, None] - p.roadmap.nodes[None]).transpose(2, 0, 1))
    assert d[np.triu_indices(n, 1)].min() >= 2.0


@pytest.mark.parametrize(("kind", "shape"), [("empty", (16, 16)), ("room", (64, 64)),
                                             ("warehouse", (20, 39))])
def test_grid_instances(kind: str, shape: tuple[int, int]) -> None:
    terrain = grid_terrain(kind, np.random.default_rng(0))
    assert terrain.shape == shape
    p = grid_instance(kind, 10, np.random.default_rng(0), connectedness=3)
    assert len(p.roadmap) == int((grid_terrain(kind, np.random.default_rng(0)) == ".").sum())
    _check_agents(p)
    for r in p.robots:  # the goal is on the start's component of the roadmap
        g = p.roadmap
        assert g.node_at(r.goal, 1e-9) in _reachable(p, g.node_at(r.start, 1e-9))
    e = p.roadmap.edges
    oset = p.obstacle_set(p.robots[0].radius)
    assert oset.segment_free(p.roadmap.nodes[e[:, 0]], p.roadmap.nodes[e[:, 1]]).all()
    assert (len(p.obstacles) > 0) == (kind != "empty")


def test_generated_roadmap_written_for_the_authors_planner(tmp_path: Path) -> None:
    p = roadmap_instance("sparse", 6, np.random.default_rng(5))
    g, t = write_roadmap_mapf(p, tmp_path / "map.xml", tmp_path / "task.xml")
    info: dict = {}
    q = read_roadmap_mapf(g, t, info=info)
    assert info["weights_off"] == 0 and info["one_way"] == 0
    assert np.array_equal(q.roadmap.nodes, p.roadmap.nodes)
    assert np.array_equal(q.roadmap.edges, p.roadmap.edges)
    assert [r.start.tolist() for r in q.robots] == [r.start.tolist() for r in p.robots]
    assert t.read_text().count("<agent ") == 6


def test_bad_arguments() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="unknown roadmap kind 'medium'"):
        roadmap_instance("medium", 3, rng)
    with pytest.raises(ValueError, match="unknown grid kind 'maze'"):
        grid_instance("maze", 3, rng)
    with pytest.raises(ValueError, match="agents: 5 requested, the 4 nodes take 4"):
        grid_instance("empty", 5, rng, size=2)
    with pytest.raises(ValueError, match="agents: expected an integer >= 1"):
        pick_agents(np.zeros((2, 2)), np.zeros(2, int), 0, rng, 0.1)
    with pytest.raises(ValueError, match="need integers n >= 2"):
        random_roadmap(5, 5, rng)
