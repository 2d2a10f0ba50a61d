"""The backend base class: options, ``solve``, and :meth:`Backend.finish`, the one grading of
every result by the validator (statuses never over-claim: ``optimal`` only when the certified
optimum confirms it, docs/api.md).  The registry, presets and :func:`optplan.solve` are in
:mod:`optplan.solver`.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, TypedDict, Unpack

import numpy as np

from optplan.metrics import evaluate
from optplan.options import check_options
from optplan.problem import Problem
from optplan.result import History, Progress, Result, Status, confirms_optimum, optimum_gap

__all__ = ["Backend", "ClaimsInTime", "Effort", "share_known_view_sets"]


class Effort(TypedDict, total=False):
    """What a solve cost: the keywords of :meth:`Backend.finish` that become the
    :class:`~optplan.result.Result`'s fields of the same names (each 0 when left out).

    Attributes
    ----------
    n_iter : int
        Iterations of the backend.
    n_eval : int
        Evaluations (of the objective, the policy, ...).
    wall_time : float
        The backend's seconds; :meth:`Backend.finish` adds the time of the validation.
    """

    n_iter: int
    n_eval: int
    wall_time: float


@dataclass(frozen=True, kw_only=True)
class Backend:
    """Base class of every backend (a frozen, keyword-only dataclass of options)."""

    name: ClassVar[str] = "backend"
    #: True when a successful solve is certified optimal by an exact method.
    certifies: ClassVar[bool] = False
    #: The preset this backend was configured from (set by :func:`get_solver`; ``None`` for a
    #: bare backend).  Not an option: ``options()`` and ``show-solver`` leave it out.
    preset: str | None = dataclasses.field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        check_options(self)
        self.check()

    def check(self) -> None:
        """Rules that relate several options (override; each option's own range is declared
        with :func:`optplan.options.option` and checked before this runs)."""

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        raise NotImplementedError

    def options(self) -> dict[str, Any]:
        """The effective options as a plain dict."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if not f.name.startswith("_") and f.name != "preset"}

    def finish(
        self,
        problem: Problem,
        paths: dict[str, np.ndarray],
        *,
        claim: Status,
        times: np.ndarray | None = None,
        cost: float = float("nan"),
        message: str = "",
        history: History | None = None,
        extras: dict[str, Any] | None = None,
        metrics_extra: dict[str, Any] | None = None,
        **effort: Unpack[Effort],
    ) -> Result:
        """Build a :class:`Result`: run the shared validator and set the status.

        ``claim`` is what the backend believes (``optimal``/``solved`` when it thinks it
        succeeded).  A success claim is downgraded to ``approximate`` when the validator
        finds the paths infeasible or not reaching their goals; other claims are kept.
        Optimal is only kept for backends that certify (``certifies = True``) and when the
        certified optimum the backend reports (``metrics_extra["optimum"]``) confirms the
        leader's length (``length_exact`` when reported, else ``length``) within
        :data:`~optplan.result.OPTIMAL_REL_TOL`; otherwise it becomes ``solved``.

        Parameters
        ----------
        problem : Problem
            The problem solved (the validator grades the paths against it).
        paths : dict
            ``robot id -> (n, 2)`` path (or trajectory, with ``times``).
        claim : Status
            The status the backend claims.
        times : array, optional
            Time stamps shared by the paths (simulated trajectories).
        cost : float
            The backend's own cost of its answer.
        message : str
            The backend's message (the validator's complaints are appended).
        history : History, optional
            Per-iteration records.
        extras : dict, optional
            Backend-specific results (``Result.extras``).
        metrics_extra : dict, optional
            Added to the validator's metrics before grading (e.g. ``optimum``,
            ``length_exact``).
        **effort
            The :class:`Effort` keywords ``n_iter``, ``n_eval`` and ``wall_time`` (the
            backend's seconds: the time of the validation is added).

        Returns
        -------
        Result
            The graded result.

        Raises
        ------
        TypeError
            A keyword that is neither a parameter nor an :class:`Effort` keyword.
        """
        unknown = sorted(effort.keys() - Effort.__optional_keys__)
        if unknown:
            raise TypeError(f"finish() got an unexpected keyword argument {unknown[0]!r} "
                            f"(the effort keywords are n_iter, n_eval, wall_time)")
        t_val = time.perf_counter()
        paths = {k: np.asarray(v, dtype=float) for k, v in paths.items()}
        share_known_view_sets(problem)
        metrics = evaluate(problem, paths, times)
        if metrics_extra:
            metrics.update(metrics_extra)
        status, message = self._grade(Status(claim), metrics, message)
        return Result(
            status=status, paths=paths, metrics=metrics, solver=self.preset or self.name,
            backend=self.name, options=self.options(), seed=None, problem=problem.name,
            times=times, cost=float(cost), n_iter=int(effort.get("n_iter", 0)),
            n_eval=int(effort.get("n_eval", 0)),
            wall_time=float(effort.get("wall_time", 0.0)) + time.perf_counter() - t_val,
            message=message,
            history=history or History(),
            extras=extras or {},
        )

    def _grade(self, status: Status, metrics: dict[str, Any],
               message: str) -> tuple[Status, str]:
        """The status of a claim given the validator's metrics (:meth:`finish`'s rules)."""
        if status in (Status.optimal, Status.solved):
            if not (metrics["feasible"] and metrics["reached"]):
                why = _validator_complaints(metrics)
                status = Status.approximate
                message = (message + "; " if message else "") + "validator: " + ", ".join(why)
            elif status is Status.optimal and not self.certifies:
                status = Status.solved
            elif status is Status.optimal:
                status, message = _confirm_optimal(metrics, message)
        elif status is Status.approximate and metrics["feasible"] and metrics["reached"]:
            # the backend gave up (e.g. IPOPT failed) but what it returned is feasible and
            # reaches the goal: that is what "solved" means
            status = Status.solved
            message = (message + "; " if message else "") + (
                "validator: the returned paths are feasible and reach the goal")
        return status, message


