"""A MovingAI ``.scen`` file as a bench batch (``optplan bench --problems X.scen``)."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pytest

from optplan.bench import expand_scen
from optplan.benchdb import read_runs
from optplan.cli import main

MAP = """type octile
height 6
width 8
map
@@@@@@@@
@......@
@.@@@@.@
@.@T.@.@
@......@
@@@@@@@@
"""

SCEN = """version 1
0\tarena.map\t8\t6\t1\t1\t6\t4\t8.00000000
0\tarena.map\t8\t6\t1\t4\t4\t3\t4.00000000
1\tarena.map\t8\t6\t6\t1\t1\t3\t7.00000000
"""


def _stem(name: str) -> str:
    """``arena-<line>`` of a ``.scen`` line's name ``...arena.map.scen#line=<line>``."""
    return "arena-" + re.search(r"#line=(\d+)", name).group(1)


@pytest.fixture
def scen(tmp_path: Path) -> Path:
    (tmp_path / "arena.map").write_text(MAP, encoding="utf-8")
    p = tmp_path / "arena.map.scen"
    p.write_text(SCEN, encoding="utf-8")
    return p


def test_bench_scen_one_row_per_line_solver_and_seed(scen: Path, tmp_path: Path,
                                                     capsys) -> None:
    out, db = tmp_path / "out", tmp_path / "runs.sqlite"
    argv = ["bench", "--problems", str(scen), "--solvers", "visgraph,apf", "--seeds", "2",
            "--out", str(out), "--db", str(db), "--quiet"]
    assert main(argv) == 0
    with (out / "results.csv").open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    cells = {(_stem(r["problem"]), r["solver"], int(r["seed"])) for r in rows}
    want = {(f"arena-{line}", s, k) for line in (2, 3, 4) for s in ("visgraph", "apf")
            for k in (0, 1)}
    assert len(rows) == 12 and cells == want
    stored = read_runs(db)
    assert len(stored) == 12
    assert {(_stem(r["problem"]), r["solver"], int(r["seed"])) for r in stored} == want
    # the any-angle optimum of each line is never longer than the .scen octile length
    octile = {"arena-2": 8.0, "arena-3": 4.0, "arena-4": 7.0}
    for r in rows:
        if r["solver"] == "visgraph":
            assert r["status"] == "optimal"
            assert float(r["length"]) <= octile[_stem(r["problem"])] + 1e-9
    # the same command again resumes: nothing new is run or stored
    assert main(argv) == 0
    assert len(read_runs(db)) == 12
    capsys.readouterr()


