"""Honest statuses: continuous-time validation, early stops, time limits, the optional reference."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pytest

import optplan as op
from optplan.generators import swap_scene
from optplan.metrics import evaluate
from optplan.problem import parse_problem
from optplan.result import OPTIMAL_REL_TOL


def crossing_scene(speed: float = 2.0) -> op.Problem:
    """A robot goes straight along y = 50 at max speed 2; a disc crosses x = 50 from below and
    is there exactly when the robot is (t = 20)."""
    return parse_problem({
        "name": "crossing", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": 1.0,
                    "max_speed": speed}],
        "dynamic_obstacles": [{"type": "circle", "name": "cart", "radius": 3.0,
                               "waypoints": [[50.0, 10.0], [50.0, 90.0]],
                               "times": [0.0, 40.0]}]})


def test_a_crossing_moving_obstacle_makes_the_straight_path_unsuccessful() -> None:
    res = op.solve(crossing_scene(), "visgraph")
    assert not res.success
    assert res.metrics["static_collisions"] == 0 and res.metrics["dynamic_contacts"] == 1
    fc = res.metrics["first_contact"]
    assert fc["other"] == "cart" and fc["robot"] == "r"
    # contact starts when the centres are 4 apart: |(10 + 2t, 50) - (50, 10 + 2t)| = 4
    t_contact = min(t for t in np.linspace(0, 40, 400001)
                    if math.hypot(10 + 2 * t - 50, 50 - 10 - 2 * t) < 4.0)
    assert fc["time"] == pytest.approx(t_contact, abs=1e-3)
    assert "'cart'" in res.message and f"t={fc['time']:.3f}" in res.message
    # at another speed the robot passes before the cart: a success again
    assert op.solve(crossing_scene(speed=5.0), "visgraph").status is op.Status.optimal


def test_a_fast_obstacle_between_two_stamps_is_detected() -> None:
    """The robot stands still; a disc of radius 1 crosses it at speed 100 between two stamps
    one second apart: at both stamps it is 50 away, in between it passes through."""
    prob = parse_problem({
        "name": "fast", "bounds": [0.0, 0.0, 200.0, 100.0],
        "robots": [{"id": "r", "start": [100.0, 50.0], "goal": [100.0, 50.0], "radius": 1.0}],
        "dynamic_obstacles": [{"type": "circle", "name": "bullet", "radius": 1.0,
                               "waypoints": [[50.0, 50.0]], "times": [0.0],
                               "velocity": [100.0, 0.0]}]})
    path = np.array([[100.0, 50.0], [100.0, 50.0]])
    m = evaluate(prob, {"r": path}, times=np.array([0.0, 1.0]))
    assert m["dynamic_contacts"] == 1 and not m["feasible"]
    assert m["first_contact"]["time"] == pytest.approx(0.48, abs=1e-6)  # centres 2 apart


def test_sa_apf_run_with_a_fast_crosser_is_checked_between_stamps() -> None:
    """An SA-APF run whose simulation steps are coarse next to a fast crossing obstacle: the
    validator replays it in continuous time."""
    prob = parse_problem({
        "name": "fast-cross", "bounds": [0.0, 0.0, 200.0, 100.0],
        "robots": [{"id": "r", "start": [20.0, 50.0], "goal": [180.0, 50.0], "radius": 2.0,
                    "max_speed": 5.0}],
        "dynamic_obstacles": [{"type": "circle", "name": "bullet", "radius": 1.0,
                               "waypoints": [[100.0, -2000.0]], "times": [0.0],
                               "velocity": [0.0, 130.0]}]})
    res = op.solve(prob, "sa-apf-paper", rng=0)
    t, p = res.times, res.path
    # recompute: did the bullet pass within 3 of the robot between two stamps?
    ts = np.linspace(t[0], t[-1], 200001)
    rob = np.stack([np.interp(ts, t, p[:, 0]), np.interp(ts, t, p[:, 1])], axis=1)
    bul = np.stack([np.full_like(ts, 100.0), -2000.0 + 130.0 * ts], axis=1)
    hit = np.hypot(*(rob - bul).T).min() < 3.0
    at_stamps = np.hypot(p[:, 0] - 100.0, p[:, 1] - (-2000.0 + 130.0 * t)).min() < 3.0
    assert hit and not at_stamps  # the scene is built so: a contact only between two stamps
    assert res.metrics["dynamic_contacts"] == 1
    assert not res.success and "bullet" in res.message


def test_two_robots_swapping_on_straight_paths_are_flagged() -> None:
    res = op.solve(swap_scene(), "visgraph")
    assert not res.success
    assert res.metrics["separation_violations"] == 1
    fc = res.metrics["first_contact"]
    assert fc["kind"] == "robot"
    # they meet head-on at speed 5 each: centres 6 apart when 160 - 10 t = 6
    assert fc["time"] == pytest.approx((160.0 - 6.0) / 10.0, abs=1e-6)
    # offset far enough sideways they pass
    assert op.solve(swap_scene(dy=7.0), "visgraph").status is op.Status.optimal


def test_the_reference_is_optional_and_timed_apart() -> None:
    prob = op.load_problem("paper-env1")
    res = op.solve(prob, "pso-paper", rng=0, k_max=5)
    assert "optimum" not in res.metrics and "ratio_to_optimum" not in res.metrics
    fresh = dataclasses.replace(prob, _cache={})  # nothing computed on it yet
    ref = op.solve(fresh, "pso-paper", rng=0, k_max=5, reference=True)
    assert ref.metrics["optimum"] == pytest.approx(737.9795766677917, rel=1e-9)
    assert ref.metrics["ratio_to_optimum"] == pytest.approx(
        ref.metrics["length"] / ref.metrics["optimum"])
    assert ref.metrics["reference_time"] > 0
    again = op.solve(fresh, "pso-paper", rng=0, k_max=5, reference=True)
    assert again.metrics["reference_time"] == 0.0  # cached per problem
    # no certified optimum: the reason is reported, not swallowed
    boxed = parse_problem({
        "name": "boxed", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 10.0], "goal": [50.0, 50.0], "radius": 1.0}],
        "obstacles": [{"type": "polygon", "vertices": [[30, 30], [70, 30], [70, 70], [30, 70]],
                       "holes": [[[40, 40], [60, 40], [60, 60], [40, 60]]]}]})
    res = op.solve(boxed, "pso-paper", rng=0, k_max=3, reference=True)
    assert "not reachable" in res.metrics["reference_error"]


@pytest.mark.parametrize("solver", ["visgraph", "pso-paper"])
def test_wall_time_includes_the_validation(solver, monkeypatch) -> None:
    """``wall_time`` is what ``op.solve`` took: at least the seconds its validator ran
    (measured by a wrapper around the validator, no timing threshold)."""
    import optplan.backend as solver_mod  # Backend.finish calls the validator there

    spent: list[float] = []
    real = solver_mod.evaluate

    def timed(*a, **k):
        t0 = time.perf_counter()
        out = real(*a, **k)
        spent.append(time.perf_counter() - t0)
        return out

    monkeypatch.setattr(solver_mod, "evaluate", timed)
    fresh = dataclasses.replace(op.load_problem("paper-env1"), _cache={})
    res = op.solve(fresh, solver, rng=0, k_max=5) if solver != "visgraph" else op.solve(
        fresh, solver)
    assert len(spent) >= 1
    assert res.wall_time >= sum(spent)


def test_finish_takes_the_effort_keywords_and_refuses_others() -> None:
    """``n_iter``, ``n_eval`` and ``wall_time`` (:class:`optplan.backend.Effort`) become the
    Result's fields (0 when left out; ``wall_time`` gains the validation); a misspelt keyword
    raises ``TypeError`` as a missing parameter would."""
    prob = op.load_problem("open-field")
    backend = op.get_solver("visgraph")
    paths = {r.id: np.array([r.start, r.goal]) for r in prob.robots}
    res = backend.finish(prob, paths, claim=op.Status.solved, n_iter=3, n_eval=7,
                         wall_time=2.0)
    assert (res.n_iter, res.n_eval) == (3, 7) and res.wall_time >= 2.0
    bare = backend.finish(prob, paths, claim=op.Status.solved)
    # the effort's defaults: no iterations, and the wall time of finish() itself (not 2.0)
    assert (bare.n_iter, bare.n_eval) == (0, 0) and 0.0 <= bare.wall_time != 2.0
    with pytest.raises(TypeError, match="unexpected keyword argument 'n_itr' .*n_iter, n_eval, "
                                        "wall_time"):
        backend.finish(prob, paths, claim=op.Status.solved, n_itr=3)


def test_a_new_problem_builds_each_obstacle_set_once(monkeypatch) -> None:
    """The swarm plans on the known view; without temporary obstacles the validator uses the
    set the planner built instead of building it again.  The swarm's
    fitness set has no bounds wall (its search box keeps the waypoints in the bounds), the
    validator's has: one build of each."""
    import optplan.geometry as geometry
    from optplan.problem import shared

    built: list[tuple[float, bool]] = []
    real = geometry.obstacle_set

    def counted(*a, **k):
        built.append((float(a[1]), bool(k.get("walls", True))))
        return real(*a, **k)

    monkeypatch.setattr(geometry, "obstacle_set", counted)
    shared.clear()  # the process's shared obstacle sets: as in a fresh process
    prob = dataclasses.replace(op.load_problem("paper-env1"), _cache={})
    assert all(o.known for o in prob.obstacles)
    op.solve(prob, "pso-paper", rng=0, k_max=3)
    assert (prob.leader.radius, True) in built
    assert len(built) == len(set(built)), built


