r"""The piloted formation base: the leader's reference, its pilot and the simulation loop.

Shared by :class:`~optplan.formation.leader_follower.LeaderFollower` and
:class:`~optplan.formation.formation_qp.FormationQP`: both plan (or take) a reference for the
leader, drive it along the reference with a pilot and ask a follower controller for the
followers' velocities every control step (:func:`run_formation`).

Pilot (leader), eqs 39-45
-------------------------
Attraction :math:`F_{att} = k\,(X_g - X)` (eq 40, :math:`k = 15`) toward the current reference
point :math:`X_g`; for every sensed obstacle within :math:`\rho_0` the improved repulsion
:math:`F_{rep1} = \eta(1/\rho - 1/\rho_0)\,\rho_g^n/\rho^2` away from the obstacle (eq 44) and
:math:`F_{rep2} = \tfrac n2\eta(1/\rho - 1/\rho_0)^2\rho_g^{n-1}` toward the reference point
(eq 45); :math:`\rho` is the clearance (distance to the obstacle minus the robot radius, clamped at
``rho_min``), :math:`\rho_g = \|X - X_g\|`.  The pilot moves along :math:`F/\|F\|` at its cruise
speed (``pilot = "builtin"``, the default).  ``pilot`` may instead name any
:class:`~optplan.interfaces.LocalPlanner` (e.g. ``"sa-apf"``, paper §IV.B): its controller then
drives the leader toward the same reference points.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.formation.slots import slot_positions, wrap
from optplan.geometry.collision import cumulative_length, resample_uniform
from optplan.interfaces import LOCAL_PLANNER, PATH_SOLVER, LocalController, resolve_stage
from optplan.potential.field import attractive_force, repulsive_force
from optplan.problem import Problem
from optplan.result import History, Progress, Result, Status
from optplan.sim import ObstacleField, SimSetup, SimState, simulate
from optplan.solver import Backend, get_solver, option
from optplan.units import Record, Unit

__all__ = ["PilotedFormation", "PilotAPF", "ReferenceTracker", "pilot_force", "reference_path",
           "make_pilot", "run_formation", "BUILTIN_PILOT", "PILOT_GAINS", "PILOT_STATS_UNITS"]

#: The units of :attr:`PilotAPF.stats`.
PILOT_STATS_UNITS = Record({"steps": Unit.DIMENSIONLESS})


def pilot_force(x: np.ndarray, goal: np.ndarray, near: np.ndarray, clear: np.ndarray,
                k: float, eta: float, rho_0: float, n: float) -> np.ndarray:
    """Total pilot force, eqs 40 + 44 + 45, summed over obstacles.

    The same improved field as SA-APF (eqs 34-37, :mod:`optplan.potential.apf`) with the
    pilot's gains.

    Parameters
    ----------
    x, goal : (2,)
    near : (m, 2)
        Nearest obstacle points.
    clear : (m,)
        Clearances ``rho`` (clamped by the caller); obstacles with ``rho > rho_0`` are ignored.
    """
    F = attractive_force(x, goal, k)
    if len(clear):
        F = F + np.sum(repulsive_force(x[None, :], near, clear, goal, eta, rho_0, n), axis=0)
    return F

# --------------------------------------------------------------------------------------
# the leader's controllers
# --------------------------------------------------------------------------------------


class PilotAPF:
    """The pilot's improved APF (eqs 39-45) as a :class:`~optplan.interfaces.LocalController`.

    Moves along ``F / |F|`` at ``speed``; never overshoots the goal.  The force is computed
    in units of ``scale`` (the problem's :attr:`~optplan.problem.Problem.length_scale`):
    positions and clearances are divided by it, ``rho_0`` and ``rho_min`` are multiples of it,
    so the direction of motion does not depend on the unit the scene is drawn in.
    """

    def __init__(self, problem: Problem, robot_id: str, *, k: float, eta: float, rho_0: float,
                 n: float, speed: float, rho_min: float = 0.5, scale: float = 1.0):
        self.robot = problem.robot(robot_id)
        self.k, self.eta, self.rho_0, self.n = k, eta, rho_0, n
        self.speed, self.rho_min, self.scale = speed, rho_min, float(scale)
        self.goal = np.array(self.robot.goal if self.robot.goal is not None
                             else self.robot.start, float)
        self.stats: dict[str, Any] = {"steps": 0}  # units: PILOT_STATS_UNITS

    def reset(self, goal: np.ndarray) -> None:
        self.goal = np.asarray(goal, float).copy()

    def velocity(self, state: SimState, index: int) -> np.ndarray | None:
        x = state.positions[index]
        s = self.scale
        near, dist = state.field.nearest(x, state.t,
                                         max_range=self.rho_0 * s + self.robot.radius)
        clear = np.maximum((dist[0] - self.robot.radius) / s, self.rho_min)
        clear = np.where(np.isfinite(dist[0]), clear, np.inf)
        F = pilot_force(x / s, self.goal / s, near[0] / s, clear, self.k, self.eta, self.rho_0,
                        self.n)
        nf = float(np.hypot(*F))
        self.stats["steps"] += 1
        if nf < 1e-12:
            return np.zeros(2)
        dt = float(state.dt)
        dist_g = float(np.hypot(*(self.goal - x)))
        return F / nf * min(self.speed, dist_g / dt)


class ReferenceTracker:
    """Drives the leader along a reference polyline with a
    :class:`~optplan.interfaces.LocalController`.

    The reference is resampled every ``spacing``; the current target is the first sample more
    than ``lookahead`` ahead of the leader's progress index (monotone).  The controller is
    ``reset`` only when the target changes.  Reference points closer than ``clearance`` to a
    sensed obstacle (one the global planner did not know) are skipped.  At the last point the
    speed is capped so the leader stops on the goal.
    """

    def __init__(self, ref: np.ndarray, controller: Any, *, spacing: float, lookahead: float,
                 speed: float, goal_tol: float, clearance: float = 0.0):
        ref = np.asarray(ref, float)
        length = cumulative_length(ref)[-1]  # the arc length resample_uniform spreads
        # at most 100,000 samples: a tiny spacing cannot exhaust memory
        n = max(2, min(100_000, int(math.ceil(length / spacing)) + 1)) if length > 0 else 1
        self.points = resample_uniform(ref, n)
        self.goal = ref[-1].copy()
        self.ctrl, self.lookahead, self.speed, self.goal_tol = controller, lookahead, speed, \
            goal_tol
        self.clearance = clearance
        self.idx = -1
        self.progress = 0
        self.gave_up = 0

    def velocity(self, state: SimState, index: int) -> np.ndarray:
        x = state.positions[index]
        dt = float(state.dt)
        dgoal = float(np.hypot(*(self.goal - x)))
        if dgoal <= 0.5 * self.goal_tol:
            return np.zeros(2)
        # progress: nearest sample within a window ahead
        win = self.points[self.progress: self.progress + 20]
        j = int(np.argmin(np.hypot(*(win - x).T)))
        self.progress += j
        d = np.hypot(*(self.points[self.progress:] - x).T)
        far = np.nonzero(d > self.lookahead)[0]
        tgt = self.progress + int(far[0]) if len(far) else len(self.points) - 1
        # skip reference points blocked by sensed (temporary / moving) obstacles
        if tgt < len(self.points) - 1 and self.clearance > 0:
            cand = self.points[tgt: tgt + 60]
            _, dist = state.field.nearest(cand, state.t, max_range=self.clearance)
            free = np.nonzero(np.min(dist, axis=1, initial=np.inf) >= self.clearance)[0]
            if len(free):
                tgt += int(free[0])
        if tgt != self.idx:
            self.idx = tgt
            self.ctrl.reset(self.points[tgt])
        u = self.ctrl.velocity(state, index)
        if u is None:
            self.gave_up += 1
            u = np.zeros(2)
        u = np.asarray(u, float)
        sp = float(np.hypot(*u))
        cap = self.speed if self.idx < len(self.points) - 1 else min(self.speed, dgoal / dt)
        if sp > cap:
            u = u * (cap / sp)
        return u


# --------------------------------------------------------------------------------------
# the shared driver
# --------------------------------------------------------------------------------------


def reference_path(problem: Problem, path_solver: Backend, rng: np.random.Generator,
                   init: dict[str, np.ndarray] | None) -> tuple[np.ndarray, str]:
    """The leader's reference: ``init[leader]``, else planned on ``problem.known_view()``.

    A path solver that returns no usable path (status ``infeasible`` / ``failed``, or fewer
    than two points) gives the straight start-goal line, said in the message.
    """
    lead = problem.leader
    if init and lead.id in init:
        return np.asarray(init[lead.id], float), "reference from init"
    name = path_solver.preset or path_solver.name
    res = path_solver.solve(problem.known_view(), rng=rng)
    path = res.paths.get(lead.id)
    if path is not None and len(path) >= 2 and res.status.value in ("optimal", "solved",
                                                                     "approximate"):
        return np.asarray(path, float), f"reference by {name} ({res.status.value})"
    if lead.goal is None:
        raise ValueError(f"problem {problem.name!r}: the leader {lead.id!r} has no goal")
    return (np.vstack([lead.start, lead.goal]),
            f"{name} returned {res.status.value}; straight-line reference used")


#: ``pilot`` value selecting the built-in eqs 39-45 pilot (:class:`PilotAPF`).
BUILTIN_PILOT = "builtin"

#: The pilot's gains passed on to a local planner used as the pilot (those it has).
PILOT_GAINS = ("k", "eta", "rho_0", "n")


def make_pilot(problem: Problem, opts: PilotedFormation, rng: np.random.Generator,
               speed: float) -> tuple[LocalController, str]:
    """The leader's controller and its name: the built-in pilot or the ``pilot`` stage's."""
    lead = problem.leader
    planner = opts.stages["pilot"]
    if planner is None:
        return PilotAPF(problem, lead.id, k=opts.k, eta=opts.eta, rho_0=opts.rho_0, n=opts.n,
                        speed=speed, scale=problem.length_scale), BUILTIN_PILOT
    return planner.controller(problem, lead.id, rng), opts.pilot


class _FormationRun:
    """One leader-follower simulation: the pilot on the reference, the followers by ``fctrl``.

    The policy, ``done`` test and history of :func:`run_formation`; the formation frame's
    heading is the leader's command direction low-passed with time constant ``tau_h``.
    """

    def __init__(self, o: PilotedFormation, problem: Problem, tracker: ReferenceTracker,
                 fctrl: Any, ref: np.ndarray, joint: Callable[..., np.ndarray] | None,
                 step_columns: Callable[[], dict[str, Any]] | None):
        self.o, self.problem, self.tracker, self.fctrl = o, problem, tracker, fctrl
        self.joint, self.step_columns = joint, step_columns
        form = problem.formation
        if form is None:
            raise ValueError(f"problem {problem.name!r} has no [formation]")
        self.lead = problem.leader
        self.ids = [self.lead.id] + [f.id for f in form.followers]
        self.fidx = list(range(1, len(self.ids)))
        self.L = np.array([f.L for f in form.followers])
        self.phi = np.array([f.phi for f in form.followers])
        self.vmax_f = np.array([problem.robot(i).max_speed for i in self.ids[1:]])
        self.tol = problem.goal_tol(self.lead)
        g0 = self.lead.goal - self.lead.start
        h0 = (float(np.arctan2(ref[1, 1] - ref[0, 1], ref[1, 0] - ref[0, 0])) if len(ref) > 1
              else float(np.arctan2(g0[1], g0[0])))
        self.heading = h0  # the formation frame's heading
        self.raw_heading = h0  # the last heading of a non-zero leader command
        self.hist = History()
        self.t_start = time.perf_counter()

    def slot_err(self, state: SimState) -> np.ndarray:
        P = state.positions
        slots = slot_positions(P[0], self.heading, self.L, self.phi)
        return np.hypot(*(P[1:] - slots).T)

    def _turn(self, ul: np.ndarray) -> None:
        if np.hypot(*ul) > 1e-9 * self.problem.length_scale:
            self.raw_heading = float(np.arctan2(ul[1], ul[0]))
        o = self.o
        a = min(1.0, o.dt / o.tau_h) if o.tau_h > 0 else 1.0
        self.heading = float(wrap(self.heading + a * wrap(self.raw_heading - self.heading)))

    def policy(self, state: SimState) -> np.ndarray:
        t0 = time.perf_counter()
        ul = self.tracker.velocity(state, 0)
        self._turn(ul)
        state.leader_velocity = ul
        if self.joint is not None:
            U = self.joint(state, ul, self.heading)
        else:
            U = np.zeros((len(self.ids), 2))
            U[0] = ul
            U[1:] = self.fctrl.velocities(state, 0, self.fidx, self.heading)
        err = self.slot_err(state)
        row = dict(iteration=state.k,
                   best_cost=float(np.hypot(*(self.lead.goal - state.positions[0]))),
                   n_eval=state.k + 1, time=time.perf_counter() - self.t_start,
                   formation_error=float(err.max()), step_time=time.perf_counter() - t0)
        if self.step_columns is not None:
            row.update(self.step_columns())
        self.hist.append(**row)
        return U

    def done(self, state: SimState) -> bool:
        P = state.positions
        if np.hypot(*(P[0] - self.lead.goal)) > self.tol or state.k == 0:
            return False
        sp = np.hypot(*state.velocities[1:].T) / self.vmax_f
        if np.all(sp < 1e-3):  # settled where the law holds them (e.g. eq 52 near a wall)
            return True
        return bool(np.all(self.slot_err(state) <= self.o.settle_tol * self.L)
                    and np.all(sp < 1e-2))


def run_formation(backend: PilotedFormation, problem: Problem, fctrl: Any, *,
                  rng: np.random.Generator, init: dict[str, np.ndarray] | None,
                  callback: Callable[[Progress], Any] | None,
                  joint: Callable[..., np.ndarray] | None = None,
                  step_columns: Callable[[], dict[str, Any]] | None = None,
                  extras: Callable[[], dict[str, Any]] | None = None) -> Result:
    """One simulation: leader tracks the reference, followers by ``fctrl``.

    Parameters
    ----------
    backend : PilotedFormation
        The options (pilot, reference, run settings).
    fctrl : FollowerController
        The followers' controller.
    joint : callable, optional
        ``joint(state, u_lead, heading) -> (R, 2)`` replaces the follower call when the
        backend also filters the leader (formation-qp with the leader in the QP).
    step_columns : callable, optional
        ``step_columns() -> dict`` of extra history columns for the step just taken (e.g. the
        QP's status and solve time).
    extras : callable, optional
        ``extras() -> dict`` of backend statistics added to ``Result.extras`` at the end.
    """
    t_start = time.perf_counter()
    if problem.formation is None:
        raise ValueError(f"{backend.name}: problem {problem.name!r} has no [formation]")
    lead = problem.leader
    ref, ref_msg = reference_path(problem, backend.stages["path_solver"], rng, init)
    speed = backend.v_factor * lead.max_speed
    pilot, pilot_name = make_pilot(problem, backend, rng, speed)
    ell = problem.length_scale
    tracker = ReferenceTracker(ref, pilot, spacing=backend.ref_spacing * ell,
                               lookahead=backend.lookahead * ell, speed=speed,
                               goal_tol=problem.goal_tol(lead),
                               clearance=2 * lead.radius + backend.lookahead * ell / 2)
    run = _FormationRun(backend, problem, tracker, fctrl, ref, joint, step_columns)
    out = simulate(problem, run.policy, ids=run.ids, dt=backend.dt,
                   max_steps=backend.max_steps, done=run.done,
                   setup=SimSetup(field=ObstacleField(problem)), callback=callback)
    claim = {"done": Status.solved, "budget": Status.approximate,
             "callback": Status.approximate}.get(out.reason, Status.failed)
    msg = f"{out.reason}" + (f" ({out.collision})" if out.collision else "")
    msg += f"; {ref_msg}; pilot {pilot_name}"
    ex = {"reference": ref, "stop_reason": out.reason, "pilot": pilot_name,
          "pilot_stats": dict(getattr(pilot, "stats", {})),
          "follower_stats": dict(getattr(fctrl, "stats", {})),
          "contacts": list(out.contacts), "time_to_goal": float(out.times[-1])}
    if extras is not None:
        ex.update(extras())
    return backend.finish(problem, out.paths(), claim=claim, times=out.times,
                          cost=float(out.times[-1]), message=msg, n_iter=out.steps,
                          n_eval=out.steps, history=run.hist, extras=ex,
                          wall_time=time.perf_counter() - t_start)


# --------------------------------------------------------------------------------------
# the shared options
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class PilotedFormation(Backend):
    r"""Options shared by the formation backends: the leader's pilot and the run.

    Every distance-like option is a multiple of the scene's length unit
    :attr:`optplan.problem.Problem.length_scale` (marked "x length_scale"; 1 on the paper's
    scenes, so the ``-paper`` presets keep the paper's literal values there): the same preset
    behaves the same on a scene drawn in centimetres, metres or kilometres.

    Parameters
    ----------
    k : float
        Pilot attraction gain (eqs 39-40); paper 15.  The pilot moves along the direction of
        the total force, computed in units of ``length_scale``.
    eta : float
        Pilot repulsion gain (eqs 41, 44-45); paper 3.7.
    rho_0 : float
        Pilot obstacle influence distance (eq 41; x length_scale); paper 100.
    n : float
        Goal-distance exponent of the improved repulsion (eq 41); paper 3.
    adapt_phi : bool
        Shrink the desired angle near obstacles by eq 52.
    rho_0_f : float
        Obstacle clearance below which eq 52 acts (x length_scale); the paper uses the same
        :math:`\rho_0 = 100`.
    c_phi : float
        The factor 20 inside the logarithms of eq 52, per length unit (used as
        ``c_phi / length_scale``); rho is clamped at ``length_scale / c_phi``.
    pilot : str or Backend
        ``"builtin"`` (default, the paper): the built-in eqs 39-45 pilot (:class:`PilotAPF`
        with ``k``, ``eta``, ``rho_0``, ``n``).  Otherwise a preset or backend name (or object)
        of a :class:`~optplan.interfaces.LocalPlanner` (e.g. ``"sa-apf"``), whose controller
        drives the leader with this backend's ``k``, ``eta``, ``rho_0`` and ``n`` (those the
        local planner has as options).  Resolved when the backend is built: a misspelled name
        or a backend without ``controller()`` is a ``ValueError``.
    path_solver : str or Backend
        Solver planning the leader's reference on ``problem.known_view()`` when ``init`` has
        none (default ``"ipso"``, the documented IPSO variant, collision-free in every measured
        run; the literal ``"ipso-paper"`` fails on some maps, see the PSO page).  Resolved when
        the backend is built.
    v_factor : float
        Leader cruise speed as a fraction of its ``max_speed`` (headroom for followers).
    ref_spacing : float
        Resampling step of the leader's reference (x length_scale).
    lookahead : float
        Target look-ahead along the reference (x length_scale); reference points closer than
        twice the leader's radius plus half of it to a sensed obstacle are skipped.
    tau_h : float
        Time constant (s) of the low-pass filter on the leader heading that orients the
        formation frame (0: raw heading of the leader's command).
    dt : float
        Control period (s).
    max_steps : int
        Simulation budget (control steps).
    settle_tol : float
        The run ends when the leader is at its goal and every follower is within
        ``settle_tol * L`` of its slot and (nearly) still, or every follower has stopped
        (a fraction of each follower's L, so scale-free).
    """

    k: float = option(15.0, lo=0.0, lo_open=True)
    eta: float = option(3.7, lo=0.0)
    rho_0: float = option(100.0, lo=0.0, lo_open=True, scale=True)
    n: float = option(3.0, lo=0.0)
    adapt_phi: bool = option(True)
    rho_0_f: float = option(100.0, lo=0.0, lo_open=True, scale=True)
    c_phi: float = option(20.0, lo=0.0, lo_open=True)
    pilot: Any = option(BUILTIN_PILOT, kind="any")
    path_solver: Any = option("ipso", kind="any")
    v_factor: float = option(0.75, lo=0.0, hi=1.0, lo_open=True)
    ref_spacing: float = option(5.0, lo=0.0, lo_open=True, scale=True)
    lookahead: float = option(15.0, lo=0.0, scale=True)
    tau_h: float = option(5.0, lo=0.0)
    dt: float = option(0.5, lo=0.0, lo_open=True)
    max_steps: int = option(4000, lo=1, hi=10_000_000)
    settle_tol: float = option(0.005, lo=0.0, lo_open=True)
    _stages: dict[str, Any] | None = field(init=False, repr=False, compare=False, default=None)

    #: The units of the follower controller's ``stats`` (each formation backend's own).
    stats_units: ClassVar[Record] = Record({})
    #: The units of the backend's own statistics in the extras (``run_formation(extras=)``).
    summary_units: ClassVar[Record] = Record({})

    @property
    def extras_units(self) -> Record:
        """The units of the result's extras (:func:`run_formation`; :mod:`optplan.units`)."""
        pilot = self.stages["pilot"]
        return Record({
            "reference": Unit.POINT, "stop_reason": Unit.TEXT, "pilot": Unit.TEXT,
            "pilot_stats": PILOT_STATS_UNITS if pilot is None else pilot.stats_units,
            "follower_stats": self.stats_units, "contacts": Unit.TEXT,
            "time_to_goal": Unit.TIME}) | self.summary_units

    def check(self) -> None:
        """Resolve the ``pilot`` and ``path_solver`` stages (a ``ValueError`` names the option)."""
        object.__setattr__(self, "_stages", {"pilot": self._resolve_pilot(), "path_solver":
                                            resolve_stage(self.name, "path_solver",
                                                          self.path_solver, PATH_SOLVER)})

    def _resolve_pilot(self) -> Any:
        if self.pilot == BUILTIN_PILOT:
            return None
        planner = resolve_stage(self.name, "pilot", self.pilot, LOCAL_PLANNER)
        gains = {g: getattr(self, g) for g in PILOT_GAINS if g in planner.options()}
        try:
            return get_solver(planner, **gains)
        except ValueError as e:
            raise ValueError(f"option 'pilot' of backend {self.name!r}: the pilot's gains "
                             f"{sorted(gains)} do not suit {self.pilot!r}: {e}") from None

    @property
    def stages(self) -> dict[str, Any]:
        """The resolved stages: ``{"pilot": LocalPlanner or None (the built-in pilot),
        "path_solver": Backend}``, set when the backend is built."""
        if self._stages is None:  # check() runs in __post_init__, so only if it was bypassed
            raise RuntimeError(f"{self.name}: the stages are not resolved (check() has not run)")
        return self._stages

    def options(self) -> dict[str, Any]:
        out = super().options()
        for k in ("pilot", "path_solver"):
            if isinstance(out[k], Backend):
                out[k] = out[k].preset or out[k].name
        return out
