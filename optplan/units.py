"""Units of reported values: every extra of a time-stepping planner declares how it transforms.

A time-stepping planner (``apf``, ``sa-apf``, ``leader-follower``, ``formation-qp``, ``hybrid``)
reports statistics beside its paths (``Result.extras``, the history's columns).  Each of them is
declared here with its :class:`Unit`, in a *spec*:

* a :class:`Unit` for a value (a number, an array, a list of them, a string);
* a :class:`Record` for a dict with fixed keys, each with its own spec;
* :class:`Each` for a dict keyed by robot ids (or statuses), or a list, whose every value has
  the same spec.

What a unit means is how the value changes when the scene is drawn at another scale ``s`` and
shifted by ``t`` (:func:`optplan.problem.transform_problem`): a ``length`` becomes ``s x``, a
``point`` ``s x + t``; a ``time``, a ``dimensionless`` number and a ``text`` stay as they are
(a value measured in units of the scene's ``length_scale`` is dimensionless); a ``wall time`` is
measured, not planned, and differs from run to run.

:func:`convert` walks a value along its spec, and an undeclared key of a :class:`Record` raises
:class:`UndeclaredUnit`: the hybrid planner, which plans in the canonical frame
(:mod:`optplan.canonical`), maps its extras back to the scene's units by :func:`to_scale`, so a
new length-valued extra cannot come back in the wrong unit, and a new extra without a unit
cannot come back at all.  ``tests/core/test_units.py`` runs every time-stepping preset on a
scene and on its scaled and shifted image and checks every declared unit against the values.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, TypeAlias

from optplan.canonical import to_world

__all__ = ["Unit", "Record", "Each", "Spec", "UndeclaredUnit", "convert", "leaves",
           "to_scale"]


class Unit(enum.Enum):
    """How a reported value transforms with the scene (module docstring)."""

    #: a distance: ``x -> s x``
    LENGTH = "length"
    #: coordinates (points, paths): ``x -> s x + t``
    POINT = "point"
    #: simulated seconds (a time step, an arrival time): unchanged
    TIME = "time"
    #: measured seconds or milliseconds: not reproducible, unchanged
    WALL_TIME = "wall time"
    #: counts, flags, ratios, angles, values in units of ``length_scale``: unchanged
    DIMENSIONLESS = "dimensionless"
    #: names, statuses, reasons, messages: unchanged
    TEXT = "text"

    @property
    def scales(self) -> bool:
        """Whether the value is multiplied by the scale of the scene (lengths and points)."""
        return self in (Unit.LENGTH, Unit.POINT)


@dataclass(frozen=True)
class Record:
    """A dict with declared keys: ``fields`` maps each key to its spec.

    A declared key may be absent from a value (e.g. a counter created on first use); a key of
    the value that is not declared raises :class:`UndeclaredUnit` in :func:`convert`.
    """

    fields: Mapping[str, Spec]

    def __or__(self, other: Record) -> Record:
        """Both records' keys; a key declared by both must have the same spec."""
        clash = sorted(k for k in set(self.fields) & set(other.fields)
                       if self.fields[k] != other.fields[k])
        if clash:
            raise ValueError(f"keys declared with two different units: {clash}")
        return Record({**self.fields, **other.fields})


@dataclass(frozen=True)
class Each:
    """A dict with any keys (robot ids, statuses) or a list: every value has spec ``item``."""

    item: Spec


Spec: TypeAlias = Unit | Record | Each


class UndeclaredUnit(KeyError):
    """A reported key that no spec declares (its unit is unknown)."""


def convert(value: Any, spec: Spec, fn: Callable[[Unit, Any], Any],
            where: str = "extras") -> Any:
    """``value`` with every part declared by a :class:`Unit` replaced by ``fn(unit, part)``.

    Parameters
    ----------
    value : any
        A reported value (``None`` stays ``None``).
    spec : Spec
        Its declaration.
    fn : callable
        ``fn(unit, part) -> new part``; a part is what a :class:`Unit` declares (a number, an
        array, a list of them, a string; never a dict).
    where : str
        The value's name, for the error messages.

    Raises
    ------
    UndeclaredUnit
        A key of a :class:`Record` value that the record does not declare.
    TypeError
        A value whose structure is not the declared one (a dict declared by a :class:`Unit`, a
        :class:`Record` that is no dict).
    """
    if value is None:
        return None
    if isinstance(spec, Unit):
        return fn(spec, _checked_part(value, where))
    out = [(k, convert(v, s, fn, name)) for k, v, s, name in _parts(value, spec, where)]
    if isinstance(value, dict):
        return dict(out)
    return type(value)(v for _, v in out)


def leaves(value: Any, spec: Spec, where: str = "extras") -> Iterator[tuple[str, Unit, Any]]:
    """Every declared part of ``value`` that is not ``None``: ``(name, unit, part)``, ``name``
    as in ``extras['local_stats']['leader']``; raises like :func:`convert`."""
    if value is None:
        return
    if isinstance(spec, Unit):
        yield where, spec, _checked_part(value, where)
        return
    for _, v, s, name in _parts(value, spec, where):
        yield from leaves(v, s, name)


def to_scale(value: Any, spec: Spec, factor: float, where: str = "extras") -> Any:
    """``value`` in units ``factor`` times larger: its lengths and points multiplied by
    ``factor`` (:func:`optplan.canonical.to_world`, through lists and arrays), everything
    else unchanged."""
    return convert(value, spec, lambda u, p: to_world(p, factor) if u.scales else p, where)


def _parts(value: Any, spec: Record | Each, where: str
           ) -> list[tuple[Any, Any, Spec, str]]:
    """The parts of a dict or list ``value``: ``(key, part, its spec, its name)``."""
    if isinstance(spec, Record):
        if not isinstance(value, dict):
            raise TypeError(f"{where}: a dict is declared, got {type(value).__name__}")
        bad = sorted(str(k) for k in value if k not in spec.fields)
        if bad:
            raise UndeclaredUnit(f"{where}: no unit is declared for {bad}")
        return [(k, v, spec.fields[k], f"{where}[{k!r}]") for k, v in value.items()]
    if isinstance(value, dict):
        return [(k, v, spec.item, f"{where}[{k!r}]") for k, v in value.items()]
    if isinstance(value, (list, tuple)):
        return [(i, v, spec.item, f"{where}[{i}]") for i, v in enumerate(value)]
    raise TypeError(f"{where}: a dict or a list is declared, got {type(value).__name__}")


def _checked_part(value: Any, where: str) -> Any:
    """``value`` when a :class:`Unit` can declare it (anything but a dict)."""
    if isinstance(value, dict):
        raise TypeError(f"{where}: a dict needs a Record or Each, not a Unit")
    return value
