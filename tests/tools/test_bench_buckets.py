"""A whole MovingAI ``.scen`` as one sweep: the bucket selection, the ``.scen`` columns (the
file's octile optimum beside the certified Euclidean one) in rows, CSV, database and Planner
Arena export, old databases without them, the per-bucket table and the report's figure."""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from optplan import bench
from optplan.bench.buckets import PANELS, plot_buckets, summarise_buckets
from optplan.bench.scen import parse_buckets, scen_columns
from optplan.benchdb import SCHEMA, read_runs
from optplan.cli import main
from optplan.maps import read_scen_entries
from optplan.maps.movingai_gen import generate_benchmark

SOLVERS = ["visgraph", "apf"]


@pytest.fixture(scope="module")
def scen(tmp_path_factory) -> Path:
    """A seeded 16 x 16 random map and 10 lines over buckets 1..4."""
    d = tmp_path_factory.mktemp("maps")
    return generate_benchmark("random", 16, d, rng=np.random.default_rng(3), queries=10).scen_path


@pytest.fixture(scope="module")
def swept(scen: Path, tmp_path_factory):
    """``optplan bench`` over buckets 1-2 and 4 of the file and ``open-field``, into a
    database; (output directory, database, printed text)."""
    d = tmp_path_factory.mktemp("sweep")
    out, db = d / "out", d / "runs.sqlite"
    argv = ["bench", "--problems", f"{scen},open-field", "--buckets", "1-2,4", "--solvers",
            ",".join(SOLVERS), "--seeds", "1", "--out", str(out), "--db", str(db), "--quiet"]
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(argv) == 0
    return out, db, buf.getvalue()


def _entries(scen: Path) -> dict[int, object]:
    return {e.line: e for e in read_scen_entries(scen)}


def test_parse_buckets_ranges_and_errors() -> None:
    assert parse_buckets("0-3,9, 2") == [0, 1, 2, 3, 9]
    assert parse_buckets("7") == [7]
    for spec, says in (("", "expected bucket numbers"), ("5-1", "ends below its start"),
                       ("x", "'x' is not a bucket number"), ("-2", "'-2' is not a bucket"),
                       ("1,,2", "'' is not a bucket"), ("9999999", "outside 0..1000000")):
        with pytest.raises(ValueError, match="--buckets") as e:
            parse_buckets(spec, "--buckets")
        assert says in str(e.value) and repr(spec) in str(e.value)


def test_rows_carry_both_optima_per_line(swept, scen: Path) -> None:
    out, _, _ = swept
    rows = bench.read_csv(out / "results.csv")
    entries = _entries(scen)
    lines = [r for r in rows if r["problem"] != "open-field"]
    want = {k for k, e in entries.items() if e.bucket in (1, 2, 4)}
    assert {r["scen_line"] for r in lines} == want and len(lines) == len(want) * len(SOLVERS)
    for r in lines:
        e = entries[r["scen_line"]]
        assert r["scen"] == scen.name and r["bucket"] == e.bucket
        assert r["octile_optimum"] == pytest.approx(e.optimal_length, rel=1e-12)
        if r["success"]:
            assert r["octile_ratio"] == pytest.approx(r["length"] / r["octile_optimum"])
            assert r["ratio"] == pytest.approx(r["length"] / r["optimum"])
        if r["solver"] == "visgraph":  # a point robot's any-angle optimum: never longer
            assert r["status"] == "optimal" and r["optimum"] <= r["octile_optimum"] + 1e-9
    field = [r for r in rows if r["problem"] == "open-field"]
    assert field and all(r["bucket"] is None and r["scen"] == "" and
                         math.isnan(r["octile_optimum"]) and math.isnan(r["octile_ratio"])
                         for r in field)


def test_database_and_arena_carry_the_scen_columns(swept, tmp_path: Path) -> None:
    out, db, _ = swept
    csv_rows = bench.read_csv(out / "results.csv")
    stored = {(r["problem"], r["solver"]): r for r in read_runs(db)}
    assert len(stored) == len(csv_rows)
    for r in csv_rows:
        s = stored[(r["problem"], r["solver"])]
        assert (s["scen"], s["bucket"], s["scen_line"]) == (r["scen"], r["bucket"],
                                                            r["scen_line"])
        for k in ("octile_optimum", "octile_ratio"):
            assert s[k] == pytest.approx(r[k], nan_ok=True)
    arena = tmp_path / "arena.db"
    assert main(["export-arena", str(db), str(arena)]) == 0
    con = sqlite3.connect(arena)
    got = con.execute("SELECT e.name, r.scen_bucket, r.scen_line, r.octile_optimum, "
                      "r.octile_ratio, r.certified_optimum FROM runs r JOIN experiments e "
                      "ON e.id = r.experimentid").fetchall()
    con.close()
    for name, bucket, line, octile, oratio, opt in got:
        s = next(v for (p, _), v in stored.items() if p == name)
        assert (bucket, line) == (s["bucket"], s["scen_line"])
        if name == "open-field":
            assert octile is None and oratio is None and opt is not None
        else:
            assert octile == pytest.approx(s["octile_optimum"])


