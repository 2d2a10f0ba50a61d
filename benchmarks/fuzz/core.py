"""The fuzz harness's records and limits: :class:`Case`, :class:`Outcome`, the families,
the outcome categories and the CPU, stall and memory limits of a case."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: the repository (the workers run there: ``python -m benchmarks.fuzz --worker``)
ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = ROOT / "problems"

#: A case still running after this many CPU seconds (its worker's and the worker's children's;
#: wall seconds where ``/proc`` is missing) is a hang (its worker is killed).
HANG_S = 10.0
#: ... or after this many wall seconds in which its worker used no CPU at all (a case blocked
#: forever: a deadlock).  Not a speed limit: a runnable process gets CPU time however loaded the
#: machine, and a case waiting for a kernel another process compiles (a lock) waits far less.
STALL_S = 600.0
#: A worker that used this many CPU seconds without becoming ready (it imports optplan: ~1-2 s)
#: is an error of the fuzz setup; so is one that died or stalled (:data:`STALL_S`) first.
STARTUP_CPU_S = 120.0
#: ``time_limit`` given to every solve of an accepted input (seconds).
SOLVE_TIME_LIMIT = 2.0
#: Extra time a case gets when it is the first of its preset (or family) in a worker process:
#: one-time costs of a fresh process (numba compilation, cvxpy, IPOPT, matplotlib) are not
#: the input's.  A worker killed after a hang is replaced by a fresh (cold) one.
COLD_S = 60.0
#: Address-space limit of a worker process (bytes).
MEMORY_LIMIT = 6 * 2**30
#: Longest acceptable error message (characters): longer ones dump the input.
MAX_MESSAGE = 1200

#: the families of inputs, in the order of the counts table
FAMILIES = ("scenario", "option", "init", "result", "map", "database", "plugin", "path", "crop",
            "scen", "arena")
CATEGORIES = ("clear error", "accepted and solved", "crash", "hang", "unclear message",
              "silently accepted", "success disagrees")
BAD = ("crash", "hang", "unclear message", "silently accepted", "success disagrees")


@dataclass
class Case:
    """One fuzz input.

    ``keys``: an error must name one of them (a scenario key such as ``obstacles[2].vertices``,
    which a more specific key such as ``obstacles[2].vertices[1][0]`` also satisfies, an option
    name, ``init`` or a pseudo key such as ``invalid TOML``).  ``must_reject``: the input is
    outside the documented ranges, so accepting it is a silent acceptance.
    """

    family: str
    id: str
    what: str
    data: dict[str, Any]
    keys: tuple[str, ...] = ()
    must_reject: bool = False


@dataclass
class Outcome:
    case: Case
    category: str
    detail: str = ""
    seconds: float = 0.0
    known: str | None = None
    compared: bool = False
