"""Backend ``formation-nlp``: the whole manoeuvre of a team as one trajectory optimisation.

A local optimum of "arrival time + weighted formation error" over the positions of the leader
and every follower on a time grid, under speed limits, exact static-obstacle constraints,
moving obstacles at their known motion and robot-robot separation (the model:
:mod:`optplan.formation.team_nlp`; docs/solvers/formation-nlp.md).  IPOPT is local: the result
depends on the warm start, by default the ``hybrid-qp`` plan of the same problem (option
``warm_start``), or the paths given by ``init=`` (timed at uniform steps up to the slowest
robot's path time).  The status is ``solved`` with "locally optimal" in the message (never
``optimal``), when the exact continuous-time validator accepts the plan and it is no worse than
its warm start in arrival and formation error; otherwise the warm start is kept and the message
says why.  ``time_limit`` (default 60 s) bounds the whole run on :data:`optplan.solver.clock`
(the warm-start planner and IPOPT, polled at every one of their progress reports).

The candidates of the team reference (:mod:`optplan.team_grading`) are built here
(:meth:`FormationNLP.team_candidates`): the team heuristics of :data:`TEAM_HEURISTICS`, each
run with the seed :data:`REFERENCE_SEED`, and the NLP polished from each of them.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan import solver as registry
from optplan.deadline import Deadline
from optplan.exact.nlp import IterProgress
from optplan.exact.nlp_pieces import SAFETY_REL, obstacle_pieces
from optplan.formation.team_nlp import MoverTable, TeamModel, solve_team_nlp
from optplan.geometry.timing import arrival_time, mover_track, positions_at
from optplan.problem import Problem
from optplan.result import History, Progress, Result, Status
from optplan.solver import Backend, get_solver, option, without_own_limit
from optplan.units import Record, Unit

__all__ = ["FormationNLP", "Warm", "TEAM_HEURISTICS", "REFERENCE_SEED", "warm_from_result"]

#: The team heuristics (presets) whose plans, and the NLP polished from each, are the candidates
#: of the team reference (:meth:`FormationNLP.team_candidates`); one not installed is left out.
TEAM_HEURISTICS = ("formation-qp", "leader-follower-paper", "hybrid-qp", "orca-team")
#: The seed (``rng``) of every team heuristic's run in the team reference.
REFERENCE_SEED = 0


@dataclass(frozen=True)
class Warm:
    """A team plan to start from: synchronised ``paths`` at ``times``, its arrival ``T0``."""

    paths: dict[str, np.ndarray]
    times: np.ndarray
    T0: float
    metrics: dict[str, Any]


@dataclass(frozen=True, kw_only=True)
class FormationNLP(Backend):
    """Joint trajectory NLP of a formation (module docstring).

    Parameters
    ----------
    n_steps : int
        Grid intervals ``N`` of the time grid (in [2, 2000], default 60).
    w_formation : float
        Weight of the mean squared slot error (relative to the mean slot distance squared)
        against the arrival time (relative to the warm start's); in [0, 1e6], default 100
        (a follower 10 % of its slot distance off its slot for the whole run costs as much as
        arriving 1 % later).
    warm_start : str
        The team planner (preset) whose plan starts IPOPT when no ``init`` is given (default
        ``hybrid-qp``).
    prune : float
        Static (robot, step, piece) pairs and moving-obstacle intervals within this fraction
        of the map diagonal of the warm start are constrained (in (0, 1], default 0.05).
    t_max : float
        Largest arrival, in multiples of the warm start's (in [1, 100], default 2).
    max_iter : int
        IPOPT's iteration limit (default 3000).
    tol : float
        IPOPT's convergence tolerance and constraint violation tolerance (default 1e-6).
    mu_strategy : str
        IPOPT's barrier update, ``"adaptive"`` (default: on ``paper-warehouse`` 42 iterations
        against 1,001 with ``"monotone"``, IPOPT's own default) or ``"monotone"``.
    time_limit : float or None
        Wall-clock budget of the whole run in seconds (> 0; ``None`` or ``inf``: none; default
        60), on :data:`optplan.solver.clock`: the warm-start planner stops at its first
        progress report after it (its plan is then returned as it is, not polished; the
        warm start's own preset limit, e.g. ``hybrid-qp``'s 60 s, is replaced by this one:
        :func:`optplan.solver.without_own_limit`) and IPOPT
        at its first iteration after it, its last iterate judged like any other (the warm
        start is kept when the iterate is invalid or worse); ``stop_reason`` is then
        ``"time_limit"``.  Building the CasADi model (before the first iteration) is not
        interrupted.  ``op.solve(time_limit=...)`` replaces it.
    """

    name: ClassVar[str] = "formation-nlp"
    #: the units of the extras (:mod:`optplan.units`)
    extras_units: ClassVar[Record] = Record({
        "ipopt": Record({"return_status": Unit.TEXT, "success": Unit.DIMENSIONLESS,
                         "static_pairs": Unit.DIMENSIONLESS, "mover_rows": Unit.DIMENSIONLESS}),
        "warm_arrival": Unit.TIME, "kept_warm_start": Unit.DIMENSIONLESS})
    n_steps: int = option(60, lo=2, hi=2000)
    w_formation: float = option(100.0, lo=0.0, hi=1e6)
    warm_start: str = option("hybrid-qp", kind="str")
    prune: float = option(0.05, lo=0.0, lo_open=True, hi=1.0)
    t_max: float = option(2.0, lo=1.0, hi=100.0)
    max_iter: int = option(3000, lo=1, hi=100_000)
    tol: float = option(1e-6, lo=1e-12, hi=1e-2)
    mu_strategy: str = option("adaptive", choices=("adaptive", "monotone"))
    time_limit: float | None = option(60.0, lo=0.0, lo_open=True, inf_ok=True, none_ok=True)

    def check(self) -> None:
        """``warm_start`` names a registered team planner other than this one."""
        if self.warm_start in (self.name, self.preset or self.name):
            raise ValueError(f"warm_start = {self.warm_start!r}: the NLP cannot start from "
                             "itself (use a team planner such as 'hybrid-qp')")
        try:
            get_solver(self.warm_start)
        except (ValueError, ImportError) as e:
            raise ValueError(f"warm_start = {self.warm_start!r}: not a solver ({e})") from None

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t0 = time.perf_counter()
        limit = Deadline(callback, self.time_limit)
        why = _unsupported(problem)
        if why:
            return self._give_up(problem, why, t0)
        if init is not None:
            warm = _warm_from_paths(problem, init)
        else:
            # the run's limit bounds the warm start (the deadline, and op.solve's, stop it),
            # not the warm start's own preset limit (hybrid-qp: 60 s); None: no bound
            own = math.inf if self.time_limit is None else self.time_limit
            ws = without_own_limit(get_solver(self.warm_start), own)
            res = ws.solve(problem, rng=rng, callback=limit.forward)
            warm = warm_from_result(problem, res)
            if limit.stopped or res.stop_reason:  # cut short: no time left to polish it
                return self._unpolished(problem, warm, limit, res.stop_reason, t0)
        if warm is None:
            return self._give_up(problem, f"the warm start ({self.warm_start}) gives no "
                                 "synchronised team plan that reaches the goal", t0)
        return self._polish(problem, warm, t0, limit)

    def polish(self, problem: Problem, warm: Warm, t0: float | None = None, *,
               callback: Callable[[Progress], Any] | None = None) -> Result:
        """Solve the NLP from ``warm`` and grade it (the kept warm start when it is better).

        ``callback`` receives IPOPT's iterations as :class:`~optplan.result.Progress`
        (``info["objective"]``); raising ``StopIteration`` stops IPOPT at its last iterate,
        which is then judged like any other (the warm start is kept when it is better).  The
        ``time_limit`` runs from this call.
        """
        t0 = time.perf_counter() if t0 is None else t0
        return self._polish(problem, warm, t0, Deadline(callback, self.time_limit))

    def _polish(self, problem: Problem, warm: Warm, t0: float, limit: Deadline) -> Result:
        """:meth:`polish` within ``limit`` (the run's deadline and callback)."""
        model, ids = self._model(problem, warm)
        ipopt = {"max_iter": int(self.max_iter), "tol": float(self.tol), "print_level": 0,
                 "sb": "yes", "mu_strategy": self.mu_strategy,
                 "constr_viol_tol": float(self.tol)}
        prog = IterProgress(limit.forward, t0)
        prog.best = warm.T0  # the arrival to beat
        X, T, info = solve_team_nlp(model, ipopt, prog if limit.forward is not None else None)
        if prog.raised:
            raise prog.raised[0]
        frame = problem.frame
        paths = {rid: frame.world(X[k] * model.scale) for k, rid in enumerate(ids)}
        times = np.linspace(0.0, T * warm.T0, self.n_steps + 1)
        n_iter = int(info.pop("iter_count"))
        res = self.finish(problem, paths, claim=Status.solved if info["success"] else
                          Status.approximate, times=times, cost=T * warm.T0,
                          message="", n_iter=n_iter, n_eval=n_iter, history=History(),
                          extras={"ipopt": info, "warm_arrival": warm.T0},
                          wall_time=time.perf_counter() - t0)
        return limit.mark(self._judged(problem, res, warm, dict(info, iter_count=n_iter), t0))

    def reference(self, problem: Problem, res: Result) -> Result:
        """The NLP warm-started from the plan ``res`` (its result, or ``res`` graded again
        when it is no synchronised team plan that arrives): one candidate of the team
        reference (:meth:`team_candidates`)."""
        t0 = time.perf_counter()
        why = _unsupported(problem)
        warm = None if why else warm_from_result(problem, res)
        if warm is None:
            return self._give_up(problem, why or "the plan is no synchronised team plan whose "
                                 "leader arrives: no team reference", t0)
        return self.polish(problem, warm, t0)

    def team_candidates(self, problem: Problem) -> dict[str, Result]:
        """The candidate plans of the team reference of ``problem``
        (:mod:`optplan.team_grading`), ``source -> result``: every installed preset of
        :data:`TEAM_HEURISTICS` run with the seed :data:`REFERENCE_SEED`, and this NLP polished
        from each of their plans whose leader arrives (``"formation-nlp from NAME"``; each
        polish within ``time_limit``).  None on a problem the NLP does not support."""
        out: dict[str, Result] = {}
        if _unsupported(problem):
            return out
        for name in TEAM_HEURISTICS:
            try:
                res = registry.solve(problem, name, rng=REFERENCE_SEED)
            except ImportError:  # its backend's package is not installed (orca: pyrvo)
                continue
            out[name] = res
            warm = warm_from_result(problem, res)
            if warm is not None:
                out[f"{self.preset or self.name} from {name}"] = self.polish(problem, warm)
        return out

    def _model(self, problem: Problem, warm: Warm) -> tuple[TeamModel, list[str]]:
        form = problem.formation
        assert form is not None
        ids = [form.leader, *[f.id for f in form.followers]]
        robots = [problem.robot(r) for r in ids]
        frame, scale, T0 = problem.frame, float(problem.frame.length), warm.T0
        grid = np.linspace(0.0, T0, self.n_steps + 1)
        X0 = np.stack([frame.local(positions_at(warm.times, warm.paths[r], grid)) / scale
                       for r in ids])
        sep = max([form.safety_distance, *[a.radius + b.radius for a in robots
                                          for b in robots if a is not b]])
        return TeamModel(
            X0=X0, radius=np.array([r.radius for r in robots]) / scale,
            speed=np.array([r.max_speed for r in robots]) * T0 / scale,
            goal=frame.local(robots[0].goal) / scale,
            L=np.array([f.L for f in form.followers]) / scale,
            phi=np.array([f.phi for f in form.followers]),
            separation=sep / scale + SAFETY_REL,
            pieces=[obstacle_pieces(problem, r, known_only=False) for r in robots],
            scale=scale, movers=_movers(problem, T0, self.t_max * T0, scale),
            w_formation=float(self.w_formation), prune=float(self.prune),
            t_max=float(self.t_max)), ids

    def _judged(self, problem: Problem, res: Result, warm: Warm, info: dict, t0: float
                ) -> Result:
        """``res`` when the validator accepts it and it is no worse than a valid warm start
        (arrival up to IPOPT's tolerance, formation RMSE up to 0.1 % of the mean slot
        distance), else the warm start."""
        m, w = res.metrics, warm.metrics
        ok = res.status is Status.solved
        warm_ok = bool(w.get("feasible") and w.get("reached"))
        slack = 1e-6 + 10 * float(self.tol)
        lbar = float(np.mean([f.L for f in problem.formation.followers])) \
            if problem.formation else 1.0
        better = ok and (not warm_ok or (
            res.cost <= warm.T0 * (1 + slack)
            and m.get("formation_rmse", 0.0) <= w.get("formation_rmse", np.inf) + 1e-3 * lbar))
        ipopt = f"IPOPT: {info['return_status']}, {info['iter_count']} iterations"
        if better:
            return _with_message(res, f"locally optimal ({ipopt}): arrival {res.cost:.6g} s, "
                                 f"warm start {warm.T0:.6g} s")
        why = ("the validator rejects the NLP's plan" if not ok else
               "the NLP's plan is not better than its warm start")
        ipopt_info = {k: v for k, v in info.items() if k != "iter_count"}
        return self._kept(problem, warm, f"kept the warm start ({why}; {ipopt})",
                          {"ipopt": ipopt_info}, t0)

    def _kept(self, problem: Problem, warm: Warm, text: str, extras: dict, t0: float
              ) -> Result:
        """The warm start graded again, with ``text`` as its message."""
        kept = self.finish(problem, warm.paths, claim=Status.solved, times=warm.times,
                           cost=warm.T0, message="", extras={
                               **extras, "kept_warm_start": True, "warm_arrival": warm.T0},
                           wall_time=time.perf_counter() - t0)
        return _with_message(kept, text)

    def _unpolished(self, problem: Problem, warm: Warm | None, limit: Deadline, reason: str,
                    t0: float) -> Result:
        """The warm start cut short by the time limit, the callback or its own limit
        (``reason``), returned as it is (not polished), or the give-up when its leader never
        arrives."""
        cause = (limit.stop_text() if limit.stopped else
                 f"stopped by its own {reason.replace('_', ' ')}")
        what = f"the warm start ({self.warm_start}) was {cause}"
        if warm is None:
            return limit.mark(self._give_up(problem, f"{what} before its leader arrived", t0))
        return limit.mark(self._kept(problem, warm, f"{what}: returned as it is, not "
                                     "polished", {}, t0))

    def _give_up(self, problem: Problem, why: str, t0: float) -> Result:
        paths = {r.id: np.vstack([r.start, r.start]) for r in problem.robots}
        return self.finish(problem, paths, claim=Status.failed, times=np.zeros(2),
                           message=why, wall_time=time.perf_counter() - t0)


def _with_message(res: Result, text: str) -> Result:
    msg = text if not res.message else f"{text}; {res.message}"
    return dataclasses.replace(res, message=msg)


def _unsupported(problem: Problem) -> str:
    """Why the NLP cannot run on ``problem`` (``""`` when it can)."""
    form = problem.formation
    if form is None or not form.followers:
        return f"problem {problem.name!r} has no formation: formation-nlp plans a team"
    if problem.robot(form.leader).goal is None:
        return f"the leader {form.leader!r} has no goal"
    return ""


def warm_from_result(problem: Problem, res: Result) -> Warm | None:
    """A :class:`Warm` start from a team planner's result (``None`` when it has no shared
    time stamps or its leader never arrives)."""
    form = problem.formation
    if form is None or res.times is None:
        return None
    ids = [form.leader, *[f.id for f in form.followers]]
    if any(r not in res.paths for r in ids):
        return None
    times = np.asarray(res.times, float)
    T0 = arrival_time(problem, form.leader, res.paths[form.leader], times)
    if T0 is None or T0 <= 0:
        return None
    return Warm({r: np.asarray(res.paths[r], float) for r in ids}, times, float(T0),
                dict(res.metrics))


def _warm_from_paths(problem: Problem, init: dict[str, np.ndarray]) -> Warm | None:
    """Paths without times: each robot timed at uniform steps up to the slowest robot's time
    along its own path (at its ``max_speed``)."""
    form = problem.formation
    assert form is not None
    ids = [form.leader, *[f.id for f in form.followers]]
    if any(r not in init for r in ids):
        return None
    T0 = max(float(np.sum(np.hypot(*np.diff(init[r], axis=0).T))) / problem.robot(r).max_speed
             for r in ids)
    if T0 <= 0:
        return None
    paths = {r: np.asarray(init[r], float) for r in ids}
    n = max(len(p) for p in paths.values())
    times = np.linspace(0.0, T0, n)
    paths = {r: positions_at(np.linspace(0.0, T0, len(p)), p, times) for r, p in paths.items()}
    from optplan.metrics import evaluate

    return Warm(paths, times, T0, evaluate(problem, paths, times))


def _movers(problem: Problem, T0: float, horizon: float, scale: float) -> list[MoverTable]:
    """The moving obstacles' tracks in the NLP's units (module docstring of team_nlp)."""
    out = []
    for d in problem.dynamic_obstacles:
        tk, pk = mover_track(d, 0.0, horizon)
        if d.kind == "circle":
            rad = float(d.radius or 0.0)
        else:
            rad = float(np.max(np.hypot(*np.asarray(d.local_geometry.exterior.coords).T)))
        step = np.diff(tk)
        speed = (float(np.max(np.hypot(*np.diff(pk, axis=0).T)[step > 0] / step[step > 0]))
                 if np.any(step > 0) else 0.0)
        out.append(MoverTable(tk / T0, problem.frame.local(pk) / scale, rad / scale,
                              speed * T0 / scale))
    return out

