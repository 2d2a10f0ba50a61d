"""Fixed-step time simulation shared by local planners and formation controllers.

Robots are discs moving as single integrators, ``x_{k+1} = x_k + dt * u_k`` with
``|u_k| <= max_speed``.  A *policy* maps the current :class:`SimState` to desired velocities;
the simulator clamps them, moves the robots, advances dynamic obstacles and checks contacts
every step.  Termination: every robot done (goal reached, or the policy says so), a collision,
the policy returning ``None`` (it gave up), a ``StopIteration`` from the callback, or the step
budget.

Sensing.  :class:`ObstacleField` answers, for a position and time, the nearest boundary point
and exact distance of every obstacle (static polygons, circles, and dynamic obstacles at time t)
within a range.  Distances are to the raw obstacle (not inflated); inside an obstacle the
distance is 0.  The static obstacles are answered by the one exact geometry core
(:meth:`optplan.geometry.ObstacleSet.nearest`, whose bounding-circle screen discards obstacles
farther than the range before any edge-level work); the simulator keeps no distance code of its
own beyond a moving circle's centre and radius and the nearest point on a disc
(:func:`disc_nearest`, also the robots' as others sense them).  Contacts are checked with the
map tolerance :attr:`optplan.geometry.Frame.eps`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any

import numpy as np

from optplan.geometry import Frame, ObstacleSet, obstacle_set
from optplan.problem import Obstacle, Problem, Robot
from optplan.result import Progress, notify

__all__ = ["ObstacleField", "SimState", "SimOutcome", "SimSetup", "simulate", "disc_nearest"]


def disc_nearest(pts: np.ndarray, c: np.ndarray, r: np.ndarray,
                 max_range: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """Nearest boundary points ``(R, m, 2)`` and distances ``(R, m)`` of the points ``pts
    (R, 2)`` to discs (centres ``c (m, 2)``, radii ``r (m,)``): exact, 0 inside; skipped
    (``nan`` / ``inf``) beyond ``max_range``; from a disc's centre, the boundary point towards
    +x.  The one nearest point on a disc of the simulator's sensing: moving circles
    (:meth:`ObstacleField.nearest`) and other robots
    (:class:`~optplan.potential.backend.RobotsAsObstacles`)."""
    v = pts[:, None, :] - c
    if v.size == 0:  # no point or no disc
        return np.full(v.shape, np.nan), np.full(v.shape[:2], np.inf)
    nv = np.hypot(v[..., 0], v[..., 1])
    d = nv - r
    if d.min() > max_range:  # the usual case: every moving circle out of range
        return np.full(v.shape, np.nan), np.full(d.shape, np.inf)
    np.maximum(d, 0.0, out=d)
    if nv.min() > 0.0:
        p = c + v * (r / nv)[..., None]
    else:  # a point at a centre: any boundary point will do, the one towards +x
        z = nv == 0.0
        p = c + v * (r / np.where(z, 1.0, nv))[..., None]
        p[z] = (c + np.stack([r, np.zeros_like(r)], axis=1))[np.nonzero(z)[1]]
    if not d.max() <= max_range:
        ok = d <= max_range
        d = np.where(ok, d, np.inf)
        p = np.where(ok[..., None], p, np.nan)
    return p, d


class ObstacleField:
    """Nearest-point queries against a problem's static and dynamic obstacles.

    The static obstacles are answered by the exact geometry core
    (:meth:`optplan.geometry.ObstacleSet.nearest` on the problem's obstacle set of radius 0);
    a moving circle is its centre and radius at time ``t``; a moving polygon is an
    :class:`~optplan.geometry.ObstacleSet` of its local shape (in the frame of the shape's own
    bounds), queried with the points relative to the obstacle's position at ``t``.

    Parameters
    ----------
    problem : Problem
    include_temporary : bool
        Include temporary (``known = false``) static obstacles (local planners see them).
    include_dynamic : bool
        Include dynamic obstacles.

    Obstacle indices: ``0 .. n_static-1`` static (problem order, filtered), then dynamic.
    """

    def __init__(self, problem: Problem, include_temporary: bool = True,
                 include_dynamic: bool = True):
        self.problem = problem
        known_only = not include_temporary
        self.static = list(problem.static_obstacles(known_only))
        self.dynamic = list(problem.dynamic_obstacles) if include_dynamic else []
        self.names = [o.name for o in self.static] + [d.name for d in self.dynamic]
        self.n_static = len(self.static)
        self.n = len(self.names)
        # static: the problem's cached engine, built from exactly this list of obstacles
        self._static_set = (problem.obstacle_set(0.0, known_only, walls=False) if self.static
                            else None)
        # dynamic: circles by index and radius; polygons as (index, engine of the local shape)
        circ = [(self.n_static + k, d.circle_radius()) for k, d in enumerate(self.dynamic)
                if d.kind == "circle"]
        self._circ_idx = np.array([j for j, _ in circ], dtype=np.int64)
        self._circ_r = np.array([r for _, r in circ], dtype=float)
        m = len(circ)  # a slice when the circles are the last m obstacles (the usual case)
        self._circ_sel = (slice(self.n - m, self.n) if m and np.array_equal(
            self._circ_idx, np.arange(self.n - m, self.n)) else self._circ_idx)
        self._dyn_polys: list[tuple[int, ObstacleSet]] = []
        for k, d in enumerate(self.dynamic):
            if d.kind != "circle":
                g = d.local_geometry
                oset = obstacle_set([Obstacle("polygon", g, True, d.name)], 0.0,
                                    Frame.from_bounds(g.bounds), walls=False)
                self._dyn_polys.append((self.n_static + k, oset))
        self._off_t: float | None = None
        self._off = np.zeros((self.n, 2))

    def offsets(self, t: float) -> np.ndarray:
        """Translation of every obstacle at time ``t``, shape ``(n, 2)`` (zero for static).

        The last query is cached: controllers and the simulator ask several times per step.
        """
        t = float(t)
        if self._off_t == t:
            return self._off
        off = np.zeros((self.n, 2))
        for k, d in enumerate(self.dynamic):
            off[self.n_static + k] = d.position(t)
        off.setflags(write=False)
        self._off_t, self._off = t, off
        return off

    def nearest(self, points: np.ndarray, t: float = 0.0,
                max_range: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """Nearest boundary points and distances for every (point, obstacle) pair.

        Parameters
        ----------
        points : array, shape ``(R, 2)`` or ``(2,)``
        t : float
            Time (positions of dynamic obstacles).
        max_range : float
            Obstacles farther than this (exact distance) are skipped (distance ``inf``).

        Returns
        -------
        nearest : array ``(R, n, 2)``
            Nearest boundary point (``nan`` where skipped).
        dist : array ``(R, n)``
            Exact distance to the obstacle (0 inside, ``inf`` where skipped).
        """
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        R, ns = len(pts), self.n_static
        if self._static_set is not None and ns == self.n:
            return self._static_set.nearest(pts, max_range)
        if self.n == 0 or R == 0:
            return np.full((R, self.n, 2), np.nan), np.full((R, self.n), np.inf)
        near = np.empty((R, self.n, 2))  # every column is filled below
        dist = np.empty((R, self.n))
        if self._static_set is not None:
            near[:, :ns], dist[:, :ns] = self._static_set.nearest(pts, max_range)
        off = self.offsets(t)
        if len(self._circ_idx):
            j = self._circ_sel
            near[:, j], dist[:, j] = disc_nearest(pts, off[j], self._circ_r, max_range)
        for i, oset in self._dyn_polys:
            q, d = oset.nearest(pts - off[i], max_range)
            near[:, i], dist[:, i] = q[:, 0] + off[i], d[:, 0]
        return near, dist


@dataclass
class SimState:
    """What a policy sees at step ``k`` (time ``t``).

    Attributes
    ----------
    k : int
        Step index (0 before the first move).
    t : float
        Simulated time (s).
    ids : list of str
        Robot ids, in the order of the rows of ``positions``.
    positions : array ``(R, 2)``
        Current positions.
    velocities : array ``(R, 2)``
        Velocities applied at the previous step (after the speed clamp; zero at ``k = 0``).
    field : ObstacleField
        The obstacles the robots sense.
    dt : float
        The simulation time step (s), the same for every step of a run.
    leader_velocity : array ``(2,)`` or None
        The leader's command for the *current* step, set by a driver that computes it before
        calling a :class:`~optplan.interfaces.FollowerController` (the hybrid planner, the
        formation backends); ``None`` (reset by the simulator before every step) when no one
        has set it, and follower controllers then use ``velocities[leader_index]``.
    contacts : list of str
        Contacts seen so far (one line each; with ``stop_on_collision`` at most one).
    """

    k: int
    t: float
    ids: list[str]
    positions: np.ndarray  # (R, 2)
    velocities: np.ndarray  # (R, 2) commanded at the previous step
    field: ObstacleField
    dt: float = dc_field(kw_only=True)
    leader_velocity: np.ndarray | None = dc_field(default=None, kw_only=True)
    contacts: list[str] = dc_field(default_factory=list, kw_only=True)

    def leader_command(self, leader_index: int) -> np.ndarray:
        """``leader_velocity`` when a driver set it, else the leader's previous velocity."""
        v = self.leader_velocity
        return np.asarray(self.velocities[leader_index] if v is None else v, dtype=float)


@dataclass
class SimOutcome:
    """Trajectories and why the run stopped."""

    times: np.ndarray  # (T,)
    positions: np.ndarray  # (T, R, 2)
    ids: list[str]
    reason: str  # 'done', 'collision', 'budget', 'gave_up', 'callback'
    collision: str = ""
    steps: int = 0
    contacts: list[str] = dc_field(default_factory=list)

    def paths(self) -> dict[str, np.ndarray]:
        return {rid: self.positions[:, i, :].copy() for i, rid in enumerate(self.ids)}


@dataclass(frozen=True, kw_only=True, eq=False)
class SimSetup:
    """The optional setup of a :func:`simulate` run: where and when it starts, the obstacles
    its contact checks see, and whether a contact ends it.

    Parameters
    ----------
    start : array ``(R, 2)``, optional
        Initial positions, one row per simulated robot in ``ids`` order (default: the
        robots' starts).
    t0 : float
        Initial time (s).
    field : ObstacleField, optional
        Obstacles used for contact checks (default: everything, temporary and dynamic).
    stop_on_collision : bool
        Stop at the first contact (robot disc overlapping an obstacle or another robot).

    Raises
    ------
    ValueError
        A setting of the wrong kind; the message names it, its value and what is allowed.
    """

    start: np.ndarray | None = None
    t0: float = 0.0
    field: ObstacleField | None = None
    stop_on_collision: bool = True

    def __post_init__(self) -> None:
        t0_ok = (isinstance(self.t0, (int, float, np.integer, np.floating))
                 and not isinstance(self.t0, bool) and math.isfinite(self.t0))
        checks = [("start", self.start is None or (np.ndim(self.start) == 2
                                                   and np.shape(self.start)[1] == 2),
                   "None or an (R, 2) array of positions"),
                  ("t0", t0_ok, "a finite number of seconds"),
                  ("field", self.field is None or isinstance(self.field, ObstacleField),
                   "None or an ObstacleField"),
                  ("stop_on_collision", isinstance(self.stop_on_collision, (bool, np.bool_)),
                   "True or False")]
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"SimSetup.{name} must be {allowed}, "
                                 f"got {getattr(self, name)!r}")


