"""Generic benchmark harness: problems x solvers x seeds -> tidy rows -> summary tables.

Pure functions; nothing is printed (the CLI prints).

>>> from optplan.bench import run_grid, summarise, to_markdown
>>> rows = run_grid(["open-field"], ["visgraph"], seeds=2)
>>> [r["status"] for r in rows]
['optimal', 'optimal']
>>> print(to_markdown(summarise(rows)).splitlines()[0])  # doctest: +ELLIPSIS
| problem | solver | runs | success | ...

Design choices
--------------
* **Common random numbers**: run ``k`` of every solver on a problem uses the same seed
  (``seeds[k]``), so paired comparisons between solvers see the same randomness budget.
* **Processes**: ``workers > 1`` uses a :class:`concurrent.futures.ProcessPoolExecutor` with
  the ``spawn`` start method (safe with threaded numerical libraries such as CasADi);
  ``workers = 1`` runs inline in the calling process.  Rows come back in grid order
  (problem, solver, seed) whatever the completion order.
* **Fail early on bad input**: problem and solver names and the option overrides are
  resolved in the calling process before anything runs, so a typo raises ``ValueError`` /
  :class:`optplan.ProblemError` at once.  An exception *inside* one run is recorded as a row
  with status ``error`` (and its message) instead of stopping the grid.
* **Statistics** (:func:`summarise`): medians and inter-quartile ranges (q75 - q25, numpy's
  linear interpolation) over the runs that returned a path (finite length), whatever their
  status; the ``success`` column is the fraction of runs with status ``optimal`` or ``solved``.
"""

from __future__ import annotations

import csv
import math
import multiprocessing
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["COLUMNS", "run_grid", "run_one", "summarise", "to_markdown", "write_csv",
           "read_csv"]

#: Columns of a tidy row, in order.
COLUMNS = ("problem", "solver", "seed", "status", "success", "length", "ratio", "collisions",
           "min_clearance", "wall_time", "n_iter", "n_eval", "message")

Overrides = Mapping[str, Mapping[str, Any]]


def _seed_list(seeds: int | Iterable[int]) -> list[int]:
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
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


def row_from_result(res: Any, problem: str, solver: str, seed: int) -> dict[str, Any]:
    """The tidy row of one :class:`optplan.Result`."""
    m = res.metrics
    ratio = m.get("ratio_to_optimum")
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
    }


def _error_row(problem: str, solver: str, seed: int, msg: str) -> dict[str, Any]:
    nan = float("nan")
    return {"problem": problem, "solver": solver, "seed": seed, "status": "error",
            "success": False, "length": nan, "ratio": nan, "collisions": -1,
            "min_clearance": nan, "wall_time": nan, "n_iter": 0, "n_eval": 0, "message": msg}


