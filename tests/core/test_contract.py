"""The Solver contract (docs/api.md), checked for every registered solver.

Every preset whose backend module exists is collected automatically, and every registered
backend that no preset uses is checked under its own name (plugins included), so a new backend
is covered as soon as it is registered.  :data:`CASES` names, per backend, a catalogue scene it
solves quickly (default ``open-field``) and options that make the run fast (default none).
"""

from __future__ import annotations

import json
import random
from functools import cache
from typing import Any

import numpy as np
import pytest

import optplan as op
from optplan.geometry.tangent.tangent_graph import problem_shortest_path
from optplan.result import OPTIMAL_REL_TOL, History, Progress, Result, Status, _jsonable

#: backend -> (catalogue scene, options that make the contract runs fast)
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "pso": ("open-field", {"n_particles": 10, "k_max": 10}),
    "mpso": ("open-field", {"n_particles": 10, "k_max": 10}),
    "ipso": ("open-field", {"n_particles": 10, "k_max": 10, "A": 4}),
    "nlp": ("open-field", {"n_segments": 8}),
    "apf": ("trap-saddle", {"max_steps": 400}),
    "sa-apf": ("trap-saddle", {"max_steps": 600}),
    "hybrid": ("open-field", {"global_solver": "visgraph"}),
    "leader-follower": ("formation-open-field", {"path_solver": "visgraph", "max_steps": 150,
                                                 "dt": 1.0}),
    "formation-qp": ("formation-open-field", {"path_solver": "visgraph", "max_steps": 150,
                                              "dt": 1.0, "gamma": 1.0}),
    # both presets: orca-team needs a [formation]; orca moves the leader alone there
    "orca": ("formation-open-field", {"max_steps": 150, "dt": 1.0, "time_horizon_obst": 1.0}),
}

#: A small scene whose optimum bends around obstacles (arcs): the second run of the
#: ``optimal`` contract for backends that certify (on ``open-field`` the optimum is a segment).
BENT_SCENE = "trap-u"


def _solvers() -> list[str]:
    presets = op.list_solvers()
    used = {type(op.get_solver(n)).name for n in presets}
    return presets + [b for b in op.list_backends() if b not in used]


SOLVERS = _solvers()


@cache
def setup(name: str) -> tuple[op.Problem, dict[str, Any], type]:
    cls = type(op.get_solver(name))
    scene, overrides = CASES.get(cls.name, ("open-field", {}))
    return op.load_problem(scene), dict(overrides), cls


class _Recorder:
    def __init__(self, stop_after: int | None = None):
        self.calls: list[Progress] = []
        self.stop_after = stop_after

    def __call__(self, progress: Progress) -> None:
        self.calls.append(progress)
        if self.stop_after is not None and len(self.calls) >= self.stop_after:
            raise StopIteration


@cache
def runs(name: str) -> dict[str, Any]:
    """Two runs with the same seed (the second with a passive callback) and a stopped run."""
    prob, ov, _ = setup(name)
    np_state = np.random.get_state()  # noqa: NPY002 - checking it is left untouched
    py_state = random.getstate()
    first = op.solve(prob, name, rng=0, **ov)
    after_np = np.random.get_state()  # noqa: NPY002
    after_py = random.getstate()
    rec = _Recorder()
    second = op.solve(prob, name, rng=0, callback=rec, **ov)
    stop = _Recorder(stop_after=1)
    stopped = op.solve(prob, name, rng=0, callback=stop, **ov)
    return {
        "first": first, "second": second, "rec": rec, "stopped": stopped, "stop": stop,
        "np_same": all(np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b
                       for a, b in zip(np_state, after_np)),
        "py_same": py_state == after_py,
    }


pytestmark = pytest.mark.parametrize("name", SOLVERS)


def test_result_fields_and_types(name: str) -> None:
    prob, _, cls = setup(name)
    r = runs(name)["first"]
    assert isinstance(r, Result)
    assert isinstance(r.status, Status)
    assert r.solver == name and r.backend == cls.name
    assert r.problem == prob.name
    assert isinstance(r.metrics, dict) and isinstance(r.extras, dict)
    assert isinstance(r.options, dict) and isinstance(r.message, str)
    assert isinstance(r.history, History)
    assert isinstance(r.n_iter, int) and r.n_iter >= 0
    assert isinstance(r.n_eval, int) and r.n_eval >= 0
    assert isinstance(r.cost, float)
    assert isinstance(r.wall_time, float) and r.wall_time >= 0
    for col in r.history.keys():
        assert len(r.history[col]) == len(r.history)


def test_paths_are_float_arrays_from_the_start(name: str) -> None:
    prob, _, _ = setup(name)
    r = runs(name)["first"]
    assert isinstance(r.paths, dict) and r.paths
    assert set(r.paths) <= set(prob.robot_ids)
    assert {x.id for x in prob.planned_robots} <= set(r.paths)
    tol = 1e-9 * max(1.0, prob.extent)
    for rid, p in r.paths.items():
        assert isinstance(p, np.ndarray) and p.dtype == np.float64
        assert p.ndim == 2 and p.shape[1] == 2 and p.shape[0] >= 1, (rid, p.shape)
        assert np.all(np.isfinite(p))
        np.testing.assert_allclose(p[0], prob.robot(rid).start, atol=tol)
    if r.times is not None:
        t = np.asarray(r.times)
        assert t.ndim == 1 and np.all(np.diff(t) >= 0)
        assert all(len(p) == len(t) for p in r.paths.values())


