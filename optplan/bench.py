"""Generic benchmark harness: problems x solvers x seeds -> tidy rows -> summary tables.

Pure functions; nothing is printed (the CLI prints).

>>> from optplan.bench import run_grid, summarise, to_markdown
>>> rows = run_grid(["open-field"], ["visgraph"], seeds=2)
>>> [r["status"] for r in rows]
['optimal', 'optimal']
>>> print(to_markdown(summarise(rows)).splitlines()[0])  # doctest: +ELLIPSIS
| problem | solver | runs | success | ...

Design choices
--------------
* **Common random numbers**: run ``k`` of every solver on a problem uses the same seed
  (``seeds[k]``), so paired comparisons between solvers see the same randomness budget.
* **Engines**: ``workers = 1`` runs inline in the calling process; ``workers > 1`` starts that
  many worker processes (``spawn`` start method, safe with threaded numerical libraries such as
  CasADi), each running one run at a time, so that one run can be stopped by ending its
  process; ``scheduler="tcp://host:8786"`` runs on an existing Dask cluster and
  ``dask_local=N`` on a :class:`distributed.LocalCluster` of ``N`` single-threaded worker
  processes (``dask[distributed]`` is an optional dependency; runs travel in chunks of about
  :data:`DASK_CHUNK_SECONDS` of work, see :func:`_run_dask`).  Whatever the engine, rows come
  back in grid order (problem, solver, seed) and the same seeds give the same rows.  Workers
  register the calling process's extra backends (:func:`optplan.register`) and resolve every
  solver and problem before their first run.
* **Cold caches for every run**: each run solves a fresh copy of the problem (empty caches,
  nothing kept from an earlier run), so a time is never a cache hit (e.g. the visibility
  graph of the previous seed).  The certified optimum (the ``ratio`` denominator) is
  computed once per problem and process on its own cold copy, and its time is reported as
  ``reference_time`` for every run of that problem.  Process-wide caches stay warm: imported
  modules, compiled CasADi functions, numba code; workers pay for them before their first run.
* **Time limits**: ``time_limit=S`` is passed to :func:`optplan.solve`, which stops a backend
  at its first iteration after ``S`` seconds (``stop_reason = "time_limit"``).  A run that
  ignores it and is still going ``S + grace`` seconds after it started (``grace = max(1 s,
  S / 2)``) is stopped by the harness and recorded with status ``time_limit`` and
  ``stop_reason = "hard_limit"``: a process-pool worker is killed and replaced; inline, a
  ``SIGALRM`` raises inside the run (this needs the run to return to Python code: use
  ``workers >= 2`` for backends stuck in C code); on Dask the run's thread is abandoned (it
  keeps a worker thread busy until the backend returns).
* **Results database** (``db=``, :mod:`optplan.benchdb`): every finished run is committed as
  it finishes; rerunning the same sweep on the same file skips the finished (problem, solver,
  seed) cells.  A ``KeyboardInterrupt`` (Ctrl-C) stops the workers at once, keeps every
  finished run and is re-raised.
* **Fail early on bad input**: problem and solver names and the option overrides are
  resolved in the calling process before anything runs, so a typo raises ``ValueError`` /
  :class:`optplan.ProblemError` at once.  An exception *inside* one run is recorded as a row
  with status ``error`` (and its message) instead of stopping the grid.
* **Statistics** (:func:`summarise`): medians and inter-quartile ranges (q75 - q25, numpy's
  linear interpolation).  Quality (length, ratio, clearance) is taken over the *successful*
  runs only (status ``optimal`` or ``solved``), next to the success rate over all runs; time
  over every run that did not raise (a run stopped at the limit counts with its time).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import multiprocessing
import os
import platform
import signal
import sys
import threading
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from multiprocessing.connection import wait as _mp_wait
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["COLUMNS", "run_grid", "run_one", "row_from_result", "summarise", "to_markdown",
           "write_csv", "read_csv", "expand_scen"]

#: Columns of a tidy row, in order.
COLUMNS = ("problem", "solver", "seed", "status", "success", "length", "ratio", "collisions",
           "min_clearance", "wall_time", "n_iter", "n_eval", "message", "optimum",
           "reference_time", "stop_reason", "backend", "options")

Overrides = Mapping[str, Mapping[str, Any]]
#: (problem, solver, seed, options, time limit)
Task = tuple[str, str, int, dict[str, Any], "float | None"]
#: (iteration, best cost, evaluations, seconds since the run started)
Trace = list[tuple[int, float, int, float]]
Record = Callable[[int, dict[str, Any], Trace, str], None]


def _seed_list(seeds: int | Iterable[int]) -> list[int]:
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        if seeds < 1:
            raise ValueError(f"seeds must be >= 1, got {seeds}")
        return list(range(int(seeds)))
    out = [int(s) for s in seeds]
    if not out:
        raise ValueError("seeds is empty")
    if any(s < 0 for s in out):
        raise ValueError(f"seeds must be non-negative, got {out}")
    return out


def _overrides_for(overrides: Overrides | None, solver: str) -> dict[str, Any]:
    """Options for ``solver``: ``overrides["*"]`` then ``overrides[solver]``."""
    if not overrides:
        return {}
    for k, v in overrides.items():
        if not isinstance(v, Mapping):
            raise ValueError(f"overrides must map solver name (or '*') -> dict of options; "
                             f"got {k!r}: {v!r}")
    return {**dict(overrides.get("*", {})), **dict(overrides.get(solver, {}))}


def _num(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return float("nan")
    return v


def _json(x: Any) -> str:
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.integer, np.floating, np.bool_)):
            return o.item()
        return str(o)

    return json.dumps(x, sort_keys=True, default=default)


def row_from_result(res: Any, problem: str, solver: str, seed: int) -> dict[str, Any]:
    """The tidy row of one :class:`optplan.Result`."""
    m = res.metrics
    ratio = m.get("ratio_to_optimum")
    opt = m.get("optimum")
    return {
        "problem": problem,
        "solver": solver,
        "seed": seed,
        "status": res.status.value,
        "success": bool(res.success),
        "length": _num(m.get("length")),
        "ratio": _num(ratio) if ratio is not None else float("nan"),
        "collisions": int(m.get("collisions", 0) or 0),
        "min_clearance": _num(m.get("min_clearance")),
        "wall_time": float(res.wall_time),
        "n_iter": int(res.n_iter),
        "n_eval": int(res.n_eval),
        "message": res.message,
        "optimum": _num(opt) if opt is not None else float("nan"),
        "reference_time": _num(m.get("reference_time")),
        "stop_reason": getattr(res, "stop_reason", "") or "",
        "backend": res.backend,
        "options": _json(res.options),
    }


def _bare_row(problem: str, solver: str, seed: int, status: str, msg: str,
              wall_time: float = float("nan"), stop_reason: str = "") -> dict[str, Any]:
    nan = float("nan")
    return {"problem": problem, "solver": solver, "seed": seed, "status": status,
            "success": False, "length": nan, "ratio": nan, "collisions": -1,
            "min_clearance": nan, "wall_time": wall_time, "n_iter": 0, "n_eval": 0,
            "message": msg, "optimum": nan, "reference_time": nan, "stop_reason": stop_reason,
            "backend": "", "options": ""}


def _error_row(problem: str, solver: str, seed: int, msg: str) -> dict[str, Any]:
    return _bare_row(problem, solver, seed, "error", msg)


def _limit_row(task: Task, elapsed: float, how: str) -> dict[str, Any]:
    p, s, k, _, limit = task
    return _bare_row(p, s, k, "time_limit",
                     f"{how} after {elapsed:.3f} s: the run ignored its time limit of "
                     f"{limit:g} s", wall_time=elapsed, stop_reason="hard_limit")


def _describe(e: BaseException) -> str:
    last = traceback.extract_tb(e.__traceback__)[-1] if e.__traceback__ else None
    where = f" at {Path(last.filename).name}:{last.lineno}" if last else ""
    return f"{type(e).__name__}: {e}{where}"


# --------------------------------------------------------------------------------------
# one run
# --------------------------------------------------------------------------------------

_REF_KEY = ("optplan.bench", "reference")


def _fresh(prob: Any) -> Any:
    """A copy of ``prob`` with empty caches (its frame kept: it only depends on the bounds)."""
    keep = {k: v for k, v in prob._cache.items() if k == ("frame",)}
    return dataclasses.replace(prob, _cache=keep)


def _reference(prob: Any) -> dict[str, Any]:
    """The certified optimum of ``prob``, computed once per process on a cold copy."""
    from optplan.solver import reference_optimum

    return prob.memo(_REF_KEY, lambda: reference_optimum(_fresh(prob)))


def _apply_reference(res: Any, prob: Any, ref: Mapping[str, Any]) -> Any:
    """What ``solve(..., reference=True)`` adds to the metrics, from a precomputed reference."""
    metrics = dict(res.metrics)
    metrics["reference_time"] = ref["reference_time"]
    if ref["optimum"] is not None and "length" in metrics and prob.leader.id in res.paths:
        metrics["optimum"] = ref["optimum"]
        metrics["ratio_to_optimum"] = metrics["length"] / ref["optimum"]
    elif ref["reference_error"] is not None:
        metrics["reference_error"] = ref["reference_error"]
    return dataclasses.replace(res, metrics=metrics)


def _execute(problem: str, solver: str, seed: int, overrides: Mapping[str, Any] | None = None,
             time_limit: float | None = None) -> tuple[dict[str, Any], Trace]:
    """One run on a cold copy of the problem: its tidy row and its thinned progress trace."""
    from optplan.benchdb import thin_progress
    from optplan.catalog import load_problem
    from optplan.solver import solve

    trace: Trace = []
    try:
        base = load_problem(problem)
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
        res = _apply_reference(res, prob, ref)
    except Exception as e:  # noqa: BLE001 - one broken run must not stop the grid
        return _error_row(problem, solver, seed, _describe(e)), []
    return row_from_result(res, problem, solver, seed), thin_progress(trace)


def run_one(problem: str, solver: str, seed: int,
            overrides: Mapping[str, Any] | None = None,
            time_limit: float | None = None) -> dict[str, Any]:
    """Solve one (problem, solver, seed) cell and return its tidy row (never raises).

    The run solves a fresh copy of the problem (no cache from earlier runs); ``time_limit`` is
    passed to :func:`optplan.solve` (no hard limit here: see :func:`run_grid`).
    """
    return _execute(problem, solver, seed, overrides, time_limit)[0]


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


# --------------------------------------------------------------------------------------
# workers
# --------------------------------------------------------------------------------------

_SETUP_DONE: set[str] = set()


def _worker_init(problems: Sequence[str], solvers: Sequence[str],
                 overrides: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """What a worker needs before its first run (small and picklable)."""
    from optplan.solver import BACKENDS

    return {"token": uuid.uuid4().hex, "backends": dict(BACKENDS), "sys_path": list(sys.path),
            "problems": list(problems), "solvers": [(s, dict(overrides[s])) for s in solvers]}


def _worker_setup(init: Mapping[str, Any]) -> None:
    """Register the caller's backends, import every solver, compute every reference (once)."""
    if init["token"] in _SETUP_DONE:
        return
    for p in init.get("sys_path", ()):
        if p not in sys.path:
            sys.path.append(p)
    from optplan.catalog import load_problem
    from optplan.solver import BACKENDS, get_solver, register

    for name, entry in init.get("backends", {}).items():
        if name not in BACKENDS:
            register(name, entry)
    for s, ov in init.get("solvers", ()):
        get_solver(s, **ov)
    for p in init.get("problems", ()):
        try:
            _reference(load_problem(p))
        except Exception:  # noqa: BLE001 - the run itself will record the error
            pass
    _SETUP_DONE.add(init["token"])


