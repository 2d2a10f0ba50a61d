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
* **Engines** (:class:`Engine`): ``Engine()`` (``workers = 1``) runs inline in the calling
  process; ``Engine(workers=N)``, ``N > 1``, starts that many worker processes (``spawn`` start
  method, safe with threaded numerical libraries such as CasADi), each running one run at a
  time, so that one run can be stopped by ending its process;
  ``Engine(scheduler="tcp://host:8786")`` runs on an existing Dask cluster and
  ``Engine(dask_local=N)`` on a :class:`distributed.LocalCluster` of ``N`` single-threaded worker
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

from optplan.bench.dask_engine import DASK_CHUNK_MAX as DASK_CHUNK_MAX
from optplan.bench.dask_engine import DASK_CHUNK_SECONDS as DASK_CHUNK_SECONDS
from optplan.bench.grid import Engine, run_grid
from optplan.bench.rows import COLUMNS, TIME_COLUMNS, row_from_result
from optplan.bench.rows import Overrides as Overrides
from optplan.bench.rows import Record as Record
from optplan.bench.rows import Task as Task
from optplan.bench.rows import Trace as Trace
from optplan.bench.run import run_one
from optplan.bench.scen import expand_scen
from optplan.bench.summary import read_csv, summarise, to_markdown, write_csv

__all__ = ["COLUMNS", "TIME_COLUMNS", "Engine", "run_grid", "run_one", "row_from_result",
           "summarise", "to_markdown", "write_csv", "read_csv", "expand_scen"]