def run_one(problem: str, solver: str, seed: int,
            overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Solve one (problem, solver, seed) cell and return its tidy row (never raises)."""
    from optplan.solver import solve

    try:
        res = solve(problem, solver, rng=seed, reference=True, **dict(overrides or {}))
    except Exception as e:  # noqa: BLE001 - one broken run must not stop the grid
        last = traceback.extract_tb(e.__traceback__)[-1] if e.__traceback__ else None
        where = f" at {Path(last.filename).name}:{last.lineno}" if last else ""
        return _error_row(problem, solver, seed, f"{type(e).__name__}: {e}{where}")
    return row_from_result(res, problem, solver, seed)


def _check_inputs(problems: Sequence[str], solvers: Sequence[str],
                  overrides: Overrides | None) -> None:
    from optplan.catalog import load_problem
    from optplan.solver import get_solver

    if not problems:
        raise ValueError("no problems given")
    if not solvers:
        raise ValueError("no solvers given")
    for p in problems:
        load_problem(p)
    for s in solvers:
        get_solver(s, **_overrides_for(overrides, s))


def run_grid(problems: Sequence[str], solvers: Sequence[str], seeds: int | Iterable[int],
             workers: int = 1, overrides: Overrides | None = None,
             progress: Callable[[int, int, dict[str, Any]], Any] | None = None
             ) -> list[dict[str, Any]]:
    """Run every (problem, solver, seed) and return one tidy row per run.

    Parameters
    ----------
    problems : list of str
        Catalogue names or ``.toml`` paths (names, not objects, so that they travel cheaply
        to worker processes).
    solvers : list of str
        Preset names, backend names or ``.toml`` preset paths.
    seeds : int or iterable of int
        ``N`` means seeds ``0 .. N-1``.  The same seeds are used for every solver.
    workers : int
        Processes; 1 runs inline.
    overrides : dict, optional
        ``{"*": {...}, "solver-name": {...}}``: options applied to every solver (``"*"``) or
        to one solver (later wins).
    progress : callable, optional
        ``progress(done, total, row)`` after each finished run.

    Returns
    -------
    list of dict
        Rows with the keys :data:`COLUMNS`, ordered by problem, solver, seed.
    """
    problems = [str(p) for p in problems]
    solvers = [str(s) for s in solvers]
    seed_list = _seed_list(seeds)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    _check_inputs(problems, solvers, overrides)
    tasks = [(p, s, k, _overrides_for(overrides, s))
             for p in problems for s in solvers for k in seed_list]
    total = len(tasks)
    rows: list[dict[str, Any] | None] = [None] * total
    if workers == 1 or total == 1:
        for i, t in enumerate(tasks):
            rows[i] = run_one(*t)
            if progress is not None:
                progress(i + 1, total, rows[i])
    else:
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(int(workers), total), mp_context=ctx) as ex:
            futs = {ex.submit(run_one, *t): i for i, t in enumerate(tasks)}
            done = 0
            for f in as_completed(futs):
                i = futs[f]
                try:
                    rows[i] = f.result()
                except Exception as e:  # noqa: BLE001 - e.g. a worker killed by the OS
                    p, s, k, _ = tasks[i]
                    rows[i] = _error_row(p, s, k, f"{type(e).__name__}: {e}")
                done += 1
                if progress is not None:
                    progress(done, total, rows[i])
    return [r for r in rows if r is not None]


# --------------------------------------------------------------------------------------
# statistics and tables
# --------------------------------------------------------------------------------------


def _stats(values: Sequence[float]) -> tuple[float, float]:
    """Median and IQR (q75 - q25) of the finite values; (nan, nan) when none."""
    v = np.asarray([_num(x) for x in values], dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return float("nan"), float("nan")
    q25, q50, q75 = np.percentile(v, [25, 50, 75])
    return float(q50), float(q75 - q25)


def _truthy(x: Any) -> bool:
    if isinstance(x, str):
        return x.strip().lower() in ("true", "1", "yes")
    return bool(x)


def summarise(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Median / IQR / success rate per (problem, solver), in first-appearance order.

    Returns dicts with ``problem``, ``solver``, ``runs``, ``success`` (fraction),
    ``errors``, ``length_median``, ``length_iqr``, ``ratio_median``, ``ratio_iqr``,
    ``collisions_median``, ``min_clearance_median``, ``time_median``, ``time_iqr`` (seconds),
    ``n_eval_median``.
    """
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((str(r["problem"]), str(r["solver"])), []).append(r)
    out = []
    for (p, s), rs in groups.items():
        ok = [r for r in rs if r.get("status") != "error"]
        length = _stats([r["length"] for r in ok])
        ratio = _stats([r["ratio"] for r in ok])
        tm = _stats([r["wall_time"] for r in ok])
        out.append({
            "problem": p,
            "solver": s,
            "runs": len(rs),
            "success": sum(_truthy(r["success"]) for r in rs) / len(rs),
            "errors": len(rs) - len(ok),
            "length_median": length[0],
            "length_iqr": length[1],
            "ratio_median": ratio[0],
            "ratio_iqr": ratio[1],
            "collisions_median": _stats([r["collisions"] for r in ok])[0],
            "min_clearance_median": _stats([r["min_clearance"] for r in ok])[0],
            "time_median": tm[0],
            "time_iqr": tm[1],
            "n_eval_median": _stats([r["n_eval"] for r in ok])[0],
        })
    return out


def _fmt(x: Any, digits: int = 2) -> str:
    v = _num(x)
    if not math.isfinite(v):
        return "-"
    return f"{v:.{digits}f}"


def to_markdown(summary: Sequence[Mapping[str, Any]]) -> str:
    """A markdown table of :func:`summarise` output (times in milliseconds)."""
    head = ["problem", "solver", "runs", "success", "length median", "length IQR",
            "ratio median", "ratio IQR", "collisions median", "time median (ms)",
            "time IQR (ms)", "evals median"]
    lines = ["| " + " | ".join(head) + " |",
             "|" + "|".join(["---"] * 2 + ["---:"] * (len(head) - 2)) + "|"]
    for s in summary:
        succ = f"{100 * s['success']:.0f} %"
        if s.get("errors"):
            succ += f" ({s['errors']} errors)"
        cells = [
            str(s["problem"]), str(s["solver"]), str(s["runs"]), succ,
            _fmt(s["length_median"]), _fmt(s["length_iqr"]),
            _fmt(s["ratio_median"], 4), _fmt(s["ratio_iqr"], 4),
            _fmt(s["collisions_median"], 0) if math.isfinite(_num(s["collisions_median"]))
            else "-",
            _fmt(1e3 * _num(s["time_median"]), 1), _fmt(1e3 * _num(s["time_iqr"]), 1),
            _fmt(s["n_eval_median"], 0),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_csv(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write tidy rows to ``path`` (columns :data:`COLUMNS` first, then any extras)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fields = list(COLUMNS)
    for r in rows:
        for k in r:
            if k not in fields:
                fields.append(k)
    with p.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=fields, restval="")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})
    return p


def read_csv(path: str | Path) -> list[dict[str, Any]]:
    """Read rows written by :func:`write_csv` back (numbers as float/int, success as bool)."""
    ints = {"seed", "collisions", "n_iter", "n_eval"}
    floats = {"length", "ratio", "min_clearance", "wall_time"}
    out = []
    with Path(path).open(newline="", encoding="utf-8") as fh:
        for r in csv.DictReader(fh):
            row: dict[str, Any] = dict(r)
            for k in ints & row.keys():
                row[k] = int(row[k]) if row[k] not in ("", None) else 0
            for k in floats & row.keys():
                row[k] = _num(row[k])
            if "success" in row:
                row["success"] = _truthy(row["success"])
            out.append(row)
    return out
