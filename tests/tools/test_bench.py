"""optplan.bench: the problems x solvers x seeds harness and its statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan import bench
from optplan.bench import pool as bench_pool
from optplan.bench import run as bench_run
from optplan.bench.rows import _overrides_for
from optplan.bench.run import _fresh

SCENE_TOML = """
name = "bench-box"
bounds = [0.0, 0.0, 50.0, 50.0]

[[robots]]
id = "r1"
start = [5.0, 25.0]
goal = [45.0, 25.0]
radius = 1.0

[[obstacles]]
type = "rectangle"
min = [20.0, 15.0]
max = [30.0, 35.0]
"""


def _strip_time(rows):
    """The rows without their times, NaN as None (NaN != NaN)."""
    return [{k: None if isinstance(v, float) and math.isnan(v) else v for k, v in r.items()
             if k not in ("wall_time", "reference_time")} for r in rows]


def test_run_grid_rows_order_and_common_seeds(tmp_path):
    scene = tmp_path / "bench-box.toml"
    scene.write_text(SCENE_TOML)
    calls = []
    rows = bench.run_grid(["open-field", str(scene)], ["visgraph", "visgraph"], seeds=[3, 7],
                          progress=lambda d, t, r: calls.append((d, t, r["seed"])))
    assert len(rows) == 2 * 2 * 2
    assert [c[0] for c in calls] == list(range(1, 9)) and {c[1] for c in calls} == {8}
    assert [(r["problem"], r["seed"]) for r in rows[:4]] == [
        ("open-field", 3), ("open-field", 7), ("open-field", 3), ("open-field", 7)]
    for r in rows:
        assert tuple(r) == bench.COLUMNS
        # visgraph returns a circumscribed polyline: a little above the exact optimum
        assert 1.0 - 1e-12 <= r["ratio"] <= 1.001 and r["n_iter"] == 1
    for r in rows[:4]:
        assert r["status"] == "optimal" and r["success"] is True and r["collisions"] == 0
    box = [r for r in rows if r["problem"] == str(scene)]
    ref = op.solve(str(scene), "visgraph", reference=True)
    assert {r["status"] for r in box} == {ref.status.value}
    assert {r["collisions"] for r in box} == {ref.metrics["collisions"]}
    # around the 10 x 20 block inflated by 1: the straight line (40) is blocked
    assert box[0]["length"] > 40.0
    assert box[0]["length"] == pytest.approx(ref.metrics["length"])
    # the harness's reference (computed once, on a cold copy) is solve(reference=True)'s
    assert box[0]["ratio"] == ref.metrics["ratio_to_optimum"]
    assert box[0]["optimum"] == ref.metrics["optimum"]
    assert box[0]["stop_reason"] == "" and box[0]["backend"] == "visgraph"
    assert '"arc_step"' in box[0]["options"]


def test_seeds_int_means_range():
    rows = bench.run_grid(["open-field"], ["visgraph"], seeds=3)
    assert [r["seed"] for r in rows] == [0, 1, 2]


def test_process_pool_matches_inline():
    a = bench.run_grid(["open-field"], ["visgraph", "visgraph"], seeds=2)
    b = bench.run_grid(["open-field"], ["visgraph", "visgraph"], seeds=2,
                       engine=bench.Engine(workers=2))
    assert _strip_time(a) == _strip_time(b)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"problems": ["open-feild"], "solvers": ["visgraph"]}, "did you mean 'open-field'"),
    ({"problems": ["open-field"], "solvers": ["visgrahp"]}, "did you mean 'visgraph'"),
    ({"problems": ["open-field"], "solvers": ["visgraph"],
      "overrides": {"*": {"arc_stp": 0.1}}}, "did you mean 'arc_step'"),
    ({"problems": ["open-field"], "solvers": ["visgraph"], "seeds": 0}, "seeds"),
    ({"problems": [], "solvers": ["visgraph"]}, "no problems"),
])
def test_bad_input_fails_before_running(kwargs, match, monkeypatch):
    ran = []
    monkeypatch.setattr(bench_run, "_execute", lambda *a, **k: ran.append(a))
    monkeypatch.setattr(bench_pool, "_execute", lambda *a, **k: ran.append(a))
    kwargs.setdefault("seeds", 1)
    with pytest.raises(ValueError, match=match):
        bench.run_grid(**kwargs)
    assert not ran


def test_overrides_star_then_per_solver():
    ov = {"*": {"a": 1, "b": 2}, "x": {"b": 3}}
    assert _overrides_for(ov, "x") == {"a": 1, "b": 3}
    assert _overrides_for(ov, "y") == {"a": 1, "b": 2}
    assert _overrides_for(None, "x") == {}
    with pytest.raises(ValueError, match="solver name"):
        _overrides_for({"bracket": True}, "x")


def test_overrides_reach_the_solver(monkeypatch):
    seen = []
    import optplan.solver

    real = optplan.solver.solve

    def spy(problem, solver, /, **kw):
        seen.append(kw)
        return real(problem, solver, **kw)

    monkeypatch.setattr(optplan.solver, "solve", spy)
    bench.run_grid(["open-field"], ["visgraph"], seeds=[5],
                   overrides={"*": {"arc_step": 0.05}, "visgraph": {"see_temporary": True}})
    assert len(seen) == 1 and callable(seen[0].pop("callback"))  # records the progress
    assert seen == [{"rng": 5, "arc_step": 0.05, "see_temporary": True}]
    bench.run_grid(["open-field"], ["visgraph"], seeds=[5], time_limit=2.5)
    assert seen[-1]["time_limit"] == 2.5


def test_a_run_that_raises_becomes_an_error_row(monkeypatch):
    import optplan.solver

    real = optplan.solver.solve

    def flaky(problem, solver, /, *, rng=None, **kw):
        if rng == 1:
            raise RuntimeError("boom")
        return real(problem, solver, rng=rng, **kw)

    monkeypatch.setattr(optplan.solver, "solve", flaky)
    rows = bench.run_grid(["open-field"], ["visgraph"], seeds=3)
    assert [r["status"] for r in rows] == ["optimal", "error", "optimal"]
    assert "RuntimeError: boom" in rows[1]["message"]
    s = bench.summarise(rows)[0]
    assert s["runs"] == 3 and s["errors"] == 1 and s["success"] == pytest.approx(2 / 3)
    assert "(1 errors)" in bench.to_markdown([s])


def _row(p, s, seed, length, success=True, status="solved", t=0.01):
    return {"problem": p, "solver": s, "seed": seed, "status": status, "success": success,
            "length": length, "ratio": length / 2.0, "collisions": 0 if success else 2,
            "min_clearance": 0.5, "wall_time": t, "n_iter": 10, "n_eval": 100, "message": "",
            "optimum": 2.0, "reference_time": 0.001, "stop_reason": "", "backend": "x",
            "options": "{}"}


def test_summarise_median_iqr_success():
    rows = [_row("p", "a", k, x, success=k != 3, status="solved" if k != 3 else "approximate",
                 t=0.01 * (k + 1))
            for k, x in enumerate([1.0, 2.0, 3.0, 4.0])]
    rows += [_row("p", "b", 0, float("nan"), success=False, status="failed")]
    s = {x["solver"]: x for x in bench.summarise(rows)}
    a = s["a"]
    assert a["runs"] == 4 and a["success"] == 0.75 and a["n_success"] == 3
    # quality over the successful runs only (1, 2, 3; not the approximate 4)
    assert a["length_median"] == 2.0
    assert a["length_iqr"] == pytest.approx(2.5 - 1.5)
    assert a["ratio_median"] == 1.0
    # failure descriptors and time over every run that returned
    assert a["collisions_median"] == 0.0
    assert a["time_median"] == pytest.approx(0.025)
    assert math.isnan(s["b"]["length_median"]) and s["b"]["success"] == 0
    md = bench.to_markdown(bench.summarise(rows)).splitlines()
    assert md[0].startswith("| problem | solver | runs | success |")
    assert len(md) == 4
    assert "| p | a | 4 | 75 % | 2.00 | 1.00 | 1.0000 |" in md[2]
    assert "| - |" in md[3]  # nan printed as '-'


def test_quality_medians_ignore_failing_runs():
    # a colliding PSO run would show a ratio of 0.97 to the certified optimum
    rows = [_row("p", "pso", 0, 2.2), _row("p", "pso", 1, 1.94, success=False,
                                           status="approximate")]
    s = bench.summarise(rows)[0]
    assert s["ratio_median"] == pytest.approx(1.1) and s["success"] == 0.5
    none_ok = bench.summarise([_row("p", "pso", 1, 1.94, success=False, status="approximate")])
    assert math.isnan(none_ok[0]["ratio_median"])
    assert math.isnan(none_ok[0]["length_median"])


def test_summarise_counts_timeouts():
    rows = [_row("p", "a", 0, 2.0), _row("p", "a", 1, 2.0, success=False, status="time_limit"),
            _row("p", "a", 2, 2.0, status="solved")]
    rows[1]["stop_reason"] = "hard_limit"
    rows[2]["stop_reason"] = "time_limit"
    s = bench.summarise(rows)[0]
    assert s["timeouts"] == 2 and s["errors"] == 0
    assert "(2 at time limit)" in bench.to_markdown([s])


def test_visgraph_runs_are_not_cache_hits(monkeypatch):
    """Every run solves a cold copy: each seed's search runs on a problem of its own, none
    of which held a path before (no wall-clock ratio: CI shares a loaded machine)."""
    from optplan.exact import visgraph

    seen = []
    real = visgraph.problem_shortest_path

    def spy(problem, *args, **kwargs):
        seen.append((problem, len(problem._cache)))  # held: no id is reused
        return real(problem, *args, **kwargs)

    monkeypatch.setattr(visgraph, "problem_shortest_path", spy)
    rows = bench.run_grid(["paper-env1"], ["visgraph"], seeds=4)
    assert len(seen) == 4 and len({id(p) for p, _ in seen}) == 4
    assert len({n for _, n in seen}) == 1  # the same cold state every time
    # the reference is computed once per problem and process, and reported for every run
    assert len({r["reference_time"] for r in rows}) == 1 and rows[0]["reference_time"] > 0
    base = op.load_problem("paper-env1")
    fresh = _fresh(base)
    assert fresh._cache is not base._cache and set(fresh._cache) <= {("frame",)}


def test_cooperative_time_limit_is_recorded():
    rows = bench.run_grid(["paper-env1"], ["pso-paper"], seeds=1, time_limit=1e-3)
    r = rows[0]
    assert r["stop_reason"] == "time_limit" and r["status"] in ("solved", "approximate")
    assert r["n_iter"] < 200 and "time limit" in r["message"]
    with pytest.raises(ValueError, match="time_limit"):
        bench.run_grid(["open-field"], ["visgraph"], seeds=1, time_limit=0)


def test_csv_round_trip(tmp_path):
    rows = [_row("p", "a", 0, 1.5), _row("p", "a", 1, float("nan"), success=False)]
    rows[0]["extra"] = "x"
    path = bench.write_csv(rows, tmp_path / "d" / "results.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[: len(bench.COLUMNS)] == list(bench.COLUMNS) and header[-1] == "extra"
    back = bench.read_csv(path)
    assert back[0]["length"] == 1.5 and back[0]["success"] is True and back[0]["seed"] == 0
    assert back[0]["optimum"] == 2.0 and back[0]["reference_time"] == 0.001
    assert np.isnan(back[1]["length"]) and back[1]["success"] is False
    assert bench.summarise(back)[0]["length_median"] == 1.5


def test_rows_carry_the_grading_in_time(tmp_path):
    """Among moving obstacles a row holds the grading against the time bracket: the same
    figures as ``solve(..., reference=True)``, the reference shared by the runs."""
    rows = bench.run_grid(["paper-apf-env1"], ["sipp", "apf-paper"], seeds=1)
    solo = op.solve("paper-apf-env1", "sipp", reference=True).metrics
    by = {r["solver"]: r for r in rows}
    for c in bench.TIME_COLUMNS:
        assert by["sipp"][c] == pytest.approx(solo[c], rel=1e-12), c
    assert by["apf-paper"]["time_reference"] == pytest.approx(solo["time_reference"])
    assert by["sipp"]["arrival_ratio_to_reference"] >= 1 - 1e-9
    md = bench.to_markdown(bench.summarise(rows))
    assert "arrival / reference median" in md and "arrival / lower median" in md
    static = bench.to_markdown(bench.summarise(bench.run_grid(["paper-env1"], ["visgraph"],
                                                              seeds=1)))
    assert "arrival / reference" not in static  # no moving obstacles, no columns in time
