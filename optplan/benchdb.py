"""The benchmark results database: one SQLite file, written one run at a time.

``optplan bench ... --db runs.sqlite`` (or :func:`optplan.bench.run_grid` with ``db=``) stores
every finished run as soon as it finishes, in its own transaction, so a crash or Ctrl-C loses at
most the runs that were still going.  Re-running the same sweep on the same file resumes it:
finished (problem, solver, seed) cells are read back instead of run again.

The file is plain SQLite (stdlib :mod:`sqlite3`; write-ahead log, whose ``-wal`` / ``-shm``
side files exist only while a sweep writes, so it is a single file when none is running) and
can be read with ``sqlite3``, pandas or DuckDB, also while a sweep is writing::

    import sqlite3, pandas as pd
    con = sqlite3.connect("runs.sqlite")
    runs = pd.read_sql("SELECT * FROM runs", con)
    conv = pd.read_sql("SELECT * FROM progress JOIN runs ON runs.id = progress.run_id", con)

Schema (version :data:`SCHEMA_VERSION`; ``docs/benchmarks.md`` has the same table):

``experiment``: one row per invocation of a sweep (a resumed sweep adds a row)
    ``id``, ``started`` / ``finished`` (ISO 8601, UTC), ``outcome`` (``complete``,
    ``interrupted``, ``error``; NULL while running or after a hard crash), ``optplan_version``,
    ``git_revision`` (``HEAD`` of the source checkout, ``+dirty`` when tracked files changed;
    NULL outside a checkout), ``python``, ``packages`` (JSON: name -> version or null),
    ``machine`` (JSON: host, platform, processor, CPU count), ``command_line``, ``spec`` (JSON:
    problems, solvers, seeds, overrides, time limit, engine), ``runs_planned``,
    ``runs_skipped`` (already in the file), ``runs_done`` (finished by this invocation).

``runs``: one row per (problem, solver, seed), UNIQUE on those three
    The columns of a tidy row (:data:`optplan.bench.COLUMNS`: status, length, optimum and
    ratio, clearance, collisions, times, the effective options; for a MovingAI ``.scen`` line
    its file, bucket, line and octile figures; among moving obstacles the grading in time,
    :data:`TIME_COLUMNS`), ``config`` (JSON: the sweep's overrides and time limit for this
    solver; a resume must match it), ``worker`` and ``finished``.  Columns added after the
    first files (:data:`_ADDED`) read as NULL from an older file, which gets them when a sweep
    writes to it.  NaN is stored as NULL; an infinite clearance (no obstacle) as ``Inf``.

``progress``: the convergence trace of each run
    ``run_id``, ``iteration``, ``best_cost`` (the backend's objective, as passed to the
    callback), ``n_eval``, ``time`` (wall seconds since the run started, measured by the
    harness the same way for every backend).  Only the first iteration, every improvement of
    the best cost and the last iteration are kept, thinned evenly to at most
    :data:`MAX_PROGRESS` rows per run.

``meta``: ``key``/``value`` pairs (``schema_version``).

Opening a file checks it before anything is read or written (:class:`ResultsDBError`, a
``ValueError``, naming the file): a file of another program (tables or columns missing), a
schema version other than :data:`SCHEMA_VERSION`, a file that fails SQLite's
``PRAGMA integrity_check`` or cannot be decoded, and a file another connection keeps locked
for more than :data:`LOCK_TIMEOUT` seconds are errors; a foreign file is never modified.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import sqlite3
import subprocess
import sys
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any

__all__ = ["SCHEMA", "SCHEMA_VERSION", "MAX_PROGRESS", "LOCK_TIMEOUT", "ResultsDB",
           "ResultsDBError", "experiment_info", "read_runs", "read_progress",
           "read_experiments", "thin_progress", "typed", "TIME_COLUMNS"]

SCHEMA_VERSION = 1
#: at most this many progress rows are stored per run
MAX_PROGRESS = 500
#: seconds to wait for a lock another connection holds on the file before giving up
LOCK_TIMEOUT = 30.0

SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (
    key   TEXT PRIMARY KEY,
    value TEXT
);
CREATE TABLE IF NOT EXISTS experiment (
    id              INTEGER PRIMARY KEY AUTOINCREMENT,
    started         TEXT NOT NULL,
    finished        TEXT,
    outcome         TEXT,
    optplan_version TEXT,
    git_revision    TEXT,
    python          TEXT,
    packages        TEXT,
    machine         TEXT,
    command_line    TEXT,
    spec            TEXT,
    runs_planned    INTEGER,
    runs_skipped    INTEGER,
    runs_done       INTEGER
);
CREATE TABLE IF NOT EXISTS runs (
    id             INTEGER PRIMARY KEY AUTOINCREMENT,
    experiment_id  INTEGER NOT NULL REFERENCES experiment(id),
    problem        TEXT NOT NULL,
    solver         TEXT NOT NULL,
    seed           INTEGER NOT NULL,
    status         TEXT NOT NULL,
    success        INTEGER NOT NULL,
    length         REAL,
    optimum        REAL,
    ratio          REAL,
    min_clearance  REAL,
    collisions     INTEGER,
    wall_time      REAL,
    reference_time REAL,
    n_iter         INTEGER,
    n_eval         INTEGER,
    stop_reason    TEXT,
    message        TEXT,
    backend        TEXT,
    options        TEXT,
    config         TEXT NOT NULL,
    worker         TEXT,
    finished       TEXT,
    scen           TEXT,
    bucket         INTEGER,
    scen_line      INTEGER,
    octile_optimum REAL,
    octile_ratio   REAL,
    arrival_at_goal REAL, time_reference REAL, time_lower_bound REAL,
    arrival_ratio_to_reference REAL, arrival_ratio_to_lower REAL,
    UNIQUE (problem, solver, seed)
);
CREATE TABLE IF NOT EXISTS progress (
    run_id    INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    iteration INTEGER NOT NULL,
    best_cost REAL,
    n_eval    INTEGER,
    time      REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS progress_run ON progress(run_id);
"""