def test_the_bench_table_is_per_bucket(swept, scen: Path) -> None:
    out, _, printed = swept
    summary = (out / "summary.md").read_text(encoding="utf-8")
    for text in (printed, summary):
        assert "| scen | bucket | solver |" in text
        rows = [ln.split(" | ") for ln in text.splitlines() if ln.startswith(f"| {scen.name}")]
        assert [(int(c[1]), c[2]) for c in rows] == [(b, s) for b in (1, 2, 4)
                                                      for s in SOLVERS]
    # printed: open-field's row, no row per line; summary.md: also every line's
    assert "| open-field | visgraph |" in printed and "#line=" not in printed
    assert any(ln.startswith(f"| {scen}#line=") and "| visgraph |" in ln
               for ln in summary.splitlines())


def test_summarise_buckets_medians_and_worst(swept) -> None:
    out, _, _ = swept
    rows = bench.read_csv(out / "results.csv")
    summary = summarise_buckets(rows)
    for s in summary:
        mine = [r for r in rows if r["bucket"] == s["bucket"] and r["solver"] == s["solver"]]
        good = [r["octile_ratio"] for r in mine if r["success"]]
        assert s["runs"] == len(mine) and s["success"] == len(good) / len(mine)
        if good:
            assert s["octile_ratio_median"] == pytest.approx(float(np.median(good)))
            assert s["octile_ratio_worst"] == pytest.approx(max(good))
        else:
            assert math.isnan(s["octile_ratio_median"])
        if s["solver"] == "visgraph":
            assert s["ratio_median"] == pytest.approx(1.0) == s["ratio_worst"]


def test_the_figure_draws_both_ratios_per_bucket_for_every_solver() -> None:
    nan = math.nan

    def row(bucket, solver, ok, length, opt, octile):
        return {"problem": f"p{bucket}-{length}", "solver": solver, "scen": "m.scen",
                "bucket": bucket, "success": ok, "status": "solved" if ok else "failed",
                "ratio": length / opt if ok else nan, "octile_ratio": length / octile,
                "wall_time": 0.01, "collisions": 0 if ok else 1}

    rows = [row(0, "a", True, 2.0, 2.0, 2.5), row(0, "a", True, 3.0, 2.0, 2.5),
            row(0, "b", True, 4.0, 2.0, 2.5), row(3, "a", True, 13.0, 12.0, 14.0),
            row(3, "b", False, 9.0, 12.0, 14.0),
            {"problem": "open-field", "solver": "a", "bucket": None}]
    fig = plot_buckets(rows, {"a": "#ff0000"})
    axes = fig.axes
    assert [ax.get_ylabel() for ax in axes] == [label for _, label in PANELS]
    want = {  # (panel, solver) -> y at buckets 0 and 3
        ("success", "a"): [1.0, 1.0], ("success", "b"): [1.0, 0.0],
        ("ratio_median", "a"): [1.25, 13 / 12], ("ratio_median", "b"): [2.0, nan],
        ("octile_ratio_median", "a"): [1.0, 13 / 14], ("octile_ratio_median", "b"): [1.6, nan],
    }
    for ax, (key, _) in zip(axes, PANELS):
        lines = {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}
        assert set(lines) == {"a", "b"}
        for solver, ln in lines.items():
            assert list(ln.get_xdata()) == [0, 3]
            np.testing.assert_allclose(ln.get_ydata(), want[(key, solver)])
    assert axes[0].get_lines()[0].get_color() == "#ff0000"


