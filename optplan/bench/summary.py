"""Summaries of a sweep's rows (medians, IQRs, success rates), their Markdown table and the
CSV file."""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from optplan.bench.rows import COLUMNS, _num


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

    Returns dicts with ``problem``, ``solver``, ``runs``, ``success`` (fraction of all runs
    with status ``optimal`` or ``solved``), ``n_success``, ``errors`` (runs that raised),
    ``timeouts`` (runs stopped by the time limit, by the solver or by the harness),
    ``length_median``, ``length_iqr``, ``ratio_median``, ``ratio_iqr`` and
    ``min_clearance_median`` over the **successful** runs only (nan when there is none),
    ``collisions_median`` and ``n_eval_median`` over the runs that returned (no error, not
    stopped by the harness), ``time_median``, ``time_iqr`` (seconds) over every run that did
    not raise.
    """
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((str(r["problem"]), str(r["solver"])), []).append(r)
    return [_summary_row(p, s, rs) for (p, s), rs in groups.items()]


def _n_timeouts(rs: Sequence[Mapping[str, Any]]) -> int:
    """Runs stopped by the time limit, by the solver or by the harness."""
    return sum(r.get("stop_reason") in ("time_limit", "hard_limit")
               or r.get("status") == "time_limit" for r in rs)


def _summary_row(p: str, s: str, rs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The summary of one (problem, solver)'s rows (see :func:`summarise`)."""
    good = [r for r in rs if _truthy(r["success"])]
    returned = [r for r in rs if r.get("status") not in ("error", "time_limit")]
    timed = [r for r in rs if r.get("status") != "error"]
    length = _stats([r["length"] for r in good])
    ratio = _stats([r["ratio"] for r in good])
    tm = _stats([r["wall_time"] for r in timed])
    return {
        "problem": p,
        "solver": s,
        "runs": len(rs),
        "success": len(good) / len(rs),
        "n_success": len(good),
        "errors": sum(r.get("status") == "error" for r in rs),
        "timeouts": _n_timeouts(rs),
        "length_median": length[0],
        "length_iqr": length[1],
        "ratio_median": ratio[0],
        "ratio_iqr": ratio[1],
        "collisions_median": _stats([r["collisions"] for r in returned])[0],
        "min_clearance_median": _stats([r["min_clearance"] for r in good])[0],
        "time_median": tm[0],
        "time_iqr": tm[1],
        "n_eval_median": _stats([r["n_eval"] for r in returned])[0],
    }


def _fmt(x: Any, digits: int = 2) -> str:
    v = _num(x)
    if not math.isfinite(v):
        return "-"
    return f"{v:.{digits}f}"


def to_markdown(summary: Sequence[Mapping[str, Any]]) -> str:
    """A markdown table of :func:`summarise` output (times in milliseconds).

    Length and ratio columns are over the successful runs only ("-" when none succeeded).
    """
    head = ["problem", "solver", "runs", "success", "length median", "length IQR",
            "ratio median", "ratio IQR", "collisions median", "time median (ms)",
            "time IQR (ms)", "evals median"]
    lines = ["| " + " | ".join(head) + " |",
             "|" + "|".join(["---"] * 2 + ["---:"] * (len(head) - 2)) + "|"]
    for s in summary:
        succ = f"{100 * s['success']:.0f} %"
        notes = []
        if s.get("errors"):
            notes.append(f"{s['errors']} errors")
        if s.get("timeouts"):
            notes.append(f"{s['timeouts']} at time limit")
        if notes:
            succ += f" ({', '.join(notes)})"
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
    floats = {"length", "ratio", "min_clearance", "wall_time", "optimum", "reference_time"}
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
