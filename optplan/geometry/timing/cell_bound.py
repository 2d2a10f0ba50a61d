r"""A certified lower bound on the arrival time that tightens with a level of refinement.

:func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound` (level 0) knows the static
distance and whether the goal is occupied; it says nothing about movers that block the *way*
(a door closed by a parked mover until ``t = 20``).  :func:`cell_lower_bound` adds a
relaxation in (cell, time slab) space that sees them.

**The relaxation** (level ``L``).  The robot is a disc of radius ``r``, speed ``<= v``, at its
start ``s`` at ``t = 0``.  The map's bounds (grown by ``max(0, 2 eps - r)`` so that every
centre the validator accepts lies inside) are split into ``2^L x 2^L`` closed cells, the time
window ``[0, H]`` into ``2^L`` closed slabs of length ``tau = H / 2^L``.  ``H`` does not depend
on the level: ``2 max(L*/v, last knot of a mover, diagonal/v) + the longest period``, or the
``horizon`` option.

* A cell-slab ``(C, k)`` is **blocked** when at every time of the closed slab some convex
  piece ``K`` of a mover (at ``K + c(t)``) or of a static obstacle holds every point of ``C``
  at distance ``< r - 4 eps`` from it; the validator's contact is distance ``< r - eps``
  (:mod:`optplan.geometry.collision.frame`), so a robot centred anywhere in ``C`` at such a
  time collides.  The test is exact up to the margin: ``x -> dist(x, K + c)`` is convex, so its
  maximum over the convex cell is at a corner; between two consecutive times of the slab's
  boundaries and all movers' knots, ``c(t)`` is linear, the maximum over the corners of
  ``dist(q - c(t), K)`` is a convex function of ``t`` and its maximum over the interval is at
  an end (the right value at the start, the left value at the end: a ``loop`` jump is checked
  on both sides).  An interval is covered when one piece covers it; the slab is blocked when
  each of its intervals is.  At level ``L >= 2`` a cell-slab is also blocked when its parent at
  level ``L - 1`` is (true for the parent means true for the child, see below; this makes
  monotonicity immune to round-off).
* A cell ``B`` is **usable** at time ``t`` unless every closed slab containing ``t`` is blocked
  (a boundary time belongs to two slabs); every ``t >= H`` is usable (nothing is claimed there).
* **Labels** (Dijkstra): ``tau(C) = 0`` for the cells containing ``s``; from a settled cell
  ``A`` (label ``a``) to a cell ``B`` sharing an edge or a corner with it, ``B`` gets at most
  ``push_B(max(a, d(s, B) / v))``: ``d(s, B)`` the least distance from ``s`` to the closed
  cell, ``push_B(c)`` the first time ``>= c`` at which ``B`` is usable.
* **The bound**: ``min(H, min over the cells G containing the goal of tau(G))``.

**The sweep** (the way on from a door, which the labels forget).  ``R_0`` = the cells holding
``s``; ``R_{k+1}`` = the cells usable at ``t_{k+1}`` whose centre is within
``v (t_{k+1} - t_j) + diag`` of a centre of ``R_j`` for ``j = k, k - 1, k - 3, k - 7, ...``
(one distance transform per slab).  With ``f_k = t_k + d(R_k, g) / v``, the sweep's bound is
the first ``f_k < t_{k+1}`` (else ``H``), and at level ``L`` the largest over levels
``1 .. L``; the relaxation's bound is the larger of the labels' and the sweep's.  Validity:
every cell holding ``x(t_k)`` is in ``R_k`` (centres of the cells holding ``x(t_j)`` and
``x(t_{k+1})`` are at most ``diag + v (t_{k+1} - t_j)`` apart; the cell is usable, else a
collision); an arrival ``T`` in slab ``k`` has ``T >= t_k + |g - x(t_k)| / v >= f_k``, so
``f_k < t_{k+1}`` and the first such index gives at most ``T``.

**Validity.**  Let ``x(t)``, ``0 <= t <= T``, be a motion at speed ``<= v`` from ``s`` that
never collides and ends at the goal ``x(T) = g``.  Its centre stays in the grown bounds (the
walls), so for every time it is in some cell.  For a cell ``B`` it visits, let ``t_B`` be its
first time in ``B`` (``B`` is closed and ``x`` continuous: the minimum exists).  Claim:
``tau(B) <= t_B``.  Induction on ``t_B`` (finitely many cells): if ``s`` is in ``B``,
``tau(B) = 0``.  Otherwise ``t_B > 0`` and ``x(t) not in B`` for ``t < t_B``; take times
``t_n`` rising to ``t_B``: one cell ``A != B`` holds infinitely many ``x(t_n)``, and being
closed it holds ``x(t_B)``, so ``A`` and ``B`` share a point (an edge or a corner) and
``t_A <= t_n < t_B``; by induction ``tau(A) <= t_A``.  Now ``t_B >= tau(A)``,
``t_B >= |x(t_B) - s| / v >= d(s, B) / v``, and ``B`` is usable at ``t_B`` (the robot is in
``B`` then; if every slab containing ``t_B`` were blocked it would collide), so
``push_B(max(tau(A), d(s, B) / v)) <= t_B``.  Dijkstra's labels are the least fixed point of
these relaxations (each ``a -> push_B(max(a, d))`` is non-decreasing and ``>= a``), so
``tau(B) <= t_B``.  The goal's cell ``G`` is visited by ``T``: ``tau(G) <= t_G <= T``.
Nothing past ``H`` is claimed, so ``min(H, .)`` keeps the bound.  With ``T >=`` the level-0
bound too, the maximum of both is a lower bound on every arrival.

**Monotonicity** (level ``L + 1 >=`` level ``L``).  Cells and slabs nest exactly (corners at
``x0 + w i / 2^L``, slab ends at ``H k / 2^L``: binary fractions).  (i) A blocked parent makes
its children blocked: a child slab's intervals lie in the parent's, on which the covering
piece's corner maximum is ``< r - 4 eps`` at both ends, hence everywhere, and a child cell's
corners lie in the parent cell (by construction, the parent's blocked set is also OR-ed in).
So a child is usable at ``t`` only if its parent is, and ``push_{B'} >= push_B``.  (ii)
``d(s, B') >= d(s, B)`` for a child ``B'`` of ``B``; the parents of two touching cells are
equal or touching; the cells containing ``s`` or ``g`` have parents containing them.  By
induction on the settle order of level ``L + 1``, ``tau_{L+1}(B') >= tau_L(B)``: a relaxation
from ``A'`` with parent ``A != B`` gives ``push_{B'}(max(tau_{L+1}(A'), d(s, B')/v)) >=
push_B(max(tau_L(A), d(s, B)/v)) >= tau_L(B)``; with ``A = B`` it gives at least
``tau_{L+1}(A') >= tau_L(B)``.  Hence the goal's minimum does not drop; ``H`` is the same.

**Cost.**  ``O(8^L)`` booleans for the blocked table and a Python Dijkstra over ``4^L``
cells: levels up to 6 or 7 take well under a second on small scenes; 10 is the largest
accepted (``8^10`` bytes: 1 GB).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from optplan.geometry.collision import convex_decompose
from optplan.geometry.timing.contact_times import ConvexShape, shape_pieces
from optplan.geometry.timing.motion import mover_period, mover_track, track_eval

if TYPE_CHECKING:
    from optplan.problem import Problem, Robot

__all__ = ["MAX_LEVEL", "TimeBound", "cell_lower_bound", "check_level", "cell_horizon",
           "static_time"]

#: Largest accepted refinement level (``8^10`` booleans in the blocked table).
MAX_LEVEL = 10

#: Coverage margin in units of the map's tolerance ``eps``: blocked means every point of the
#: cell is closer than ``r - MARGIN eps`` to one piece (the validator: ``< r - eps``).
MARGIN = 4.0



@dataclass(frozen=True)
class TimeBound:
    """A certified lower bound on the arrival time (s) and what it rests on (defined here, the
    lower of the two bound modules; :mod:`.time_bounds` re-exports it)."""

    value: float | None
    static_bound: float | None
    goal_bound: float | None
    reason: str


_NEIGHBOURS = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]


def check_level(level) -> int:
    """Validate a refinement level.

    Parameters
    ----------
    level : int
        ``0 <= level <= MAX_LEVEL`` (``bool`` is not an ``int`` here).

    Returns
    -------
    int

    Raises
    ------
    ValueError
        Naming ``level``, its value and the range.
    """
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)):
        raise ValueError(f"level = {level!r}: an int in [0, {MAX_LEVEL}] is required")
    if not 0 <= int(level) <= MAX_LEVEL:
        raise ValueError(f"level = {level!r} is out of range [0, {MAX_LEVEL}]")
    return int(level)


def static_time(problem: Problem, robot: Robot) -> float | None:
    """The certified shortest path length of ``robot`` among all static obstacles over its
    ``max_speed``, ``None`` without a certified optimum (cached with the problem)."""
    from optplan.geometry.tangent import problem_shortest_path

    res = problem_shortest_path(problem, robot, known_only=False)
    if res.polyline is None or not res.info.get("certified"):
        return None
    return float(res.length) / robot.max_speed


def cell_horizon(problem: Problem, static: float | None, max_speed: float) -> float:
    """The relaxation's time window ``H`` (s), the same at every level.

    Parameters
    ----------
    problem : Problem
    static : float or None
        The static bound ``L* / v`` (:func:`static_time`), ``None`` when there is none.
    max_speed : float

    Returns
    -------
    float
        ``2 max(static bound, last knot of a mover, bounds diagonal / max_speed)`` plus the
        longest period of a repeating mover.
    """
    knots = [float(np.max(d.times)) for d in problem.dynamic_obstacles]
    periods = [p for p in map(mover_period, problem.dynamic_obstacles) if p is not None]
    return (2.0 * max([static or 0.0, *knots, problem.extent / max_speed])
            + (max(periods) if periods else 0.0))


def _box(problem: Problem, radius: float) -> tuple[float, float, float, float]:
    """The bounds, grown by ``max(0, 2 eps - r)`` (every accepted centre lies inside)."""
    x0, y0, x1, y1 = (float(b) for b in problem.bounds)
    g = max(0.0, 2.0 * problem.frame.eps - radius)
    return x0 - g, y0 - g, x1 + g, y1 + g


def _corners(box: Sequence[float], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Corner coordinates of the ``n x n`` cells, relative to the box's lower-left corner
    (binary fractions of the sides: they nest exactly across levels)."""
    frac = np.arange(n + 1, dtype=float) / n
    return (box[2] - box[0]) * frac, (box[3] - box[1]) * frac


