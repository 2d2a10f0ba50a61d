"""The tidy rows of a sweep: columns, one row per run (results, errors, limits), seeds and
overrides."""

from __future__ import annotations

import json
import traceback
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from optplan.benchdb import TIME_COLUMNS

#: Columns of a tidy row, in order.
COLUMNS = ("problem", "solver", "seed", "status", "success", "length", "ratio", "collisions",
           "min_clearance", "wall_time", "n_iter", "n_eval", "message", "optimum",
           "reference_time", "stop_reason", "backend", "options", "scen", "bucket", "scen_line",
           "octile_optimum", "octile_ratio", *TIME_COLUMNS)

#: the ``.scen`` columns of a row whose problem is not a ``.scen`` line
#: (:func:`optplan.bench.scen.with_scen` fills them in)
_NO_SCEN_ROW = {"scen": "", "bucket": None, "scen_line": None, "octile_optimum": float("nan"),
                "octile_ratio": float("nan")}

Overrides = Mapping[str, Mapping[str, Any]]
#: (problem, solver, seed, options, time limit)
Task = tuple[str, str, int, dict[str, Any], "float | None"]
#: (iteration, best cost, evaluations, seconds since the run started)
Trace = list[tuple[int, float, int, float]]
Record = Callable[[int, dict[str, Any], Trace, str], None]


def _seed_list(seeds: int | Iterable[int]) -> list[int]:
    if isinstance(seeds, bool):  # an int to isinstance, but neither a count nor seeds
        raise TypeError(f"seeds must be an int or an iterable of ints, got {seeds!r}")
    if isinstance(seeds, (int, np.integer)):
        if seeds < 1:
            raise ValueError(f"seeds must be >= 1, got {seeds}")
        return list(range(int(seeds)))
    out = [int(s) for s in seeds]
    if not out:
        raise ValueError("seeds is empty")
    if any(s < 0 for s in out):
        raise ValueError(f"seeds must be non-negative, got {out}")
    return out


def _overrides_for(overrides: Overrides | None, solver: str) -> dict[str, Any]:
    """Options for ``solver``: ``overrides["*"]`` then ``overrides[solver]``."""
    if not overrides:
        return {}
    for k, v in overrides.items():
        if not isinstance(v, Mapping):
            raise ValueError(f"overrides must map solver name (or '*') -> dict of options; "
                             f"got {k!r}: {v!r}")
    return {**dict(overrides.get("*", {})), **dict(overrides.get(solver, {}))}


def _num(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return float("nan")
    return v


def _json(x: Any) -> str:
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.integer, np.floating, np.bool_)):
            return o.item()
        return str(o)

    return json.dumps(x, sort_keys=True, default=default)


def row_from_result(res: Any, problem: str, solver: str, seed: int) -> dict[str, Any]:
    """The tidy row of one :class:`optplan.Result`."""
    m = res.metrics
    ratio = m.get("ratio_to_optimum")
    opt = m.get("optimum")
    return {
        "problem": problem,
        "solver": solver,
        "seed": seed,
        "status": res.status.value,
        "success": bool(res.success),
        "length": _num(m.get("length")),
        "ratio": _num(ratio) if ratio is not None else float("nan"),
        "collisions": int(m.get("collisions", 0) or 0),
        "min_clearance": _num(m.get("min_clearance")),
        "wall_time": float(res.wall_time),
        "n_iter": int(res.n_iter),
        "n_eval": int(res.n_eval),
        "message": res.message,
        "optimum": _num(opt) if opt is not None else float("nan"),
        "reference_time": _num(m.get("reference_time")),
        "stop_reason": getattr(res, "stop_reason", "") or "",
        "backend": res.backend,
        "options": _json(res.options),
        **_NO_SCEN_ROW,
        **{c: _num(m.get(c)) for c in TIME_COLUMNS},
    }


def _bare_row(problem: str, solver: str, seed: int, status: str, msg: str,
              wall_time: float = float("nan"), stop_reason: str = "") -> dict[str, Any]:
    nan = float("nan")
    return {"problem": problem, "solver": solver, "seed": seed, "status": status,
            "success": False, "length": nan, "ratio": nan, "collisions": -1,
            "min_clearance": nan, "wall_time": wall_time, "n_iter": 0, "n_eval": 0,
            "message": msg, "optimum": nan, "reference_time": nan, "stop_reason": stop_reason,
            "backend": "", "options": "", **_NO_SCEN_ROW, **dict.fromkeys(TIME_COLUMNS, nan)}


def _error_row(problem: str, solver: str, seed: int, msg: str) -> dict[str, Any]:
    return _bare_row(problem, solver, seed, "error", msg)


def _limit_row(task: Task, elapsed: float, how: str) -> dict[str, Any]:
    p, s, k, _, limit = task
    return _bare_row(p, s, k, "time_limit",
                     f"{how} after {elapsed:.3f} s: the run ignored its time limit of "
                     f"{limit:g} s", wall_time=elapsed, stop_reason="hard_limit")


def _describe(e: BaseException) -> str:
    last = traceback.extract_tb(e.__traceback__)[-1] if e.__traceback__ else None
    where = f" at {Path(last.filename).name}:{last.lineno}" if last else ""
    return f"{type(e).__name__}: {e}{where}"
