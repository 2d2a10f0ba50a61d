"""Fuzz optplan's input validation (issue 14): bad input never crashes, never hangs, never lies.

Families of malformed input, each case run in a worker process with a limit of
:data:`~.core.HANG_S` seconds of CPU (the worker's and its children's), or of :data:`STALL_S` wall
seconds during which the worker used no CPU at all (a case blocked forever): a case still
running then is killed and counted as a hang.  No limit is a wall-clock one that a machine
shared with other jobs could reach: a loaded machine makes a case slower, not more
CPU-hungry, and a runnable process still gets CPU time.  Workers start with a readiness
handshake and no deadline of their own (one that dies, uses :data:`STARTUP_CPU_S` CPU seconds
or no CPU for :data:`STALL_S` seconds before it is ready is an error of the fuzz setup).  A
memory limit (:data:`MEMORY_LIMIT`) too:

* **scenario**: mutations of the catalogue's TOML scenes (``problems/*.toml``): deleted keys,
  wrong types (``type = ["polygon"]``, a table as ``type``, ``leader = ["r1"]``, 3000 nested
  arrays, ...), non-finite and huge numbers (``nan``, ``inf``, ``1e300``, ``-1e300``, ...),
  empty / degenerate / self-intersecting / duplicate-vertex polygons, starts and goals inside
  obstacles or outside the bounds, unknown keys, TOML syntax errors, non-UTF-8 bytes, empty
  files, directories, huge vertex counts, bad dynamic-obstacle time series, formations naming
  missing robots, the leader as a follower or no followers.  Each file is loaded with
  :func:`optplan.load_problem`; a rejected file is also given to ``optplan show`` (one line on
  stderr, exit 2); an accepted one is solved with ``visgraph`` and the solver's ``success`` is
  compared with an independent shapely check of the path (:func:`independent_check`).
* **option**: bad values for every option of every preset (:func:`optplan.list_solvers`): wrong
  types, ``nan``, ``inf``, ``-inf``, ``1e300``, ``-1e300``, ``0``, negative numbers, huge
  integers, wrong strings; as ``solve`` overrides and (for a share of them) inside a preset
  file.  Accepted values are solved on a small scene with a time limit.
* **init**: bad initial guesses for every preset (NaN, inf, huge, empty, wrong shapes, unknown
  robot ids, strings, ...).
* **result**: corrupted result JSON files (truncated, wrong types, shapes and lengths, ...),
  loaded with :meth:`optplan.Result.load` and drawn with ``optplan plot``.
* **map**: ROS ``map_server`` YAML files (every key out of range or of the wrong type,
  unknown and missing keys, bad YAML, non-UTF-8 bytes) with good and bad images (PGM
  ``maxval 0`` / 70000, zero width, truncated PGM and PNG, garbage), resolutions 1e-300 /
  1e300 / ``numpy.float32``, bare images, MovingAI ``.map`` files (a UTF-8 BOM, CRLF, a
  citation after the grid, a grid row too many) and in-memory ``nav_msgs/OccupancyGrid``
  dicts (wrong ``data`` length or values, ``"50"`` inside ``data``, numpy and ``bytes`` data,
  resolution <= 0 or 1e-300 or a numpy scalar, a tilted origin, 81M cells, ...), read with
  :func:`optplan.maps.read_grid` / :func:`~optplan.maps.read_occupancy_grid`; a rejected file
  is also given to ``optplan import-map``.
* **database**: results databases (intact, of another program, of schema version 99 or none,
  failing SQLite's integrity check, text SQLite cannot decode, truncated, byte flips, a text
  file, an empty file, a directory, a missing file, one locked by another connection) read
  with every :mod:`optplan.benchdb` reader, opened with ``ResultsDB`` and given to
  ``optplan report`` and ``optplan export-arena``.
* **path**: ``nav_msgs/Path`` dicts read with :func:`optplan.maps.read_path_msg`: stamps
  decreasing, out of ROS's range (``sec`` < 0 or >= 2**31, ``nanosec`` >= 10**9), of the
  wrong type, missing; bad poses, quaternions, keys; random stamp sequences; and paths
  written by :func:`~optplan.maps.timed_path_msg` read back.  An accepted path must have
  finite points and non-decreasing times in range.
* **crop**: ``import_map(..., crop=...)`` on a map with an unknown margin: ``"auto"``, bools
  and ``numpy.bool_`` must crop exactly when they say so, anything else (0, 1, 0.0,
  ``numpy.int64(0)``, strings, None, ...) is an error naming ``crop``; and extreme
  resolutions.
* **scen**: MovingAI ``.scen`` files read with :func:`optplan.maps.read_scen`: version lines,
  a UTF-8 BOM (in the ``.scen`` and the ``.map``), CRLF, blank lines, trailing text, wrong field
  counts, non-numbers, cells outside the map or blocked, bad optimal lengths, two maps, a
  missing map, non-UTF-8 bytes, empty files.
* **arena**: :func:`optplan.bench.summary.export_arena` and ``optplan export-arena`` of
  databases without runs or with a damaged row (``length = 'abc'``, a ``config`` that is not
  JSON, ...: the error names the file and the row), onto a directory, the database itself, a
  missing folder, an existing file; an export must load as an OMPL database with every run,
  and a failed one must leave no ``.tmp`` file behind.
* **plugin**: plugin distributions (entry points ``optplan.backends`` / ``optplan.presets``)
  whose package raises or exits when imported, with malformed entry points, missing modules,
  classes or preset folders, broken preset files, beside a working plugin; each case in a
  fresh Python process, which must still solve with ``visgraph``, run ``optplan list``, and
  name the distribution in the warning or error about the broken part.

Every case is classified:

==========================  ===========================================================
``clear error``             an optplan error (``ProblemError`` / ``ValueError`` /
                            ``ResultFileError``) whose message names the file (when there is
                            one) and the key or option
``accepted and solved``     accepted (and solved / loaded) without trouble
``crash``                   any other exception (or a dead worker)
``hang``                    still running after :data:`HANG_S` CPU seconds (or blocked,
                            with no CPU time, for :data:`STALL_S` seconds)
``unclear message``         an optplan error naming neither the file nor the key, a raw
                            ``UnicodeDecodeError`` / ``JSONDecodeError`` / numpy message, or
                            a CLI error that is not one line with exit status 2
``silently accepted``       a value outside its documented range accepted
``success disagrees``       the solver's ``success`` contradicts the independent path check
==========================  ===========================================================

Run ``python benchmarks/fuzz_inputs.py`` for the full run (>= 3,000 scenarios, >= 2,500 option
values, >= 200 inits, >= 50 result files, >= 100 maps, >= 25 databases, >= 15 plugins,
>= 50 path messages, >= 30 crop values, >= 30 ``.scen`` files, >= 15 exports;
``--workers N``, ``--seed S``, ``--quick``, ``--family F``) and the counts table;
``tests/tools/test_fuzz.py`` runs a bounded, seeded slice.  Known findings in files other
engineers own (backends, ``solve``'s option and ``init`` checks) are listed in
:data:`benchmarks.fuzz.report.KNOWN_FINDINGS`: cases they explain are reported in their own
column.

One module per surface, each with its cases and its runner: :mod:`.scenarios` (with
:mod:`.scenario_parts`, the mutators of a scene's parts, and :mod:`.values`, the TOML writer and
the bad values), :mod:`.options`, :mod:`.inits`, :mod:`.results`, :mod:`.maps`,
:mod:`.databases`, :mod:`.plugins`, :mod:`.surfaces` (path, crop, scen, arena); the machinery:
:mod:`.core` (records, limits), :mod:`.checks` (the independent path check, the message
classification), :mod:`.runner` (the worker processes) and :mod:`.report` (known findings,
the counts table, :func:`main`).  ``python benchmarks/fuzz_inputs.py`` and
``python -m benchmarks.fuzz`` (from the repository) run :func:`main`.
"""

