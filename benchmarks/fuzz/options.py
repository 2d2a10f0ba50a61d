"""The **option** family: bad values for every option of every preset (:class:`OptionFuzzer`),
as ``solve`` overrides and inside preset files, and their runner."""

from __future__ import annotations

import dataclasses
import functools
import math
import random
import sys
import tomllib
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error, _compare
from benchmarks.fuzz.core import SOLVE_TIME_LIMIT, Case, Outcome
from benchmarks.fuzz.values import _short, _toml_value, toml_dumps

#: The scene a preset's accepted options and inits are solved on.
FORMATION_BACKENDS = ("leader-follower", "formation-qp", "formation-nlp", "hybrid")


def option_scene(backend: str, opts: dict[str, Any] | None = None) -> str:
    """A team scene for a team planner (a formation backend, or ``orca`` with ``team``),
    else a single-robot trap."""
    team = backend in FORMATION_BACKENDS or bool((opts or {}).get("team"))
    return "formation-open-field" if team else "trap-u"


@functools.lru_cache(maxsize=1)
def preset_table() -> dict[str, tuple[str, dict[str, Any]]]:
    """preset -> (backend, effective options) of every preset."""
    import optplan as op
    from optplan.solver import get_solver

    out = {}
    for name in op.list_solvers():
        try:
            b = get_solver(name)
        except (ValueError, ImportError) as e:  # a preset broken in this checkout
            print(f"fuzz: skipping preset {name}: {e}", file=sys.stderr)
            continue
        out[name] = (b.name, b.options())
    return out


def _values_for(default: Any) -> list[tuple[Any, bool]]:
    """Bad values for an option with this default: (value, must it be rejected?)."""
    common: list[tuple[Any, bool]] = [([1], True), ({"a": 1}, True), (None, False)]
    if isinstance(default, bool):
        return common + [(1, True), (0, True), ("true", True), (0.5, True), (math.nan, True),
                         ("yes", True)]
    if isinstance(default, str):
        return common + [(3, True), ("no-such-thing", True), ("", False), (True, True),
                         ([default], True), (default.upper() + "x", True), (math.nan, True)]
    nums: list[tuple[Any, bool]] = [
        (math.nan, True), (math.inf, True), (-math.inf, True), (1e300, False),
        (-1e300, False), (0, False), (-1, False), (-0.5, False), (10**30, False),
        (2**63, False), (1e-300, False), ("3", True), (True, True), ("nan", True)]
    if isinstance(default, int) or default is None:
        nums += [(0.5, False), (-(10**30), False), (10**6, False)]
    if isinstance(default, float):
        nums += [(default * 1e6 if default else 1e6, False), (-default, False)]
    return common + nums


class OptionFuzzer:
    def __init__(self, seed: int = 0):
        self.rng = random.Random(seed)

    def cases(self, presets: dict[str, tuple[str, dict]] | None = None) -> list[Case]:
        presets = presets or preset_table()
        out = []
        n = 0
        for name, (backend, opts) in presets.items():
            for opt, default in opts.items():
                inf_ok = _declares_inf(name, opt)
                for value, must in _values_for(default):
                    if inf_ok and isinstance(value, float) and math.isinf(value) and value > 0:
                        must = False  # the option documents what infinity means
                    n += 1
                    via = "file" if self.rng.random() < 0.15 and _toml_ok(value) else "override"
                    out.append(Case("option", f"option/{n:05d}/{name}/{opt}",
                                    f"{opt} = {_short(value)}",
                                    {"preset": name, "backend": backend, "option": opt,
                                     "value": value, "via": via,
                                     "scene": option_scene(backend, opts)},
                                    (opt,), must))
        return out


def _declares_inf(preset: str, opt: str) -> bool:
    """Option ``opt`` of ``preset`` is declared ``inf_ok`` (``optplan.options.option``)."""
    from optplan.options import option_spec
    from optplan.solver import get_solver

    fields = {f.name: f for f in dataclasses.fields(type(get_solver(preset)))}
    spec = option_spec(fields[opt]) if opt in fields else None
    return bool(spec and spec.inf_ok)


def _toml_ok(v: Any) -> bool:
    try:
        tomllib.loads("v = " + _toml_value(v))
    except (TypeError, tomllib.TOMLDecodeError):
        return False
    return v is not None


def run_option(case: Case, tmp: Path) -> Outcome:
    import optplan as op

    d = case.data
    opt, value = d["option"], d["value"]
    file = None
    kwargs: dict[str, Any] = {}
    solver: Any = d["preset"]
    if d["via"] == "file":
        from optplan.solver import all_preset_files

        src = tomllib.loads(all_preset_files()[d["preset"]].read_text(encoding="utf-8"))
        src.setdefault("options", {})[opt] = value
        path = tmp / f"{d['preset']}-fuzz.toml"
        path.write_text(toml_dumps(src), encoding="utf-8")
        solver, file = str(path), str(path)
    elif opt != "time_limit":
        kwargs[opt] = value
    try:
        if opt == "time_limit" and d["via"] != "file":
            # a backend's own ``time_limit`` option (the hybrids' default budget): the call's
            # ``time_limit=`` is the same keyword, so the option is set on the preset and the
            # run keeps the slice's short limit
            solver = op.get_solver(d["preset"], time_limit=value)
        res = op.solve(d["scene"], solver, rng=0, time_limit=SOLVE_TIME_LIMIT, **kwargs)
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, file)
        return Outcome(case, cat, det)
    if case.must_reject:
        return Outcome(case, "silently accepted", f"accepted ({res.status})")
    return _compare(case, op.load_problem(d["scene"]), res) if not op.load_problem(
        d["scene"]).formation else Outcome(case, "accepted and solved", str(res.status))