@pytest.mark.parametrize("solver, problem, over", [
    ("ipso", "paper-env1", {"k_max": 10**6}),
    ("nlp-ipopt", "paper-env1", {}),
    ("sa-apf-paper", "paper-hybrid", {}),
    ("hybrid-paper", "paper-hybrid", {}),
])
def test_time_limit_stops_every_kind_of_backend(solver, problem, over, monkeypatch) -> None:
    """The run stops at its first poll of the deadline after the limit.  The deadline's clock
    (``optplan.solver.clock``) is a fake that advances one second per reading, so the outcome
    does not depend on the machine's speed or load: the first poll is past the limit."""
    import optplan.solver as solver_mod

    readings = []

    def ticks() -> float:
        readings.append(None)
        return float(len(readings))

    monkeypatch.setattr(solver_mod, "clock", ticks)
    res = op.solve(op.load_problem(problem), solver, rng=0, time_limit=0.5, **over)
    # behaviour only: how soon it returns is bench_overhead.py's figure, not a test bound
    assert res.stop_reason == "time_limit", res.message
    assert len(readings) == 2, len(readings)  # the start, then the first poll: it stopped
    assert res.status in (op.Status.solved, op.Status.approximate)
    assert "time limit" in res.message


def test_callback_stop_and_errors() -> None:
    def stop(p):
        raise StopIteration

    res = op.solve("paper-env1", "ipso", rng=0, callback=stop)
    assert res.stop_reason == "callback"
    assert res.status in (op.Status.solved, op.Status.approximate)

    class Boom(Exception):
        pass

    def boom(p):
        raise Boom("from the callback")

    for solver in ("ipso", "sa-apf-paper", "visgraph"):
        with pytest.raises(Boom):
            op.solve("paper-env1" if solver != "sa-apf-paper" else "paper-apf-env1", solver,
                     rng=0, callback=boom)
    with pytest.raises(ValueError, match="time_limit"):
        op.solve("paper-env1", "visgraph", time_limit=-1)


