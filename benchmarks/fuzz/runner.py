"""Running the cases: :data:`RUNNERS` (family -> runner), the worker processes (a case that
overruns :data:`~benchmarks.fuzz.core.HANG_S` CPU seconds or stalls is killed) and
:func:`run_cases`."""

from __future__ import annotations

import dataclasses
import os
import pickle
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error
from benchmarks.fuzz.core import (
    COLD_S,
    HANG_S,
    MEMORY_LIMIT,
    ROOT,
    STALL_S,
    STARTUP_CPU_S,
    Case,
    Outcome,
)
from benchmarks.fuzz.databases import run_database
from benchmarks.fuzz.inits import run_init
from benchmarks.fuzz.maps import run_map
from benchmarks.fuzz.options import run_option
from benchmarks.fuzz.plugins import run_plugin
from benchmarks.fuzz.results import run_result
from benchmarks.fuzz.scenarios import run_scenario
from benchmarks.fuzz.surfaces import run_arena, run_crop, run_path, run_scen


def run_selftest(case: Case, tmp: Path) -> Outcome:
    """Harness self-test cases: spin (a hang that computes), sleep (a hang that waits),
    raise (a crash or an error message)."""
    d = case.data
    if "spin" in d:
        t_end = time.process_time() + d["spin"]
        while time.process_time() < t_end:
            pass
    if "sleep" in d:
        time.sleep(d["sleep"])
    if "raise" in d:
        exc = {"TypeError": TypeError, "ValueError": ValueError}[d["raise"]]
        try:
            raise exc(d.get("message", "boom"))
        except Exception as e:  # noqa: BLE001
            return Outcome(case, *_classify_error(e, case, None))
    return Outcome(case, "accepted and solved", "ok")


RUNNERS = {"scenario": run_scenario, "option": run_option, "init": run_init,
           "result": run_result, "selftest": run_selftest, "map": run_map,
           "database": run_database, "plugin": run_plugin, "path": run_path, "crop": run_crop,
           "scen": run_scen, "arena": run_arena}


def run_case(case: Case, tmp: Path) -> Outcome:
    import warnings

    t0 = time.perf_counter()
    sub = tmp / f"c{abs(hash(case.id)) % 10**8}"
    sub.mkdir(parents=True, exist_ok=True)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = RUNNERS[case.family](case, sub)
    except RecursionError as e:
        out = Outcome(case, "crash", f"RecursionError in the harness: {e}")
    finally:
        shutil.rmtree(sub, ignore_errors=True)
    out.seconds = time.perf_counter() - t0
    return out



def _send(stream, obj: Any) -> None:
    b = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    data = memoryview(struct.pack("<Q", len(b)) + b)
    while data:
        n = stream.write(data)
        data = data[n if n is not None else len(data):]
    stream.flush()


def _read_exactly(stream, n: int) -> bytes:
    buf = b""
    while len(buf) < n:
        chunk = stream.read(n - len(buf))
        if not chunk:
            raise EOFError
        buf += chunk
    return buf


def _recv(stream) -> Any:
    """One message; the parent reads an unbuffered pipe (no read-ahead hides a message from
    ``select``)."""
    (n,) = struct.unpack("<Q", _read_exactly(stream, 8))
    return pickle.loads(_read_exactly(stream, n))


def _case_to_dict(c: Case) -> dict:
    return dataclasses.asdict(c)


def _cold_key(case: Case) -> str:
    """What a case's first use in a process compiles (numba, cvxpy, IPOPT, matplotlib)."""
    return case.data.get("preset") or {"scenario": "visgraph", "result": "plot",
                                       "database": "plot"}.get(case.family, case.family)


def worker_main() -> None:
    """Serve cases on stdin/stdout (length-prefixed pickles); prints go to /dev/null."""
    try:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    except (ImportError, ValueError, OSError):
        pass
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 1000))
    proto_in = os.fdopen(os.dup(0), "rb")
    proto_out = os.fdopen(os.dup(1), "wb")
    devnull = os.open(os.devnull, os.O_RDWR)
    os.dup2(devnull, 0)
    os.dup2(devnull, 1)
    sys.stdout = open(os.devnull, "w")  # noqa: SIM115
    os.environ.setdefault("MPLBACKEND", "Agg")
    tmp = Path(tempfile.mkdtemp(prefix="optplan-fuzz-"))
    import optplan  # noqa: F401  (import once, before the first case)

    _send(proto_out, {"ready": True})
    warmed: set[str] = set()
    try:
        while True:
            try:
                msg = _recv(proto_in)
            except EOFError:
                break
            case = Case(**msg)
            key = _cold_key(case)
            _send(proto_out, {"started": True,
                              "cold": key not in warmed and case.family != "selftest"})
            warmed.add(key)
            try:
                out = run_case(case, tmp)
                reply = {"category": out.category, "detail": out.detail,
                         "seconds": out.seconds, "compared": out.compared}
            except MemoryError:
                reply = {"category": "crash", "detail": "MemoryError", "seconds": 0.0,
                         "compared": False}
            _send(proto_out, reply)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


