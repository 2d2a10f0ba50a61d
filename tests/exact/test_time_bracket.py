"""The ``time-bracket`` preset: a certified bracket on the earliest arrival over all motions."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.exact.sipp import earliest_arrival
from optplan.exact.time_bracket import lattice, shortcut
from optplan.problem import parse_problem
from optplan.time_families import DOOR_KEEPER
from optplan.time_families import door_scene as door
from tests.geometry.time_scenes import time_scene


def _bracket(p: op.Problem, **options) -> op.Result:
    return op.solve(p, "time-bracket", time_limit=600, **options)


def test_the_door_scene_is_bracketed_and_the_upper_side_beats_sipp():
    p = door()
    sipp = earliest_arrival(p, "r")
    res = _bracket(p, max_level=3, gap_tol=0.0)
    m = res.metrics
    assert res.status is op.Status.solved and m["collisions"] == 0 and m["reached"]
    # the robot must wait for the door: no motion passes before t = 20, then 18 to go
    assert m["arrival_lower"] <= 20.0 + 18.0 <= m["arrival_upper"]
    assert m["arrival_upper"] < sipp.arrival - 0.4  # waits in the room, not in the doorway
    assert m["arrival_gap"] == pytest.approx(1 - m["arrival_lower"] / m["arrival_upper"])
    levels = res.extras["time_bracket"]["levels"]
    assert [lv["level"] for lv in levels] == [0, 1, 2, 3]
    assert levels[0]["upper"] == pytest.approx(sipp.arrival, rel=1e-12)  # level 0 is sipp
    ups, los = [lv["upper"] for lv in levels], [lv["lower"] for lv in levels]
    assert ups == sorted(ups, reverse=True) and los == sorted(los)  # never worse
    assert "gap" in res.message and res.stop_reason == ""


def test_a_bracket_that_closes_is_optimal():
    """Nothing in the way: sipp's arrival equals the certified bound at level 0."""
    far = {"type": "circle", "radius": 0.1, "waypoints": [[1, 9], [2, 9]], "times": [0, 1]}
    res = _bracket(time_scene([far]))
    assert res.status is op.Status.optimal
    assert res.metrics["arrival_upper"] == pytest.approx(8.0, rel=1e-12)
    assert res.metrics["arrival_gap"] <= 1e-9
    assert len(res.extras["time_bracket"]["levels"]) == 1
    assert "the earliest over all motions" in res.message


def test_waypoints_never_make_sipp_later():
    rng = np.random.default_rng(7)
    for _ in range(4):
        movers = [{"type": "circle", "radius": float(rng.uniform(0.2, 0.6)),
                   "waypoints": rng.uniform(1, 9, (3, 2)).tolist(),
                   "times": sorted(rng.uniform(0, 12, 3).tolist()),
                   "after": str(rng.choice(["hold", "loop", "bounce"]))}
                   for _ in range(3)]
        p = time_scene(movers, obstacles=[((5, 3), 1.0)])
        plain = earliest_arrival(p, "r")
        if plain.arrival is None:
            continue
        for level in (1, 2, 3):
            w = earliest_arrival(p, "r", waypoints=lattice(p, "r", level))
            assert w.arrival is not None and w.arrival <= plain.arrival + 1e-9


def test_the_lattices_are_nested_and_free():
    p = door()
    oset = p.obstacle_set(0.3, known_only=False)
    prev = lattice(p, "r", 0)
    assert prev.shape == (0, 2)
    for level in (1, 2, 3, 4):
        pts = lattice(p, "r", level)
        assert oset.segment_free(pts, pts).all()
        have = {tuple(np.round(q, 9)) for q in pts}
        assert all(tuple(np.round(q, 9)) in have for q in prev)
        prev = pts


def test_shortcut_keeps_the_path_free_and_no_longer():
    p = door(movers=())
    path = np.array([[2, 10], [5, 12], [8, 8], [12, 12], [18.0, 9.8], [22, 10], [38, 10]])
    cut = shortcut(p, "r", path)
    oset = p.obstacle_set(0.3, known_only=False)
    assert oset.crossings(cut[None]).count[0] == 0
    seg = lambda q: float(np.hypot(*np.diff(q, axis=0).T).sum())  # noqa: E731
    assert seg(cut) < seg(path) and (cut[0] == path[0]).all() and (cut[-1] == path[-1]).all()


@pytest.mark.parametrize("scale,shift", [(1.0, (0.0, 0.0)), (1e-2, (3e3, -7e2)),
                                         (50.0, (-1e4, 2e4))])
def test_the_bracket_scales_with_space_and_time_and_ignores_translation(scale, shift):
    base = _bracket(door(), max_level=2, gap_tol=0.0).metrics
    m = _bracket(door(scale, shift), max_level=2, gap_tol=0.0).metrics
    assert m["arrival_upper"] == pytest.approx(base["arrival_upper"] * scale, rel=1e-6)
    assert m["arrival_lower"] == pytest.approx(base["arrival_lower"] * scale, rel=1e-6)