def _worker_id() -> str:
    return f"{platform.node()}:{os.getpid()}"


def _run_inline(todo: Sequence[int], tasks: Sequence[Task], hard: float | None,
                init: Mapping[str, Any], record: Record) -> None:
    _worker_setup(init)
    wid = _worker_id()
    for i in todo:
        t0 = time.perf_counter()
        out, how = _guarded(tasks[i], hard)
        if out is None:
            record(i, _limit_row(tasks[i], time.perf_counter() - t0, how), [], wid)
        else:
            record(i, out[0], out[1], wid)


def _pool_worker(conn: Any, init: Mapping[str, Any]) -> None:
    """A process-pool worker: set up, then run the tasks it is sent one at a time."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    try:
        _worker_setup(init)
    except BaseException as e:  # noqa: BLE001 - reported to the parent
        conn.send(("setup_error", _describe(e)))
        return
    wid = _worker_id()
    conn.send(("ready",))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        i, task = msg
        row, trace = _execute(*task)
        conn.send(("done", i, row, trace, wid))


class _Slot:
    """One pool worker process and the task it is running."""

    def __init__(self, ctx: Any, init: Mapping[str, Any]):
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_pool_worker, args=(child, init), daemon=True,
                                name="optplan-bench-worker")
        self.proc.start()
        child.close()
        self.ready = False
        self.task: int | None = None
        self.t0 = 0.0

    def kill(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join(1.0)
        self.conn.close()


def _dispatch(slots: Sequence[_Slot], queue: deque, tasks: Sequence[Task]) -> None:
    """Send the next queued run to every idle worker that is ready."""
    for s in slots:
        if s.ready and s.task is None and queue:
            i = queue.popleft()
            s.conn.send((i, tasks[i]))
            s.task, s.t0 = i, time.perf_counter()


def _wait_timeout(slots: Sequence[_Slot], hard: float | None) -> float:
    """How long to wait for a message: 0.5 s, or less when a run nears its hard limit."""
    timeout = 0.5
    if hard is not None:
        now = time.perf_counter()
        for s in slots:
            if s.task is not None:
                timeout = min(timeout, max(0.0, s.t0 + hard - now) + 0.01)
    return timeout


def _receive(s: _Slot, ready: Sequence[Any]) -> Any:
    """The worker's message, or None when its process died."""
    try:
        if s.conn in ready or s.conn.poll():
            return s.conn.recv()
    except (EOFError, OSError):
        pass
    return None


