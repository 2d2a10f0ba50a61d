"""Bad input never crashes, never hangs, never lies -- a bounded, seeded slice of the
input fuzz of the package ``benchmarks/fuzz/`` (the full run is ``python
benchmarks/fuzz_inputs.py``: >= 3,000 scenarios, >= 2,500 option values, >= 200 inits, >= 50
result files, and its counts table), with every map, results-database, ROS path message,
``crop=``, ``.scen`` and Planner Arena export case and a seeded sample of the plugin cases.

Every case runs in a worker process with a CPU-time limit (and a stall limit for a case blocked
forever; no wall-clock limit a loaded machine could reach: the workers start with a readiness
handshake and no deadline of their own); the slice must show no crash, no hang, no unclear
message, no silent acceptance of an out-of-range value and no success the independent shapely
check contradicts.  Outcomes explained by a finding in code this suite does not own
(``KNOWN_FINDINGS`` of ``benchmarks/fuzz/report.py``) are not counted, and every listed
finding must still reproduce in the slice: a stale entry fails the test, naming the entry to
remove.
"""

from __future__ import annotations

import random
import sys
from pathlib import Path

import numpy as np
import pytest

import optplan as op
from benchmarks import fuzz as fz
from benchmarks.fuzz import checks, report

ROOT = Path(__file__).resolve().parents[2]

SEED = 14
#: the slice: scenario mutations (small scenes), option values, inits, result files
N_SCENARIOS, N_OPTIONS, N_INITS, N_RESULTS = 200, 200, 40, 40
#: plugin cases sampled (each runs a fresh process, ~1 s; tests/core/test_plugins.py covers
#: the mechanism, the full run of benchmarks/fuzz_inputs.py every case)
N_PLUGINS = 6
SMALL_SCENES = ("open-field", "trap-u", "trap-gnron", "trap-saddle", "trap-channel",
                "paper-env1", "paper-env2", "paper-apf-env1", "paper-apf-env2",
                "paper-formation", "formation-open-field", "paper-hybrid", "paper-warehouse")


def _slice() -> list[fz.Case]:
    rng = random.Random(SEED)
    cases = fz.ScenarioFuzzer(SEED).cases(N_SCENARIOS, SMALL_SCENES)
    presets = fz.preset_table()
    opts = fz.OptionFuzzer(SEED).cases(presets)
    # every preset, then a random sample (cheap rejections and accepted values alike)
    by_preset: dict[str, list[fz.Case]] = {}
    for c in opts:
        by_preset.setdefault(c.data["preset"], []).append(c)
    pick = [rng.choice(v) for v in by_preset.values()]
    rest = [c for c in opts if c not in pick]
    cases += pick + rng.sample(rest, N_OPTIONS - len(pick))
    cases += rng.sample(fz.init_cases(presets, SEED), N_INITS)
    cases += rng.sample(fz.result_cases(SEED, n_random=12), N_RESULTS)
    cases += fz.map_cases(SEED) + fz.database_cases(SEED)
    cases += rng.sample(fz.plugin_cases(), N_PLUGINS)
    # every case of the ROS path message, crop=, .scen and Planner Arena export families
    cases += fz.surface_cases(SEED)
    return cases


@pytest.fixture(scope="module")
def outcomes() -> list[fz.Outcome]:
    return fz.annotate(fz.run_cases(_slice(), workers=2))


def _report(bad: list[fz.Outcome]) -> str:
    return "\n".join(f"{o.category}: {o.case.id} ({o.case.what}; {o.case.data.get('note', '')})"
                     f": {o.detail[:300]}" for o in bad)


@pytest.mark.parametrize("family", fz.FAMILIES)
def test_slice_has_no_crash_hang_unclear_message_or_lie(outcomes, family):
    sel = [o for o in outcomes if o.case.family == family]
    assert sel, f"the slice has no {family} cases"
    bad = [o for o in fz.failures(sel) if o.case.family == family]
    assert not bad, f"{len(bad)} new bad outcome(s):\n" + _report(bad)
    # most inputs are bad: the slice must really exercise the validation
    clear = sum(o.category == "clear error" for o in sel)
    assert clear >= len(sel) // 3, fz.counts_table(outcomes)


