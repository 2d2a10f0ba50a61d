"""Find and parse the scenario catalogue (``problems/*.toml``) and presets (``solvers/*.toml``).

The shipped occupancy maps the map scenes were imported from live in ``problems/maps/``
(:func:`map_files`, :func:`find_map`).

The catalogues are data directories, not import packages.  They are looked up in order:
``$OPTPLAN_CATALOG`` (a directory holding ``problems/`` and ``solvers/``), the source checkout
next to the package (editable installs), and the copy shipped inside the wheel
(``optplan/_data``).
"""

from __future__ import annotations

import difflib
import os
import tomllib
from functools import lru_cache
from pathlib import Path

from optplan.problem import Problem, ProblemError, read_problem

__all__ = ["catalog_dir", "problem_files", "preset_files", "load_problem", "list_problems",
           "read_preset", "map_files", "find_map"]

#: Suffixes of the shipped occupancy maps in ``problems/maps/`` (:func:`map_files`).
MAP_SUFFIXES = (".yaml", ".yml", ".map")


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
    return {p.stem: p for p in sorted(catalog_dir("solvers").glob("*.toml"))}


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
    """The parsed TOML of a preset file.

    Parameters
    ----------
    path : Path
        The preset file.

    Returns
    -------
    dict
        Its top-level table.

    Raises
    ------
    ValueError
        Naming the file: a directory, unreadable, not UTF-8, invalid or too deeply nested TOML.
    """
    if path.is_dir():
        raise ValueError(f"{path}: is a directory, not a preset file")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
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
    """Reject unknown top-level keys of a preset and a missing ``backend``.

    Parameters
    ----------
    path : Path
        The preset file (named in errors).
    data : dict
        Its top-level table.

    Raises
    ------
    ValueError
        Naming the file and the key.
    """
    allowed = {"backend", "summary", "options", "paper", "paper_notes"}
    for k in data:
        if k not in allowed:
            close = difflib.get_close_matches(k, allowed, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"{path}: {k}: unknown key{hint} (allowed: {sorted(allowed)})")
    if "backend" not in data:
        raise ValueError(f"{path}: backend: missing required key")


def _check_preset_types(path: Path, data: dict) -> None:
    """Check the types of a preset's values: strings, tables, ``paper_notes`` of strings.

    Parameters
    ----------
    path : Path
        The preset file (named in errors).
    data : dict
        Its top-level table (keys already checked).

    Raises
    ------
    ValueError
        Naming the file and the key.
    """
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
