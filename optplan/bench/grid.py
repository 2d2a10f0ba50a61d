"""The grid runner: problems x solvers x seeds, checked, resumed from a database, run on an
engine."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from optplan.bench.dask_engine import _import_dask, _run_dask
from optplan.bench.pool import _run_inline, _run_pool, _worker_init
from optplan.bench.rows import (
    COLUMNS,
    Overrides,
    Record,
    Task,
    Trace,
    _json,
    _overrides_for,
    _seed_list,
)
from optplan.bench.scen import scen_columns, with_scen


def _check_inputs(problems: Sequence[str], solvers: Sequence[str],
                  overrides: Overrides | None) -> dict[str, dict[str, Any]]:
    """Load every problem and make every solver (errors raise here, before anything runs);
    the ``.scen`` columns of each problem (:func:`optplan.bench.scen.scen_columns`)."""
    from optplan.bench.scen import load_bench_problem
    from optplan.solver import get_solver

    if not problems:
        raise ValueError("no problems given")
    if not solvers:
        raise ValueError("no solvers given")
    scen = {p: scen_columns(load_bench_problem(p)) for p in problems}
    for s in solvers:
        get_solver(s, **_overrides_for(overrides, s))
    return scen


def _config(options: Mapping[str, Any], time_limit: float | None) -> str:
    """What a resumed sweep must match for one solver: its overrides and the time limit."""
    return _json({"overrides": dict(options), "time_limit": time_limit})


def _not_count(v: Any) -> bool:
    """Not an integer >= 1 (a bool is not an integer here)."""
    return isinstance(v, bool) or not isinstance(v, (int, np.integer)) or bool(v < 1)


def _check_time_args(time_limit: Any, time_grace: Any) -> None:
    """``time_limit``: seconds > 0 (or None); ``time_grace``: seconds >= 0 (or None)."""
    if time_limit is not None and (isinstance(time_limit, bool) or not isinstance(
            time_limit, (int, float)) or not 0 < time_limit < math.inf):
        raise ValueError(f"time_limit must be a number of seconds > 0, got {time_limit!r}")
    if time_grace is not None and not 0 <= time_grace < math.inf:
        raise ValueError(f"time_grace must be a number of seconds >= 0, got {time_grace!r}")


@dataclass(frozen=True, kw_only=True)
class Engine:
    """Where the runs of :func:`run_grid` execute: inline, a local process pool, or Dask.

    Parameters
    ----------
    workers : int
        Processes of the local pool; 1 (the default) runs inline in the calling process.
    scheduler : str, optional
        Address of a Dask scheduler (``"tcp://host:8786"``) to run on.
    dask_local : int, optional
        Start a Dask ``LocalCluster`` with this many worker processes and run on it.

    Raises
    ------
    ValueError
        ``workers`` or ``dask_local`` is no integer >= 1 (the message names the option and
        its value), both Dask engines are given, or ``workers`` is not 1 on Dask.
    """

    workers: int = 1
    scheduler: str | None = None
    dask_local: int | None = None

    def __post_init__(self) -> None:
        if _not_count(self.workers):
            raise ValueError(f"workers must be an integer >= 1, got {self.workers!r}")
        if self.dask_local is not None and _not_count(self.dask_local):
            raise ValueError(f"dask_local must be an integer >= 1, got {self.dask_local!r}")
        if self.scheduler is not None and self.dask_local is not None:
            raise ValueError("give a Dask scheduler address or dask_local, not both")
        if self.uses_dask and self.workers != 1:
            raise ValueError("workers sets the local process pool; on Dask the cluster's "
                             "workers run the sweep (leave workers = 1)")

    @property
    def uses_dask(self) -> bool:
        """True on a Dask cluster (``scheduler`` or ``dask_local`` given)."""
        return self.scheduler is not None or self.dask_local is not None


def _hard_limit(time_limit: float | None, time_grace: float | None) -> float | None:
    """Seconds after which the harness stops a run: ``time_limit`` plus the grace."""
    if time_limit is None:
        return None
    return float(time_limit) + (max(1.0, 0.5 * time_limit) if time_grace is None
                                else float(time_grace))


def _resume(db: str | Path, done: Mapping[tuple, Any], tasks: Sequence[Task],
            configs: Mapping[str, str], rows: list[dict[str, Any] | None]) -> list[int]:
    """The task indices still to run given the finished cells ``done`` of the database;
    fills ``rows`` with the stored rows; raises if a stored cell used other options."""
    todo, clash = [], []
    for i, t in enumerate(tasks):
        hit = done.get(t[:3])
        if hit is None:
            todo.append(i)
            continue
        if hit[0] != configs[t[1]]:
            clash.append((t, hit[0]))
        rows[i] = {c: hit[1].get(c) for c in COLUMNS}
    if clash:
        (p, s, k, _, _), old = clash[0]
        raise ValueError(
            f"{db}: {len(clash)} stored run(s) were made with other options, e.g. "
            f"{p} / {s} / seed {k} with {old}; this sweep asks for {configs[s]}. "
            f"Use another database file (or the same options) to resume")
    return todo


def _engine_name(engine: Engine) -> str:
    """The engine as the database's ``experiment`` table records it."""
    if engine.scheduler:
        return f"dask {engine.scheduler}"
    return (f"dask-local {engine.dask_local}" if engine.dask_local
            else f"workers {engine.workers}")


