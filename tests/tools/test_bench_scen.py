"""A MovingAI ``.scen`` file as a bench batch (``optplan bench --problems X.scen``)."""

from __future__ import annotations

import csv
from pathlib import Path

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
    cells = {(Path(r["problem"]).stem, r["solver"], int(r["seed"])) for r in rows}
    want = {(f"arena-{line}", s, k) for line in (2, 3, 4) for s in ("visgraph", "apf")
            for k in (0, 1)}
    assert len(rows) == 12 and cells == want
    stored = read_runs(db)
    assert len(stored) == 12
    assert {(Path(r["problem"]).stem, r["solver"], int(r["seed"])) for r in stored} == want
    # the any-angle optimum of each line is never longer than the .scen octile length
    octile = {"arena-2": 8.0, "arena-3": 4.0, "arena-4": 7.0}
    for r in rows:
        if r["solver"] == "visgraph":
            assert r["status"] == "optimal"
            assert float(r["length"]) <= octile[Path(r["problem"]).stem] + 1e-9
    # the same command again resumes: nothing new is run or stored
    assert main(argv) == 0
    assert len(read_runs(db)) == 12
    capsys.readouterr()


def test_bench_scen_radius(scen: Path, tmp_path: Path, capsys) -> None:
    paths = expand_scen([str(scen), "open-field"], tmp_path / "p", radius=0.2)
    assert [Path(p).name for p in paths[:3]] == ["arena-2.toml", "arena-3.toml",
                                                 "arena-4.toml"]
    assert paths[3] == "open-field"
    from optplan.catalog import load_problem

    assert load_problem(paths[0]).robots[0].radius == 0.2
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