def test_a_far_mover_changes_nothing():
    far = {"type": "circle", "radius": 0.5, "waypoints": [[5, 1], [5, 1.5]], "times": [0, 100]}
    a = _bracket(door(), max_level=2, gap_tol=0.0).metrics
    b = _bracket(door(movers=(DOOR_KEEPER, far)), max_level=2, gap_tol=0.0).metrics
    assert b["arrival_upper"] == pytest.approx(a["arrival_upper"], rel=1e-9)
    assert b["arrival_lower"] == pytest.approx(a["arrival_lower"], rel=1e-9)


def test_one_robot_only():
    p = parse_problem({
        "name": "two", "bounds": [0, 0, 10, 10],
        "robots": [{"id": "a", "start": [1, 1], "goal": [9, 1], "radius": 0.2},
                   {"id": "b", "start": [1, 9], "goal": [9, 9], "radius": 0.2}]})
    with pytest.raises(ValueError, match="time-bracket plans one robot"):
        op.solve(p, "time-bracket")


def test_progress_reports_the_bracket():
    seen = []
    op.solve(door(), "time-bracket", max_level=2, gap_tol=0.0, time_limit=600,
             callback=seen.append)
    last = seen[-1]
    assert np.isfinite(last.best_cost) and 0 < last.info["arrival_lower"] <= last.best_cost
    assert 0 <= last.info["arrival_gap"] < 1


_CLOSER = {"type": "circle", "radius": 0.8, "name": "closer",
           "waypoints": [[20, 30], [20, 10], [20, 10], [20, 30]], "times": [0, 5, 25, 30]}


def test_a_door_that_closes_and_reopens():
    """The door is open until t = 5 (the robot needs 17.2 s to reach it), shut by a parked
    disc until t = 25, then the disc leaves upwards at speed 4.  By hand: in the doorway
    (|y - 10| <= 0.7 between the walls) the robot's centre is within 0.86 of the door's
    centre, less than the 1.1 it must keep, so it crosses x = 20 no earlier than t = 25.1
    (the disc 1.1 - 0.7 above its centre), and 18 remain: T* >= 43.1.  Waiting at
    (18.8, 10) until t = 25.2 and then driving straight arrives at 44.4 (the distance only
    grows: d^2 = (1.2 - s)^2 + (0.8 + 4 s)^2), so T* <= 44.4."""
    p = door(movers=(_CLOSER,))
    res = _bracket(p, max_level=3, gap_tol=0.0)
    m = res.metrics
    assert res.status is op.Status.solved and m["collisions"] == 0
    assert 43.1 <= m["arrival_upper"] <= 44.4  # the rings beside the parked disc beat the hand
    assert m["arrival_lower"] <= 43.1
    from optplan.geometry.timing import arrival_lower_bound
    fine = arrival_lower_bound(p, "r", level=8).value
    assert 42.5 < fine <= 43.1  # the cells see the shut door (the static bound says 36)


def test_a_valid_start_path_seeds_the_upper_side():
    """A plan of the scene with the walls is a valid motion without them: started from it,
    the bracket of the bare scene is never later (the issue's metamorphic case)."""
    p = door()
    walled = _bracket(p, max_level=1, gap_tol=0.0)
    bare = p.replaced(obstacles=())
    res = op.solve(bare, "time-bracket", max_level=1, gap_tol=0.0, time_limit=600,
                   init={"r": walled.paths["r"]})
    seeded = res.extras["time_bracket"]["init"]
    assert seeded["used"] and seeded["arrival"] <= walled.metrics["arrival_upper"] * (1 + 1e-9)
    assert res.metrics["arrival_upper"] <= walled.metrics["arrival_upper"] * (1 + 1e-9)
    assert res.metrics["collisions"] == 0
    off = op.solve(bare, "time-bracket", max_level=0, time_limit=600,
                   init={"r": np.array([[2, 10], [20, 10], [38, 10.0]])})  # through the keeper
    assert not off.extras["time_bracket"]["init"]["used"] or off.metrics["collisions"] == 0


def test_the_time_limit_stops_within_one_refinement(monkeypatch):
    """A clock that jumps past the limit once level 1 is done: the refinement stops at the
    next poll, inside level 2, and returns level 1's bracket (load-independent: no wall time
    is measured)."""
    from optplan import solver

    state = {"now": 0.0}
    monkeypatch.setattr(solver, "clock", lambda: state["now"])

    def jump(progress):
        if progress.iteration >= 2:  # level 1 reported
            state["now"] = 1e9

    res = op.solve(door(), "time-bracket", max_level=6, gap_tol=0.0, time_limit=5.0,
                   callback=jump)
    levels = res.extras["time_bracket"]["levels"]
    assert res.stop_reason == "time_limit" and "stopped by the time limit" in res.message
    assert [lv["level"] for lv in levels][:2] == [0, 1] and len(levels) <= 3
    assert levels[-1]["upper"] == levels[1]["upper"] == res.metrics["arrival_upper"]
    assert res.status is op.Status.solved and res.metrics["collisions"] == 0
