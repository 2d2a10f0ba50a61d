"""Waiting for a child process without a wall-clock deadline (issue 42).

A test's ``subprocess.run(..., timeout=120)`` fails when a loaded machine (a shared CI runner
at load 8-17 on 2 cores) makes the child slow, not wrong.  These helpers wait as long as the
child computes and stop it only when it is broken:

* a **runaway**: the child and its descendants used more than ``cpu_limit`` CPU seconds
  (:data:`CPU_LIMIT_S` by default: far beyond any test's child; CPU time does not grow with the
  load);
* a **deadlock**: the child's process tree used no CPU at all for :data:`STALL_S` wall seconds
  (a runnable process gets CPU time even on a loaded machine; one blocked forever does not).

Either kills the whole tree and fails the test with a message saying which.  CPU time is read
from ``/proc`` (Linux), else from psutil when installed; with neither, only the suite's own
deadline applies.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from typing import Any

#: CPU seconds (the child's and its descendants') after which a child is a runaway.
CPU_LIMIT_S = 900.0
#: Wall seconds without any CPU time used by the child's tree after which it is deadlocked.
STALL_S = 900.0
#: How often the child is looked at (seconds).
POLL_S = 0.05


def _proc_table() -> dict[int, tuple[int, float]] | None:
    """pid -> (parent pid, CPU seconds incl. reaped children) of every process, or None."""
    if os.path.isdir("/proc"):
        tick = os.sysconf("SC_CLK_TCK")
        table = {}
        for d in os.listdir("/proc"):
            if not d.isdigit():
                continue
            try:
                with open(f"/proc/{d}/stat") as f:
                    rest = f.read().rpartition(")")[2].split()
            except OSError:
                continue
            # after the name: state, ppid, ..., utime (12th), stime, cutime, cstime
            table[int(d)] = (int(rest[1]), sum(int(x) for x in rest[11:15]) / tick)
        return table
    try:
        import psutil
    except ImportError:
        return None
    table = {}
    for p in psutil.process_iter(["ppid", "cpu_times"]):
        t = p.info["cpu_times"]
        if t is not None:
            table[p.pid] = (p.info["ppid"], t.user + t.system + t.children_user
                            + t.children_system)
    return table


def tree(pid: int, table: dict[int, tuple[int, float]]) -> list[int]:
    """``pid`` and its descendants present in ``table``."""
    out, todo = [], [pid] if pid in table else []
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, (pp, _) in table.items() if pp == p]
    return out


def tree_cpu(pid: int) -> float | None:
    """CPU seconds used so far by process ``pid`` and its descendants (None when unknown)."""
    table = _proc_table()
    if table is None or pid not in table:
        return None
    return sum(table[p][1] for p in tree(pid, table))


def kill_tree(pid: int) -> None:
    """SIGKILL ``pid`` and its descendants."""
    table = _proc_table() or {}
    for p in tree(pid, table) or [pid]:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


class Watch:
    """The limits of one child: :meth:`check` fails (after killing the child's tree) once it
    is a runaway or deadlocked."""

    def __init__(self, proc: subprocess.Popen, what: str = "", cpu_limit: float = CPU_LIMIT_S,
                 stall_s: float = STALL_S):
        self.proc, self.cpu_limit, self.stall_s = proc, cpu_limit, stall_s
        self.what = what or " ".join(map(str, proc.args))[:200]  # type: ignore[arg-type]
        self.cpu = tree_cpu(proc.pid) or 0.0
        self.progress_at = time.monotonic()

    def check(self) -> None:
        cpu = tree_cpu(self.proc.pid)
        if cpu is None:  # gone (or no way to tell): the caller sees its end
            return
        now = time.monotonic()
        if cpu > self.cpu:
            self.cpu, self.progress_at = cpu, now
        if cpu > self.cpu_limit:
            kill_tree(self.proc.pid)
            raise AssertionError(f"runaway child killed: it used {cpu:.0f} CPU s (limit "
                                 f"{self.cpu_limit:g}): {self.what}")
        if now - self.progress_at > self.stall_s:
            kill_tree(self.proc.pid)
            raise AssertionError(f"deadlocked child killed: no CPU time used in "
                                 f"{self.stall_s:g} s of wall time: {self.what}")


def communicate(proc: subprocess.Popen, input: Any = None, **limits: Any) -> tuple[Any, Any]:
    """``proc.communicate(input)`` without a wall deadline (see the module docstring)."""
    watch = Watch(proc, **limits)
    started = False
    while True:
        try:
            return proc.communicate(None if started else input, timeout=POLL_S * 4)
        except subprocess.TimeoutExpired:  # retrying loses no output
            started = True
            watch.check()


def run(args: Sequence[str], *, input: Any = None, check: bool = False,
        capture_output: bool = False, cpu_limit: float = CPU_LIMIT_S, stall_s: float = STALL_S,
        **kw: Any) -> subprocess.CompletedProcess:
    """``subprocess.run`` without a wall-clock ``timeout`` (see the module docstring)."""
    if capture_output:
        kw.update(stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if input is not None:
        kw["stdin"] = subprocess.PIPE
    with subprocess.Popen(args, **kw) as proc:
        try:
            out, err = communicate(proc, input, cpu_limit=cpu_limit, stall_s=stall_s)
        finally:
            if proc.poll() is None:
                kill_tree(proc.pid)
    res = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    if check:
        res.check_returncode()
    return res


def wait_until(cond: Callable[[], bool], proc: subprocess.Popen, what: str = "",
               **limits: Any) -> None:
    """Wait until ``cond()`` holds while ``proc`` runs (no wall deadline); fails when ``proc``
    ends first (with its output) or breaks a limit of :class:`Watch`."""
    watch = Watch(proc, what, **limits)
    while not cond():
        assert proc.poll() is None, (what, proc.communicate())
        watch.check()
        time.sleep(POLL_S)
