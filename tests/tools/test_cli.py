"""The ``optplan`` command line (optplan.cli.main)."""

from __future__ import annotations

import importlib.machinery
import json
import os
import sys
import types
import warnings

import pytest

from optplan import cli
from optplan.cli import app
from optplan.result import Result
from tests import helpers


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


def test_solve_progress_shows_the_bracket_closing(capsys):
    rc, out, err = run(capsys, "solve", "paper-apf-env1", "time-bracket", "--progress",
                       "--no-reference")
    assert rc == 0, err
    lines = [ln for ln in err.splitlines() if ln.startswith("progress:")]
    assert lines and "bracket [" in lines[-1] and lines[-1].endswith("gap 0 %")
    assert len(lines) == len(set(lines))  # one line per change
    assert "status      optimal" in out


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


def test_bench_solvers_all_runs_every_preset(capsys, tmp_path, monkeypatch):
    import optplan.bench

    seen = {}

    def fake_grid(problems, solvers, seeds, **kw):
        seen["solvers"] = list(solvers)
        return []

    monkeypatch.setattr(optplan.bench, "run_grid", fake_grid)
    run(capsys, "bench", "--problems", "open-field", "--solvers", "all", "--seeds", "1",
        "--quiet", "--out", str(tmp_path / "b"))
    from optplan import list_solvers

    assert seen["solvers"] == list_solvers()


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
    monkeypatch.setattr(app, "_experiment", lambda name: None)
    rc, _, err = run(capsys, "validate", "paper-env1")
    assert rc == 2 and "optplan.experiments.validate is missing" in _one_line_error(err)