def _distance(p: np.ndarray, shape: ConvexShape) -> np.ndarray:
    """Distance from points ``p`` ``(..., 2)`` to a convex shape at the origin (0 inside)."""
    if shape.is_circle:
        return np.maximum(np.hypot(p[..., 0], p[..., 1]) - float(shape.radius or 0.0), 0.0)
    v = shape.vertices
    assert v is not None
    e = np.roll(v, -1, axis=0) - v
    rel = p[..., None, :] - v  # (..., m, 2)
    cross = e[:, 0] * rel[..., 1] - e[:, 1] * rel[..., 0]
    inside = np.all(cross >= 0.0, axis=-1)
    ee = np.einsum("mk,mk->m", e, e)
    u = np.clip(np.einsum("...mk,mk->...m", rel, e) / ee, 0.0, 1.0)
    d = np.hypot(rel[..., 0] - u * e[:, 0], rel[..., 1] - u * e[:, 1]).min(axis=-1)
    return np.where(inside, 0.0, d)


def _cell_max(dist: np.ndarray) -> np.ndarray:
    """Per cell, the largest of its four corner values: ``(n+1, n+1, ...) -> (n, n, ...)``."""
    return np.maximum(np.maximum(dist[:-1, :-1], dist[1:, :-1]),
                      np.maximum(dist[:-1, 1:], dist[1:, 1:]))