#: The grading in time of a run among moving obstacles (the planned robot's,
#: :func:`optplan.time_grading.with_time_reference`; NULL without movers or an arrival).
TIME_COLUMNS = ("arrival_at_goal", "time_reference", "time_lower_bound",
                "arrival_ratio_to_reference", "arrival_ratio_to_lower")

#: columns of ``runs`` that come from a tidy row (:data:`optplan.bench.COLUMNS`)
_ROW_COLS = ("problem", "solver", "seed", "status", "success", "length", "optimum", "ratio",
             "min_clearance", "collisions", "wall_time", "reference_time", "n_iter", "n_eval",
             "stop_reason", "message", "backend", "options", "scen", "bucket", "scen_line",
             "octile_optimum", "octile_ratio", *TIME_COLUMNS)
_FLOATS = ("length", "optimum", "ratio", "min_clearance", "wall_time", "reference_time",
           "octile_optimum", "octile_ratio", *TIME_COLUMNS)
_INTS = ("seed", "collisions", "n_iter", "n_eval")
#: columns of ``runs`` added after the first files were written (the ``.scen`` columns, the
#: grading in time): a file without them is read as if they were NULL, and gets them when a
#: sweep writes to it
_ADDED = {"scen": "TEXT", "bucket": "INTEGER", "scen_line": "INTEGER", "octile_optimum": "REAL",
          "octile_ratio": "REAL", **dict.fromkeys(TIME_COLUMNS, "REAL")}


class ResultsDBError(ValueError):
    """A results database that cannot be used: locked, of another program, of another schema
    version, or damaged.  The message names the file."""


def _is_lock(e: sqlite3.Error) -> bool:
    code = getattr(e, "sqlite_errorcode", None)
    return code in (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED) or "locked" in str(e)


