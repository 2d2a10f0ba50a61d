"""Declarative backend options: :func:`option` declares a field's range beside the field.

A backend is a frozen, keyword-only dataclass whose fields are its options.  Each field is
declared with :func:`option`, which records the allowed values in the field's metadata::

    n_particles: int = option(50, lo=1, hi=100_000)
    w: float = option(0.5, lo=0.0, hi=2.0)
    rho_0: float = option(20.0, lo=0.0, lo_open=True, scale=True)
    l: float | None = option(None, lo=0.0, lo_open=True)          # None allowed: the default
    bounds_mode: str = option("reflect", choices=("reflect", "clamp", "random"))
    detect_eq38: bool = option(True)

:func:`check_options` validates every declared field generically (called by
``Backend.__post_init__``); rules that relate two options live in the backend's
``check()`` method.  The *meaning* of an option is written once, in the numpy-style
``Parameters`` section of the class docstring (the API reference renders it);
:func:`describe_options` joins it with the declaration, for ``optplan show-solver NAME``.

Kinds are inferred from the default (``bool``, ``int``, ``float``, ``str``) unless ``kind=``
is given; a ``float`` option accepts ints.  Infinity is rejected unless the declaration says
``inf_ok=True`` (and the docstring then documents what infinity means).  ``None`` is accepted
when it is the default or ``none_ok=True``.  ``scale=True`` marks a length measured in the
problem's length unit (:attr:`optplan.problem.Problem.length_scale`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["OptionSpec", "option", "option_spec", "check_options", "check_value",
           "describe_options"]

_KEY = "optplan.option"


@dataclass(frozen=True)
class OptionSpec:
    """The allowed values of one option (see :func:`option`)."""

    kind: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[Any, ...] | None = None
    none_ok: bool = False
    inf_ok: bool = False
    scale: bool = False

    def describe(self) -> str:
        """The allowed values as text: ``a number in [0, 60]``, ``an integer in [1, 100]``,
        ``one of 'a', 'b'``, ``true or false``."""
        if self.choices is not None:
            s = "one of " + ", ".join(repr(c) for c in self.choices)
        elif self.kind in ("int", "float"):
            lo = "-inf" if self.lo is None else f"{self.lo:g}"
            hi = "inf" if self.hi is None else f"{self.hi:g}"
            lb = "(" if self.lo_open or self.lo is None else "["
            rb = ")" if self.hi_open or self.hi is None else "]"
            s = f"{'an integer' if self.kind == 'int' else 'a number'} in {lb}{lo}, {hi}{rb}"
            if self.inf_ok:
                s += " or +inf"
        else:
            s = {"bool": "true or false", "str": "a string"}.get(self.kind, "any value")
        if self.none_ok:
            s += " or None"
        if self.scale:
            s += " (x length_scale)"
        return s


def option(default: Any, *, lo: float | None = None, hi: float | None = None,
           lo_open: bool = False, hi_open: bool = False,
           choices: tuple[Any, ...] | None = None, kind: str | None = None,
           none_ok: bool = False, inf_ok: bool = False, scale: bool = False) -> Any:
    """A dataclass field with its allowed values declared (see the module docstring).

    Parameters
    ----------
    default
        The default value (immutable: numbers, strings, ``None``, tuples).
    lo, hi : float or None
        Bounds of a numeric option (``None``: unbounded on that side, still finite).
    lo_open, hi_open : bool
        Exclude the bound itself.
    choices : tuple or None
        The allowed values of a choice option.
    kind : {"bool", "int", "float", "str", "any"} or None
        The value type; inferred from ``default`` when omitted (``None`` default: ``float``).
    none_ok : bool
        Accept ``None`` (implied by a ``None`` default).
    inf_ok : bool
        Accept ``+inf`` / ``-inf`` (the option's docstring says what it means).
    scale : bool
        The option is a length in the problem's length unit.
    """
    if kind is None:
        if choices is not None:
            kind = "choice"
        elif isinstance(default, bool):
            kind = "bool"
        elif isinstance(default, int):
            kind = "int"
        elif isinstance(default, str):
            kind = "str"
        else:
            kind = "float"
    spec = OptionSpec(kind=kind, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open,
                      choices=None if choices is None else tuple(choices),
                      none_ok=none_ok or default is None, inf_ok=inf_ok, scale=scale)
    return dataclasses.field(default=default, metadata={_KEY: spec})


def option_spec(f: dataclasses.Field) -> OptionSpec | None:
    """The declaration of dataclass field ``f`` (``None`` if it was not declared)."""
    return f.metadata.get(_KEY)


_TYPES: dict[str, tuple[type, ...]] = {
    "bool": (bool, np.bool_),
    "str": (str,),
    "int": (int, np.integer),
    "float": (int, float, np.integer, np.floating),
}


def _type_ok(spec: OptionSpec, value: Any) -> bool:
    """``value`` has the declared kind (a bool is never a number)."""
    if spec.choices is not None:
        return not isinstance(value, bool) and value in spec.choices
    if spec.kind == "any":
        return True
    if spec.kind in ("int", "float") and isinstance(value, (bool, np.bool_)):
        return False
    return isinstance(value, _TYPES[spec.kind])


def _range_ok(spec: OptionSpec, v: float) -> bool:
    """The number ``v`` lies in the declared range (infinity only with ``inf_ok``)."""
    if math.isnan(v):
        return False
    if math.isinf(v):
        return spec.inf_ok and v > 0  # only +inf, and only where it is documented
    lo_ok = spec.lo is None or (v > spec.lo if spec.lo_open else v >= spec.lo)
    hi_ok = spec.hi is None or (v < spec.hi if spec.hi_open else v <= spec.hi)
    return lo_ok and hi_ok


def check_value(spec: OptionSpec, name: str, value: Any, owner: str) -> None:
    """Raise ``ValueError`` naming ``owner`` and ``name`` unless ``value`` is allowed."""
    if value is None:
        ok = spec.none_ok
    else:
        ok = _type_ok(spec, value)
        if ok and spec.kind in ("int", "float") and spec.choices is None:
            ok = _range_ok(spec, float(value))
    if not ok:
        raise ValueError(f"option {name!r} of backend {owner!r} must be {spec.describe()}, "
                         f"got {value!r}")


def check_options(obj: Any) -> None:
    """Validate every declared option of dataclass instance ``obj`` (raises ``ValueError``)."""
    owner = getattr(obj, "name", type(obj).__name__)
    for f in dataclasses.fields(obj):
        spec = option_spec(f)
        if spec is not None:
            check_value(spec, f.name, getattr(obj, f.name), owner)


def _entries(lines: list[str], i0: int) -> list[tuple[list[str], str]]:
    """``(names, first paragraph)`` of each entry of the numpy section headed at ``i0``."""
    base = len(lines[i0]) - len(lines[i0].lstrip())
    out: list[tuple[list[str], list[str]]] = []
    done = False
    for j in range(i0 + 2, len(lines)):
        ln = lines[j]
        if not ln.strip():
            done = bool(out and out[-1][1])
            continue
        if len(ln) - len(ln.lstrip()) <= base:
            if j + 1 < len(lines) and set(lines[j + 1].strip()) == {"-"}:
                break  # the next section
            head = ln.strip().split(" : ")[0].rstrip(" \\")
            out.append(([n.strip(" \\") for n in head.split(",") if n.strip(" \\")], []))
            done = False
        elif out and not done:
            out[-1][1].append(ln.strip())
    return [(names, " ".join(text).strip()) for names, text in out]


def _parameter_docs(cls: type) -> dict[str, str]:
    """``name -> first paragraph`` of the numpy ``Parameters`` sections along ``cls``'s MRO.

    An entry that says "see ..." or "shared ..." (a pointer to a base class) is skipped, so
    the base class's own entry is used.
    """
    out: dict[str, str] = {}
    for klass in cls.__mro__:
        lines = (klass.__dict__.get("__doc__") or "").expandtabs().splitlines()
        heads = [i for i, ln in enumerate(lines[:-1])
                 if ln.strip() == "Parameters" and set(lines[i + 1].strip()) == {"-"}]
        for names, text in _entries(lines, heads[0]) if heads else []:
            if text and not text.lower().startswith(("shared", "see ")):
                for n in names:
                    out.setdefault(n, text)
    return out


def describe_options(cls: type) -> list[dict[str, Any]]:
    """One row per option of backend class ``cls``: name, default, allowed values, meaning."""
    docs = _parameter_docs(cls)
    rows = []
    for f in dataclasses.fields(cls):
        if not f.init or f.name.startswith("_") or f.name == "preset":
            continue  # ``preset`` names the configuration; it is not an option
        spec = option_spec(f)
        default = f.default if f.default is not dataclasses.MISSING else None
        rows.append({"name": f.name, "default": default,
                     "allowed": spec.describe() if spec else "(undeclared)",
                     "meaning": docs.get(f.name, "")})
    return rows
