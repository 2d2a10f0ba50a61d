"""Declarative options (optplan.options): generic validation, declarations complete, show-solver."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import optplan as op
from optplan.cli import main
from optplan.options import OptionSpec, check_value, describe_options, option, option_spec

BACKENDS = op.list_backends()


def cls_of(name: str) -> type:
    return type(op.get_solver(name))


@pytest.mark.parametrize("name", BACKENDS)
def test_every_option_is_declared_and_documented(name: str) -> None:
    cls = cls_of(name)
    for f in dataclasses.fields(cls):
        if f.init and not f.name.startswith("_") and f.name != "preset":
            assert option_spec(f) is not None, f"{name}.{f.name} is not declared with option()"
    undocumented = [r["name"] for r in describe_options(cls) if not r["meaning"]]
    assert not undocumented, f"{name}: no docstring entry for {undocumented}"


@pytest.mark.parametrize("name", BACKENDS)
def test_every_default_satisfies_its_declaration(name: str) -> None:
    cls = cls_of(name)
    for f in dataclasses.fields(cls):
        spec = option_spec(f)
        if spec is not None and f.default is not dataclasses.MISSING:
            check_value(spec, f.name, f.default, name)


@pytest.mark.parametrize("name", BACKENDS)
def test_wrong_types_are_rejected_by_name(name: str) -> None:
    cls = cls_of(name)
    for f in dataclasses.fields(cls):
        spec = option_spec(f)
        if spec is None or spec.kind == "any":
            continue
        bad = "x" if spec.kind != "str" else 3.5
        if spec.choices is not None:
            bad = "no-such-choice"
        with pytest.raises(ValueError, match=f"option '{f.name}' of backend '{name}'"):
            op.get_solver(name, **{f.name: bad})


@pytest.mark.parametrize("value, ok", [(0.5, True), (0, False), (1, True), (1.5, False),
                                       (math.inf, False), (math.nan, False), (True, False),
                                       (np.float64(0.25), True), ("0.5", False), (None, False)])
def test_half_open_float_range(value, ok) -> None:
    s = OptionSpec(kind="float", lo=0.0, hi=1.0, lo_open=True)
    if ok:
        check_value(s, "a", value, "b")
    else:
        with pytest.raises(ValueError, match=r"option 'a' of backend 'b' must be a number in "
                                             r"\(0, 1\]"):
            check_value(s, "a", value, "b")


def test_int_bool_choice_none_and_inf() -> None:
    i = OptionSpec(kind="int", lo=1, hi=10)
    check_value(i, "n", np.int64(3), "b")
    for bad in (3.0, True, 11, 0):
        with pytest.raises(ValueError, match=r"an integer in \[1, 10\]"):
            check_value(i, "n", bad, "b")
    b = OptionSpec(kind="bool")
    check_value(b, "f", False, "b")
    with pytest.raises(ValueError, match="true or false"):
        check_value(b, "f", 1, "b")
    c = OptionSpec(kind="choice", choices=("a", "b"))
    with pytest.raises(ValueError, match="one of 'a', 'b'"):
        check_value(c, "m", "c", "b")
    n = OptionSpec(kind="float", lo=0.0, none_ok=True)
    check_value(n, "x", None, "b")
    inf = OptionSpec(kind="float", lo=0.0, inf_ok=True)
    check_value(inf, "x", math.inf, "b")
    for bad in (-1.0, -math.inf, math.nan):
        with pytest.raises(ValueError, match=r"a number in \[0, inf\) or \+inf"):
            check_value(inf, "x", bad, "b")


def test_option_infers_the_kind_and_none() -> None:
    assert option_spec(option(3)).kind == "int"
    assert option_spec(option(True)).kind == "bool"
    assert option_spec(option("a", choices=("a", "b"))).kind == "choice"
    assert option_spec(option(None, lo=0.0)).none_ok
    assert option_spec(option(2.0, scale=True)).describe().endswith("(x length_scale)")


@pytest.mark.parametrize("name", op.list_solvers())
def test_show_solver_prints_every_option(name: str, capsys) -> None:
    assert main(["show-solver", name]) == 0
    text = capsys.readouterr().out
    assert "(undeclared)" not in text
    for row in describe_options(cls_of(name)):
        assert f"  {row['name']} " in text


def test_show_solver_unknown_name(capsys) -> None:
    assert main(["show-solver", "no-such-solver"]) == 2
    assert "unknown solver 'no-such-solver'" in capsys.readouterr().err


def test_generated_options_table_lists_every_option_with_each_presets_value() -> None:
    """docs: ``<!-- options-table: A B -->`` (the APF page) is this table, built from the
    declared options, so a changed default or range shows up in the docs."""
    import importlib.util
    from pathlib import Path

    from optplan.doc_tables import options_table
    from optplan.solver import get_solver

    presets = ["apf-paper", "sa-apf-paper"]
    table = options_table(presets)
    lines = table.splitlines()
    assert lines[0] == "| option | meaning | allowed | `apf-paper` | `sa-apf-paper` |"
    solvers = [get_solver(p) for p in presets]
    names = {n for s in solvers for n in s.options()}
    rows = {ln.split("|")[1].strip().strip("`"): ln for ln in lines[2:]}
    assert set(rows) == names
    for name, ln in rows.items():
        cells = [c.strip() for c in ln.split("|")[1:-1]]
        assert len(cells) == 5, ln
        for s, c in zip(solvers, cells[3:], strict=True):
            assert c == (f"`{getattr(s, name)!r}`" if name in s.options() else "-")
    assert "(x length_scale)" in rows["rho_0"] and "eq 4" in rows["k"]
    assert rows["n"].endswith("| - | `3.0` |")  # an option of sa-apf only
    spec = importlib.util.spec_from_file_location(
        "paper_tables", Path(__file__).parents[2] / "docs" / "hooks" / "paper_tables.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    page = ("a\n\n<!-- options-table: apf-paper sa-apf-paper -->\n\n"
            "<!-- paper-table: apf-paper -->\n")
    out = hook.on_page_markdown(page)
    assert table in out and "<!--" not in out and "| option | `apf-paper` | paper |" in out