def test_slice_solves_accepted_scenarios_and_checks_them(outcomes):
    sc = [o for o in outcomes if o.case.family == "scenario"]
    solved = [o for o in sc if o.category == "accepted and solved"]
    assert len(solved) >= 10 and all(o.compared for o in solved)


def test_every_known_finding_still_reproduces(outcomes):
    """Strict: a KNOWN_FINDINGS entry that explains no outcome of the slice is stale (the
    finding was fixed) and must be removed, so a stale entry cannot hide a new bug."""
    stale = fz.stale_findings(outcomes)
    assert not stale, (f"KNOWN_FINDINGS entries that no longer reproduce in the slice: {stale}; "
                       "remove them from benchmarks/fuzz/report.py (KNOWN_FINDINGS)")


def test_stale_findings_are_reported(monkeypatch):
    o = fz.Outcome(fz.Case("selftest", "selftest/x", "x", {}), "hang", "d")
    monkeypatch.setattr(report, "KNOWN_FINDINGS", {
        "fixed": ("somewhere", "no longer happens", lambda o: False),
        "live": ("elsewhere", "still happens", lambda o: o.category == "hang")})
    assert fz.stale_findings(fz.annotate([o])) == ["fixed"]
    assert o.known == "live" and fz.failures([o]) == []


def test_full_run_sizes():
    """The full run's option, init and result families reach their documented sizes (the
    scenario count is a parameter: 3,000 by default)."""
    presets = fz.preset_table()
    assert len(fz.OptionFuzzer(0).cases(presets)) >= 2500
    assert len(fz.init_cases(presets)) >= 200
    assert len(fz.result_cases(0)) >= 50
    assert len(fz.map_cases(0)) >= 100 and len(fz.database_cases(0)) >= 25
    assert len(fz.plugin_cases()) >= 15
    assert len(fz.path_cases(0)) >= 50 and len(fz.crop_cases()) >= 30
    assert len(fz.scen_cases()) >= 30 and len(fz.arena_cases()) >= 15
    assert len(fz.ScenarioFuzzer(0).cases(200, ["open-field", "trap-u"])) == 200


# -- the harness itself --------------------------------------------------------------------


def test_harness_classifies_hangs_crashes_and_messages():
    mk = fz.Case
    cases = [
        mk("selftest", "selftest/spin", "spin", {"spin": 30.0}),
        mk("selftest", "selftest/sleep", "sleep", {"sleep": 30.0}),
        mk("selftest", "selftest/crash", "crash", {"raise": "TypeError"}),
        mk("selftest", "selftest/clear", "clear", {"raise": "ValueError",
                                                   "message": "f.toml: robots[0].goal: bad"},
           ("robots[0].goal",)),
        mk("selftest", "selftest/unclear", "unclear", {"raise": "ValueError",
                                                       "message": "cannot reshape array"},
           ("robots[0].goal",)),
        mk("selftest", "selftest/ok", "ok", {}),
    ]
    # a hang is 1 s of CPU (a computing case), or 5 s without any CPU time (a blocked one:
    # however loaded the machine, a runnable worker gets some CPU time in 5 s); the other
    # self-test cases return at once
    outs = fz.run_cases(cases, workers=1, hang_s=1.0, stall_s=5.0)
    got = {o.case.what: o.category for o in outs}
    assert got == {"spin": "hang", "sleep": "hang", "crash": "crash", "clear": "clear error",
                   "unclear": "unclear message", "ok": "accepted and solved"}
    detail = {o.case.what: o.detail for o in outs}
    assert "after 1 CPU s" in detail["spin"] and "blocked" in detail["sleep"], detail