class _Worker:
    def __init__(self, log: Path):
        self.log = open(log, "ab")  # noqa: SIM115
        env = {**os.environ, "PYTHONHASHSEED": "0", "MPLBACKEND": "Agg",
               "PYTHONWARNINGS": "ignore"}
        # the package from the repository (cwd): python -m benchmarks.fuzz --worker
        self.proc = subprocess.Popen([sys.executable, "-m", "benchmarks.fuzz", "--worker"],
                                     stdin=subprocess.PIPE, bufsize=0, stdout=subprocess.PIPE,
                                     stderr=self.log, env=env, cwd=str(ROOT))
        self.log_path = log
        self.case: Case | None = None
        self.t0 = time.monotonic()
        self.cpu0: float | None = _tree_cpu(self.proc.pid)
        self.ready = False
        self.running = False  # the case's clock runs
        self.budget = HANG_S
        self.last_cpu, self.progress_at = self.cpu0, self.t0  # the stall watch

    def start_case(self, case: Case) -> None:
        self.case, self.t0, self.running = case, time.monotonic(), False
        self.cpu0 = _tree_cpu(self.proc.pid)
        self.last_cpu, self.progress_at = self.cpu0, self.t0
        _send(self.proc.stdin, _case_to_dict(case))

    def used(self, now: float) -> tuple[float, float, float]:
        """``(CPU seconds, wall seconds, wall seconds without CPU progress)`` since the current
        case was sent (or since the worker started, before it is ready); CPU: wall where
        ``/proc`` is missing (and then no stall)."""
        wall = now - self.t0
        cpu = _tree_cpu(self.proc.pid)
        if cpu is None or self.cpu0 is None:
            return wall, wall, 0.0
        if self.last_cpu is None or cpu > self.last_cpu:
            self.last_cpu, self.progress_at = cpu, now
        return cpu - self.cpu0, wall, now - self.progress_at

    def log_tail(self) -> str:
        self.log.flush()
        try:
            return self.log_path.read_text(errors="replace")[-1500:]
        except OSError:
            return ""

    def kill(self) -> None:
        """Kill the worker and its descendants (a plugin case's child)."""
        _kill_tree(self.proc.pid)
        try:
            self.proc.wait(timeout=60)  # SIGKILLed: reaped at once (not a limit on the case)
        except (OSError, subprocess.TimeoutExpired):
            pass
        self.log.close()


class _Tally:
    """The outcomes of a fuzz run so far (and the progress callback)."""

    def __init__(self, total: int, progress: Callable[[int, int, Outcome], None] | None):
        self.results: dict[str, Outcome] = {}
        self.total = total
        self.progress = progress

    def record(self, out: Outcome) -> None:
        self.results[out.case.id] = out
        if self.progress:
            self.progress(len(self.results), self.total, out)


def _on_message(w: _Worker, msg: dict | None, tally: _Tally, hang_s: float) -> bool:
    """Handle one message of worker ``w``; ``True`` when the worker died and must be
    replaced (a case it was running is a crash)."""
    if msg is None:
        if not w.ready:
            raise RuntimeError(f"a fuzz worker exited before it was ready (exit "
                               f"{w.proc.wait()}); its log {w.log_path}:\n{w.log_tail()}")
        if w.case is not None:
            tally.record(Outcome(w.case, "crash", f"worker died (exit {w.proc.poll()})",
                                 time.monotonic() - w.t0))
        return True
    if "ready" in msg:
        w.ready = True
    elif "started" in msg:
        w.running = True
        w.budget = hang_s + (COLD_S if msg.get("cold") else 0.0)
    else:
        tally.record(Outcome(w.case, msg["category"], msg["detail"], msg["seconds"],
                             compared=msg["compared"]))
        w.case = None
    return False


