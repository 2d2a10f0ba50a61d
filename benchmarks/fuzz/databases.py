"""The **database** family: results databases (intact, foreign, of another schema, corrupt,
truncated, locked, ...) read with every :mod:`optplan.benchdb` reader and the CLI."""

from __future__ import annotations

import random
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _cli, _message_ok, _prepare
from benchmarks.fuzz.core import Case, Outcome


def _db_bytes(tmp: Path, edit: Callable[[Any], None] | None = None, runs: int = 3) -> bytes:
    """A small results database (made-up runs), optionally edited with SQL, as bytes."""
    import sqlite3

    from optplan import benchdb

    path = tmp / f"db{random.random()}.sqlite"
    with benchdb.ResultsDB(path) as db:
        exp = db.begin_experiment(benchdb.experiment_info("fuzz"), planned=runs, skipped=0)
        for k in range(runs):
            row = {"problem": "open-field", "solver": "visgraph", "seed": k, "status": "optimal",
                   "success": True, "length": 10.0 + k, "optimum": 10.0, "ratio": 1.0,
                   "min_clearance": 1.0, "collisions": 0, "wall_time": 0.01, "n_iter": 1,
                   "n_eval": 1, "message": "fuzz run " * 4, "backend": "visgraph",
                   "options": "{}"}
            db.add_run(exp, row, "{}", [(i, 5.0 - i, i, 0.1 * i) for i in range(5)], "w")
        db.end_experiment(exp, "complete")
    if edit is not None:
        con = sqlite3.connect(path)
        edit(con)
        con.commit()
        con.close()
    return path.read_bytes()


def _corrupt(data: bytes, page: int, size: int = 4096) -> bytes:
    b = bytearray(data)
    b[page * size - 200: page * size - 50] = b"\xff" * 150
    return bytes(b)


def _root_page(table: str) -> Callable[[bytes, Path], int]:
    def find(data: bytes, tmp: Path) -> int:
        import sqlite3

        p = tmp / "probe.sqlite"
        p.write_bytes(data)
        con = sqlite3.connect(p)
        (root,) = con.execute("SELECT rootpage FROM sqlite_master WHERE name = ?",
                              (table,)).fetchone()
        con.close()
        p.unlink()
        return int(root)
    return find


def database_cases(seed: int = 0) -> list[Case]:
    """Results databases: intact, another program's, another version, damaged, locked."""
    rng = random.Random(seed)
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-db-"))
    out: list[Case] = []

    def add(what: str, content: bytes | None, keys: tuple[str, ...], must: bool,
            kind: str = "file") -> None:
        out.append(Case("database", f"database/{len(out) + 1:04d}/{what}", what,
                        {"bytes": content, "kind": kind}, keys, must))

    try:
        good = _db_bytes(tmp)
        add("intact", good, (), False)
        # report: "holds no runs"; export-arena: "no runs to export" (Planner Arena cannot
        # open a database without experiments)
        add("no runs", _db_bytes(tmp, runs=0), ("holds no runs", "no runs to export"), False)
        for what, sql, keys in (
                ("foreign runs table", "DROP TABLE progress", ("not an optplan results database",)),
                ("runs without columns", "ALTER TABLE runs DROP COLUMN message",
                 ("not an optplan results database",)),
                ("schema version 99", "UPDATE meta SET value = '99'", ("meta.schema_version",)),
                ("schema version text", "UPDATE meta SET value = 'x'", ("meta.schema_version",)),
                ("no schema version", "DELETE FROM meta", ("not an optplan results database",)),
                ("text not UTF-8", "UPDATE runs SET message = CAST(X'66ff' AS TEXT)",
                 ("damaged",))):
            # text SQLite cannot decode is found where it is read: the runs, not the progress
            add(what, _db_bytes(tmp, lambda con, s=sql: con.execute(s)), keys,
                "UTF-8" not in what)
        add("progress page damaged", _corrupt(good, _root_page("progress")(good, tmp)),
            ("integrity check", "damaged"), True)
        add("runs index damaged", _corrupt(good, _root_page("sqlite_autoindex_runs_1")(good, tmp)),
            ("integrity check", "damaged"), True)
        other = tmp / "other.sqlite"
        import sqlite3

        con = sqlite3.connect(other)
        con.execute("CREATE TABLE runs (x TEXT, y REAL)")
        con.commit()
        con.close()
        add("another program's file", other.read_bytes(), ("not an optplan results database",),
            True)
        for frac in (0.1, 0.5, 0.9):
            add(f"truncated {frac:g}", good[: int(len(good) * frac)],
                ("not an optplan results database", "damaged", "integrity check"), True)
        for k in range(12):
            i = rng.randrange(100, len(good))
            add(f"byte flip {k}", good[:i] + bytes([rng.randrange(256)]) + good[i + 1:],
                ("not an optplan results database", "damaged", "integrity check",
                 "meta.schema_version", "holds no runs", "no runs to export"), False)
        add("text file", b"hello, not a database\n" * 50, ("not an optplan results database",),
            True)
        add("empty file", b"", ("not an optplan results database", "holds no runs",
                                 "no runs to export"), False)
        add("locked", good, ("locked",), True, kind="locked")
        add("directory", None, ("no such results database", "cannot open the results database"),
            True, kind="dir")
        # a missing file is a new database to ResultsDB (a sweep creates it), an error to readers
        add("missing", None, ("no such results database",), False, kind="missing")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def _db_calls(path: Path) -> list[tuple[str, Callable[[], Any]]]:
    from optplan import benchdb

    return [("read_runs", lambda: benchdb.read_runs(path)),
            ("read_progress", lambda: benchdb.read_progress(path)),
            ("read_experiments", lambda: benchdb.read_experiments(path)),
            ("ResultsDB", lambda: benchdb.ResultsDB(path).close())]