def _db_error(path: Path, e: sqlite3.Error) -> ResultsDBError:
    """The error to report for ``e``, raised by SQLite on the results database ``path``."""
    if _is_lock(e):
        return ResultsDBError(
            f"{path}: the results database is locked by another connection (waited "
            f"{LOCK_TIMEOUT:g} s); wait until the program holding it (another sweep, an open "
            f"sqlite3 shell) lets it go, or use another file")
    if isinstance(e, sqlite3.DatabaseError) and "not a database" in str(e):
        return ResultsDBError(f"{path}: not an optplan results database (not an SQLite file)")
    if "unable to open" in str(e):
        what = "a directory" if path.is_dir() else "no permission, or its folder is missing?"
        return ResultsDBError(f"{path}: cannot open the results database ({what})")
    return ResultsDBError(f"{path}: the results database is damaged ({e}); restore a copy, or "
                          f"run the sweep again into a new file")


@contextmanager
def _guarded(path: Path) -> Iterator[None]:
    """Turn SQLite's errors on ``path`` into :class:`ResultsDBError` naming the file."""
    try:
        yield
    except sqlite3.Error as e:
        raise _db_error(path, e) from None


@cache
def _layout() -> dict[str, tuple[str, ...]]:
    """Table -> columns of :data:`SCHEMA`."""
    con = sqlite3.connect(":memory:")
    try:
        con.executescript(SCHEMA)
        return _tables(con)
    finally:
        con.close()


def _tables(con: sqlite3.Connection) -> dict[str, tuple[str, ...]]:
    names = [r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table' "
                                       "AND name NOT LIKE 'sqlite_%' ORDER BY name")]
    return {t: tuple(r[1] for r in con.execute(f'PRAGMA table_info("{t}")')) for t in names}


def _check_layout(path: Path, tables: Mapping[str, Sequence[str]]) -> None:
    """Every table and column of :data:`SCHEMA` is there (extra ones are allowed)."""
    ours = ", ".join(_layout())
    for table, cols in _layout().items():
        if table not in tables:
            have = ", ".join(tables) or "none"
            raise ResultsDBError(f"{path}: not an optplan results database: no table {table!r} "
                                 f"(it has: {have}; optplan's tables: {ours})")
        missing = [c for c in cols if c not in tables[table]
                   and not (table == "runs" and c in _ADDED)]
        if missing:
            raise ResultsDBError(
                f"{path}: not an optplan results database: table {table!r} has no column "
                f"{', '.join(missing)} (its columns: {', '.join(tables[table])})")


def _check_version(path: Path, con: sqlite3.Connection) -> None:
    row = con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
    if row is None:
        raise ResultsDBError(f"{path}: not an optplan results database: table 'meta' has no "
                             f"schema_version")
    if str(row[0]) != str(SCHEMA_VERSION):
        raise ResultsDBError(
            f"{path}: meta.schema_version: results database schema version {row[0]!r}; this "
            f"optplan reads and writes version {SCHEMA_VERSION} only (a newer optplan wrote "
            f"it? upgrade optplan, or use another file)")


def _check_file(path: Path, con: sqlite3.Connection) -> bool:
    """Check an open results database before it is used; ``True`` when it has no tables yet
    (a new or empty file).  Raises :class:`ResultsDBError` naming the file."""
    tables = _tables(con)
    if not tables:
        return True
    _check_layout(path, tables)
    _check_version(path, con)
    bad = [r[0] for r in con.execute("PRAGMA integrity_check(3)")]
    if bad != ["ok"]:
        raise ResultsDBError(
            f"{path}: the results database fails SQLite's integrity check "
            f"({'; '.join(' '.join(b.split()) for b in bad)}); restore a copy, or run the "
            f"sweep again into a new file")
    return False


def _open(path: Path) -> sqlite3.Connection:
    """A connection to ``path`` waiting :data:`LOCK_TIMEOUT` seconds for locks."""
    with _guarded(path):
        return sqlite3.connect(str(path), timeout=LOCK_TIMEOUT)


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="milliseconds")


def _inserted_id(cur: sqlite3.Cursor) -> int:
    """The row id of the row the ``INSERT`` just run on ``cur`` added (``lastrowid`` is only
    ``None`` before any ``INSERT``)."""
    rid = cur.lastrowid
    if rid is None:
        raise sqlite3.DatabaseError("INSERT gave no row id")
    return int(rid)


