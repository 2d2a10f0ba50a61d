r"""Certified shortest path: the arc-exact tangent visibility graph (``optplan.geometry``).

The mathematics lives in :mod:`optplan.geometry.tangent.tangent_graph` (the certified optimum is a
geometry algorithm); this module is the thin :class:`~optplan.backend.Backend` driver.

For each planned robot (a disc of radius ``r >= 0``) the search returns the exact length of the
shortest path among the true obstacles (segments + arcs), reported as ``metrics["optimum"]`` and
``metrics["length_exact"]``, and a polyline that replaces each arc by a circumscribed polyline
(so it stays ``>= r`` from every obstacle; ``metrics["length"]`` is that polyline's length,
slightly above the exact one).

The bounds are a wall of the exact geometry (the robot's disc stays inside them), so the
search is complete inside the bounds.  Statuses: ``optimal`` when a path is found (the global
optimum for this problem, to round-off) and the validator accepts the polyline; ``infeasible``
when the start or goal lies within ``r`` of an obstacle or of the bounds, or the goal is
unreachable (proven: the tangent graph contains a path whenever one exists).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.geometry.tangent import problem_shortest_path
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status, notify
from optplan.solver import Backend, option

__all__ = ["VisGraph", "shortest_length"]

#: ``graph`` option -> ``problem_shortest_path``'s ``build`` (None: decided by the map).
_BUILD = {"auto": None, "lazy": False, "built": True}


def shortest_length(problem: Problem, robot: Robot, known_only: bool = True) -> float | None:
    """Exact length of the certified shortest path of ``robot`` (None if there is none)."""
    res = problem_shortest_path(problem, robot, known_only)
    return res.length if res.info.get("certified") else None


@dataclass(frozen=True, kw_only=True)
class VisGraph(Backend):
    """Exact Euclidean shortest path of a disc robot among true polygons and circles.

    Parameters
    ----------
    see_temporary : bool
        Also avoid temporary (``known = false``) obstacles.  Default ``False``: plan on the map
        a global planner knows (paper §V), like the PSO planners.
    arc_step : float
        Largest angle (rad, in [1e-4, pi/2]) spanned by one chord of the circumscribed polyline
        that replaces each arc of the exact path.  Smaller: a returned polyline closer to the
        exact length.  Default ``pi / 36`` (5 degrees; the polyline is at most ~0.03 % longer
        than the arcs it replaces).
    graph : str
        ``"auto"`` (default): the map's graph is built whole on its first query and searched
        compiled on maps of ``SIGHTLINES_MIN`` (1000) circles or more (where the sight lines
        make the build cheap and a lazy query is slow: ``benchmarks/bench_maps_scale.py``),
        unless its circles crowd together (the build's sight lines run past
        ``VIEWS_PER_CIRCLE`` (1000) views per circle plus ``VIEWS_BASE`` (10 million): a
        polygon of 20,000 vertices round a small circle runs about 9,000 per circle:
        ``benchmarks/bench_crowded.py``); smaller or crowded maps are searched lazily.
        ``"lazy"``: the graph grows as the lazy A* reaches it.  ``"built"``: always built
        first
        (:meth:`~optplan.geometry.tangent.tangent_graph.TangentGraph.build`; not interrupted
        by a time limit between its phases' polls).  Every problem with the same static map
        and radius shares one graph per process (:mod:`optplan.problem.shared`: at most 8
        maps and 1 GiB of graphs, least recently used dropped), so only the first query on a
        map pays for it.  The two searches give the same path and the same bits (one
        function makes a path's length and polyline) except where shortest paths tie; the
        choice depends on the map only, never on earlier queries.
    """

    name: ClassVar[str] = "visgraph"
    certifies: ClassVar[bool] = True
    see_temporary: bool = option(False)
    arc_step: float = option(math.pi / 36, lo=1e-4, hi=math.pi / 2)
    graph: str = option("auto", choices=("auto", "lazy", "built"))

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        t0 = time.perf_counter()
        known_only = not self.see_temporary
        paths, infos, exact = {}, {}, {}
        status, msgs = Status.optimal, []
        stopped = False
        for k, r in enumerate(problem.planned_robots):
            if stopped:
                paths[r.id] = np.vstack([r.start, r.start])
                status = Status.approximate
                continue
            def poll(k=k, r=r) -> bool:  # the callback during a long search (time limits)
                return notify(callback, Progress(iteration=k, best_cost=math.inf, n_eval=k,
                                                 elapsed=time.perf_counter() - t0,
                                                 info={"robot": r.id, "phase": "search"}))

            res = problem_shortest_path(problem, r, known_only, float(self.arc_step),
                                        stop=poll if callback is not None else None,
                                        build=_BUILD[self.graph])
            if res.info.get("stopped"):
                stopped = True
                status = Status.approximate
                msgs.append(f"{r.id}: stopped during the search")
                paths[r.id] = np.vstack([r.start, r.start])
                continue
            # one phase per planned robot: the callback sees it (and may stop the run)
            stopped = notify(callback, Progress(iteration=k + 1, best_cost=res.length,
                                                n_eval=k + 1,
                                                elapsed=time.perf_counter() - t0,
                                                info={"robot": r.id, **res.info}))
            infos[r.id] = dict(res.info)
            if res.polyline is None:
                status = Status.infeasible
                msgs.append(f"{r.id}: {res.info.get('reason', 'no path')}")
                paths[r.id] = np.vstack([r.start, r.start])
                continue
            paths[r.id] = res.polyline
            exact[r.id] = res.length
        lead = problem.leader.id if problem.leader.id in paths else next(iter(paths))
        extra = {}
        if lead in exact:
            extra["length_exact"] = exact[lead]
            if infos[lead].get("certified"):
                extra["optimum"] = exact[lead]
        extra["lengths_exact"] = exact
        hist = History()
        hist.append(iteration=0, best_cost=exact.get(lead, np.nan), n_eval=1,
                    time=time.perf_counter() - t0)
        return self.finish(
            problem, paths, claim=status, cost=exact.get(lead, np.inf),
            message="; ".join(msgs) or "arc-exact shortest path on the tangent visibility "
                                       "graph (certified)",
            n_iter=1, n_eval=1, history=hist, extras={"graph": infos}, metrics_extra=extra,
            wall_time=time.perf_counter() - t0,
        )
