r"""Hybrid planner: global path -> inflection points -> local planning -> formation (paper §V).

The paper's six steps (§V, Fig. 15) and how this backend realises them:

1. *Map.*  The scenario is the map; the global planner sees only ``problem.known_view()``
   (known static obstacles), the local planner senses everything (known, temporary and moving
   obstacles) through the simulator's :class:`~optplan.sim.ObstacleField`.
2. *Formation control.*  Followers are driven by the ``formation`` stage's
   ``followers_controller`` (a :class:`~optplan.interfaces.FormationBackend`: leader-follower
   L-phi with active avoidance, or the formation QP); ``formation = ""`` runs the leader alone.
3. *Global path.*  The ``global_solver`` stage's ``solve(problem.known_view())`` (IPSO in the
   paper, any path solver here).  An ``init`` path for a robot replaces this stage.
4. *Inflection points.*  :func:`inflection_points` scans the global path and keeps the vertices
   where it turns by more than ``angle_tol`` degrees; they become the sub-goals, followed by the
   final goal (:func:`subgoals`).
5. *Local planning.*  The leader is driven toward the current sub-goal by the
   ``local_solver`` stage's ``controller(problem, leader, rng)`` (a
   :class:`~optplan.interfaces.LocalPlanner`; SA-APF in the paper): the controller's
   ``velocity(state, index)`` is evaluated at every simulator step; the followers keep the
   formation around the leader at the same time, in one :func:`optplan.sim.simulate` run (the
   leader's command reaches their controller as ``state.leader_velocity``).

The stages are resolved when the backend is built (:attr:`Hybrid.stages`).
6. *Replanning.*  When the leader comes within ``reach_tol`` of an intermediate sub-goal the
   controller is ``reset`` to the next one; the run ends when the final goal is reached (and the
   followers have settled in their slots), on a collision, when the local planner gives up at
   the final goal, or at the step budget.

Inflection points (step 4) are defined in :mod:`optplan.hybrid.subgoals`.


Choices where the paper is silent (documented in ``docs/solvers/hybrid.md``)
---------------------------------------------------------------------------
* A sub-goal is *reached* within ``reach_tol`` (default ``max(2 r, 2 v_max dt)``); the final
  goal within the scenario's goal tolerance.
* An intermediate sub-goal that lies inside a sensed temporary obstacle (distance to it below
  the robot radius, so the sub-goal is not a feasible position) is skipped as soon as the robot
  senses it; so is one the leader makes no progress toward for ``stall_steps`` steps, and one
  at which the local planner gives up.  At the final goal, giving up ends the run
  (status ``approximate``).
* The leader heading given to the formation controller is the direction of the leader's last
  non-zero commanded velocity; once the leader is at its goal it stops (zero velocity), and the
  run continues for at most ``settle_steps`` steps until every follower is within
  ``settle_tol`` (fraction of its ``L``) of its slot.

Modules: :mod:`optplan.hybrid.subgoals` (step 4), :mod:`optplan.hybrid.stages` (step 3),
:mod:`optplan.hybrid.policy` (steps 2 and 5), :mod:`optplan.hybrid.tracker` (step 6),
:mod:`optplan.hybrid.answer` (the result, in world units) and this module (the backend).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.canonical import canonical_problem, to_canonical
from optplan.hybrid.answer import (
    assemble,
    early_answer,
    extras_units,
    long_path_note,
    world_answer,
)
from optplan.hybrid.policy import HybridPolicy, Team
from optplan.hybrid.stages import StageCallback, global_stage
from optplan.hybrid.subgoals import subgoals
from optplan.hybrid.tracker import Driver, SubgoalTracker
from optplan.interfaces import (
    FORMATION_BACKEND,
    LOCAL_PLANNER,
    PATH_SOLVER,
    resolve_stage,
    stage_name,
)
from optplan.options import option
from optplan.problem import Problem
from optplan.result import Progress, Result, Status
from optplan.sim import SimSetup, simulate
from optplan.solver import Backend, make_rng
from optplan.units import Record

__all__ = ["Hybrid"]


@dataclass(frozen=True, kw_only=True)
class Hybrid(Backend):
    r"""Hybrid planner of paper §V (Fig. 15): global path, inflection points, local planning.

    Parameters
    ----------
    global_solver : str or Backend
        Preset (or backend) planning each driving robot's path on ``problem.known_view()``
        (step 3): any solver (:data:`optplan.interfaces.PATH_SOLVER`).  Paper: IPSO; default
        ``"ipso"``, the documented variant, because the literal ``"ipso-paper"`` (eq 24) is
        not collision-free in every run (counts on the hybrid page).
    local_solver : str or Backend
        A :class:`~optplan.interfaces.LocalPlanner` whose ``controller(problem, robot_id,
        rng)`` drives the leader between sub-goals (step 5).  Paper: SA-APF,
        ``"sa-apf-paper"``.
    formation : str or Backend
        A :class:`~optplan.interfaces.FormationBackend` whose ``followers_controller(problem,
        rng)`` drives the followers (step 2/5): ``"leader-follower-paper"`` (paper),
        ``"formation-qp"``, or ``""`` to run the leader(s) alone.  Ignored for problems without
        a ``[formation]``.
    angle_tol : float
        Inflection-point tolerance :math:`\theta_{tol}` (degrees, ``[0, 180)``): a vertex of the
        global path is a sub-goal when the path turns there by more than this (step 4; see
        :func:`inflection_points`).
    leader_rho_0 : float or None
        Influence distance of the leader's local planner (x length_scale): replaces the
        ``local_solver``'s ``rho_0``.  ``None`` keeps the local planner's own (``sa-apf-paper``:
        20, eq 34); the paper's formation pilot (eq 41) uses 100.
    subgoal_spacing : float
        ``0`` (paper): the sub-goals are the inflection points and the goal.  ``> 0`` (an
        option beyond the paper): also split every leg between sub-goals into pieces no longer
        than this (x length_scale), see :func:`subgoals`.
    dt : float
        Simulation time step (s), ``(0, 10]``.
    max_steps : int
        Step budget of the whole run (including follower settling).
    reach_tol : float
        Distance (x length_scale) at which an intermediate sub-goal counts as reached (step 6);
        ``0`` means automatic, ``max(2 r, 2 v_max dt)`` with ``r``, ``v_max`` the robot's radius
        and speed.  The final goal uses the scenario's goal tolerance.
    reach_visible : bool
        ``False`` (paper): an intermediate sub-goal is reached within ``reach_tol``.  ``True``
        (beyond the paper): also require the straight segment to the next sub-goal to be clear
        of the known static obstacles, so the leader does not turn toward the next sub-goal
        before it has rounded the corner (the stall rule still skips it).
    stall_steps : int
        Skip an intermediate sub-goal after this many steps without getting closer to it by at
        least a tenth of the robot radius (``0`` disables; choice beyond the paper).
    skip_blocked : bool
        Skip an intermediate sub-goal found (by sensing) to lie inside a temporary obstacle.
    settle_steps : int
        Extra steps allowed, after the leader reached its goal, for the followers to settle.
    v_factor : float
        With followers, the leader's speed is capped at ``v_factor * max_speed`` so the
        followers have speed headroom to hold their slots in turns (``(0, 1]``; the same
        convention as the formation backends).  Without followers the leader uses its full
        speed.
    heading_rate : float
        ``0`` (paper): the formation frame turns with the leader's velocity direction at once.
        ``> 0`` (beyond the paper): the heading passed to the formation controller turns at
        most this fast (rad/s), so the slots swing round smoothly at sharp turns.
    settle_tol : float
        A follower has settled when within ``settle_tol * L`` of its slot (``(0, 1]``; a
        fraction of the formation distance ``L``, so it scales with the scene).
    stop_on_collision : bool
        Stop the simulation at the first contact (the result is then ``approximate``).
    time_limit : float or None
        Wall-clock budget of the whole run (s; ``None`` or ``inf``: none).  Every stage
        reports its progress to the run's callback (the global solver every iteration, the
        simulation, i.e. the local planner and the formation, every step), which stops the run
        at the first report after the limit: the result is graded as it stands (``solved``
        only when what was driven is feasible and reached the goal, else ``approximate``),
        its ``stop_reason`` is ``"time_limit"`` and its message says so.  The presets: 60.
    leader_safe_step : bool or None
        ``None`` keeps the local planner's own ``safe_step``; ``True`` (beyond the paper;
        ``hybrid-qp``, ``hybrid-guided``) makes the leader's local planner test each step
        exactly and slide it along the obstacle or clip it to the bounds instead of taking a
        step the step guard would stop the run at.

    Notes
    -----
    The three stage options are resolved when the backend is built (:attr:`stages`): a name
    that is no solver, or names a solver of the wrong kind (e.g. ``local_solver =
    "visgraph"``), raises ``ValueError`` naming the option, the kind expected and close
    matches.
    """

    name: ClassVar[str] = "hybrid"

    global_solver: Any = option("ipso", kind="any")
    local_solver: Any = option("sa-apf-paper", kind="any")
    formation: Any = option("leader-follower-paper", kind="any")
    leader_rho_0: float | None = option(None, lo=0.0, lo_open=True, scale=True)
    angle_tol: float = option(10.0, lo=0.0, hi=180.0, hi_open=True)
    subgoal_spacing: float = option(0.0, lo=0.0, scale=True)
    dt: float = option(0.1, lo=0.0, hi=10.0, lo_open=True)
    max_steps: int = option(20000, lo=1, hi=10_000_000)
    reach_tol: float = option(0.0, lo=0.0, scale=True)
    reach_visible: bool = option(False)
    stall_steps: int = option(300, lo=0, hi=10_000_000)
    skip_blocked: bool = option(True)
    settle_steps: int = option(400, lo=0, hi=10_000_000)
    settle_tol: float = option(0.1, lo=0.0, hi=1.0, lo_open=True)
    v_factor: float = option(0.75, lo=0.0, hi=1.0, lo_open=True)
    heading_rate: float = option(0.0, lo=0.0)
    stop_on_collision: bool = option(True)
    time_limit: float | None = option(60.0, lo=0.0, lo_open=True, inf_ok=True, none_ok=True)
    leader_safe_step: bool | None = option(None, kind="bool", none_ok=True)
    _stages: dict[str, Any] | None = field(init=False, repr=False, compare=False, default=None)

    def check(self) -> None:
        """Resolve the three stages (names of the wrong kind raise ``ValueError``) and check
        that ``leader_rho_0`` and ``leader_safe_step`` can be applied to the local planner."""
        local = resolve_stage(self.name, "local_solver", self.local_solver, LOCAL_PLANNER)
        for opt, field_name, value in (
                ("leader_rho_0", "rho_0", None if self.leader_rho_0 is None
                 else float(self.leader_rho_0)),
                ("leader_safe_step", "safe_step", self.leader_safe_step)):
            if value is not None:
                local = self._leader_field(local, opt, field_name, value)
        stages = {
            "global_solver": resolve_stage(self.name, "global_solver", self.global_solver,
                                           PATH_SOLVER),
            "local_solver": local,
            "formation": (None if isinstance(self.formation, str) and self.formation == ""
                          else resolve_stage(self.name, "formation", self.formation,
                                             FORMATION_BACKEND)),
        }
        object.__setattr__(self, "_stages", stages)

    def _leader_field(self, local: Any, opt: str, name: str, value: Any) -> Any:
        """The local planner ``local`` with its option ``name`` set to ``value`` (the hybrid's
        option ``opt``); ``ValueError`` when it has no such option or rejects the value."""
        if not hasattr(local, name):
            raise ValueError(f"option {opt!r} of backend 'hybrid': the local planner "
                             f"{stage_name(self.local_solver)!r} has no option {name!r} "
                             f"(set {opt} = None to use it as it is)")
        try:
            out = dataclasses.replace(local, **{name: value})
        except ValueError as e:
            raise ValueError(f"option {opt!r} of backend 'hybrid': {e}") from None
        object.__setattr__(out, "_preset", getattr(local, "_preset", None))
        return out

    @property
    def stages(self) -> dict[str, Any]:
        """The resolved stages: ``global_solver`` (Backend), ``local_solver``
        (:class:`~optplan.interfaces.LocalPlanner`) and ``formation``
        (:class:`~optplan.interfaces.FormationBackend`, or None for ``formation = ""``)."""
        if self._stages is None:  # check() runs in __post_init__, so only if it was bypassed
            raise RuntimeError(f"{self.name}: the stages are not resolved (check() has not run)")
        return self._stages

    @property
    def extras_units(self) -> Record:
        """The units of the result's extras (:func:`~optplan.hybrid.answer.extras_units`,
        :mod:`optplan.units`), with the stages' declared ``stats_units``."""
        form = self.stages["formation"]
        return extras_units(self.stages["local_solver"].stats_units,
                            form.stats_units if form is not None else Record({}))

    def options(self) -> dict[str, Any]:
        out = super().options()
        for k in ("global_solver", "local_solver", "formation"):
            out[k] = stage_name(out[k])
        return out

    # ---------------------------------------------------------------------------------
    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t_start = time.perf_counter()
        world, problem = problem, canonical_problem(problem)
        rng = make_rng(rng)[0]
        rng_global, rng_local, rng_form = rng.spawn(3)
        cb = StageCallback(callback, problem.world_unit, self.time_limit)
        team = self._team(problem)
        if init:
            init = {k: to_canonical(problem, v) for k, v in init.items()}
        glob = global_stage(self, problem, team, init, rng_global, cb, t_start)
        if isinstance(glob, dict):
            return self._world_result(world, problem, glob, cb)
        drivers = self._drivers(problem, team, glob.paths, rng_local)
        fctrl = (self.stages["formation"].followers_controller(problem, rng_form)
                 if team.use_formation else None)
        tracker = SubgoalTracker(drivers, skip_blocked=self.skip_blocked,
                                 stall_steps=self.stall_steps, sensing=problem.sensing_range,
                                 reach_visible=self.reach_visible, unit=problem.length_scale)
        policy = HybridPolicy(self, problem, team, drivers, tracker, fctrl)
        try:
            out = simulate(problem, policy, ids=team.ids, dt=self.dt, max_steps=self.max_steps,
                           done=policy.done,
                           setup=SimSetup(stop_on_collision=self.stop_on_collision),
                           callback=cb.forward, progress_cost=policy.progress_cost)
        except (np.linalg.LinAlgError, FloatingPointError, ArithmeticError) as e:
            answer = early_answer(problem, team.ids, glob.result,
                                  f"numerical failure in the simulation: {e}", t_start,
                                  self.angle_tol, Status.failed)
        else:
            answer = assemble(self, glob, policy, out, t_start, cb.stop_text())
        return self._world_result(world, problem, answer, cb)

    def _world_result(self, world: Problem, image: Problem, answer: dict[str, Any],
                      cb: StageCallback) -> Result:
        """The answer planned on the canonical ``image`` mapped back to ``world`` (x its unit;
        each path starts at the robot's exact start) and graded there by the validator; a
        successful path far longer than the certified optimum says so in the message
        (:func:`~optplan.hybrid.answer.long_path_note`), a run stopped by the time limit in
        its ``stop_reason``."""
        paths, kwargs = world_answer(world, image, answer, self.extras_units)
        res = self.finish(world, paths, **kwargs)
        note = long_path_note(world, res)
        if note:
            res = dataclasses.replace(res, message="; ".join(m for m in (res.message, note) if m))
        return dataclasses.replace(res, stop_reason=cb.stop_reason)

    # -- which robots drive themselves, which follow -----------------------------------
    def _team(self, problem: Problem) -> Team:
        form = problem.formation
        use = bool(form is not None and self.stages["formation"] is not None)
        follower_ids = [f.id for f in form.followers] if form is not None else []
        drivers = [r for r in problem.robots if r.id not in follower_ids and r.goal is not None]
        if form is not None and not use:
            drivers = [problem.leader]
        ids = [r.id for r in drivers] + (follower_ids if use else [])
        return Team(drivers, follower_ids if use else [], ids, use)



    # -- step 4: inflection points -> sub-goals, one local controller per driver -------
    def _drivers(self, problem: Problem, team: Team, gpaths: dict[str, np.ndarray],
                 rng: np.random.Generator) -> list[Driver]:
        planner = self.stages["local_solver"]
        rngs = rng.spawn(len(team.drivers))
        drivers = []
        for i, r in enumerate(team.drivers):
            if r.goal is None:  # drivers are robots with a goal (_team; the leader has one)
                raise ValueError(f"{self.name}: robot {r.id!r} drives itself but has no goal")
            goals = subgoals(gpaths[r.id], r.goal, self.angle_tol,
                             self.subgoal_spacing * problem.length_scale)
            ctrl = planner.controller(problem, r.id, rngs[i])
            ctrl.reset(goals[0].copy())
            reach = (self.reach_tol * problem.length_scale
                     or max(2.0 * r.radius, 2.0 * r.max_speed * self.dt))
            g = r.goal - r.start
            drivers.append(Driver(team.ids.index(r.id), r, goals, ctrl, reach,
                                   problem.goal_tol(r), heading=float(math.atan2(g[1], g[0]))))
        return drivers

