"""Results database files that cannot be used (another program's, another schema version,
damaged, locked) end in an error naming the file; a sweep killed with SIGKILL leaves its runs
counted and no traceback."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from optplan import bench, benchdb, cli
from optplan.bench.grid import _config
from tests import helpers
from tests.tools.test_benchdb import _count

#: the configuration of a visgraph run without overrides or time limit
CONFIG = _config({}, None)


def _row(seed: int) -> dict:
    return {"problem": "open-field", "solver": "visgraph", "seed": seed, "status": "optimal",
            "success": True, "length": 10.0 + seed, "optimum": 10.0, "ratio": 1.0,
            "min_clearance": 1.0, "collisions": 0, "wall_time": 0.01, "reference_time": 0.01,
            "n_iter": 1, "n_eval": 1, "stop_reason": "", "message": "a message " * 5,
            "backend": "visgraph", "options": "{}"}


def _small_db(path: Path, runs: int = 3, end: bool = True) -> Path:
    """A results database of ``runs`` made-up runs, each with a short trace."""
    with benchdb.ResultsDB(path) as db:
        exp = db.begin_experiment(benchdb.experiment_info("pytest"), planned=runs, skipped=0)
        for k in range(runs):
            db.add_run(exp, _row(k), CONFIG, [(i, 5.0 - i, i, 0.1 * i) for i in range(5)], "w")
        if end:
            db.end_experiment(exp, "complete")
    return path


def _sql(path: Path, *statements: str) -> None:
    """Run ``statements`` on ``path`` (as another program would) and commit."""
    con = sqlite3.connect(path)
    for st in statements:
        con.execute(st)
    con.commit()
    con.close()


def _unusable(path: Path, capsys, *match: str, opens: bool = False) -> None:
    """Every reader and writer refuses ``path`` with an error naming it and ``match`` (those
    that read the runs only, when the file ``opens``)."""
    before = path.read_bytes()
    calls = [lambda: benchdb.read_runs(path),
             lambda: bench.run_grid(["open-field"], ["visgraph"], seeds=1, db=path)]
    if not opens:
        calls += [lambda: benchdb.ResultsDB(path), lambda: benchdb.read_progress(path),
                  lambda: benchdb.read_experiments(path)]
    for call in calls:
        with pytest.raises(benchdb.ResultsDBError) as e:
            call()
        assert str(e.value).startswith(f"{path}: ")
        for m in match:
            assert m in str(e.value)
    for argv in (["report", str(path), "--out", str(path.parent / "report")],
                 ["export-arena", str(path), str(path.parent / "arena.db")]):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"optplan: error: {path}: ") and "internal error" not in err
    assert not (path.parent / "report" / "index.html").exists()  # nothing drawn
    assert path.read_bytes() == before  # and nothing written into it


def test_a_file_of_another_program_is_refused_and_left_alone(tmp_path, capsys):
    path = tmp_path / "other.sqlite"
    _sql(path, "CREATE TABLE runs (x TEXT, y REAL)", "INSERT INTO runs VALUES ('a', 1.0)")
    _unusable(path, capsys, "not an optplan results database", "no table 'experiment'",
              "it has: runs")
    _sql(path, "CREATE TABLE experiment (id INTEGER)", "CREATE TABLE meta (key TEXT)",
         "CREATE TABLE progress (run_id INTEGER)")
    _unusable(path, capsys, "table 'experiment' has no column started", "its columns: id")
    # an OMPL (Planner Arena) export is not a results database either
    arena = tmp_path / "arena-in.db"
    assert cli.main(["export-arena", str(_small_db(tmp_path / "r.sqlite")), str(arena)]) == 0
    capsys.readouterr()
    _unusable(arena, capsys, "not an optplan results database")


def test_another_schema_version_is_refused(tmp_path, capsys):
    path = _small_db(tmp_path / "v99.sqlite")
    _sql(path, "UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    _unusable(path, capsys, "meta.schema_version", "version '99'", "version 1")


def _corrupt_page(path: Path, table: str) -> None:
    """Overwrite the end of ``table``'s root page (its cell content) with 0xff bytes."""
    con = sqlite3.connect(path)
    (size,) = con.execute("PRAGMA page_size").fetchone()
    (root,) = con.execute("SELECT rootpage FROM sqlite_master WHERE name = ?",
                          (table,)).fetchone()
    con.close()
    with open(path, "r+b") as f:
        f.seek(root * size - 200)
        f.write(b"\xff" * 150)