def test_bench_scen_radius(scen: Path, tmp_path: Path, capsys) -> None:
    paths = expand_scen([str(scen), "open-field"], radius=0.2)
    assert paths == [f"{scen}#line={k},radius=0.2" for k in (2, 3, 4)] + ["open-field"]
    from optplan.bench.scen import load_bench_problem

    p = load_bench_problem(paths[0])
    assert p.robots[0].radius == 0.2 and p.name == "arena-2"
    assert not (tmp_path / "p").exists()  # nothing written
    # --radius without a .scen, or a negative one, is bad input (exit 2)
    assert main(["bench", "--problems", "open-field", "--solvers", "visgraph", "--radius",
                 "0.1", "--out", str(tmp_path / "o")]) == 2
    assert main(["bench", "--problems", str(scen), "--solvers", "visgraph", "--radius",
                 "-1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--radius is the robot radius of .scen problems" in err
    assert "--radius must be a finite number >= 0" in err


def test_bench_scen_missing_map(tmp_path: Path, capsys) -> None:
    p = tmp_path / "lonely.scen"
    p.write_text(SCEN, encoding="utf-8")
    assert main(["bench", "--problems", str(p), "--solvers", "visgraph", "--quiet",
                 "--out", str(tmp_path / "o")]) == 2
    assert "cannot find the map" in capsys.readouterr().err


# -- issue 42: what a .scen file may contain -------------------------------------------------


def _entries(tmp_path: Path, text: str | bytes) -> list:
    from optplan.maps import read_scen_entries

    p = tmp_path / "x.scen"
    p.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
    return read_scen_entries(p)


def _cells(entries: list) -> list:
    return [(e.bucket, e.map, e.start, e.goal, e.optimal_length, e.line) for e in entries]


@pytest.mark.parametrize("head", ["version 1\n", "version 1.0\n", "Version 1\n", ""])
def test_the_versions_movingai_defines_are_read(tmp_path: Path, head: str) -> None:
    body = SCEN.split("\n", 1)[1]
    got = _cells(_entries(tmp_path, head + body))
    shift = 0 if head else -1
    assert got == [(0, "arena.map", (1, 1), (6, 4), 8.0, 2 + shift),
                   (0, "arena.map", (1, 4), (4, 3), 4.0, 3 + shift),
                   (1, "arena.map", (6, 1), (1, 3), 7.0, 4 + shift)]


@pytest.mark.parametrize("head", ["version 2", "version 0.9", "version", "version 1 beta",
                                  "version one"])
def test_another_version_is_an_error(tmp_path: Path, head: str) -> None:
    from optplan import ProblemError

    with pytest.raises(ProblemError, match=rf"x\.scen: line 1: unsupported version line "
                                           rf"'{head}' \(allowed: 'version 1' or 'version "
                                           rf"1\.0', the MovingAI \.scen format's\)"):
        _entries(tmp_path, head + "\n" + SCEN.split("\n", 1)[1])


def test_a_byte_order_mark_and_trailing_white_space_are_read(tmp_path: Path) -> None:
    ref = _cells(_entries(tmp_path, SCEN))
    assert _cells(_entries(tmp_path, b"\xef\xbb\xbf" + SCEN.encode())) == ref
    crlf = SCEN.replace("\n", " \t\r\n")  # Windows line ends after trailing blanks and tabs
    assert _cells(_entries(tmp_path, crlf)) == ref


@pytest.mark.parametrize("tail", ["\textra", "\t0", " # comment"])
def test_text_after_the_nine_fields_is_an_error_that_shows_it(tmp_path: Path,
                                                              tail: str) -> None:
    from optplan import ProblemError

    lines = SCEN.splitlines()
    lines[2] += tail
    shown = tail.strip().split()[0] if tail.startswith(" ") else tail.strip()
    with pytest.raises(ProblemError, match=rf"x\.scen: line 3: text after the 9 fields "
                                           rf"\(bucket map .* optimal_length\): '{shown}"):
        _entries(tmp_path, "\n".join(lines) + "\n")


# -- a .scen line by name (optplan.maps.read_scen_line) ----------------------------------------


def test_a_scen_line_by_name_is_read_once_per_process(scen: Path) -> None:
    from optplan.bench.scen import load_bench_problem as load_problem
    from optplan.maps import read_scen, scen_batch, scen_line_name

    name = scen_line_name(scen, 3)
    assert name == f"{scen}#line=3"
    a, b = load_problem(name), load_problem(str(scen) + "#line=4")
    want = read_scen(scen)
    assert (a.name, b.name) == ("arena-3", "arena-4")
    np.testing.assert_array_equal(a.robots[0].start, want[1].robots[0].start)
    np.testing.assert_array_equal(b.robots[0].goal, want[2].robots[0].goal)
    assert load_problem(name) is a  # the batch is kept ...
    assert a.obstacle_set(0.0) is b.obstacle_set(0.0)  # ... and its lines share one map
    batch = scen_batch(scen)
    scen.write_text(SCEN.replace("6\t4\t8.00000000", "6\t3\t7.00000000"), encoding="utf-8")
    assert scen_batch(scen) is not batch  # a changed file is read again
    assert load_problem(name) is not a
    assert scen_line_name(scen, 2, 0.25) == f"{scen}#line=2,radius=0.25"
    assert load_problem(scen_line_name(scen, 2, 0.25)).robots[0].radius == 0.25


@pytest.mark.parametrize("tail, words", [
    ("#line=9", "has no problem at line 9 (lines 2 to 4)"),
    ("#line=2,radius=-1", "radius '-1' is not a finite number >= 0"),
    ("#line=2,radius=nan", "radius 'nan' is not a finite number >= 0"),
    ("#line=2,radius=abc", "radius 'abc' is not a finite number >= 0"),
    ("#line=two", "expected <file>.scen#line=N"),
])
def test_bad_scen_line_names(scen: Path, tail: str, words: str) -> None:
    from optplan.bench.scen import load_bench_problem as load_problem
    from optplan.problem import ProblemError

    with pytest.raises(ProblemError, match=re.escape(words)):
        load_problem(str(scen) + tail)


def test_a_missing_scen_file_by_line_name(tmp_path: Path) -> None:
    from optplan.maps import read_scen_line
    from optplan.problem import ProblemError

    with pytest.raises(ProblemError, match="cannot read the .scen file"):
        read_scen_line(str(tmp_path / "gone.map.scen") + "#line=2")


def test_scen_line_names_in_worker_processes(scen: Path) -> None:
    """Worker processes load the lines by name (each reads the file once) and give the rows
    of the inline run."""
    from optplan import bench

    names = expand_scen([str(scen)], radius=0.1)
    keep = ("problem", "status", "length", "optimum", "scen_line", "bucket")
    inline = bench.run_grid(names, ["visgraph"], seeds=1)
    pooled = bench.run_grid(names, ["visgraph"], seeds=1, engine=bench.Engine(workers=2))
    assert [{k: r[k] for k in keep} for r in pooled] == [{k: r[k] for k in keep} for r in inline]
    assert [r["status"] for r in inline] == ["optimal"] * 3