def _check_hangs(pool: list[_Worker], tally: _Tally, hang_s: float, log_dir: Path,
                 stall_s: float = STALL_S, startup_cpu_s: float = STARTUP_CPU_S) -> None:
    """A case over its CPU budget, or whose worker used no CPU for ``stall_s`` wall seconds,
    is a hang (its worker is replaced); a worker that does not become ready (it stalls, or
    uses ``startup_cpu_s`` CPU seconds first) is an error of the fuzz setup.  No wall-clock
    limit otherwise: a loaded machine only makes the wait longer."""
    now = time.monotonic()
    for w in list(pool):
        if not w.ready:
            cpu, wall, stalled = w.used(now)
            if cpu > startup_cpu_s or stalled > stall_s:
                why = (f"used {cpu:.0f} CPU s" if cpu > startup_cpu_s else
                       f"used no CPU for {stalled:.0f} s (blocked)")
                raise RuntimeError(f"a fuzz worker {why} without becoming ready ({wall:.0f} s "
                                   f"after it started); its log {w.log_path}:\n{w.log_tail()}")
            continue
        if w.case is None:
            continue
        over = w.budget if w.running else startup_cpu_s  # sent, not yet started: the import
        cpu, wall, stalled = w.used(now)
        if cpu > over or stalled > stall_s:
            cold = " (including a cold start)" if over > hang_s else ""
            why = (f"still running after {over:g} CPU s{cold}" if cpu > over else
                   f"blocked: its worker used no CPU for {stalled:.0f} s (a deadlock?)")
            tally.record(Outcome(w.case, "hang", f"{why} ({cpu:.1f} CPU s, {wall:.1f} wall s)",
                                 wall))
            w.case = None
            _replace(pool, w, log_dir)


def _proc_table() -> dict[int, tuple[int, int]] | None:
    """pid -> (parent pid, CPU clock ticks incl. reaped children) of every process
    (``/proc``: Linux; None elsewhere)."""
    try:
        stats = {}
        for d in os.listdir("/proc"):
            if d.isdigit():
                try:
                    with open(f"/proc/{d}/stat") as f:
                        rest = f.read().rpartition(")")[2].split()
                except OSError:
                    continue
                # fields after the name: state, ppid, ..., utime (12th), stime, cutime, cstime
                stats[int(d)] = (int(rest[1]), sum(int(x) for x in rest[11:15]))
    except OSError:
        return None
    return stats


def _tree(pid: int, stats: dict[int, tuple[int, int]]) -> list[int]:
    """``pid`` and its descendants in ``stats`` (:func:`_proc_table`)."""
    out, todo = [], [pid] if pid in stats else []
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, (pp, _) in stats.items() if pp == p]
    return out


def _tree_cpu(pid: int) -> float | None:
    """CPU seconds used so far by process ``pid`` and its descendants (``/proc``: Linux;
    None elsewhere or when ``pid`` is gone)."""
    stats = _proc_table()
    if stats is None or pid not in stats:
        return None
    return sum(stats[p][1] for p in _tree(pid, stats)) / os.sysconf("SC_CLK_TCK")


def _kill_tree(pid: int) -> None:
    """SIGKILL process ``pid`` and its descendants."""
    import signal

    for p in _tree(pid, _proc_table() or {}) or [pid]:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


def run_cases(cases: list[Case], workers: int = 2, hang_s: float = HANG_S,
              progress: Callable[[int, int, Outcome], None] | None = None,
              log_dir: Path | None = None, stall_s: float = STALL_S,
              startup_cpu_s: float = STARTUP_CPU_S) -> list[Outcome]:
    """Run every case in ``workers`` worker processes; a case running longer than
    ``hang_s`` CPU seconds, or whose worker used no CPU for ``stall_s`` wall seconds, is a
    hang (its worker is killed and replaced).  A worker has no start-up deadline: it is
    used once it says it is ready (:func:`_check_hangs` catches one that never will)."""
    log_dir = Path(log_dir or tempfile.mkdtemp(prefix="optplan-fuzz-logs-"))
    log_dir.mkdir(parents=True, exist_ok=True)
    todo = list(reversed(cases))
    tally = _Tally(len(cases), progress)
    pool = [_Worker(log_dir / f"worker{i}.log") for i in range(max(1, workers))]
    try:
        while len(tally.results) < len(cases):
            for w in pool:
                if w.ready and w.case is None and todo:
                    w.start_case(todo.pop())
            fds = {w.proc.stdout.fileno(): w for w in pool}
            ready, _, _ = select.select(list(fds), [], [], 0.2)
            for fd in ready:
                w = fds[fd]
                try:
                    msg = _recv(w.proc.stdout)
                except EOFError:
                    msg = None
                if _on_message(w, msg, tally, hang_s):
                    _replace(pool, w, log_dir)
            _check_hangs(pool, tally, hang_s, log_dir, stall_s, startup_cpu_s)
    finally:
        for w in pool:
            w.kill()
    return [tally.results[c.id] for c in cases]


def _replace(pool: list[_Worker], w: _Worker, log_dir: Path) -> None:
    i = pool.index(w)
    w.kill()
    pool[i] = _Worker(log_dir / f"worker{i}.log")