@pytest.mark.parametrize("script, message", [
    ("echo broken import >&2; exit 3", r"exited before it was ready \(exit 3\).*broken import"),
    ("echo waiting >&2; exec sleep 600", "used no CPU for .* without becoming ready.*waiting")])
def test_a_worker_that_cannot_start_is_reported_not_waited_for(monkeypatch, tmp_path, script,
                                                                message):
    """No start-up deadline: a worker is used once it says it is ready; one that dies first,
    or is blocked (no CPU time for the stall limit), is an error of the fuzz setup showing its
    log (not a replacement loop, not a wait for ever)."""
    fake = tmp_path / "python"
    fake.write_text(f"#!/bin/sh\n{script}\n")
    fake.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(fake))
    case = fz.Case("selftest", "selftest/ok", "ok", {})
    with pytest.raises(RuntimeError, match=f"(?s){message}"):
        fz.run_cases([case], workers=1, log_dir=tmp_path / "logs", stall_s=1.0)


def test_message_key_matching():
    ok = checks._message_ok
    assert ok("f.toml: obstacles[2].vertices[1][0]: bad", ("obstacles[2].vertices",), "f.toml")[0]
    assert ok("f.toml: obstacles[2]: bad", ("obstacles[2]",), "f.toml")[0]
    assert not ok("f.toml: obstacles[2]: bad", ("obstacles[2].vertices",), "f.toml")[0]
    assert not ok("f.toml: dynamic_obstacles[0].name: x", ("obstacles[0]",), "f.toml")[0]
    assert not ok("f.toml: obstacles[0].name: x", ("name",), "f.toml")[0]
    assert not ok("robots[1].goal: missing", ("formation.followers",), None)[0]
    assert not ok("g.toml: name: x", ("name",), "f.toml")[0]
    assert ok("override: option 'c1' of backend 'ipso' must be ...", ("c1",), None)[0]
    assert not ok("x: " + "v" * 2000, (), None)[0]


def _scene(obstacles, radius=1.0):
    return op.parse_problem({
        "name": "t", "bounds": [0.0, 0.0, 100.0, 100.0], "obstacles": obstacles,
        "robots": [{"id": "r", "start": [10.0, 50.0], "goal": [90.0, 50.0], "radius": radius}]})


def test_independent_check():
    p = _scene([{"type": "circle", "center": [50.0, 50.0], "radius": 10.0}])
    through = {"r": np.array([[10.0, 50.0], [90.0, 50.0]])}
    assert fz.independent_check(p, through) == (False, "r: hits circle 'obstacle0' "
                                                       "(distance -10)")
    # exactly tangent to the inflated circle (distance r = 1 from the disc of radius 10)
    above = {"r": np.array([[10.0, 50.0], [10.0, 61.0], [90.0, 61.0], [90.0, 50.0]])}
    assert fz.independent_check(p, above)[0]
    assert not fz.independent_check(p, {"r": above["r"] - [0.0, 1e-6]})[0]
    assert not fz.independent_check(p, {"r": above["r"][:-1]})[0]  # goal not reached
    assert not fz.independent_check(p, {"r": above["r"][1:]})[0]  # not from the start
    res = op.solve(p, "visgraph")
    assert res.success and fz.independent_check(p, res.paths)[0]
    # a point robot may touch a polygon but not enter it
    sq = [{"type": "polygon", "vertices": [[40.0, 40.0], [60.0, 40.0], [60.0, 60.0],
                                          [40.0, 60.0]]}]
    q = _scene(sq, radius=0.0)
    touch = {"r": np.array([[10.0, 50.0], [40.0, 60.0], [60.0, 60.0], [90.0, 50.0]])}
    assert fz.independent_check(q, touch)[0]
    assert not fz.independent_check(q, {"r": touch["r"] - [0.0, 1e-3]})[0]


def test_toml_writer_round_trips_the_catalogue():
    import tomllib

    for name, d in fz.catalogue().items():
        assert tomllib.loads(fz.toml_dumps(d)) == d, name
