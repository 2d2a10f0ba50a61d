"""The scene families for the references in time (optplan.time_families)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Point

from optplan.geometry.tangent import problem_shortest_path
from optplan.problem.writer import problem_to_dict
from optplan.time_families import TIME_FAMILY_KINDS, time_family

SEEDS = (1, 2, 3, 4, 5)


@pytest.mark.parametrize("kind", TIME_FAMILY_KINDS)
def test_every_kind_builds_valid_scenes(kind: str) -> None:
    for seed in SEEDS:
        p = time_family(kind, np.random.default_rng(seed))
        r = p.leader
        assert p.name == f"time-{kind}" and len(p.robots) == 1
        assert 0.3 <= r.radius <= 2.5 and 1.0 <= r.max_speed <= 5.0
        start = Point(*r.start)
        assert all(d.geometry_at(0.0).distance(start) > r.radius for d in p.dynamic_obstacles)
        res = problem_shortest_path(p, r, known_only=False)
        assert res.polyline is not None and math.isfinite(res.length)
        motions = {"velocity" if d.velocity is not None else d.after
                   for d in p.dynamic_obstacles}
        if kind == "open":
            assert 5 <= len(p.dynamic_obstacles) <= 20
            assert motions == {"hold", "loop", "bounce", "velocity"}
            assert {d.kind for d in p.dynamic_obstacles} == {"circle", "polygon"}
        elif kind == "warehouse":
            assert 50 <= len(p.obstacles) <= 100 and len(p.dynamic_obstacles) == 20
            assert motions <= {"loop", "bounce"}
            assert all(o.kind == "rectangle" for o in p.obstacles)
        else:
            assert "hold" in motions and 2 <= len(p.obstacles)


@pytest.mark.parametrize("kind", TIME_FAMILY_KINDS)
def test_same_seed_same_scene_other_seed_other_scene(kind: str) -> None:
    a = problem_to_dict(time_family(kind, np.random.default_rng(7)))
    b = problem_to_dict(time_family(kind, np.random.default_rng(7)))
    c = problem_to_dict(time_family(kind, np.random.default_rng(8)))
    assert a == b
    assert a != c


def test_unknown_kind_lists_the_kinds() -> None:
    with pytest.raises(ValueError, match="open, doors, warehouse"):
        time_family("forest", np.random.default_rng(0))
