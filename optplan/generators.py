"""Scene generators: scaled formation scenes and seeded variants of catalogue scenes.

:func:`formation_scene` builds an obstacle-free (or lightly cluttered) formation problem with
``N`` robots (one leader, ``N - 1`` followers) in a ``line``, ``wedge`` or ``grid`` shape, with
the followers' L-phi slots derived from the shape (convention of :class:`optplan.problem.Follower`).
:func:`jitter_phases` shifts the phase of every moving obstacle of a problem by a seeded random
time, the variants used by ``optplan bench --tag formation``.  :func:`random_obstacles` scatters
seeded random obstacles of every kind the kernels handle (benchmarks and kernel tests).
:func:`swap_scene` is two independently planned robots swapping ends of an empty field.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import shapely
from shapely.geometry import Polygon

from optplan.problem import Follower, Formation, Obstacle, Problem, Robot, parse_problem

__all__ = ["formation_offsets", "formation_scene", "jitter_phases", "random_obstacles",
           "swap_scene"]

SHAPES = ("line", "wedge", "grid")


def formation_offsets(n: int, shape: str, spacing: float) -> np.ndarray:
    """Follower offsets in the leader frame (x forward, y left), shape ``(n - 1, 2)``.

    ``line``: abreast, alternating left/right of the leader; ``wedge``: a V opening backwards;
    ``grid``: a square-ish block behind the leader, centred on its line.
    """
    if n < 2:
        raise ValueError(f"a formation needs at least 2 robots, got {n}")
    if shape not in SHAPES:
        raise ValueError(f"shape must be one of {SHAPES}, got {shape!r}")
    m = n - 1
    k = np.arange(1, m + 1)
    side = np.where(k % 2 == 1, 1.0, -1.0)
    rank = (k + 1) // 2
    if shape == "line":
        return np.stack([np.zeros(m), side * rank * spacing], axis=1)
    if shape == "wedge":
        return np.stack([-rank * spacing * math.cos(math.pi / 6),
                         side * rank * spacing * math.sin(math.pi / 6) * 2], axis=1)
    cols = int(math.ceil(math.sqrt(n)))
    centre = (cols - 1) // 2
    cells = [(-r * spacing, (c - centre) * spacing)
             for r in range(cols + 1) for c in range(cols) if (r, c) != (0, centre)]
    return np.array(cells[:m], float)


def formation_scene(n: int, shape: str = "grid", *, spacing: float = 12.0,
                    radius: float = 2.0, max_speed: float = 4.0, distance: float = 300.0,
                    obstacles: int = 0, seed: int = 0) -> Problem:
    """A formation problem with ``n`` robots starting in their slots.

    The leader drives ``distance`` along +x; followers start at their slots (heading 0).
    ``obstacles`` random discs (seeded) are scattered along the route, away from the starts.
    """
    off = formation_offsets(n, shape, spacing)
    span = float(np.abs(off).max()) + 4 * spacing
    x0, y0 = 0.0, 0.0
    lead = np.array([span, span])
    goal = lead + np.array([distance, 0.0])
    bounds = (x0, y0, goal[0] + span, 2 * span)
    L = np.hypot(off[:, 0], off[:, 1])
    # offset (x, y) in the leader frame = L [-cos phi, sin phi]
    phi = np.arctan2(off[:, 1], -off[:, 0])
    robots = [Robot("leader", lead, goal, radius, max_speed)]
    fol = []
    for k in range(n - 1):
        rid = f"f{k + 1}"
        robots.append(Robot(rid, lead + off[k], None, radius, max_speed))
        fol.append(Follower(rid, float(L[k]), float(phi[k])))
    form = Formation("leader", tuple(fol), safety_distance=max(2.5 * radius, 0.5 * spacing))
    data = {
        "name": f"formation-{shape}-{n}",
        "description": f"{n} robots in a {shape} formation driving {distance:g} along +x",
        "source": "optplan.generators.formation_scene (synthetic)",
        "tags": ["formation", "generated"],
        "bounds": list(bounds),
        "robots": [{"id": r.id, "start": r.start.tolist(), "radius": r.radius,
                    "max_speed": r.max_speed, **({"goal": r.goal.tolist()} if r.goal is not None
                                                 else {})} for r in robots],
        "formation": {"leader": "leader", "safety_distance": form.safety_distance,
                      "followers": [{"id": f.id, "L": f.L, "phi": f.phi} for f in fol]},
    }
    if obstacles:
        rng = np.random.default_rng(seed)
        obs = []
        for _ in range(obstacles):
            c = [float(rng.uniform(lead[0] + 0.3 * distance, goal[0])),
                 float(rng.uniform(span * 0.3, span * 1.7))]
            obs.append({"type": "circle", "center": c, "radius": float(rng.uniform(3, 8)),
                        "known": False})
        data["obstacles"] = obs
    return parse_problem(data, f"<generated {data['name']}>")


def jitter_phases(problem: Problem, rng: np.random.Generator, span: float | None = None
                  ) -> Problem:
    """A copy of ``problem`` with every moving obstacle's timeline shifted by a random phase.

    The shift is uniform in ``[0, span)`` (default: each obstacle's own period, i.e. its
    waypoint time span, doubled for ``bounce``; 60 s for constant-velocity obstacles).
    """
    dyn = []
    for d in problem.dynamic_obstacles:
        period = span
        if period is None:
            T = float(d.times[-1] - d.times[0])
            period = (2 * T if d.after == "bounce" else T) if T > 0 else 60.0
        shift = float(rng.uniform(0.0, period))
        if d.velocity is not None:
            wp = d.waypoints - shift * d.velocity[None, :]
            dyn.append(dataclasses.replace(d, waypoints=wp))
        else:
            dyn.append(dataclasses.replace(d, times=d.times - shift))
    return dataclasses.replace(problem, dynamic_obstacles=tuple(dyn), _cache={})


def random_obstacles(n: int, seed: int = 0, side: float = 500.0,
                     keep_free: tuple = ()) -> list[Obstacle]:
    """``n`` seeded random obstacles in a ``side`` square, size ~ ``1 / sqrt(n)`` (constant
    covered fraction): circles, rectangles, triangles, hexagons (two convex pieces) and concave
    U shapes (several pieces), each rotated at random.

    Obstacles whose centre is closer than twice the size to a point of ``keep_free`` are
    skipped (so fewer than ``n`` may be returned).
    """
    rng = np.random.default_rng(seed)
    size = side * 0.3 / math.sqrt(n)
    out: list[Obstacle] = []
    for i in range(n):
        c = rng.uniform(0.05 * side, 0.95 * side, 2)
        if any(math.dist(c, q) < 2 * size for q in keep_free):
            continue
        s = size * rng.uniform(0.5, 1.5)
        kind = i % 5
        if kind == 0:
            # exact circle: centre and radius are the model, no polygon (geometry None)
            out.append(Obstacle("circle", None, True, f"c{i}", center=c, radius=s / 2))
            continue
        if kind == 1:
            v = [[-s / 2, -s / 3], [s / 2, -s / 3], [s / 2, s / 3], [-s / 2, s / 3]]
        elif kind == 2:
            v = [[-s / 2, -s / 2], [s / 2, -s / 3], [0.0, s / 2]]
        elif kind == 3:
            v = [[s / 2 * math.cos(a), s / 2 * math.sin(a)]
                 for a in np.linspace(0, 2 * math.pi, 7)[:-1]]
        else:  # a U: a square with a notch
            v = [[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]]
            v = [[(x - 1.5) * s / 3, (y - 1.5) * s / 3] for x, y in v]
        th = rng.uniform(0, 2 * math.pi)
        rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        poly = shapely.geometry.polygon.orient(Polygon(np.asarray(v) @ rot.T + c), 1.0)
        out.append(Obstacle("polygon", poly, True, f"p{i}"))
    return out


def swap_scene(dy: float = 0.0) -> Problem:
    """Robots ``a`` and ``b`` (radius 3, speed 5) swap the ends of an empty 200 x 100 field,
    ``b`` offset sideways by ``dy`` (0: exactly head-on); no formation, so both are planned."""
    return parse_problem({
        "name": "swap", "bounds": [0.0, 0.0, 200.0, 100.0], "obstacles": [],
        "robots": [{"id": "a", "start": [20.0, 50.0], "goal": [180.0, 50.0], "radius": 3.0,
                    "max_speed": 5.0},
                   {"id": "b", "start": [180.0, 50.0 + dy], "goal": [20.0, 50.0 + dy],
                    "radius": 3.0, "max_speed": 5.0}]})
