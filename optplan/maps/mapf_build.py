"""Multi-agent path-finding instances as Problems: the roadmap of a grid (:func:`grid_roadmap`)
and the validated problem of a roadmap or a grid with its agents (:func:`roadmap_problem`,
:func:`grid_mapf_problem`); the readers (:mod:`optplan.maps.mapf`) and the generators
(:mod:`optplan.maps.mapf_gen`) build their instances here.

An agent is a start node and a goal node (indices into the roadmap's nodes).  Two agents may
not share a start node or a goal node, and their discs may not overlap at their starts or at
their goals (a robot waits at its start before it leaves and at its goal after it arrives, so
the instance would have no solution); the errors name the source and the agents.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from optplan.maps.checks import err, number
from optplan.maps.grid import Grid
from optplan.maps.importer import _polygon_table, _world
from optplan.maps.polygons import grid_polygons
from optplan.problem import Problem, RoadmapGraph, parse_problem

__all__ = ["CCBS_RADIUS", "CONNECTEDNESS", "grid_moves", "grid_roadmap", "roadmap_problem",
           "grid_mapf_problem", "check_agent_ends"]

#: The agents' radius Continuous-CBS uses by default (``const.h``: ``CN_AGENT_SIZE``), in cells
#: (in the roadmaps' units for a roadmap): ``sqrt(2) / 4``.
CCBS_RADIUS = math.sqrt(2.0) / 4.0

#: The connectedness values of a grid (Continuous-CBS's ``<connectedness>``): ``k`` gives
#: ``2**k`` moves per cell (2: 4-connected, 3: 8-connected, 4: 16, 5: 32 neighbours).
CONNECTEDNESS = (2, 3, 4, 5)


def grid_moves(connectedness: int) -> list[tuple[int, int]]:
    """The moves of a ``2**connectedness``-connected grid, one of each opposite pair.

    Parameters
    ----------
    connectedness : int
        2 (the 4 axis moves), 3 (also the 4 diagonals), 4 or 5 (every move ``(a, b)`` with
        ``gcd(a, b) = 1`` and ``max(|a|, |b|) <= connectedness - 2``: 16 and 32 moves, as
        Continuous-CBS's ``map.cpp``).

    Returns
    -------
    list of (int, int)
        ``(dcol, drow)`` pairs, ``2**(connectedness - 1)`` of them (the opposite moves are the
        same undirected edges).
    """
    if connectedness not in CONNECTEDNESS:
        raise ValueError(f"connectedness: expected one of {CONNECTEDNESS}, got "
                         f"{connectedness!r}")
    if connectedness == 2:
        return [(1, 0), (0, 1)]
    n = connectedness - 2
    return [(a, b) for b in range(0, n + 1) for a in range(-n, n + 1)
            if (b > 0 or a > 0) and math.gcd(a, b) == 1]


def grid_roadmap(grid: Grid, radius: float, connectedness: int, problem: Problem,
                 info: dict | None = None) -> RoadmapGraph:
    """The roadmap of a grid: its free cells' centres, joined by the grid's moves that a disc
    of ``radius`` drives clear of every obstacle.

    Parameters
    ----------
    grid : Grid
        The map (its obstacle cells: occupied and unknown).
    radius : float
        The robots' radius (map units).
    connectedness : int
        The moves (:func:`grid_moves`).
    problem : Problem
        The map's problem (its obstacles: the exact union of the obstacle cells): a move is an
        edge when :meth:`~optplan.geometry.ObstacleSet.pairs_free` of
        ``problem.obstacle_set(radius)`` passes it (the validator's exact test, the bounds a
        wall, touching allowed).
    info : dict, optional
        Receives ``candidates`` (moves between two free cells) and ``blocked`` (those the disc
        cannot drive).

    Returns
    -------
    RoadmapGraph
        Node ``k`` is the ``k``-th free cell in row-major order (row 0 at the top).
    """
    free = ~grid.obstacle_mask()
    rows, cols = np.nonzero(free)
    index = np.full(free.shape, -1, dtype=np.int64)
    index[rows, cols] = np.arange(len(rows))
    nodes = grid.cell_to_world(np.column_stack([cols + 0.5, grid.height - rows - 0.5]))
    pairs = []
    for dc, dr in grid_moves(connectedness):
        r2, c2 = rows + dr, cols + dc
        inside = (r2 >= 0) & (r2 < grid.height) & (c2 >= 0) & (c2 < grid.width)
        j = index[r2[inside], c2[inside]]
        i = np.flatnonzero(inside)
        pairs.append(np.column_stack([i[j >= 0], j[j >= 0]]))
    cand = np.vstack(pairs) if pairs else np.zeros((0, 2), np.int64)
    ok = problem.obstacle_set(radius).pairs_free(nodes, cand[:, 0], cand[:, 1])
    if info is not None:
        info.update(candidates=len(cand), blocked=int(np.sum(~ok)))
    return RoadmapGraph(nodes, cand[ok])


def check_agent_ends(where: Any, nodes: np.ndarray, ends: Sequence[tuple[int, int]],
                     radius: float, labels: Sequence[tuple[str, str]]) -> None:
    """Check that no two agents overlap at their starts or at their goals.

    Parameters
    ----------
    where : path or str
        The source named in the error (the task file).
    nodes : numpy.ndarray
        The roadmap's node coordinates, ``(n, 2)``.
    ends : sequence of (int, int)
        Per agent, its start and goal node.
    radius : float
        Every agent's radius.
    labels : sequence of (str, str)
        Per agent, how its start and its goal are named in messages (``"start_id 'n5'"``).

    Raises
    ------
    ProblemError
        ``"<where>: agent 3: start_id 'n5' is agent 1's start too (...)"``, or naming the two
        nodes closer than twice the radius.
    """
    for side, what in ((0, "start"), (1, "goal")):
        at = np.array([e[side] for e in ends], dtype=np.int64)
        p = nodes[at]
        d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
        bad = (d < 2.0 * radius) | (at[:, None] == at[None, :])
        bad &= np.tri(len(at), k=-1, dtype=bool)
        if not bad.any():
            continue
        k, j = (int(x) for x in np.argwhere(bad)[0])
        if at[k] == at[j]:
            raise err(where, f"agent {k}", f"{labels[k][side]} is agent {j}'s {what} too (two "
                                           f"robots on one node overlap at t = 0"
                                           + (")" if side == 0 else " and forever after)"))
        raise err(where, f"agent {k}", f"its {what} ({labels[k][side]}) is {d[k, j]:.6g} from "
                                       f"agent {j}'s ({labels[j][side]}), less than twice the "
                                       f"radius {radius:g}: the two robots overlap there")


def _radius(where: Any, radius: Any, hi: float | None = None) -> float:
    """The robots' radius: a number >= 0 (at most ``hi`` when given)."""
    r = number(radius, where, "radius")
    if r < 0 or (hi is not None and r > hi):
        allowed = f"[0, {hi:g}]" if hi is not None else ">= 0"
        raise err(where, "radius", f"must lie in {allowed}, got {radius!r}")
    return r


def _check_cells(where: Any, grid: Grid,
                 cells: Sequence[tuple[tuple[int, int], tuple[int, int]]]) -> None:
    """At least one agent; every start and goal cell a free cell of the grid."""
    if not cells:
        raise err(where, "agents", "no agents: a MAPF instance needs at least one")
    blocked = grid.obstacle_mask()
    for k, ends in enumerate(cells):
        for what, (x, y) in zip(("start", "goal"), ends):
            if not (0 <= x < grid.width and 0 <= y < grid.height):
                raise err(where, f"agent {k}", f"{what} cell ({x}, {y}) lies outside the "
                                               f"{grid.width} x {grid.height} map")
            if blocked[y, x]:
                raise err(where, f"agent {k}", f"{what} cell ({x}, {y}) is blocked")


def _robots(ends: Sequence[tuple[int, int]], nodes: np.ndarray, radius: float,
            max_speed: float) -> list[dict[str, Any]]:
    """The ``[[robots]]`` tables of the agents (ids ``a0``, ``a1``, ...)."""
    return [{"id": f"a{k}", "start": nodes[s].tolist(), "goal": nodes[g].tolist(),
             "radius": radius, "max_speed": max_speed} for k, (s, g) in enumerate(ends)]


def roadmap_problem(graph: RoadmapGraph, ends: Sequence[tuple[int, int]], *, radius: float,
                    max_speed: float = 1.0, scene: dict[str, Any], where: str) -> Problem:
    """A validated problem of agents on a roadmap in the open plane (no static obstacles).

    Parameters
    ----------
    graph : RoadmapGraph
        The roadmap.
    ends : sequence of (int, int)
        Per agent, its start and goal node (checked with :func:`check_agent_ends` first).
    radius, max_speed : float
        Every robot's radius (>= 0) and speed (map units, per second).
    scene : dict
        The scenario's ``name``, ``description``, ``source`` and ``tags``.
    where : str
        The source named in errors.

    Returns
    -------
    Problem
        Robots ``a0``, ``a1``, ...; bounds: the nodes' bounding box grown by the radius and
        1 % of its diagonal (1 when the nodes are one point), so no disc at a node touches the
        wall.
    """
    lo, hi = graph.nodes.min(axis=0), graph.nodes.max(axis=0)
    diag = float(np.hypot(*(hi - lo)))
    pad = radius + 0.01 * (diag if diag > 0 else 1.0)
    data = {**scene, "bounds": [*(lo - pad).tolist(), *(hi + pad).tolist()],
            "robots": _robots(ends, graph.nodes, radius, max_speed),
            "roadmap": {"nodes": graph.nodes.tolist(), "edges": graph.edges.tolist()}}
    return parse_problem(data, where)


def grid_mapf_problem(grid: Grid, cells: Sequence[tuple[tuple[int, int], tuple[int, int]]], *,
                      radius: float = CCBS_RADIUS, connectedness: int = 2,
                      max_speed: float = 1.0, scene: dict[str, Any], where: str,
                      info: dict | None = None) -> Problem:
    """A validated MAPF problem on a grid: its obstacle cells exactly (one polygon with holes
    per 8-connected component, no growth), the roadmap of :func:`grid_roadmap`, the agents.

    Parameters
    ----------
    grid : Grid
        The map.
    cells : sequence of ((x, y), (x, y))
        Per agent, its start and goal cell (column ``x``, row ``y`` from the top, as MovingAI
        writes them), free cells of the grid.
    radius : float
        Every robot's radius, in ``[0, 0.5]`` cells (map units: ``x grid.resolution``);
        default :data:`CCBS_RADIUS`.
    connectedness : int
        :func:`grid_moves`.
    max_speed : float
        Every robot's speed (map units / s).
    scene : dict
        The scenario's ``name``, ``description``, ``source`` and ``tags``.
    where : str
        The source named in errors (messages name ``agent k``).
    info : dict, optional
        Receives :func:`grid_roadmap`'s counts and ``nodes``, ``edges``.

    Returns
    -------
    Problem
        Bounds: the grid's; robots ``a0``, ``a1``, ... at the cells' centres.
    """
    r = _radius(where, radius, 0.5 * grid.resolution)
    if connectedness not in CONNECTEDNESS:
        raise err(where, "connectedness", f"expected one of {CONNECTEDNESS}, got "
                                          f"{connectedness!r}")
    _check_cells(where, grid, cells)
    polys = [_world(grid, q) for q in grid_polygons(grid.obstacle_mask(), grow=0.0,
                                                     simplify=0.0)]
    stem = str(scene.get("name", "map"))
    data = {**scene, "bounds": list(grid.bounds),
            "obstacles": [_polygon_table(q, f"{stem}-{k}") for k, q in enumerate(polys)],
            "robots": [{"id": "probe", "start": grid.cell_centre(cells[0][0][1],
                                                                 cells[0][0][0]).tolist(),
                        "goal": grid.cell_centre(cells[0][1][1], cells[0][1][0]).tolist(),
                        "radius": r}]}
    walls = parse_problem(data, where)
    graph = grid_roadmap(grid, r, connectedness, walls, info)
    free = ~grid.obstacle_mask()
    index = np.cumsum(free.ravel()).reshape(free.shape) - 1
    ends = [(int(index[s[1], s[0]]), int(index[g[1], g[0]])) for s, g in cells]
    check_agent_ends(where, graph.nodes, ends, r,
                     [(f"start cell {s}", f"goal cell {g}") for s, g in cells])
    data.update(robots=_robots(ends, graph.nodes, r, max_speed),
                roadmap={"nodes": graph.nodes.tolist(), "edges": graph.edges.tolist()})
    if info is not None:
        info.update(nodes=len(graph), edges=len(graph.edges))
    return parse_problem(data, where)
