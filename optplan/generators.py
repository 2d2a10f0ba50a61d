"""Scene generators: scaled formation scenes and seeded variants of catalogue scenes.

:func:`formation_scene` builds an obstacle-free (or lightly cluttered) formation problem with
``N`` robots (one leader, ``N - 1`` followers) in a ``line``, ``wedge`` or ``grid`` shape, with
the followers' L-phi slots derived from the shape (convention of :class:`optplan.problem.Follower`).
:func:`jitter_phases` shifts the phase of every moving obstacle of a problem by a seeded random
time, the variants used by ``optplan bench --tag formation``.  :func:`random_obstacles` scatters
seeded random obstacles of every kind the kernels handle (benchmarks and kernel tests).
:func:`swap_scene` is two independently planned robots swapping ends of an empty field.
:func:`corridor_scene` draws seeded maps of a family that is hard for global planners to get
into the right corridor (homotopy class): walls with narrow doors, warehouse shelf rows and U
traps (``optplan.swarm.ipso``'s tail benchmark).  :func:`movingai_benchmark` writes seeded
MovingAI-format grid maps (random, room, maze, street) and their ``.scen`` queries
(:mod:`optplan.maps.movingai_gen`).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry import Polygon

from optplan.problem import Follower, Formation, Obstacle, Problem, Robot, parse_problem

if TYPE_CHECKING:
    from optplan.maps.movingai_gen import GeneratedMap

__all__ = ["formation_offsets", "formation_scene", "jitter_phases", "random_obstacles",
           "swap_scene", "corridor_scene", "CORRIDOR_KINDS", "movingai_benchmark"]

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


#: Kinds of :func:`corridor_scene`.
CORRIDOR_KINDS = ("doors", "shelves", "u-traps")


def _rect(x0: float, y0: float, x1: float, y1: float, name: str) -> dict:
    return {"type": "rectangle", "min": [float(x0), float(y0)], "max": [float(x1), float(y1)],
            "name": name}


def _doors(rng: np.random.Generator, side: float, r: float) -> tuple[list, list, list]:
    """2-4 walls across the map, thin or thick, each with 1-3 doors 3-6 robot diameters wide,
    a few discs between the walls; start on the left, goal on the right."""
    n_walls = int(rng.integers(2, 5))
    xs = np.linspace(0.2, 0.8, n_walls) * side + rng.uniform(-0.04, 0.04, n_walls) * side
    obs: list = []
    for w, x in enumerate(xs):
        t = rng.uniform(0.015, 0.08) * side  # thin walls, or thick ones: long corridors
        n_doors = int(rng.integers(1, 4))
        widths = rng.uniform(3.0, 6.0, n_doors) * 2 * r
        # door centres: sorted, apart by more than the widths, inside [0.08, 0.92] side
        for _ in range(100):
            c = np.sort(rng.uniform(0.08, 0.92, n_doors) * side)
            if n_doors == 1 or np.all(np.diff(c) > 0.1 * side):
                break
        y = 0.0
        for k in range(n_doors):
            lo, hi = c[k] - widths[k] / 2, c[k] + widths[k] / 2
            if lo > y:
                obs.append(_rect(x - t / 2, y, x + t / 2, lo, f"wall{w}-{k}"))
            y = hi
        obs.append(_rect(x - t / 2, y, x + t / 2, side, f"wall{w}-{n_doors}"))
    gaps = np.concatenate([[0.0], xs, [side]])
    for q in range(int(rng.integers(2, 7))):
        g = int(rng.integers(1, n_walls))  # between two walls
        lo, hi = gaps[g] + 0.06 * side, gaps[g + 1] - 0.06 * side
        if hi <= lo:
            continue
        obs.append({"type": "circle", "center": [float(rng.uniform(lo, hi)),
                                                 float(rng.uniform(0.15, 0.85) * side)],
                    "radius": float(rng.uniform(0.02, 0.05) * side), "name": f"disc{q}"})
    start = [0.05 * side, float(rng.uniform(0.1, 0.9) * side)]
    goal = [0.95 * side, float(rng.uniform(0.1, 0.9) * side)]
    return obs, start, goal


def _shelves(rng: np.random.Generator, side: float, r: float) -> tuple[list, list, list]:
    """Blocks of long parallel shelf rows (2-4 blocks across, 4-8 rows each) with aisles of
    3-6 robot diameters and cross aisles between the blocks, some shelves missing or split by
    a gap, the layout turned by 90 degrees at random; start and goal in opposite corners."""
    cols = int(rng.integers(2, 5))
    rows = int(rng.integers(4, 9))
    x0, x1 = 0.1 * side, 0.9 * side
    y0, y1 = 0.1 * side, 0.9 * side
    cross = rng.uniform(3.0, 6.0, cols - 1) * 2 * r
    width = (x1 - x0 - cross.sum()) / cols
    pitch = (y1 - y0) / rows
    turn = rng.random() < 0.5
    boxes: list[tuple[float, float, float, float]] = []
    x = x0
    for c in range(cols):
        for q in range(rows):
            if rng.random() < 0.1:  # a missing shelf
                continue
            aisle = max(3.0 * 2 * r, rng.uniform(0.35, 0.6) * pitch)
            sy0 = y0 + q * pitch + aisle / 2
            sy1 = y0 + (q + 1) * pitch - aisle / 2
            if sy1 - sy0 < r:
                continue
            a = x + rng.uniform(0.0, 0.05) * width
            b = x + width - rng.uniform(0.0, 0.05) * width
            if rng.random() < 0.2:  # split in two by a gap of 2.5-4 robot diameters
                g = rng.uniform(a + 0.3 * (b - a), b - 0.3 * (b - a))
                half = rng.uniform(2.5, 4.0) * r
                boxes += [(a, sy0, g - half, sy1), (g + half, sy0, b, sy1)]
            else:
                boxes.append((a, sy0, b, sy1))
        x += width + (cross[c] if c < cols - 1 else 0.0)
    obs = [_rect(*((bx[1], bx[0], bx[3], bx[2]) if turn else bx), f"shelf{k}")
           for k, bx in enumerate(boxes)]
    corners = [(0.04, 0.04), (0.96, 0.96)] if rng.random() < 0.5 else [(0.04, 0.96),
                                                                       (0.96, 0.04)]
    if rng.random() < 0.5:
        corners = corners[::-1]
    jit = rng.uniform(-0.02, 0.02, (2, 2))
    start = [float((corners[0][0] + jit[0, 0]) * side), float((corners[0][1] + jit[0, 1]) * side)]
    goal = [float((corners[1][0] + jit[1, 0]) * side), float((corners[1][1] + jit[1, 1]) * side)]
    return obs, start, goal


def _u_shape(c: np.ndarray, size: float, thick: float, heading: float) -> list:
    """A U of outer size ``size`` and wall thickness ``thick`` whose opening faces
    ``heading`` (radians), centred at ``c``."""
    h, t = size / 2, thick
    v = np.array([[-h, -h], [h, -h], [h, h], [h - t, h], [h - t, -h + t], [-h + t, -h + t],
                  [-h + t, h], [-h, h]])  # opening toward +y
    a = heading - math.pi / 2
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return (v @ rot.T + c).tolist()


def _u_traps(rng: np.random.Generator, side: float, r: float) -> tuple[list, list, list]:
    """2-4 U traps along the start-goal line, opening toward the start (the straight approach
    runs into them), and 3-8 discs and boxes of clutter; start and goal near opposite
    corners."""
    th = rng.uniform(0.0, 2 * math.pi)
    d = np.array([math.cos(th), math.sin(th)])
    mid = np.full(2, side / 2)
    start = mid - 0.44 * side * d / np.abs(d).max()
    goal = mid + 0.44 * side * d / np.abs(d).max()
    obs: list = []
    n_u = int(rng.integers(2, 5))
    for k, f in enumerate(np.linspace(0.25, 0.75, n_u)):
        c = start + f * (goal - start) + rng.uniform(-0.04, 0.04, 2) * side
        size = rng.uniform(0.12, 0.2) * side
        heading = th + math.pi + rng.uniform(-0.4, 0.4)  # opening toward the start
        obs.append({"type": "polygon", "vertices": _u_shape(c, size, rng.uniform(0.15, 0.25)
                                                            * size, heading), "name": f"u{k}"})
    for q in range(int(rng.integers(3, 9))):
        c = rng.uniform(0.1, 0.9, 2) * side
        if min(np.hypot(*(c - start)), np.hypot(*(c - goal))) < 0.12 * side:
            continue
        s = rng.uniform(0.02, 0.05) * side
        if q % 2:
            obs.append({"type": "circle", "center": c.tolist(), "radius": float(s),
                        "name": f"disc{q}"})
        else:
            obs.append(_rect(c[0] - s, c[1] - s / 2, c[0] + s, c[1] + s / 2, f"box{q}"))
    return obs, start.tolist(), goal.tolist()


def corridor_scene(kind: str, seed: int = 0, *, side: float = 500.0,
                   radius: float = 4.0) -> Problem:
    """A seeded map of the corridor family (one robot, every obstacle known).

    ``kind``:

    * ``"doors"``: 2-4 walls across a ``side`` square, 1.5-8 % of ``side`` thick, each with
      1-3 doors 3-6 robot diameters wide (narrow corridors through the thick ones), and a few
      discs between the walls; the robot crosses from the left edge to the right edge.
    * ``"shelves"``: 2-4 blocks of 4-8 long parallel shelf rows with aisles of 3-6 robot
      diameters and cross aisles between the blocks, ~10 % of the shelves missing and ~20 %
      split by a gap, rows horizontal or vertical; the robot crosses between opposite corners
      (many corridors of nearly equal length).
    * ``"u-traps"``: 2-4 U-shaped obstacles along the start-goal line with their opening toward
      the start, plus discs and boxes; start and goal near opposite sides.

    Every draw whose start and goal are not connected for the robot's disc (checked with the
    certified shortest path, :func:`optplan.geometry.tangent.tangent_graph.problem_shortest_path`)
    or lie within an obstacle is redrawn from the next sub-seed, so the map is reproducible from
    ``(kind, seed)`` alone.  Name: ``corridor-{kind}-{seed}``.
    """
    from optplan.geometry.tangent import problem_shortest_path

    makers = {"doors": _doors, "shelves": _shelves, "u-traps": _u_traps}
    if kind not in makers:
        raise ValueError(f"kind must be one of {CORRIDOR_KINDS}, got {kind!r}")
    for sub in range(100):
        rng = np.random.default_rng([seed, sub, CORRIDOR_KINDS.index(kind)])
        obs, start, goal = makers[kind](rng, side, radius)
        data = {
            "name": f"corridor-{kind}-{seed}",
            "description": f"generated corridor map ({kind}, seed {seed})",
            "source": "optplan.generators.corridor_scene (synthetic)",
            "tags": ["generated", "corridors", kind],
            "bounds": [0.0, 0.0, side, side],
            "robots": [{"id": "r1", "start": [float(v) for v in start],
                        "goal": [float(v) for v in goal], "radius": radius,
                        "max_speed": 5.0}],
            "obstacles": obs,
        }
        prob = parse_problem(data, f"<generated {data['name']}>")
        if math.isfinite(problem_shortest_path(prob, prob.robots[0]).length):
            return prob
    raise RuntimeError(f"corridor_scene({kind!r}, {seed}): no connected map in 100 draws")


def movingai_benchmark(kind: str, size: int, out: str | Path, *, rng: np.random.Generator,
                       queries: int = 100, density: float = 0.2, name: str | None = None
                       ) -> GeneratedMap:
    """A seeded MovingAI benchmark map and its ``.scen``, written into ``out``:
    :func:`optplan.maps.movingai_gen.generate_benchmark` (imported on first use: its A* is
    compiled code).

    Parameters
    ----------
    kind : ``"random"``, ``"room"``, ``"maze"`` or ``"street"``
        The map family.
    size : int
        Cells per side (8 to 2048).
    out : path
        The directory.
    rng : numpy.random.Generator
        Every random choice.
    queries, density, name
        Lines of the ``.scen``, the blocked share of a random map, the files' stem.

    Returns
    -------
    optplan.maps.movingai_gen.GeneratedMap
        The paths written, the size, the blocked share, the queries and their buckets.
    """
    from optplan.maps.movingai_gen import generate_benchmark

    return generate_benchmark(kind, size, out, rng=rng, queries=queries, density=density,
                              name=name)
