"""``optplan export-arena``: a results database as OMPL's benchmark database, loaded by Planner
Arena's own loader (``plannerarena.database.load_database``, a dev dependency)."""

from __future__ import annotations

import re
import shutil
import sqlite3
from pathlib import Path

import pytest

from optplan.bench import run_grid
from optplan.bench.summary import ARENA_STATUS, export_arena
from optplan.benchdb import read_runs
from optplan.cli import main

#: OMPL's columns (ompl_benchmark_statistics.py), in its order: Planner Arena reads the
#: experiments' parameters from column 12 on and the runs' attributes from column 3 on
OMPL_EXPERIMENTS = ["id", "name", "totaltime", "timelimit", "memorylimit", "runcount",
                    "version", "hostname", "cpuinfo", "date", "seed", "setup"]


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("arena")
    db = d / "runs.sqlite"
    run_grid(["open-field", "paper-env1"], ["visgraph", "apf"], seeds=2, db=db)
    out = d / "arena.db"
    assert main(["export-arena", str(db), str(out)]) == 0
    return db, out


def _columns(con: sqlite3.Connection, table: str) -> list[str]:
    return [r[1] for r in con.execute(f"PRAGMA table_info({table})")]


def test_the_export_has_ompls_schema(sweep) -> None:
    _, out = sweep
    con = sqlite3.connect(out)
    tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    assert {"experiments", "plannerConfigs", "enums", "runs", "progress"} <= tables
    assert _columns(con, "experiments") == OMPL_EXPERIMENTS
    assert _columns(con, "plannerConfigs") == ["id", "name", "settings"]
    assert _columns(con, "enums") == ["name", "value", "description"]
    runs = _columns(con, "runs")
    assert runs[:3] == ["id", "experimentid", "plannerid"]
    assert {"time", "memory", "solved", "approximate_solution", "solution_length",
            "solution_clearance", "status"} <= set(runs)
    assert _columns(con, "progress")[:2] == ["runid", "time"]
    assert con.execute("PRAGMA foreign_key_check").fetchall() == []
    con.close()


def test_planner_arena_loads_the_export(sweep) -> None:
    pl = pytest.importorskip("polars")
    database = pytest.importorskip("plannerarena.database")
    db, out = sweep
    data = database.load_database(str(out))
    assert data["problem_names"] == ["open-field", "paper-env1"]
    assert data["parameters"] == []  # no extra experiment columns read as parameters
    assert sorted(data["planner_configs"]["planner"].cast(pl.Utf8).to_list()) == [
        "apf", "visgraph"]
    assert {"time", "solved", "approximate solution", "solution length", "solution clearance",
            "status", "certified optimum", "ratio to optimum", "collisions"} <= set(
        data["attributes"])
    runs = data["runs"]
    assert len(runs) == 8
    assert set(runs["version"].cast(pl.Utf8).to_list()) == {f"optplan {_version()}"}
    # every run as stored by optplan: status through the enum, the flags, lengths, ratios
    status = dict(zip(data["enums"]["value"].to_list(), data["enums"]["description"].to_list()))
    mine = {(r["problem"], r["solver"], r["seed"]): r for r in read_runs(db)}
    for r in runs.iter_rows(named=True):
        ref = mine[(r["experiment"], str(r["planner"]), r["seed"])]
        assert status[r["status"]] == ref["status"]
        assert r["solved"] == int(ref["success"])
        assert r["approximate solution"] == int(ref["status"] == "approximate")
        assert r["certified optimum"] == pytest.approx(ref["optimum"])
        assert r["collisions"] == ref["collisions"]
        if ref["success"]:
            assert r["solution length"] == pytest.approx(ref["length"])
            assert r["ratio to optimum"] == pytest.approx(ref["ratio"])
    assert {status[v] for v in runs.filter(pl.col("planner") == "visgraph")["status"]} == {
        "optimal"}
    # the convergence traces, by run
    prog = data["progress"]
    assert len(prog) > 0 and set(prog["runid"].to_list()) <= set(runs["id"].to_list())
    assert {"time", "best cost", "iterations"} <= set(prog.columns)


def _version() -> str:
    from optplan import __version__

    return __version__


def test_status_enum_and_refusals(sweep, tmp_path: Path) -> None:
    db, out = sweep
    con = sqlite3.connect(out)
    assert [d for _, d in con.execute(
        "SELECT value, description FROM enums WHERE name = 'status' ORDER BY value")] == list(
        ARENA_STATUS)
    con.close()
    with pytest.raises(ValueError, match="would replace the results database"):
        export_arena(db, db)
    with pytest.raises(FileNotFoundError, match="no such results database"):
        export_arena(tmp_path / "none.sqlite", tmp_path / "a.db")
    bad = tmp_path / "bad.sqlite"
    bad.write_text("not a database")
    assert main(["export-arena", str(bad), str(tmp_path / "b.db")]) == 2
    assert not (tmp_path / "b.db").exists()


