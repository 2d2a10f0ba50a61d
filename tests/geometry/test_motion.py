"""The motion model of moving obstacles and the continuous-time validator.

The validator (:func:`optplan.evaluate` with time stamps) is checked against an independent
reference written here with numpy and shapely only: the mover's position from the documented
rules (``problems/README.md``), the exact minimum distance on every linear sub-interval between
the breakpoints of both tracks (point-to-segment distance for a circle, shapely's segment to
polygon distance for a polygon) and a dense sampling (20,000 times plus every breakpoint, both
sides of each jump) that cross-checks the exact minimum.  Waypoint times are multiples of 1/64 s
so the reference's period arithmetic is exact at every period boundary.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely

import optplan as op
from optplan.geometry.timing.motion import mover_track, track_eval

DY = 1.0 / 64.0  # time grid of the movers' waypoint times (exact binary fractions)
N_DENSE = 20_000
BOUNDS = [-40.0, -40.0, 40.0, 40.0]
L = float(np.hypot(80.0, 80.0))


# --------------------------------------------------------------------------------------
# the independent reference
# --------------------------------------------------------------------------------------

def ref_position(spec: dict, t: np.ndarray, side: str = "right") -> np.ndarray:
    """The documented motion model; ``side="left"``: the limit from the left at a loop jump."""
    t = np.atleast_1d(np.asarray(t, float))
    times, w = spec["times"], spec["waypoints"]
    t0 = times[0]
    if spec.get("velocity") is not None:
        return w[0] + (t - t0)[:, None] * np.asarray(spec["velocity"])
    if len(times) == 1:
        return np.repeat(w[:1], len(t), axis=0)
    span = times[-1] - t0
    u = t - t0
    after = spec.get("after", "hold")
    if after == "hold":
        tau = np.clip(u, 0.0, span)
    elif after == "loop":
        k = np.floor(u / span)
        f = u - k * span
        if side == "left":
            f = np.where((f == 0.0) & (k >= 1), span, f)
        tau = np.where(u < 0, 0.0, f)
    else:  # bounce: forwards, then backwards, period 2 span
        f = np.mod(u, 2.0 * span)
        tau = np.where(u < 0, 0.0, np.where(f <= span, f, 2.0 * span - f))
    return np.stack([np.interp(t0 + tau, times, w[:, 0]), np.interp(t0 + tau, times, w[:, 1])],
                    axis=1)


def ref_knots(spec: dict, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Times in ``[lo, hi]`` where the mover's velocity may change, and the loop jump times."""
    times = spec["times"]
    if spec.get("velocity") is not None or len(times) == 1:
        return np.zeros(0), np.zeros(0)
    after = spec.get("after", "hold")
    if after == "hold":
        return times[(times >= lo) & (times <= hi)], np.zeros(0)
    t0, span = times[0], times[-1] - times[0]
    base = times - t0
    if after == "bounce":
        base, period = np.concatenate([base, 2 * span - base[::-1]]), 2 * span
    else:
        period = span
    out, jumps = [times], []
    k = 0
    while t0 + k * period <= hi:
        out.append(t0 + k * period + base)
        if after == "loop" and k >= 1:
            jumps.append(t0 + k * period)
        k += 1
    knots = np.concatenate(out)
    return knots[(knots >= lo) & (knots <= hi)], np.array(jumps)