def _static_pieces(problem: Problem) -> list[tuple[ConvexShape, np.ndarray]]:
    """Convex pieces of every static obstacle (temporary ones included) with their offsets."""
    out: list[tuple[ConvexShape, np.ndarray]] = []
    for o in problem.static_obstacles(known_only=False):
        if o.is_circle:
            c, rad = o.disc()
            out.append((ConvexShape(radius=rad), np.asarray(c, float)))
        else:
            out.extend((ConvexShape(vertices=v), np.zeros(2)) for v in
                       convex_decompose(o.geometry))
    return out


class _Stop(Exception):
    """``stop`` asked: the relaxation ends (the bound is then the trivial 0)."""


def _poll(stop: Callable[[], bool] | None) -> None:
    """Raise :class:`_Stop` when ``stop`` asks."""
    if stop is not None and stop():
        raise _Stop


def _blocked_level(problem: Problem, radius: float, box: Sequence[float], horizon: float,
                   level: int, stop: Callable[[], bool] | None = None) -> np.ndarray:
    """The blocked table ``(n, n, n)`` (cell x, cell y, slab) of one level, without parents;
    ``stop`` is polled per obstacle piece and per 64 time intervals."""
    n = 2 ** level
    reach = radius - MARGIN * problem.frame.eps
    out = np.zeros((n, n, n), bool)
    if reach <= 0.0:
        return out
    xs, ys = _corners(box, n)
    origin = np.array([box[0], box[1]], float)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)  # (n+1, n+1, 2)
    for shape, at in _static_pieces(problem):
        _poll(stop)
        out |= (_cell_max(_distance(grid - (at - origin), shape)) < reach)[:, :, None]
    if not problem.dynamic_obstacles:
        return out
    ends = horizon * (np.arange(n + 1, dtype=float) / n)
    tracks = [mover_track(d, 0.0, horizon) for d in problem.dynamic_obstacles]
    knots = np.concatenate([tk for tk, _ in tracks])
    cuts = np.unique(np.concatenate([ends, knots[(knots > 0.0) & (knots < horizon)]]))
    first = np.searchsorted(cuts, ends[:-1])  # the first interval of each slab
    covered = np.zeros((n, n, len(cuts) - 1), bool)
    for d, (tk, pk) in zip(problem.dynamic_obstacles, tracks):
        a = track_eval(tk, pk, cuts[:-1], "right") - origin
        b = track_eval(tk, pk, cuts[1:], "left") - origin
        for shape in shape_pieces(d.kind, d.radius, d.local_geometry):
            for c in range(0, len(a), 64):
                _poll(stop)
                da = _cell_max(_distance(grid[:, :, None, :] - a[c:c + 64], shape))
                db = _cell_max(_distance(grid[:, :, None, :] - b[c:c + 64], shape))
                covered[:, :, c:c + 64] |= (da < reach) & (db < reach)
    return out | np.logical_and.reduceat(covered, first, axis=2)