def test_python_dash_m(tmp_path):
    out = helpers.run([sys.executable, "-m", "optplan", "list", "solvers"],
                      capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0 and "visgraph" in out.stdout


def test_import_optplan_stays_light():
    code = ("import sys, optplan, optplan.cli, optplan.bench; "
            "print(any(m.startswith('matplotlib') for m in sys.modules))")
    out = helpers.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "False"


# -- bad input is one line and exit 2, never a traceback or a warning -----------------------

_SCENE = """name = "s"
bounds = [0.0, 0.0, 100.0, 100.0]

[[robots]]
id = "leader"
start = [10.0, 10.0]
goal = [90.0, 90.0]
radius = 1.0

[[robots]]
id = "f1"
start = [5.0, 10.0]
radius = 1.0
"""
_FORMATION = '[formation]\nleader = "leader"\nfollowers = [{ id = "f1", L = 5.0, phi = 0.5 }]\n'
_POLY = '[[obstacles]]\ntype = "polygon"\nvertices = [[40.0, 40.0], [60.0, 40.0], [50.0, 60.0]]\n'

#: bad scenario files -> text the one error line must contain (besides the file name)
BAD_SCENES: dict[str, tuple[str, str]] = {
    "type-list": (_SCENE + _FORMATION + _POLY.replace('"polygon"', '["polygon"]'),
                  "obstacles[0].type: expected a string"),
    "type-table": (_SCENE + _FORMATION + _POLY.replace('"polygon"', '{ kind = "polygon" }'),
                   "obstacles[0].type: expected a string"),
    "leader-list": (_SCENE + _FORMATION.replace('leader = "leader"', 'leader = ["leader"]'),
                    "formation.leader: expected a robot id string"),
    "leader-table": (_SCENE + _FORMATION.replace('leader = "leader"', 'leader = { id = 1 }'),
                     "formation.leader: expected a robot id string"),
    "followers-empty": (_SCENE + '[formation]\nleader = "leader"\nfollowers = []\n',
                        "formation.followers: expected at least one follower"),
    "followers-missing": (_SCENE + '[formation]\nleader = "leader"\n',
                          "formation.followers: missing required key"),
    "follower-unknown": (_SCENE + _FORMATION.replace('id = "f1"', 'id = "f9"'),
                         "formation.followers[0].id: names no robot: 'f9'"),
    "leader-as-follower": (_SCENE + _FORMATION.replace('id = "f1"', 'id = "leader"'),
                           "formation.followers[0].id: the leader 'leader' cannot"),
    "no-formation": (_SCENE, "robots[1].goal: missing required key"),
    "nested-3000": (_SCENE + _FORMATION + "zz = " + "[" * 3000 + "]" * 3000 + "\n",
                    "invalid TOML: arrays or inline tables nested too deeply"),
    "circle-minus-1e300": (_SCENE + _FORMATION + '[[obstacles]]\ntype = "circle"\n'
                           'center = [-1e300, 0.0]\nradius = 1.0\n',
                           "obstacles[0].center[0]: magnitude 1e+300 is beyond"),
    "speed-1e300": (_SCENE.replace("radius = 1.0\n", "radius = 1.0\nmax_speed = 1e300\n", 1)
                    + _FORMATION, "robots[0].max_speed: must be <="),
    "empty": ("", "name: missing required key"),
    "syntax": ("name = \n", "invalid TOML"),
}


def _bad_files(tmp_path):
    files = {}
    for name, (text, needle) in BAD_SCENES.items():
        f = tmp_path / f"{name}.toml"
        f.write_text(text, encoding="utf-8")
        files[name] = (["show", str(f)], str(f), needle)
    latin = tmp_path / "latin1.toml"
    latin.write_bytes(('name = "caf\xe9"\n').encode("latin-1"))
    files["non-utf8"] = (["show", str(latin)], str(latin), "not UTF-8 text")
    d = tmp_path / "dir.toml"
    d.mkdir()
    files["directory"] = (["show", str(d)], str(d), "is a directory")
    # result files
    good = tmp_path / "good.json"
    assert cli.main(["solve", "open-field", "visgraph", "--json", str(good)]) == 0
    base = json.loads(good.read_text())
    text = good.read_text()

    def res(name, content, needle):
        f = tmp_path / f"{name}.json"
        f.write_text(content if isinstance(content, str) else json.dumps(content))
        files[f"result-{name}"] = (["plot", str(f), "--out", str(tmp_path / "x.png")], str(f),
                                   needle)

    res("truncated", text[: len(text) // 2], "invalid JSON")
    res("empty-object", {}, "status: missing required key")
    res("three-columns", {**base, "paths": {"r1": [[0, 0, 0], [1, 1, 1]]}}, "paths.r1")
    res("flat", {**base, "paths": {"r1": [0.0, 1.0, 2.0, 3.0]}}, "paths.r1")
    res("metrics-list", {**base, "metrics": [1, 2]}, "metrics: expected an object")
    res("times-length", {**base, "times": [0.0] * 7}, "times: expected one time stamp")
    res("unknown-robot", {**base, "paths": {**base["paths"], "zz": [[1.0, 1.0]]}},
        "paths.zz: problem 'open-field' has no robot 'zz'")
    res("huge-point", {**base, "paths": {"r1": [[10.0, 10.0], [1e300, 1e300]]}}, "paths.r1")
    res("length-string", {**base, "metrics": {**base["metrics"], "length": "long"}},
        "metrics.length: expected a number")
    res("times-decreasing", {**base, "times": [1.0, 0.0]}, "times: expected finite, non-decr")
    res("no-problem", {k: v for k, v in base.items() if k != "scenario"} | {
        "problem": "no-such-problem"}, "problem: unknown problem 'no-such-problem'")
    res("bad-scenario", {**base, "scenario": {**base["scenario"], "bounds": [0, 0, 1]}},
        "scenario: bounds: expected [xmin, ymin, xmax, ymax]")
    return files


_DRIVER = r"""
import contextlib, io, json, os, sys, tempfile, warnings
from optplan import cli
out = []
for argv in json.loads(sys.stdin.read()):
    warnings.resetwarnings()
    warnings.simplefilter("always")  # nothing deduplicated: every warning would show
    sys.stderr.flush()
    with tempfile.TemporaryFile("w+") as err:
        saved = os.dup(2)
        os.dup2(err.fileno(), 2)
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                rc = cli.main(argv)
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
        err.seek(0)
        out.append([rc, err.read()])
print(json.dumps(out))
"""


def test_bad_files_give_one_line_and_exit_2_in_a_real_process(tmp_path):
    """Every bad file of the sample: exit status 2 and exactly one stderr line naming the file
    and the key (file-descriptor level capture: a warning or traceback would show)."""
    files = _bad_files(tmp_path)
    argvs = [v[0] for v in files.values()]
    proc = helpers.run([sys.executable, "-c", _DRIVER], input=json.dumps(argvs),
                       capture_output=True, text=True, cwd=tmp_path,
                       env={**os.environ, "PYTHONWARNINGS": "always"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    for (name, (_, path, needle)), (rc, err) in zip(files.items(), got):
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert rc == 2 and len(lines) == 1, (name, rc, err)
        assert lines[0].startswith("optplan: error: ") and path in lines[0], (name, err)
        assert needle in lines[0], (name, lines[0])


def test_console_script_bad_file_end_to_end(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(BAD_SCENES["followers-empty"][0], encoding="utf-8")
    p = helpers.run([sys.executable, "-W", "always", "-m", "optplan", "show", str(bad)],
                    capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.count("\n") == 1 and "formation.followers: expected at least" in p.stderr
    p = helpers.run([sys.executable, "-m", "optplan", "--traceback", "show", str(bad)],
                    capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode == 1 and "Traceback" in p.stderr and "ProblemError" in p.stderr


def test_warnings_never_precede_the_error_line(capsys, monkeypatch):
    def warn_then(fail):
        def fake(argv, out):
            warnings.warn("invalid value encountered in divide", RuntimeWarning, stacklevel=1)
            warnings.warn("invalid value encountered in divide", RuntimeWarning, stacklevel=1)
            if fail:
                raise ValueError("x.toml: robots[0].radius: must be >= 0, got -1")
            print("done", file=out)
            return 0
        return fake

    monkeypatch.setattr(app, "_dispatch", warn_then(True))
    rc, out, err = run(capsys, "show", "x.toml")
    assert rc == 2 and _one_line_error(err) == (
        "optplan: error: x.toml: robots[0].radius: must be >= 0, got -1")
    # after a success each distinct warning is reported once, after the output
    monkeypatch.setattr(app, "_dispatch", warn_then(False))
    rc, out, err = run(capsys, "show", "x.toml")
    assert rc == 0 and out == "done\n"
    assert err == ("optplan: warning: RuntimeWarning: invalid value encountered in divide\n")


def test_internal_error_is_one_line_exit_1(capsys, monkeypatch):
    def boom(argv, out):
        raise TypeError("unhashable type: 'list'")

    monkeypatch.setattr(app, "_dispatch", boom)
    rc, _, err = run(capsys, "show", "x.toml")
    lines = err.strip().splitlines()
    assert rc == 1 and len(lines) == 1 and "Traceback" not in err
    assert lines[0].startswith("optplan: internal error: TypeError: unhashable type")
    assert "--traceback" in lines[0]
    with pytest.raises(TypeError):
        cli.main(["--traceback", "show", "x.toml"])


@pytest.mark.parametrize(("argv", "needle"), [
    (["plot", "R", "--out", "x.txt"], "--out x.txt: unsupported format '.txt'"),
    (["plot", "R", "--out", "x.png", "--dpi", "0"], "--dpi must be in [1, 1200]"),
    (["plot", "R", "--out", "x.png", "--dpi", "1e9"], "--dpi must be in [1, 1200]"),
    (["plot", "R", "--out", "x.png", "--snapshot-every", "-1"], "--snapshot-every must be >= 0"),
    (["animate", "R", "--out", "x.png"], "unsupported format '.png'"),
    (["animate", "R", "--out", "x.gif", "--fps", "inf"], "--fps must be > 0"),
    (["animate", "R", "--out", "x.gif", "--fps", "nan"], "--fps must be > 0"),
    (["animate", "R", "--out", "x.gif", "--max-frames", "0"], "--max-frames must be in"),
    (["show", "open-field", "--out", "m.png", "--dpi", "100000"], "--dpi must be in"),
    (["show", "open-field", "--out", "m.bmp"], "unsupported format '.bmp'"),
])
def test_plot_animate_show_option_ranges(capsys, tmp_path, argv, needle):
    js = tmp_path / "r.json"
    assert cli.main(["solve", "open-field", "visgraph", "--json", str(js)]) == 0
    capsys.readouterr()
    argv = [str(js) if a == "R" else str(tmp_path / a) if a.startswith(("x.", "m.")) else a
            for a in argv]
    rc, _, err = run(capsys, *argv)
    assert rc == 2 and needle in _one_line_error(err).replace(str(tmp_path) + "/", "")


@pytest.mark.parametrize(("argv", "needle"), [
    (["validate", "open-field", "--seeds", "0"], "--seeds must be in [1, 100000], got 0"),
    (["validate", "open-field", "--seeds", "-3"], "--seeds must be in"),
    (["validate", "open-field", "--first-seed", "-1"], "--first-seed must be >= 0"),
    (["validate", "open-field", "--solver", "ipso-papr"], "--solver ipso-papr: unknown solver"),
    (["validate", "open-field", "--nlp", "nlp-ipop"], "--nlp nlp-ipop: unknown solver"),
    (["validate", "no/such.toml"], "no/such.toml: no such scenario file"),
])
def test_validate_checks_its_arguments_first(capsys, monkeypatch, argv, needle):
    calls = _fake_experiment(monkeypatch, "validate")
    rc, _, err = run(capsys, *argv)
    assert rc == 2 and needle in _one_line_error(err) and calls == []
