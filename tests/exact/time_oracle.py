"""Brute-force oracles in time for a disc robot among moving obstacles.

Independent of optplan's motion and contact code: this module reads only the raw fields of
:class:`optplan.problem.DynamicObstacle` (``kind``, ``local_geometry``, ``times``,
``waypoints``, ``velocity``, ``after``, ``radius``) and re-implements the motion model of
``problems/README.md`` (section ``[[dynamic_obstacles]]``) from its text.  It never imports
``optplan.geometry`` nor calls ``DynamicObstacle.position`` / ``.distance``.

* :func:`mover_position` and :func:`clearance`: where a mover is, and how far a point is from
  its shape, at time ``t``;
* :func:`check_trajectory`: a dense sampled check of a timed piecewise-linear trajectory,
  with a documented error bound;
* :func:`grid_earliest_arrival` and :func:`grid_schedule`: a brute-force earliest arrival
  along a fixed polyline on an ``(s, t)`` grid (path-velocity decomposition), conservative
  when the robot is inflated by a margin.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from optplan.problem import DynamicObstacle, Problem

__all__ = [
    "mover_position",
    "mover_breakpoints",
    "mover_max_speed",
    "clearance",
    "polygon_distance",
    "check_trajectory",
    "grid_earliest_arrival",
    "grid_schedule",
]

#: Relative tolerance under which two event times of :func:`check_trajectory` are merged.
_MERGE_REL = 1e-12


# --------------------------------------------------------------------------------------------
# motion model
# --------------------------------------------------------------------------------------------
def _track_time(dyn: DynamicObstacle, t: np.ndarray) -> np.ndarray:
    """Map times ``t`` to the time on ``[times[0], times[-1]]`` whose waypoint interpolation
    gives the position (``hold`` / ``loop`` / ``bounce``), for a mover with >= 2 waypoints."""
    times = np.asarray(dyn.times, dtype=float)
    t0, tn = float(times[0]), float(times[-1])
    period = tn - t0
    after = dyn.after or "hold"
    if after == "hold":
        return np.clip(t, t0, tn)
    rel = np.maximum(t - t0, 0.0)  # before t0: the first waypoint, whatever ``after`` is
    if after == "loop":
        k = np.floor(rel / period)
        r = rel - k * period
        # floating guards: r in [0, period); r == period means the next period has begun
        r = np.where(r >= period, 0.0, np.maximum(r, 0.0))
        return t0 + r
    if after == "bounce":
        k = np.floor(rel / (2.0 * period))
        r = np.clip(rel - k * 2.0 * period, 0.0, 2.0 * period)
        return t0 + np.where(r <= period, r, 2.0 * period - r)
    raise ValueError(f"dynamic obstacle {dyn.name!r}: unknown after={after!r}")


def mover_position(dyn: DynamicObstacle, t: float | np.ndarray) -> np.ndarray:
    """Reference point of a mover at time(s) ``t`` (own reading of ``problems/README.md``).

    Parameters
    ----------
    dyn : DynamicObstacle
        The mover (only its raw fields are read).
    t : float or numpy.ndarray
        A time or a 1-D array of times (s), of any sign.

    Returns
    -------
    numpy.ndarray
        Shape ``(2,)`` for a scalar ``t``, ``(len(t), 2)`` for an array.

    Notes
    -----
    * ``velocity`` given: ``waypoints[0] + (t - times[0]) * velocity`` for every ``t``;
    * one waypoint: parked there;
    * otherwise, with ``t0 = times[0]`` and ``P = times[-1] - t0``: the first waypoint before
      ``t0``, linear between consecutive waypoints on ``[t0, times[-1]]``, and after that
      ``hold`` (last waypoint), ``loop`` (period ``P``, right-continuous jump back to the
      first waypoint at ``t0 + k P``, ``k >= 1``) or ``bounce`` (period ``2 P``, backwards
      then forwards, continuous).
    """
    scalar = np.ndim(t) == 0
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    wps = np.asarray(dyn.waypoints, dtype=float).reshape(-1, 2)
    times = np.asarray(dyn.times, dtype=float).reshape(-1)
    if dyn.velocity is not None:
        t0 = float(times[0]) if times.size else 0.0
        vel = np.asarray(dyn.velocity, dtype=float).reshape(2)
        out = wps[0][None, :] + (tt - t0)[:, None] * vel[None, :]
    elif len(wps) == 1:
        out = np.repeat(wps[:1], len(tt), axis=0)
    else:
        tau = _track_time(dyn, tt)
        out = np.column_stack([np.interp(tau, times, wps[:, 0]),
                               np.interp(tau, times, wps[:, 1])])
    return out[0] if scalar else out


def mover_breakpoints(dyn: DynamicObstacle, t_lo: float, t_hi: float) -> np.ndarray:
    """Times in ``[t_lo, t_hi]`` where the mover's velocity may change or it may jump.

    Between two consecutive breakpoints the reference point moves linearly.  ``loop`` jump
    times ``t0 + k P`` are among them (they coincide with ``times[-1] + (k - 1) P``).

    Returns
    -------
    numpy.ndarray
        Sorted unique times (possibly empty).
    """
    times = np.asarray(dyn.times, dtype=float).reshape(-1)
    if dyn.velocity is not None or len(times) < 2:
        return np.empty(0)
    t0, tn = float(times[0]), float(times[-1])
    period = tn - t0
    after = dyn.after or "hold"
    if after == "hold" or t_hi < t0:
        ev = times
    else:
        full = period if after == "loop" else 2.0 * period
        base = times if after == "loop" else np.concatenate([times, 2.0 * tn - times[::-1]])
        k_lo = max(0, math.floor((t_lo - t0) / full) - 1)
        k_hi = max(0, math.ceil((t_hi - t0) / full) + 1)
        ks = np.arange(k_lo, k_hi + 1, dtype=float)
        ev = (base[None, :] + full * ks[:, None]).ravel()
    ev = ev[(ev >= t_lo) & (ev <= t_hi)]
    return np.unique(ev)


def mover_max_speed(dyn: DynamicObstacle) -> float:
    """Largest speed of the mover's reference point (a ``loop`` jump does not count)."""
    if dyn.velocity is not None:
        return float(np.hypot(*np.asarray(dyn.velocity, dtype=float).reshape(2)))
    wps = np.asarray(dyn.waypoints, dtype=float).reshape(-1, 2)
    if len(wps) < 2:
        return 0.0
    times = np.asarray(dyn.times, dtype=float).reshape(-1)
    d = np.hypot(*np.diff(wps, axis=0).T)
    return float(np.max(d / np.diff(times)))