def _float_in(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(v) else v


def _float_out(x: Any) -> float:
    return float("nan") if x is None else float(x)


def typed(path: Path, table: str, rid: Any, col: str, v: Any, kind: type,
          allowed: tuple = ()) -> Any:
    """A stored REAL (``kind`` float; NULL is nan) or INTEGER (int; NULL is None) in ``allowed``;
    else (``'abc'``, a blob, a fraction) an error naming the file, table, row and column."""
    ok = v is None or isinstance(v, (int, float)) and (kind is float or float(v).is_integer())
    if ok and (not allowed or v in allowed):
        return _float_out(v) if kind is float else None if v is None else int(v)
    want = f"one of {', '.join(map(str, allowed))}" if allowed else \
        "a number (REAL)" if kind is float else "an integer"
    raise ResultsDBError(f"{path}: the results database is damaged: table {table}, row id "
                         f"{rid}, column {col}: {v!r} is not {want}; fix or delete that row "
                         f"(sqlite3), or run the sweep again")


def thin_progress(trace: Sequence[tuple[int, float, int, float]],
                  cap: int = MAX_PROGRESS) -> list[tuple[int, float, int, float]]:
    """Keep the first row, every improvement of ``best_cost`` and the last row; at most ``cap``.

    ``trace`` rows are ``(iteration, best_cost, n_eval, time)``.  When more than ``cap`` rows
    remain, evenly spaced ones are kept (always the first and the last).

    >>> thin_progress([(0, 5.0, 1, 0.0), (1, 5.0, 2, 0.1), (2, 4.0, 3, 0.2), (3, 4.0, 4, 0.3)])
    [(0, 5.0, 1, 0.0), (2, 4.0, 3, 0.2), (3, 4.0, 4, 0.3)]
    """
    if not trace:
        return []
    keep = [0]
    best = trace[0][1]
    for i in range(1, len(trace)):
        c = trace[i][1]
        if c == c and (best != best or c < best):  # c < best, nan-safe
            keep.append(i)
            best = c
    if keep[-1] != len(trace) - 1:
        keep.append(len(trace) - 1)
    if len(keep) > cap:
        pick = sorted({round(j * (len(keep) - 1) / (cap - 1)) for j in range(cap)})
        keep = [keep[j] for j in pick]
    return [tuple(trace[i]) for i in keep]  # type: ignore[misc]


# --------------------------------------------------------------------------------------
# provenance
# --------------------------------------------------------------------------------------

#: packages whose versions are recorded in ``experiment.packages``
PACKAGES = ("numpy", "scipy", "shapely", "casadi", "cvxpy", "clarabel", "matplotlib", "numba",
            "dask", "distributed")


def _git_revision() -> str | None:
    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        return None
    try:
        rev = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=5)
        if rev.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain",
                                "--untracked-files=no"], capture_output=True, text=True,
                               timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    out = rev.stdout.strip()
    if dirty.returncode == 0 and dirty.stdout.strip():
        out += "+dirty"
    return out