def _blocked(problem: Problem, radius: float, box: Sequence[float], horizon: float,
             level: int, stop: Callable[[], bool] | None = None) -> list[np.ndarray]:
    """The blocked tables of levels ``1 .. level``, each OR-ed with its parent's."""
    tables = [_blocked_level(problem, radius, box, horizon, 1, stop)]
    for lv in range(2, level + 1):
        up = tables[-1].repeat(2, axis=0).repeat(2, axis=1).repeat(2, axis=2)
        tables.append(up | _blocked_level(problem, radius, box, horizon, lv, stop))
    return tables


def _push(row: np.ndarray, ends: np.ndarray, c: float) -> float:
    """The first time ``>= c`` at which a cell with blocked slabs ``row`` is usable."""
    horizon = float(ends[-1])
    if c >= horizon:
        return c
    k = int(np.searchsorted(ends, c, side="right")) - 1
    if not row[k] or (c == ends[k] and k > 0 and not row[k - 1]):
        return c
    free = np.flatnonzero(~row[k + 1:])
    return float(ends[k + 1 + int(free[0])]) if len(free) else horizon


def _span(lo: np.ndarray, p: float) -> list[int]:
    """Indices of the closed intervals ``[lo[i], lo[i + 1]]`` holding ``p``."""
    return [i for i in range(len(lo) - 1) if lo[i] <= p <= lo[i + 1]]


