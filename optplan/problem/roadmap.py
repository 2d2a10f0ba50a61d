"""A roadmap that confines the robots of a problem: :class:`RoadmapGraph`.

Continuous-time multi-agent path finding (``ccbs``) plans disc robots on a given graph: they
drive along its edges, straight segments between the nodes' coordinates, at their full speed,
and wait at its nodes for any duration.  A :class:`~optplan.problem.Problem` that carries a
roadmap (``problem.roadmap``) has every robot's start and goal on one of its nodes; planners
that know the model (``ccbs``) keep to it, the others move in the plane, and the validator
checks every plan in the plane alike (static map, moving obstacles, the other robots, in
continuous time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["RoadmapGraph"]


@dataclass(frozen=True, eq=False)
class RoadmapGraph:
    """An undirected graph in the plane whose edges are straight segments.

    Attributes
    ----------
    nodes : numpy.ndarray
        Node coordinates, shape ``(n, 2)``, finite, map units; no two nodes coincide.
    edges : numpy.ndarray
        Edges as node-index pairs, shape ``(m, 2)`` int, each ``i < j``, no repeats, no
        self-loops (sorted by ``(i, j)``).  An edge is driven in either direction; its length
        is the Euclidean distance of its nodes.

    Raises
    ------
    ValueError
        If the arrays have the wrong shape, a coordinate is not finite, an index is out of
        range, an edge is a self-loop, or two nodes coincide (the message names which).
    """

    nodes: np.ndarray
    edges: np.ndarray
    _adj: list = field(default_factory=list, repr=False, compare=False)

    def __post_init__(self) -> None:
        nodes = _checked_nodes(self.nodes)
        e = _checked_edges(self.edges, len(nodes))
        nodes.setflags(write=False)
        e.setflags(write=False)
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "edges", e)
        adj: list[list[int]] = [[] for _ in range(len(nodes))]
        for i, j in e.tolist():
            adj[i].append(j)
            adj[j].append(i)
        object.__setattr__(self, "_adj", [np.asarray(sorted(a), dtype=np.int64) for a in adj])

    def __len__(self) -> int:
        return len(self.nodes)

    @property
    def lengths(self) -> np.ndarray:
        """The edges' lengths, shape ``(m,)``."""
        d = self.nodes[self.edges[:, 1]] - self.nodes[self.edges[:, 0]]
        return np.hypot(d[:, 0], d[:, 1])

    def neighbours(self, v: int) -> np.ndarray:
        """The nodes joined to node ``v`` by an edge, ascending."""
        return self._adj[v]

    def node_at(self, point, tol: float) -> int | None:
        """The node within ``tol`` of ``point`` (the nearest), else ``None``."""
        d = np.hypot(*(self.nodes - np.asarray(point, float)).T)
        k = int(np.argmin(d)) if len(d) else -1
        return k if k >= 0 and d[k] <= tol else None

    def transformed(self, scale: float = 1.0, shift=(0.0, 0.0)) -> RoadmapGraph:
        """The graph with its nodes mapped by ``x -> scale * x + shift``."""
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f"roadmap transform: scale must be finite and > 0, got {scale!r}")
        return RoadmapGraph(self.nodes * scale + np.asarray(shift, float), self.edges.copy())


def _checked_nodes(raw) -> np.ndarray:
    """The nodes as a float ``(n, 2)`` array, checked (class docstring)."""
    if np.ndim(raw) != 2 or np.shape(raw)[1:] != (2,):
        raise ValueError(f"roadmap nodes: expected shape (n, 2), got {np.shape(raw)}")
    nodes = np.array(raw, dtype=float)
    if not np.isfinite(nodes).all():
        raise ValueError(f"roadmap node {int(np.argwhere(~np.isfinite(nodes))[0, 0])}: "
                         "coordinates must be finite")
    _, first, count = np.unique(nodes, axis=0, return_index=True, return_counts=True)
    if (count > 1).any():
        at = nodes[first[np.argmax(count > 1)]]
        twins = np.flatnonzero((nodes == at).all(axis=1))
        raise ValueError(f"roadmap nodes {twins.tolist()} coincide at {at.tolist()}")
    return nodes


def _checked_edges(raw, n: int) -> np.ndarray:
    """The edges as a sorted, unique int ``(m, 2)`` array of ``i < j``, checked."""
    raw = np.asarray(raw)
    if raw.size and (raw.ndim != 2 or raw.shape[1] != 2):
        raise ValueError(f"roadmap edges: expected shape (m, 2), got {raw.shape}")
    if raw.size and not np.issubdtype(raw.dtype, np.integer):
        raise ValueError(f"roadmap edges: node indices must be integers, got {raw.dtype}")
    e = raw.astype(np.int64).reshape(-1, 2)
    bad = np.flatnonzero((e < 0).any(axis=1) | (e >= n).any(axis=1))
    if bad.size:
        raise ValueError(f"roadmap edge {int(bad[0])} {e[bad[0]].tolist()}: node index "
                         f"outside [0, {n - 1}]")
    loops = np.flatnonzero(e[:, 0] == e[:, 1])
    if loops.size:
        raise ValueError(f"roadmap edge {int(loops[0])}: a self-loop at node "
                         f"{int(e[loops[0], 0])}")
    return np.unique(np.sort(e, axis=1), axis=0)
