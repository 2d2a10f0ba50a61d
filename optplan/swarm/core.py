"""Encoding, search space and fitness of the swarm path planners ``pso``, ``mpso``, ``ipso``
(paper §III).

Encoding
    A particle is the ``D = 2 n`` coordinates of ``n`` intermediate waypoints, interleaved
    ``[x_1, y_1, x_2, y_2, ..., x_n, y_n]``; the path is ``start -> p_1 -> ... -> p_n -> goal``
    (Cartesian encoding).  ``n`` is the option ``n_waypoints``.  :func:`decode` turns particles
    into polylines, :func:`as_particle` a path into a particle.

Fitness (eqs 31-33)
    ``fit = f_1 + f_2`` with ``f_1`` the polyline length (eq 31) and
    ``f_2 = penalty_weight * sum_i alpha_i`` (eq 32), ``alpha_i`` the number of obstacles
    the robot's disc hits along segment ``i`` (touching is not a collision).  Beyond the
    paper, ``penetration_weight * penetration`` can be added (how deep the path goes into
    obstacles, see below): it gives the swarm a gradient out of obstacles (the count alone is
    a flat landscape).

    **Default penalty weight** ``(n + 1) * diag`` (``diag`` = diagonal of the map bounds).
    Every waypoint stays inside the bounds (bounds handling, :mod:`optplan.swarm.operators`),
    so each of the ``n + 1`` segments is at most ``diag`` long and any collision-free particle
    costs at most ``(n + 1) * diag``; a colliding one costs at least
    ``|goal - start| + penalty_weight > (n + 1) * diag``.  Hence every collision-free path
    beats every colliding path: the fitness is lexicographic (feasibility first, then length)
    and gbest can never be a colliding shortcut while a feasible particle exists.

    The whole swarm is scored with one call of the collision test per evaluation,
    :meth:`optplan.geometry.ObstacleSet.crossings`: the exact disc-robot test against the raw
    obstacles (``alpha_i`` = number of obstacles closer than the robot radius to segment
    ``i``; penetration = ``r - distance`` or ``r + inside length`` per colliding convex
    piece).  It is the validator's own test (on the known obstacles), so a fitness-feasible
    path is validator-feasible as far as the known obstacles go.

Visibility tests
    :func:`segment_free` and :func:`pairs_free` test segments against ``space.clear``, the
    fitness kernel for a disc :data:`CLEAR_MARGIN` x the map diagonal larger (the roadmap,
    :mod:`optplan.swarm.roadmap`, and the refinement, :mod:`optplan.swarm.refine`, use them).

The other subjects of the family live in the modules named after them:
:mod:`optplan.swarm.operators` (velocity update, bounds handling, initial swarm),
:mod:`optplan.swarm.refine` (string pulling, corner cutting), :mod:`optplan.swarm.signatures`
(homotopy signatures), :mod:`optplan.swarm.samples` and :mod:`optplan.swarm.roadmap` (the
sparse roadmap and its corridors), :mod:`optplan.swarm.backend` (the shared driver).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from optplan.geometry.collision import obstacle_points, resample_path
from optplan.problem import Problem, Robot

if TYPE_CHECKING:
    from optplan.geometry import ObstacleSet

__all__ = [
    "SwarmSpace",
    "SwarmEval",
    "make_space",
    "default_penalty",
    "decode",
    "evaluate_swarm",
    "evaluate_paths",
    "PathBuffer",
    "as_particle",
    "segment_free",
    "pairs_free",
    "Interrupted",
    "EVAL_SEGMENTS",
]

#: Clearance kept by roadmap edges and tightened paths, as a fraction of the map diagonal
#: (1000 x the geometric tolerance ``eps``; see :class:`SwarmSpace`).
CLEAR_MARGIN = 1e-6

#: Path segments scored in one pass of the fitness kernel when the space has a deadline poll:
#: a larger batch (a huge swarm, many waypoints) is scored in passes of at most this many
#: segments with a poll between two passes, so one evaluation is never an unbounded step.
EVAL_SEGMENTS = 1 << 16


class Interrupted(Exception):
    """The deadline's poll asked to stop in the middle of an evaluation.

    ``ev`` holds the fitness of the whole batch: the rows scored before the poll, and the rest
    as never feasible (cost and length ``inf``, one crossing), so that nothing unscored can
    become a best.
    """

    def __init__(self, ev: SwarmEval):
        super().__init__("stopped during an evaluation")
        self.ev = ev


# --------------------------------------------------------------------------------------
# search space, fitness
# --------------------------------------------------------------------------------------


def default_penalty(bounds: tuple[float, float, float, float], n_waypoints: int) -> float:
    """``(n + 1) * diag``: makes every collision-free path beat every colliding one.

    With all waypoints inside the bounds a feasible path is at most ``(n + 1) * diag`` long,
    while a colliding one costs at least ``|goal - start| + penalty``.
    """
    x0, y0, x1, y1 = bounds
    return float((n_waypoints + 1) * math.hypot(x1 - x0, y1 - y0))


@dataclass(frozen=True, eq=False)
class SwarmSpace:
    """The search space of one robot: endpoints, box bounds per dimension, the fitness map.

    ``obstacles`` is the fitness kernel (None: no obstacles, every path is collision-free).
    ``clear`` is the same test for a disc :data:`CLEAR_MARGIN` x the map diagonal larger: the
    roadmap and the tightening use it, so that the paths they make keep that margin from the
    obstacles instead of touching them within the validator's tolerance (default: ``obstacles``).
    """

    start: np.ndarray
    goal: np.ndarray
    n_waypoints: int
    lo: np.ndarray
    hi: np.ndarray
    obstacles: ObstacleSet | None
    penalty_weight: float
    penetration_weight: float = 0.0
    clear: ObstacleSet | None = None
    #: The deadline's poll (True: stop), called between the passes of a large evaluation
    #: (:data:`EVAL_SEGMENTS`); ``None``: no deadline.
    poll: Callable[[], bool] | None = None

    @property
    def dim(self) -> int:
        return 2 * self.n_waypoints

    @cached_property
    def span(self) -> np.ndarray:
        """``hi - lo`` per dimension (computed once; read-only)."""
        out = self.hi - self.lo
        out.flags.writeable = False
        return out

    @cached_property
    def diag(self) -> float:
        """Diagonal of the map bounds (computed once)."""
        return float(math.hypot(*(self.hi[:2] - self.lo[:2])))

    @cached_property
    def _seg_ones(self) -> np.ndarray:
        """Ones over the ``n + 1`` segments (row sums by a matrix-vector product)."""
        return np.ones(self.n_waypoints + 1)

    @cached_property
    def signature_points(self) -> np.ndarray:
        """One reference point per kernel item (world coordinates), shape ``(K, 2)``."""
        if self.obstacles is None or self.obstacles.n_items == 0:
            return np.zeros((0, 2))
        return np.ascontiguousarray(obstacle_points(self.obstacles) + self.obstacles.frame.origin)

    @cached_property
    def signature_keys(self) -> np.ndarray:
        """Per reference point a 64-bit key (splitmix64 of its index) hashed into signatures."""
        return _splitmix_keys(len(self.signature_points))


def make_space(problem: Problem, robot: Robot, n_waypoints: int, *,
               penalty_weight: float | None = None,
               penetration_weight: float = 0.0,
               poll: Callable[[], bool] | None = None) -> SwarmSpace:
    """Build the :class:`SwarmSpace` of ``robot`` on the map ``problem`` (pass a known view).

    The fitness scores with :meth:`optplan.problem.Problem.obstacle_set` of the known static
    obstacles for the robot's radius (the exact disc-robot test, built once per problem and
    radius, cached).  ``poll``: the deadline (:attr:`SwarmSpace.poll`).
    """
    x0, y0, x1, y1 = problem.bounds
    lo = np.tile([x0, y0], n_waypoints).astype(float)
    hi = np.tile([x1, y1], n_waypoints).astype(float)
    # the bounds are the search box (bounds handling keeps every waypoint inside them), not
    # a wall of the fitness: the swarm's encoding is the paper's; the validator holds the
    # robot's disc inside the bounds (docs/geometry.md, "The bounds are a wall")
    obs = problem.obstacle_set(robot.radius, known_only=True, walls=False)
    clear = problem.obstacle_set(robot.radius + CLEAR_MARGIN * math.hypot(x1 - x0, y1 - y0),
                                 known_only=True, walls=False)
    pw = default_penalty(problem.bounds, n_waypoints) if penalty_weight is None else penalty_weight
    return SwarmSpace(np.asarray(robot.start, float), np.asarray(robot.goal, float),
                      n_waypoints, lo, hi, obs, float(pw), float(penetration_weight), clear,
                      poll)


def decode(X: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Particles ``(P, 2n)`` -> polylines ``(P, n + 2, 2)`` (start, waypoints, goal)."""
    P = X.shape[0]
    out = np.empty((P, space.n_waypoints + 2, 2))
    out[:, 0] = space.start
    out[:, 1:-1] = X.reshape(P, space.n_waypoints, 2)
    out[:, -1] = space.goal
    return out


