"""One run of a sweep: a solve with its shared reference, and the hard time limit around it."""

from __future__ import annotations

import dataclasses
import signal
import threading
import time
from collections.abc import Mapping
from typing import Any

from optplan.bench.rows import Task, Trace, _describe, _error_row, _num, row_from_result

_REF_KEY = ("optplan.bench", "reference")


def _fresh(prob: Any) -> Any:
    """A copy of ``prob`` with empty caches (its frame kept: it only depends on the bounds)."""
    return prob.replaced(keep=("frame",))


def _reference(prob: Any) -> dict[str, Any]:
    """The certified optimum of ``prob``, computed once per process on a cold copy."""
    from optplan.solver import reference_optimum

    return prob.memo(_REF_KEY, lambda: reference_optimum(_fresh(prob)))


def _time_reference(base: Any) -> Any:
    """The reference in time of ``solve(..., reference=True)``, computed once per process and
    robot on a cold copy of ``base`` (the problem as loaded, shared by its runs)."""
    from optplan.solver import time_reference

    return lambda _prob, rid: base.memo(("optplan.bench", "time_reference", rid),
                                        lambda: time_reference(_fresh(base), rid))


def _apply_reference(res: Any, prob: Any, ref: Mapping[str, Any], base: Any) -> Any:
    """What ``solve(..., reference=True)`` adds to the metrics, from a precomputed reference
    (and, with moving obstacles, the grading in time against ``base``'s shared reference)."""
    from optplan.solver import with_reference
    from optplan.time_grading import with_time_reference

    metrics = with_reference(res.metrics, prob, res.paths, dict(ref))
    t0 = time.perf_counter()
    graded = with_time_reference(metrics, prob, res.paths, res.times, _time_reference(base))
    if graded is not metrics:
        graded["reference_time"] = _num(metrics.get("reference_time")) + (
            time.perf_counter() - t0)
    return dataclasses.replace(res, metrics=graded)


def _execute(problem: str, solver: str, seed: int, overrides: Mapping[str, Any] | None = None,
             time_limit: float | None = None) -> tuple[dict[str, Any], Trace]:
    """One run on a cold copy of the problem: its tidy row and its thinned progress trace."""
    from optplan.bench.scen import load_bench_problem
    from optplan.benchdb import thin_progress
    from optplan.solver import solve

    trace: Trace = []
    try:
        base = load_bench_problem(problem)
        ref = _reference(base)
        prob = _fresh(base)
        t0 = time.perf_counter()

        def record(p: Any) -> None:
            trace.append((int(p.iteration), _num(p.best_cost), int(p.n_eval),
                          time.perf_counter() - t0))

        kw: dict[str, Any] = {"rng": seed, "callback": record}
        if time_limit is not None:
            kw["time_limit"] = time_limit
        res = solve(prob, solver, **kw, **dict(overrides or {}))
        res = _apply_reference(res, prob, ref, base)
    except Exception as e:  # noqa: BLE001 - one broken run must not stop the grid
        return _error_row(problem, solver, seed, _describe(e)), []
    return row_from_result(res, problem, solver, seed), thin_progress(trace)


def run_one(problem: str, solver: str, seed: int,
            overrides: Mapping[str, Any] | None = None,
            time_limit: float | None = None) -> dict[str, Any]:
    """Solve one (problem, solver, seed) cell and return its tidy row (never raises).

    The run solves a fresh copy of the problem (no cache from earlier runs); ``time_limit`` is
    passed to :func:`optplan.solve` (no hard limit here: see :func:`run_grid`).  A problem
    read from a ``.scen`` line gets its ``.scen`` columns (:func:`optplan.bench.scen.with_scen`).
    """
    from optplan.bench.scen import NO_SCEN, load_bench_problem, scen_columns, with_scen

    row = _execute(problem, solver, seed, overrides, time_limit)[0]
    try:
        cols = scen_columns(load_bench_problem(problem))
    except Exception:  # noqa: BLE001 - the row already says why the problem did not load
        cols = dict(NO_SCEN)
    return with_scen(row, cols)


class _HardTimeout(BaseException):
    """Raised by the inline watchdog (a BaseException: a backend's ``except Exception``
    does not swallow it)."""


def _guarded(task: Task, hard: float | None) -> tuple[tuple[dict[str, Any], Trace] | None, str]:
    """``_execute(*task)``, stopped after ``hard`` seconds: (result or None, how it stopped).

    In the main thread a ``SIGALRM`` raises inside the run; elsewhere (a Dask worker thread)
    the run goes to a daemon thread that is abandoned when it overruns.
    """
    if hard is None:
        return _execute(*task), ""
    if threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
        def on_alarm(signum: int, frame: Any) -> None:
            raise _HardTimeout

        old = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, hard)
        try:
            return _execute(*task), ""
        except _HardTimeout:
            return None, "stopped in-process by the harness"
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)
    box: list[Any] = []
    th = threading.Thread(target=lambda: box.append(_execute(*task)), daemon=True,
                          name=f"optplan-run-{task[0]}-{task[1]}-{task[2]}")
    th.start()
    th.join(hard)
    if th.is_alive() or not box:
        return None, "abandoned by the harness (its thread runs on until the backend returns)"
    return box[0], ""
