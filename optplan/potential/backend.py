"""The time-stepping potential-field backend: shared options and the simulation driver.

:class:`PotentialFieldBackend` holds the options of ``apf`` and ``sa-apf``;
:func:`run_local_planner` simulates every planned robot with its own controller
(:class:`~optplan.potential.controller.APFController` or SA-APF's) in one
:func:`optplan.sim.simulate` run and builds the result; with several planned robots each one
senses the others as discs (:class:`RobotsAsObstacles`).  The field is in
:mod:`optplan.potential.field`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from optplan.geometry.collision import path_lengths
from optplan.options import option
from optplan.potential.controller import STATS_UNITS, APFController, Trace
from optplan.potential.field import FieldParams
from optplan.potential.swept import StepGuard
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status
from optplan.sim import ObstacleField, SimSetup, SimState, disc_nearest, simulate
from optplan.solver import Backend, make_rng
from optplan.units import Each, Record, Unit

__all__ = ["PotentialFieldBackend", "run_local_planner", "RobotsAsObstacles",
           "oscillation_index", "EXTRAS_UNITS"]

#: The units of the result's extras (:func:`run_local_planner`; :mod:`optplan.units`).
EXTRAS_UNITS = Record({
    "local_minima_detected": Unit.DIMENSIONLESS, "detections": Each(Unit.DIMENSIONLESS),
    "local_minima_escaped": Unit.DIMENSIONLESS, "sa_steps": Unit.DIMENSIONLESS,
    "sim_steps": Unit.DIMENSIONLESS, "sim_reason": Unit.TEXT, "length_scale": Unit.LENGTH,
    "controllers": Each(STATS_UNITS), "minima": Each(Unit.POINT), "collision": Unit.TEXT,
    "time_to_goal": Unit.TIME, "oscillation_index": Unit.DIMENSIONLESS})


def oscillation_index(path: np.ndarray, unit: float = 1.0) -> float:
    """Sum of absolute heading changes (rad) per ``unit`` of length of a trajectory (the
    local planners pass the problem's ``length_scale``, so the index is scale-free)."""
    p = np.asarray(path, dtype=float)
    d = np.diff(p, axis=0)
    s = np.hypot(d[:, 0], d[:, 1])
    d = d[s > 1e-9]
    L = float(s.sum()) / float(unit)
    if len(d) < 2 or L <= 0:
        return 0.0
    th = np.arctan2(d[:, 1], d[:, 0])
    dth = np.abs((np.diff(th) + np.pi) % (2 * np.pi) - np.pi)
    return float(dth.sum() / L)



class RobotsAsObstacles(ObstacleField):
    """An obstacle field plus other robots as disc obstacles frozen at their current positions.

    Beyond the paper (which plans one robot, or a formation through its leader): when
    ``run_local_planner`` simulates several independently planned robots, each one senses the
    others through this view of the field (option ``sense_robots``).  The robots come after
    the scene's dynamic obstacles, so they count as moving obstacles (``n_static`` is
    unchanged), also for :meth:`~optplan.potential.controller.APFController.evade`.
    A view of the ``base`` field (it builds no engine of its own): it answers what the
    controllers ask of a field, ``nearest``, ``n``, ``n_static`` and the ``static`` obstacles
    (the base's).
    """

    def __init__(self, base: ObstacleField, centers: np.ndarray, radii: np.ndarray):
        self.base, self.static = base, base.static
        self.centers = np.asarray(centers, dtype=float).reshape(-1, 2)
        self.radii = np.asarray(radii, dtype=float).reshape(-1)
        self.n_static = base.n_static
        self.n = base.n + len(self.radii)

    def nearest(self, points: np.ndarray, t: float = 0.0,
                max_range: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`ObstacleField.nearest` with the robot discs appended (same conventions)."""
        near, dist = self.base.nearest(points, t, max_range)
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        rn, rd = disc_nearest(pts, self.centers, self.radii, max_range)
        return np.concatenate([near, rn], axis=1), np.concatenate([dist, rd], axis=1)


# --------------------------------------------------------------------------------------
# shared solve(): simulate every planned robot with its own controller
# --------------------------------------------------------------------------------------


class _TeamPolicy:
    """The simulator's policy of :func:`run_local_planner`: every robot not yet at its goal
    (nor stopped) moves by its controller; with ``sense_robots`` it senses the other robots
    as discs where they are now.  A robot whose controller gives up (``None``) stops; the run
    ends when every robot is at its goal or stopped."""

    def __init__(self, ctrls: list[APFController], goals: np.ndarray, tols: np.ndarray,
                 radii: np.ndarray, sense_robots: bool, guard: StepGuard):
        self.ctrls, self.goals, self.tols, self.radii = ctrls, goals, tols, radii
        self.sense_robots = sense_robots
        self.guard = guard
        self.stopped = np.zeros(len(ctrls), bool)

    def at_goal(self, pos: np.ndarray) -> np.ndarray:
        return np.hypot(*(pos - self.goals).T) <= self.tols

    def done(self, state: SimState) -> bool:
        return bool(np.all(self.at_goal(state.positions) | self.stopped))

    def _seen(self, state: SimState, i: int) -> SimState:
        """What robot ``i`` senses: the state, with the other robots as discs."""
        if not self.sense_robots:
            return state
        o = np.arange(len(self.ctrls)) != i
        return dataclasses.replace(state, field=RobotsAsObstacles(
            state.field, state.positions[o], self.radii[o]))

    def __call__(self, state: SimState) -> np.ndarray | None:
        out = np.zeros((len(self.ctrls), 2))
        reached = self.at_goal(state.positions)
        for i, c in enumerate(self.ctrls):
            if reached[i] or self.stopped[i]:
                continue
            v = c.velocity(self._seen(state, i), i)
            if v is None:
                self.stopped[i] = True
            else:
                out[i] = v
        if np.all(self.stopped | reached) and np.any(self.stopped):
            return None
        if self.guard.check(state.positions, out, state.dt, state.t, ~(reached | self.stopped)):
            return None  # a step would cross a static obstacle: the run ends in a collision
        return out

    def cost(self, state: SimState) -> float:
        return float(np.max(np.hypot(*(state.positions - self.goals).T)))


def run_local_planner(backend: PotentialFieldBackend, problem: Problem, rng: np.random.Generator,
                      callback: Callable[[Progress], Any] | None) -> Any:
    """Simulate ``problem.planned_robots`` with ``backend``'s controllers; build the Result."""
    t_start = time.perf_counter()
    robots = problem.planned_robots
    ids = [r.id for r in robots]
    ctrls = [backend.controller(problem, r.id, rng) for r in robots]
    goals = np.array([r.goal for r in robots], dtype=float)
    tols = np.array([problem.goal_tol(r) for r in robots])
    dt = backend.dt
    fld = ObstacleField(problem)
    radii = np.array([r.radius for r in robots], dtype=float)
    policy = _TeamPolicy(ctrls, goals, tols, radii, backend.sense_robots and len(robots) > 1,
                         StepGuard(problem, robots))
    try:
        out = simulate(problem, policy, ids=ids, dt=dt, max_steps=backend.max_steps,
                       done=policy.done, setup=SimSetup(field=fld), callback=callback,
                       progress_cost=policy.cost)
    except (FloatingPointError, np.linalg.LinAlgError) as e:  # numerical failure -> failed
        starts = {r.id: np.vstack([r.start, r.start]) for r in robots}
        return backend.finish(problem, starts, claim=Status.failed, times=np.array([0.0, dt]),
                              message=f"numerical failure: {e}",
                              wall_time=time.perf_counter() - t_start)
    paths = out.paths()
    reached = policy.at_goal(out.positions[-1])
    claim, msg = _local_outcome(out, bool(np.all(reached)), ids, ctrls, backend.max_steps,
                                policy.guard.collision)
    lead = problem.leader.id if problem.leader.id in paths else ids[0]
    li = ids.index(lead)
    t_goal = _time_to_goal(out, li, goals[li], tols[li]) if reached[li] else float("nan")
    unit = problem.length_scale
    extras = _local_extras(out, ids, ctrls, unit)
    extras["collision"] = policy.guard.collision or out.collision
    # the backend's own measures of the leader's trajectory (the validator's are the metrics)
    extras.update(time_to_goal=t_goal, oscillation_index=oscillation_index(paths[lead], unit))
    return backend.finish(problem, paths, claim=claim, times=out.times,
                          cost=float(path_lengths(paths[lead])),
                          message=msg, n_iter=int(out.steps), n_eval=int(out.steps),
                          history=_trace_history(ctrls[li].trace, dt), extras=extras,
                          wall_time=time.perf_counter() - t_start)


def _time_to_goal(out: Any, i: int, goal: np.ndarray, tol: float) -> float:
    """Simulated time at which robot ``i`` first came within ``tol`` of its goal."""
    dg = np.hypot(*(out.positions[:, i, :] - goal).T)
    return float(out.times[int(np.argmax(dg <= tol))])


def _local_extras(out: Any, ids: list[str], ctrls: list[APFController],
                  unit: float) -> dict[str, Any]:
    """The result's extras (units: :data:`EXTRAS_UNITS`) but the leader's ``time_to_goal``
    and ``oscillation_index``: the controllers' detection counts and statistics, the run."""
    detections = {k: int(sum(c.stats["detections"][k] for c in ctrls))
                  for k in ("eq38", "stall", "oscillation")}
    return {
        "local_minima_detected": int(sum(c.stats["local_minima_detected"] for c in ctrls)),
        "detections": detections,
        "local_minima_escaped": int(sum(c.stats["escapes"] for c in ctrls)),
        "sa_steps": int(sum(c.stats["sa_steps"] for c in ctrls)),
        "sim_steps": int(out.steps),
        "sim_reason": out.reason,
        "length_scale": unit,
        "controllers": {ids[i]: c.stats for i, c in enumerate(ctrls)},
        "minima": {ids[i]: [m.tolist() for m in c.minima] for i, c in enumerate(ctrls)},
        "collision": out.collision,
    }


def _local_outcome(out: Any, reached: bool, ids: list[str], ctrls: list[APFController],
                   max_steps: int, swept: str = "") -> tuple[Status, str]:
    """The claimed status and the message of a finished local-planner simulation
    (``swept``: the step the :class:`~optplan.potential.swept.StepGuard` refused)."""
    if swept:
        return Status.failed, f"collision: {swept}"
    if out.reason == "collision":
        return Status.failed, f"collision: {out.collision}"
    if out.reason == "done" and reached:
        return Status.solved, "goal reached"
    if out.reason == "callback":
        return Status.approximate, "stopped by the callback"
    if out.reason == "budget":
        return Status.approximate, f"step budget ({max_steps}) exhausted"
    why = "; ".join(f"{ids[i]}: {c.stats['gave_up']}" for i, c in enumerate(ctrls)
                    if c.stats["gave_up"])
    return Status.approximate, f"gave up: {why}"


def _trace_history(tr: Trace, dt: float) -> History:
    """The controller's per-step trace as the result's history."""
    hist = History()
    for k in range(len(tr.force)):
        hist.append(iteration=k, best_cost=tr.potential[k], n_eval=k + 1,
                    time=k * dt, force=tr.force[k], potential=tr.potential[k],
                    temperature=tr.temperature[k], sa=tr.mode[k] != "apf")
    return hist


# --------------------------------------------------------------------------------------
# the shared backend
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class PotentialFieldBackend(Backend):
    """Options shared by ``apf`` and ``sa-apf`` (the time-stepping potential-field planners).

    Lengths marked "(x length_scale)" are multiples of the problem's length unit
    :attr:`optplan.problem.Problem.length_scale` (1 on the paper's maps); the potential is
    evaluated on positions divided by it (:class:`FieldParams`), so a preset behaves the same
    on a scene drawn in centimetres, metres or kilometres.

    Parameters
    ----------
    k : float
        Attraction gain (eq 4), force per length unit of goal distance.  Paper: 15.
    eta : float
        Repulsion gain (eq 5 for ``apf``, eq 34 for ``sa-apf``), per length unit.  Paper: 3.7.
    rho_0 : float
        Obstacle influence distance (eq 5 / 34), measured as clearance from the robot disc
        (x length_scale).  Paper: 20.
    l : float or None
        Step length per time step (eq 13, x length_scale); ``None`` = the robot's
        ``max_speed * dt`` (``dt`` of the simulation that runs the controller).
    dt : float
        Time step of the planner's own simulation, s.
    max_steps : int
        Step budget of the simulation (the run never hangs).
    rho_min : float
        Clamp of the clearance in eqs 5-6 / 34-37 so forces stay finite (x length_scale;
        at most ``rho_0``).
    sense_range : float or None
        Sensing range measured from the robot centre (x length_scale); ``None`` = the
        scenario's ``[sensing]`` range, else ``rho_0 + radius``.
    window : int
        Steps in the stall / oscillation window of the local-minimum detection.
    stall_ratio : float
        Stall when the net displacement over ``window`` steps is below
        ``stall_ratio * window * l`` (dimensionless).
    n_probe : int
        Probe directions on each circle of the reachable region ``R(p)`` (eq 38).
    detect_eq38 : bool
        Use the eq 38 test (the stall and oscillation tests are always on).
    evade_factor : float
        Moving-obstacle safety step when a dynamic obstacle is closer than ``evade_factor * l``
        (:meth:`APFController.evade`); ``0`` disables it (dimensionless).
    sense_robots : bool
        Beyond the paper: with several planned robots (no formation), each senses the others
        as disc obstacles at their current positions (:class:`RobotsAsObstacles`); without
        it they drive through each other.  No effect with one planned robot.
    safe_step : bool
        Beyond the paper (``False`` in the ``-paper`` presets): a step whose straight segment
        is not free (exact test) is replaced by its slide along the nearest obstacle or its
        clip to the bounds, halved until free
        (:meth:`~optplan.potential.controller.APFController.free_step`), so the robot never
        enters an obstacle.
    guide : {"none", "visgraph"}
        Beyond the paper (``"none"`` in the ``-paper`` presets): ``"visgraph"`` drives the
        field toward the farthest visible vertex of the exact shortest path on the known map
        (:mod:`optplan.potential.guide`).
    """

    k: float = option(15.0, lo=0.0, lo_open=True)
    eta: float = option(3.7, lo=0.0)
    rho_0: float = option(20.0, lo=0.0, lo_open=True, scale=True)
    l: float | None = option(None, lo=0.0, lo_open=True, scale=True)
    dt: float = option(0.2, lo=0.0, hi=60.0, lo_open=True)
    max_steps: int = option(3000, lo=1, hi=10_000_000)
    rho_min: float = option(0.05, lo=0.0, lo_open=True, scale=True)
    sense_range: float | None = option(None, lo=0.0, lo_open=True, scale=True)
    window: int = option(16, lo=4, hi=10_000)
    stall_ratio: float = option(0.15, lo=0.0, hi=1.0, lo_open=True)
    n_probe: int = option(16, lo=3, hi=360)
    detect_eq38: bool = option(True)
    evade_factor: float = option(0.0, lo=0.0, hi=100.0)
    sense_robots: bool = option(True)
    safe_step: bool = option(False)
    guide: str = option("none", choices=("none", "visgraph"))

    #: The units of the controllers' ``stats`` (:class:`~optplan.interfaces.LocalPlanner`).
    stats_units: ClassVar[Record] = STATS_UNITS
    #: The units of the result's extras (:mod:`optplan.units`).
    extras_units: ClassVar[Record] = EXTRAS_UNITS

    if TYPE_CHECKING:  # each planner (APF, SAAPF) defines it (LocalPlanner)
        def controller(self, problem: Problem, robot_id: str, rng: np.random.Generator
                       ) -> APFController: ...

    def check(self) -> None:
        if self.rho_min > self.rho_0:
            raise ValueError(f"option 'rho_min' of backend {self.name!r} must be <= rho_0 "
                             f"({self.rho_0!r}), got {self.rho_min!r}")

    def sensing(self, problem: Problem, robot: Robot) -> float:
        """Sensing range from the robot centre, map units: the option (x length_scale), the
        scenario's ``[sensing]`` range, else ``rho_0 * length_scale + radius``."""
        s = problem.length_scale
        if self.sense_range is not None:
            return float(self.sense_range * s)
        if problem.sensing_range is not None:
            return float(problem.sensing_range)
        return float(self.rho_0 * s + robot.radius)

    def _params(self, problem: Problem, robot: Robot, eta: float, n: float) -> FieldParams:
        s = problem.length_scale
        return FieldParams(self.k, eta, self.rho_0 * s, n, self.rho_min * s, robot.radius,
                           self.sensing(problem, robot), s)

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None):
        gen = make_rng(rng)[0]
        return run_local_planner(self, problem, gen, callback)
