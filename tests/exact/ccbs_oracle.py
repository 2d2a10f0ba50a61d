"""Brute-force references for ``ccbs``: a joint search on a time grid, and a dense check.

:func:`joint_grid_optimum` plans every robot at once on a graph whose edge lengths are whole
multiples of ``dt`` (speed 1): every action starts and ends on the grid ``k dt``; a joint state
is where each robot is (a node, or a step along an edge) and whether it has settled at its goal
for ever; Dijkstra over joint states, each step costing ``dt`` per robot not settled.  Its
plans are valid continuous-time plans (each step checked exactly), so its optimum is an upper
bound of the continuous optimum: ``ccbs`` can never do worse.
"""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np


def _min_distance(p0, p1, q0, q1) -> float:
    """Least distance of two centres moving linearly over one step (p0 -> p1, q0 -> q1)."""
    c = np.subtract(p0, q0)
    e = np.subtract(p1, q1) - c
    ee = float(e @ e)
    tau = 0.0 if ee == 0 else min(max(-float(c @ e) / ee, 0.0), 1.0)
    return float(np.hypot(*(c + tau * e)))


def _position(nodes, state) -> np.ndarray:
    """Where a robot is: at a node ``(v,)`` or ``k`` steps along ``u -> v`` of ``n`` steps."""
    if len(state) == 1:
        return nodes[state[0]]
    u, v, k, n = state
    return nodes[u] + (nodes[v] - nodes[u]) * (k / n)


def _moves(nbrs, steps, state, goal, done):
    """A robot's next states (and whether it settles): wait, start or go on along an edge."""
    if done:
        return [(state, True)]
    if len(state) == 4:
        u, v, k, n = state
        nxt = (v,) if k + 1 == n else (u, v, k + 1, n)
        return [(nxt, False)] + ([(nxt, True)] if nxt == (goal,) else [])
    v = state[0]
    out = [(state, False)] + ([(state, True)] if v == goal else [])
    for w in nbrs[v]:
        n = steps[(v, w)]
        nxt = (w,) if n == 1 else (v, w, 1, n)
        out.append((nxt, False))
        if nxt == (goal,):
            out.append((nxt, True))
    return out


def joint_grid_optimum(nodes, edges, starts, goals, radii, dt: float, max_time: float
                       ) -> float:
    """The least sum of arrival times of the joint grid search (module docstring), ``inf``
    when there is none up to ``max_time``."""
    nodes = np.asarray(nodes, float)
    nbrs: dict[int, list[int]] = {v: [] for v in range(len(nodes))}
    steps = {}
    for a, b in edges:
        n = round(float(np.hypot(*(nodes[b] - nodes[a]))) / dt)
        nbrs[a].append(b)
        nbrs[b].append(a)
        steps[(a, b)] = steps[(b, a)] = n
    start = tuple(((s,), s == g) for s, g in zip(starts, goals))
    best = {start: 0.0}
    seq = itertools.count()
    heap = [(0.0, next(seq), 0, start)]
    while heap:
        cost, _, t, joint = heapq.heappop(heap)
        if all(d for _, d in joint):
            return cost
        if cost > best.get(joint, math.inf) or t * dt > max_time:
            continue
        options = [_moves(nbrs, steps, s, goals[r], d) for r, (s, d) in enumerate(joint)]
        for nxt in itertools.product(*options):
            if _collide(nodes, joint, nxt, radii):
                continue
            c = cost + dt * sum(not d for _, d in joint)
            if c < best.get(nxt, math.inf):
                best[nxt] = c
                heapq.heappush(heap, (c, next(seq), t + 1, nxt))
    return math.inf


def _collide(nodes, joint, nxt, radii) -> bool:
    """Whether two robots overlap during the step ``joint -> nxt``."""
    for i, j in itertools.combinations(range(len(joint)), 2):
        d = _min_distance(_position(nodes, joint[i][0]), _position(nodes, nxt[i][0]),
                          _position(nodes, joint[j][0]), _position(nodes, nxt[j][0]))
        if d < (radii[i] + radii[j]) * (1 - 1e-9):
            return True
    return False


def sampled_separation(paths: dict[str, np.ndarray], times: np.ndarray, n: int = 4000
                       ) -> float:
    """The least pairwise centre distance minus the contact distance, over ``n`` samples per
    time step (dense sampling, independent of the closed forms)."""
    ids = list(paths)
    ts = np.unique(np.concatenate([np.linspace(a, b, 8) for a, b in zip(times[:-1], times[1:])]
                                  + [np.linspace(times[0], times[-1], n)]))
    pos = {k: np.c_[np.interp(ts, times, paths[k][:, 0]), np.interp(ts, times, paths[k][:, 1])]
           for k in ids}
    return min(float(np.min(np.hypot(*(pos[a] - pos[b]).T))) for a, b in
               itertools.combinations(ids, 2))
