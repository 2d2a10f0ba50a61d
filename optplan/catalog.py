"""Find and parse the scenario catalogue (``problems/*.toml``) and presets (``solvers/*.toml``).

The shipped occupancy maps the map scenes were imported from live in ``problems/maps/``
(:func:`map_files`, :func:`find_map`).

The catalogues are data directories, not import packages.  They are looked up in order:
``$OPTPLAN_CATALOG`` (a directory holding ``problems/`` and ``solvers/``), the source checkout
next to the package (editable installs), and the copy shipped inside the wheel
(``optplan/_data``).

Plugin distributions add backends (entry-point group ``optplan.backends``, ``line =
"toyplug.planner:Line"``) and preset folders (``optplan.presets``, ``toyplug =
"toyplug.presets"``: a package, regular or namespace, whose folder holds ``*.toml`` presets).
A plugin cannot break the toolkit: an entry point that is malformed or names what is not a
:class:`~optplan.backend.Backend` subclass, a module, class or dependency that is missing, a
plugin package that raises when imported (``sys.exit()`` and any other ``BaseException``
included; ``KeyboardInterrupt`` is never caught) and a plugin preset that cannot be read or
names an unknown backend are each reported once per process as a :class:`PluginWarning`
naming the distribution, the entry point and the error; everything else keeps working.
Asking for the broken backend or preset by name raises an error with the same text
(:func:`broken_backend`).
"""

from __future__ import annotations

import copy
import difflib
import os
import re
import tomllib
import warnings
from functools import lru_cache
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any

from optplan.problem import Problem, ProblemError, read_problem

__all__ = ["catalog_dir", "problem_files", "preset_files", "load_problem", "list_problems",
           "read_preset", "map_files", "find_map", "BACKEND_GROUP", "PRESET_GROUP",
           "PluginWarning", "check_entry", "discover_backends", "plugin_preset_files",
           "broken_backend", "interrupted", "plugin_origin", "preset_origin", "load_failed",
           "preset_failed"]

#: Suffixes of the shipped occupancy maps in ``problems/maps/`` (:func:`map_files`).
MAP_SUFFIXES = (".yaml", ".yml", ".map")
#: Preset files whose parse :func:`_preset_toml` keeps (all are dropped past it).
PARSED_MAX = 256
#: ``preset_files``' listing per directory: (its ``*.toml`` file names, stem -> path).
_listing: dict[Path, tuple[tuple[str, ...], dict[str, Path]]] = {}
#: ``_preset_toml``'s parses: path -> (the file's text, its parsed TOML).
_parsed: dict[Path, tuple[str, dict]] = {}


def _candidates() -> list[Path]:
    here = Path(__file__).resolve().parent
    out = []
    env = os.environ.get("OPTPLAN_CATALOG")
    if env:
        out.append(Path(env))
    out += [here.parent, here / "_data"]
    return out


def catalog_dir(kind: str) -> Path:
    """Directory of the ``problems`` or ``solvers`` catalogue."""
    for base in _candidates():
        d = base / kind
        if d.is_dir() and any(d.glob("*.toml")):
            return d
    raise FileNotFoundError(
        f"cannot find the optplan {kind}/ catalogue (looked in "
        f"{', '.join(str(b / kind) for b in _candidates())})"
    )


def problem_files() -> dict[str, Path]:
    return {p.stem: p for p in sorted(catalog_dir("problems").glob("*.toml"))}


def preset_files() -> dict[str, Path]:
    """The shipped presets, ``solvers/*.toml``, by file stem.  The paths are made again only
    when the directory's file names change (every ``op.solve`` by preset name asks)."""
    d = catalog_dir("solvers")
    try:
        names = tuple(sorted(n for n in os.listdir(d) if n.endswith(".toml")))
    except OSError:
        return {}
    got = _listing.get(d)
    if got is None or got[0] != names:
        got = _listing[d] = (names, {p.stem: p for p in (d / n for n in names)})
    return dict(got[1])


def map_files() -> dict[str, Path]:
    """The shipped occupancy maps, ``problems/maps/*.yaml`` (ROS ``map_server``, with their
    images) and ``*.map`` (MovingAI), by file stem; read them with :mod:`optplan.maps`."""
    d = catalog_dir("problems") / "maps"
    if not d.is_dir():
        return {}
    return {p.stem: p for p in sorted(d.iterdir()) if p.suffix.lower() in MAP_SUFFIXES}


