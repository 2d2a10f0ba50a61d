r"""Certified shortest path: visibility graph over inflated obstacles + Dijkstra.

Mathematics (domain-notes §2.1)
-------------------------------
Among disjoint polygonal obstacles, every Euclidean shortest path is a polyline whose inner
vertices are obstacle vertices (de Berg et al., *Computational Geometry*, Lemma 15.1;
Lozano-Pérez & Wesley 1979).  Hence Dijkstra on the visibility graph, whose nodes are start,
goal and the obstacle vertices and whose edges are the mutually visible pairs weighted by
Euclidean length, returns the global optimum for a point robot in the configuration space.

Construction used here:

1. C-space: the static obstacles inflated by the robot radius and merged
   (:func:`optplan.geometry.inflate`).  By default only *known* obstacles are used, the map a
   global planner sees (paper §V); ``see_temporary = true`` plans around temporary ones too.
2. Nodes: start, goal and the *convex* vertices of the inflated union inside the bounds
   (reflex vertices never lie on a shortest path).
3. Edges: only *bitangent* pairs are kept: at an obstacle vertex, both ring neighbours must lie
   on the same side of the edge's line, otherwise the path would enter the obstacle there or
   could be shortened (the reduced visibility graph).  Candidates are then checked with the
   vectorised interior-crossing test (touching is allowed), all pairs in one array call; a
   convex part at one of the edge's own end vertices is skipped (a tangent line cannot enter
   it).
4. Dijkstra (``scipy.sparse.csgraph``).

Certificate.  The map is the *inscribed* round buffer; the same search on the
*circumscribed* buffer gives an upper bound, so ``length_inscribed <= L*(disc robot) <=
length_circumscribed`` (domain-notes §2.2).  Both are reported in ``metrics``.

Statuses: ``optimal`` when a path exists (and the validator accepts it); ``infeasible`` when
the start or goal lies inside an inflated obstacle or the goal is not reachable.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from optplan.geometry_old import InflatedMap, candidate_pairs, inside_lengths
from optplan.problem import Problem, Robot
from optplan.result import History, Status
from optplan.solver import Backend

__all__ = ["VisGraph", "cached_shortest_path", "shortest_path", "shortest_length"]


def _convex_nodes(imap: InflatedMap, bounds, tol: float):
    """Convex vertices inside the bounds: positions, offsets to ring neighbours, part index."""
    vs, prevs, nexts, part = [], [], [], []
    for k, poly in enumerate(imap.parts):
        for ring in (poly.exterior, *poly.interiors):
            c = np.asarray(ring.coords)[:-1]
            if len(c) < 3:
                continue
            prev = np.roll(c, 1, axis=0)
            nxt = np.roll(c, -1, axis=0)
            a, b = c - prev, nxt - c
            cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
            keep = cross > 1e-12 * max(1.0, float(np.abs(c).max()))
            vs.append(c[keep])
            prevs.append(prev[keep])
            nexts.append(nxt[keep])
            part.append(np.full(int(keep.sum()), k))
    if not vs:
        z = np.zeros((0, 2))
        return z, z, z, np.zeros(0, int)
    v, p, n, part = map(np.concatenate, (vs, prevs, nexts, part))
    x0, y0, x1, y1 = bounds
    inside = (v[:, 0] >= x0 - tol) & (v[:, 0] <= x1 + tol) & (v[:, 1] >= y0 - tol) & (
        v[:, 1] <= y1 + tol)
    return v[inside], p[inside] - v[inside], n[inside] - v[inside], part[inside]


def _tangent_pairs(nodes: np.ndarray, to_prev: np.ndarray, to_next: np.ndarray,
                   block: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``i < j`` whose line is tangent at both ends (reduced visibility graph).

    At an obstacle vertex ``u`` the edge ``u -> w`` is kept when both ring neighbours of ``u``
    lie on the same side of the line (or on it).  Start and goal (zero neighbour offsets) pass
    trivially.  Evaluated as a dense ``n x n`` test in row blocks (bounded memory).
    """
    n = len(nodes)
    x, y = nodes[:, 0], nodes[:, 1]
    ok = np.empty((n, n), bool)
    for s in range(0, n, block):
        e = min(n, s + block)
        dx = x[None, :] - x[s:e, None]
        dy = y[None, :] - y[s:e, None]
        c1 = dx * to_prev[s:e, 1:2] - dy * to_prev[s:e, 0:1]
        c2 = dx * to_next[s:e, 1:2] - dy * to_next[s:e, 0:1]
        np.greater_equal(c1 * c2, 0.0, out=ok[s:e])
    ok &= ok.T
    return np.nonzero(np.triu(ok, 1))


