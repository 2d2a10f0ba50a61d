r"""The built tangent graph as one explicit graph: tangent points chained along their circles.

After :meth:`~optplan.geometry.tangent_graph.TangentGraph.build` every free tangent of the map
is known.  :class:`ChainGraph` turns them into a graph whose shortest paths are the map's shortest
paths, searched by the compiled A* of :mod:`optplan.geometry.chain_search`:

* **Nodes**: the two end points of every free tangent (``E`` of them): its departure (on
  circle ``i`` with sense ``s_i``) and its arrival (on circle ``j`` with sense ``s_j``),
  numbered chain by chain so that a chain's nodes are neighbours in memory.
* **Tangent edges**: a departure to its arrival, of the tangent's length.
* **Chain edges**: on each circle and sense, the nodes sorted by their position along the
  travel direction (the cone offset, counted in the sense of travel; all the way round and
  back to the first for a circle obstacle); each node leads to the next one, along the arc
  between them, of length ``rho * sweep``, when the exact arc test
  (:class:`~optplan.geometry.circles.ArcChecker`) finds that arc free.  A path that arrives
  at angle ``a`` and leaves at angle ``d`` of the same circle follows the chain from ``a`` to
  ``d``: the arc ``a -> d`` is free exactly when each of its pieces is.

The tangent search's rules carry over: a departure up to ``ANGLE_TOL`` behind an arrival
counts as reached with no sweep (the arrival sorts ``ANGLE_TOL`` earlier than its angle), and
an arrival never continues to a departure behind it, so a path through a vertex stays on the
side of its cone (the bitangent condition).  For a point robot (``rho = 0``) the chain edges
cost nothing and need no arc test.

A query adds its start, goal and their tangents to this graph
(:mod:`optplan.geometry.chain_search`); the arrays here do not change.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.geometry.circles import ANGLE_TOL, TWO_PI, Circles
from optplan.geometry.tangent_edges import cone_off

__all__ = ["ChainGraph", "chain_key", "chains_of"]


def chain_key(C: Circles, c: np.ndarray, s: np.ndarray, off: np.ndarray) -> np.ndarray:
    """Position of the points at cone offsets ``off`` on circles ``c`` along the travel
    direction ``s``: ``off`` counter-clockwise, ``width - off`` clockwise on a vertex circle,
    ``-off mod 2 pi`` clockwise on a circle obstacle (all in ``[0, width]`` or ``[0, 2 pi)``)."""
    full = C.full[c]
    back = np.where(full, np.mod(-off, TWO_PI), C.width[c] - off)
    key = np.where(s > 0, off, back)
    return np.where(full & (key > TWO_PI - ANGLE_TOL), 0.0, key)


@dataclass(frozen=True)
class ChainGraph:
    """The explicit graph of a built :class:`~optplan.geometry.tangent_graph.TangentGraph`.

    Attributes
    ----------
    n_edges : int
        ``E``, the free tangents; their ``2E`` end points are the nodes, numbered in chain
        order (chain ``u = 2 circle + (sense < 0)`` is nodes ``uptr[u] .. uptr[u + 1] - 1``,
        sorted by position).
    tgt, tcost : ndarrays ``(2E,)``
        A departure's arrival (``-1`` for an arrival) and the tangent's length.
    circle, sense : ndarrays ``(2E,)``
        The node's circle and sense of travel.
    theta, key : ndarrays ``(2E,)``
        The node's angle on its circle and its position along the travel direction
        (:func:`chain_key`).
    point : complex ndarray ``(2E,)``
        The node's point (local frame).
    nxt, sweep, ncost : ndarrays ``(2E,)``
        The next node of its chain (``-1``: none, or the arc to it is blocked), the angle the
        arc to it sweeps and its length.
    sort_key, uptr : ndarrays
        The nodes' sort keys (the key, ``ANGLE_TOL`` earlier for an arrival; ascending
        within a chain) and the chains' first nodes.
    arc_tests : int
        Exact arc tests run to make the chains.
    """

    n_edges: int
    tgt: np.ndarray
    tcost: np.ndarray
    circle: np.ndarray
    sense: np.ndarray
    theta: np.ndarray
    key: np.ndarray
    point: np.ndarray
    nxt: np.ndarray
    sweep: np.ndarray
    ncost: np.ndarray
    sort_key: np.ndarray
    uptr: np.ndarray
    arc_tests: int

    @property
    def nbytes(self) -> int:
        """Memory held by the arrays (bytes)."""
        return sum(getattr(self, k).nbytes for k in self.__dataclass_fields__
                   if isinstance(getattr(self, k), np.ndarray))


def _tangents(C: Circles, edges: dict) -> dict[str, np.ndarray]:
    """The stored tangents of every circle and sense, concatenated."""
    items = [(i, si, e) for (i, si), e in edges.items() if len(e.j)]
    if not items:
        z = np.zeros(0)
        return {"i": z.astype(np.int64), "si": z.astype(np.int64), "j": z.astype(np.int64),
                "sj": z.astype(np.int64), "seg": z, "pi": z.astype(complex),
                "pj": z.astype(complex), "th_d": z, "th_a": z, "od": z}
    cnt = np.array([len(e.j) for _, _, e in items])
    return {
        "i": np.repeat([i for i, _, _ in items], cnt),
        "si": np.repeat([si for _, si, _ in items], cnt),
        "j": np.concatenate([e.j for _, _, e in items]).astype(np.int64),
        "sj": np.concatenate([e.sj for _, _, e in items]).astype(np.int64),
        "seg": np.concatenate([e.seg for _, _, e in items]),
        "pi": np.concatenate([e.pi if e.pi is not None else np.full(len(e.j), C.center[i])
                              for i, _, e in items]),
        "pj": np.concatenate([e.pj for _, _, e in items]),
        "th_d": np.concatenate([e.th_d for _, _, e in items]),
        "th_a": np.concatenate([e.th_a for _, _, e in items]),
        "od": np.concatenate([e.od for _, _, e in items]),
    }


def _arcs_free(arcs: Any, C: Circles, src: np.ndarray, th: np.ndarray, sweep: np.ndarray,
               sense: np.ndarray) -> tuple[np.ndarray, int]:
    """Exact tests of the arcs on circles ``src`` from ``th`` over ``sweep`` in ``sense``
    (only those with ``rho > 0`` and ``sweep > 0`` are tested); (free, tests run)."""
    free = np.ones(len(src), bool)
    todo = np.flatnonzero((C.rho[src] > 0) & (sweep > 0))
    if len(todo) == 0:
        return free, 0
    u = 2 * src[todo] + (sense[todo] < 0)
    order = todo[np.argsort(u, kind="stable")]
    us = 2 * src[order] + (sense[order] < 0)
    cuts = np.flatnonzero(np.diff(us)) + 1
    for grp in np.split(order, cuts):
        k = grp[0]
        free[grp] = arcs.free(int(src[k]), th[grp], sweep[grp], int(sense[k]))
    return free, len(todo)


def chains_of(C: Circles, edges: dict, arcs: Any) -> ChainGraph:
    """:class:`ChainGraph` of the free tangents ``edges`` (``(circle, sense) -> Edges``, every
    one free) on circles ``C``; ``arcs`` the graph's
    :class:`~optplan.geometry.circles.ArcChecker`."""
    t = _tangents(C, edges)
    E = len(t["j"])
    circle = np.concatenate([t["i"], t["j"]])
    sense = np.concatenate([t["si"], t["sj"]])
    off = np.concatenate([t["od"], cone_off(C, t["j"], t["th_a"])])
    key = chain_key(C, circle, sense, off)
    arrival = np.r_[np.zeros(E, bool), np.ones(E, bool)]
    sort_key = key - ANGLE_TOL * arrival
    u = 2 * circle + (sense < 0)
    order = np.lexsort((~arrival, sort_key, u))
    us = u[order]
    uptr = np.searchsorted(us, np.arange(2 * C.n + 1))
    nxt = np.full(2 * E, -1, np.int64)
    sweep = np.zeros(2 * E)
    same = np.flatnonzero(us[:-1] == us[1:])
    a, b = order[same], order[same + 1]
    nxt[a] = b
    sweep[a] = np.maximum(key[b] - key[a], 0.0)
    # a circle obstacle's chain goes round: its last node leads to its first
    lo, hi = uptr[:-1], uptr[1:]
    ring = np.flatnonzero((hi - lo >= 2) & C.full[np.arange(2 * C.n) // 2])
    a, b = order[hi[ring] - 1], order[lo[ring]]
    nxt[a] = b
    sweep[a] = key[b] + TWO_PI - key[a]
    has = np.flatnonzero(nxt >= 0)
    theta = np.concatenate([t["th_d"], t["th_a"]])
    free, n_arc = _arcs_free(arcs, C, circle[has], theta[has], sweep[has], sense[has])
    nxt[has[~free]] = -1
    # number the nodes in chain order (a chain's nodes are neighbours in memory)
    rank = np.empty(2 * E, np.int64)
    rank[order] = np.arange(2 * E)
    tgt = np.full(2 * E, -1, np.int64)
    tgt[rank[:E]] = rank[E:]
    tcost = np.zeros(2 * E)
    tcost[rank[:E]] = t["seg"]
    nx = nxt[order]
    nx[nx >= 0] = rank[nx[nx >= 0]]
    point = np.concatenate([t["pi"], t["pj"]])
    return ChainGraph(E, tgt, tcost, circle[order], sense[order], theta[order], key[order],
                      point[order], nx, sweep[order], (C.rho[circle] * sweep)[order],
                      sort_key[order], uptr, n_arc)