def find_map(name_or_path: str | Path) -> Path:
    """A map file: an existing path as given, else a shipped map by name (``"warehouse"``)."""
    p = Path(name_or_path)
    if p.exists():
        return p
    files = map_files()
    if str(name_or_path) in files:
        return files[str(name_or_path)]
    close = difflib.get_close_matches(str(name_or_path), list(files), n=3)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise ProblemError(f"{name_or_path}: no such map file and no shipped map of that name{hint} "
                       f"(shipped: {', '.join(files) or 'none'})")


@lru_cache(maxsize=64)
def _load_cached(path: str, mtime: float) -> Problem:
    return read_problem(path)


def load_problem(name_or_path: str | Path | Problem) -> Problem:
    """Load a scenario by catalogue name (``"paper-env1"``) or path to a ``.toml`` file."""
    if isinstance(name_or_path, Problem):
        return name_or_path
    if not isinstance(name_or_path, (str, Path)):
        raise ProblemError(f"expected a problem name, a .toml path or a Problem, got "
                           f"{type(name_or_path).__name__}")
    s = str(name_or_path)
    p = Path(s)
    if p.is_dir() and (s.endswith(".toml") or s not in problem_files()):
        raise ProblemError(f"{s}: is a directory, not a scenario file")
    if s.endswith(".toml") or p.is_file():
        if not p.is_file():
            raise ProblemError(f"{s}: no such scenario file")
        try:
            mtime = p.stat().st_mtime
        except OSError as e:
            raise ProblemError(f"{s}: cannot read file ({e.strerror or e})") from None
        return _load_cached(str(p.resolve()), mtime)
    files = problem_files()
    if s not in files:
        close = difflib.get_close_matches(s, list(files), n=3)
        hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise ProblemError(f"unknown problem {s!r}{hint} (see optplan.list_problems())")
    f = files[s]
    return _load_cached(str(f), f.stat().st_mtime)


def list_problems(tag: str | None = None) -> list[str]:
    """Catalogue names, optionally only those carrying ``tag``."""
    names = list(problem_files())
    if tag is None:
        return names
    return [n for n in names if tag in load_problem(n).tags]


def read_preset(path: Path) -> dict:
    """Parse a preset file: ``backend``, ``summary``, ``[options]``, ``[paper]``, ``[paper_notes]``.

    ``[paper]`` (optional) maps option names to the value the paper prints (a number, or a
    string such as ``"not given"``); ``[paper_notes]`` maps option names to why the preset
    differs or how the value was read.  :func:`paper_table` renders both beside the preset's
    options (the solver pages show it).

    Raises
    ------
    ValueError
        Naming the file and the key: unreadable, not UTF-8, invalid TOML, unknown or missing
        keys, ``backend`` / ``summary`` not strings, ``options`` not a table.
    """
    path = Path(path)
    data = _preset_toml(path)
    _check_preset_keys(path, data)
    _check_preset_types(path, data)
    return {"backend": data["backend"], "summary": data.get("summary", ""),
            "options": data.get("options", {}), "paper": data.get("paper", {}),
            "paper_notes": data.get("paper_notes", {})}


def _preset_toml(path: Path) -> dict:
    """The parsed TOML of a preset file (a copy).  The file is read every time and parsed
    again only when its text changed (the parses of at most :data:`PARSED_MAX` files are
    kept): every ``op.solve`` by preset reads its preset."""
    if path.is_dir():
        raise ValueError(f"{path}: is a directory, not a preset file")
    try:
        text = path.read_text(encoding="utf-8")
        got = _parsed.get(path)
        if got is None or got[0] != text:
            if len(_parsed) >= PARSED_MAX:
                _parsed.clear()
            got = _parsed[path] = (text, tomllib.loads(text))
        return copy.deepcopy(got[1])
    except OSError as e:
        raise ValueError(f"{path}: cannot read file ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise ValueError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: invalid TOML: {e}") from None
    except RecursionError:
        raise ValueError(f"{path}: invalid TOML: arrays or inline tables nested too "
                         "deeply") from None