def ref_gaps(spec: dict, kind: str, shape, stamps: np.ndarray, path: np.ndarray
             ) -> tuple[float, float, float]:
    """Centre-to-shape distance of the robot's centre: exact minimum, dense minimum, and the
    largest relative speed (for the sampling bound).

    The window is ``[min(0, first stamp), last stamp]``; the robot waits at its first point
    before its first stamp.  ``shape``: the circle's radius or the polygon (local frame).
    """
    lo, hi = min(0.0, stamps[0]), stamps[-1]
    knots, jumps = ref_knots(spec, lo, hi)
    T = np.unique(np.concatenate([stamps, knots, [lo, hi]]))

    def robot(t):
        return np.stack([np.interp(t, stamps, path[:, 0]), np.interp(t, stamps, path[:, 1])],
                        axis=1)

    def dist(rel):  # rel (n, 2): centre-to-shape distance (signed for a circle)
        if kind == "circle":
            return np.hypot(rel[:, 0], rel[:, 1]) - shape
        return shapely.distance(shapely.points(rel), shape)

    a = robot(T[:-1]) - ref_position(spec, T[:-1], "right")
    b = robot(T[1:]) - ref_position(spec, T[1:], "left")
    if kind == "circle":  # point (origin) to segment a-b, analytically
        d = b - a
        dd = np.einsum("ij,ij->i", d, d)
        s = np.clip(-np.einsum("ij,ij->i", a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
        q = a + s[:, None] * d
        exact = float(np.min(np.hypot(q[:, 0], q[:, 1]))) - shape
    else:
        segs = shapely.linestrings(np.stack([a, b], axis=1))
        exact = float(np.min(shapely.distance(segs, shape)))
    ts = np.unique(np.concatenate([np.linspace(lo, hi, N_DENSE), T]))
    dense = float(np.min(dist(robot(ts) - ref_position(spec, ts, "right"))))
    if len(jumps):
        jumps = jumps[(jumps >= lo) & (jumps <= hi)]
        dense = min(dense, float(np.min(dist(robot(jumps) - ref_position(spec, jumps, "left")),
                                        initial=np.inf)))
    v_robot = np.max(np.hypot(*np.diff(path, axis=0).T) / np.diff(stamps), initial=0.0)
    if spec.get("velocity") is not None:
        v_mover = float(np.hypot(*spec["velocity"]))
    elif len(spec["times"]) > 1:
        v_mover = float(np.max(np.hypot(*np.diff(spec["waypoints"], axis=0).T)
                               / np.diff(spec["times"])))
    else:
        v_mover = 0.0
    return exact, dense, (v_robot + v_mover) * (hi - lo) / (N_DENSE - 1)


# --------------------------------------------------------------------------------------
# random cases
# --------------------------------------------------------------------------------------

def _dyadic_times(rng: np.random.Generator, t0: float, gap_lo: float, gap_hi: float,
                  n: int) -> np.ndarray:
    gaps = np.maximum(np.round(rng.uniform(gap_lo, gap_hi, n - 1) / DY), 2) * DY
    return np.round(t0 / DY) * DY + np.r_[0.0, np.cumsum(gaps)]


def _mover(rng: np.random.Generator, branch: str) -> dict:
    """One random mover of ``branch`` (the motion model's branches and their corner cases)."""
    m = int(rng.integers(2, 6))
    wps = rng.uniform(-12.0, 12.0, (m, 2))
    after = branch if branch in ("hold", "loop", "bounce") else str(rng.choice(["loop", "bounce"]))
    if branch == "velocity":
        return {"waypoints": wps[:1], "velocity": rng.uniform(-2.0, 2.0, 2),
                "times": np.array([np.round(rng.uniform(-10.0, 10.0) / DY) * DY])}
    if branch == "single":
        return {"waypoints": wps[:1], "times": np.array([np.round(rng.uniform(-5, 5) / DY) * DY])}
    t0 = {"hold": (-5.0, 10.0), "late-start": (3.0, 15.0)}.get(branch, (-10.0, 3.0))
    gaps = {"many-periods": (0.1, 0.6), "short-period": (2 * DY, 0.3)}.get(branch, (0.5, 4.0))
    return {"waypoints": wps, "after": after,
            "times": _dyadic_times(rng, rng.uniform(*t0), *gaps, m)}


def _shape(rng: np.random.Generator) -> tuple[str, object, dict]:
    """A circle or a star-shaped (possibly non-convex) polygon, as (kind, reference shape,
    scenario keys)."""
    if rng.random() < 0.5:
        R = float(rng.uniform(0.5, 3.0))
        return "circle", R, {"type": "circle", "radius": R}
    k = int(rng.integers(3, 9))
    ang = np.sort(rng.uniform(0.0, 2 * np.pi, k))
    ang = ang + np.arange(k) * 1e-3  # distinct
    rad = rng.uniform(0.5, 3.0, k)
    v = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
    poly = shapely.Polygon(v)
    if not poly.is_valid or poly.area < 0.1:
        return _shape(rng)
    return "polygon", poly, {"type": "polygon", "vertices": v.tolist()}


def _robot(rng: np.random.Generator, branch: str) -> tuple[np.ndarray, np.ndarray]:
    n = int(rng.integers(2, 8))
    pts = rng.uniform(-12.0, 12.0, (n, 2))
    dt = rng.uniform(3.0, 6.0, n - 1) if branch == "short-period" else rng.uniform(0.3, 6.0, n - 1)
    t_first = 0.0 if rng.random() < 0.6 else float(rng.uniform(-3.0, 3.0))
    return pts, t_first + np.r_[0.0, np.cumsum(dt)]


def _problem(spec: dict, keys: dict, start, goal, r: float) -> op.Problem:
    dyn = {**keys, "waypoints": np.asarray(spec["waypoints"]).tolist(),
           "times": np.asarray(spec["times"]).tolist()}
    if spec.get("velocity") is not None:
        dyn["velocity"] = np.asarray(spec["velocity"]).tolist()
    if "after" in spec:
        dyn["after"] = spec["after"]
    return op.parse_problem({
        "name": "motion-case", "bounds": BOUNDS,
        "robots": [{"id": "r", "start": list(map(float, start)), "goal": list(map(float, goal)),
                    "radius": float(r), "max_speed": 10.0}],
        "dynamic_obstacles": [dyn]})


#: how far the robot's radius is set from the exact closest approach, relative to the radius:
#: r = d* / (1 + s), so the robot overlaps by -s r (s < 0) or clears by s r (s > 0)
MARGINS = (-0.14, -1e-3, -2e-5, 2e-5, 1e-3, 0.14, None)
BRANCHES = ("hold", "loop", "bounce", "velocity", "single", "late-start", "many-periods",
            "short-period")
N_CASES = 42


@pytest.mark.parametrize("branch", BRANCHES)
def test_validator_matches_the_dense_reference(branch: str) -> None:
    rng = np.random.default_rng([23, BRANCHES.index(branch)])
    decided = {"collide": 0, "free": 0}
    for case in range(N_CASES):
        spec = _mover(rng, branch)
        kind, shape, keys = _shape(rng)
        path, stamps = _robot(rng, branch)
        exact, dense, sample_bound = ref_gaps(spec, kind, shape, stamps, path)
        # the reference agrees with itself: the exact minimum is a lower bound of the samples
        # and the samples come within the sampling resolution of it
        assert exact <= dense + 1e-9 * L, (branch, case)
        assert dense <= exact + sample_bound + 1e-9 * L, (branch, case)
        s = MARGINS[case % len(MARGINS)]
        r = exact / (1.0 + s) if s is not None and 0.5 <= exact <= 12.0 else rng.uniform(0.5, 2.0)
        m = op.evaluate(_problem(spec, keys, path[0], path[-1], r), {"r": path}, stamps)
        flagged = m["dynamic_contacts"] > 0
        band = 1e-6 * r
        where = (branch, case, kind, spec.get("after"), s, exact - r)
        if dense - r < -band or exact - r < -band:
            assert flagged, where
            decided["collide"] += 1
            first = m["first_contact"]
            t = np.array([first["time"]])
            at = first["position"] - ref_position(spec, t)
            d_at = (np.hypot(*at[0]) - shape if kind == "circle"
                    else float(shapely.distance(shapely.Point(at[0]), shape)))
            assert d_at - r <= band, where  # the first contact is a real contact
        elif exact - r > band:
            assert not flagged, where
            decided["free"] += 1
        if exact > 0.0:  # centre outside the shape: the reported clearance is exact
            assert abs(m["min_clearance_dynamic"] - (exact - r)) <= 1e-9 * L + 1e-6 * r, where
    # every branch sees both outcomes, including the near-threshold ones
    assert decided["collide"] >= 4 and decided["free"] >= 4, decided


# --------------------------------------------------------------------------------------
# the motion model
# --------------------------------------------------------------------------------------

def _dyn(after: str, times=(0.0, 5.0, 10.0), wps=((0.0, 0.0), (10.0, 0.0), (10.0, 10.0))):
    p = op.parse_problem({
        "name": "dyn", "bounds": BOUNDS,
        "robots": [{"id": "r", "start": [30.0, 30.0], "goal": [35.0, 35.0], "radius": 1.0}],
        "dynamic_obstacles": [{"type": "circle", "radius": 1.0, "waypoints": [list(w) for w in wps],
                               "times": list(times), "after": after}]})
    return p.dynamic_obstacles[0]


@pytest.mark.parametrize("after", ["hold", "loop", "bounce"])
def test_position_follows_the_documented_model(after: str) -> None:
    spec = {"times": np.array([2.0, 7.0, 12.0]), "after": after,
            "waypoints": np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])}
    d = _dyn(after, spec["times"], spec["waypoints"])
    t = np.random.default_rng(5).uniform(-20.0, 80.0, 2000)
    t = np.concatenate([t, 2.0 + np.arange(-10, 32) * 2.5])  # every knot, period boundary
    np.testing.assert_allclose(d.position(t), ref_position(spec, t), atol=1e-12 * L)
    # before times[0] every branch waits at the first waypoint
    np.testing.assert_array_equal(d.position(np.array([-100.0, 0.0, 1.99])), np.zeros((3, 2)))


