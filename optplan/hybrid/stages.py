"""The hybrid planner's global stage (paper §V step 3) and the stages' progress forwarding.

:func:`global_stage` plans a path for every driving robot on the known map
(``problem.known_view()``) with the ``global_solver`` stage (an ``init`` path replaces it);
:class:`StageCallback` forwards the stages' progress to the caller in world units, with a
running iteration offset.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from optplan.deadline import Deadline
from optplan.hybrid.answer import early_answer
from optplan.hybrid.policy import Team
from optplan.hybrid.steps import GlobalStage, RunOptions
from optplan.problem import Problem, Robot
from optplan.result import Progress, Result, Status
from optplan.units import Record, Unit, to_scale

__all__ = ["StageCallback", "global_stage", "PROGRESS_INFO_UNITS"]

_D = Unit.DIMENSIONLESS
#: The units of the stages' ``Progress.info`` (:mod:`optplan.units`), mapped back from the
#: canonical frame by them: the swarm's, the visibility graph's (its search counters), the
#: NLP's (its objective, in normalised units); the simulator reports none.  A stage that
#: reports a key declared nowhere here stops the run with
#: :class:`~optplan.units.UndeclaredUnit`.
PROGRESS_INFO_UNITS = Record({
    "robot": Unit.TEXT, "feasible_best_length": Unit.LENGTH, "phase": Unit.TEXT,
    "n_circles": _D, "n_expanded": _D, "n_generated": _D, "n_checked": _D, "certified": _D,
    "reason": Unit.TEXT, "stopped": _D, "objective": _D})


class StageCallback(Deadline):
    """Forwards the stages' progress with a running iteration offset; remembers a stop.

    With a ``time_limit`` (seconds from construction, on :data:`optplan.solver.clock`) it
    also stops every stage at its first progress report after the limit (the global
    solver's polls, the simulator's step, which drives the local planner and the formation):
    ``timed_out`` then says why."""

    def __init__(self, callback: Callable[[Progress], Any] | None, unit: float = 1.0,
                 time_limit: float | None = None):
        super().__init__(callback, time_limit)
        self.offset = 0
        self.unit = unit  # world length of a canonical unit (best_cost is a length)

    def __call__(self, p: Progress) -> None:
        if self.stopped:  # a stage on its way out: the stop stands (no more clock readings)
            raise StopIteration
        if self.expired():
            raise StopIteration
        info = to_scale(p.info, PROGRESS_INFO_UNITS, self.unit, "Progress.info")
        self.report(Progress(p.iteration + self.offset, p.best_cost * self.unit, p.n_eval,
                             p.elapsed, info, p.sim_time))

    @property
    def stop_reason(self) -> str:
        """``"time_limit"``, ``"callback"`` or ``""`` (the stages ran to their end)."""
        return "time_limit" if self.timed_out else ("callback" if self.stopped else "")

    def stop_text(self) -> str:
        """What stopped the run, for the message."""
        if self.timed_out:
            return f"time limit ({self.time_limit:g} s) reached"
        return "stopped by callback"


def global_stage(opts: RunOptions, problem: Problem, team: Team,
                 init: dict[str, np.ndarray] | None, rng: np.random.Generator,
                 cb: StageCallback, t_start: float) -> GlobalStage | dict[str, Any]:
    """Step 3: a path per driving robot (an ``init`` path replaces the planned one), or the
    early answer (a dict, :func:`~optplan.hybrid.answer.early_answer`) when the callback
    stopped the stage or no path exists on the known map."""
    out = GlobalStage({})
    need = [r for r in team.drivers if not (init and r.id in init)]
    if need:
        t0 = time.perf_counter()
        gres = opts.stages["global_solver"].solve(problem.known_view(), rng=rng,
                                                  callback=cb.forward)
        out.result, out.wall_time = gres, time.perf_counter() - t0
        cb.offset += max(gres.n_iter, len(gres.history))
        if cb.stopped:
            return early_answer(problem, team.ids, gres, f"{cb.stop_text()} during the "
                                "global stage", t_start, opts.angle_tol)
        if gres.status is Status.infeasible:
            return early_answer(problem, team.ids, gres, "global planner: no path exists on "
                                f"the known map ({gres.message})", t_start, opts.angle_tol,
                                Status.infeasible)
        _take_paths(gres, need, out)
    for r in team.drivers:
        if init and r.id in init:
            out.paths[r.id] = np.vstack([r.start, np.asarray(init[r.id], dtype=float)[1:]])
    return out


def _take_paths(gres: Result, need: list[Robot], out: GlobalStage) -> None:
    """The global result's path of each robot in ``need`` into ``out`` (the straight line to
    the goal, with a message, where it has none), and a note when it is not solved."""
    for r in need:
        p = gres.paths.get(r.id)
        if p is None or len(p) < 2 or gres.status is Status.failed:
            out.messages.append(f"global stage gave no path for {r.id} "
                                f"({gres.status.value}); heading straight for the goal")
            if r.goal is None:  # drivers are robots with a goal (Hybrid._team)
                raise ValueError(f"robot {r.id!r} drives itself but has no goal")
            p = np.vstack([r.start, r.goal])
        out.paths[r.id] = np.asarray(p, dtype=float)
    if gres.status not in (Status.optimal, Status.solved):
        out.messages.append(f"global path {gres.status.value} on the known map")
