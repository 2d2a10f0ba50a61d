"""The **init** family: bad (and odd but valid) initial guesses for every preset, and their
runner."""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error, _compare
from benchmarks.fuzz.core import SOLVE_TIME_LIMIT, Case, Outcome
from benchmarks.fuzz.options import option_scene, preset_table
from benchmarks.fuzz.values import catalogue


def init_cases(presets: dict[str, tuple[str, dict]] | None = None, seed: int = 0) -> list[Case]:
    """Bad (and odd but valid) initial guesses for every preset."""
    import numpy as np

    presets = presets or preset_table()
    rng = random.Random(seed)
    out = []
    n = 0
    for name, (backend, opts) in presets.items():
        scene = option_scene(backend, opts)
        sd = catalogue()[scene]
        lead = sd.get("formation", {}).get("leader") or sd["robots"][0]["id"]
        r0 = next(r for r in sd["robots"] if r["id"] == lead)
        s, g = np.array(r0["start"], float), np.array(r0["goal"], float)
        line = np.linspace(s, g, 6)
        variants: list[tuple[str, Any, bool]] = [
            ("nan", np.where(np.arange(12).reshape(6, 2) == 5, np.nan, line), True),
            ("inf", np.where(np.arange(12).reshape(6, 2) == 4, np.inf, line), True),
            ("-inf", np.where(np.arange(12).reshape(6, 2) == 7, -np.inf, line), True),
            ("1e300", line * 1e300, True), ("-1e300", line * -1e300, True),
            ("1e200 waypoint", np.vstack([line[:3], [[1e200, 0.0]], line[3:]]), True),
            ("empty", np.zeros((0, 2)), True), ("flat", line.ravel(), True),
            ("(4, 3)", np.ones((4, 3)), True), ("(6, 2, 1)", line[..., None], True),
            ("scalar", 3.0, True), ("string", "straight", True),
            ("list of strings", [["a", "b"]], True), ("ragged", [[1.0, 2.0], [3.0]], True),
            ("unknown robot", {"nobody": line}, True),
            ("dict of strings", {lead: "line"}, True),
            ("too many points", np.zeros((100_001, 2)), True),
            ("bool array", np.ones((4, 2), dtype=bool), False),
            ("single point", line[:1], False), ("outside bounds", line + 1e4, False),
            ("through obstacles", line, False), ("reversed", line[::-1], False),
            ("huge but finite", line * 1e9, True), ("integer list", line.astype(int).tolist(),
                                                    False),
            ("object array", np.array([[1.0, None]], dtype=object), True),
            ("complex", line.astype(complex) * 1j, True),
        ]
        rng.shuffle(variants)
        for what, value, must in variants:
            n += 1
            out.append(Case("init", f"init/{n:04d}/{name}/{what}", what,
                            {"preset": name, "backend": backend, "scene": scene,
                             "value": value}, ("init",), must))
    return out


def run_init(case: Case, tmp: Path) -> Outcome:
    import optplan as op

    d = case.data
    try:
        res = op.solve(d["scene"], d["preset"], rng=0, time_limit=SOLVE_TIME_LIMIT,
                       init=d["value"])
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, None)
        return Outcome(case, cat, det)
    if case.must_reject:
        return Outcome(case, "silently accepted", f"accepted ({res.status})")
    prob = op.load_problem(d["scene"])
    if prob.formation:
        return Outcome(case, "accepted and solved", str(res.status))
    return _compare(case, prob, res)