def experiment_info(command_line: str | None = None,
                    spec: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Provenance of a sweep: versions, git revision, machine, command line, spec."""
    from importlib import metadata

    from optplan import __version__

    pkgs: dict[str, str | None] = {}
    for name in PACKAGES:
        try:
            pkgs[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pkgs[name] = None
    machine = {"host": platform.node(), "platform": platform.platform(),
               "machine": platform.machine(), "processor": platform.processor(),
               "cpu_count": os.cpu_count()}
    if command_line is None:
        command_line = " ".join(sys.argv)
    return {"optplan_version": __version__, "git_revision": _git_revision(),
            "python": sys.version.split()[0] + f" ({platform.python_implementation()})",
            "packages": pkgs, "machine": machine, "command_line": command_line,
            "spec": dict(spec or {})}


# --------------------------------------------------------------------------------------
# the database
# --------------------------------------------------------------------------------------


class ResultsDB:
    """A results database file (created with :data:`SCHEMA` when new).

    >>> import tempfile, os
    >>> db = ResultsDB(os.path.join(tempfile.mkdtemp(), "runs.sqlite"))
    >>> exp = db.begin_experiment(experiment_info("doctest"), planned=0, skipped=0)
    >>> db.end_experiment(exp, "complete"); db.close()
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.parent and not self.path.parent.exists():
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self.con = _open(self.path)
        try:
            with _guarded(self.path):
                self._setup()
        except BaseException:
            self.con.close()
            raise

    def _setup(self) -> None:
        """Check the file (:func:`_check_file`, before anything is written), then set the
        write-ahead log and create the tables of a new file."""
        self.con.execute("PRAGMA foreign_keys = ON")
        fresh = _check_file(self.path, self.con)
        # WAL + synchronous NORMAL: a commit costs ~0.2 ms instead of ~15 ms (no fsync per
        # run); committed runs survive a crash or kill of the sweep (not a power cut, where
        # the last runs may be lost, never the file).  The -wal/-shm side files exist only
        # while a sweep writes: the file is a single file again once it closes.
        self.con.execute("PRAGMA journal_mode = WAL")
        self.con.execute("PRAGMA synchronous = NORMAL")
        if fresh:
            with self.con:
                self.con.executescript(SCHEMA)
                self.con.execute("INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)",
                                 (str(SCHEMA_VERSION),))
            _check_file(self.path, self.con)  # another process may have made it meanwhile
        have = _tables(self.con)["runs"]
        with self.con:
            for c, sql in _ADDED.items():
                if c not in have:
                    self.con.execute(f"ALTER TABLE runs ADD COLUMN {c} {sql}")

    # -- writing ---------------------------------------------------------------------
    def begin_experiment(self, info: Mapping[str, Any], planned: int, skipped: int) -> int:
        with _guarded(self.path), self.con:
            cur = self.con.execute(
                "INSERT INTO experiment (started, optplan_version, git_revision, python, "
                "packages, machine, command_line, spec, runs_planned, runs_skipped, runs_done) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 0)",
                (_now(), info.get("optplan_version"), info.get("git_revision"),
                 info.get("python"), json.dumps(info.get("packages", {}), sort_keys=True),
                 json.dumps(info.get("machine", {}), sort_keys=True),
                 info.get("command_line"), json.dumps(info.get("spec", {}), default=str),
                 int(planned), int(skipped)))
        return _inserted_id(cur)

    def end_experiment(self, experiment_id: int, outcome: str) -> None:
        """Record when and how the sweep ended.  ``runs_done`` is not set here: each
        :meth:`add_run` counts its run in the run's own transaction, so the count equals the
        stored runs even when the sweep is interrupted between storing a run and counting it
        in memory."""
        with _guarded(self.path), self.con:
            self.con.execute("UPDATE experiment SET finished = ?, outcome = ? WHERE id = ?",
                             (_now(), outcome, int(experiment_id)))

    def add_run(self, experiment_id: int, row: Mapping[str, Any], config: str,
                progress: Iterable[Sequence[Any]] = (), worker: str = "") -> int:
        """Insert one finished run and its progress rows, and count it in the experiment's
        ``runs_done``, in one transaction (committed): a sweep killed at any moment leaves
        ``runs_done`` equal to the runs it stored."""
        vals = []
        for c in _ROW_COLS:
            v = row.get(c)
            if c in _FLOATS:
                v = _float_in(v)
            elif c == "success":
                v = int(bool(v))
            elif c in _INTS:
                v = None if v is None else int(v)
            vals.append(v)
        with _guarded(self.path), self.con:
            cur = self.con.execute(
                f"INSERT INTO runs (experiment_id, {', '.join(_ROW_COLS)}, config, worker, "
                f"finished) VALUES ({', '.join('?' * (len(_ROW_COLS) + 4))})",
                (int(experiment_id), *vals, config, worker, _now()))
            run_id = _inserted_id(cur)
            self.con.executemany(
                "INSERT INTO progress (run_id, iteration, best_cost, n_eval, time) "
                "VALUES (?, ?, ?, ?, ?)",
                [(run_id, int(it), _float_in(c), int(ne), float(t))
                 for it, c, ne, t in progress])
            self.con.execute("UPDATE experiment SET runs_done = runs_done + 1 WHERE id = ?",
                             (int(experiment_id),))
        return run_id

    # -- reading ---------------------------------------------------------------------
    def finished(self) -> dict[tuple[str, str, int], tuple[str, dict[str, Any]]]:
        """``(problem, solver, seed) -> (config, tidy row)`` of every stored run."""
        out = {}
        for r in self.runs(with_ids=True):
            out[(r["problem"], r["solver"], r["seed"])] = (r.pop("config"), r)
            r.pop("id"), r.pop("worker"), r.pop("finished")
        return out

    def runs(self, with_ids: bool = False) -> list[dict[str, Any]]:
        """Every run as a tidy row (NULL -> nan, success -> bool), in insertion order."""
        extra = ", id, config, worker, finished" if with_ids else ", id"
        with _guarded(self.path):
            have = _tables(self.con)["runs"]
            cols = ", ".join(c if c in have else f"NULL AS {c}" for c in _ROW_COLS)
            cur = self.con.execute(f"SELECT {cols}{extra} FROM runs ORDER BY id")
            names = [d[0] for d in cur.description]
            recs = cur.fetchall()
        out = []
        for rec in recs:
            r = dict(zip(names, rec))
            rid = r["id"] if with_ids else r.pop("id")
            for c, kind in [*((c, float) for c in _FLOATS), *((c, int) for c in _INTS),
                            ("bucket", int), ("scen_line", int)]:
                r[c] = typed(self.path, "runs", rid, c, r[c], kind)
                r[c] = 0 if r[c] is None and c in _INTS else r[c]
            r["success"] = bool(typed(self.path, "runs", rid, "success", r["success"], int,
                                      (0, 1)))
            for c in ("stop_reason", "message", "backend", "options", "scen"):
                r[c] = r[c] or ""
            out.append(r)
        return out

    def close(self) -> None:
        self.con.close()

    def __enter__(self) -> ResultsDB:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _connect_read(path: str | Path) -> sqlite3.Connection:
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such results database")
    # a read-write connection (that only reads): the last connection to close removes the
    # write-ahead log's side files, which a read-only one would leave behind
    con = _open(p)
    try:
        with _guarded(p):
            if _check_file(p, con):
                raise ResultsDBError(f"{p}: not an optplan results database (no tables)")
    except BaseException:
        con.close()
        raise
    return con


def read_runs(path: str | Path) -> list[dict[str, Any]]:
    """The tidy rows of a results database, with ``id``, ``config``, ``worker``, ``finished``."""
    con = _connect_read(path)
    try:
        db = ResultsDB.__new__(ResultsDB)
        db.path, db.con = Path(path), con
        return db.runs(with_ids=True)
    finally:
        con.close()


def read_progress(path: str | Path) -> dict[int, dict[str, list[float]]]:
    """``run id -> {"iteration": [...], "best_cost": [...], "n_eval": [...], "time": [...]}``."""
    con = _connect_read(path)
    out: dict[int, dict[str, list[float]]] = {}
    try:
        with _guarded(Path(path)):
            recs = con.execute("SELECT rowid, run_id, iteration, best_cost, n_eval, time FROM "
                               "progress ORDER BY run_id, rowid").fetchall()
        for row, *vals in recs:
            rid, it, c, ne, t = (typed(Path(path), "progress", row, col, v, kind) for col, v, kind
                                 in zip(("run_id", "iteration", "best_cost", "n_eval", "time"),
                                        vals, (int, int, float, int, float)))
            d = out.setdefault(rid, {"iteration": [], "best_cost": [], "n_eval": [], "time": []})
            d["iteration"].append(it)
            d["best_cost"].append(c)
            d["n_eval"].append(ne or 0)
            d["time"].append(t)
    finally:
        con.close()
    return out


def read_experiments(path: str | Path) -> list[dict[str, Any]]:
    """The ``experiment`` rows (JSON columns decoded)."""
    con = _connect_read(path)
    try:
        with _guarded(Path(path)):
            cur = con.execute("SELECT * FROM experiment ORDER BY id")
            names = [d[0] for d in cur.description]
            recs = cur.fetchall()
        out = []
        for rec in recs:
            r = dict(zip(names, rec))
            for k in ("packages", "machine", "spec"):
                try:
                    r[k] = json.loads(r[k]) if r[k] else {}
                except json.JSONDecodeError:
                    pass
            out.append(r)
        return out
    finally:
        con.close()