# -- issue 42: what the export refuses, and what it leaves behind ----------------------------


def _leftovers(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir() if p.name.endswith(".tmp"))


def test_an_empty_results_database_is_refused(tmp_path: Path, capsys) -> None:
    from optplan.benchdb import ResultsDB

    empty = tmp_path / "empty.sqlite"
    ResultsDB(empty).close()
    with pytest.raises(ValueError, match=r"empty\.sqlite: no runs to export: the results "
                                         r"database holds no runs \(Planner Arena cannot open"):
        export_arena(empty, tmp_path / "a.db")
    assert not (tmp_path / "a.db").exists() and _leftovers(tmp_path) == []
    assert main(["export-arena", str(empty), str(tmp_path / "a.db")]) == 2
    err = capsys.readouterr().err
    assert "no runs to export" in err and "internal error" not in err


@pytest.mark.parametrize(("column", "value", "shown"), [
    ("length", "'abc'", r"column length: 'abc' is not a number \(REAL\)"),
    ("seed", "1.5", r"column seed: 1\.5 is not an integer"),
    ("success", "7", r"column success: 7 is not one of 0, 1"),
    ("bucket", "x'00'", r"column bucket: b'\\x00' is not an integer"),
    ("options", "'{oops'", r"column options: '\{oops' is not a JSON object"),
    ("config", "'[1]'", r"column config: '\[1\]' is not a JSON object"),
    ("config", "'{\"time_limit\": \"soon\"}'", r"column config: .* \(with a finite number as "
                                                r"time_limit\)"),
])
def test_a_damaged_row_names_the_file_table_row_column_and_value(
        sweep, tmp_path: Path, capsys, column: str, value: str, shown: str) -> None:
    db, _ = sweep
    bad = tmp_path / "bad.sqlite"
    shutil.copy(db, bad)
    con = sqlite3.connect(bad)
    (rid,) = con.execute("SELECT id FROM runs ORDER BY id LIMIT 1 OFFSET 2").fetchone()
    con.execute(f"UPDATE runs SET {column} = {value} WHERE id = ?", (rid,))
    con.commit()
    con.close()
    pattern = rf"bad\.sqlite: the results database is damaged: table runs, row id {rid}, {shown}"
    with pytest.raises(ValueError, match=pattern):
        export_arena(bad, tmp_path / "a.db")
    assert not (tmp_path / "a.db").exists() and _leftovers(tmp_path) == []
    assert main(["export-arena", str(bad), str(tmp_path / "a.db")]) == 2
    assert re.search(pattern, capsys.readouterr().err)


def test_a_damaged_progress_row_is_named_too(sweep, tmp_path: Path) -> None:
    db, _ = sweep
    bad = tmp_path / "bad.sqlite"
    shutil.copy(db, bad)
    con = sqlite3.connect(bad)
    (row,) = con.execute("SELECT rowid FROM progress LIMIT 1").fetchone()
    con.execute("UPDATE progress SET time = 'later' WHERE rowid = ?", (row,))
    con.commit()
    con.close()
    with pytest.raises(ValueError, match=rf"bad\.sqlite: .* damaged: table progress, row id "
                                         rf"{row}, column time: 'later' is not a number"):
        export_arena(bad, tmp_path / "a.db")


def test_the_destination_is_checked_first_and_no_temporary_file_stays(
        sweep, tmp_path: Path, monkeypatch) -> None:
    db, out = sweep
    folder = tmp_path / "dir.db"
    folder.mkdir()
    with pytest.raises(ValueError, match=r"dir\.db: is a directory; give the Planner Arena "
                                         r"database's file name"):
        export_arena(db, folder)
    assert list(folder.iterdir()) == [] and _leftovers(tmp_path) == []
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match=r"cannot make its folder .*file"):
        export_arena(db, tmp_path / "file" / "a.db")
    # a failure while writing removes the temporary file and keeps the previous export
    dst = tmp_path / "keep.db"
    shutil.copy(out, dst)
    before = dst.read_bytes()

    def boom(*args, **kwargs):
        raise sqlite3.OperationalError("disk I/O error")

    monkeypatch.setattr("optplan.bench.summary._write_arena", boom)
    with pytest.raises(sqlite3.OperationalError):
        export_arena(db, dst)
    assert dst.read_bytes() == before and _leftovers(tmp_path) == []
    monkeypatch.undo()
    # and a valid export replaces the file: the same content as the first one
    counts = export_arena(db, dst)
    assert counts["runs"] == 8 and _leftovers(tmp_path) == []
    con = sqlite3.connect(dst)
    assert con.execute("SELECT COUNT(*) FROM runs").fetchone() == (8,)
    con.close()
