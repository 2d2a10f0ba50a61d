"""Summaries of a sweep's rows (medians, IQRs, success rates), their Markdown table, the CSV
file, and the sweep as an OMPL benchmark database for Planner Arena (:func:`export_arena`)."""

from __future__ import annotations

import csv
import json
import math
import os
import sqlite3
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from optplan.bench.rows import COLUMNS, TIME_COLUMNS, _num


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
    ``arrival_ratio_median`` and ``arrival_lower_ratio_median`` (the arrival at the goal point
    over the reference in time and over its certified lower bound, over the successful runs
    graded in time: problems with moving obstacles; nan otherwise),
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


def _time_medians(good: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """The medians of the arrival ratios (to the reference in time, to its lower side)."""
    return {"arrival_ratio_median": _stats([_num(r.get("arrival_ratio_to_reference"))
                                            for r in good])[0],
            "arrival_lower_ratio_median": _stats([_num(r.get("arrival_ratio_to_lower"))
                                                  for r in good])[0]}


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
        **_time_medians(good),
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
    When a problem has moving obstacles, two columns more: the medians of the arrival at the
    goal point over the reference in time and over its lower bound.
    """
    head = ["problem", "solver", "runs", "success", "length median", "length IQR",
            "ratio median", "ratio IQR", "collisions median", "time median (ms)",
            "time IQR (ms)", "evals median"]
    timed = any(math.isfinite(_num(s.get("arrival_ratio_median"))) for s in summary)
    if timed:  # graded in time (moving obstacles): the arrival against the time bracket
        head += ["arrival / reference median", "arrival / lower median"]
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
        if timed:
            cells += [_fmt(s.get("arrival_ratio_median"), 4),
                      _fmt(s.get("arrival_lower_ratio_median"), 4)]
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
    floats = {"length", "ratio", "min_clearance", "wall_time", "optimum", "reference_time",
              "octile_optimum", "octile_ratio", *TIME_COLUMNS}
    out = []
    with Path(path).open(newline="", encoding="utf-8") as fh:
        for r in csv.DictReader(fh):
            row: dict[str, Any] = dict(r)
            for k in ints & row.keys():
                row[k] = int(row[k]) if row[k] not in ("", None) else 0
            for k in {"bucket", "scen_line"} & row.keys():  # empty: not a .scen line
                row[k] = int(row[k]) if row[k] not in ("", None) else None
            for k in floats & row.keys():
                row[k] = _num(row[k])
            if "success" in row:
                row["success"] = _truthy(row["success"])
            out.append(row)
    return out


# --------------------------------------------------------------------------------------
# OMPL's benchmark database (Planner Arena)
# --------------------------------------------------------------------------------------

#: OMPL's benchmark database schema (``ompl_benchmark_statistics.py``): the five tables, with
#: the columns every OMPL database has; ``runs`` and ``progress`` get one column per attribute
ARENA_SCHEMA = """
CREATE TABLE experiments (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512),
    totaltime REAL, timelimit REAL, memorylimit REAL, runcount INTEGER, version VARCHAR(128),
    hostname VARCHAR(1024), cpuinfo TEXT, date DATETIME, seed VARCHAR(24), setup TEXT);
CREATE TABLE plannerConfigs (id INTEGER PRIMARY KEY AUTOINCREMENT,
    name VARCHAR(512) NOT NULL, settings TEXT);
CREATE TABLE enums (name VARCHAR(512), value INTEGER, description TEXT,
    PRIMARY KEY (name, value));