def _validator_complaints(metrics: dict[str, Any]) -> list[str]:
    """Why the validator rejects a success claim, in the order of the checks."""
    why = []
    if metrics["static_collisions"]:
        why.append(f"{metrics['static_collisions']} static collision(s) with "
                   + ", ".join(repr(n) for n in metrics["crossed"]))
    fc = metrics.get("first_contact")
    if fc is not None:
        why.append(_first_contact_text(metrics, fc))
    if not metrics["in_bounds"]:
        why.append("out of bounds")
    if not metrics["reached"]:
        why.append("goal not reached")
    if not metrics.get("starts_ok", True):
        why.append("path does not start at the start")
    return why


def _first_contact_text(metrics: dict[str, Any], fc: dict[str, Any]) -> str:
    """The validator's phrase for contacts in time: their number and the first one."""
    n_t = metrics["dynamic_contacts"] + metrics["separation_violations"]
    return (f"{n_t} contact(s) in time ({metrics['timing']} timing); first: "
            f"{fc['robot']} with {fc['kind']} {fc['other']!r} at "
            f"t={fc['time']:.3f} near ({fc['position'][0]:.4g}, "
            f"{fc['position'][1]:.4g})")


def _confirm_optimal(metrics: dict[str, Any], message: str) -> tuple[Status, str]:
    """The grading of an ``optimal`` claim of a certifying backend: kept when the certified
    optimum it reports confirms the length (:func:`~optplan.result.confirms_optimum`), else
    ``solved`` with the gap in the message."""
    # the validator's metrics always report the length, a float (float() changes no value)
    length = float(metrics.get("length_exact", metrics["length"]))
    opt = metrics.get("optimum")
    if confirms_optimum(length, opt):
        return Status.optimal, message
    why = ("no certified optimum reported" if opt is None else
           f"locally optimal: {100 * optimum_gap(length, opt):.3g} % above the certified "
           f"optimum {opt:.6g}")
    return Status.solved, (message + "; " if message else "") + why


def share_known_view_sets(problem: Problem) -> None:
    """Let the validator use the obstacle sets a backend built on ``problem.known_view()``.

    Without temporary obstacles the known view's static map is the problem's, but the view is
    a copy with its own cache (:meth:`Problem.known_view`), so the set a planner built on it
    (the swarm planners plan on the view) would be built a second time by the validator.  This
    copies the view's sets (built on the view if absent: the same cost) into the problem's
    cache for every robot radius.  With temporary obstacles the two maps differ: nothing done.
    """
    if any(not o.known for o in problem.obstacles):
        return
    view = problem.known_view()
    for r in sorted({float(x.radius) for x in problem.robots}):
        problem.memo(("obstacle_set", r, False), functools.partial(view.obstacle_set, r))


class ClaimsInTime:
    """A backend whose ``optimal`` is a claim in time (its arrival is certified earliest), not
    on the length: the validator only has to accept the plan (``sipp``, ``time-bracket``)."""

    def _grade(self, status: Status, metrics: dict[str, Any],
               message: str) -> tuple[Status, str]:
        """``optimal`` stands when the validator would call the plan ``solved``."""
        grade = super()._grade  # type: ignore[misc]
        if status is Status.optimal:
            graded, message = grade(Status.solved, metrics, message)
            return (Status.optimal if graded is Status.solved else graded), message
        return grade(status, metrics, message)
