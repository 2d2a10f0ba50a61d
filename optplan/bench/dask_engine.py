"""Dask execution of a sweep: chunks of tasks on a distributed cluster (local or a scheduler)."""

from __future__ import annotations

import math
import os
import signal
import time
from collections import deque
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from optplan.bench.pool import _worker_id, _worker_setup
from optplan.bench.rows import Record, Task, Trace, _error_row, _limit_row
from optplan.bench.run import _guarded


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
    out: list[tuple[dict[str, Any], Trace, str]] = []
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
