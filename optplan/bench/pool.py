"""Process execution of a sweep: inline runs and a pool of worker processes (one task each at a
time, killed and replaced past the hard limit)."""

from __future__ import annotations

import multiprocessing
import os
import platform
import signal
import sys
import time
import uuid
from collections import deque
from collections.abc import Mapping, Sequence
from multiprocessing.connection import wait as _mp_wait
from typing import Any

from optplan.bench.rows import Record, Task, _describe, _error_row, _limit_row
from optplan.bench.run import _execute, _guarded, _reference

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
    from optplan.bench.scen import load_bench_problem
    from optplan.solver import BACKENDS, get_solver, register

    for name, entry in init.get("backends", {}).items():
        if name not in BACKENDS:
            register(name, entry)
    for s, ov in init.get("solvers", ()):
        get_solver(s, **ov)
    for p in init.get("problems", ()):
        try:
            _reference(load_bench_problem(p))
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
    """A process-pool worker: set up, then run the tasks it is sent one at a time.  When the
    parent is gone (killed: SIGKILL, a crash) the worker ends quietly at its next message."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    try:
        try:
            _worker_setup(init)
        except BaseException as e:  # noqa: BLE001 - reported to the parent
            conn.send(("setup_error", _describe(e)))
            return
        wid = _worker_id()
        conn.send(("ready",))
        while True:
            msg = conn.recv()
            if msg is None:
                return
            i, task = msg
            row, trace = _execute(*task)
            conn.send(("done", i, row, trace, wid))
    except (EOFError, OSError):  # the parent's end of the pipe is closed (BrokenPipeError)
        return


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