def test_status_and_success_consistent(name: str) -> None:
    _, _, cls = setup(name)
    r = runs(name)["first"]
    assert r.success == (r.status in (Status.optimal, Status.solved))
    if r.success:
        assert r.metrics["feasible"] and r.metrics["reached"], r.message
    if r.status is Status.optimal:
        assert cls.certifies, "only exact backends may claim 'optimal'"
    assert str(r.status) == r.status.value


def _check_optimal_claim(prob: op.Problem, r: Result) -> None:
    """``optimal`` means one thing (docs/api.md, "Status"): the certified optimum of the map
    the solver planned on exists and confirms the length within OPTIMAL_REL_TOL, and the
    validator accepts the paths."""
    if r.status is not Status.optimal:
        return
    known_only = not r.options.get("see_temporary", False)
    ref = problem_shortest_path(prob, prob.leader, known_only)
    assert ref.polyline is not None and ref.info.get("certified"), r.message
    length = r.metrics.get("length_exact", r.metrics["length"])  # visgraph: its exact arcs
    assert length <= ref.length * (1 + OPTIMAL_REL_TOL), (length / ref.length - 1, r.message)
    m = op.evaluate(prob, r.paths, r.times)
    assert m["feasible"] and m["reached"], r.message


def test_optimal_is_confirmed_by_the_certified_optimum(name: str) -> None:
    prob, ov, cls = setup(name)
    _check_optimal_claim(prob, runs(name)["first"])
    if cls.certifies:  # an exact backend also on a scene whose optimum has arcs
        bent = op.load_problem(BENT_SCENE)
        r = op.solve(bent, name, rng=0, **ov)
        assert r.status in (Status.optimal, Status.solved), r.message
        _check_optimal_claim(bent, r)


def test_metrics_come_from_the_validator(name: str) -> None:
    prob, _, _ = setup(name)
    r = runs(name)["first"]
    for key in ("feasible", "length", "collisions", "reached"):
        assert key in r.metrics, key
    m = op.evaluate(prob, r.paths, r.times)
    for key in ("feasible", "collisions", "reached"):
        assert r.metrics[key] == m[key], key
    assert r.metrics["length"] == pytest.approx(m["length"])


def test_seed_and_effective_options_recorded(name: str) -> None:
    _, ov, _ = setup(name)
    r = runs(name)["first"]
    assert r.seed == 0
    assert _jsonable(r.options) == _jsonable(op.get_solver(name, **ov).options())
    for k, v in ov.items():
        assert _jsonable(r.options[k]) == _jsonable(v)


def test_same_seed_same_paths_and_global_state_untouched(name: str) -> None:
    d = runs(name)
    a, b = d["first"], d["second"]
    assert a.status is b.status
    assert set(a.paths) == set(b.paths)
    for k in a.paths:
        np.testing.assert_array_equal(a.paths[k], b.paths[k])
    assert d["np_same"], "the global numpy random state was used"
    assert d["py_same"], "the global `random` state was used"


def test_callback_is_called_and_stop_is_honoured(name: str) -> None:
    d = runs(name)
    full, rec, stopped, stop = d["first"], d["rec"], d["stopped"], d["stop"]
    assert all(isinstance(p, Progress) for p in rec.calls)
    if full.n_iter > 1:
        assert rec.calls, "the backend iterates but never calls notify(callback, ...)"
    assert isinstance(stopped, Result) and isinstance(stopped.status, Status)
    if stop.calls:
        assert len(stop.calls) == 1, "the backend kept calling back after StopIteration"
        if full.n_iter > 1:
            assert stopped.n_iter < full.n_iter


def test_json_round_trip(name: str, tmp_path) -> None:
    r = runs(name)["first"]
    f = tmp_path / "result.json"
    r.save(f)
    back = Result.load(f)
    assert back.status is r.status
    assert set(back.paths) == set(r.paths)
    for k in r.paths:
        np.testing.assert_array_equal(back.paths[k], r.paths[k])
    assert json.dumps(_jsonable(back.metrics), sort_keys=True) == json.dumps(
        _jsonable(r.metrics), sort_keys=True)
    assert back.to_dict() == json.loads(f.read_text())


def test_unknown_override_is_rejected_with_a_suggestion(name: str) -> None:
    prob, ov, _ = setup(name)
    opts = list(op.get_solver(name).options())
    if not opts:
        pytest.skip("backend has no options")
    real = max(opts, key=len)
    typo = real[:-1] + ("x" if real[-1] != "x" else "y") + "_"
    with pytest.raises(ValueError, match=f"did you mean '{real}'"):
        op.solve(prob, name, rng=0, **{**ov, typo: 1})
