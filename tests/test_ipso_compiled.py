"""The compiled IPSO step (optplan.backends.ipso_compiled) is a bit-identical twin of the numpy
step: same random draws, same floating-point operations."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.backends import ipso as ip
from optplan.backends import ipso_compiled as ipc
from optplan.backends import swarm as sw

pytest.importorskip("numba")


def _state(backend: ip.IPSO, space: sw.SwarmSpace, seed: int, spread: float):
    """A mid-run swarm: random positions (some near the bounds), velocities large enough to
    leave the map (``spread`` x the range: > 1 also exercises the triangle wave)."""
    rng = np.random.default_rng(seed)
    P, D = backend.n_particles, space.dim
    X = space.lo + space.span * rng.random((P, D))
    X[: P // 5] = np.where(rng.random((P // 5, D)) < 0.5, space.lo, space.hi)  # on a bound
    V = spread * space.span * rng.standard_normal((P, D))
    st = sw.new_state(X, V, sw.evaluate_swarm(X, space))
    st.pbest += 0.1 * space.span * rng.standard_normal((P, D))
    st.F += rng.integers(0, 3, P) * 1000.0  # ties and ranks
    st.stats["engine"] = "numba"
    backend._start(space, st, rng)
    return st


def _numpy_step(b: ip.IPSO, space, st, w, k, rng, B):
    P = len(st.F)
    m, CV, isl = b._children(space, st, k, rng, B[P:])
    X, V = b._move(space, st, w, k, rng, out=B[:P])
    out = sw.bound_positions(B[:P + m], space.lo, space.hi, b.bounds_mode, rng)
    if out is not None:
        V = sw.bounce_velocity(V, out[:P], b.bounds_mode)
    return m, CV, isl, V


OPTIONS = [
    {},
    {"bounds_mode": "clip"},
    {"v_max": math.inf},
    {"position_update": "step"},
    {"islands": 5, "crossover_tol": math.inf},
    {"islands": 2, "A": 8, "crossover_tol": 0.2},
    {"A": 0},
]


@pytest.mark.parametrize("opts", OPTIONS, ids=[str(o) for o in OPTIONS])
@pytest.mark.parametrize("spread", [0.05, 3.0])
def test_compiled_step_is_bit_identical_to_numpy(opts, spread):
    prob = op.load_problem("paper-env1")
    b = ip.IPSO(**{"n_particles": 50, "k_max": 200, "A": 10, **opts})
    space = sw.make_space(prob.known_view(), prob.robots[0], 6)
    for seed in range(4):
        st = _state(b, space, seed, spread)
        k = 17 * seed
        w = 0.4 + 0.1 * seed
        B1 = sw.PathBuffer(space, 50 + 2 * b.A).X(0)
        B2 = sw.PathBuffer(space, 50 + 2 * b.A).X(0)
        r1, r2 = np.random.default_rng(seed), np.random.default_rng(seed)
        m1, CV1, isl1, V1 = _numpy_step(b, space, st, w, k, r1, B1)
        m2, CV2, isl2, V2 = b._step_compiled(space, st, w, k, r2, B2)
        assert m1 == m2
        n = 50 + 2 * m1
        np.testing.assert_array_equal(B1[:n], B2[:n])
        np.testing.assert_array_equal(V1, V2)
        if m1:
            np.testing.assert_array_equal(CV1, CV2)
        assert (isl1 is None) == (isl2 is None)
        if isl1 is not None:
            np.testing.assert_array_equal(isl1, isl2)
        # both consumed the generator identically
        assert r1.random() == r2.random()
        # and every coordinate is inside the map
        assert np.all((B2[:n] >= space.lo) & (B2[:n] <= space.hi))


@pytest.mark.parametrize("scene", ["paper-env1", "paper-env2"])
def test_whole_ipso_paper_runs_agree_between_engines(scene, monkeypatch):
    """ipso-paper end to end: numpy engine vs numba engine (kernel and step)."""
    runs = {}
    for engine in ("numpy", "numba"):
        monkeypatch.setenv("OPTPLAN_ENGINE", engine)
        runs[engine] = [op.solve(scene, "ipso-paper", rng=s, k_max=60) for s in range(3)]
    for a, b in zip(runs["numpy"], runs["numba"], strict=True):
        assert a.extras["per_robot"]["r1"]["engine"] == "numpy"
        assert b.extras["per_robot"]["r1"]["engine"] == "numba"
        np.testing.assert_array_equal(a.paths["r1"], b.paths["r1"])
        np.testing.assert_array_equal(np.asarray(a.history["best_cost"]),
                                      np.asarray(b.history["best_cost"]))


def test_python_fallback_of_the_compiled_functions_matches():
    """Without numba the same functions run as plain Python (the ``py_func`` here)."""
    rng = np.random.default_rng(3)
    F = rng.integers(0, 4, 20).astype(float)
    X = rng.random((20, 6))
    fast = ipc.select_pairs(F, X, 6, 2, 0.05)
    slow = ipc.select_pairs.py_func(F, X, 6, 2, 0.05)
    for a, b in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(a, b)


def test_engine_is_recorded(monkeypatch):
    monkeypatch.setenv("OPTPLAN_ENGINE", "numpy")
    res = op.solve("open-field", "ipso-paper", rng=0, k_max=3)
    assert res.extras["per_robot"]["r1"]["engine"] == "numpy"
    # an explicit option wins over the environment variable (which only redefines "auto")
    res = op.solve("open-field", "ipso-paper", rng=0, k_max=3, engine="numba")
    assert res.extras["per_robot"]["r1"]["engine"] == "numba"


@pytest.mark.parametrize("opts", [{}, {"islands": 5, "A": 10}, {"islands": 2, "A": 8}],
                         ids=["global", "5 islands", "2 islands"])
def test_compiled_absorb_is_bit_identical_to_numpy(opts):
    """Personal bests, eq 29 and the replacement of the worst particles."""
    prob = op.load_problem("paper-env1")
    b = ip.IPSO(**{"n_particles": 50, "k_max": 200, **opts})
    space = sw.make_space(prob.known_view(), prob.robots[0], 6)
    for seed in range(5):
        st1 = _state(b, space, seed, 0.05)
        st2 = _state(b, space, seed, 0.05)
        rng = np.random.default_rng(100 + seed)
        m = b.A if seed % 2 else 4
        B = space.lo + space.span * rng.random((50 + 2 * m, space.dim))
        cost = rng.integers(0, 6, len(B)) * 100.0 + rng.random(len(B))  # ties in F
        CV = rng.standard_normal((m, space.dim))
        isl = (np.sort(rng.integers(0, b._n_islands, m // 2)).repeat(1)
               if b._n_islands > 1 else None)
        if isl is not None:
            isl = np.concatenate([isl, isl])
        X1, V1 = B[:50].copy(), st1.V.copy()
        X2, V2 = B[:50].copy(), st2.V.copy()
        F1, k1 = b._absorb(st1, X1, V1, cost, B, m, CV, isl)
        F2, k2 = b._absorb_compiled(st2, X2, V2, cost, B, m, CV, isl)
        assert k1 == k2
        for a1, a2 in [(F1, F2), (X1, X2), (V1, V2), (st1.pbest, st2.pbest),
                       (st1.pbest_f, st2.pbest_f)]:
            np.testing.assert_array_equal(a1, a2)
        # the replaced slots hold children or mutants, with their own cost
        assert np.isin(F1, cost).all()


@pytest.mark.parametrize("scene", ["paper-env1", "paper-hybrid"])
def test_whole_ipso_variant_runs_agree_between_engines(scene, monkeypatch):
    """The documented variant (penetration term, snap moves onto corners, islands,
    tightening) puts waypoints within ~1e-6 of the collision threshold: the engines must still
    take the same decisions."""
    runs = {}
    for engine in ("numpy", "numba"):
        monkeypatch.setenv("OPTPLAN_ENGINE", engine)
        runs[engine] = op.solve(scene, "ipso", rng=1, k_max=120)
    a, b = runs["numpy"], runs["numba"]
    np.testing.assert_array_equal(a.paths["r1"], b.paths["r1"])
    np.testing.assert_array_equal(np.asarray(a.history["best_cost"]),
                                  np.asarray(b.history["best_cost"]))
