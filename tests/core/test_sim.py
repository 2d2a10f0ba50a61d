"""The simulator's sensing (``ObstacleField``) against shapely, and its contact tolerance."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

import optplan as op
from optplan.sim import ObstacleField, SimSetup, simulate

SCENE = {
    "name": "sim-sensing",
    "bounds": [0, 0, 100, 100],
    "robots": [{"id": "r", "start": [5, 5], "goal": [95, 95], "radius": 1.0, "max_speed": 2.0}],
    "obstacles": [
        {"type": "rectangle", "name": "box", "min": [10, 60], "max": [50, 95]},
        {"type": "circle", "name": "tmp", "center": [25, 30], "radius": 8, "known": False},
        {"type": "polygon", "name": "ring", "vertices": [[60, 10], [95, 10], [95, 45], [60, 45]],
         "holes": [[[68, 18], [68, 37], [87, 37], [87, 18]]]},
        {"type": "polygon", "name": "ell",
         "vertices": [[60, 60], [90, 60], [90, 66], [66, 66], [66, 90], [60, 90]]},
    ],
    "dynamic_obstacles": [
        {"type": "circle", "name": "puck", "radius": 4, "waypoints": [[20, 50], [80, 50]],
         "times": [0, 10], "after": "bounce"},
        {"type": "polygon", "name": "vee",
         "vertices": [[-6, -6], [6, -6], [6, 6], [3, 6], [0, -1], [-3, 6], [-6, 6]],
         "waypoints": [[30, 5]], "velocity": [2.5, 1.5]},
    ],
}


@pytest.fixture(scope="module")
def scene() -> op.Problem:
    return op.parse_problem(SCENE)


def _oracle(prob: op.Problem, fld: ObstacleField, pts: np.ndarray, t: float):
    """Per obstacle: shapely distance (0 inside) and the boundary as a shapely geometry."""
    P = shapely.points(pts)
    dist, bnd = [], []
    for o in fld.static:
        if o.is_circle:
            dist.append(np.maximum(np.hypot(*(pts - o.center).T) - o.radius, 0.0))
            bnd.append(shapely.Point(o.center).buffer(o.radius, 256).boundary)
        else:
            dist.append(shapely.distance(P, o.geometry))
            bnd.append(o.geometry.boundary)
    for d in fld.dynamic:
        c = d.position(t)
        if d.kind == "circle":
            dist.append(np.maximum(np.hypot(*(pts - c).T) - d.radius, 0.0))
            bnd.append(shapely.Point(c).buffer(d.radius, 256).boundary)
        else:
            g = d.geometry_at(t)
            dist.append(shapely.distance(P, g))
            bnd.append(g.boundary)
    return np.stack(dist, axis=1), bnd


@pytest.mark.parametrize("t", [0.0, 7.3])
def test_nearest_matches_shapely(scene, t):
    fld = ObstacleField(scene)
    assert fld.names == ["box", "tmp", "ring", "ell", "puck", "vee"] and fld.n_static == 4
    rng = np.random.default_rng(int(10 * t))
    pts = rng.uniform(0, 100, (1500, 2))
    # points in the ring's hole, inside the moving vee and on its notch, deep inside the box
    c = scene.dynamic_obstacles[1].position(t)
    pts = np.vstack([pts, [[77, 27], [70, 20], [30, 77], [60.5, 44.5]],
                     c + [[-5, -5], [0, -3], [0, 2], [4.5, 0]]])
    near, dist = fld.nearest(pts, t)
    ref, bnd = _oracle(scene, fld, pts, t)
    assert near.shape == (len(pts), fld.n, 2) and dist.shape == (len(pts), fld.n)
    np.testing.assert_allclose(dist, ref, rtol=0, atol=1e-9)
    inside = ref == 0
    assert inside[:, 2].sum() > 100 and inside[:, 5].sum() >= 2  # ring and vee are exercised
    assert np.all(dist[inside] == 0.0)
    assert dist[-6, 2] > 0 and dist[-7, 2] > 0  # in the hole: outside the ring
    for j in range(fld.n):
        # the nearest point is on the boundary, and it is the nearest one (also from inside)
        on = shapely.distance(shapely.points(near[:, j]), bnd[j])
        tol = 1e-9 if j not in (1, 4) else 1e-3  # circle oracles are polygonised
        assert np.max(on) < tol
        to_b = shapely.distance(shapely.points(pts), bnd[j])
        np.testing.assert_allclose(np.hypot(*(pts - near[:, j]).T), to_b, rtol=0, atol=tol)


@pytest.mark.parametrize("t", [0.0, 7.3])
def test_nearest_range_and_deep_inside(scene, t):
    fld = ObstacleField(scene)
    rng = np.random.default_rng(5)
    pts = rng.uniform(0, 100, (800, 2))
    c = scene.dynamic_obstacles[1].position(t)
    pts = np.vstack([pts, [[30, 77.5]], c + [[0, -4]]])  # 17.5 deep in the box; in the vee
    ref, _ = _oracle(scene, fld, pts, t)
    for rr in (0.5, 3.0, 15.0):
        near, dist = fld.nearest(pts, t, max_range=rr)
        seen = ref <= rr
        clear = np.abs(ref - rr) > 1e-7  # no point on the range threshold
        assert np.array_equal(np.isfinite(dist) & clear, seen & clear)
        assert np.array_equal(np.isnan(near).any(axis=-1), ~np.isfinite(dist))
        np.testing.assert_allclose(dist[seen], ref[seen], rtol=0, atol=1e-9)
        assert dist[-2, 0] == 0.0 and dist[-1, 5] == 0.0  # inside reads 0 at any range
    # at the moving circle's centre: distance 0, nearest point towards +x
    pc = scene.dynamic_obstacles[0].position(t)
    near, dist = fld.nearest(pc, t, max_range=1.0)
    assert dist[0, 4] == 0.0 and np.allclose(near[0, 4], pc + [4.0, 0.0], atol=1e-12)
    # single point, (2,) input
    near, dist = fld.nearest(np.array([30.0, 77.5]), t, max_range=1.0)
    assert dist.shape == (1, fld.n) and dist[0, 0] == 0.0 and np.isinf(dist[0, 1:]).all()
    assert np.isnan(near[0, 1:]).all()  # every moving obstacle out of range, too


def test_nearest_filters_and_empty(scene):
    fld = ObstacleField(scene, include_temporary=False, include_dynamic=False)
    assert fld.names == ["box", "ring", "ell"] and fld.n == fld.n_static == 3
    pts = np.array([[25.0, 30.0], [30.0, 77.0]])
    near, dist = fld.nearest(pts)
    ref = [shapely.distance(shapely.points(pts), o.geometry) for o in fld.static]
    np.testing.assert_allclose(dist, np.stack(ref, axis=1), atol=1e-12)
    empty = ObstacleField(op.load_problem("open-field"))
    near, dist = empty.nearest(pts, 0.0, 5.0)
    assert near.shape == (2, 0, 2) and dist.shape == (2, 0)


def test_contact_tolerance_is_the_frame_eps():
    """A tiny map (diagonal 0.1): touching is no contact, ``2 eps`` of overlap is one."""
    prob = op.parse_problem({
        "name": "tiny", "bounds": [0, 0, 0.06, 0.08],
        "robots": [{"id": "r", "start": [0.01, 0.04], "goal": [0.01, 0.07], "radius": 0.01,
                    "max_speed": 0.01}],
        "obstacles": [{"type": "rectangle", "min": [0.03, 0.02], "max": [0.05, 0.06]}],
    })
    eps = prob.frame.eps
    assert eps == pytest.approx(1e-10)

    def run(x):
        out = simulate(prob, lambda s: np.zeros((1, 2)), ids=["r"], dt=1.0, max_steps=1,
                       done=lambda s: False, setup=SimSetup(start=np.array([[x, 0.04]])))
        return out.reason

    assert run(0.02) == "budget"  # distance exactly r
    assert run(0.02 + 0.5 * eps) == "budget"
    assert run(0.02 + 2 * eps) == "collision"


def test_state_fields_dt_leader_velocity_and_contacts():
    """Typed SimState fields instead of a memory dict: ``dt`` from the simulator,
    ``leader_velocity`` reset before every step, contacts recorded in order."""
    prob = op.parse_problem({
        "name": "two", "bounds": [0, 0, 50, 20],
        "robots": [{"id": "a", "start": [5, 10], "goal": [45, 10], "radius": 1.0,
                    "max_speed": 2.0},
                   {"id": "b", "start": [12, 10], "goal": [45, 12], "radius": 1.0,
                    "max_speed": 2.0}],
    })
    seen = []

    def policy(state):
        seen.append((state.dt, state.leader_velocity))
        state.leader_velocity = np.array([1.0, 0.0])  # a driver's note for this step only
        assert state.leader_command(0).tolist() == [1.0, 0.0]
        return np.array([[2.0, 0.0], [0.0, 0.0]])

    out = simulate(prob, policy, ids=["a", "b"], dt=0.5, max_steps=10, done=lambda s: False,
                   setup=SimSetup(stop_on_collision=False))
    assert all(dt == 0.5 and lv is None for dt, lv in seen)
    assert out.contacts and out.contacts[0].startswith("a touched b")
    assert all(isinstance(c, str) for c in out.contacts)
    assert not hasattr(out, "memory")


@pytest.mark.parametrize(("bad", "allowed"), [
    ({"start": np.zeros(2)}, r"None or an \(R, 2\) array"),
    ({"t0": float("nan")}, "a finite number of seconds"), ({"t0": True}, "a finite number"),
    ({"field": "all"}, "None or an ObstacleField"), ({"stop_on_collision": 1}, "True or False")])
def test_sim_setup_names_the_setting_its_value_and_what_is_allowed(bad, allowed):
    (name,) = bad
    with pytest.raises(ValueError, match=rf"SimSetup\.{name} must be {allowed}.*, got "):
        SimSetup(**bad)


def test_sim_setup_start_and_t0():
    """``start`` needs one row per robot of ``ids``; ``t0`` shifts every time stamp."""
    prob = op.parse_problem({
        "name": "one", "bounds": [0, 0, 10, 10],
        "robots": [{"id": "r", "start": [1, 1], "goal": [9, 1], "radius": 0.5,
                    "max_speed": 1.0}]})
    kw = {"ids": ["r"], "dt": 0.5, "max_steps": 4, "done": lambda s: False}
    with pytest.raises(ValueError, match=r"one row per robot of ids, shape \(1, 2\), got \(2, 2\)"):
        simulate(prob, lambda s: np.ones((1, 2)), setup=SimSetup(start=np.ones((2, 2))), **kw)
    with pytest.raises(TypeError, match="setup must be a SimSetup, got dict"):
        simulate(prob, lambda s: np.ones((1, 2)), setup={"t0": 1.0}, **kw)
    out = simulate(prob, lambda s: np.array([[1.0, 0.0]]),
                   setup=SimSetup(start=np.array([[2.0, 2.0]]), t0=3.0), **kw)
    assert out.times.tolist() == [3.0, 3.5, 4.0, 4.5, 5.0]
    assert out.positions[0, 0].tolist() == [2.0, 2.0]
    assert out.positions[-1, 0].tolist() == [4.0, 2.0]