from __future__ import annotations

from benchmarks.fuzz.checks import independent_check
from benchmarks.fuzz.core import (
                                  BAD,
                                  CATEGORIES,
                                  FAMILIES,
                                  HANG_S,
                                  MEMORY_LIMIT,
                                  STALL_S,
                                  STARTUP_CPU_S,
                                  Case,
                                  Outcome,
)
from benchmarks.fuzz.databases import database_cases
from benchmarks.fuzz.inits import init_cases
from benchmarks.fuzz.maps import map_cases
from benchmarks.fuzz.options import OptionFuzzer, preset_table
from benchmarks.fuzz.plugins import plugin_cases
from benchmarks.fuzz.report import (
                                  annotate,
                                  build_cases,
                                  counts_table,
                                  failures,
                                  known_finding,
                                  main,
                                  stale_findings,
                                  surface_cases,
)
from benchmarks.fuzz.results import result_cases
from benchmarks.fuzz.runner import run_case, run_cases
from benchmarks.fuzz.scenarios import ScenarioFuzzer
from benchmarks.fuzz.surfaces import arena_cases, crop_cases, path_cases, scen_cases
from benchmarks.fuzz.values import catalogue, toml_dumps

__all__ = ["BAD", "CATEGORIES", "FAMILIES", "HANG_S", "MEMORY_LIMIT", "STALL_S",
           "STARTUP_CPU_S", "Case", "Outcome", "OptionFuzzer", "ScenarioFuzzer", "annotate",
           "arena_cases", "build_cases", "catalogue", "counts_table", "crop_cases",
           "database_cases", "failures", "independent_check", "init_cases", "known_finding",
           "main", "map_cases", "path_cases", "plugin_cases", "preset_table", "result_cases",
           "run_case", "run_cases", "scen_cases", "stale_findings", "surface_cases",
           "toml_dumps"]
