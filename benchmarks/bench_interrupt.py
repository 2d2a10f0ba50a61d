"""How fast a sweep stops on Ctrl-C: the time from SIGINT to the exit of ``optplan bench``.

For each engine (inline, ``--workers 2``, ``--dask-local 2`` when ``dask[distributed]`` is
installed) a sweep of ``pso-paper`` on ``paper-env1`` and ``paper-env2`` (``k_max = 60``, 40
seeds) is started in a subprocess with a results database; once ``--after`` runs are stored,
SIGINT is sent and the time until the process exits is measured.  Printed per engine and
repetition: seconds from the signal to the exit, the exit status (130 expected) and the rows
kept.  The behaviour (exit 130, rows kept, resume) is what ``tests/tools/test_benchdb.py``
tests; the time is this script's figure (the docs quote it), measured on whatever else the
machine runs.

Run: ``python benchmarks/bench_interrupt.py [--repeats 3] [--after 6]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import signal
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _rows(db: Path) -> int:
    try:
        with sqlite3.connect(db) as con:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
    except sqlite3.Error:
        return 0


def one(engine: list[str], after: int, tmp: Path) -> tuple[float, int, int]:
    """(seconds from SIGINT to exit, exit status, rows kept) of one interrupted sweep."""
    db = tmp / f"i{time.monotonic_ns()}.sqlite"
    cmd = [sys.executable, "-m", "optplan", "bench", "--problems", "paper-env1,paper-env2",
           "--solvers", "pso-paper", "--set", "k_max=60", "--seeds", "40", *engine,
           "--db", str(db), "--out", str(tmp / "out"), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            cwd=tmp,  # SIGINT not ignored even when this script runs detached
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 300
        while _rows(db) < after and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=120)
        took = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
    return took, int(proc.returncode), _rows(db)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="sweeps per engine (3)")
    ap.add_argument("--after", type=int, default=6, help="runs stored before SIGINT (6)")
    a = ap.parse_args(argv)
    engines = {"inline": [], "--workers 2": ["--workers", "2"]}
    if importlib.util.find_spec("distributed") is not None:
        engines["--dask-local 2"] = ["--dask-local", "2"]
    print("## Ctrl-C: seconds from SIGINT to the exit of optplan bench\n")
    print(f"load average before: {os.getloadavg()[0]:.2f}\n")
    print("| engine | median s | worst s | exit statuses | rows kept |")
    print("|---|---:|---:|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for name, engine in engines.items():
            runs = [one(engine, a.after, Path(d)) for _ in range(a.repeats)]
            secs = [r[0] for r in runs]
            print(f"| {name} | {statistics.median(secs):.2f} | {max(secs):.2f} | "
                  f"{sorted({r[1] for r in runs})} | {[r[2] for r in runs]} |")


if __name__ == "__main__":
    main()