@dataclass(frozen=True)
class SwarmEval:
    """Fitness of a batch of particles: ``cost = length + penalty*count + pen_w*penetration``."""

    cost: np.ndarray
    length: np.ndarray
    count: np.ndarray
    penetration: np.ndarray

    def take(self, idx: Any) -> SwarmEval:
        """The rows ``idx`` (slice, index array or mask)."""
        return SwarmEval(self.cost[idx], self.length[idx], self.count[idx],
                         self.penetration[idx])


def evaluate_swarm(X: np.ndarray, space: SwarmSpace) -> SwarmEval:
    """Eqs 31-33 for a whole batch: one collision-test call for all particles (in passes,
    each decoded on its own, with a deadline: :func:`evaluate_paths`)."""
    rows = max(1, EVAL_SEGMENTS // (space.n_waypoints + 1))
    if space.poll is None or len(X) <= rows:
        return evaluate_paths(decode(X, space), space)
    return _in_passes(len(X), rows, lambda a, b: _evaluate(decode(X[a:b], space), space),
                      space.poll)


def evaluate_paths(paths: np.ndarray, space: SwarmSpace) -> SwarmEval:
    """Eqs 31-33 for already decoded polylines ``(P, n + 2, 2)`` (see :class:`PathBuffer`).

    With a deadline (``space.poll``), a batch of more than :data:`EVAL_SEGMENTS` segments is
    scored in passes with a poll between two; raises :class:`Interrupted` when it asks to
    stop.
    """
    rows = max(1, EVAL_SEGMENTS // max(1, paths.shape[1] - 1))
    if space.poll is None or len(paths) <= rows:
        return _evaluate(paths, space)
    return _in_passes(len(paths), rows, lambda a, b: _evaluate(paths[a:b], space), space.poll)


def _in_passes(n: int, rows: int, score: Callable[[int, int], SwarmEval],
               poll: Callable[[], bool]) -> SwarmEval:
    """The fitness of ``n`` rows scored ``rows`` at a time by ``score(a, b)``, with ``poll``
    between two passes (raises :class:`Interrupted` when it asks to stop)."""
    parts = []
    for c in range(0, n, rows):
        parts.append(score(c, min(c + rows, n)))
        if c + rows < n and poll():
            m = n - c - rows
            parts.append(SwarmEval(np.full(m, np.inf), np.full(m, np.inf),
                                   np.ones(m, np.int64), np.zeros(m)))
            raise Interrupted(_joined(parts))
    return _joined(parts)


def _joined(parts: list[SwarmEval]) -> SwarmEval:
    """The fitness of consecutive batches as one."""
    return SwarmEval(*(np.concatenate([getattr(e, f) for e in parts])
                       for f in ("cost", "length", "count", "penetration")))


def _evaluate(paths: np.ndarray, space: SwarmSpace) -> SwarmEval:
    """Eqs 31-33 of one pass (:func:`evaluate_paths`)."""
    z = paths.view(np.complex128)[..., 0]  # points as complex numbers
    length = np.abs(z[:, 1:] - z[:, :-1]) @ space._seg_ones
    if space.obstacles is None:  # no obstacles: nothing to cross
        count, pen = np.zeros(len(paths), np.int64), np.zeros(len(paths))
    else:
        cr = space.obstacles.crossings(paths, penetration=space.penetration_weight > 0)
        count, pen = cr.count, cr.penetration
    cost = length + space.penalty_weight * count
    if space.penetration_weight:
        cost += space.penetration_weight * pen
    return SwarmEval(cost, length, count, pen)


class PathBuffer:
    """Two preallocated batches of polylines ``(rows, n + 2, 2)`` with start and goal filled in.

    ``X(i)`` is the ``(rows, 2n)`` particle view of batch ``i % 2`` (it shares memory with
    ``paths(i)``): an iteration writes its particles straight into the polylines that the
    fitness kernel reads, with no decode or concatenation.  Two batches alternate so that the
    swarm of iteration ``k`` (a view into one) is intact while iteration ``k + 1`` writes the
    other; each is allocated when first used (a run stopped before its first iteration
    allocates neither).
    """

    def __init__(self, space: SwarmSpace, rows: int) -> None:
        self._space, self._rows = space, rows
        self._paths: list[np.ndarray | None] = [None, None]  # made on first use (a large
        self._X: list[np.ndarray | None] = [None, None]  # swarm's is hundreds of MB)

    def _batch(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        b = i % 2
        p, X = self._paths[b], self._X[b]
        if p is None or X is None:
            space, rows = self._space, self._rows
            p = np.empty((rows, space.n_waypoints + 2, 2))
            p[:, 0] = space.start
            p[:, -1] = space.goal
            X = p[:, 1:-1].reshape(rows, space.dim)  # a view: each row's inner block
            if not np.shares_memory(X, p):  # pragma: no cover - numpy guarantees the view
                raise RuntimeError("PathBuffer: the particle view of the paths is a copy")
            self._paths[b], self._X[b] = p, X
        return p, X

    def paths(self, i: int) -> np.ndarray:
        return self._batch(i)[0]

    def X(self, i: int) -> np.ndarray:
        return self._batch(i)[1]


# --------------------------------------------------------------------------------------
# polylines: resampling, visibility
# --------------------------------------------------------------------------------------


def as_particle(path: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """A path as a particle: its ``n_waypoints`` interior points, clipped into the bounds."""
    w = resample_path(path, space.n_waypoints + 1)[1:-1].reshape(-1)
    return np.clip(w, space.lo, space.hi)


def segment_free(a: np.ndarray, b: np.ndarray, space: SwarmSpace) -> np.ndarray:
    """Collision-free flags of segments ``a[i] -> b[i]`` with the margin of ``space.clear``
    (:func:`pairs_free` of the stacked end points)."""
    n = len(a)
    idx = np.arange(n, dtype=np.int64)
    return pairs_free(np.concatenate([np.asarray(a, float).reshape(-1, 2),
                                      np.asarray(b, float).reshape(-1, 2)]), idx, idx + n,
                      space)


def pairs_free(points: np.ndarray, i: np.ndarray, j: np.ndarray,
               space: SwarmSpace) -> np.ndarray:
    """Collision-free flags of the segments ``points[i[q]] -> points[j[q]]`` with the margin
    of ``space.clear`` (no obstacles: all free).

    One call of :meth:`optplan.geometry.ObstacleSet.pairs_free` (the compiled
    :func:`optplan.geometry.collision.kernel.free_pairs`): the decision of
    :meth:`optplan.geometry.ObstacleSet.segment_free` (``crossings(...).count == 0``) with an
    early exit per segment; the segments are given by point indices, so a roadmap or a
    string pulling tests its vertex pairs without gathering their end points."""
    test = space.clear if space.clear is not None else space.obstacles
    if test is None:  # no obstacles: every segment is free
        return np.ones(len(i), dtype=bool)
    return test.pairs_free(points, i, j)

def _splitmix_keys(n: int) -> np.ndarray:
    """``n`` 64-bit keys (splitmix64 of 1..n as signed int64): hashing, not randomness."""
    mask = (1 << 64) - 1
    out = np.empty(n, np.int64)
    for i in range(n):
        z = ((i + 1) * 0x9E3779B97F4A7C15) & mask
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        z ^= z >> 31
        out[i] = z - (1 << 64) if z >= 1 << 63 else z
    return out