def test_a_file_failing_the_integrity_check_is_refused(tmp_path, capsys):
    path = _small_db(tmp_path / "bad.sqlite")
    _corrupt_page(path, "progress")
    con = sqlite3.connect(path)
    try:
        check = con.execute("PRAGMA integrity_check").fetchall()
    except sqlite3.DatabaseError as e:
        check = [(str(e),)]
    assert check != [("ok",)]
    assert len(con.execute("SELECT * FROM runs").fetchall()) == 3  # the runs still read
    con.close()
    _unusable(path, capsys, "fails SQLite's integrity check")


def test_text_that_is_not_utf8_is_an_error(tmp_path, capsys):
    path = _small_db(tmp_path / "text.sqlite")
    _sql(path, "UPDATE runs SET message = CAST(X'66ff' AS TEXT) WHERE seed = 1")
    con = sqlite3.connect(path)
    assert con.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
    con.close()
    _unusable(path, capsys, "the results database is damaged", "UTF-8", opens=True)


def test_a_locked_file_is_an_error_naming_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(benchdb, "LOCK_TIMEOUT", 0.1)
    path = _small_db(tmp_path / "locked.sqlite")
    holder = sqlite3.connect(path, isolation_level=None)
    try:
        holder.execute("BEGIN EXCLUSIVE")  # writers wait, then give up
        with pytest.raises(benchdb.ResultsDBError, match="locked by another connection"):
            bench.run_grid(["open-field"], ["visgraph"], seeds=5, db=path)
        assert len(benchdb.read_runs(path)) == 3  # readers still read (write-ahead log)
        holder.execute("ROLLBACK")
        holder.execute("PRAGMA locking_mode = EXCLUSIVE")
        holder.execute("BEGIN EXCLUSIVE")  # now readers wait, then give up
        assert cli.main(["report", str(path), "--out", str(tmp_path / "r")]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"optplan: error: {path}: the results database is locked")
        assert "waited 0.1 s" in err
    finally:
        holder.close()
    assert len(benchdb.read_runs(path)) == 3


def test_a_lock_during_a_sweep_stops_it_with_its_runs_kept(tmp_path, monkeypatch):
    monkeypatch.setattr(benchdb, "LOCK_TIMEOUT", 0.1)
    path = tmp_path / "mid.sqlite"
    holder = sqlite3.connect(path, isolation_level=None)

    def lock_after_two(done, total, row):
        if done == 2:
            holder.execute("BEGIN EXCLUSIVE")

    try:
        with pytest.raises(benchdb.ResultsDBError, match=f"{path}: .*locked"):
            bench.run_grid(["open-field"], ["visgraph"], seeds=5, db=path,
                           progress=lock_after_two)
    finally:
        holder.close()
    (exp,) = benchdb.read_experiments(path)
    assert [r["seed"] for r in benchdb.read_runs(path)] == [0, 1]
    assert exp["runs_done"] == 2 and exp["outcome"] is None


def test_a_directory_is_not_a_database(tmp_path, capsys):
    path = tmp_path / "runs.sqlite"
    path.mkdir()
    with pytest.raises(benchdb.ResultsDBError, match=r"cannot open the results database \(a "
                                                     r"directory\)"):
        bench.run_grid(["open-field"], ["visgraph"], seeds=1, db=path)
    assert cli.main(["report", str(path), "--out", str(tmp_path / "r")]) == 2
    assert f"{path}: " in capsys.readouterr().err


def test_each_stored_run_counts_itself(tmp_path):
    path = _small_db(tmp_path / "count.sqlite", runs=4, end=False)  # as a killed sweep leaves it
    (exp,) = benchdb.read_experiments(path)
    assert exp["runs_done"] == 4 and exp["outcome"] is None


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX")
def test_a_killed_sweep_leaves_no_traceback_and_counts_its_runs(tmp_path):
    db = tmp_path / "k.sqlite"
    cmd = [sys.executable, "-m", "optplan", "bench", "--problems", "paper-env1",
           "--solvers", "pso-paper", "--set", "k_max=60", "--seeds", "40", "--workers", "2",
           "--db", str(db), "--out", str(tmp_path / "out"), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=tmp_path)
    try:
        # no wall-clock bound (tests/helpers.py): only a runaway or deadlocked sweep fails
        helpers.wait_until(lambda: _count(db) >= 3, proc, "the sweep's first 3 runs")
        proc.kill()
        # the workers inherit stderr: it closes when the last of them has ended
        _, err = helpers.communicate(proc)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    runs = benchdb.read_runs(db)
    (exp,) = benchdb.read_experiments(db)
    assert 3 <= len(runs) < 40
    assert exp["runs_done"] == len(runs) and exp["outcome"] is None
