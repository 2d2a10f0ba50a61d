"""Scene generators: the corridor map family and the older formation / obstacle generators."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.generators import (
    CORRIDOR_KINDS,
    corridor_scene,
    formation_scene,
    random_obstacles,
    swap_scene,
)
from optplan.geometry.tangent.tangent_graph import problem_shortest_path


def _signature(prob: op.Problem) -> list:
    out = []
    for o in prob.obstacles:
        if o.is_circle:
            out.append(("c", *np.round(o.center, 9), round(float(o.radius), 9)))
        else:
            out.append(("p", *np.round(o.geometry.bounds, 9)))
    return out


@pytest.mark.parametrize("kind", CORRIDOR_KINDS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_corridor_scene_is_seeded_solvable_and_named(kind, seed):
    a, b = corridor_scene(kind, seed), corridor_scene(kind, seed)
    assert a.name == f"corridor-{kind}-{seed}" and "generated" in a.tags
    assert _signature(a) == _signature(b)  # reproducible from (kind, seed) alone
    assert len(a.robots) == 1 and all(o.known for o in a.obstacles)
    r = a.robots[0]
    oset = a.obstacle_set(r.radius)
    for p in (r.start, r.goal):
        assert oset.point_distances(np.asarray(p)[None])[0] >= r.radius
        assert np.all(a.frame.in_bounds(np.asarray(p)[None]))
    assert math.isfinite(problem_shortest_path(a, r).length)
    assert _signature(corridor_scene(kind, seed + 10)) != _signature(a)


def test_corridor_kinds_have_their_structure():
    doors = corridor_scene("doors", 0)
    walls = [o for o in doors.obstacles if o.name.startswith("wall")]
    assert len({o.name.split("-")[0] for o in walls}) >= 2  # at least two walls
    # every wall spans the map height except for its doors (3-6 robot diameters wide)
    r = doors.robots[0].radius
    for w in {o.name.split("-")[0] for o in walls}:
        ys = sorted(o.geometry.bounds[1::2] for o in walls if o.name.startswith(w + "-"))
        gaps = [b[0] - a[1] for a, b in zip(ys, ys[1:])]
        assert gaps and all(6 * r - 1e-9 <= g <= 12 * r + 1e-9 for g in gaps)
    shelves = corridor_scene("shelves", 0)
    assert sum(o.name.startswith("shelf") for o in shelves.obstacles) >= 8
    traps = corridor_scene("u-traps", 0)
    us = [o for o in traps.obstacles if o.name.startswith("u")]
    assert len(us) >= 2 and all(not o.is_circle and len(o.geometry.exterior.coords) == 9
                                for o in us)


def test_corridor_scene_rejects_an_unknown_kind():
    with pytest.raises(ValueError, match="kind"):
        corridor_scene("maze", 0)


def test_older_generators_still_work():
    f = formation_scene(5, "wedge", obstacles=3, seed=1)
    assert len(f.robots) == 5 and f.formation is not None and len(f.obstacles) == 3
    obs = random_obstacles(25, seed=3)
    assert [o.name for o in obs] == [o.name for o in random_obstacles(25, seed=3)]
    s = swap_scene(2.0)
    assert [r.id for r in s.robots] == ["a", "b"]
