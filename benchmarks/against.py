"""Run a benchmark's queries on the current checkout and on older commits in one session.

The ``--against REV [REV ...]`` option of ``bench_sa_apf_grid.py``, ``bench_ipso.py`` and
``bench_visgraph.py``. Each ``REV`` is checked out in a temporary ``git worktree`` (its numba
kernels compile there on its worker's first query, before the timed part of that query); every
checkout gets one worker process, the benchmark script itself run with ``--worker`` and
``PYTHONPATH`` = the checkout, so ``import optplan`` loads that checkout's package (the
script's own code is the current one: a worker may only call what exists at both commits), all
workers on one CPU (:func:`shared_cpu`). A
worker answers one request per line of its standard input with one JSON line (:func:`serve`).
:func:`alternate` sends every query to every worker in turn, never to two at once, the order
reversed every query, so the machine's load hits all alike; :func:`compare` gives the ratio of
the medians (current / REV, wall and CPU: below 1 is faster) and how many queries gave the same
answer. Several revisions in one run bisect a regression: each row's ratio is against the
current checkout.

The answers carry ``wall`` and ``cpu`` seconds (:func:`timed`) and a ``digest`` of the answer
(:func:`digest`); whatever else the script puts in them passes through.
"""

from __future__ import annotations

import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CURRENT = "current"


def serve(answer: Callable[[list[str]], dict]) -> None:
    """The worker's loop: each line of standard input split into words, ``answer(words)``
    printed as one JSON line, until the input closes."""
    for line in sys.stdin:
        print(json.dumps(answer(line.split())), flush=True)


def timed(fn: Callable[[], Any]) -> tuple[Any, float, float]:
    """``fn()``, its wall seconds (``perf_counter``) and CPU seconds of this process
    (``process_time``)."""
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def digest(*parts: Any) -> str:
    """SHA-256 (hex) of ``parts``: strings as UTF-8, everything else as its float64 bytes."""
    h = hashlib.sha256()
    for p in parts:
        h.update(p.encode() if isinstance(p, str) else np.ascontiguousarray(p, float).tobytes())
    return h.hexdigest()


def shared_cpu() -> int | None:
    """The one CPU every worker runs on (the last this process may use), or None where the
    affinity cannot be set.  The workers answer one at a time, so one CPU costs them nothing;
    on two CPUs each worker used to settle on its own, and a CPU slowed by the host's other
    load (a virtual machine's neighbours) slowed one checkout for a whole run: five runs of
    ``bench_ipso.py --against`` on the same two commits gave ratios from 0.92 to 1.24 on one
    map (docs/solvers/pso.md)."""
    if not hasattr(os, "sched_getaffinity"):
        return None
    return max(os.sched_getaffinity(0))


class Worker:
    """The worker process of ``script --worker *args`` on the checkout at ``root``, pinned to
    :func:`shared_cpu` (its threads too)."""

    def __init__(self, script: str, root: Path, args: Sequence[str]) -> None:
        env = dict(os.environ, PYTHONPATH=str(root))
        cpu = shared_cpu()
        pin = None if cpu is None else (lambda: os.sched_setaffinity(0, {cpu}))
        self.p = subprocess.Popen([sys.executable, script, "--worker", *args], env=env,
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                  cwd=root, preexec_fn=pin)

    def ask(self, *words: object) -> dict:
        """Send one request (``words`` joined by spaces); the worker's JSON answer."""
        assert self.p.stdin is not None and self.p.stdout is not None
        request = " ".join(map(str, words))
        self.p.stdin.write(request + "\n")
        self.p.stdin.flush()
        out = self.p.stdout.readline()
        if not out:
            raise RuntimeError(f"the worker stopped on the request {request!r}")
        return json.loads(out)

    def close(self) -> None:
        """End the worker (closing its input ends its loop)."""
        assert self.p.stdin is not None
        self.p.stdin.close()
        self.p.wait()