def _polygon_edges(geom: shapely.Geometry) -> tuple[np.ndarray, np.ndarray]:
    """Edge start and end points ``(e, 2)`` of every ring of a (multi)polygon."""
    starts, ends = [], []
    for part in getattr(geom, "geoms", [geom]):
        for ring in [part.exterior, *part.interiors]:
            xy = np.asarray(ring.coords, dtype=float)[:, :2]
            starts.append(xy[:-1])
            ends.append(xy[1:])
    return np.concatenate(starts), np.concatenate(ends)


def polygon_distance(geom: shapely.Geometry, pts: np.ndarray, chunk_cells: int = 400_000
                     ) -> np.ndarray:
    """Distance from points ``(m, 2)`` to a (multi)polygon, 0 inside (plain numpy).

    The minimum over edges of the point-segment distance, set to 0 where the even-odd
    crossing rule over all rings says the point is inside.  Agrees with
    ``shapely.distance`` (tested) and is several times faster on many points.
    """
    a, b = _polygon_edges(geom)
    ab = b - a
    len2 = np.einsum("ij,ij->i", ab, ab)
    len2 = np.where(len2 > 0, len2, 1.0)
    out = np.empty(len(pts))
    step = max(1, chunk_cells // max(1, len(a)))
    for lo in range(0, len(pts), step):
        p = pts[lo:lo + step, None, :]
        ap = p - a[None]
        u = np.clip((ap[..., 0] * ab[:, 0] + ap[..., 1] * ab[:, 1]) / len2, 0.0, 1.0)
        dx = ap[..., 0] - u * ab[:, 0]
        dy = ap[..., 1] - u * ab[:, 1]
        dmin = np.sqrt(np.min(dx * dx + dy * dy, axis=1))
        py, px = p[..., 1], p[..., 0]
        straddle = (a[:, 1] > py) != (b[:, 1] > py)
        dy_e = np.where(ab[:, 1] != 0, ab[:, 1], 1.0)
        x_cross = a[:, 0] + (py - a[:, 1]) * ab[:, 0] / dy_e
        inside = np.count_nonzero(straddle & (px < x_cross), axis=1) % 2 == 1
        out[lo:lo + step] = np.where(inside, 0.0, dmin)
    return out


def _shape_distance(dyn: DynamicObstacle, rel: np.ndarray) -> np.ndarray:
    """Distance from points ``rel`` (``(m, 2)``, in the mover's local frame) to its shape."""
    if dyn.kind == "circle" and dyn.radius is not None:
        return np.maximum(np.hypot(rel[:, 0], rel[:, 1]) - float(dyn.radius), 0.0)
    return polygon_distance(dyn.local_geometry, rel)


def clearance(dyn: DynamicObstacle, point: np.ndarray | Sequence[float],
              t: float | np.ndarray) -> float | np.ndarray:
    """Distance from ``point`` to the mover's shape at time ``t`` (0 inside or on it).

    Parameters
    ----------
    dyn : DynamicObstacle
        The mover; a ``circle`` is the exact disc of ``radius`` (not its polygon), a
        ``polygon`` its ``local_geometry`` translated to :func:`mover_position`
        (:func:`polygon_distance`).
    point : array_like
        One point ``(2,)`` or points ``(m, 2)``.
    t : float or numpy.ndarray
        A time, or one time per point.

    Returns
    -------
    float or numpy.ndarray
        A float for one point and a scalar time, else an array of shape ``(m,)``.
    """
    pts = np.asarray(point, dtype=float)
    single = pts.ndim == 1 and np.ndim(t) == 0
    pts = np.atleast_2d(pts)
    tt = np.asarray(t, dtype=float)
    centre = mover_position(dyn, tt)
    rel = pts - np.atleast_2d(centre)
    d = _shape_distance(dyn, rel)
    return float(d[0]) if single else d


# --------------------------------------------------------------------------------------------
# continuous-time check of a timed trajectory
# --------------------------------------------------------------------------------------------
def _clean_trajectory(times: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop repeated stamps with the same point; reject decreasing stamps and teleports."""
    if times.ndim != 1 or points.shape != (len(times), 2) or len(times) == 0:
        raise ValueError("times must be (n,) and points (n, 2), n >= 1")
    dt = np.diff(times)
    if np.any(dt < 0):
        raise ValueError("trajectory times must be non-decreasing")
    same = dt == 0
    if np.any(same):
        jump = np.hypot(*(points[1:] - points[:-1]).T)[same]
        if np.any(jump > 1e-12 * (1.0 + np.abs(points).max())):
            raise ValueError("trajectory jumps (two points at the same time stamp)")
        keep = np.concatenate([[True], ~same])
        times, points = times[keep], points[keep]
    return times, points


def _robot_at(times: np.ndarray, points: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Piecewise-linear robot position, held at the last point after ``times[-1]``."""
    if len(times) == 1:
        return np.repeat(points[:1], len(t), axis=0)
    return np.column_stack([np.interp(t, times, points[:, 0]), np.interp(t, times, points[:, 1])])


def _interval_samples(a: float, b: float, n: int) -> np.ndarray:
    return np.linspace(a, b, n + 1)


def check_trajectory(problem: Problem, times: np.ndarray | Sequence[float],
                     points: np.ndarray | Sequence[Sequence[float]], radius: float,
                     samples_per_second: float = 20.0, *, step: float | None = None,
                     horizon: float | None = None, max_samples: int = 5_000_000) -> float:
    """Minimum over movers of ``clearance - radius`` along a timed trajectory (sampled).

    The robot moves linearly between consecutive ``(times[i], points[i])`` and is held at its
    last point afterwards, up to ``horizon`` (default ``times[-1]``).  The check covers
    ``[times[0], horizon]``.

    Parameters
    ----------
    problem : Problem
        Its ``dynamic_obstacles`` are checked (static obstacles are ignored).
    times, points : array_like
        Stamps ``(n,)`` (non-decreasing; a repeated stamp must repeat the point) and centre
        positions ``(n, 2)``.
    radius : float
        The robot's radius.
    samples_per_second : float
        Minimum number of samples per second, whatever the relative speed.
    step : float, optional
        Largest relative displacement between consecutive samples (robot minus mover).
        Default ``radius / 20`` (``1e-3`` of the bounds' diagonal for a point robot).
    horizon : float, optional
        End of the check; default ``times[-1]``.
    max_samples : int
        ``ValueError`` if the check would need more samples than this.

    Returns
    -------
    float
        ``min over movers and samples of clearance - radius`` (``inf`` without movers).  A
        trajectory is accepted when this is ``>= -tol``.

    Notes
    -----
    Event times are the robot's stamps and every mover breakpoint
    (:func:`mover_breakpoints`: waypoint times, repeated with the ``loop`` / ``bounce``
    period; ``loop`` jump times included).  Between two consecutive events both the robot and
    every mover move linearly, so the relative position is one straight segment; it is sampled
    uniformly so that consecutive samples are at most ``step`` apart in relative position, and
    both ends are sampled *from inside the interval*: at a ``loop`` jump the mover is checked
    at its last waypoint (left limit, extrapolated along the piece) and at its first waypoint
    (right value), never in between.

    Guarantee: clearance is 1-Lipschitz in the relative position, so the true continuous
    minimum ``m*`` satisfies ``returned - step / 2 <= m* <= returned`` (up to floating point).
    """
    tt = np.asarray(times, dtype=float).reshape(-1)
    pp = np.asarray(points, dtype=float).reshape(-1, 2)
    tt, pp = _clean_trajectory(tt, pp)
    movers = tuple(problem.dynamic_obstacles)
    if not movers:
        return math.inf
    t_lo = float(tt[0])
    t_hi = float(tt[-1]) if horizon is None else max(float(horizon), float(tt[-1]))
    if step is None:
        x0, y0, x1, y1 = problem.bounds
        step = radius / 20.0 if radius > 0 else 1e-3 * math.hypot(x1 - x0, y1 - y0)
    if step <= 0:
        raise ValueError("step must be > 0")

    events = [tt[(tt >= t_lo) & (tt <= t_hi)], np.array([t_lo, t_hi])]
    events += [mover_breakpoints(d, t_lo, t_hi) for d in movers]
    ev = np.unique(np.concatenate(events))
    if len(ev) > 1:  # merge float duplicates (e.g. t0 + k P computed two ways)
        keep = np.concatenate([[True], np.diff(ev) > _MERGE_REL * (1.0 + np.abs(ev[1:]))])
        ev = ev[keep]
        ev[-1] = t_hi
    if len(ev) == 1:  # a single instant
        rob = _robot_at(tt, pp, ev)
        return min(float(np.min(clearance(d, rob, ev))) for d in movers) - radius

    a, b = ev[:-1], ev[1:]
    q1, q3 = a + 0.25 * (b - a), a + 0.75 * (b - a)
    mid = 0.5 * (a + b)
    span = (b - a)[:, None]
    v_rob = (_robot_at(tt, pp, q3) - _robot_at(tt, pp, q1)) / (0.5 * span)
    v_mov = [(mover_position(d, q3) - mover_position(d, q1)) / (0.5 * span) for d in movers]
    w = np.max([np.hypot(*(v_rob - vm).T) for vm in v_mov], axis=0)
    n = np.maximum(np.ceil(np.maximum(w * (b - a) / step, samples_per_second * (b - a))), 1)
    n = n.astype(np.int64)
    if int(n.sum()) + len(n) > max_samples:
        raise ValueError(f"check_trajectory would need {int(n.sum())} samples (> {max_samples})")
    ts = np.concatenate([_interval_samples(float(x), float(y), int(k))
                         for x, y, k in zip(a, b, n)])
    rob = _robot_at(tt, pp, ts)
    rob_end = _robot_at(tt, pp, b)
    worst = math.inf
    for d, vm in zip(movers, v_mov):
        # right-continuous values at every sample (interval starts included) ...
        worst = min(worst, float(np.min(_shape_distance(d, rob - mover_position(d, ts)))))
        # ... and left limits at every interval end, extrapolated along the interval's piece
        left = mover_position(d, mid) + vm * (b - mid)[:, None]
        worst = min(worst, float(np.min(_shape_distance(d, rob_end - left))))
    return worst - radius


# --------------------------------------------------------------------------------------------
# brute-force earliest arrival along a fixed path, (s, t) grid
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Grid:
    s: np.ndarray            # (ns + 1,) arc lengths, s[-1] = S
    t: np.ndarray            # (nt + 1,) times, t[0] = 0
    k_max: int               # largest forward step (grid cells) per time step
    move_free: list          # move_free[d][j, i]: move (s_i, t_j) -> (s_{i+d}, t_{j+1}) free
    reach: np.ndarray        # (nt + 1, ns + 1) reachable nodes
    arrival: int | None      # index j of the earliest arrival at s = S


def _polyline(path: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices without zero-length segments, and their cumulative arc lengths."""
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) > 1:
        seg = np.hypot(*np.diff(p, axis=0).T)
        p = p[np.concatenate([[True], seg > 0])]
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    return p, cum


def _free(movers: Sequence[DynamicObstacle], pts: np.ndarray, ts: np.ndarray,
          need: float) -> np.ndarray:
    """Whether every mover is at least ``need`` away from ``pts[i]`` at ``ts[i]``."""
    ok = np.ones(len(pts), dtype=bool)
    for d in movers:
        ok &= _shape_distance(d, pts - mover_position(d, ts)) >= need
    return ok


def _free_on(movers: Sequence[DynamicObstacle], vertices: np.ndarray, cum: np.ndarray,
             s: np.ndarray, t: np.ndarray, need: float) -> np.ndarray:
    """Freedom on the outer product ``t x s`` (shape ``(len(t), len(s))``)."""
    xy = np.column_stack([np.interp(s, cum, vertices[:, 0]), np.interp(s, cum, vertices[:, 1])])
    pts = np.tile(xy, (len(t), 1))
    ts = np.repeat(t, len(s))
    return _free(movers, pts, ts, need).reshape(len(t), len(s))


def _substeps(movers: Sequence[DynamicObstacle], max_speed: float, dt: float, ds: float,
              margin: float, substeps: int | None) -> int:
    if substeps is not None:
        return max(1, int(substeps))
    lip = max_speed + max((mover_max_speed(d) for d in movers), default=0.0)
    h = margin if margin > 0 else ds
    return max(1, math.ceil(lip * dt / h - 1e-9))


def _search(problem: Problem, path: np.ndarray | Sequence[Sequence[float]], radius: float,
            max_speed: float, ds: float, dt: float, horizon: float, margin: float,
            substeps: int | None, stay: bool) -> _Grid:
    vertices, cum = _polyline(np.asarray(path, dtype=float))
    length = float(cum[-1])
    ns = max(1, math.ceil(length / ds - 1e-9)) if length > 0 else 0
    nt = max(1, math.ceil(horizon / dt - 1e-9))
    s = np.linspace(0.0, length, ns + 1)
    t = np.linspace(0.0, horizon, nt + 1)
    ds_eff = length / ns if ns else ds
    dt_eff = horizon / nt
    k_max = math.floor(max_speed * dt_eff / ds_eff + 1e-9) if ns else 0
    k_max = min(k_max, ns)
    movers = tuple(problem.dynamic_obstacles)
    need = radius + margin
    m_sub = _substeps(movers, max_speed, dt_eff, ds_eff, margin, substeps)

    node = _free_on(movers, vertices, cum, s, t, need)
    move_free = []
    for d in range(k_max + 1):
        ok = node[:-1, : ns + 1 - d] & node[1:, d:]
        for m in range(1, m_sub):
            f = m / m_sub
            ok &= _free_on(movers, vertices, cum, s[: ns + 1 - d] + d * ds_eff * f,
                           t[:-1] + dt_eff * f, need)
        move_free.append(ok)

    # at the goal, waiting from t_j to the horizon must be free (only with ``stay``)
    if stay:
        wait = np.concatenate([move_free[0][:, ns], [True]])
        goal_ok = np.flip(np.cumprod(np.flip(wait)).astype(bool)) & node[:, ns]
    else:
        goal_ok = np.ones(nt + 1, dtype=bool)

    reach = np.zeros((nt + 1, ns + 1), dtype=bool)
    reach[0, 0] = node[0, 0]
    arrival = 0 if (reach[0, ns] and goal_ok[0]) else None
    j = 0
    while arrival is None and j < nt:
        row = reach[j]
        if not row.any():
            break
        nxt = reach[j + 1]
        for d in range(k_max + 1):
            nxt[d:] |= row[: ns + 1 - d] & move_free[d][j]
        j += 1
        if nxt[ns] and goal_ok[j]:
            arrival = j
    return _Grid(s, t, k_max, move_free, reach, arrival)


def grid_earliest_arrival(problem: Problem, path: np.ndarray | Sequence[Sequence[float]],
                          radius: float, max_speed: float, ds: float, dt: float,
                          horizon: float, margin: float, *, substeps: int | None = None,
                          stay: bool = False) -> float | None:
    """Earliest arrival along a fixed polyline by brute force on an ``(s, t)`` grid.

    Parameters
    ----------
    problem : Problem
        Its ``dynamic_obstacles`` are the obstacles (static ones are ignored: the path is
        assumed clear of them).
    path : array_like
        Polyline ``(n, 2)`` from the start (``s = 0``) to the goal (``s = S``, its length).
    radius, max_speed : float
        The robot's radius and speed limit.
    ds, dt : float
        Largest grid steps; the grid uses ``ceil(S / ds)`` equal steps in ``s`` and
        ``ceil(horizon / dt)`` equal steps in ``t`` (so effective steps are ``<=`` these).
    horizon : float
        Last grid time (the search starts at ``t = 0``).
    margin : float
        The robot disc is inflated by ``margin`` for every freedom test.
    substeps : int, optional
        Samples per move (``m / substeps`` of the move, ``m = 1..substeps``; the start node is
        free by induction).  Default: ``ceil(Lip * dt / margin)`` with ``Lip = max_speed + the
        largest mover speed`` (``ceil(Lip * dt / ds)`` when ``margin == 0``).
    stay : bool
        If true, an arrival at ``t_j`` counts only if the robot can then wait at the goal up
        to ``horizon`` (default: arrival only, nothing is required afterwards).

    Returns
    -------
    float or None
        The earliest grid time ``t_j`` at which ``s = S`` is reached, or ``None`` (start not
        free, or the goal not reached by ``horizon``).

    Notes
    -----
    Moves: from ``(s_i, t_j)`` to ``(s_{i+d}, t_{j+1})`` with ``0 <= d * ds <= max_speed *
    dt`` (wait or go forward, never back); a move is free if its end node and its
    ``substeps - 1`` interior samples (linear in both ``s`` and ``t``) are free, a node is
    free if every mover is at least ``radius + margin`` from the robot centre.

    Conservative (a lower bound on it is never reported): the clearance along the robot's
    motion is Lipschitz in time with constant ``Lip`` (``max_speed`` plus the fastest mover;
    a ``loop`` jump only happens between two samples), and samples are ``dt / substeps``
    apart, so between samples the clearance drops by at most ``Lip * dt / substeps`` below
    ``radius + margin``.  With the default ``substeps`` that is ``<= margin``: every grid
    schedule is feasible for the un-inflated problem in continuous time, hence the returned
    time is ``>=`` the true optimum ``T*`` (no resolution slack in that direction).  Upwards
    there is no guarantee: it is typically ``T*`` of the problem inflated by ``margin`` plus
    a few ``dt`` (and ``S / (k_max ds) * dt - S / max_speed`` when ``max_speed * dt / ds`` is
    not an integer, since the grid speed is ``k_max ds / dt <= max_speed``).
    """
    return _time_of(_search(problem, path, radius, max_speed, ds, dt, horizon, margin,
                            substeps, stay))


def _time_of(grid: _Grid) -> float | None:
    return None if grid.arrival is None else float(grid.t[grid.arrival])


def grid_schedule(problem: Problem, path: np.ndarray | Sequence[Sequence[float]],
                  radius: float, max_speed: float, ds: float, dt: float, horizon: float,
                  margin: float, *, substeps: int | None = None,
                  stay: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The schedule behind :func:`grid_earliest_arrival` (same parameters).

    Returns
    -------
    tuple of numpy.ndarray or None
        ``(times, s, points)``: grid times ``t_0 .. t_arrival``, the arc length at each and the
        robot centre ``(len(times), 2)`` there (feed ``times, points`` to
        :func:`check_trajectory`), or ``None`` when there is no arrival.
    """
    grid = _search(problem, path, radius, max_speed, ds, dt, horizon, margin, substeps, stay)
    if grid.arrival is None:
        return None
    ns = len(grid.s) - 1
    idx = [ns]
    k = ns
    for j in range(grid.arrival, 0, -1):
        for d in range(min(grid.k_max, k) + 1):
            if grid.reach[j - 1, k - d] and grid.move_free[d][j - 1, k - d]:
                k -= d
                break
        else:  # pragma: no cover - reach was built from these very moves
            raise AssertionError("grid backtrack failed")
        idx.append(k)
    sv = grid.s[np.array(idx[::-1])]
    vertices, cum = _polyline(np.asarray(path, dtype=float))
    pts = np.column_stack([np.interp(sv, cum, vertices[:, 0]), np.interp(sv, cum, vertices[:, 1])])
    return grid.t[: grid.arrival + 1].copy(), sv, pts