def _replace_dead(slots: list[_Slot], k: int, tasks: Sequence[Task], ctx: Any,
                  init: Mapping[str, Any], record: Record) -> None:
    """Worker ``k`` died: record its run as an error and start a new worker in its slot."""
    s = slots[k]
    s.kill()
    code = s.proc.exitcode
    if not s.ready:
        raise RuntimeError(
            f"a bench worker process exited during start-up (exit code "
            f"{code}); workers are started with 'spawn', so a script that "
            f"runs a sweep needs an  if __name__ == '__main__':  guard")
    if s.task is not None:
        p, sv, seed = tasks[s.task][:3]
        record(s.task, _error_row(p, sv, seed, f"the worker process died "
                                  f"(exit code {code})"), [], "")
    slots[k] = _Slot(ctx, init)


def _handle_message(s: _Slot, msg: Any, record: Record) -> None:
    """Act on a message of a live worker: ready, a finished run, or a failed set-up."""
    if msg[0] == "ready":
        s.ready = True
    elif msg[0] == "done":
        _, i, row, trace, wid = msg
        s.task = None
        record(i, row, trace, wid)
    elif msg[0] == "setup_error":
        raise RuntimeError(f"a bench worker could not start: {msg[1]}")


def _enforce_hard_limit(slots: list[_Slot], tasks: Sequence[Task], hard: float | None,
                        ctx: Any, init: Mapping[str, Any], record: Record) -> None:
    """Kill (and replace) every worker whose run is past the hard limit; record the runs."""
    if hard is None:
        return
    now = time.perf_counter()
    for k, s in enumerate(slots):
        if s.task is not None and now - s.t0 > hard:
            i, elapsed = s.task, now - s.t0
            s.kill()
            record(i, _limit_row(tasks[i], elapsed, "killed (worker process ended) "
                                 "by the harness"), [], "")
            slots[k] = _Slot(ctx, init)