def simulate(
    problem: Problem,
    policy: Callable[[SimState], np.ndarray | None],
    *,
    ids: list[str],
    dt: float,
    max_steps: int,
    done: Callable[[SimState], bool],
    setup: SimSetup = SimSetup(),
    callback: Callable[[Progress], Any] | None = None,
    progress_cost: Callable[[SimState], float] | None = None,
) -> SimOutcome:
    """Run ``policy`` from the robots' starts until ``done``, a collision, or the budget.

    Parameters
    ----------
    problem : Problem
    policy : callable
        ``policy(state) -> (R, 2)`` desired velocities, or ``None`` to give up.
    ids : list of str
        Robots simulated (in this order).
    dt : float
        Time step (s).
    max_steps : int
        Step budget.
    done : callable
        ``done(state) -> bool``; checked before every step.
    setup : SimSetup
        Initial positions and time, the obstacles of the contact checks, and whether a
        contact stops the run (default: the robots' starts at t = 0, every obstacle, stop).
    callback : callable, optional
        Receives a :class:`~optplan.result.Progress` each step (``elapsed``: wall seconds,
        ``sim_time``: simulated time); ``StopIteration`` stops.
    progress_cost : callable, optional
        Scalar reported as ``best_cost`` to the callback (e.g. distance to goal).

    Returns
    -------
    SimOutcome
        The trajectories (one row of ``positions`` per time in ``times``) and why the run
        stopped.

    Raises
    ------
    TypeError
        ``setup`` is no :class:`SimSetup`.
    ValueError
        ``setup.start`` has not one row per robot of ``ids``.
    """
    if not isinstance(setup, SimSetup):
        raise TypeError(f"setup must be a SimSetup, got {type(setup).__name__}")
    wall0 = time.perf_counter()
    fld = setup.field or ObstacleField(problem)
    t0 = setup.t0
    robots = [problem.robot(i) for i in ids]
    radii = np.array([r.radius for r in robots])
    vmax = np.array([r.max_speed for r in robots])
    pos = _start_positions(robots, setup.start)
    state = SimState(0, t0, list(ids), pos.copy(), np.zeros_like(pos), fld, dt=float(dt))
    times = [t0]
    traj = [pos.copy()]
    reason, coll = "budget", ""
    tol = problem.frame.eps
    for k in range(max_steps):
        state.k, state.t, state.leader_velocity = k, t0 + k * dt, None
        if done(state):
            reason = "done"
            break
        u = policy(state)
        if u is None:
            reason = "gave_up"
            break
        u = _clamp_speeds(np.asarray(u, dtype=float).reshape(pos.shape), vmax)
        pos = pos + dt * u
        state.positions, state.velocities = pos.copy(), u
        t_new = t0 + (k + 1) * dt
        times.append(t_new)
        traj.append(pos.copy())
        contact = _contact(fld, pos, t_new, radii, ids, tol)
        if contact:
            coll = contact
            state.contacts.append(coll)
            if setup.stop_on_collision:
                reason = "collision"
                break
        if _report(callback, progress_cost, state, k, t_new, wall0):
            reason = "callback"
            break
    else:
        state.t = t0 + max_steps * dt
        if done(state):
            reason = "done"
    return SimOutcome(np.array(times), np.array(traj), list(ids), reason, coll,
                      len(times) - 1, list(state.contacts))