def _open_db(db: str | Path, tasks: Sequence[Task], configs: Mapping[str, str],
             rows: list[dict[str, Any] | None], spec: dict[str, Any],
             command_line: str | None) -> tuple[Any, int, list[int]]:
    """Open the results database, resume from it, begin the experiment: (store, id, todo)."""
    from optplan.benchdb import ResultsDB, experiment_info

    keys = [t[:3] for t in tasks]
    if len(set(keys)) != len(keys):
        raise ValueError("with a results database every (problem, solver, seed) must be "
                         "unique: the problems, solvers or seeds repeat")
    store = ResultsDB(db)
    try:
        todo = _resume(db, store.finished(), tasks, configs, rows)
        total = len(tasks)
        exp_id = store.begin_experiment(experiment_info(command_line, spec),
                                        planned=total, skipped=total - len(todo))
    except BaseException:
        store.close()
        raise
    return store, exp_id, todo


def _run_engine(todo: Sequence[int], tasks: Sequence[Task], hard: float | None,
                init: Mapping[str, Any], record: Record, engine: Engine) -> None:
    """Run ``todo`` on the engine chosen: Dask, inline, or the process pool."""
    if engine.uses_dask:
        _run_dask(todo, tasks, hard, init, record, engine.scheduler, engine.dask_local)
    elif engine.workers == 1 or len(todo) == 1:
        _run_inline(todo, tasks, hard, init, record)
    else:
        _run_pool(todo, tasks, int(engine.workers), hard, init, record)


def _tasks(problems: Sequence[str], solvers: Sequence[str], seed_list: Sequence[int],
           options: Mapping[str, dict[str, Any]], time_limit: float | None) -> list[Task]:
    """One task per (problem, solver, seed), in that order."""
    return [(p, s, k, options[s], time_limit)
            for p in problems for s in solvers for k in seed_list]


def _db_spec(problems: list[str], solvers: list[str], seed_list: list[int],
             overrides: Overrides | None, time_limit: float | None,
             engine: str) -> dict[str, Any]:
    """The sweep as the database's ``experiment`` table records it."""
    return {"problems": problems, "solvers": solvers, "seeds": seed_list,
            "overrides": {k: dict(v) for k, v in (overrides or {}).items()},
            "time_limit": time_limit, "engine": engine}


