"""Every extra of a time-stepping planner declares its unit (optplan.units), and the unit is right.

Every preset runs on a small scene with a moving obstacle, a formation and a temporary obstacle;
a preset whose backend runs the simulator must declare ``extras_units``, every extra it reports
must be declared there (an undeclared key raises), and on the same scene scaled by ``SCALE``
and shifted by ``SHIFT`` every declared value must transform by its unit: a length by the scale,
a point by the scale and the shift, a time and a dimensionless value not at all.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np
import pytest

import optplan as op
import optplan.sim
from optplan.problem import parse_problem, transform_problem
from optplan.units import Each, Record, UndeclaredUnit, Unit, convert, leaves, to_scale

#: a power of 4: scaling by it is exact in binary floating point, square roots included
SCALE = 4.0
SHIFT = (-300.0, 1000.0)
#: the shifted scene's last bits differ (translation is not exact), hence a tolerance
REL = 1e-6

SCENE = {
    "name": "units-scene", "bounds": [0.0, 0.0, 160.0, 160.0], "length_scale": 1.0,
    "goal_tolerance": 1.0,
    "robots": [
        {"id": "leader", "start": [30.0, 30.0], "goal": [130.0, 120.0], "radius": 2.0,
         "max_speed": 4.0},
        {"id": "f1", "start": [10.0, 40.0], "radius": 2.0, "max_speed": 4.0},
        {"id": "f2", "start": [40.0, 10.0], "radius": 2.0, "max_speed": 4.0},
    ],
    "formation": {"leader": "leader", "safety_distance": 6.0, "followers": [
        {"id": "f1", "L": 15.0, "phi": math.pi / 4}, {"id": "f2", "L": 15.0, "phi": -math.pi / 4}]},
    "obstacles": [
        {"type": "polygon", "name": "block",
         "vertices": [[70.0, 55.0], [85.0, 55.0], [85.0, 70.0], [70.0, 70.0]]},
        {"type": "circle", "name": "temporary", "center": [100.0, 95.0], "radius": 4.0,
         "known": False},
    ],
    "dynamic_obstacles": [
        {"type": "circle", "name": "crosser", "radius": 4.0,
         "waypoints": [[140.0, 40.0], [40.0, 140.0]], "times": [0.0, 10.0],
         "after": "bounce"}],
}


def test_convert_maps_every_declared_unit() -> None:
    spec = Record({"p": Unit.POINT, "n": Unit.DIMENSIONLESS,
                   "per": Each(Record({"d": Unit.LENGTH, "why": Unit.TEXT}))})
    value = {"p": np.array([[1.0, 2.0]]), "n": 3, "per": {"a": {"d": 2.0, "why": "x"}}}
    out = to_scale(value, spec, 10.0)
    assert np.array_equal(out["p"], [[10.0, 20.0]]) and out["n"] == 3
    assert out["per"] == {"a": {"d": 20.0, "why": "x"}}
    assert sorted(n for n, _, _ in leaves(value, spec)) == [
        "extras['n']", "extras['p']", "extras['per']['a']['d']", "extras['per']['a']['why']"]


def test_an_undeclared_key_raises() -> None:
    spec = Record({"a": Unit.LENGTH, "sub": Record({"b": Unit.TIME})})
    with pytest.raises(UndeclaredUnit, match="'new'"):
        to_scale({"a": 1.0, "new": 2.0}, spec, 2.0)
    with pytest.raises(UndeclaredUnit, match=r"extras\['sub'\].*'c'"):
        list(leaves({"sub": {"b": 1.0, "c": 2.0}}, spec))
    with pytest.raises(TypeError, match="Record or Each"):
        convert({"a": {"x": 1.0}}, spec, lambda u, p: p)
    assert to_scale({"a": None}, spec, 2.0) == {"a": None}  # a declared key may be None


def test_records_merge_only_when_they_agree() -> None:
    a, b = Record({"x": Unit.LENGTH}), Record({"y": Unit.TIME})
    assert (a | b).fields == {"x": Unit.LENGTH, "y": Unit.TIME}
    with pytest.raises(ValueError, match="two different units"):
        a | Record({"x": Unit.TIME})


def _spy_simulate(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Count the simulator's runs (every run starts with ``_start_positions``)."""
    calls: list[int] = []
    real = optplan.sim._start_positions

    def spy(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(optplan.sim, "_start_positions", spy)
    return calls


@cache
def _scene(scale: float, shift: tuple[float, float]) -> op.Problem:
    return transform_problem(parse_problem(SCENE, "units-scene"), scale, shift)


def _check_unit(name: str, unit: Unit, a: Any, b: Any) -> None:
    """``b`` (the transformed scene's value) is ``a`` transformed by ``unit``."""
    if unit in (Unit.TEXT, Unit.WALL_TIME):
        return
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if unit is Unit.LENGTH:
        a = a * SCALE
    elif unit is Unit.POINT:
        a = (a.reshape(-1, 2) * SCALE + np.asarray(SHIFT)).reshape(a.shape)
    size = SCALE * 200.0 if unit.scales else 1.0
    assert a.shape == b.shape, f"{name}: shape {b.shape}, expected {a.shape}"
    assert np.allclose(b, a, rtol=REL, atol=REL * size, equal_nan=True), (
        f"{name} ({unit.value}): {b.ravel()[:4]}, expected {a.ravel()[:4]}")


#: options of the presets too slow as they are here (the same extras: fewer NLP steps and
#: IPOPT iterations; the units, not the optimum, are under test)
FAST_OPTIONS = {"formation-nlp": {"n_steps": 20, "max_iter": 60}}


@pytest.mark.parametrize("solver", op.list_solvers())
def test_every_extra_declares_its_unit(solver: str, monkeypatch: pytest.MonkeyPatch) -> None:
    runs = _spy_simulate(monkeypatch)
    backend = op.get_solver(solver)
    fast = FAST_OPTIONS.get(solver, {})
    # a callback: the hybrid maps its stages' Progress.info back by their declared units too
    base = op.solve(_scene(1.0, (0.0, 0.0)), backend, rng=0, reference=False,
                    callback=lambda p: None, **fast)
    if not runs:
        pytest.skip(f"{solver} does not step in time")
    spec = getattr(backend, "extras_units", None)
    assert isinstance(spec, Record), f"{solver}: a time-stepping backend declares extras_units"
    moved = op.solve(_scene(SCALE, SHIFT), backend, rng=0, reference=False, **fast)
    assert moved.status == base.status
    a = {n: (u, v) for n, u, v in leaves(base.extras, spec)}
    b = {n: (u, v) for n, u, v in leaves(moved.extras, spec)}
    assert set(a) == set(b)
    for name, (unit, value) in a.items():
        _check_unit(f"{solver} {name}", unit, value, b[name][1])
