r"""The built tangent graph as one explicit graph: tangent points chained along their circles.

After :meth:`~optplan.geometry.tangent.tangent_graph.TangentGraph.build` every free tangent of the
map is known.  :class:`ChainGraph` turns them into a graph whose shortest paths are the map's
shortest paths, searched by the compiled A* of :mod:`optplan.geometry.tangent.chain_search`:

* **Nodes**: the departure points of the free tangents (``E`` of them, on circle ``i`` with
  sense ``s_i``), numbered chain by chain so that a chain's nodes are neighbours in memory.
* **Chains**: on each circle and sense, the departures sorted by their position along the
  travel direction (the cone offset, counted in the sense of travel; all the way round and
  back to the first for a circle obstacle); each leads to the next one, along the arc
  between them, of length ``rho * sweep``, when the exact arc test
  (:class:`~optplan.geometry.tangent.circles.ArcChecker`) finds that arc free.
* **Tangent edges**: a departure leads to the *entry* of its tangent's arrival point: the
  first departure of the arrival's chain at or after it, of length ``seg + rho * sweep``
  (the tangent, then the arc to the entry, tested exactly).  Arrival points are not nodes:
  from an arrival a path can only go on along its circle, and the first place where it can
  leave is the entry.

A path that arrives at angle ``a`` and leaves at angle ``d`` of the same circle goes to the
entry of ``a`` and along the chain to ``d``: the arc ``a -> d`` is free exactly when each of
its pieces is, so no path is lost and every edge is the exact length of a free piece of path.
The tangent search's rules carry over: a departure up to ``ANGLE_TOL`` behind an arrival
counts as reached with no sweep, and an arrival never continues to a departure behind it, so
a path through a vertex stays on the side of its cone (the bitangent condition).  For a point
robot (``rho = 0``) the arcs cost nothing and need no test.

A query adds its start, goal and their tangents to this graph
(:mod:`optplan.geometry.tangent.chain_search`); the arrays here do not change.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.geometry.tangent.circles import ANGLE_TOL, TWO_PI, Circles
from optplan.geometry.tangent.tangent_edges import cone_off

__all__ = ["ChainGraph", "arcs_free", "chain_key", "chains_of", "entry_of", "first_above",
           "dense_rank", "stable_argsort"]


def chain_key(C: Circles, c: np.ndarray, s: np.ndarray, off: np.ndarray) -> np.ndarray:
    """Position of the points at cone offsets ``off`` on circles ``c`` along the travel
    direction ``s``: ``off`` counter-clockwise, ``width - off`` clockwise on a vertex circle,
    ``-off mod 2 pi`` clockwise on a circle obstacle (all in ``[0, width]`` or ``[0, 2 pi)``)."""
    full = C.full[c]
    back = np.where(full, np.mod(-off, TWO_PI), C.width[c] - off)
    key = np.where(s > 0, off, back)
    return np.where(full & (key > TWO_PI - ANGLE_TOL), 0.0, key)


def stable_argsort(k: np.ndarray) -> np.ndarray:
    """``np.argsort(k, kind="stable")`` of non-negative int64 keys, as one quicksort of the
    distinct keys ``k n + index`` where they fit in int64 (a third of the time of numpy's
    stable sort of 741,092 keys)."""
    n = len(k)
    if n == 0 or int(k.max()) >= 2**62 // n:
        return np.argsort(k, kind="stable")
    return np.argsort(k * n + np.arange(n))


def dense_rank(x: np.ndarray) -> np.ndarray:
    """Per item, the number of distinct values below it (equal values, equal ranks)."""
    o = np.argsort(x)
    xs = x[o]
    run = np.ones(len(x), np.int64)
    run[0:1] = 0
    run[1:] = xs[1:] != xs[:-1]
    rank = np.empty(len(x), np.int64)
    rank[o] = np.cumsum(run)
    return rank


def first_above(uptr: np.ndarray, key: np.ndarray, u: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Per item: the first node of chain ``u`` (nodes ``uptr[u] .. uptr[u + 1] - 1``, keys
    ascending) whose key is above ``x``, ``uptr[u + 1]`` when none (a vectorised binary
    search within each chain)."""
    lo = uptr[u].copy()
    hi = uptr[u + 1].copy()
    while True:
        act = np.flatnonzero(lo < hi)
        if len(act) == 0:
            return lo
        mid = (lo[act] + hi[act]) // 2
        above = key[mid] > x[act]
        hi[act[above]] = mid[above]
        lo[act[~above]] = mid[~above] + 1


