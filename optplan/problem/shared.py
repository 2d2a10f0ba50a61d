"""The obstacle sets of one process, shared by every problem with the same static map.

:meth:`optplan.problem.Problem.obstacle_set` (the exact collision engine every solver, the
validator and the tangent graph use) is a function of the problem's static obstacles, its
bounds, the robot radius and two flags only.  Problems that share those (the lines of one
``.scen``, the copies a sweep solves, the same scenario file loaded again) share one
:class:`~optplan.geometry.ObstacleSet` through the cache here, keyed by a digest of that
geometry (:func:`map_digest`), and with it everything kept on the set: the map's
:class:`~optplan.geometry.tangent.tangent_graph.TangentGraph` (built or lazy) and its compiled
search's work arrays.  The first problem pays for the set (and the graph), the later ones
only for their queries.

Memory: at most :data:`MAX_SETS` obstacle sets are kept, and the tangent graphs on them hold
at most :data:`MAX_GRAPH_BYTES` together (their arrays, ``TangentGraph.nbytes``); past either
bound the least recently used sets are dropped from the cache (a set stays alive as long as a
problem that uses it does).  The cache belongs to the process: threads share it (a lock
guards it; one graph answers one query at a time), worker processes (``optplan bench``'s
pool, Dask's workers) each have their own.  :func:`clear` empties it.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import shapely

__all__ = ["MAX_SETS", "MAX_GRAPH_BYTES", "clear", "map_digest", "problem_digest",
           "shared_set", "stats"]

#: Obstacle sets (maps, radii) kept per process.
MAX_SETS = 8
#: Bytes the tangent graphs of the kept sets may hold together (``TangentGraph.nbytes``).
MAX_GRAPH_BYTES = 2**30

_lock = threading.RLock()
_sets: OrderedDict[tuple, Any] = OrderedDict()
_stats = {"hits": 0, "misses": 0, "dropped": 0}
#: Digests of the last obstacle tuples seen (by identity; the tuple is kept so that its id
#: is not reused): the copies of one problem (``Problem.replaced``) share their tuple.
_digests: OrderedDict[tuple, tuple[tuple, str]] = OrderedDict()
_DIGESTS = 8


def map_digest(obstacles: Iterable, bounds: tuple[float, ...]) -> str:
    """A digest of a static map: the bounds and, per obstacle in order, its kind, name,
    ``known`` flag, circle centre and radius, and polygon (its WKB: every vertex's bits)."""
    obstacles = list(obstacles)
    h = hashlib.blake2b(digest_size=20)
    h.update(np.asarray(bounds, np.float64).tobytes())
    polys = [o.geometry for o in obstacles if o.geometry is not None]
    wkb = iter(shapely.to_wkb(np.array(polys, dtype=object), hex=False)) if polys else iter(())
    for o in obstacles:
        h.update(f"{o.kind}\0{o.name}\0{bool(o.known)}\0".encode())
        if o.center is not None:
            h.update(np.asarray(o.center, np.float64).tobytes())
        if o.radius is not None:
            h.update(np.float64(o.radius).tobytes())
        if o.geometry is not None:
            w = next(wkb)
            h.update(len(w).to_bytes(8, "little"))
            h.update(w)
    return h.hexdigest()


def problem_digest(obstacles: tuple, known_only: bool, bounds: tuple[float, ...]) -> str:
    """:func:`map_digest` of the static ``obstacles`` of a problem (only the known ones with
    ``known_only``) and its ``bounds``, computed once per obstacle tuple (about 9 ms for the
    5,754 polygons of a 1024 x 1024 street map)."""
    key = (id(obstacles), bool(known_only), tuple(map(float, bounds)))
    with _lock:
        hit = _digests.get(key)
        if hit is not None and hit[0] is obstacles:
            _digests.move_to_end(key)
            return hit[1]
    d = map_digest((o for o in obstacles if o.known or not known_only), bounds)
    with _lock:
        _digests[key] = (obstacles, d)
        while len(_digests) > _DIGESTS:
            _digests.popitem(last=False)
    return d


def _graph_bytes(oset: Any) -> int:
    g = oset._cache.get("tangent_graph")
    return int(g.nbytes) if g is not None else 0


def _trim() -> None:
    """Drop the least recently used sets past :data:`MAX_SETS` or :data:`MAX_GRAPH_BYTES`
    (the most recent one stays)."""
    while len(_sets) > 1 and (len(_sets) > MAX_SETS or
                              sum(_graph_bytes(s) for s in _sets.values()) > MAX_GRAPH_BYTES):
        _sets.popitem(last=False)
        _stats["dropped"] += 1


def shared_set(key: tuple, make: Callable[[], Any]) -> Any:
    """The obstacle set under ``key`` (``(digest, radius, known_only, walls)``), made by
    ``make()`` when the process has none (under the lock: two threads never make one twice)."""
    with _lock:
        s = _sets.get(key)
        if s is not None:
            _sets.move_to_end(key)
            _stats["hits"] += 1
        else:
            s = _sets[key] = make()
            _stats["misses"] += 1
        _trim()
        return s


def stats() -> dict[str, int]:
    """``sets`` kept, ``graph_bytes`` they hold, ``hits``, ``misses``, ``dropped``."""
    with _lock:
        return {"sets": len(_sets), "graph_bytes": sum(_graph_bytes(s) for s in _sets.values()),
                **_stats}


def clear() -> None:
    """Empty the cache (the sets stay with the problems that hold them)."""
    with _lock:
        _sets.clear()
        _digests.clear()