def test_nlp_is_optimal_only_when_the_certified_optimum_confirms_it() -> None:
    # a straight optimum: the KKT point is the optimum to round-off
    line = op.solve("trap-gnron", "nlp-ipopt", reference=True)
    assert line.status is op.Status.optimal, line.message
    assert line.metrics["ratio_to_optimum"] <= 1 + OPTIMAL_REL_TOL
    prob = op.load_problem("paper-env1")
    good = op.solve(prob, "nlp-ipopt")  # started from the certified (tangent-graph) path
    # in the optimum's class, but its chords cannot follow the optimum's arcs: not confirmed
    assert good.status is op.Status.solved, good.message
    gap = good.extras["ipopt"]["r1"]["optimum_gap"]
    assert OPTIMAL_REL_TOL < gap < 1e-3
    assert "locally optimal (KKT)" in good.message and "the optimum's homotopy class" in \
        good.message
    # a collision-free swarm path in another corridor: a KKT point there is only "solved"
    from optplan.geometry.collision.homotopy import same_homotopy

    oset = prob.obstacle_set(prob.robots[0].radius)
    best = good.paths["r1"]
    runs = (op.solve(prob, "pso-paper", rng=s) for s in range(30))
    wrong = next((w for w in runs if w.metrics["feasible"]
                  and not same_homotopy(w.paths["r1"], best, oset)), None)
    assert wrong is not None, "no feasible pso-paper seed in 0..29 outside the optimal corridor"
    res = op.solve(prob, "nlp-ipopt", init=wrong.paths)
    assert res.status is op.Status.solved
    assert "locally optimal (KKT)" in res.message and "another homotopy class" in res.message