def _close_slots(slots: Sequence[_Slot], clean: bool) -> None:
    """Stop every worker: politely (then killed if need be) after a clean sweep, else at once."""
    for s in slots:
        if clean:
            try:
                s.conn.send(None)
            except OSError:
                pass
            s.proc.join(2.0)
        s.kill()


def _run_pool(todo: Sequence[int], tasks: Sequence[Task], workers: int, hard: float | None,
              init: Mapping[str, Any], record: Record) -> None:
    """Runs on a pool of ``spawn`` worker processes, one run at a time per worker; a worker
    that dies or overruns the hard limit is replaced."""
    ctx = multiprocessing.get_context("spawn")
    queue = deque(todo)
    slots = [_Slot(ctx, init) for _ in range(min(workers, len(todo)))]
    clean = False
    try:
        while queue or any(s.task is not None for s in slots):
            _dispatch(slots, queue, tasks)
            ready = _mp_wait([s.conn for s in slots] + [s.proc.sentinel for s in slots],
                             _wait_timeout(slots, hard))
            for k, s in enumerate(slots):
                if s.conn not in ready and s.proc.sentinel not in ready:
                    continue
                msg = _receive(s, ready)
                if msg is None:  # the process died
                    _replace_dead(slots, k, tasks, ctx, init, record)
                else:
                    _handle_message(s, msg, record)
            _enforce_hard_limit(slots, tasks, hard, ctx, init, record)
        clean = True
    finally:
        _close_slots(slots, clean)


def _import_dask() -> Any:
    try:
        import distributed
    except ImportError as e:
        raise ImportError(
            "running a sweep on Dask (--scheduler / --dask-local) needs the optional dependency "
            "dask[distributed]: pip install 'optplan[dask]' (or: pip install "
            "'dask[distributed]')") from e
    return distributed


#: a Dask task runs consecutive runs for about this many seconds (see :func:`_run_dask`)
DASK_CHUNK_SECONDS = 0.5
#: and at most this many runs
DASK_CHUNK_MAX = 64


def _dask_chunk(chunk: Sequence[Task], init: Mapping[str, Any], hard: float | None
                ) -> list[tuple[dict[str, Any], Trace, str]]:
    """Consecutive runs on a Dask worker (in one of its threads)."""
    _worker_setup(init)
    try:
        from distributed import get_worker

        wid = str(get_worker().address)
    except (ImportError, ValueError):
        wid = _worker_id()
    out = []
    for task in chunk:
        t0 = time.perf_counter()
        res, how = _guarded(task, hard)
        if res is None:
            out.append((_limit_row(task, time.perf_counter() - t0, how), [], wid))
        else:
            out.append((res[0], res[1], wid))
    return out