def _check_preset_keys(path: Path, data: dict) -> None:
    """Reject unknown top-level keys of a preset and a missing ``backend``."""
    allowed = {"backend", "summary", "options", "paper", "paper_notes"}
    for k in data:
        if k not in allowed:
            close = difflib.get_close_matches(k, allowed, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"{path}: {k}: unknown key{hint} (allowed: {sorted(allowed)})")
    if "backend" not in data:
        raise ValueError(f"{path}: backend: missing required key")


def _check_preset_types(path: Path, data: dict) -> None:
    """Check the types of a preset's values: strings, tables, ``paper_notes`` of strings."""
    for k in ("backend", "summary"):
        if k in data and not isinstance(data[k], str):
            raise ValueError(f"{path}: {k}: expected a string, got {type(data[k]).__name__}")
    for k in ("options", "paper", "paper_notes"):
        if not isinstance(data.get(k, {}), dict):
            raise ValueError(f"{path}: {k}: expected a table, got {type(data[k]).__name__}")
    for k, v in data.get("paper_notes", {}).items():
        if not isinstance(v, str):
            raise ValueError(f"{path}: paper_notes.{k}: expected a string, got "
                             f"{type(v).__name__}")


# --------------------------------------------------------------------------------------
# plugin distributions
# --------------------------------------------------------------------------------------

#: Entry-point groups of plugin distributions.
BACKEND_GROUP = "optplan.backends"
PRESET_GROUP = "optplan.presets"

#: ``package.module:Class`` (dotted identifiers on both sides of one colon)
_ENTRY = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")
_MODULE = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")

#: per-process state: what was reported, the broken backends, the plugin presets
_state: dict[str, Any] = {"reported": set(), "broken": {}}


class PluginWarning(UserWarning):
    """A plugin distribution could not be loaded; the rest of optplan works without it."""


def describe(ep: EntryPoint) -> str:
    """How messages name a plugin's entry point.

    Parameters
    ----------
    ep : EntryPoint
        An entry point of a plugin distribution.

    Returns
    -------
    str
        ``plugin distribution 'toyplug' (entry point line = toyplug.planner:Line in
        optplan.backends)``.
    """
    dist = getattr(ep, "dist", None)
    name = getattr(dist, "name", None) or "?"
    return f"plugin distribution {name!r} (entry point {ep.name} = {ep.value} in {ep.group})"


def report(message: str) -> None:
    """Warn ``message`` as a :class:`PluginWarning`, once per process."""
    if message in _state["reported"]:
        return
    _state["reported"].add(message)
    warnings.warn(message, PluginWarning, stacklevel=3)


def check_entry(value: str, what: str = "backend") -> str | None:
    """Why ``value`` is not a valid entry point of a ``what`` (None when it is).

    >>> check_entry("toyplug.planner:Line") is None
    True
    >>> check_entry("toyplug.planner")
    "expected 'package.module:Class', got 'toyplug.planner'"
    """
    pattern, form = (_ENTRY, "package.module:Class") if what == "backend" else (_MODULE,
                                                                                "package.folder")
    if not isinstance(value, str) or not pattern.match(value.strip()):
        return f"expected {form!r}, got {value!r}"
    return None


