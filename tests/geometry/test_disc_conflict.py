"""Closed-form contact of two discs on timed motions (``ccbs``'s conflicts), hand-derived."""

from __future__ import annotations

import math

import numpy as np
import pytest

from optplan.geometry.timing.disc_conflict import TimedMotion, contact_interval, unsafe_interval


def _m(a, b, t0, t1) -> TimedMotion:
    return TimedMotion(tuple(map(float, a)), tuple(map(float, b)), float(t0), float(t1))


def test_two_discs_crossing():
    """Centres at (t - 2, 0) and (0, t - 2): distance sqrt(2) |t - 2| < 1."""
    hit = contact_interval(_m((-2, 0), (2, 0), 0, 4), _m((0, -2), (0, 2), 0, 4), 1.0)
    assert hit == pytest.approx((2 - math.sqrt(0.5), 2 + math.sqrt(0.5)), rel=1e-12)


def test_head_on_on_the_same_segment():
    """Distance |2t - 4| < 1 on (1.5, 2.5)."""
    hit = contact_interval(_m((0, 0), (4, 0), 0, 4), _m((4, 0), (0, 0), 0, 4), 1.0)
    assert hit == pytest.approx((1.5, 2.5), rel=1e-12)


def test_a_disc_waiting_on_the_path():
    """A disc held for ever at (2, 0.5): distance sqrt((t - 2)^2 + 0.25) < 1."""
    hold = _m((2, 0.5), (2, 0.5), 0, math.inf)
    hit = contact_interval(_m((0, 0), (4, 0), 0, 4), hold, 1.0)
    half = math.sqrt(0.75)
    assert hit == pytest.approx((2 - half, 2 + half), rel=1e-12)


def test_touching_is_allowed():
    """Passing at exactly the contact distance is no contact; a hair closer is."""
    move = _m((0, 0), (4, 0), 0, 4)
    assert contact_interval(move, _m((2, 1), (2, 1), 0, math.inf), 1.0) is None
    assert contact_interval(move, _m((2, 1 - 1e-9), (2, 1 - 1e-9), 0, math.inf), 1.0)


def test_no_common_window_no_contact():
    assert contact_interval(_m((0, 0), (1, 0), 0, 1), _m((0, 0), (1, 0), 2, 3), 1.0) is None


def test_unsafe_starts_against_a_hold_and_a_finite_wait():
    """A move (0,0) -> (4,0) of 4 s started at s is within 1 of (2, 0.5) for t - s in
    (2 - sqrt(0.75), 2 + sqrt(0.75)); the wait from t = 0 (for ever, or until 10)."""
    move = _m((0, 0), (4, 0), 0, 4)
    half = math.sqrt(0.75)
    lo, hi = unsafe_interval(move, _m((2, 0.5), (2, 0.5), 0, math.inf), 1.0)
    assert lo == pytest.approx(-2 - half, rel=1e-12) and hi == math.inf
    lo, hi = unsafe_interval(move, _m((2, 0.5), (2, 0.5), 0, 10), 1.0)
    assert (lo, hi) == pytest.approx((-2 - half, 10 - 2 + half), rel=1e-12)


def test_unsafe_starts_head_on():
    """Head-on on one segment: every start whose window meets the other's collides."""
    lo, hi = unsafe_interval(_m((0, 0), (4, 0), 0, 4), _m((4, 0), (0, 0), 0, 4), 1.0)
    assert (lo, hi) == pytest.approx((-4, 4), rel=1e-12)


def test_unsafe_starts_crossing():
    """Crossing at right angles (the move of ``test_two_discs_crossing`` started at s): the
    relative position (t - s - 2, 2 - t), distance^2 minimised over t at t = 2 + s / 2, where it
    is s^2 / 2: unsafe for |s| < sqrt(2)."""
    lo, hi = unsafe_interval(_m((-2, 0), (2, 0), 0, 4), _m((0, -2), (0, 2), 0, 4), 1.0)
    assert (lo, hi) == pytest.approx((-math.sqrt(2), math.sqrt(2)), rel=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_unsafe_interval_is_the_set_of_colliding_starts(seed):
    """Against :func:`contact_interval` on a grid of start times (random motions)."""
    rng = np.random.default_rng(seed)
    a, b, c, d = rng.uniform(-3, 3, (4, 2))
    dur, t1 = rng.uniform(0.5, 4.0, 2)
    wait = seed % 3 == 0
    fixed = _m(c, c if wait else d, 0.0, math.inf if seed % 2 == 0 and wait else t1)
    moving = _m(a, b, 0.0, dur)
    radius = 1.5
    hit = unsafe_interval(moving, fixed, radius)
    for s in np.linspace(-10, 10, 801):
        m = _m(a, b, s, s + dur)
        inside = contact_interval(m, fixed, radius) is not None
        if hit is not None and min(abs(s - hit[0]), abs(s - hit[1])) < 1e-6:
            continue
        assert inside == (hit is not None and hit[0] < s < hit[1]), (s, hit)


def _sampled_contact(p: TimedMotion, q: TimedMotion, radius: float, n: int = 20001):
    """The first and last sampled time at which the centres are closer than ``radius``
    (dense sampling of the common window, the far end of a hold cut at 50 s)."""
    lo, hi = max(p.t0, q.t0), min(p.t1, q.t1, 50.0)
    if not hi > lo:
        return None
    t = np.linspace(lo, hi, n)

    def at(m: TimedMotion) -> np.ndarray:
        if m.a == m.b:
            return np.tile(m.a, (n, 1))
        f = ((t - m.t0) / (m.t1 - m.t0))[:, None]
        return np.asarray(m.a) + f * (np.asarray(m.b) - np.asarray(m.a))

    inside = np.hypot(*(at(p) - at(q)).T) < radius
    return (t[inside][0], t[inside][-1], t[1] - t[0]) if inside.any() else None


@pytest.mark.parametrize("seed", range(4))
def test_contact_intervals_against_dense_sampling(seed):
    """The vectorised contact, row by row, against dense sampling of random moves, waits
    and holds (the scalar :func:`contact_interval` is its one-row call)."""
    from optplan.geometry.timing.disc_conflict import TimedMotions, contact_intervals

    rng = np.random.default_rng(100 + seed)
    ps, qs = [], []
    for _ in range(60):
        pair = []
        for kind in rng.integers(0, 3, 2):
            a, b = rng.uniform(-3, 3, (2, 2))
            t0 = rng.uniform(0, 4)
            t1 = math.inf if kind == 2 else t0 + rng.uniform(0.5, 6)
            pair.append(_m(a, a if kind else b, t0, t1))
        ps.append(pair[0])
        qs.append(pair[1])
    start, end = contact_intervals(TimedMotions.of(ps), TimedMotions.of(qs), 1.2)
    hits = 0
    for p, q, s, e in zip(ps, qs, start, end):
        ref = _sampled_contact(p, q, 1.2)
        one = contact_interval(p, q, 1.2)
        assert (one is None) == np.isnan(s) and (one is None or one == (s, e))
        if ref is None:  # no sample inside: at most a sliver between two samples
            assert np.isnan(s) or min(e, 50.0) - s < 1e-2
            continue
        hits += 1
        assert s == pytest.approx(ref[0], abs=ref[2]) and min(e, 50.0) == pytest.approx(
            ref[1], abs=ref[2])
    assert hits >= 5
