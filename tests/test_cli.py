"""The ``optplan`` command line (optplan.cli.main)."""

from __future__ import annotations

import importlib.machinery
import subprocess
import sys
import types

import pytest

from optplan import cli
from optplan.result import Result


def run(capsys, *argv):
    rc = cli.main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def _one_line_error(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("optplan: error: ")
    assert "Traceback" not in err
    return lines[0]


# -- parse_set ----------------------------------------------------------------------------


def test_parse_set_uses_toml_literals():
    got = cli.parse_set(["w=[0.9,0.2]", "n = 30", "c1=1.5", "flag=true", "name=ipso-paper",
                         'q="quoted"', "mode=a b"])
    assert got == {"w": [0.9, 0.2], "n": 30, "c1": 1.5, "flag": True, "name": "ipso-paper",
                   "q": "quoted", "mode": "a b"}
    assert type(got["n"]) is int and type(got["c1"]) is float


@pytest.mark.parametrize("bad", ["novalue", "=3", ""])
def test_parse_set_rejects_malformed(bad):
    with pytest.raises(cli.CLIError, match="key=value"):
        cli.parse_set([bad])


# -- list / show ----------------------------------------------------------------------------


def test_no_command_prints_help(capsys):
    rc, out, _ = run(capsys)
    assert rc == 0 and "solve" in out and "bench" in out and "animate" in out


def test_help_exits_zero(capsys):
    rc, out, _ = run(capsys, "solve", "-h")
    assert rc == 0 and "--set" in out


def test_list(capsys):
    rc, out, _ = run(capsys, "list")
    assert rc == 0
    assert "problems (" in out and "open-field" in out and "straight line" in out
    assert "solvers (" in out and "visgraph" in out and "Certified shortest path" in out
    rc, out, _ = run(capsys, "list", "problems", "--tag", "basic")
    assert rc == 0 and "open-field" in out and "solvers (" not in out
    assert "paper-env1" not in out
    rc, out, _ = run(capsys, "list", "solvers")
    assert rc == 0 and "problems (" not in out and "visgraph" in out


def test_show_prints_summary_and_optimum(capsys, tmp_path):
    png = tmp_path / "map.png"
    rc, out, _ = run(capsys, "show", "open-field", "--out", str(png))
    assert rc == 0
    assert "open-field: Empty 100 x 100 field" in out
    assert "visgraph optimum (r1, known static map): 106.3015" in out  # hypot(80, 70)
    assert png.is_file() and png.stat().st_size > 1000


# -- solve ------------------------------------------------------------------------------------


def test_solve_summary_json_and_plot(capsys, tmp_path):
    js, png = tmp_path / "r.json", tmp_path / "r.png"
    rc, out, err = run(capsys, "solve", "open-field", "visgraph", "--seed", "4",
                       "--set", "arc_step=0.05", "--json", str(js), "--plot", str(png))
    assert rc == 0, err
    assert "status      optimal" in out
    assert "length      106.3015   ratio to optimum 1.0000" in out
    assert "collisions  0" in out and "ms" in out and "message" in out
    res = Result.load(js)
    assert res.status.value == "optimal" and res.seed == 4
    assert res.options["arc_step"] == 0.05
    assert png.is_file() and png.stat().st_size > 1000


def test_misspelled_problem_exits_2_with_suggestion(capsys):
    rc, out, err = run(capsys, "solve", "open-feild", "visgraph")
    assert rc == 2 and out == ""
    line = _one_line_error(err)
    assert "did you mean 'open-field'" in line


@pytest.mark.parametrize(("argv", "needle"), [
    (["solve", "open-field", "visgrahp"], "did you mean 'visgraph'"),
    (["solve", "open-field", "visgraph", "--set", "arc_stp=0.1"], "did you mean 'arc_step'"),
    (["solve", "open-field", "visgraph", "--set", "see_temporary=3"], "must be true or false"),
    (["solve", "open-field", "visgraph", "--set", "oops"], "key=value"),
    (["solve", "no/such/file.toml", "visgraph"], "no such scenario file"),
    (["show", "paper-env9"], "unknown problem"),
    (["plot", "missing.json", "--out", "x.png"], "no such result file"),
])
def test_bad_input_is_one_line_exit_2(capsys, argv, needle):
    rc, _, err = run(capsys, *argv)
    assert rc == 2
    assert needle in _one_line_error(err)


def test_argparse_errors_exit_2(capsys):
    rc, _, err = run(capsys, "solve", "open-field")
    assert rc == 2 and "optplan solve: error:" in err
    rc, _, err = run(capsys, "frobnicate")
    assert rc == 2 and "invalid choice" in err


def test_malformed_result_json(capsys, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    rc, _, err = run(capsys, "plot", str(bad), "--out", str(tmp_path / "x.png"))
    assert rc == 2 and "invalid JSON" in _one_line_error(err)


def test_traceback_flag_reraises():
    with pytest.raises(ValueError, match="unknown problem"):
        cli.main(["--traceback", "show", "nope-problem"])


# -- plot / animate ----------------------------------------------------------------------------


def test_plot_and_animate_from_json(capsys, tmp_path):
    js = tmp_path / "r.json"
    assert cli.main(["solve", "open-field", "visgraph", "--json", str(js)]) == 0
    png, gif = tmp_path / "fig.png", tmp_path / "run.gif"
    rc, out, _ = run(capsys, "plot", str(js), "--out", str(png), "--snapshot-every", "2")
    assert rc == 0 and png.is_file() and f"wrote {png}" in out
    rc, out, _ = run(capsys, "animate", str(js), "--out", str(gif), "--fps", "5",
                     "--max-frames", "5")
    assert rc == 0 and gif.is_file()
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames > 1
    rc, _, err = run(capsys, "animate", str(js), "--out", str(gif), "--fps", "0")
    assert rc == 2 and "--fps" in err


# -- bench ---------------------------------------------------------------------------------


def test_bench_generic(capsys, tmp_path):
    rc, out, err = run(capsys, "bench", "--problems", "open-field", "--solvers", "visgraph",
                       "--seeds", "3", "--out", str(tmp_path / "b"))
    assert rc == 0, err
    assert "| open-field | visgraph | 3 | 100 % | 106.30 |" in out
    assert "3/3" in err  # progress bar
    csv_lines = (tmp_path / "b" / "results.csv").read_text().splitlines()
    assert csv_lines[0].startswith("problem,solver,seed,status,success,length,ratio,collisions,"
                                   "min_clearance,wall_time,n_iter,n_eval")
    assert len(csv_lines) == 4
    md = (tmp_path / "b" / "summary.md").read_text()
    assert "| open-field | visgraph | 3 |" in md and "seeds 0..2" in md


def test_bench_tag_without_experiment_uses_tagged_problems(capsys, tmp_path):
    rc, out, err = run(capsys, "bench", "--tag", "basic", "--solvers", "visgraph", "--seeds",
                       "1", "--quiet", "--out", str(tmp_path / "b"))
    assert rc == 0, err
    assert "| open-field | visgraph | 1 |" in out and err == ""


def test_bench_errors(capsys, tmp_path):
    rc, _, err = run(capsys, "bench", "--problems", "open-field", "--out", str(tmp_path))
    assert rc == 2 and "--solvers" in _one_line_error(err)
    rc, _, err = run(capsys, "bench", "--tag", "no-such-tag", "--solvers", "visgraph",
                     "--out", str(tmp_path))
    assert rc == 2 and "no problem tagged 'no-such-tag'" in _one_line_error(err)


def _fake_experiment(monkeypatch, name: str, rc=0):
    calls = []
    mod = types.ModuleType(f"optplan.experiments.{name}")
    mod.__spec__ = importlib.machinery.ModuleSpec(mod.__name__, None)

    def main(argv):
        calls.append(list(argv))
        print("experiment ran")
        return rc

    mod.main = main
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    return calls


def test_bench_tag_dispatches_to_experiment(capsys, monkeypatch):
    calls = _fake_experiment(monkeypatch, "my_study", rc=3)
    rc, out, _ = run(capsys, "bench", "--tag", "my-study", "--seeds", "30", "--fast")
    assert rc == 3 and "experiment ran" in out
    assert calls == [["--seeds", "30", "--fast"]]
    rc, _, _ = run(capsys, "bench", "--seeds", "2", "--tag=my-study")
    assert calls[-1] == ["--seeds", "2"]


def test_validate_dispatch_and_missing(capsys, monkeypatch):
    calls = _fake_experiment(monkeypatch, "validate")
    rc, out, _ = run(capsys, "validate", "paper-env1", "--solver", "ipso-paper", "--seeds", "3")
    assert rc == 0 and calls == [["paper-env1", "--solver", "ipso-paper", "--seeds", "3"]]
    monkeypatch.setattr(cli, "_experiment", lambda name: None)
    rc, _, err = run(capsys, "validate", "paper-env1")
    assert rc == 2 and "optplan.experiments.validate is missing" in _one_line_error(err)


def test_python_dash_m(tmp_path):
    out = subprocess.run([sys.executable, "-m", "optplan", "list", "solvers"],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert out.returncode == 0 and "visgraph" in out.stdout


def test_import_optplan_stays_light():
    code = ("import sys, optplan, optplan.cli, optplan.bench; "
            "print(any(m.startswith('matplotlib') for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "False"