def _dask_client(distributed: Any, scheduler: str | None, dask_local: int | None
                 ) -> tuple[Any, Any]:
    import logging

    if dask_local:
        import dask

        # the workers' statistical profiler samples every thread's stack every 10 ms (under
        # the GIL): it slows pure-Python runs down measurably, and a sweep does not need it
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            cluster = distributed.LocalCluster(n_workers=int(dask_local), threads_per_worker=1,
                                               processes=True, dashboard_address=None,
                                               silence_logs=logging.ERROR)
        return distributed.Client(cluster), cluster
    try:
        return distributed.Client(scheduler, timeout="10s"), None
    except (OSError, TimeoutError) as e:
        raise OSError(f"cannot connect to the Dask scheduler at {scheduler}: {e}") from None


def _kill(pids: Sequence[int]) -> None:
    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass


class _DaskFeed:
    """The queue of a Dask sweep: chunks in flight, the run times so far, chunk sizing."""

    def __init__(self, client: Any, todo: Sequence[int], tasks: Sequence[Task],
                 init: Mapping[str, Any], hard: float | None):
        self.client, self.tasks, self.init, self.hard = client, tasks, init, hard
        self.queue = deque(todo)
        self.flying: dict[str, tuple[Any, list[int]]] = {}
        self.done_times: list[float] = []
        self.counter = 0
        self.cache = {"t": -math.inf, "n": 1}
        self.abandoned = False

    def threads(self) -> int:
        """Worker threads in the cluster (asked of the scheduler at most every 5 s)."""
        if time.monotonic() - self.cache["t"] > 5.0:
            self.cache["n"] = max(1, sum(int(n) for n in self.client.nthreads().values()))
            self.cache["t"] = time.monotonic()
        return int(self.cache["n"])

    def _chunk_size(self, n_threads: int) -> int:
        """Runs in the next chunk: about DASK_CHUNK_SECONDS of the median run time."""
        size = 1
        if self.done_times:
            med = float(np.median(self.done_times[-200:]))
            size = int(min(DASK_CHUNK_MAX, max(1, DASK_CHUNK_SECONDS // max(med, 1e-4))))
        # near the end, leave something for every worker
        return max(1, min(size, len(self.queue) // (2 * n_threads) or 1))

    def submit(self, pipe: Any, n_threads: int) -> None:
        """Send the next chunk of queued runs."""
        size = self._chunk_size(n_threads)
        idx = [self.queue.popleft() for _ in range(min(size, len(self.queue)))]
        self.counter += 1
        f = self.client.submit(_dask_chunk, [self.tasks[i] for i in idx], self.init, self.hard,
                               pure=False, key=f"optplan-bench-{self.init['token']}-"
                                               f"{self.counter}")
        self.flying[f.key] = (f, idx)
        pipe.add(f)

    def fill(self, pipe: Any) -> None:
        """Keep about two chunks in flight per worker thread."""
        n_threads = self.threads()
        while self.queue and len(self.flying) < 2 * n_threads:
            self.submit(pipe, n_threads)

    def collect(self, f: Any, record: Record) -> None:
        """Record the runs of a finished chunk (error rows when the chunk itself failed)."""
        _, idx = self.flying.pop(f.key)
        try:
            results = f.result()
        except Exception as e:  # noqa: BLE001 - e.g. a worker lost three times: recorded
            results = [(_error_row(*self.tasks[i][:3], f"{type(e).__name__}: {e}"), [], "")
                       for i in idx]
        f.release()
        for i, (row, trace, wid) in zip(idx, results):
            if math.isfinite(row["wall_time"]):
                self.done_times.append(row["wall_time"])
            self.abandoned = self.abandoned or row["status"] == "time_limit"
            record(i, row, trace, wid)


def _dask_shutdown(feed: _DaskFeed, cluster: Any, pids: Sequence[int], stop_now: bool) -> None:
    """Cancel what is in flight, close the client and our own cluster, best effort.

    Every finished run is stored by now: a slow or failing shutdown must not lose the sweep
    (e.g. a TimeoutError closing a busy cluster on a loaded machine).
    """
    client, flying = feed.client, feed.flying
    steps = [lambda: client.cancel([f for f, _ in flying.values()]) if flying else None,
             lambda: client.close(timeout=5)]
    if cluster is not None:
        if stop_now:  # our own workers stop now, not after their runs
            steps.append(lambda: _kill(pids))
        steps.append(lambda: cluster.close(timeout=5))
    for step in steps:
        try:
            step()
        except Exception:  # noqa: BLE001 - best effort, after every run is recorded
            pass


def _run_dask(todo: Sequence[int], tasks: Sequence[Task], hard: float | None,
              init: Mapping[str, Any], record: Record, scheduler: str | None,
              dask_local: int | None) -> None:
    """Runs on Dask, streamed back as they complete.

    A Dask task costs milliseconds of scheduling (more than a fast run), so consecutive runs
    are grouped into chunks of about :data:`DASK_CHUNK_SECONDS` of solver time (estimated from
    the median run so far; one run per chunk until the first results arrive), with about two
    chunks in flight per worker thread.  An interrupt cancels the chunks in flight.
    """
    distributed = _import_dask()
    client, cluster = _dask_client(distributed, scheduler, dask_local)
    feed = _DaskFeed(client, todo, tasks, init, hard)
    pids: list[int] = []
    interrupted = False
    try:
        if cluster is not None:
            pids = list(client.run(os.getpid).values())
        client.run(_worker_setup, init)  # workers joining later set up on their first task
        pipe = distributed.as_completed()
        feed.fill(pipe)
        for f in pipe:
            feed.collect(f, record)
            feed.fill(pipe)
    except BaseException:
        interrupted = True
        raise
    finally:
        _dask_shutdown(feed, cluster, pids, interrupted or feed.abandoned)


def expand_scen(problems: Sequence[str], directory: str | Path, *, radius: float = 0.0
                ) -> list[str]:
    """Replace every MovingAI ``.scen`` file among ``problems`` by one scenario per line.

    Each ``.scen`` is read with :func:`optplan.maps.read_scen` (its ``.map`` next to it; one
    robot of ``radius``, a point by default, from the start cell's centre to the goal cell's)
    and written with :func:`optplan.maps.write_batch` as ``<directory>/<scen stem>/<scen
    stem>-<line>.toml``; the paths of those files take the ``.scen``'s place, in line order
    (names and paths travel to worker processes; rewriting the same files on a rerun keeps a
    results database's cells, so ``db=`` resumes).  Other entries are kept as they are.

    Raises
    ------
    optplan.ProblemError
        A ``.scen`` (or its map) that cannot be read, or a line whose start or goal is
        blocked.
    """
    from optplan.maps import read_scen, write_batch

    out: list[str] = []
    for entry in problems:
        s = str(entry)
        if not s.lower().endswith(".scen"):
            out.append(s)
            continue
        batch = read_scen(s, radius=radius)
        stem = Path(s).name[: -len(".scen")]
        stem = stem[: -len(".map")] if stem.lower().endswith(".map") else stem
        out.extend(str(q) for q in write_batch(batch, Path(directory) / (stem or "scen")))
    return out


def _check_inputs(problems: Sequence[str], solvers: Sequence[str],
                  overrides: Overrides | None) -> None:
    from optplan.catalog import load_problem
    from optplan.solver import get_solver

    if not problems:
        raise ValueError("no problems given")
    if not solvers:
        raise ValueError("no solvers given")
    for p in problems:
        load_problem(p)
    for s in solvers:
        get_solver(s, **_overrides_for(overrides, s))


def _config(options: Mapping[str, Any], time_limit: float | None) -> str:
    """What a resumed sweep must match for one solver: its overrides and the time limit."""
    return _json({"overrides": dict(options), "time_limit": time_limit})


def _check_grid_args(workers: Any, time_limit: Any, time_grace: Any, scheduler: str | None,
                     dask_local: Any) -> bool:
    """Validate the engine and time-limit arguments of :func:`run_grid`; True to use Dask."""
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if time_limit is not None and (isinstance(time_limit, bool) or not isinstance(
            time_limit, (int, float)) or not 0 < time_limit < math.inf):
        raise ValueError(f"time_limit must be a number of seconds > 0, got {time_limit!r}")
    if time_grace is not None and not 0 <= time_grace < math.inf:
        raise ValueError(f"time_grace must be a number of seconds >= 0, got {time_grace!r}")
    if dask_local is not None and (isinstance(dask_local, bool) or not isinstance(
            dask_local, (int, np.integer)) or dask_local < 1):
        raise ValueError(f"dask_local must be an integer >= 1, got {dask_local!r}")
    use_dask = scheduler is not None or dask_local is not None
    if scheduler is not None and dask_local is not None:
        raise ValueError("give a Dask scheduler address or dask_local, not both")
    if use_dask and workers != 1:
        raise ValueError("workers sets the local process pool; on Dask the cluster's workers "
                         "run the sweep (leave workers = 1)")
    return use_dask


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


def _engine_name(scheduler: str | None, dask_local: int | None, workers: int) -> str:
    if scheduler:
        return f"dask {scheduler}"
    return f"dask-local {dask_local}" if dask_local else f"workers {workers}"


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
                init: Mapping[str, Any], record: Record, workers: int, use_dask: bool,
                scheduler: str | None, dask_local: int | None) -> None:
    """Run ``todo`` on the engine chosen: Dask, inline, or the process pool."""
    if use_dask:
        _run_dask(todo, tasks, hard, init, record, scheduler, dask_local)
    elif workers == 1 or len(todo) == 1:
        _run_inline(todo, tasks, hard, init, record)
    else:
        _run_pool(todo, tasks, int(workers), hard, init, record)


def run_grid(problems: Sequence[str], solvers: Sequence[str], seeds: int | Iterable[int],
             workers: int = 1, overrides: Overrides | None = None,
             progress: Callable[[int, int, dict[str, Any]], Any] | None = None, *,
             time_limit: float | None = None, db: str | Path | None = None,
             scheduler: str | None = None, dask_local: int | None = None,
             command_line: str | None = None, time_grace: float | None = None
             ) -> list[dict[str, Any]]:
    """Run every (problem, solver, seed) and return one tidy row per run.

    Parameters
    ----------
    problems : list of str
        Catalogue names or ``.toml`` paths (names, not objects, so that they travel cheaply
        to worker processes; on a remote Dask cluster a path must be readable by the workers).
    solvers : list of str
        Preset names, backend names or ``.toml`` preset paths.
    seeds : int or iterable of int
        ``N`` means seeds ``0 .. N-1``.  The same seeds are used for every solver.
    workers : int
        Processes; 1 runs inline.
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
    scheduler : str, optional
        Address of a Dask scheduler (``"tcp://host:8786"``) to run on.
    dask_local : int, optional
        Start a Dask ``LocalCluster`` with this many worker processes and run on it.
    command_line : str, optional
        Recorded in the database's ``experiment`` table (default: ``sys.argv``).
    time_grace : float, optional
        Seconds past ``time_limit`` before the harness stops a run (default
        ``max(1, time_limit / 2)``).

    Returns
    -------
    list of dict
        Rows with the keys :data:`COLUMNS`, ordered by problem, solver, seed.
    """
    problems = [str(p) for p in problems]
    solvers = [str(s) for s in solvers]
    seed_list = _seed_list(seeds)
    use_dask = _check_grid_args(workers, time_limit, time_grace, scheduler, dask_local)
    _check_inputs(problems, solvers, overrides)
    if use_dask:
        _import_dask()
    options = {s: _overrides_for(overrides, s) for s in solvers}
    tasks: list[Task] = [(p, s, k, options[s], time_limit)
                         for p in problems for s in solvers for k in seed_list]
    total = len(tasks)
    configs = {s: _config(options[s], time_limit) for s in solvers}
    hard = _hard_limit(time_limit, time_grace)
    rows: list[dict[str, Any] | None] = [None] * total
    todo = list(range(total))
    store, exp_id = None, 0
    if db is not None:
        spec = {"problems": problems, "solvers": solvers, "seeds": seed_list,
                "overrides": {k: dict(v) for k, v in (overrides or {}).items()},
                "time_limit": time_limit,
                "engine": _engine_name(scheduler, dask_local, workers)}
        store, exp_id, todo = _open_db(db, tasks, configs, rows, spec, command_line)
    n_done = 0

    def record(i: int, row: dict[str, Any], trace: Trace, worker: str) -> None:
        nonlocal n_done
        rows[i] = row
        if store is not None:
            store.add_run(exp_id, row, configs[tasks[i][1]], trace, worker)
        n_done += 1
        if progress is not None:
            progress(n_done, len(todo), row)

    outcome = "error"
    try:
        if todo:
            init = _worker_init(problems, solvers, options)
            _run_engine(todo, tasks, hard, init, record, workers, use_dask, scheduler,
                        dask_local)
        outcome = "complete"
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise
    finally:
        if store is not None:
            store.end_experiment(exp_id, outcome, n_done)
            store.close()
    return [r for r in rows if r is not None]


# --------------------------------------------------------------------------------------
# statistics and tables
# --------------------------------------------------------------------------------------


def _stats(values: Sequence[float]) -> tuple[float, float]:
    """Median and IQR (q75 - q25) of the finite values; (nan, nan) when none."""
    v = np.asarray([_num(x) for x in values], dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return float("nan"), float("nan")
    q25, q50, q75 = np.percentile(v, [25, 50, 75])
    return float(q50), float(q75 - q25)


def _truthy(x: Any) -> bool:
    if isinstance(x, str):
        return x.strip().lower() in ("true", "1", "yes")
    return bool(x)


def summarise(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Median / IQR / success rate per (problem, solver), in first-appearance order.

    Returns dicts with ``problem``, ``solver``, ``runs``, ``success`` (fraction of all runs
    with status ``optimal`` or ``solved``), ``n_success``, ``errors`` (runs that raised),
    ``timeouts`` (runs stopped by the time limit, by the solver or by the harness),
    ``length_median``, ``length_iqr``, ``ratio_median``, ``ratio_iqr`` and
    ``min_clearance_median`` over the **successful** runs only (nan when there is none),
    ``collisions_median`` and ``n_eval_median`` over the runs that returned (no error, not
    stopped by the harness), ``time_median``, ``time_iqr`` (seconds) over every run that did
    not raise.
    """
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((str(r["problem"]), str(r["solver"])), []).append(r)
    out = []
    for (p, s), rs in groups.items():
        good = [r for r in rs if _truthy(r["success"])]
        returned = [r for r in rs if r.get("status") not in ("error", "time_limit")]
        timed = [r for r in rs if r.get("status") != "error"]
        length = _stats([r["length"] for r in good])
        ratio = _stats([r["ratio"] for r in good])
        tm = _stats([r["wall_time"] for r in timed])
        out.append({
            "problem": p,
            "solver": s,
            "runs": len(rs),
            "success": len(good) / len(rs),
            "n_success": len(good),
            "errors": sum(r.get("status") == "error" for r in rs),
            "timeouts": sum(r.get("stop_reason") in ("time_limit", "hard_limit")
                            or r.get("status") == "time_limit" for r in rs),
            "length_median": length[0],
            "length_iqr": length[1],
            "ratio_median": ratio[0],
            "ratio_iqr": ratio[1],
            "collisions_median": _stats([r["collisions"] for r in returned])[0],
            "min_clearance_median": _stats([r["min_clearance"] for r in good])[0],
            "time_median": tm[0],
            "time_iqr": tm[1],
            "n_eval_median": _stats([r["n_eval"] for r in returned])[0],
        })
    return out


def _fmt(x: Any, digits: int = 2) -> str:
    v = _num(x)
    if not math.isfinite(v):
        return "-"
    return f"{v:.{digits}f}"


def to_markdown(summary: Sequence[Mapping[str, Any]]) -> str:
    """A markdown table of :func:`summarise` output (times in milliseconds).

    Length and ratio columns are over the successful runs only ("-" when none succeeded).
    """
    head = ["problem", "solver", "runs", "success", "length median", "length IQR",
            "ratio median", "ratio IQR", "collisions median", "time median (ms)",
            "time IQR (ms)", "evals median"]
    lines = ["| " + " | ".join(head) + " |",
             "|" + "|".join(["---"] * 2 + ["---:"] * (len(head) - 2)) + "|"]
    for s in summary:
        succ = f"{100 * s['success']:.0f} %"
        notes = []
        if s.get("errors"):
            notes.append(f"{s['errors']} errors")
        if s.get("timeouts"):
            notes.append(f"{s['timeouts']} at time limit")
        if notes:
            succ += f" ({', '.join(notes)})"
        cells = [
            str(s["problem"]), str(s["solver"]), str(s["runs"]), succ,
            _fmt(s["length_median"]), _fmt(s["length_iqr"]),
            _fmt(s["ratio_median"], 4), _fmt(s["ratio_iqr"], 4),
            _fmt(s["collisions_median"], 0) if math.isfinite(_num(s["collisions_median"]))
            else "-",
            _fmt(1e3 * _num(s["time_median"]), 1), _fmt(1e3 * _num(s["time_iqr"]), 1),
            _fmt(s["n_eval_median"], 0),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_csv(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write tidy rows to ``path`` (columns :data:`COLUMNS` first, then any extras)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fields = list(COLUMNS)
    for r in rows:
        for k in r:
            if k not in fields:
                fields.append(k)
    with p.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=fields, restval="")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})
    return p


def read_csv(path: str | Path) -> list[dict[str, Any]]:
    """Read rows written by :func:`write_csv` back (numbers as float/int, success as bool)."""
    ints = {"seed", "collisions", "n_iter", "n_eval"}
    floats = {"length", "ratio", "min_clearance", "wall_time", "optimum", "reference_time"}
    out = []
    with Path(path).open(newline="", encoding="utf-8") as fh:
        for r in csv.DictReader(fh):
            row: dict[str, Any] = dict(r)
            for k in ints & row.keys():
                row[k] = int(row[k]) if row[k] not in ("", None) else 0
            for k in floats & row.keys():
                row[k] = _num(row[k])
            if "success" in row:
                row["success"] = _truthy(row["success"])
            out.append(row)
    return out