def _error(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return (f"{type(e).__name__}: {text}" if text else type(e).__name__)[:300]


def interrupted(e: BaseException) -> bool:
    """Whether ``e`` is (or a group holding) a ``KeyboardInterrupt``, which is never caught.

    Parameters
    ----------
    e : BaseException
        An exception a plugin raised.

    Returns
    -------
    bool
        True for ``KeyboardInterrupt`` and exception groups containing one; False for
        everything else a plugin may raise (``SystemExit`` included).
    """
    if isinstance(e, BaseExceptionGroup):
        return e.subgroup(KeyboardInterrupt) is not None
    return isinstance(e, KeyboardInterrupt)


def discover_backends(backends: dict[str, str]) -> list[str]:
    """Add the plugin backends to ``backends`` (name -> ``module:Class``); a shipped name wins.

    A malformed entry point is not added: it is reported and recorded as broken.

    Returns
    -------
    list of str
        The conflicts: plugin backends ignored because the name is taken.
    """
    conflicts = []
    for ep in entry_points(group=BACKEND_GROUP):
        why = check_entry(ep.value)
        if why is not None:
            msg = f"{describe(ep)} ignored: {why}"
            _state["broken"].setdefault(ep.name, msg)
            report(msg)
            continue
        if ep.name not in backends:
            backends[ep.name] = ep.value
            _state.setdefault("plugin_backends", {})[ep.name] = describe(ep)
        elif backends[ep.name] != ep.value:
            conflicts.append(f"plugin backend {ep.name!r} = {ep.value!r} ignored: the name is "
                             f"taken by {backends[ep.name]!r}")
    return conflicts


def broken_backend(name: str) -> str | None:
    """The report on the plugin backend ``name`` when it could not be loaded, else None."""
    return _state["broken"].get(name)


def plugin_origin(name: str) -> str | None:
    """How messages name the plugin entry point of the backend ``name`` (None when the backend
    is not a plugin's: shipped or added with ``register``)."""
    origin: str | None = _state.get("plugin_backends", {}).get(name)
    return origin


def load_failed(name: str, entry: str, why: str) -> str:
    """Record and report that the backend ``name`` (``entry``) cannot be loaded.

    Parameters
    ----------
    name : str
        The backend name.
    entry : str
        Its ``module:Class`` entry.
    why : str
        What went wrong (``importing it raised ...``).

    Returns
    -------
    str
        The message, naming the distribution and the entry point of a plugin backend (the
        caller raises it as an :class:`ImportError`).
    """
    who = plugin_origin(name) or f"backend {name!r} = {entry!r}"
    msg = f"{who}: {why}"
    _state["broken"][name] = msg
    report(msg)
    return msg


def import_failed(name: str, entry: str, e: BaseException) -> str:
    """Record and report that importing the backend ``name`` (``entry``) raised ``e``; return
    the message (the caller raises it as an :class:`ImportError`)."""
    return load_failed(name, entry, f"importing it raised {_error(e)}")


def _preset_dirs(ep: EntryPoint) -> list[Path]:
    """The folders of the preset package ``ep.value`` (several for a namespace package)."""
    import importlib.util

    why = check_entry(ep.value, "presets")
    if why is not None:
        raise ValueError(why)
    spec = importlib.util.find_spec(ep.value.strip())
    if spec is None:
        raise ModuleNotFoundError(f"no module named {ep.value.strip()!r}")
    if spec.submodule_search_locations is None:
        raise ValueError(f"{ep.value!r} is a module, not a package folder")
    return [Path(p) for p in spec.submodule_search_locations]


def plugin_preset_files() -> dict[str, Path]:
    """Presets shipped by plugin distributions: file stem -> path (the first one found wins).

    A preset package that cannot be found or raises when imported (``SystemExit`` included,
    ``KeyboardInterrupt`` never caught) is reported (once) and skipped.
    """
    if "presets" not in _state:
        out: dict[str, Path] = {}
        origin: dict[Path, str] = {}
        for ep in entry_points(group=PRESET_GROUP):
            try:
                dirs = _preset_dirs(ep)
            except BaseException as e:  # noqa: BLE001 - a plugin must not break optplan
                if interrupted(e):
                    raise
                report(f"{describe(ep)}: presets skipped: {_error(e)}")
                continue
            for d in dirs:
                for f in sorted(d.glob("*.toml")):
                    if f.stem not in out:
                        out[f.stem] = f
                        origin[f] = describe(ep)
        _state["presets"], _state["preset_origin"] = out, origin
    return dict(_state["presets"])


def preset_origin(path: Path) -> str | None:
    """How messages name the plugin entry point that ships the preset file ``path`` (None for
    a shipped preset or a file given by path)."""
    plugin_preset_files()
    origin: str | None = _state["preset_origin"].get(Path(path))
    return origin


def preset_failed(path: Path, e: Exception) -> str:
    """Report (once) that the plugin preset ``path`` cannot be used because of ``e``.

    Parameters
    ----------
    path : Path
        A preset file shipped by a plugin (:func:`plugin_preset_files`).
    e : Exception
        Why it cannot be used (a ``ValueError`` naming the file).

    Returns
    -------
    str
        The message, naming the distribution, the entry point, the file and the error (the
        caller raises it as a ``ValueError``).
    """
    text = " ".join(str(e).split())
    where = "" if str(path) in text else f"{path}: "
    msg = f"{preset_origin(path) or path}: {where}{text}"
    report(msg)
    return msg