def test_nlp_callback_errors_propagate_without_a_dump(capfd) -> None:
    class Boom(Exception):
        pass

    def boom(p):
        raise Boom("stop here")

    with pytest.raises(Boom):
        op.solve("paper-env1", "nlp-ipopt", callback=boom)
    assert "Boom" not in capfd.readouterr().err


def test_progress_elapsed_is_wall_time_and_sim_time_is_separate() -> None:
    seen = []
    t0 = time.perf_counter()
    res = op.solve("paper-apf-env1", "sa-apf-paper", rng=0, callback=seen.append)
    wall = time.perf_counter() - t0
    assert seen and all(p.elapsed <= wall + 1e-6 for p in seen)
    # simulated seconds: the clock of the trajectory, whatever the machine's speed
    assert seen[-1].sim_time == pytest.approx(float(res.times[-1]))
    assert all(b.elapsed >= a.elapsed for a, b in zip(seen, seen[1:]))
    swarm = []
    op.solve("paper-env1", "ipso", rng=0, callback=swarm.append)
    assert swarm[-1].sim_time is None and swarm[-1].elapsed > 0


@pytest.mark.parametrize("s, shift", [(0.01, (0.0, 0.0)), (100.0, (3e5, -2e5))])
def test_continuous_time_validation_is_scale_and_translation_invariant(s, shift) -> None:
    """Scaling lengths and speeds (not times) keeps every contact and its time."""
    from optplan.problem import transform_problem

    base = op.load_problem("paper-formation")
    moved = transform_problem(base, s, shift)
    a, b = op.solve(base, "visgraph"), op.solve(moved, "visgraph")
    assert a.status == b.status
    assert b.metrics["length_exact"] == pytest.approx(a.metrics["length_exact"] * s, rel=1e-9)
    fa, fb = a.metrics["first_contact"], b.metrics["first_contact"]
    assert (fa is None) == (fb is None)
    if fa is not None:
        assert fb["other"] == fa["other"] and fb["time"] == pytest.approx(fa["time"], rel=1e-6)
    assert b.metrics["dynamic_contacts"] == a.metrics["dynamic_contacts"]