@dataclass(frozen=True)
class ChainGraph:
    """The explicit graph of a built :class:`~optplan.geometry.tangent.tangent_graph.TangentGraph`.

    Attributes
    ----------
    n_edges : int
        ``E``, the free tangents.  Node ``x`` (``0 <= x < E``) is the departure point of
        tangent ``x``; nodes are numbered chain by chain (chain ``u = 2 circle + (sense < 0)``
        is nodes ``uptr[u] .. uptr[u + 1] - 1``, sorted by key).
    circle, sense, theta, key, point : ndarrays ``(E,)``
        The departure's circle, sense of travel, angle on its circle, position along the
        travel direction (:func:`chain_key`) and point (local frame).
    nxt, sweep, ncost : ndarrays ``(E,)``
        The next departure of its chain (``-1``: none, or the arc to it is blocked), the
        angle that arc sweeps and its length.
    a_circle, a_sense, a_theta, a_key : ndarrays ``(E,)``
        The arrival point of tangent ``x`` (the same attributes but its point).
    seg : ndarray ``(E,)``
        Tangent lengths.
    a_pos : ndarray ``(E,)``
        The arrival's *entry*: the first departure of its chain at or after it (``ANGLE_TOL``
        of slack), ``uptr[u + 1]`` when none; ``a_sweep`` the arc to it.
    tgt, tcost : ndarrays ``(E,)``
        The edge of tangent ``x``: to its arrival's entry (``-1``: none, or that arc is
        blocked), of length ``seg + rho * a_sweep``.
    a_order, a_group : ndarrays ``(E,)``
        The arrivals sorted by the gap between departures they lie in (``a_group`` =
        ``u (E + 1) + a_pos``, ascending): the arrivals that reach a goal's departure
        without passing a departure (:mod:`~optplan.geometry.tangent.chain_search`).
    arc_tests : int
        Exact arc tests run to make the chains.
    """

    n_edges: int
    circle: np.ndarray
    sense: np.ndarray
    theta: np.ndarray
    key: np.ndarray
    point: np.ndarray
    nxt: np.ndarray
    sweep: np.ndarray
    ncost: np.ndarray
    uptr: np.ndarray
    a_circle: np.ndarray
    a_sense: np.ndarray
    a_theta: np.ndarray
    a_key: np.ndarray
    seg: np.ndarray
    a_pos: np.ndarray
    a_sweep: np.ndarray
    tgt: np.ndarray
    tcost: np.ndarray
    a_order: np.ndarray
    a_group: np.ndarray
    arc_tests: int

    @property
    def nbytes(self) -> int:
        """Memory held by the arrays (bytes)."""
        return sum(getattr(self, k).nbytes for k in self.__dataclass_fields__
                   if isinstance(getattr(self, k), np.ndarray))


def arcs_free(arcs: Any, C: Circles, src: np.ndarray, th: np.ndarray, sweep: np.ndarray,
               sense: np.ndarray) -> tuple[np.ndarray, int]:
    """Exact tests of the arcs on circles ``src`` from ``th`` over ``sweep`` in ``sense``
    (only those with ``rho > 0`` and ``sweep > 0`` are tested); (free, tests run)."""
    free = np.ones(len(src), bool)
    todo = np.flatnonzero((C.rho[src] > 0) & (sweep > 0))
    if len(todo):
        free[todo] = arcs.free_many(src[todo], th[todo], sweep[todo], sense[todo])
    return free, len(todo)