def _start_positions(robots: list[Robot], start: np.ndarray | None) -> np.ndarray:
    """The initial positions: ``start`` when given, else the robots' starts."""
    if start is None:
        return np.array([r.start for r in robots], dtype=float)
    pos = np.array(start, dtype=float)
    if pos.shape != (len(robots), 2):
        raise ValueError(f"SimSetup.start must have one row per robot of ids, shape "
                         f"({len(robots)}, 2), got {pos.shape}")
    return pos


def _report(callback: Callable[[Progress], Any] | None,
            progress_cost: Callable[[SimState], float] | None, state: SimState, k: int,
            t: float, wall0: float) -> bool:
    """Send step ``k``'s :class:`~optplan.result.Progress` to ``callback``."""
    cost = progress_cost(state) if progress_cost else float("nan")
    return notify(callback, Progress(k, cost, k + 1, time.perf_counter() - wall0, {},
                                     sim_time=t))


def _clamp_speeds(u: np.ndarray, vmax: np.ndarray) -> np.ndarray:
    """Scale each robot's velocity down to its speed limit (directions kept)."""
    sp = np.hypot(u[:, 0], u[:, 1])
    scale = np.where(sp > vmax, vmax / np.where(sp > 0, sp, 1.0), 1.0)
    return u * scale[:, None]


