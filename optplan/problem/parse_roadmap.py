"""The ``[roadmap]`` table of the scenario format: a multi-agent path-finding instance's graph
(:class:`~optplan.problem.roadmap.RoadmapGraph`), and the checks that tie the robots to it.

``nodes = [[x, y], ...]`` and ``edges = [[i, j], ...]`` (0-based node indices, either order,
each pair once).  Every node lies inside the bounds, every robot's start and goal is a node (up
to the map's tolerance ``eps``, :attr:`optplan.problem.Problem.frame`), and no two robots'
discs overlap at their starts or at their goals (both are held for a positive time on a
roadmap: the instance would be infeasible).  Errors name the file and the key.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from optplan.problem.context import _ROADMAP_KEYS, _Ctx
from optplan.problem.model import Problem, _show
from optplan.problem.roadmap import RoadmapGraph


def _edge_array(ctx: _Ctx, raw: Any) -> np.ndarray:
    """``roadmap.edges`` as an ``(m, 2)`` int array: pairs of TOML integers (bools refused)."""
    if not isinstance(raw, list):
        raise ctx.err("roadmap.edges", f"expected a list of node-index pairs [i, j], got "
                                       f"{_show(raw)}")
    for k, e in enumerate(raw):
        if type(e) is not list or len(e) != 2 or any(type(v) is not int for v in e):
            raise ctx.err(f"roadmap.edges[{k}]", f"expected a pair of node indices [i, j] "
                                                 f"(integers), got {_show(e)}")
    try:
        return np.array(raw, dtype=np.int64).reshape(-1, 2)
    except OverflowError:
        raise ctx.err("roadmap.edges", "a node index beyond the 64-bit range") from None


def _parse_roadmap(ctx: _Ctx, tbl: Any, frame: Any) -> RoadmapGraph:
    """The ``[roadmap]`` table: ``nodes`` inside the bounds and ``edges`` between them."""
    if not isinstance(tbl, dict):
        raise ctx.err("roadmap", f"expected a table, got {_show(tbl)}")
    ctx.check_keys(tbl, _ROADMAP_KEYS, "roadmap.")
    nodes = ctx.points(ctx.require(tbl, "nodes", "roadmap."), "roadmap.nodes", 1, coord=True)
    edges = _edge_array(ctx, ctx.require(tbl, "edges", "roadmap."))
    inside = frame.in_bounds(nodes)
    if not inside.all():
        k = int(np.flatnonzero(~inside)[0])
        raise ctx.err(f"roadmap.nodes[{k}]", f"{nodes[k].tolist()} lies outside the bounds")
    try:
        return RoadmapGraph(nodes, edges)
    except ValueError as e:
        key = "roadmap.edges" if str(e).startswith("roadmap edge") else "roadmap.nodes"
        raise ctx.err(key, str(e)) from None


def _end_nodes(ctx: _Ctx, prob: Problem, graph: RoadmapGraph, key: str) -> list[int | None]:
    """Per robot, the node its ``key`` (``start``/``goal``) lies on (None without a goal)."""
    eps = prob.frame.eps
    out: list[int | None] = []
    for i, r in enumerate(prob.robots):
        p = r.start if key == "start" else r.goal
        if p is None:
            out.append(None)
            continue
        v = graph.node_at(p, eps)
        if v is None:
            near = int(np.argmin(np.hypot(*(graph.nodes - p).T)))
            gap = float(np.hypot(*(graph.nodes[near] - p)))
            raise ctx.err(f"robots[{i}].{key}", f"{p.tolist()} is not a node of the roadmap "
                          f"(the nearest, roadmap.nodes[{near}] {graph.nodes[near].tolist()}, "
                          f"is {gap:.6g} away; tolerance eps = {eps:.3g}, 1e-9 x the bounds "
                          "diagonal)")
        out.append(v)
    return out


def _first_overlap(points: np.ndarray, radii: np.ndarray, eps: float) -> tuple[int, int] | None:
    """The first pair ``(i, j)``, ``j < i``, of discs that overlap (touching allowed; two
    discs at one point always overlap, point robots too), else None."""
    d = np.hypot(*(points[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    bad = (d < radii[:, None] + radii[None, :] - eps) | (d == 0)
    bad &= np.tri(len(points), k=-1, dtype=bool)
    if not bad.any():
        return None
    i, j = (int(x) for x in np.argwhere(bad)[0])
    return i, j


def _check_roadmap_ends(ctx: _Ctx, prob: Problem) -> None:
    """Every start and goal is a node; no two robots overlap at their starts or goals."""
    graph = prob.roadmap
    if graph is None:
        return
    for key in ("start", "goal"):
        nodes = _end_nodes(ctx, prob, graph, key)
        idx = [i for i, v in enumerate(nodes) if v is not None]
        pts = graph.nodes[[v for v in nodes if v is not None]].reshape(-1, 2)
        pair = _first_overlap(pts, np.array([prob.robots[i].radius for i in idx]),
                              prob.frame.eps)
        if pair is None:
            continue
        i, j = idx[pair[0]], idx[pair[1]]
        r, q = prob.robots[i], prob.robots[j]
        gap = float(np.hypot(*(pts[pair[0]] - pts[pair[1]])))
        how = (f"the same node {nodes[i]}" if nodes[i] == nodes[j] else
               f"nodes {nodes[j]} and {nodes[i]}, {gap:.6g} apart, radii {q.radius:g} + "
               f"{r.radius:g}")
        raise ctx.err(f"robots[{i}].{key}", f"robot {r.id!r} overlaps robot {q.id!r} "
                                            f"(robots[{j}]) at their {key}s ({how})")