def test_loop_track_jumps_at_each_period_end() -> None:
    d = _dyn("loop")
    tk, pk = mover_track(d, -1.0, 30.0)
    for b in (10.0, 20.0):  # the period boundaries: twice, last waypoint then first
        k = np.flatnonzero(tk == b)
        assert len(k) >= 2
        np.testing.assert_array_equal(pk[k[0]], [10.0, 10.0])
        np.testing.assert_array_equal(pk[k[1]], [0.0, 0.0])
    np.testing.assert_array_equal(track_eval(tk, pk, [20.0], "left"), [[10.0, 10.0]])
    np.testing.assert_array_equal(track_eval(tk, pk, [20.0], "right"), [[0.0, 0.0]])
    np.testing.assert_array_equal(d.position(20.0), [0.0, 0.0])
    np.testing.assert_allclose(d.position(19.5), [10.0, 9.0])  # the last leg, not towards w0
    tb, _ = mover_track(_dyn("bounce"), -1.0, 30.0)
    assert np.all(np.diff(tb) >= 0)


def _parked(d_spec: dict, at, r: float, stamps=(0.0, 40.0)) -> dict:
    """Metrics of a robot parked at ``at`` for ``stamps`` next to a looping circle mover."""
    prob = op.parse_problem({
        "name": "parked", "bounds": BOUNDS,
        "robots": [{"id": "r", "start": list(at), "goal": [at[0] + 30.0, at[1]], "radius": r}],
        "dynamic_obstacles": [d_spec]})
    path = np.array([at, at], float)
    return op.evaluate(prob, {"r": path}, np.asarray(stamps, float))


