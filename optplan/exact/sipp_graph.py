r"""The roadmap of the ``sipp`` preset and its windows in time (``optplan.exact.sipp``).

**Roadmap.**  The vertices and edges are those of the arc-exact tangent visibility graph of
the static map (:mod:`optplan.geometry.tangent.tangent_graph`): a *vertex* is the start, the goal,
or the point where a tangent segment arrives on a circle (one per tangent: circle ``i`` in sense
``s_i`` to circle ``j`` in sense ``s_j``); the edges out of a vertex on circle ``j`` are the
*chains* "arc along ``j`` to the departure point of a tangent, then that tangent", exactly the
successors the tangent graph's A* generates (``candidates`` and ``departures`` of
:class:`~optplan.geometry.tangent.tangent_search.TangentSearch`: the same circles, the same
normal-cone filter), checked with its exact tests (the segment predicate of
the obstacle set, the exact arc test).  Each arc is driven along its *circumscribed polyline*
(:func:`~optplan.geometry.tangent.tangent_graph.arc_polyline`, chords of at most ``arc_step`` rad,
redrawn up to four times four times finer, never finer than :data:`FINEST_STEP`, where it
comes too close to a neighbouring obstacle, as the tangent graph does); its corners are
vertices of the chain, where the robot may wait like at every other vertex.  No graph is
stored: the chains of a vertex are generated when a state on it is first expanded, sorted by
length plus the distance to the goal, and
checked lazily (:class:`Roadmap`).

**Windows in time.**  A chain is a polyline driven at full speed ``v`` with waits at its
corners.  Its segment ``a -> b`` is forbidden to a departure at ``t`` when the disc crossing it
from ``t`` at speed ``v`` overlaps a moving obstacle:
:func:`~optplan.geometry.timing.st_regions.forbidden_departures`, computed here for many segments in
one vectorised pass (:func:`segment_windows`: the same regions and the same extremes, over all
the obstacles' shapes at once, :mod:`optplan.geometry.timing.st_batch`).  A point is
busy when the disc parked there overlaps a moving obstacle
(:func:`~optplan.geometry.timing.time_bounds.parked_contact_times`); its *safe intervals* are the
closed complement (:func:`~optplan.geometry.timing.intervals.free_intervals`).  Only the moving
obstacles whose motion on ``[0, horizon]`` passes near a point or a segment are handed to these
functions (:class:`MoverBoxes`, an axis-aligned box test that never drops a contact).
:func:`chain_schedule` is the earliest arrival along one chain.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from optplan.geometry.collision import ObstacleSet
from optplan.geometry.tangent import TangentGraph, TangentSearch, arc_polyline, circles_of
from optplan.geometry.timing import (
    Intervals,
    first_free,
    mover_pieces,
    parked_contact_times,
    path_regions,
    shape_pieces,
)
from optplan.geometry.timing.st_batch import ShapeRows, batch_sections, region_ranges
from optplan.geometry.timing.st_regions import MoverTable, mover_table

if TYPE_CHECKING:
    from optplan.problem import DynamicObstacle

__all__ = ["MoverBoxes", "segment_windows", "chain_schedule", "Chains", "Roadmap", "GOAL_KEY",
           "START_KEY"]

#: Keys of the start and goal vertices (a tangent-point vertex is keyed by its tangent
#: ``(i, s_i, j, s_j)``, ``i = -1`` for the start).
START_KEY: tuple = ("start",)
GOAL_KEY: tuple = ("goal",)

#: Refinements of a circumscribed arc polyline that comes too close to a neighbour (each
#: divides the chord angle by 4), as in
#: :func:`optplan.geometry.tangent.tangent_graph.problem_shortest_path`.
_REFINE = 4
#: The finest chord angle (rad) of a refinement: the smallest ``arc_step`` accepted.  A chain
#: then has at most ``2 pi / FINEST_STEP`` (about 63,000) corners, so drawing one chain, or
#: computing its windows, is a bounded step between two polls of the deadline.
FINEST_STEP = 1e-4


# --------------------------------------------------------------------------------------
# moving obstacles near a point or a segment
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MoverBoxes:
    """Axis-aligned boxes of the moving obstacles' motions on ``[0, horizon]``.

    Each box holds every point of the obstacle's shape at every time of the window (the
    reference point's linear pieces, :func:`~optplan.geometry.timing.motion.mover_pieces`, clipped
    to the window, plus the shape's extent) grown by the robot's ``radius``; a point or segment
    outside a box cannot touch that obstacle in the window.  ``horizon`` is the window's end
    (:meth:`build`'s); :meth:`segment_windows` keeps each obstacle's pieces on the window
    (:func:`~optplan.geometry.timing.st_regions.mover_table`) once computed.
    """

    movers: list[DynamicObstacle]
    lo: np.ndarray
    hi: np.ndarray
    horizon: float
    _tables: dict[int, MoverTable] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def build(cls, movers: list[DynamicObstacle], radius: float, horizon: float
              ) -> MoverBoxes:
        """The boxes of ``movers`` on ``[0, horizon]`` for a robot of ``radius``."""
        lo = np.zeros((len(movers), 2))
        hi = np.zeros((len(movers), 2))
        for k, d in enumerate(movers):
            ta, tb, b, w = mover_pieces(d, 0.0, horizon)
            dt = np.maximum(np.minimum(tb, horizon) - ta, 0.0)
            ends = np.vstack([b, b + dt[:, None] * w])
            ext = np.vstack([_shape_box(s) for s in shape_pieces(d.kind, d.radius,
                                                                   d.local_geometry)])
            lo[k] = ends.min(axis=0) + ext[:, :2].min(axis=0) - radius
            hi[k] = ends.max(axis=0) + ext[:, 2:].max(axis=0) + radius
        return cls(list(movers), lo, hi, float(horizon))

    def near(self, point) -> list[DynamicObstacle]:
        """The obstacles whose box holds ``point``."""
        p = np.asarray(point, float)
        ok = np.all((self.lo <= p) & (self.hi >= p), axis=1)
        return [self.movers[k] for k in np.flatnonzero(ok)]

    def near_segments(self, a: np.ndarray, b: np.ndarray) -> list[DynamicObstacle]:
        """The obstacles whose box meets the box of at least one segment ``a[k] -> b[k]``
        (``(n, 2)`` each)."""
        return [self.movers[k] for k in self._near_ids(a, b)]

    def _near_ids(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The indices of the obstacles of :meth:`near_segments`."""
        lo, hi = np.minimum(a, b)[:, None, :], np.maximum(a, b)[:, None, :]
        ok = np.all((self.lo[None] <= hi) & (self.hi[None] >= lo), axis=2).any(axis=0)
        return np.flatnonzero(ok)

    def segment_windows(self, a: np.ndarray, b: np.ndarray, radius: float, speed: float
                        ) -> tuple[list[Intervals], list[Intervals]]:
        """:func:`segment_windows` of the segments ``a[k] -> b[k]`` against the obstacles
        near them on the boxes' window ``[0, horizon]``; each obstacle's pieces on the window
        (:func:`~optplan.geometry.timing.st_regions.mover_table`) are computed once and kept."""
        ids = self._near_ids(a, b).tolist()
        for k in ids:
            if k not in self._tables:
                self._tables[k] = mover_table(self.movers[k], self.horizon)
        return segment_windows([self.movers[k] for k in ids], a, b, radius, speed,
                               self.horizon, [self._tables[k] for k in ids])

    def parked_busy(self, point, radius: float, t_lo: float, t_hi: float) -> Intervals:
        """:func:`~optplan.geometry.timing.time_bounds.parked_contact_times` of the disc parked at
        ``point`` against the obstacles near it."""
        near = self.near(point)
        return parked_contact_times(near, point, radius, t_lo, t_hi) if near else []


# --------------------------------------------------------------------------------------
# windows in time
# --------------------------------------------------------------------------------------


def _shape_box(shape) -> np.ndarray:
    """``(x_lo, y_lo, x_hi, y_hi)`` of a convex piece in its local frame."""
    if shape.is_circle:
        r = float(shape.radius)
        return np.array([-r, -r, r, r])
    v = np.asarray(shape.vertices)
    return np.r_[v.min(axis=0), v.max(axis=0)]


def _reach(shape) -> float:
    """Largest distance from a convex piece's reference point (its local origin) to it."""
    if shape.is_circle:
        return float(shape.radius)
    return float(np.max(np.hypot(*np.asarray(shape.vertices).T)))


def _point_segment(p: np.ndarray, a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` to the segments ``a -> a + d`` (rows)."""
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    return np.hypot(*(p - a - t[:, None] * d).T)


def _cross(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return x[:, 0] * y[:, 1] - x[:, 1] * y[:, 0]


def _may_meet(reg) -> np.ndarray:
    """Per region: the robot's segment and the segment its obstacle's reference point sweeps
    over the piece come within the piece's reach plus the robot's radius (else the region is
    empty: every point of the piece is within its reach of the reference point)."""
    # frame of the robot's segment start A: robot s u (s in [0, ell]), reference
    # B - A + t' w (t' in [0, T])
    dp = reg.ell[:, None] * reg.u
    b0, dq = -reg.c0, reg.T[:, None] * reg.w
    p0 = np.zeros_like(b0)
    d = np.minimum.reduce([_point_segment(p0, b0, dq), _point_segment(dp, b0, dq),
                           _point_segment(b0, p0, dp), _point_segment(b0 + dq, p0, dp)])
    den = _cross(dp, dq)
    par = den == 0
    den = np.where(par, 1.0, den)
    s, t = _cross(b0, dq) / den, _cross(b0, dp) / den
    d = np.where(~par & (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1), 0.0, d)
    reach = np.array([_reach(x) for x in reg.shapes])[reg.shape] + reg.radius
    slack = 1e-9 * (reach + np.abs(reg.c0).max(axis=1) + reg.ell + np.hypot(*dq.T))
    return d <= reach + slack


def _grouped(k: np.ndarray, lo: np.ndarray, hi: np.ndarray, n: int) -> list[Intervals]:
    """Per group ``0..n-1``: the union of the open intervals ``(lo_i, hi_i)`` with ``k_i``
    equal to it (:func:`~optplan.geometry.timing.intervals.merge_open` of each group: the
    intervals in the same order, by ``lo`` and then by position, merged the same way, in one
    pass over all groups)."""
    out: list[Intervals] = [[] for _ in range(n)]
    if len(k) == 0:
        return out
    order = np.lexsort((lo, k))  # stable: by group, then lo, then position
    for g, x, y in zip(k[order].tolist(), lo[order].tolist(), hi[order].tolist()):
        o = out[g]
        if o and x <= o[-1][1]:
            o[-1] = (o[-1][0], max(o[-1][1], y))
        else:
            o.append((x, y))
    return out


def segment_windows(movers: list[DynamicObstacle], a: np.ndarray, b: np.ndarray,
                    radius: float, speed: float, horizon: float,
                    tables: list[MoverTable] | None = None
                    ) -> tuple[list[Intervals], list[Intervals]]:
    """:func:`~optplan.geometry.timing.st_regions.forbidden_departures` of many segments at once,
    and the busy times of their end points.

    Parameters
    ----------
    movers : list of DynamicObstacle
    a, b : ndarray ``(n, 2)``
        The segments ``a[k] -> b[k]`` (world coordinates, each of positive length).
    radius, speed, horizon : float
        The robot's disc, its speed on the segments and the time window ``[0, horizon]``.
    tables : list of MoverTable, optional
        The movers' :func:`~optplan.geometry.timing.st_regions.mover_table` on the window
        (computed here when not given).

    Returns
    -------
    forbidden : list of Intervals
        Per segment, the departure times at which the disc crossing it at ``speed`` overlaps
        a moving obstacle (sorted disjoint open intervals, touching ones merged).
    busy : list of Intervals
        Per segment, the times at which the disc parked at ``b[k]`` overlaps a moving obstacle
        (the same set as :func:`~optplan.geometry.timing.time_bounds.parked_contact_times` on the
        window).

    Notes
    -----
    The segments are strung into one polyline ``a0, b0, a1, b1, ...`` whose convex forbidden
    regions (:func:`~optplan.geometry.timing.st_regions.path_regions`) are those of the segments
    plus those of the connectors ``b_k -> a_{k+1}``; the connectors' regions are dropped, and so are
    the regions whose segment and obstacle piece never come within reach (a segment-to-segment
    distance).  The departures of the rest are the extremes of ``t' - sigma / speed``
    (:func:`~optplan.geometry.timing.st_regions.region_extremes`), as in
    :func:`~optplan.geometry.timing.st_regions.forbidden_departures`; the busy times at ``b[k]`` are
    the regions' sections at ``sigma = ell`` (:func:`~optplan.geometry.timing.st_regions.sections`).
    Both are evaluated over all regions at once, the two extremes in one pass
    (:func:`~optplan.geometry.timing.st_batch.region_ranges`,
    :func:`~optplan.geometry.timing.st_batch.batch_sections`: the same bits as shape by shape).
    """
    a = np.asarray(a, float).reshape(-1, 2)
    b = np.asarray(b, float).reshape(-1, 2)
    n = len(a)
    empty: tuple[list[Intervals], list[Intervals]] = ([[] for _ in range(n)],
                                                      [[] for _ in range(n)])
    if n == 0 or not movers:
        return empty
    poly = np.empty((2 * n, 2))
    poly[0::2], poly[1::2] = a, b
    reg = path_regions(movers, poly, radius, horizon, tables)
    if len(reg):
        reg = reg.take(np.flatnonzero((reg.seg % 2 == 0) & _may_meet(reg)))
    if len(reg) == 0:
        return empty
    sh = ShapeRows.of(reg)
    hi, lo = region_ranges(reg, np.array([-1.0 / speed, 1.0]), np.zeros(len(reg)), reg.ell, sh)
    ok = np.isfinite(hi) & (hi > -lo)
    k = reg.seg // 2
    forbidden = _grouped(k[ok], reg.ta[ok] - lo[ok], reg.ta[ok] + hi[ok], n)
    s_lo, s_hi = batch_sections(reg, reg.ell, sh)
    on = ~np.isnan(s_lo)
    busy = _grouped(k[on], reg.ta[on] + s_lo[on], reg.ta[on] + s_hi[on], n)
    return forbidden, busy


def chain_schedule(t0: float, leave_by: float, lengths: list[float],
                   forbidden: list[Intervals], safe: list[Intervals], speed: float,
                   horizon: float) -> dict[int, tuple[float, list[float]]]:
    """Earliest arrivals at the end of a chain driven at ``speed``, with waits at its corners.

    Parameters
    ----------
    t0, leave_by : float
        The arrival at the chain's first point and the end of that point's safe interval
        (the robot may wait there until then).
    lengths, forbidden : list
        Per segment ``k`` (point ``k`` to ``k + 1``): its length and forbidden departures.
    safe : list of Intervals
        Per segment ``k``: the safe intervals of point ``k + 1`` (the last: the chain's end).
    speed, horizon : float
        Full speed on the segments; no arrival after ``horizon``.

    Returns
    -------
    dict
        Safe interval index at the chain's end -> ``(arrival, departures)``: the earliest
        arrival in that interval and the departure time from each point of the chain.

    Notes
    -----
    Safe-interval dynamic programming along the chain (Phillips and Likhachev 2011): per
    point, the earliest arrival in each of its safe intervals; from an arrival ``t`` in an
    interval ending at ``e``, the next point's safe interval ``[c, d]`` is entered by the
    earliest departure ``t' >= max(t, c - l / v)``, ``t' <= min(e, d - l / v)``, outside the
    segment's forbidden departures.  An earlier arrival in the same interval dominates a later
    one (the robot may wait), so the earliest arrival per interval is exact.
    """
    layer: dict[int, tuple[float, float, list[float]]] = {-1: (t0, leave_by, [])}
    for k, length in enumerate(lengths):
        dt = length / speed
        nxt: dict[int, tuple[float, float, list[float]]] = {}
        for t, end, deps in layer.values():
            j0 = bisect.bisect_left(safe[k], (t + dt, -math.inf)) - 1
            for j in range(max(j0, 0), len(safe[k])):
                c, d = safe[k][j]
                if c - dt > end:
                    break
                lo, hi = max(t, c - dt), min(end, d - dt, horizon - dt)
                dep = first_free(forbidden[k], lo) if lo <= hi else math.inf
                if dep <= hi and (j not in nxt or dep + dt < nxt[j][0]):
                    nxt[j] = (dep + dt, d, [*deps, dep])
        layer = nxt
        if not layer:
            break
    return {j: (arr, deps) for j, (arr, _, deps) in layer.items()}


# --------------------------------------------------------------------------------------
# the roadmap
# --------------------------------------------------------------------------------------


@dataclass
class Chains:
    """The chains out of one vertex, sorted by ``key`` (module docstring).

    Attributes
    ----------
    key : ndarray
        Length of the chain with exact arcs (a lower bound of its drawn length) plus the
        distance from its end to the goal: ``key / speed`` is an admissible lower bound on the
        time from the vertex to the goal through the chain.
    target : list of tuple
        The key of the vertex each chain ends at.
    end, theta, circle, sense : ndarray
        Its end point (local, complex), arrival angle, circle and sense.
    pi, sweep, th_d : ndarray
        Departure point of the tangent (local, complex), the arc swept before it, the
        departure angle.
    ok : ndarray of int8
        0 not checked yet, 1 free, -1 blocked.
    points : list
        Per checked free chain, its drawn polyline (world, ``(m, 2)``).
    """

    key: np.ndarray
    target: list[tuple]
    end: np.ndarray
    theta: np.ndarray
    circle: np.ndarray
    sense: np.ndarray
    pi: np.ndarray
    sweep: np.ndarray
    th_d: np.ndarray
    ok: np.ndarray
    points: list[np.ndarray | None] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.key)


@dataclass(frozen=True)
class Vertex:
    """A roadmap vertex: its key, circle (``-1`` start, ``-2`` goal, ``-3 - k`` waypoint ``k``),
    sense, arrival angle
    and point (local complex, world)."""

    key: tuple
    circle: int
    sense: int
    theta: float
    z: complex
    xy: np.ndarray


class Roadmap:
    """The tangent roadmap of one robot: vertices, their chains, the exact static checks.

    Parameters
    ----------
    oset : ObstacleSet
        The static obstacles (all of them, temporary ones included) for the robot's radius.
    start, goal : array-like ``(2,)``
        World coordinates.
    arc_step : float
        Largest angle (rad) spanned by one chord of a circumscribed arc polyline.
    waypoints : array-like ``(m, 2)``, optional
        Free points (world) added as vertices: the robot may wait there, and every vertex
        has a chain to each of them (a straight segment from a point, the arc then the
        tangent from a circle); the free-space vertices of the time bracket
        (:mod:`optplan.exact.time_bracket`).  Keyed ``("w", k)``.
    """

    def __init__(self, oset: ObstacleSet, start, goal, arc_step: float, waypoints=None):
        fr = oset.frame
        self.oset, self.fr, self.arc_step = oset, fr, float(arc_step)
        s_loc, g_loc = fr.local(np.asarray(start, float)), fr.local(np.asarray(goal, float))
        self.zs, self.zg = complex(s_loc[0], s_loc[1]), complex(g_loc[0], g_loc[1])
        self.start_xy, self.goal_xy = np.asarray(start, float), np.asarray(goal, float)
        self.wp_xy = np.zeros((0, 2)) if waypoints is None else np.asarray(waypoints, float)
        w_loc = fr.local(self.wp_xy) if len(self.wp_xy) else np.zeros((0, 2))
        self.wp_z = w_loc[:, 0] + 1j * w_loc[:, 1]
        self.info: dict[str, Any] = {"n_expanded": 0, "n_generated": 0, "n_checked": 0}
        self.graph = TangentSearch(oset, (C := circles_of(oset)), self.zs, self.zg, self.info,
                                   TangentGraph(oset, C))
        self.vertices: list[Vertex] = []
        self.index: dict[tuple, int] = {}
        self.chains: dict[int, Chains] = {}
        #: Called with the number of corners of every chain drawn (the search counts its work
        #: and polls its deadline there; it may raise to end the search).
        self.tick: Callable[[int], None] = _no_tick
        self.vertex(START_KEY, -1, 1, 0.0, self.zs)
        self.vertex(GOAL_KEY, -2, 1, 0.0, self.zg)

    def vertex(self, key: tuple, circle: int, sense: int, theta: float, z: complex) -> int:
        """The id of the vertex ``key`` (created with these attributes on first sight)."""
        v = self.index.get(key)
        if v is None:
            v = len(self.vertices)
            self.index[key] = v
            xy = (self.start_xy if key == START_KEY else self.goal_xy if key == GOAL_KEY
                  else self.wp_xy[key[1]] if key[0] == "w"
                  else self.fr.world(np.array([z.real, z.imag])))
            self.vertices.append(Vertex(key, circle, sense, theta, z, xy))
        return v

    def heuristic(self, v: int) -> float:
        """Straight-line distance from vertex ``v`` to the goal."""
        return abs(self.vertices[v].z - self.zg)

    def out_chains(self, v: int) -> Chains:
        """The chains out of vertex ``v`` (generated on first call, sorted by key)."""
        if v not in self.chains:
            self.chains[v] = self._generate(v)
        return self.chains[v]

    def _generate(self, v: int) -> Chains:
        """Candidate chains out of ``v``: the tangent graph's successors of an arrival at
        ``v`` (every tangent leaving its circle in its sense, both senses at the target, and
        the goal), filtered by the normal cones."""
        g, vx = self.graph, self.vertices[v]
        i, si, th_a = vx.circle, vx.sense, vx.theta
        self.info["n_expanded"] += 1
        ci, ri = (vx.z, 0.0) if i < 0 else (g.cen[i], float(g.rho[i]))
        jj, sj, dd, delta, nl, pj, th_arr = g.candidates(i, si, ci, ri, points=self.wp_z)
        pi, th_d, sweep, ok = g.departures(i, si, th_a, ci, ri, nl)
        isg = jj < 0
        if g.n:
            ok &= isg | np.isfinite(g.cone_off(np.where(isg, 0, jj), th_arr))
        seg = np.sqrt(np.maximum(dd * dd - delta * delta, 0.0))
        key = ri * sweep + seg + np.abs(pj - self.zg)
        sel = np.flatnonzero(ok)
        sel = sel[np.argsort(key[sel], kind="stable")]
        self.info["n_generated"] += int(sel.size)
        target = [GOAL_KEY if jj[k] == -2 else ("w", -3 - int(jj[k])) if jj[k] < 0
                  else (i, si, int(jj[k]), int(sj[k])) for k in sel]
        return Chains(key[sel], target, pj[sel], th_arr[sel], jj[sel], sj[sel], pi[sel],
                      sweep[sel], th_d[sel], np.zeros(sel.size, np.int8), [None] * sel.size)

    def target(self, ch: Chains, k: int) -> int:
        """The id of the vertex chain ``k`` of ``ch`` ends at."""
        return self.vertex(ch.target[k], int(ch.circle[k]), int(ch.sense[k]),
                           float(ch.theta[k]), complex(ch.end[k]))

    def check(self, v: int, ch: Chains, k: int) -> bool:
        """Whether chain ``k`` out of ``v`` is free (exact checks of it and of a batch of the
        unchecked chains after it); its polyline is then ``ch.points[k]``."""
        if ch.ok[k] == 0:
            idx = np.arange(k, min(len(ch), k + max(8, int(np.count_nonzero(ch.ok)))))
            idx = idx[ch.ok[idx] == 0]
            self.info["n_checked"] += len(idx)
            free = self._tangents_free(v, ch, idx)
            for m, f in zip(idx.tolist(), free.tolist()):
                pts = self._drawn(v, ch, m) if f else None
                ch.points[m] = pts
                ch.ok[m] = 1 if pts is not None else -1
                self.tick(1 if pts is None else len(pts))
        return bool(ch.ok[k] == 1)

    def _tangents_free(self, v: int, ch: Chains, idx: np.ndarray) -> np.ndarray:
        """Exact tests of the tangent segments and the exact arcs of chains ``idx``."""
        vx = self.vertices[v]
        fr = self.fr
        a = fr.world(np.stack([ch.pi[idx].real, ch.pi[idx].imag], axis=1))
        b = fr.world(np.stack([ch.end[idx].real, ch.end[idx].imag], axis=1))
        free = self.oset.segment_free(a, b)
        i = vx.circle
        if i >= 0 and self.graph.rho[i] > 0:
            m = free & (ch.sweep[idx] > 0)
            if m.any():
                free[m] = self.graph.arcs.free(i, np.full(int(m.sum()), vx.theta),
                                               ch.sweep[idx][m], vx.sense)
        return free

    def _drawn(self, v: int, ch: Chains, k: int) -> np.ndarray | None:
        """The drawn polyline of chain ``k`` (world): the vertex, the corners of the
        circumscribed arc, the tangent's departure and end points; ``None`` when no
        circumscribed polyline up to the finest is free."""
        vx = self.vertices[v]
        end = self.vertices[self.target(ch, k)].xy
        i, step = vx.circle, self.arc_step
        if i < 0 or self.graph.rho[i] == 0 or ch.sweep[k] == 0:
            return _dedup(np.vstack([vx.xy, end]))
        c, rho = complex(self.graph.cen[i]), float(self.graph.rho[i])
        for _ in range(_REFINE + 1):
            arc = arc_polyline(c, rho, vx.theta, float(ch.sweep[k]) * vx.sense, step)
            z = np.concatenate([arc[1:-1], [ch.pi[k]]])
            mid = self.fr.world(np.stack([z.real, z.imag], axis=1))
            pts = _dedup(np.vstack([vx.xy, mid, end]))
            if self.oset.segment_free(pts[:-2], pts[1:-1]).all():
                return pts
            if step <= FINEST_STEP:
                break
            self.tick(len(pts))
            step = max(step / 4, FINEST_STEP)
        return None


def _no_tick(n: int) -> None:
    """The default :attr:`Roadmap.tick`: no deadline."""


def _dedup(pts: np.ndarray) -> np.ndarray:
    """``pts`` without consecutive repeats."""
    keep = np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]
    return pts[keep]
