"""Problems -> scenario TOML text and files (one or a batch)."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from optplan.problem import Problem, problem_to_dict


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if not math.isfinite(x):
            raise ValueError(f"cannot write the non-finite number {x!r} to TOML")
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def _toml_points(pts: Sequence, indent: str = "  ", per_line: int = 4, kind: type = float) -> str:
    """A list of points ``[x, y]`` (``kind`` int: node-index pairs), ``per_line`` a line."""
    items = [_toml_value([kind(x), kind(y)]) for x, y in pts]
    if len(items) <= per_line:
        return "[" + ", ".join(items) + "]"
    lines = [indent + ", ".join(items[i:i + per_line]) + ","
             for i in range(0, len(items), per_line)]
    return "[\n" + "\n".join(lines) + "\n]"


def _problem_tables(problem: Problem) -> tuple[dict, list[tuple[str, dict]]]:
    """Top-level keys and the ``[[array]]``/``[table]`` sections of a problem
    (:func:`optplan.problem.problem_to_dict`, laid out for TOML)."""
    d = problem_to_dict(problem)
    top = {k: v for k, v in d.items()
           if k not in ("sensing", "formation", "robots", "obstacles", "dynamic_obstacles",
                        "roadmap")}
    sections: list[tuple[str, dict]] = []
    if "sensing" in d:
        sections.append(("[sensing]", d["sensing"]))
    if "formation" in d:
        sections.append(("[formation]", d["formation"]))
    for key in ("robots", "obstacles", "dynamic_obstacles"):
        sections += [(f"[[{key}]]", t) for t in d.get(key, [])]
    if "roadmap" in d:
        sections.append(("[roadmap]", d["roadmap"]))
    return top, sections


def to_toml(problem: Problem, header: str | None = None) -> str:
    """The scenario file of ``problem`` (every key of the TOML format it uses; numbers written
    with ``repr`` so that reading the file back gives the same doubles)."""
    top, sections = _problem_tables(problem)
    lines = [f"# {ln}".rstrip() for ln in (header or "").splitlines()]
    for k, v in top.items():
        lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for head, t in sections:
        lines += ["", head]
        for k, v in t.items():
            if k in ("vertices", "waypoints", "nodes"):
                lines.append(f"{k} = {_toml_points(v)}")
            elif k == "edges":
                lines.append(f"{k} = {_toml_points(v, per_line=8, kind=int)}")
            elif k == "holes":
                rings = ",\n".join("  " + _toml_points(h, indent="    ") for h in v)
                lines.append(f"holes = [\n{rings},\n]")
            else:
                lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    return "\n".join(lines) + "\n"


def write_toml(problem: Problem, path: str | Path, header: str | None = None) -> Path:
    """Write ``problem`` as a scenario TOML file (:func:`to_toml`); returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(to_toml(problem, header), encoding="utf-8")
    return p


def write_batch(problems: Iterable[Problem], directory: str | Path) -> list[Path]:
    """Write problems (e.g. :func:`read_scen`) as ``<directory>/<name>.toml``; the paths are
    a batch for :func:`optplan.bench.run_grid`."""
    d = Path(directory)
    return [write_toml(q, d / f"{q.name}.toml") for q in problems]
