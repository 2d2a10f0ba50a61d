"""Seeded multi-agent path-finding instances: random roadmaps (``sparse``, ``dense``) and
MovingAI-style grids (``empty``, ``room``, ``warehouse``), each a validated Problem whose ``k``
agents have distinct starts and distinct goals, every goal on its start's connected component
(``docs/mapf.md``).  Every random choice comes from the ``rng`` argument (a
``numpy.random.Generator``): the same seed gives the same instance.

* **roadmaps** (:func:`random_roadmap`, :func:`roadmap_instance`): ``n`` points uniform in a
  square of side 256 (about the extent of the Continuous-CBS roadmaps, drawn on the 256 x 257
  ``den520d`` map), no two closer than 2 units, each joined to its ``k`` nearest neighbours,
  plus the Euclidean minimum spanning tree (so the graph is connected).  ``sparse``: 150
  nodes, ``k = 3`` (mean degree 4.0 on seeds 0 to 2; the authors' sparse roadmap: 170 nodes,
  mean degree 4.1); ``dense``: 900 nodes, ``k = 15`` (mean degree 16.8 to 16.9; theirs: 878
  nodes, 16.7).  :func:`~optplan.maps.write_roadmap_mapf` writes one for the authors' planner.
* **grids** (:func:`grid_terrain`, :func:`grid_instance`): ``empty`` (16 x 16 free cells, as
  MovingAI's ``empty-16-16``), ``room`` (64 x 64, rooms of 7 x 7 cells behind one-cell walls
  with doors: :func:`~optplan.maps.movingai_gen.benchmark_terrain`'s ``room`` family, as
  ``room-64-64-8``), ``warehouse`` (rows of shelves between aisles, a free margin around, as
  MovingAI's ``warehouse-10-20-10-2-1`` at a smaller scale).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.spatial import Delaunay, cKDTree

from optplan.maps.grid import FREE, OCCUPIED, Grid
from optplan.maps.mapf_build import CCBS_RADIUS, grid_mapf_problem, roadmap_problem
from optplan.maps.movingai_gen import benchmark_terrain
from optplan.problem import Problem, RoadmapGraph

__all__ = ["ROADMAP_KINDS", "GRID_KINDS", "random_roadmap", "roadmap_instance",
           "grid_terrain", "grid_instance", "pick_agents"]

#: The roadmap families: ``kind -> (nodes, k nearest neighbours)``.
ROADMAP_KINDS = {"sparse": (150, 3), "dense": (900, 15)}
#: The grid families and their default side (cells; ``warehouse``: its layout's size).
GRID_KINDS = {"empty": 16, "room": 64, "warehouse": None}
#: The side of the square the roadmaps' nodes are drawn in, and their least distance.
SIDE, MIN_SEPARATION = 256.0, 2.0


def _points(n: int, rng: np.random.Generator, side: float, sep: float) -> np.ndarray:
    """``n`` points uniform in ``[0, side]^2``, none closer than ``sep`` to another (darts)."""
    pts = np.zeros((0, 2))
    tries = 0
    while len(pts) < n:
        tries += 1
        if tries > 100 * n:
            raise ValueError(f"cannot place {n} points {sep:g} apart in a square of side "
                             f"{side:g}")
        q = rng.uniform(0.0, side, size=2)
        if not len(pts) or np.hypot(*(pts - q).T).min() >= sep:
            pts = np.vstack([pts, q])
    return pts


def random_roadmap(n: int, k: int, rng: np.random.Generator, *, side: float = SIDE,
                   min_separation: float = MIN_SEPARATION) -> RoadmapGraph:
    """A connected random roadmap: ``k``-nearest-neighbour edges plus the Euclidean minimum
    spanning tree of ``n`` separated random points.

    Parameters
    ----------
    n : int
        Nodes, >= 2.
    k : int
        Nearest neighbours joined to each node, 1 to ``n - 1``.
    rng : numpy.random.Generator
        Every random choice.
    side : float
        The nodes lie in ``[0, side]^2``.
    min_separation : float
        No two nodes closer.

    Returns
    -------
    RoadmapGraph
    """
    if not (isinstance(n, (int, np.integer)) and n >= 2 and
            isinstance(k, (int, np.integer)) and 1 <= k < n):
        raise ValueError(f"need integers n >= 2 and 1 <= k < n, got n={n!r}, k={k!r}")
    pts = _points(int(n), rng, float(side), float(min_separation))
    _, near = cKDTree(pts).query(pts, k=int(k) + 1)
    knn = np.column_stack([np.repeat(np.arange(n), k), near[:, 1:].ravel()])
    tri = Delaunay(pts).simplices
    d = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]])
    w = np.hypot(*(pts[d[:, 0]] - pts[d[:, 1]]).T)
    mst = minimum_spanning_tree(coo_matrix((w, (d[:, 0], d[:, 1])), shape=(n, n))).tocoo()
    return RoadmapGraph(pts, np.vstack([knn, np.column_stack([mst.row, mst.col])]))


def _components(graph: RoadmapGraph) -> np.ndarray:
    """The connected component of every node (breadth-first search)."""
    label = np.full(len(graph), -1, dtype=np.int64)
    for s in range(len(graph)):
        if label[s] >= 0:
            continue
        label[s] = s
        todo = deque([s])
        while todo:
            for v in graph.neighbours(todo.popleft()):
                if label[v] < 0:
                    label[v] = s
                    todo.append(int(v))
    return label


def _far(p: np.ndarray, taken: list[int], nodes: np.ndarray, gap: float) -> bool:
    """Whether ``p`` is at least ``gap`` from every node in ``taken``."""
    return not taken or float(np.hypot(*(nodes[taken] - p).T).min()) >= gap


def pick_agents(nodes: np.ndarray, labels: np.ndarray, agents: int, rng: np.random.Generator,
                radius: float) -> list[tuple[int, int]]:
    """``agents`` random start/goal node pairs: distinct starts, distinct goals, each goal on
    its start's component (``labels``) and not the start itself, no two starts (no two
    goals) closer than ``2 x radius``.

    Parameters
    ----------
    nodes : numpy.ndarray
        The nodes' coordinates, ``(n, 2)``.
    labels : numpy.ndarray
        Per node, its connected component.
    agents : int
        How many, >= 1.
    rng : numpy.random.Generator
        Every random choice (the starts in a random order of the nodes, each goal the first
        admissible node of a random order of the start's component).
    radius : float
        The robots' radius.

    Returns
    -------
    list of (int, int)

    Raises
    ------
    ValueError
        When the nodes cannot take that many agents.
    """
    if isinstance(agents, bool) or not isinstance(agents, (int, np.integer)) or agents < 1:
        raise ValueError(f"agents: expected an integer >= 1, got {agents!r}")
    sizes = np.bincount(labels, minlength=len(nodes))
    starts: list[int] = []
    goals: list[int] = []
    gap = 2.0 * radius
    for s in rng.permutation(len(nodes)).tolist():
        if len(starts) == agents:
            break
        if sizes[labels[s]] < 2 or not _far(nodes[s], starts, nodes, gap):
            continue
        goal = next((int(v) for v in rng.permutation(np.flatnonzero(labels == labels[s]))
                     if v != s and _far(nodes[v], goals, nodes, gap)), None)
        if goal is not None:
            starts.append(s)
            goals.append(goal)
    if len(starts) < agents:
        raise ValueError(f"agents: {agents} requested, the {len(nodes)} nodes take "
                         f"{len(starts)} (distinct starts and goals, {gap:g} apart)")
    return list(zip(starts, goals))


def roadmap_instance(kind: str, agents: int, rng: np.random.Generator, *,
                     radius: float = CCBS_RADIUS, max_speed: float = 1.0) -> Problem:
    """A random roadmap of a family and ``agents`` random agents on it.

    Parameters
    ----------
    kind : ``"sparse"`` or ``"dense"``
        :data:`ROADMAP_KINDS` (module docstring).
    agents : int
        Robots, >= 1.
    rng : numpy.random.Generator
        Every random choice (the roadmap, then the agents).
    radius, max_speed : float
        Every robot's.

    Returns
    -------
    Problem
        Named ``<kind>-roadmap-<agents>``, tagged ``mapf``, ``roadmap``, ``generated``.
    """
    if kind not in ROADMAP_KINDS:
        raise ValueError(f"unknown roadmap kind {kind!r} (expected one of "
                         f"{', '.join(ROADMAP_KINDS)})")
    n, k = ROADMAP_KINDS[kind]
    graph = random_roadmap(n, k, rng)
    ends = pick_agents(graph.nodes, _components(graph), agents, rng, radius)
    scene = {"name": f"{kind}-roadmap-{agents}", "tags": ["mapf", "roadmap", "generated"],
             "description": f"MAPF: {agents} random agents on a random {kind} roadmap ({n} "
                            f"nodes, {len(graph.edges)} edges)",
             "source": f"optplan.maps.mapf_gen.roadmap_instance({kind!r}, {agents})"}
    return roadmap_problem(graph, ends, radius=radius, max_speed=max_speed, scene=scene,
                           where=f"<{kind} roadmap>")


def _warehouse(rows: int = 4, cols: int = 5, shelf: int = 5, aisle: int = 2,
               margin: int = 3) -> np.ndarray:
    """``rows x cols`` shelf blocks of ``shelf x 2`` cells, ``aisle`` cells apart, inside a
    free margin of ``margin`` cells (terrain characters)."""
    h = 2 * margin + rows * 2 + (rows - 1) * aisle
    w = 2 * margin + cols * shelf + (cols - 1) * aisle
    t = np.full((h, w), ".", dtype="<U1")
    for i in range(rows):
        for j in range(cols):
            r0, c0 = margin + i * (2 + aisle), margin + j * (shelf + aisle)
            t[r0:r0 + 2, c0:c0 + shelf] = "@"
    return t


def grid_terrain(kind: str, rng: np.random.Generator, size: int | None = None) -> np.ndarray:
    """A MovingAI-style MAPF grid as terrain characters (``"."`` free, ``"@"`` blocked).

    Parameters
    ----------
    kind : ``"empty"``, ``"room"`` or ``"warehouse"``
        :data:`GRID_KINDS` (module docstring).
    rng : numpy.random.Generator
        The room family's doors.
    size : int, optional
        Cells per side of ``empty`` (default 16) and ``room`` (default 64, 8 to 2048); the
        warehouse's layout is fixed (39 x 20 cells).

    Returns
    -------
    numpy.ndarray
        ``(height, width)`` characters, row 0 at the top.
    """
    if kind not in GRID_KINDS:
        raise ValueError(f"unknown grid kind {kind!r} (expected one of {', '.join(GRID_KINDS)})")
    if kind == "warehouse":
        return _warehouse()
    side = size if size is not None else GRID_KINDS[kind] or 0
    if kind == "room":
        return benchmark_terrain("room", side, rng)
    if isinstance(side, bool) or not isinstance(side, (int, np.integer)) or side < 1:
        raise ValueError(f"size: expected an integer >= 1, got {side!r}")
    return np.full((int(side), int(side)), ".", dtype="<U1")


def grid_instance(kind: str, agents: int, rng: np.random.Generator, *, size: int | None = None,
                  connectedness: int = 2, radius: float = CCBS_RADIUS) -> Problem:
    """A MovingAI-style grid (:func:`grid_terrain`) and ``agents`` random agents on it.

    Parameters
    ----------
    kind, size
        :func:`grid_terrain`.
    agents : int
        Robots, >= 1: start and goal cells drawn by :func:`pick_agents` among the free cells
        of one 4-connected component (for ``radius <= 0.5`` every axis move between free
        cells is a roadmap edge, so the goal is reachable in the roadmap).
    rng : numpy.random.Generator
        Every random choice (the terrain, then the agents).
    connectedness : int
        The grid's moves (:func:`~optplan.maps.mapf_build.grid_moves`).
    radius : float
        Every robot's radius, cells (at most 0.5).

    Returns
    -------
    Problem
        Named ``<kind>-<width>-<height>-<agents>``, tagged ``mapf``, ``grid``, ``generated``.
    """
    terrain = grid_terrain(kind, rng, size)
    free = terrain == "."
    labels, _ = ndimage.label(free)
    rows, cols = np.nonzero(free)
    ends = pick_agents(np.column_stack([cols, rows]).astype(float), labels[rows, cols], agents,
                       rng, min(radius, 0.5))
    h, w = terrain.shape
    cells = [((int(cols[s]), int(rows[s])), (int(cols[g]), int(rows[g]))) for s, g in ends]
    grid = Grid(np.where(free, FREE, OCCUPIED).astype(np.uint8), 1.0, source=f"<{kind} grid>")
    scene: dict[str, Any] = {
        "name": f"{kind}-{w}-{h}-{agents}", "tags": ["mapf", "grid", "generated"],
        "description": f"MAPF: {agents} random agents on a {w} x {h} {kind} grid "
                       f"({connectedness}-connectedness, {2 ** connectedness} moves)",
        "source": f"optplan.maps.mapf_gen.grid_instance({kind!r}, {agents})"}
    return grid_mapf_problem(grid, cells, radius=radius, connectedness=connectedness,
                             scene=scene, where=f"<{kind} grid>")