def chains_of(C: Circles, t: dict[str, np.ndarray], arcs: Any) -> ChainGraph:
    """:class:`ChainGraph` of the free tangents ``t`` (arrays as
    :func:`~optplan.geometry.tangent.tangent_edges.tangent_edges` gives them, every one free) on
    circles ``C``; ``arcs`` the graph's :class:`~optplan.geometry.tangent.circles.ArcChecker`.
    ``t``'s arrays are replaced (sorted) in place, so that the unsorted ones are freed."""
    E = len(t["j"])
    key = chain_key(C, t["i"], t["si"], t["od"])
    u = 2 * t["i"] + (t["si"] < 0)
    # departures by chain and position: np.lexsort((key, u)) (the same stable order), as
    # one sort of exact integer keys (chain, rank of the position), about a third of its time
    order = stable_argsort(u * E + dense_rank(key))
    names = list(t)
    with ThreadPoolExecutor(2) as pool:  # the permutations in two threads
        for k, v in zip(names, pool.map(lambda k: t[k][order], names)):
            t[k] = v
    key, u = key[order], u[order]
    uptr = np.searchsorted(u, np.arange(2 * C.n + 1))
    nxt = np.full(E, -1, np.int64)
    sweep = np.zeros(E)
    same = np.flatnonzero(u[:-1] == u[1:])
    nxt[same] = same + 1
    sweep[same] = np.maximum(key[same + 1] - key[same], 0.0)
    # a circle obstacle's chain goes round: its last departure leads to its first
    lo, hi = uptr[:-1], uptr[1:]
    ring = np.flatnonzero((hi - lo >= 2) & C.full[np.arange(2 * C.n) // 2])
    nxt[hi[ring] - 1] = lo[ring]
    sweep[hi[ring] - 1] = key[lo[ring]] + TWO_PI - key[hi[ring] - 1]
    has = np.flatnonzero(nxt >= 0)
    free, n_arc = arcs_free(arcs, C, t["i"][has], t["th_d"][has], sweep[has], t["si"][has])
    nxt[has[~free]] = -1
    # arrivals: the entry (first departure at or after), the arc to it
    a_key = chain_key(C, t["j"], t["sj"], cone_off(C, t["j"], t["th_a"]))
    au = 2 * t["j"] + (t["sj"] < 0)
    half = E // 2  # two threads (numpy's indexing and comparisons release the GIL)
    with ThreadPoolExecutor(2) as pool:
        a_pos = np.concatenate(list(pool.map(
            lambda k: first_above(uptr, key, au[k], a_key[k] - ANGLE_TOL),
            [slice(0, half), slice(half, None)])))
    entry, a_sweep = entry_of(C, uptr, key, t["j"], au, a_key, a_pos)
    has = np.flatnonzero(entry >= 0)
    free, n_entry = arcs_free(arcs, C, t["j"][has], t["th_a"][has], a_sweep[has],
                               t["sj"][has])
    entry[has[~free]] = -1
    a_group = au * (E + 1) + a_pos
    a_order = stable_argsort(a_group)
    return ChainGraph(E, t["i"], t["si"], t["th_d"], key, t["pi"], nxt, sweep,
                      C.rho[t["i"]] * sweep, uptr, t["j"], t["sj"], t["th_a"], a_key, t["seg"],
                      a_pos, a_sweep, entry, t["seg"] + C.rho[t["j"]] * a_sweep,
                      a_order, a_group[a_order], n_arc + n_entry)


def entry_of(C: Circles, uptr: np.ndarray, key: np.ndarray, c: np.ndarray, u: np.ndarray,
             k: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Entries of points at keys ``k`` on circles ``c`` (chains ``u``; ``pos`` from
    :func:`first_above` with ``k - ANGLE_TOL``): the first departure at or after each
    (round to the chain's first on a circle obstacle; ``-1``: none) and the angle swept."""
    lo, hi = uptr[u], uptr[u + 1]
    wrap = (pos >= hi) & C.full[c] & (hi > lo)
    entry = np.where(pos < hi, pos, np.where(wrap, lo, -1))
    e = np.maximum(entry, 0)
    sw = key[e] + np.where(wrap, TWO_PI, 0.0) - k if len(key) else np.zeros(len(k))
    return entry, np.where(entry >= 0, np.maximum(sw, 0.0), 0.0)