def shortest_path(imap: InflatedMap, start: np.ndarray, goal: np.ndarray,
                  bounds: tuple[float, float, float, float]) -> tuple[np.ndarray | None, dict]:
    """Shortest path from ``start`` to ``goal`` around ``imap``; ``(path or None, info)``."""
    tol = 1e-9 * max(1.0, float(np.max(np.abs(bounds))))
    info: dict = {"n_nodes": 0, "n_edges": 0}
    for key, p in (("start", start), ("goal", goal)):
        hit = imap.containing(p)
        if hit is not None:
            info["reason"] = f"{key} {np.asarray(p).tolist()} lies inside inflated obstacle {hit}"
            return None, info
    v, vp, vn, part = _convex_nodes(imap, bounds, tol)
    z = np.zeros((2, 2))
    nodes = np.vstack([start[None], goal[None], v])
    part = np.r_[-1, -1, part]
    n = len(nodes)
    info["n_nodes"] = n
    i, j = _tangent_pairs(nodes, np.vstack([z, vp]), np.vstack([z, vn]))
    a, b = nodes[i], nodes[j]
    # visibility: the vectorised interior test on every (candidate edge, nearby part) pair,
    # except a convex part at one of the edge's own end vertices: a line tangent to a convex
    # polygon at a vertex cannot enter it
    si, oi = candidate_pairs(a, b, imap)
    own = (oi == part[i][si]) | (oi == part[j][si])
    keep = ~(own & imap.convex[oi])
    si, oi = si[keep], oi[keep]
    blocked = np.zeros(len(i), bool)
    if si.size:
        hit = inside_lengths(a[si], b[si], oi, imap) > 1e-9 * imap.scale
        blocked[si[hit]] = True
    i, j = i[~blocked], j[~blocked]
    w = np.hypot(*(nodes[i] - nodes[j]).T)
    info["n_edges"] = int(len(i))
    g = csr_matrix((np.r_[w, w], (np.r_[i, j], np.r_[j, i])), shape=(n, n))
    dist, pred = dijkstra(g, directed=False, indices=0, return_predecessors=True)
    if not np.isfinite(dist[1]):
        info["reason"] = "goal is not reachable from start in the inflated map"
        return None, info
    order = [1]
    while order[-1] != 0:
        order.append(int(pred[order[-1]]))
    return nodes[order[::-1]], info


def cached_shortest_path(problem: Problem, robot: Robot, known_only: bool = True,
                         mode: str = "inscribed") -> tuple[np.ndarray | None, dict]:
    """:func:`shortest_path` for ``robot`` on ``problem``'s inflated map, cached per problem."""
    key = ("visgraph", robot.id, known_only, mode)
    if key not in problem._cache:
        imap = problem.inflated(robot.radius, mode=mode, known_only=known_only)
        problem._cache[key] = shortest_path(imap, robot.start, robot.goal, problem.bounds)
    path, info = problem._cache[key]
    return (None if path is None else path.copy()), dict(info)


def shortest_length(problem: Problem, robot: Robot, known_only: bool = True,
                    mode: str = "inscribed") -> float | None:
    """Length of the certified shortest path of ``robot`` (None if infeasible)."""
    path, _ = cached_shortest_path(problem, robot, known_only, mode)
    if path is None:
        return None
    return float(np.sum(np.hypot(*np.diff(path, axis=0).T)))


@dataclass(frozen=True, kw_only=True)
class VisGraph(Backend):
    """Exact Euclidean shortest path for a disc robot among inflated static obstacles.

    Parameters
    ----------
    see_temporary : bool
        Also avoid temporary (``known = false``) obstacles.  Default ``False``: plan on the map
        a global planner knows (paper §V), like the PSO planners.
    bracket : bool
        Also solve on the circumscribed inflation and report
        ``metrics["length_circumscribed"]`` (upper bound of the disc-robot optimum).
    """

    name: ClassVar[str] = "visgraph"
    certifies: ClassVar[bool] = True
    see_temporary: bool = False
    bracket: bool = True

    def __post_init__(self) -> None:
        for k in ("see_temporary", "bracket"):
            if not isinstance(getattr(self, k), bool):
                raise ValueError(f"option {k!r} of backend 'visgraph' must be true or false, "
                                 f"got {getattr(self, k)!r}")

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        t0 = time.perf_counter()
        known_only = not self.see_temporary
        paths, infos, lengths = {}, {}, {}
        status, msgs = Status.optimal, []
        for r in problem.planned_robots:
            path, info = cached_shortest_path(problem, r, known_only)
            infos[r.id] = info
            if path is None:
                status = Status.infeasible
                msgs.append(f"{r.id}: {info['reason']}")
                paths[r.id] = np.vstack([r.start, r.start])
                continue
            paths[r.id] = path
            if self.bracket:
                cpath, _ = cached_shortest_path(problem, r, known_only, "circumscribed")
                lengths[r.id] = None if cpath is None else float(
                    np.sum(np.hypot(*np.diff(cpath, axis=0).T)))
        lead = problem.leader.id if problem.leader.id in paths else next(iter(paths))
        extra = {}
        if status is Status.optimal:
            extra["length_inscribed"] = float(np.sum(np.hypot(*np.diff(paths[lead], axis=0).T)))
            if self.bracket:
                extra["length_circumscribed"] = lengths.get(lead)
        hist = History()
        hist.append(iteration=0, best_cost=extra.get("length_inscribed", np.nan), n_eval=1,
                    time=time.perf_counter() - t0)
        return self.finish(
            problem, paths, claim=status, cost=extra.get("length_inscribed", np.inf),
            message="; ".join(msgs) or "shortest path on the visibility graph (certified)",
            n_iter=1, n_eval=1, history=hist, extras={"graph": infos}, metrics_extra=extra,
            wall_time=time.perf_counter() - t0,
        )
