"""Result, Status, History and Progress: what every solver returns (contract: docs/api.md)."""

from __future__ import annotations

import enum
import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Status", "Result", "History", "Progress", "notify", "ResultFileError",
           "SCHEMA_VERSION", "OPTIMAL_REL_TOL", "optimum_gap", "confirms_optimum"]

#: Version of the Result JSON layout written by :meth:`Result.save`.
SCHEMA_VERSION = 1

#: The one tolerance of ``optimal``: a path is confirmed optimal when its length is at most
#: ``optimum * (1 + OPTIMAL_REL_TOL)``, the optimum being the certified one of
#: :mod:`optplan.geometry.tangent.tangent_graph`.  1e-9 is round-off: the NLP reaches it (gaps
#: <= 1e-12) wherever its polyline can represent the optimum (docs/api.md, "Status").
OPTIMAL_REL_TOL = 1e-9


def optimum_gap(length: float, optimum: float) -> float:
    """Relative excess ``length / optimum - 1`` of a path over the certified optimum.

    Parameters
    ----------
    length, optimum : float
        Path length and certified optimum (map units).

    Returns
    -------
    float
        The gap (0 for two zero lengths, ``inf`` for a positive length over a zero optimum).
    """
    if optimum > 0:
        return float(length) / float(optimum) - 1.0
    return 0.0 if length <= 0 else math.inf


def confirms_optimum(length: float, optimum: float | None,
                     rel_tol: float = OPTIMAL_REL_TOL) -> bool:
    """True when the certified ``optimum`` confirms ``length`` (``optimal``'s one test).

    Parameters
    ----------
    length : float
        Length of the path whose claim is checked (map units).
    optimum : float or None
        The certified optimum of the same robot on the same map (``None``: there is none).
    rel_tol : float
        Relative tolerance, default :data:`OPTIMAL_REL_TOL`.

    Returns
    -------
    bool
        ``length <= optimum * (1 + rel_tol)`` for a finite optimum, else False.
    """
    if optimum is None or not math.isfinite(optimum) or not math.isfinite(length):
        return False
    return float(length) <= float(optimum) * (1.0 + rel_tol)


class ResultFileError(ValueError):
    """A result file (or dict) is malformed; the message names the file and the key."""


class Status(enum.StrEnum):
    """Outcome of a solve.

    ``optimal``: certified globally optimal: the certified optimum (the exact tangent graph)
    confirms the path's length within :data:`OPTIMAL_REL_TOL`, *and* the validator accepts it.
    ``solved``: feasible (validator) but not certified.
    ``approximate``: something was returned, but it is infeasible or does not reach the goal.
    ``infeasible``: proven infeasible.  ``failed``: nothing usable (e.g. a collision in a
    simulation, a numerical failure).
    """

    optimal = "optimal"
    solved = "solved"
    approximate = "approximate"
    infeasible = "infeasible"
    failed = "failed"

    def __str__(self) -> str:  # print(res.status) -> "optimal"
        return self.value


class History:
    """Per-iteration columns (``iteration``, ``best_cost``, ``n_eval``, ``time`` + extras).

    ``hist.append(iteration=3, best_cost=1.0, ...)`` adds a row; ``hist["best_cost"]`` returns a
    numpy array.  Missing values in a row are stored as ``nan``.
    """

    def __init__(self, columns: dict[str, list] | None = None):
        self._cols: dict[str, list] = {k: list(v) for k, v in (columns or {}).items()}
        self._n = max((len(v) for v in self._cols.values()), default=0)

    def append(self, **row: Any) -> None:
        for k in row:
            if k not in self._cols:
                self._cols[k] = [np.nan] * self._n
        for k, col in self._cols.items():
            col.append(row.get(k, np.nan))
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._cols:
            raise KeyError(f"history has no column {key!r}; columns: {sorted(self._cols)}")
        return np.asarray(self._cols[key])

    def __contains__(self, key: object) -> bool:
        return key in self._cols

    def keys(self) -> list[str]:
        return list(self._cols)

    def to_dict(self) -> dict[str, list]:
        return {k: [_jsonable(x) for x in v] for k, v in self._cols.items()}

    def __repr__(self) -> str:
        return f"History({self._n} rows; columns={self.keys()})"