_LOOP = {"type": "circle", "radius": 1.0, "waypoints": [[-10.0, 0.0], [-10.0, 10.0], [10.0, 10.0]],
         "times": [0.0, 5.0, 10.0], "after": "loop"}


def test_a_loop_jump_is_never_swept() -> None:
    # (0, 5) lies on the jump from (10, 10) back to (-10, 0), 5 from the mover's real path
    m = _parked(_LOOP, (0.0, 5.0), 0.5)
    assert m["dynamic_contacts"] == 0
    assert m["min_clearance_dynamic"] == pytest.approx(5.0 - 1.0 - 0.5, abs=1e-9 * L)


def test_before_times0_a_loop_waits_at_its_first_waypoint() -> None:
    m = _parked({**_LOOP, "times": [3.0, 8.0, 13.0]}, (-10.0, -1.9), 1.0, stamps=(0.0, 2.0))
    assert m["dynamic_contacts"] == 1
    assert m["first_contact"]["time"] == 0.0


def test_the_last_leg_of_a_loop_runs_to_the_last_waypoint() -> None:
    # last leg (-10, 10) -> (-10, 0) during [5, 10], then the jump to (10, 10): the robot,
    # 1.9 below the last waypoint, is touched at t = 9.95 and is deepest (0.1) just before t = 10
    m = _parked({**_LOOP, "waypoints": [[10.0, 10.0], [-10.0, 10.0], [-10.0, 0.0]]},
                (-10.0, -1.9), 1.0, stamps=(0.0, 10.0))
    assert m["dynamic_contacts"] == 1
    assert m["first_contact"]["time"] == pytest.approx(9.95, abs=1e-9 * L)  # eps / speed 2
    assert m["min_clearance_dynamic"] == pytest.approx(-0.1, abs=1e-9 * L)