def _contact(fld: ObstacleField, pos: np.ndarray, t: float, radii: np.ndarray,
             ids: list[str], tol: float) -> str:
    """The first contact of the robots at ``pos`` and time ``t``, described.

    Obstacle contacts are reported before robot-robot contacts.
    """
    _, d = fld.nearest(pos, t, max_range=float(radii.max()) + 1.0)
    hit = d < radii[:, None] - tol
    pair_hit = _pair_hits(pos, radii, tol, len(ids))
    if hit.any():
        ri, oi = np.argwhere(hit)[0]
        return f"{ids[ri]} touched {fld.names[oi]} at t={t:.2f}"
    if pair_hit.any():
        ri, rj = np.argwhere(pair_hit)[0]
        return f"{ids[ri]} touched {ids[rj]} at t={t:.2f}"
    return ""


def _pair_hits(pos: np.ndarray, radii: np.ndarray, tol: float, n_robots: int) -> np.ndarray:
    """Which pairs of robot discs overlap by more than ``tol``."""
    if n_robots > 1:
        diff = pos[:, None, :] - pos[None, :, :]
        dd = np.hypot(diff[..., 0], diff[..., 1])
        np.fill_diagonal(dd, np.inf)
        rr = radii[:, None] + radii[None, :]
        return dd < rr - tol
    return np.zeros((1, 1), bool)