def _labels(blocked: np.ndarray, xs: np.ndarray, ys: np.ndarray, ends: np.ndarray,
            start: np.ndarray, speed: float, stop: Callable[[], bool] | None
            ) -> np.ndarray | None:
    """Dijkstra's labels ``(n, n)`` (module docstring); ``None`` when ``stop`` asked."""
    n = len(xs) - 1
    dx = np.maximum(np.maximum(xs[:-1] - start[0], start[0] - xs[1:]), 0.0)
    dy = np.maximum(np.maximum(ys[:-1] - start[1], start[1] - ys[1:]), 0.0)
    reach = np.hypot(dx[:, None], dy[None, :]) / speed
    label = np.full((n, n), math.inf)
    heap: list[tuple[float, int, int]] = []
    for i in _span(xs, float(start[0])):
        for j in _span(ys, float(start[1])):
            label[i, j] = 0.0
            heap.append((0.0, i, j))
    done = np.zeros((n, n), bool)
    pops = 0
    while heap:
        a, i, j = heapq.heappop(heap)
        if done[i, j]:
            continue
        done[i, j] = True
        pops += 1
        if stop is not None and pops % 256 == 0 and stop():
            return None
        for di, dj in _NEIGHBOURS:
            p, q = i + di, j + dj
            if 0 <= p < n and 0 <= q < n and not done[p, q]:
                t = _push(blocked[p, q], ends, max(a, float(reach[p, q])))
                if t < label[p, q]:
                    label[p, q] = t
                    heapq.heappush(heap, (t, p, q))
    return label


def _cell_gaps(lo: np.ndarray, p: float) -> np.ndarray:
    """Per closed interval ``[lo[i], lo[i + 1]]``, the distance from ``p`` to it."""
    return np.maximum(np.maximum(lo[:-1] - p, p - lo[1:]), 0.0)


def _sweep(blocked: np.ndarray, xs: np.ndarray, ys: np.ndarray, ends: np.ndarray,
           start: np.ndarray, goal: np.ndarray, speed: float,
           stop: Callable[[], bool] | None = None) -> float:
    """The reachable-set bound (module docstring, "The sweep"): the least
    ``f_k = t_k + d(R_k, g) / v`` below ``t_{k+1}`` (``R_k``: the cells the robot may be in at
    the slab end ``t_k``), else the horizon."""
    from scipy.ndimage import distance_transform_edt

    n = len(xs) - 1
    w, h = float(xs[1] - xs[0]), float(ys[1] - ys[0])
    diag, tau = math.hypot(w, h), float(ends[1] - ends[0])
    to_goal = np.hypot(_cell_gaps(xs, float(goal[0]))[:, None],
                       _cell_gaps(ys, float(goal[1]))[None, :]) / speed
    reach = np.zeros((n, n), bool)
    reach[np.ix_(_span(xs, float(start[0])), _span(ys, float(start[1])))] = True
    past: list[np.ndarray] = []  # distance of every cell centre to R_j's centres, j <= k
    for k in range(n):
        _poll(stop)
        if not reach.any():  # no motion lasts past t_k
            break
        f = float(ends[k]) + float(to_goal[reach].min())
        if f < float(ends[k + 1]):  # an arrival in slab k is possible, not before f
            return f
        past.append(distance_transform_edt(~reach, sampling=(w, h)))
        # usable at t_{k+1}: not blocked in every closed slab holding it
        nxt = ~(blocked[:, :, k] & (blocked[:, :, k + 1] if k + 1 < n else True))
        m = 1
        while m <= len(past):  # within v (t_{k+1} - t_j) of R_j, for j = k + 1 - m
            nxt &= past[-m] <= speed * m * tau + diag
            m *= 2
        reach = nxt
    return float(ends[-1])