@dataclass(frozen=True)
class Progress:
    """What ``callback`` receives every iteration / step."""

    iteration: int
    best_cost: float
    n_eval: int
    elapsed: float
    """Wall-clock seconds since the backend started (every backend)."""
    info: dict = field(default_factory=dict)
    sim_time: float | None = None
    """Simulated time (s) of time-stepping backends (potential fields, formations, hybrid)."""


def notify(callback: Callable[[Progress], Any] | None, progress: Progress) -> bool:
    """Call ``callback``; return True when it asked to stop by raising ``StopIteration``."""
    if callback is None:
        return False
    try:
        callback(progress)
    except StopIteration:
        return True
    return False


@dataclass(frozen=True)
class Result:
    """The outcome of :func:`optplan.solve` (every field is described in docs/api.md, "Results")."""

    status: Status
    paths: dict[str, np.ndarray]
    metrics: dict[str, Any]
    solver: str
    backend: str
    options: dict[str, Any]
    seed: int | None
    problem: str = ""
    times: np.ndarray | None = None
    cost: float = float("nan")
    n_iter: int = 0
    n_eval: int = 0
    wall_time: float = 0.0
    message: str = ""
    history: History = field(default_factory=History)
    extras: dict[str, Any] = field(default_factory=dict)
    stop_reason: str = ""
    """Why the run stopped early: ``"time_limit"``, ``"callback"``, or ``""`` (it finished)."""
    scenario: Any = field(default=None, repr=False, compare=False)
    """The problem that was solved (a :class:`optplan.Problem`, or its scenario table after
    :meth:`load`), embedded in the JSON so that plots redraw the map that was solved."""

    def scenario_problem(self):
        """The solved :class:`optplan.Problem` (from the embedded scenario), or ``None``."""
        from optplan.problem import Problem, parse_problem

        if isinstance(self.scenario, Problem):
            return self.scenario
        if isinstance(self.scenario, dict):
            return parse_problem(self.scenario, f"<scenario embedded in result {self.problem}>")
        return None

    @property
    def success(self) -> bool:
        return self.status in (Status.optimal, Status.solved)

    @property
    def path(self) -> np.ndarray:
        """The leader's (or single robot's) path."""
        key = self.metrics.get("leader") or next(iter(self.paths))
        return self.paths[key]

    def summary(self) -> str:
        m = self.metrics
        parts = [f"status {self.status.value}", f"length {m.get('length', float('nan')):.4f}"]
        if m.get("ratio_to_optimum") is not None:
            parts.append(f"ratio to optimum {m['ratio_to_optimum']:.4f}")
        parts.append(f"collisions {m.get('collisions', '?')}")
        parts.append(f"time {self.wall_time * 1e3:.1f} ms")
        return f"{self.problem} / {self.solver}: " + ", ".join(parts)

    # -- JSON round trip -------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "schema": SCHEMA_VERSION,
            "status": self.status.value,
            "problem": self.problem,
            "solver": self.solver,
            "backend": self.backend,
            "options": _jsonable(self.options),
            "seed": self.seed,
            "paths": {k: np.asarray(v).tolist() for k, v in self.paths.items()},
            "times": None if self.times is None else np.asarray(self.times).tolist(),
            "cost": _jsonable(self.cost),
            "metrics": _jsonable(self.metrics),
            "n_iter": self.n_iter,
            "n_eval": self.n_eval,
            "wall_time": self.wall_time,
            "message": self.message,
            "stop_reason": self.stop_reason,
            "scenario": _scenario_dict(self.scenario),
            "history": self.history.to_dict(),
            "extras": _jsonable(self.extras),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "<result>") -> Result:
        """Rebuild a Result from :meth:`to_dict` output, validating every field.

        Raises
        ------
        ResultFileError
            Naming ``where`` (the file) and the offending key.
        """
        d = _check_result_dict(d, where)
        return cls(
            status=Status(d["status"]),
            paths={k: np.asarray(v, dtype=float).reshape(-1, 2)
                   for k, v in d["paths"].items()},
            times=None if d.get("times") is None else np.asarray(d["times"], dtype=float),
            metrics=_unjson(d.get("metrics", {})),
            solver=d["solver"],
            backend=d["backend"],
            options=d.get("options", {}),
            seed=d.get("seed"),
            problem=d.get("problem", ""),
            cost=_unjson(d.get("cost")),
            n_iter=d.get("n_iter", 0),
            n_eval=d.get("n_eval", 0),
            wall_time=d.get("wall_time", 0.0),
            message=d.get("message", ""),
            stop_reason=d.get("stop_reason", ""),
            scenario=d.get("scenario"),
            history=History({k: _unjson(v) for k, v in d.get("history", {}).items()}),
            extras=_unjson(d.get("extras", {})),
        )

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=1), encoding="utf-8")

    @classmethod
    def load(cls, path: str | Path) -> Result:
        """Read a result saved by :meth:`save`; raises :class:`ResultFileError` naming the
        file and the key for anything malformed (unreadable, not JSON, wrong schema, shapes,
        types, lengths)."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as e:
            raise ResultFileError(f"{p}: cannot read file ({e.strerror or e})") from None
        except UnicodeDecodeError as e:
            raise ResultFileError(f"{p}: not UTF-8 text ({e.reason} at byte {e.start})") from None
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise ResultFileError(f"{p}: invalid JSON ({e.msg} at line {e.lineno}, column "
                                  f"{e.colno})") from None
        except RecursionError:
            raise ResultFileError(f"{p}: JSON nested too deeply") from None
        return cls.from_dict(data, str(p))


_NONFINITE = ("nan", "inf", "-inf")
#: Metrics that are numbers in every result (validated on load).
_NUMERIC_METRICS = ("length", "optimum", "ratio_to_optimum", "min_clearance",
                    "min_clearance_dynamic", "collisions", "static_collisions",
                    "dynamic_contacts", "separation_violations", "penetration", "min_separation",
                    "formation_rmse", "reference_time")


_Err = Callable[[str, str], "ResultFileError"]


def _check_header(d: Any, err: _Err) -> None:
    """A JSON object of a readable schema, the required keys, a known status, string keys."""
    if not isinstance(d, dict):
        raise err("<root>", f"expected a JSON object, got {type(d).__name__}")
    schema = d.get("schema", SCHEMA_VERSION)
    if isinstance(schema, bool) or not isinstance(schema, int) or schema > SCHEMA_VERSION:
        raise err("schema", f"unsupported result schema {schema!r} (this optplan reads "
                  f"<= {SCHEMA_VERSION})")
    for key in ("status", "solver", "backend", "paths"):
        if key not in d:
            raise err(key, "missing required key")
    if d["status"] not in {s.value for s in Status}:
        raise err("status", f"unknown status {d['status']!r} (allowed: "
                  + ", ".join(s.value for s in Status) + ")")
    for key in ("solver", "backend", "problem", "message", "stop_reason"):
        if key in d and not isinstance(d[key], str):
            raise err(key, f"expected a string, got {type(d[key]).__name__}")


def _check_paths(paths: Any, err: _Err) -> set[int]:
    """A non-empty object robot id -> finite ``(n, 2)`` points; the set of the ``n``."""
    if not isinstance(paths, dict) or not paths:
        raise err("paths", "expected a non-empty object robot id -> list of [x, y]")
    n_pts = set()
    for rid, v in paths.items():
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise err(f"paths.{rid}", "expected a list of [x, y] numbers") from None
        if a.ndim != 2 or a.shape[1] != 2 or len(a) == 0:
            raise err(f"paths.{rid}", f"expected shape (n >= 1, 2), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise err(f"paths.{rid}", "non-finite coordinates")
        n_pts.add(len(a))
    return n_pts


def _check_times(times: Any, n_pts: set[int], err: _Err) -> None:
    """None, or one number per path point."""
    if times is None:
        return
    try:
        t = np.asarray(times, dtype=float)
    except (TypeError, ValueError):
        raise err("times", "expected a list of numbers") from None
    if t.ndim != 1 or n_pts != {len(t)}:
        raise err("times", f"expected one time stamp per path point ({sorted(n_pts)}), got "
                  f"shape {t.shape}")


def _check_containers(d: dict, err: _Err) -> None:
    """Objects where objects belong, counts, and the wall time."""
    if d.get("scenario") is not None and not isinstance(d["scenario"], dict):
        raise err("scenario", f"expected an object (a scenario table), got "
                  f"{type(d['scenario']).__name__}")
    for key in ("metrics", "options", "history", "extras"):
        if key in d and not isinstance(d[key], dict):
            raise err(key, f"expected an object, got {type(d[key]).__name__}")
    for key in ("n_iter", "n_eval"):
        if key in d and (isinstance(d[key], bool) or not isinstance(d[key], int)
                         or d[key] < 0):
            raise err(key, f"expected a non-negative integer, got {d[key]!r}")
    wt = d.get("wall_time", 0.0)
    if isinstance(wt, bool) or not isinstance(wt, (int, float)) or not (0 <= wt < math.inf):
        raise err("wall_time", f"expected a finite number of seconds >= 0, got {wt!r}")


def _number_like(v: Any) -> bool:
    """A JSON number, or one of the strings NaN / inf are stored as."""
    return (not isinstance(v, bool) and isinstance(v, (int, float))) or v in _NONFINITE


def _check_numbers(d: dict, err: _Err) -> None:
    """The cost, the numeric metrics and the seed."""
    if "cost" in d and d["cost"] is not None and not _number_like(d["cost"]):
        raise err("cost", f"expected a number, got {d['cost']!r}")
    metrics = d.get("metrics")
    for k, v in (metrics.items() if isinstance(metrics, dict) else ()):
        if k in _NUMERIC_METRICS and not _number_like(v):
            raise err(f"metrics.{k}", f"expected a number, got {v!r}")
    if "seed" in d and d["seed"] is not None and (isinstance(d["seed"], bool)
                                                  or not isinstance(d["seed"], int)):
        raise err("seed", f"expected an integer or null, got {d['seed']!r}")


def _check_result_dict(d: Any, where: str) -> dict[str, Any]:
    """Validate the layout of a result dict (schema version, keys, types, shapes, lengths)."""

    def err(key: str, msg: str) -> ResultFileError:
        return ResultFileError(f"{where}: {key}: {msg}")

    _check_header(d, err)
    n_pts = _check_paths(d["paths"], err)
    _check_times(d.get("times"), n_pts, err)
    _check_containers(d, err)
    _check_numbers(d, err)
    hist = d.get("history", {})
    lens = {len(v) for v in hist.values() if isinstance(v, list)}
    if any(not isinstance(v, list) for v in hist.values()) or len(lens) > 1:
        raise err("history", "expected columns of equal length")
    return d


def _scenario_dict(scenario: Any) -> dict | None:
    from optplan.problem import Problem, problem_to_dict

    if isinstance(scenario, Problem):
        return problem_to_dict(scenario)
    return scenario if isinstance(scenario, dict) else None


def _jsonable(x: Any) -> Any:
    """Convert numpy / dataclass / enum values into JSON-friendly ones (nan -> 'nan')."""
    if isinstance(x, enum.Enum):
        return x.value
    if is_dataclass(x) and not isinstance(x, type):
        return _jsonable(asdict(x))
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.bool_, bool)):
        return bool(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        f = float(x)
        if f != f:
            return "nan"
        if f in (float("inf"), float("-inf")):
            return "inf" if f > 0 else "-inf"
        return f
    return x


def _unjson(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _unjson(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_unjson(v) for v in x]
    if x == "nan":
        return float("nan")
    if x == "inf":
        return float("inf")
    if x == "-inf":
        return float("-inf")
    return x