@contextmanager
def workers(script: str, revs: Sequence[str] = (),
            args: Sequence[str] = ()) -> Iterator[dict[str, Worker]]:
    """Workers by checkout name: :data:`CURRENT` (this checkout) and each commit of ``revs``
    in a temporary worktree (removed at the end)."""
    with tempfile.TemporaryDirectory() as tmp:
        roots = {CURRENT: ROOT}
        for k, rev in enumerate(revs):
            wt = Path(tmp) / f"against-{k}"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt),
                            rev], check=True, capture_output=True)
            roots[rev] = wt
        started: dict[str, Worker] = {}
        try:
            for name, root in roots.items():
                started[name] = Worker(script, root, args)
            yield started
        finally:
            for w in started.values():
                w.close()
            for name, root in roots.items():
                if name != CURRENT:
                    subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                    str(root)], check=False, capture_output=True)


def alternate(pool: dict[str, Worker], jobs: Sequence[Sequence[object]]) -> dict[str, list[dict]]:
    """Every job (a request's words) on every worker, one at a time, the order of the
    workers swapped every job; ``{checkout: answers in job order}``.  Progress on stderr."""
    names = list(pool)
    out: dict[str, list[dict]] = {n: [] for n in names}
    for j, job in enumerate(jobs):
        for name in (names if j % 2 == 0 else names[::-1]):
            out[name].append(pool[name].ask(*job))
        print(f"  {' '.join(map(str, job))}: " + ", ".join(
            f"{n} {out[n][-1]['wall'] * 1e3:.1f} ms" for n in names),
            file=sys.stderr, flush=True)
    return out


def compare(cur: list[dict], old: list[dict],
            keep: Callable[[dict], bool] = lambda r: True) -> tuple[float, float, int, int]:
    """Ratio of the median wall and of the median CPU time (current / old), and the queries
    with the same ``digest`` among those that both sides ``keep``, and how many those are."""
    rw = statistics.median(r["wall"] for r in cur) / statistics.median(r["wall"] for r in old)
    rc = statistics.median(r["cpu"] for r in cur) / statistics.median(r["cpu"] for r in old)
    both = [(a, b) for a, b in zip(cur, old, strict=True) if keep(a) and keep(b)]
    return rw, rc, sum(a["digest"] == b["digest"] for a, b in both), len(both)


def table(groups: dict[tuple[str, ...], dict[str, list[dict]]], keys: Sequence[str],
          against: bool, unit: str = "ms",
          extra: tuple[Sequence[str], Callable[[list[dict]], list[str]]] = ((), lambda r: []),
          keep: Callable[[dict], bool] = lambda r: True) -> str:
    """The markdown table of a run: a row per group (its ``keys`` cells) and checkout with the
    queries, the ``extra`` columns (their headers and a function of the answers), the median
    and worst wall and CPU time (``unit`` ms: ".1f", s: ".2f"), a digest of all the answers in
    order (12 hex digits) and, ``against`` older commits, the ratio of the medians to the
    current checkout's and the same answers (:func:`compare`, among the answers both sides
    ``keep``)."""
    scale, fmt = (1e3, ".1f") if unit == "ms" else (1.0, ".2f")
    head = [*keys, "checkout", "queries", *extra[0], f"wall median / worst ({unit})",
            f"CPU median / worst ({unit})", "digest"]
    if against:
        head += ["median ratio current / checkout (wall, CPU)", "same answer"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for group, by in groups.items():
        for name, rows in by.items():
            cells = [*group, name, str(len(rows)), *extra[1](rows)]
            for k in ("wall", "cpu"):
                v = [r[k] * scale for r in rows]
                cells.append(f"{statistics.median(v):{fmt}} / {max(v):{fmt}}")
            cells.append(digest("".join(r["digest"] for r in rows))[:12])
            if against and name != CURRENT:
                rw, rc, same, n = compare(by[CURRENT], rows, keep)
                cells += [f"{rw:.2f}, {rc:.2f}", f"{same}/{n}"]
            elif against:
                cells += ["", ""]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def load_line(before: tuple[float, float, float], after: tuple[float, float, float]) -> str:
    """The machine and its load averages before and after a run."""
    import platform

    return (f"Machine: {platform.machine()}, {os.cpu_count()} cores; load average (1, 5, 15 "
            f"min) before {before[0]:.1f} {before[1]:.1f} {before[2]:.1f}, "
            f"after {after[0]:.1f} {after[1]:.1f} {after[2]:.1f}")