CREATE TABLE runs (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER,
    plannerid INTEGER, {runs},
    FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
    FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
CREATE TABLE progress (runid INTEGER, time REAL, best_cost REAL, iterations INTEGER,
    evaluations INTEGER, PRIMARY KEY (runid, time),
    FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
"""

#: ``runs`` attributes: (column, SQL type, tidy-row key); OMPL's names first, then optplan's
ARENA_RUN_COLUMNS = (
    ("time", "REAL", "wall_time"), ("memory", "REAL", None), ("solved", "BOOLEAN", "success"),
    ("approximate_solution", "BOOLEAN", None), ("solution_length", "REAL", "length"),
    ("solution_clearance", "REAL", "min_clearance"), ("status", "ENUM", None),
    ("iterations", "INTEGER", "n_iter"), ("evaluations", "INTEGER", "n_eval"),
    ("certified_optimum", "REAL", "optimum"), ("ratio_to_optimum", "REAL", "ratio"),
    ("collisions", "INTEGER", "collisions"), ("reference_time", "REAL", "reference_time"),
    ("seed", "INTEGER", "seed"), ("octile_optimum", "REAL", "octile_optimum"),
    ("octile_ratio", "REAL", "octile_ratio"), ("scen_bucket", "INTEGER", "bucket"),
    ("scen_line", "INTEGER", "scen_line"), ("arrival_at_goal", "REAL", "arrival_at_goal"),
    ("time_reference", "REAL", "time_reference"),
    ("time_lower_bound", "REAL", "time_lower_bound"),
    ("arrival_ratio_to_reference", "REAL", "arrival_ratio_to_reference"),
    ("arrival_ratio_to_lower", "REAL", "arrival_ratio_to_lower"))

#: the ``status`` enum: optplan's statuses, then the harness's outcomes
ARENA_STATUS = ("optimal", "solved", "approximate", "infeasible", "failed", "error",
                "time_limit")


def _arena_real(x: Any) -> float | None:
    """A finite float, else None (OMPL stores nan and inf as NULL)."""
    v = _num(x)
    return v if math.isfinite(v) else None


def _arena_run(row: Mapping[str, Any]) -> list[Any]:
    """The ``runs`` attribute values of a tidy row, in :data:`ARENA_RUN_COLUMNS` order."""
    status = str(row.get("status", ""))
    out: list[Any] = []
    for col, sql, key in ARENA_RUN_COLUMNS:
        if col == "status":
            out.append(ARENA_STATUS.index(status) if status in ARENA_STATUS else None)
        elif col == "approximate_solution":
            out.append(int(status == "approximate"))
        elif key is None:
            out.append(None)  # memory: not measured
        elif sql == "BOOLEAN":
            out.append(int(bool(row.get(key))))
        elif sql == "INTEGER":
            out.append(None if row.get(key) is None else int(row[key]))
        else:
            out.append(_arena_real(row.get(key)))
    return out


def _arena_key(row: Mapping[str, Any], sweeps: Mapping[int, Mapping[str, Any]]
               ) -> tuple[str, str]:
    """The experiment of a run: (problem, ``optplan VERSION`` of the sweep that ran it)."""
    sweep = sweeps.get(int(row.get("experiment_id") or 0), {})
    return str(row["problem"]), f"optplan {sweep.get('optplan_version') or '0.0.0'}"


def _arena_experiments(runs: Sequence[Mapping[str, Any]],
                       sweeps: Mapping[int, Mapping[str, Any]]) -> dict[tuple[str, str], dict]:
    """One experiment per (problem, optplan version): its ``experiments`` row."""
    out: dict[tuple[str, str], dict] = {}
    for r in runs:
        sweep = sweeps.get(int(r.get("experiment_id") or 0), {})
        key = _arena_key(r, sweeps)
        machine: dict[str, Any] = sweep.get("machine") or {}
        if not isinstance(machine, dict):
            machine = {}
        limit = r["config"].get("time_limit")
        e = out.setdefault(key, {
            "name": key[0], "totaltime": 0.0, "timelimit": None, "memorylimit": None,
            "seeds": set(), "version": key[1], "hostname": machine.get("host"),
            "cpuinfo": f"{machine.get('processor') or machine.get('machine') or '?'}, "
                       f"{machine.get('cpu_count')} CPUs ({machine.get('platform')})",
            "date": sweep.get("started"), "setup": set()})
        e["totaltime"] += _arena_real(r.get("wall_time")) or 0.0
        if limit is not None:
            e["timelimit"] = max(e["timelimit"] or 0.0, float(limit))
        e["seeds"].add(int(r["seed"]))
        e["setup"].add(str(sweep.get("command_line") or ""))
    return out


def _arena_counts(runs: Sequence[Mapping[str, Any]]) -> int:
    """Runs per planner configuration of an experiment (the most any configuration has)."""
    per: dict[str, int] = {}
    for r in runs:
        per[r["solver"]] = per.get(r["solver"], 0) + 1
    return max(per.values(), default=0)


def export_arena(db: str | Path, out: str | Path) -> dict[str, int]:
    """Write a results database (``optplan bench --db``) as an OMPL benchmark database.

    The file has OMPL's schema (``experiments``, ``plannerConfigs``, ``enums``, ``runs``,
    ``progress``) and opens in Planner Arena (``plannerarena``, the benchmark browser of OMPL):
    one experiment per problem (and optplan version), one planner configuration per solver and
    its effective options, one ``runs`` row per run with OMPL's attributes (``time``,
    ``memory`` (NULL: not measured), ``solved``, ``approximate solution``, ``solution
    length``, ``solution clearance``, ``status``) and optplan's (``iterations``,
    ``evaluations``, ``certified optimum``, ``ratio to optimum``, ``collisions`` (the
    validator's, in continuous time), ``reference time``, ``seed``, and for a ``.scen`` line
    ``octile optimum``, ``octile ratio``, ``scen bucket``, ``scen line``), and the convergence
    traces in ``progress`` (``time``, ``best cost``, ``iterations``, ``evaluations``).
    NaN and infinite values are NULL, as OMPL stores them.

    Parameters
    ----------
    db : str or Path
        The results database.
    out : str or Path
        The OMPL database to write; an existing file is replaced (written to a temporary
        file first, then renamed).

    Returns
    -------
    dict
        ``experiments``, ``planners``, ``runs``, ``progress``: the rows written.

    Raises
    ------
    ValueError
        ``db`` is not a results database, has no runs (an empty file would not load in
        Planner Arena: ``no runs to export``), or is damaged (the message names the table, the
        row id, the column and the value); ``out`` is ``db`` itself, a directory or not a
        regular file.  Nothing is left behind: the temporary file is removed on any error.
    FileNotFoundError
        ``db`` does not exist.
    """
    from optplan.benchdb import read_experiments, read_progress, read_runs

    src, dst = Path(db), _arena_destination(Path(db), Path(out))
    runs = read_runs(src)
    if not runs:
        raise ValueError(f"{src}: no runs to export: the results database holds no runs "
                         f"(Planner Arena cannot open a database without experiments); run a "
                         f"sweep into it first (optplan bench ... --db {src})")
    sweeps = {int(e["id"]): e for e in read_experiments(src)}
    progress = read_progress(src)
    _decode_runs(src, runs)
    fd, name = tempfile.mkstemp(prefix=f".{dst.name}.", suffix=".tmp", dir=dst.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        con = sqlite3.connect(str(tmp))
        try:
            counts = _write_arena(con, runs, sweeps, progress)
            con.commit()
        finally:
            con.close()
        os.replace(tmp, dst)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return counts


def _arena_destination(src: Path, dst: Path) -> Path:
    """``dst`` checked before anything is read or written: not the results database, not a
    directory nor another non-file; its folder made."""
    if dst.exists() and src.exists() and dst.resolve() == src.resolve():
        raise ValueError(f"{dst}: the Planner Arena database would replace the results "
                         f"database it is made from; give another file name")
    if dst.is_dir():
        raise ValueError(f"{dst}: is a directory; give the Planner Arena database's file "
                         f"name (e.g. {dst / 'arena.db'})")
    if dst.exists() and not dst.is_file():
        raise ValueError(f"{dst}: not a regular file; give another file name")
    try:
        dst.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"{dst}: cannot make its folder {dst.parent} ({e.strerror})") from None
    return dst


def _decode_runs(src: Path, runs: list[dict[str, Any]]) -> None:
    """Add each run's sweep (``experiment_id``) and decode its JSON ``config`` and
    ``options`` (a time limit a number); a damaged value is an error naming the file, the
    table, the row id, the column and the value."""
    from optplan.benchdb import ResultsDBError, typed

    con = sqlite3.connect(f"file:{src}?mode=ro", uri=True)
    try:
        sweep_of = dict(con.execute("SELECT id, experiment_id FROM runs").fetchall())
    finally:
        con.close()
    for r in runs:
        r["experiment_id"] = typed(src, "runs", r["id"], "experiment_id",
                                   sweep_of.get(r["id"]), int)
        for col in ("config", "options"):
            raw = r[col]
            try:
                val = json.loads(raw or "{}")
            except (TypeError, ValueError):
                val = None
            limit = val.get("time_limit") if isinstance(val, dict) else None
            if not isinstance(val, dict) or not (limit is None or (
                    isinstance(limit, (int, float)) and _arena_real(limit) is not None)):
                raise ResultsDBError(f"{src}: the results database is damaged: table runs, row "
                                     f"id {r['id']}, column {col}: {raw!r} is not a JSON "
                                     f"object (with a finite number as time_limit)")
            r[col] = val


def _write_arena(con: sqlite3.Connection, runs: Sequence[dict[str, Any]],
                 sweeps: Mapping[int, Mapping[str, Any]],
                 progress: Mapping[int, Mapping[str, list[float]]]) -> dict[str, int]:
    """Fill an empty SQLite database with the OMPL tables (:func:`export_arena`)."""
    cols = ARENA_RUN_COLUMNS
    con.executescript(ARENA_SCHEMA.format(runs=", ".join(f"{c} {t}" for c, t, _ in cols)))
    con.executemany("INSERT INTO enums VALUES ('status', ?, ?)", list(enumerate(ARENA_STATUS)))
    exp_ids, planner_ids = {}, {}
    for key, e in _arena_experiments(runs, sweeps).items():
        seeds = sorted(e["seeds"])
        mine = [r for r in runs if str(r["problem"]) == key[0]]
        cur = con.execute(
            "INSERT INTO experiments (name, totaltime, timelimit, memorylimit, runcount, "
            "version, hostname, cpuinfo, date, seed, setup) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
            (e["name"], e["totaltime"], e["timelimit"], e["memorylimit"],
             _arena_counts(mine), e["version"], e["hostname"], e["cpuinfo"], e["date"],
             f"{seeds[0]}..{seeds[-1]}", "optplan bench: " + "; ".join(sorted(e["setup"]))))
        exp_ids[key] = cur.lastrowid
    n_prog = 0
    for r in runs:
        key = _arena_key(r, sweeps)
        settings = json.dumps({"backend": r["backend"], "options": r["options"]},
                              sort_keys=True)
        if (r["solver"], settings) not in planner_ids:
            cur = con.execute("INSERT INTO plannerConfigs (name, settings) VALUES (?, ?)",
                              (r["solver"], settings))
            planner_ids[(r["solver"], settings)] = cur.lastrowid
        cur = con.execute(
            f"INSERT INTO runs (experimentid, plannerid, {', '.join(c for c, _, _ in cols)}) "
            f"VALUES ({', '.join('?' * (len(cols) + 2))})",
            (exp_ids[key], planner_ids[(r["solver"], settings)], *_arena_run(r)))
        trace = progress.get(int(r["id"]), {})
        rows = [(cur.lastrowid, t, _arena_real(c), int(it), int(ne)) for t, c, it, ne in zip(
            trace.get("time", []), trace.get("best_cost", []), trace.get("iteration", []),
            trace.get("n_eval", []))]
        n_prog += con.executemany("INSERT OR IGNORE INTO progress VALUES (?, ?, ?, ?, ?)",
                                  rows).rowcount
    return {"experiments": len(exp_ids), "planners": len(planner_ids), "runs": len(runs),
            "progress": n_prog}