def cell_lower_bound(problem: Problem, robot_id: str | None = None, *, level: int,
                     stop: Callable[[], bool] | None = None,
                     horizon: float | None = None) -> TimeBound:
    """The cell-slab relaxation's lower bound on the arrival time of ``robot_id``.

    Parameters
    ----------
    problem : Problem
    robot_id : str, optional
        Default the planned robot (``problem.leader``).
    level : int
        ``2^level x 2^level`` cells and ``2^level`` slabs (``0 <= level <= MAX_LEVEL``); the
        bound does not decrease as ``level`` grows (module docstring).
    stop : callable, optional
        Polled every 256 settled cells; True ends the search: the value is then ``0`` (still
        valid), the reason says it stopped.
    horizon : float, optional
        The time window ``H`` (default :func:`cell_horizon`); the bound is at most ``H``.

    Returns
    -------
    TimeBound
        ``value``: the relaxation's bound alone (``0`` at level 0: one cell holds start and
        goal), ``static_bound`` the static one (:func:`static_time`); ``goal_bound`` is
        ``None``.  :func:`~optplan.geometry.timing.time_bounds.arrival_lower_bound` with
        ``level`` takes the maximum of this and its level-0 bound.

    Raises
    ------
    ValueError
        For a bad ``level`` or ``horizon``, an unknown robot or one without a goal.
    """
    lv = check_level(level)
    robot = problem.leader if robot_id is None else problem.robot(robot_id)
    if robot.goal is None:
        raise ValueError(f"robot {robot.id!r} has no goal (a formation follower): no arrival "
                         "bound")
    static = static_time(problem, robot)
    speed = float(robot.max_speed)
    big_h = cell_horizon(problem, static, speed) if horizon is None else float(horizon)
    if not (math.isfinite(big_h) and big_h > 0.0):
        raise ValueError(f"horizon = {horizon!r}: a finite time > 0 is required")
    if lv == 0:
        return TimeBound(0.0, static, None, "cell relaxation, level 0: one cell")
    box = _box(problem, float(robot.radius))
    n = 2 ** lv
    xs, ys = _corners(box, n)
    origin = np.array([box[0], box[1]], float)
    start = np.asarray(robot.start, float) - origin
    goal = np.asarray(robot.goal, float) - origin
    try:
        tables = _blocked(problem, float(robot.radius), box, big_h, lv, stop)
        # the sweep of every level up to this one (its bound need not rise with the level)
        swept = max(min(big_h, _sweep(t, *_corners(box, len(t)), big_h * np.arange(
            len(t) + 1, dtype=float) / len(t), start, goal, speed, stop)) for t in tables)
    except _Stop:
        return TimeBound(0.0, static, None, f"cell relaxation, level {lv}: stopped")
    ends = big_h * (np.arange(n + 1, dtype=float) / n)
    label = _labels(tables[-1], xs, ys, ends, start, speed, stop)
    if label is None:
        return TimeBound(0.0, static, None, f"cell relaxation, level {lv}: stopped")
    cells = [label[i, j] for i in _span(xs, float(goal[0])) for j in _span(ys, float(goal[1]))]
    first = min([big_h, *cells])
    value = max(first, swept)
    why = ("the goal's cell is not reached within the horizon" if value >= big_h else
           "first usable time of the goal's cell" if first >= swept else
           "the sweep of the cells reachable at each slab end")
    return TimeBound(float(value), static, None,
                     f"cell relaxation, level {lv} ({n} x {n} cells, {n} slabs of "
                     f"{big_h / n:.6g} s, horizon {big_h:.6g} s): {why}")
