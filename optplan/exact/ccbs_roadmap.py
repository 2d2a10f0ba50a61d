r"""The graph ``ccbs`` plans on: the problem's roadmap, or *the roadmap model* of its map.

**Given roadmap.**  ``problem.roadmap`` (:class:`~optplan.problem.RoadmapGraph`) when the
problem has one: every robot's start and goal are nodes of it.

**The roadmap model** (a problem without a roadmap).  Nodes: the robots' starts and goals, and
the corners of the static map pushed outward by the largest robot radius times
``1 + CORNER_MARGIN`` (a polygon's corners by its mitred offset; a circle's by the regular
octagon whose sides touch the circle grown by that distance), inside the bounds.  Edges: every
pair of nodes whose straight segment is free for at least one robot.  It is a visibility graph
of the grown map: optimal paths of a single robot among polygons bend at the grown corners, so
it holds the shortest paths of the largest robot among polygons, and a close approximation
otherwise (circles are octagons).  It is a *model*: the optimum within it is not the optimum
over all motions in the plane.

**Per robot** (:func:`agent_models`): the edges whose segment is free for that robot's radius
(:meth:`~optplan.geometry.ObstacleSet.segment_free`, the exact engine of the validator, every
static obstacle, temporary ones included), and the moving obstacles as its hard constraints,
exact on ``[0, horizon]``.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from optplan.exact.ccbs_sipp import AgentModel
from optplan.exact.sipp_graph import MoverBoxes
from optplan.problem import Problem, RoadmapGraph

__all__ = ["roadmap_model", "agent_models", "CORNER_MARGIN"]

#: Relative margin of the grown corners (of the largest robot radius).
CORNER_MARGIN = 1e-3
#: Corners of the octagon that stands for a static circle.
_OCTAGON = 8


def _corners(problem: Problem, grow: float) -> np.ndarray:
    """The static map's corners pushed outward by ``grow`` (module docstring)."""
    pts = []
    for o in problem.obstacles:
        if o.is_circle:
            c, r = o.disc()
            ang = 2 * math.pi * (np.arange(_OCTAGON) + 0.5) / _OCTAGON
            rho = (r + grow) / math.cos(math.pi / _OCTAGON)
            pts.append(np.c_[c[0] + rho * np.cos(ang), c[1] + rho * np.sin(ang)])
            continue
        g = shapely.buffer(o.polygon(), grow, join_style="mitre", mitre_limit=10.0)
        for poly in getattr(g, "geoms", [g]):
            for ring in (poly.exterior, *poly.interiors):
                pts.append(np.asarray(ring.coords)[:-1])
    return np.vstack(pts) if pts else np.zeros((0, 2))


def roadmap_model(problem: Problem) -> RoadmapGraph:
    """The graph of ``problem``: its roadmap, else the roadmap model (module docstring)."""
    if problem.roadmap is not None:
        return problem.roadmap
    robots = problem.planned_robots
    r_max = max(r.radius for r in robots)
    r_min = min(r.radius for r in robots)
    ends = np.array([p for r in robots for p in (r.start, r.goal)], float)
    corners = _corners(problem, r_max * (1.0 + CORNER_MARGIN))
    x0, y0, x1, y1 = problem.bounds
    inside = ((corners[:, 0] >= x0 + r_min) & (corners[:, 0] <= x1 - r_min)
              & (corners[:, 1] >= y0 + r_min) & (corners[:, 1] <= y1 - r_min))
    pts = np.vstack([ends, corners[inside]])
    _, first = np.unique(pts, axis=0, return_index=True)
    pts = pts[np.sort(first)]
    i, j = np.triu_indices(len(pts), k=1)
    free = np.zeros(len(i), bool)
    for r in sorted({x.radius for x in robots}):
        free |= problem.obstacle_set(r, known_only=False).segment_free(pts[i], pts[j])
    return RoadmapGraph(pts, np.c_[i[free], j[free]])


def _node(graph: RoadmapGraph, point, tol: float, what: str) -> int:
    """The node at ``point`` (``ValueError`` naming ``what`` when there is none)."""
    k = graph.node_at(point, tol)
    if k is None:
        raise ValueError(f"ccbs: {what} {np.asarray(point).tolist()} is not a node of the "
                         "roadmap")
    return k


def agent_models(problem: Problem, graph: RoadmapGraph, horizon: float) -> list[AgentModel]:
    """Per planned robot: its graph (the edges free for its radius), start and goal nodes,
    and the moving obstacles on ``[0, horizon]`` (module docstring).

    Raises
    ------
    ValueError
        If a robot has no goal, or its start or goal is not a node of ``graph``.
    """
    tol = 1e-9 * max(problem.extent, 1e-300)
    lengths = graph.lengths
    models = []
    movers = list(problem.dynamic_obstacles)
    for r in problem.planned_robots:
        if r.goal is None:
            raise ValueError(f"ccbs: robot {r.id!r} has no goal")
        e = graph.edges
        free = problem.obstacle_set(r.radius, known_only=False).segment_free(
            graph.nodes[e[:, 0]], graph.nodes[e[:, 1]]) if len(e) else np.zeros(0, bool)
        nbrs: list[list[tuple[int, float]]] = [[] for _ in range(len(graph))]
        for (a, b), ln, ok in zip(e.tolist(), lengths.tolist(), free.tolist()):
            if ok:
                nbrs[a].append((b, ln))
                nbrs[b].append((a, ln))
        boxes = MoverBoxes.build(movers, r.radius, horizon) if movers else None
        models.append(AgentModel(graph.nodes, nbrs, _node(graph, r.start, tol, f"{r.id} start"),
                                 _node(graph, r.goal, tol, f"{r.id} goal"), float(r.radius),
                                 float(r.max_speed), boxes, horizon if movers else math.inf))
    return models
