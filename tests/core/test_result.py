"""Result / Status / History / Progress behaviour and the JSON round trip."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import optplan as op
from optplan.result import History, Progress, Result, ResultFileError, Status, notify


def _result(**kw) -> Result:
    base = dict(
        status=Status.solved,
        paths={"r1": np.array([[0.0, 0.0], [1.5, 2.0], [3.0, 4.0]]),
               "r2": np.array([[1.0, 1.0], [2.0, 2.0]])},
        metrics={"feasible": True, "length": 5.0, "collisions": 0, "reached": True,
                 "min_clearance": float("inf"), "lengths": {"r1": 5.0, "r2": math.sqrt(2)},
                 "ratio_to_optimum": float("nan"), "flag": np.bool_(True),
                 "count": np.int64(3), "arr": np.arange(3.0)},
        solver="my-preset", backend="visgraph", options={"bracket": True, "w": (0.9, 0.4)},
        seed=7, problem="open-field", cost=5.0, n_iter=3, n_eval=30, wall_time=0.25,
        message="ok", extras={"stats": {"iters": np.int32(3)}, "status": Status.optimal},
    )
    base.update(kw)
    return Result(**base)


def test_status_str_and_value() -> None:
    assert str(Status.optimal) == "optimal"
    assert f"{Status.infeasible}" == "infeasible"
    assert Status("solved") is Status.solved
    assert Status.failed == "failed"  # str enum compares equal to its value
    assert [s.value for s in Status] == ["optimal", "solved", "approximate", "infeasible",
                                         "failed"]
    with pytest.raises(ValueError):
        Status("great")


@pytest.mark.parametrize("status,ok", [(Status.optimal, True), (Status.solved, True),
                                       (Status.approximate, False), (Status.infeasible, False),
                                       (Status.failed, False)])
def test_success_follows_status(status: Status, ok: bool) -> None:
    assert _result(status=status).success is ok


def test_path_is_leader_path() -> None:
    r = _result()
    assert r.path is r.paths["r1"]
    r2 = _result(metrics={"leader": "r2"})
    assert r2.path is r2.paths["r2"]


def test_json_round_trip(tmp_path) -> None:
    h = History()
    h.append(iteration=0, best_cost=10.0, n_eval=5, time=0.1)
    h.append(iteration=1, best_cost=8.0, n_eval=10, time=0.2, escapes=1)
    r = _result(history=h, times=np.array([0.0, 1.0, 2.0]), cost=float("inf"),
                paths={"r1": np.array([[0.0, 0.0], [1.5, 2.0], [3.0, 4.0]]),
                       "r2": np.array([[1.0, 1.0], [2.0, 2.0], [2.0, 2.0]])})
    f = tmp_path / "r.json"
    r.save(f)
    json.loads(f.read_text())  # valid JSON (nan / inf encoded as strings)
    back = Result.load(f)
    assert back.status is Status.solved
    assert set(back.paths) == {"r1", "r2"}
    for k in r.paths:
        assert back.paths[k].dtype == float
        np.testing.assert_array_equal(back.paths[k], r.paths[k])
    np.testing.assert_array_equal(back.times, r.times)
    assert back.metrics["length"] == 5.0
    assert back.metrics["feasible"] is True
    assert back.metrics["count"] == 3
    assert back.metrics["min_clearance"] == float("inf")
    assert math.isnan(back.metrics["ratio_to_optimum"])
    assert back.metrics["arr"] == [0.0, 1.0, 2.0]
    assert back.cost == float("inf")
    assert (back.solver, back.backend, back.seed, back.problem) == (
        "my-preset", "visgraph", 7, "open-field")
    assert back.options == {"bracket": True, "w": [0.9, 0.4]}
    assert (back.n_iter, back.n_eval, back.wall_time, back.message) == (3, 30, 0.25, "ok")
    assert back.extras == {"stats": {"iters": 3}, "status": "optimal"}
    np.testing.assert_array_equal(back.history["best_cost"], [10.0, 8.0])
    assert np.isnan(back.history["escapes"][0]) and back.history["escapes"][1] == 1
    assert back.to_dict() == r.to_dict()


def test_round_trip_of_a_real_solve(tmp_path) -> None:
    r = op.solve("open-field", "visgraph", rng=3)
    r.save(tmp_path / "v.json")
    back = Result.load(tmp_path / "v.json")
    assert back.status is r.status is Status.optimal
    np.testing.assert_array_equal(back.path, r.path)
    assert back.metrics["length"] == r.metrics["length"]
    assert back.summary() == r.summary()


def test_history_columns_and_padding() -> None:
    h = History()
    assert len(h) == 0 and h.keys() == []
    h.append(iteration=0, best_cost=3.0)
    h.append(iteration=1, best_cost=2.0, temperature=0.5)
    h.append(iteration=2)
    assert len(h) == 3
    assert "temperature" in h and "nope" not in h
    assert h.keys() == ["iteration", "best_cost", "temperature"]
    np.testing.assert_array_equal(h["iteration"], [0, 1, 2])
    b = h["best_cost"]
    assert isinstance(b, np.ndarray) and b[:2].tolist() == [3.0, 2.0] and np.isnan(b[2])
    t = h["temperature"]
    assert np.isnan(t[0]) and t[1] == 0.5 and np.isnan(t[2])
    with pytest.raises(KeyError, match="best_cost"):
        h["bets_cost"]
    d = h.to_dict()
    assert d["best_cost"][2] == "nan"
    h2 = History(d)
    assert len(h2) == 3 and h2.keys() == h.keys()
    assert "3 rows" in repr(h)


def test_notify_stop_protocol() -> None:
    p = Progress(iteration=1, best_cost=2.0, n_eval=3, elapsed=0.1)
    assert notify(None, p) is False
    seen = []
    assert notify(seen.append, p) is False and seen == [p]

    def stop(_: Progress) -> None:
        raise StopIteration

    assert notify(stop, p) is True

    def boom(_: Progress) -> None:
        raise RuntimeError("user bug")

    with pytest.raises(RuntimeError):  # other exceptions propagate
        notify(boom, p)


def test_summary_mentions_status_and_length() -> None:
    s = _result().summary()
    assert "status solved" in s and "length 5.0000" in s and s.startswith("open-field / my-preset")


@pytest.mark.parametrize("text, match", [
    ("", "invalid JSON"),
    ('{"status": "solved", "solver": "x", "backend": "y", "paths": {"r": [[0, 0]]', "invalid JSON"),
    ("{}", "status: missing required key"),
    ("[]", "expected a JSON object"),
    ('{"status": "great", "solver": "x", "backend": "y", "paths": {"r": [[0, 0]]}}',
     "unknown status"),
    ('{"status": "solved", "solver": "x", "backend": "y", "paths": {"r": [[0, 0, 0]]}}',
     r"paths.r: expected shape \(n >= 1, 2\)"),
    ('{"status": "solved", "solver": "x", "backend": "y", "paths": {"r": [0, 1, 2, 3]}}',
     "paths.r: expected shape"),
    ('{"status": "solved", "solver": "x", "backend": "y", "paths": {"r": [[0, 0]]}, '
     '"metrics": [1, 2]}', "metrics: expected an object"),
    ('{"status": "solved", "solver": "x", "backend": "y", "paths": {"r": [[0, 0], [1, 1]]}, '
     '"times": [0, 1, 2]}', "times: expected one time stamp per path point"),
    ('{"schema": 99, "status": "solved", "solver": "x", "backend": "y", "paths": {}}',
     "unsupported result schema"),
])
def test_corrupted_result_files_name_file_and_key(tmp_path, text, match) -> None:
    f = tmp_path / "bad.json"
    f.write_text(text)
    with pytest.raises(ResultFileError, match=match) as ei:
        Result.load(f)
    assert str(f) in str(ei.value)


def test_non_utf8_and_missing_result_files(tmp_path) -> None:
    f = tmp_path / "bin.json"
    f.write_bytes(b"\xff\xfe{")
    with pytest.raises(ResultFileError, match="not UTF-8"):
        Result.load(f)
    with pytest.raises(ResultFileError, match="cannot read"):
        Result.load(tmp_path / "missing.json")


def test_result_embeds_the_solved_scenario(tmp_path) -> None:
    prob = op.parse_problem({
        "name": "paper-env1", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r1", "start": [5.0, 5.0], "goal": [95.0, 95.0], "radius": 1.0}],
        "obstacles": [{"type": "circle", "center": [50.0, 50.0], "radius": 10.0}]})
    res = op.solve(prob, "visgraph")
    res.save(tmp_path / "r.json")
    back = Result.load(tmp_path / "r.json")
    p = back.scenario_problem()
    # an edited copy named like a catalogue scene: the embedded map is the one that was solved
    assert p.bounds == prob.bounds and len(p.obstacles) == 1 and p.obstacles[0].is_circle
    assert back.metrics["optimum"] == pytest.approx(res.metrics["optimum"])