def run_database(case: Case, tmp: Path) -> Outcome:
    import sqlite3

    from optplan import benchdb

    kind = case.data["kind"]
    path = _prepare(case, tmp, ".sqlite") if kind != "locked" else tmp / "locked.sqlite"
    holder = None
    if kind == "locked":
        path.write_bytes(case.data["bytes"])
        holder = sqlite3.connect(path, isolation_level=None)
        holder.execute("PRAGMA locking_mode = EXCLUSIVE")
        holder.execute("BEGIN EXCLUSIVE")
        benchdb.LOCK_TIMEOUT = 0.2
    accepted, errors = [], []
    try:
        for argv in (["report", str(path), "--out", str(tmp / "report")],
                     ["export-arena", str(path), str(tmp / "arena.db")]):
            rc, err = _cli(argv)
            lines = [ln for ln in err.splitlines() if ln.strip()]
            if rc == 0:
                accepted.append(argv[0])
            elif rc != 2 or len(lines) != 1 or not lines[0].startswith("optplan: error: "):
                return Outcome(case, "crash" if rc == 1 else "unclear message",
                               f"CLI {argv[0]} exit {rc}: {err[-300:]!r}")
            else:
                ok, why = _message_ok(lines[0], case.keys, str(path))
                if not ok:
                    return Outcome(case, "unclear message", f"CLI {argv[0]}: {why}: {lines[0]}")
                errors.append(f"{argv[0]}: {lines[0]}")
        for name, call in _db_calls(path):
            try:
                call()
                accepted.append(name)
            except (ValueError, FileNotFoundError) as e:
                ok, why = _message_ok(str(e), case.keys, str(path))
                if not ok:
                    return Outcome(case, "unclear message", f"{name}: {why}: {e}")
                errors.append(f"{name}: {e}")
            except Exception as e:  # noqa: BLE001
                return Outcome(case, "crash", f"{name}: {type(e).__name__}: {e}")
    finally:
        if holder is not None:
            holder.close()
            benchdb.LOCK_TIMEOUT = 30.0
    if case.must_reject and accepted:
        return Outcome(case, "silently accepted", f"accepted by {', '.join(accepted)}")
    if errors:
        return Outcome(case, "clear error", errors[0][:300])
    return Outcome(case, "accepted and solved", "read, reported and exported")