def test_a_jump_onto_the_robot_is_caught_at_the_jump_time() -> None:
    # the robot waits beside w0 from t = 12; the mover is elsewhere until it jumps at t = 20
    spec = {**_LOOP, "waypoints": [[-10.0, 0.0], [10.0, 0.0], [10.0, 20.0]]}
    prob = op.parse_problem({
        "name": "jump", "bounds": BOUNDS,
        "robots": [{"id": "r", "start": [0.0, -30.0], "goal": [-10.0, -1.5], "radius": 1.0}],
        "dynamic_obstacles": [spec]})
    path = np.array([[0.0, -30.0], [-10.0, -1.5], [-10.0, -1.5]])
    m = op.evaluate(prob, {"r": path}, np.array([0.0, 12.0, 25.0]))
    assert m["dynamic_contacts"] == 1
    assert m["first_contact"]["time"] == 20.0


# --------------------------------------------------------------------------------------
# a reported scene: a looping mover 14 % of the robot's radius deep at t = 17.77 (was missed)
# --------------------------------------------------------------------------------------

def _report_scene(after: str) -> op.Problem:
    """Robot (radius 1, max_speed 1) from (10, 50) to (40, 50); a disc of radius 2 whose last
    leg (loop) or way back (bounce) passes 2.86 above the robot at t = 17.77, 2.23 s before
    the period boundary t = 20, moving horizontally: the deepest point, 0.14 r."""
    y = 52.86
    wps = ([[23.31, y], [33.31, y], [80.0, 90.0]] if after == "bounce"
           else [[80.0, 90.0], [33.31, y], [23.31, y]])
    return op.parse_problem({
        "name": f"loop-jump-{after}", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [40.0, 50.0], "radius": 1.0,
                    "max_speed": 1.0}],
        "dynamic_obstacles": [{"type": "circle", "radius": 2.0, "waypoints": wps,
                               "times": [0.0, 5.0, 10.0], "after": after}]})


@pytest.mark.parametrize("after", ["loop", "bounce"])
def test_report_scene_is_not_a_success(after: str) -> None:
    prob = _report_scene(after)
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.approximate, res.message  # what bounce gets; loop agrees
    assert res.metrics["dynamic_contacts"] == 1
    assert res.metrics["min_clearance_dynamic"] == pytest.approx(-0.14, abs=1e-9 * prob.extent)
    first = res.metrics["first_contact"]
    assert first["kind"] == "moving obstacle" and 15.0 < first["time"] < 17.77
    # the validator called directly on the straight path, timed at max_speed
    m = op.evaluate(prob, {"r": np.array([[10.0, 50.0], [40.0, 50.0]])})
    assert not m["feasible"] and m["dynamic_contacts"] == 1
    np.testing.assert_allclose(prob.dynamic_obstacles[0].position(17.77), [27.77, 52.86])