def run_grid(problems: Sequence[str], solvers: Sequence[str], seeds: int | Iterable[int],
             engine: Engine = Engine(), overrides: Overrides | None = None,
             progress: Callable[[int, int, dict[str, Any]], Any] | None = None, *,
             time_limit: float | None = None, db: str | Path | None = None,
             command_line: str | None = None, time_grace: float | None = None
             ) -> list[dict[str, Any]]:
    """Run every (problem, solver, seed) and return one tidy row per run.

    Parameters
    ----------
    problems : list of str
        Catalogue names, ``.toml`` paths or ``.scen`` lines' names (``<file>.scen#line=N``:
        :func:`optplan.bench.scen.expand_scen`) (names, not objects, so that they travel
        cheaply to worker processes; on a remote Dask cluster a path must be readable by the
        workers).
    solvers : list of str
        Preset names, backend names or ``.toml`` preset paths.
    seeds : int or iterable of int
        ``N`` means seeds ``0 .. N-1``.  The same seeds are used for every solver.
    engine : Engine
        Where the runs execute: ``Engine()`` (the default) inline, ``Engine(workers=4)`` on
        4 worker processes, ``Engine(dask_local=4)`` or ``Engine(scheduler="tcp://host:8786")``
        on Dask.
    overrides : dict, optional
        ``{"*": {...}, "solver-name": {...}}``: options applied to every solver (``"*"``) or
        to one solver (later wins).
    progress : callable, optional
        ``progress(done, total, row)`` after each finished run (``total``: the runs this call
        executes, without those resumed from ``db``).
    time_limit : float, optional
        Seconds per run: passed to :func:`optplan.solve`; a run still going ``time_limit +
        time_grace`` seconds after it started is stopped by the harness (status
        ``time_limit``).
    db : str or Path, optional
        SQLite results database (:mod:`optplan.benchdb`): each run is stored when it
        finishes; cells already in the file are not run again (their stored rows are
        returned).  The stored runs of a cell must have been made with the same overrides and
        time limit.
    command_line : str, optional
        Recorded in the database's ``experiment`` table (default: ``sys.argv``).
    time_grace : float, optional
        Seconds past ``time_limit`` before the harness stops a run (default
        ``max(1, time_limit / 2)``).

    Returns
    -------
    list of dict
        Rows with the keys :data:`COLUMNS`, ordered by problem, solver, seed.

    Raises
    ------
    TypeError
        ``engine`` is no :class:`Engine`.
    ValueError
        Bad input (problems, solvers, seeds, overrides, time limits), before anything runs.
    """
    if not isinstance(engine, Engine):
        raise TypeError(f"engine must be an optplan.bench.Engine (e.g. Engine(workers=2)), "
                        f"got {engine!r}")
    problems = [str(p) for p in problems]
    solvers = [str(s) for s in solvers]
    seed_list = _seed_list(seeds)
    _check_time_args(time_limit, time_grace)
    scen = _check_inputs(problems, solvers, overrides)
    if engine.uses_dask:
        _import_dask()
    options = {s: _overrides_for(overrides, s) for s in solvers}
    tasks = _tasks(problems, solvers, seed_list, options, time_limit)
    total = len(tasks)
    configs = {s: _config(options[s], time_limit) for s in solvers}
    hard = _hard_limit(time_limit, time_grace)
    rows: list[dict[str, Any] | None] = [None] * total
    todo = list(range(total))
    store, exp_id = None, 0
    if db is not None:
        spec = _db_spec(problems, solvers, seed_list, overrides, time_limit,
                        _engine_name(engine))
        store, exp_id, todo = _open_db(db, tasks, configs, rows, spec, command_line)
    record = _Recorder(rows, tasks, configs, store, exp_id, progress, len(todo), scen)
    outcome = "error"
    try:
        if todo:
            init = _worker_init(problems, solvers, options)
            _run_engine(todo, tasks, hard, init, record, engine)
        outcome = "complete"
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise
    finally:
        if store is not None:
            _end_experiment(store, exp_id, outcome)
    return [with_scen(r, scen[r["problem"]]) for r in rows if r is not None]


def _end_experiment(store: Any, exp_id: int, outcome: str) -> None:
    """Record how the sweep ended and close the database.  When the sweep already failed
    (the database locked or damaged while it ran), that error is the one reported: a second
    one from this update is dropped (``runs_done`` is right anyway: each stored run counts
    itself)."""
    try:
        store.end_experiment(exp_id, outcome)
    except ValueError:
        if outcome == "complete":
            raise
    finally:
        store.close()


class _Recorder:
    """``record(i, row, trace, worker)``: a finished run, with the ``.scen`` columns of its
    problem, into ``rows``, the database and the progress callback."""

    def __init__(self, rows: list[dict[str, Any] | None], tasks: Sequence[Task],
                 configs: Mapping[str, str], store: Any, exp_id: int,
                 progress: Callable[[int, int, dict[str, Any]], Any] | None, n_todo: int,
                 scen: Mapping[str, dict[str, Any]]):
        self.rows, self.tasks, self.configs, self.scen = rows, tasks, configs, scen
        self.store, self.exp_id, self.progress, self.n_todo = store, exp_id, progress, n_todo
        self.n_done = 0

    def __call__(self, i: int, row: dict[str, Any], trace: Trace, worker: str) -> None:
        row = with_scen(row, self.scen[self.tasks[i][0]])
        self.rows[i] = row
        if self.store is not None:
            self.store.add_run(self.exp_id, row, self.configs[self.tasks[i][1]], trace, worker)
        self.n_done += 1
        if self.progress is not None:
            self.progress(self.n_done, self.n_todo, row)