def test_bad_bucket_selections_are_errors_naming_the_option(scen: Path, tmp_path: Path,
                                                            capsys) -> None:
    base = ["bench", "--solvers", "visgraph", "--quiet", "--out", str(tmp_path / "o")]
    assert main([*base, "--problems", str(scen), "--buckets", "3-1"]) == 2
    assert "--buckets '3-1': the range '3-1' ends below its start" in capsys.readouterr().err
    assert main([*base, "--problems", str(scen), "--buckets", "40-41"]) == 2
    have = sorted({e.bucket for e in read_scen_entries(scen)})
    err = capsys.readouterr().err
    assert f"{scen}: no line is in the buckets asked for (40-41)" in err
    assert f"the file's buckets: {have[0]}-{have[-1]}" in err
    assert main([*base, "--problems", "open-field", "--buckets", "1"]) == 2
    assert "--buckets is the bucket selection of .scen problems" in capsys.readouterr().err


def test_scen_columns_of_a_problem_loaded_by_its_line_name(scen: Path, tmp_path: Path) -> None:
    from optplan.bench.scen import load_bench_problem as load_problem

    paths = bench.expand_scen([str(scen)], buckets=[2])
    e = _entries(scen)
    for p in paths:
        cols = scen_columns(load_problem(p))
        line = int(p.rsplit("#line=", 1)[1])
        assert cols == {"scen": scen.name, "bucket": 2, "scen_line": line,
                        "octile_optimum": pytest.approx(e[line].optimal_length)}
    assert scen_columns(load_problem("open-field"))["bucket"] is None


def _old_database(path: Path) -> None:
    """A results database as written before the ``.scen`` columns existed: one run."""
    old = SCHEMA
    for col in ("scen TEXT", "bucket INTEGER", "scen_line INTEGER", "octile_optimum REAL",
                "octile_ratio REAL"):
        old = old.replace(f"    {col.split()[0]:<15}{col.split()[1]},\n", "")
    assert "octile" not in old
    con = sqlite3.connect(path)
    con.executescript(old)
    con.execute("INSERT INTO meta VALUES ('schema_version', '1')")
    con.execute("INSERT INTO experiment (started, outcome) VALUES ('2026-01-01', 'complete')")
    con.execute("INSERT INTO runs (experiment_id, problem, solver, seed, status, success, "
                "length, optimum, ratio, wall_time, config) VALUES (1, 'open-field', "
                "'visgraph', 0, 'optimal', 1, 2.0, 2.0, 1.0, 0.01, "
                "'{\"overrides\": {}, \"time_limit\": null}')")
    con.commit()
    con.close()


def test_an_old_database_reads_and_is_extended_when_written(tmp_path: Path) -> None:
    db = tmp_path / "old.sqlite"
    _old_database(db)
    before = db.read_bytes()
    (r,) = read_runs(db)
    assert r["bucket"] is None and r["scen"] == "" and math.isnan(r["octile_ratio"])
    assert db.read_bytes() == before  # reading changes nothing
    index = tmp_path / "rep"
    from optplan.report import write_report

    assert write_report(db, index).is_file()
    rows = bench.run_grid(["open-field", "paper-env1"], ["visgraph"], seeds=1, db=db)
    assert [r["status"] for r in rows] == ["optimal", "optimal"]  # open-field resumed
    con = sqlite3.connect(db)
    cols = [c[1] for c in con.execute("PRAGMA table_info(runs)")]
    con.close()
    assert cols[-5:] == ["scen", "bucket", "scen_line", "octile_optimum", "octile_ratio"]
    assert [x["bucket"] for x in read_runs(db)] == [None, None]


def test_the_report_has_one_section_per_scen_with_the_bucket_figure(swept, tmp_path: Path,
                                                                     scen: Path) -> None:
    _, db, _ = swept
    assert main(["report", str(db), "--out", str(tmp_path / "rep")]) == 0
    page = (tmp_path / "rep" / "index.html").read_text(encoding="utf-8")
    pngs = sorted(p.name for p in (tmp_path / "rep").glob("*.png"))
    slug = scen.name
    assert f"{slug}-buckets.png" in pngs and f"{slug}-outcome.png" in pngs
    assert "open-field-convergence.png" in pngs
    assert not any("line-" in p or "-seed3-" in p for p in pngs)  # no section per line
    assert "length / octile optimum: median, worst" in page


def test_run_one_gives_a_scen_line_its_columns(scen: Path, tmp_path: Path) -> None:
    path = bench.expand_scen([str(scen)], buckets=[3])[0]
    row = bench.run_one(path, "visgraph", 0)
    e = _entries(scen)[row["scen_line"]]
    assert row["bucket"] == e.bucket == 3 and row["scen"] == scen.name
    assert row["octile_ratio"] == pytest.approx(row["length"] / e.optimal_length)
    missing = bench.run_one(str(tmp_path / "gone.toml"), "visgraph", 0)
    assert missing["status"] == "error" and missing["bucket"] is None
