"""The Solver interface: registry, presets, :func:`solve` (the API contract, docs/api.md).

A *backend* is an implementation: a frozen, keyword-only dataclass in its family's package
(``optplan/exact/``, ``swarm/``, ``potential/``, ``formation/``, ``hybrid/``)
whose fields are its options, with a ``solve(problem, /, *, rng, init, callback)`` method.
A *solver* is a named, configured backend: a preset in ``solvers/NAME.toml``.

Backends are registered lazily as ``"module:Class"`` strings; nothing heavy is imported until
a backend is used.  A backend whose module is not present is simply not listed.

Writing a backend (a subclass of :class:`Backend` with ``option(...)`` fields, ``check`` and
``solve``, added to :data:`BACKENDS` or by :func:`register`): docs/adding-a-solver.md.

Plugins: an installed distribution declares backends in the entry-point group
``optplan.backends`` (``my-planner = "my_pkg.planner:MyPlanner"``) and presets in
``optplan.presets`` (``my_pkg = "my_pkg.presets"``: a package whose directory holds preset
``*.toml`` files).  They are discovered lazily, the first time the registry is used, in every
process (so they also work in the CLI and in ``optplan bench`` worker processes).  A backend
added with :func:`register` exists in the calling process, and :mod:`optplan.bench` passes it on
to its workers; another process (the CLI) does not know it.  A plugin that is malformed, is
missing a module, class or dependency, names what is not a :class:`Backend` subclass, raises
(or exits) when imported, or ships a preset naming an unknown backend is reported once
(:class:`optplan.catalog.PluginWarning`) and leaves everything else working; asking for it by
name raises ``ImportError`` (a backend) or ``ValueError`` (a preset) with the same text.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib
import importlib.util
import math
import time
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from optplan.backend import Backend
from optplan.catalog import BACKEND_GROUP as BACKEND_GROUP
from optplan.catalog import PRESET_GROUP as PRESET_GROUP
from optplan.catalog import (
    broken_backend,
    check_entry,
    discover_backends,
    import_failed,
    interrupted,
    load_failed,
    load_problem,
    plugin_origin,
    preset_failed,
    preset_files,
    preset_origin,
    read_preset,
)
from optplan.catalog import plugin_preset_files as plugin_preset_files
from optplan.goal_completion import completion_length
from optplan.mapf_grading import with_sum_reference
from optplan.options import option
from optplan.problem import Problem
from optplan.result import Progress, Result, Status
from optplan.team_grading import with_team_reference
from optplan.time_grading import with_time_reference

__all__ = [
    "BACKENDS",
    "Backend",
    "register",
    "get_solver",
    "list_solvers",
    "list_backends",
    "solve",
    "make_rng",
    "option",
    "without_own_limit",
]

#: backend name -> "module:Class" (resolved lazily).
BACKENDS: dict[str, str] = {
    "visgraph": "optplan.exact.visgraph:VisGraph",
    "sipp": "optplan.exact.sipp:SIPP",
    "time-bracket": "optplan.exact.time_bracket:TimeBracket",
    "ccbs": "optplan.exact.ccbs:CCBS",
    "pso": "optplan.swarm.pso:PSO",
    "mpso": "optplan.swarm.mpso:MPSO",
    "ipso": "optplan.swarm.ipso:IPSO",
    "nlp": "optplan.exact.nlp:WaypointNLP",
    "apf": "optplan.potential.apf:APF",
    "sa-apf": "optplan.potential.sa_apf:SAAPF",
    "leader-follower": "optplan.formation.leader_follower:LeaderFollower",
    "formation-qp": "optplan.formation.formation_qp:FormationQP",
    "formation-nlp": "optplan.formation.formation_nlp:FormationNLP",
    "orca": "optplan.formation.orca:ORCA",
    "hybrid": "optplan.hybrid.planner:Hybrid",
}


_plugins: dict[str, Any] = {}

#: The one clock of every deadline (seconds, monotonic): :func:`solve` starts the
#: ``time_limit`` on it and its callback wrapper reads it at every poll of a backend (backends
#: see the deadline only through ``callback``).  Tests replace it
#: (``monkeypatch.setattr(optplan.solver, "clock", fake)``, e.g. with ``time.process_time``)
#: to bound overruns without depending on the machine's load (docs/api.md, "Time limits").
clock: Callable[[], float] = time.perf_counter


def _discover() -> None:
    """Register the backends of installed plugin distributions (once per process)."""
    if "done" in _plugins:
        return
    _plugins["done"] = True
    conflicts = discover_backends(BACKENDS)
    if conflicts:
        _plugins.setdefault("conflicts", []).extend(conflicts)


def all_preset_files() -> dict[str, Path]:
    """Shipped presets, then plugin presets (a shipped name wins)."""
    return {**plugin_preset_files(), **preset_files()}


def register(name: str, entry_point: str) -> None:
    """Register a backend ``name -> "module:Class"``.

    Raises
    ------
    ValueError
        On a name collision, or an entry point not of the form ``package.module:Class``.
    """
    why = check_entry(entry_point)
    if why is not None:
        raise ValueError(f"register({name!r}, ...): {why}")
    if name in BACKENDS and BACKENDS[name] != entry_point:
        raise ValueError(f"backend {name!r} is already registered as {BACKENDS[name]!r}")
    BACKENDS[name] = entry_point


def _available(name: str) -> bool:
    """Whether the module of backend ``name`` exists (without importing the module itself).

    A plugin backend whose module cannot be found, or whose package raises (or exits) when
    imported, is reported (:func:`optplan.catalog.import_failed`) and counts as absent; a
    shipped backend whose module is not present is simply absent.
    """
    if broken_backend(name):
        return False
    entry = BACKENDS[name]
    mod = entry.split(":")[0]
    plugin = plugin_origin(name) is not None
    try:
        found = importlib.util.find_spec(mod) is not None
        if plugin and not found:
            raise ModuleNotFoundError(f"No module named {mod!r}", name=mod)
    except BaseException as e:  # noqa: BLE001 - a plugin's package raised when imported
        if interrupted(e):
            raise
        if plugin or not isinstance(e, ModuleNotFoundError):
            import_failed(name, entry, e)
        return False
    return found


def list_backends() -> list[str]:
    """Backend names whose implementation is present (plugins included)."""
    _discover()
    return [n for n in BACKENDS if _available(n)]


def _unknown_backend(name: str) -> str:
    close = difflib.get_close_matches(name, list(BACKENDS), n=3)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    return f"unknown backend {name!r}{hint} (backends: {', '.join(BACKENDS)})"


def _preset_data(path: Path) -> dict[str, Any]:
    """Read the preset ``path`` and check that its backend is registered."""
    try:
        data = read_preset(path)
        backend = data["backend"]
        if backend not in BACKENDS and not broken_backend(backend):
            raise ValueError(f"{path}: backend: {_unknown_backend(backend)}")
    except ValueError as e:
        if preset_origin(path) is None:
            raise
        raise ValueError(preset_failed(path, e)) from None
    return data


def list_solvers(backends: bool = False) -> list[str]:
    """Preset names whose backend is present (and bare backend names with ``backends=True``).

    A plugin preset that cannot be read or names an unknown backend is reported once and not
    listed.
    """
    _discover()
    out = []
    for name, path in all_preset_files().items():
        try:
            b = _preset_data(path)["backend"]
        except ValueError:
            continue
        if b in BACKENDS and _available(b):
            out.append(name)
    if backends:
        out += list_backends()
    return out


class _BadEntry(ImportError):
    """An entry point whose module has no such attribute, or whose object is not a
    :class:`Backend` subclass."""


def _import_class(entry: str) -> type[Backend]:
    """Import the ``module:Class`` ``entry`` and check that it is a :class:`Backend` subclass."""
    mod, cls = entry.split(":")
    module = importlib.import_module(mod)
    if not hasattr(module, cls):
        raise _BadEntry(f"module {mod!r} has no {cls!r}")
    obj = getattr(module, cls)
    if not (isinstance(obj, type) and issubclass(obj, Backend)):
        what = (f"the module {obj.__name__!r}" if isinstance(obj, types.ModuleType)
                else f"the class {obj.__qualname__!r}" if isinstance(obj, type)
                else f"an object of type {type(obj).__name__!r}")
        raise _BadEntry(f"{cls!r} is {what}, not a subclass of optplan.Backend")
    return obj


def _load_error(name: str, entry: str, e: BaseException) -> Exception:
    """The error to raise when loading the backend ``name`` (``entry``) raised ``e``: an
    ``ImportError`` naming the plugin distribution and the entry point (reported once), or for
    a backend that is not a plugin's, one naming the missing package."""
    if plugin_origin(name) is None and isinstance(e, ModuleNotFoundError) and e.name:
        if e.name.split(".")[0] != "optplan":
            return ImportError(f"backend {name!r} needs the package {e.name!r}: pip install "
                               f"{e.name}")
        return ValueError(f"backend {name!r} is registered but not implemented in this build")
    if isinstance(e, _BadEntry):
        return ImportError(load_failed(name, entry, str(e)))
    return ImportError(import_failed(name, entry, e))


def _load_class(name: str) -> type[Backend]:
    _discover()
    broken = broken_backend(name)
    if broken:
        raise ImportError(broken)
    if name not in BACKENDS:
        raise ValueError(_unknown_backend(name))
    entry = BACKENDS[name]
    try:
        return _import_class(entry)
    except BaseException as e:  # noqa: BLE001 - a plugin's module raised (or exited)
        if interrupted(e):
            raise
        raise _load_error(name, entry, e) from e


def _check_names(cls: type[Backend], options: dict[str, Any], where: str) -> None:
    """Raise ``ValueError`` naming ``where`` for option names ``cls`` does not have."""
    fields = {f.name for f in dataclasses.fields(cls)
              if f.init and not f.name.startswith("_") and f.name != "preset"}
    for k in options:
        if k not in fields:
            close = difflib.get_close_matches(k, list(fields), n=2)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise ValueError(
                f"{where}: unknown option {k!r} for backend {cls.name!r}{hint} "
                f"(valid: {', '.join(sorted(fields))})"
            )


def _apply_options(cls: type[Backend], options: dict[str, Any], where: str,
                   preset: str | None) -> Backend:
    _check_names(cls, options, where)
    try:
        return cls(**options, preset=preset)
    except (ValueError, TypeError) as e:
        raise ValueError(f"{where}: {e}") from None


def get_solver(spec: str | Path | Backend, **overrides: Any) -> Backend:
    """Resolve a solver: a ``Backend`` object, a ``.toml`` path, a preset name or a backend name.

    ``overrides`` replace options; unknown names raise ``ValueError`` listing the valid ones.
    """
    if isinstance(spec, Backend):
        if overrides:
            _apply_options(type(spec), overrides, "override", None)  # validates names
            return dataclasses.replace(spec, **overrides)  # keeps spec.preset
        return spec
    s = str(spec)
    path = Path(s)
    if s.endswith(".toml"):
        if not path.is_file():
            raise ValueError(f"{s}: no such preset file")
        data, where, preset = _preset_data(path), str(path), path.stem
    else:
        _discover()
        presets = all_preset_files()
        if s in presets:
            data, where, preset = _preset_data(presets[s]), str(presets[s]), s
        elif s in BACKENDS:
            data, where, preset = {"backend": s, "options": {}}, f"backend {s}", None
        else:
            if broken_backend(s):
                raise ImportError(broken_backend(s))
            names = list(dict.fromkeys([*presets, *BACKENDS]))
            close = difflib.get_close_matches(s, names, n=3)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise ValueError(f"unknown solver {s!r}{hint} (see optplan.list_solvers())")
    cls = _load_class(data["backend"])
    _check_names(cls, data["options"], where)
    _check_names(cls, overrides, "override")
    opts = {**data["options"], **overrides}
    if overrides:
        where += f" with overrides {sorted(overrides)}"
    return _apply_options(cls, opts, where, preset)


def make_rng(rng: int | np.random.Generator | None) -> tuple[np.random.Generator, int | None]:
    """Turn the ``rng`` argument into a Generator and the seed to record.

    ``int`` -> that seed; ``None`` -> a fresh seed drawn from OS entropy and recorded;
    ``Generator`` -> used as is (seed recorded as ``None``).
    """
    if isinstance(rng, np.random.Generator):
        return rng, None
    if rng is None:
        entropy = np.random.SeedSequence().entropy  # numpy types it int | Sequence[int] | None
        assert isinstance(entropy, int), "a SeedSequence drawn from OS entropy has an int one"
        seed = int(entropy % (2**63))
        return np.random.default_rng(seed), seed
    if isinstance(rng, (bool, float)) or not isinstance(rng, (int, np.integer)) or rng < 0:
        raise ValueError(f"rng must be a non-negative int, a numpy Generator or None, got {rng!r}")
    return np.random.default_rng(int(rng)), int(rng)


# --------------------------------------------------------------------------------------
# the front door
# --------------------------------------------------------------------------------------


def reference_optimum(problem: Problem) -> dict[str, Any]:
    """The certified optimum of the planned robot on the known static map, cached per problem.

    Returns ``{"optimum": float or None, "reference_time": s, "reference_error": str or None}``:
    the exact length of the tangent-graph shortest path
    (:mod:`optplan.geometry.tangent.tangent_graph`) when it is certified, else ``None`` with the
    reason.  The time is that of the first computation (0 when cached).
    """
    from optplan.geometry.tangent import problem_shortest_path

    fresh: list[bool] = []

    def build() -> dict[str, Any]:
        fresh.append(True)
        t0 = time.perf_counter()
        res = problem_shortest_path(problem, problem.leader, known_only=True)
        err = None
        if res.polyline is None:
            err = res.info.get("reason", "no path")
        elif not res.info.get("certified"):  # only on a set built without walls
            err = "the shortest path is not certified"
        return {"optimum": res.length if err is None else None,
                "reference_time": time.perf_counter() - t0, "reference_error": err}

    out = problem.memo(("reference_optimum",), build)
    return dict(out) if fresh else {**out, "reference_time": 0.0}


#: Largest number of points accepted in one ``init`` path.
MAX_INIT_POINTS = 100_000


def check_init(problem: Problem, init: Any) -> dict[str, np.ndarray]:
    """Validate ``solve``'s ``init``: ``robot id -> (n, 2)`` finite arrays (a bare array means
    the leader), 1 <= n <= :data:`MAX_INIT_POINTS`, coordinates the geometry core can resolve.

    Raises
    ------
    ValueError
        Naming ``init[robot id]``, the value's shape or problem and the allowed form.
    """
    if not isinstance(init, dict):
        init = {problem.leader.id: init}
    out = {}
    ids = problem.robot_ids
    for k, v in init.items():
        key = f"init[{k!r}]"
        if k not in ids:
            raise ValueError(f"{key}: problem {problem.name!r} has no robot {k!r} "
                             f"(robots: {', '.join(ids)})")
        try:
            raw = np.asarray(v)
            if raw.dtype.kind not in "iuf":  # complex, bool, strings, objects
                raise TypeError
            a = raw.astype(float)
        except (TypeError, ValueError):
            what = getattr(getattr(v, "dtype", None), "name", None) or type(v).__name__
            raise ValueError(f"{key}: expected an (n, 2) array of real numbers, got "
                             f"{what}") from None
        if a.ndim != 2 or a.shape[1] != 2 or not 1 <= len(a) <= MAX_INIT_POINTS:
            raise ValueError(f"{key}: expected shape (n, 2) with 1 <= n <= {MAX_INIT_POINTS}, "
                             f"got {a.shape}")
        if not np.all(np.isfinite(a)):
            bad = np.argwhere(~np.isfinite(a))[0]
            raise ValueError(f"{key}: non-finite coordinate at row {bad[0]} ({a[tuple(bad)]})")
        ext = float(np.max(np.abs(problem.frame.local(a))))
        try:
            problem.frame.check_extent(ext, key)
        except ValueError as e:
            raise ValueError(str(e)) from None
        out[k] = a
    return out


def with_reference(metrics: dict[str, Any], problem: Problem, paths: dict[str, Any],
                   ref: dict[str, Any]) -> dict[str, Any]:
    """``metrics`` plus what a reference (:func:`reference_optimum`) adds: ``reference_time``,
    and ``optimum`` with ``ratio_to_optimum`` or ``reference_error``; a run that ends inside the
    goal tolerance, off the goal point, also gets ``goal_completion`` and ``length_to_goal``
    (:mod:`optplan.goal_completion`), and its ratio is ``length_to_goal / optimum``."""
    out = dict(metrics)
    out["reference_time"] = ref["reference_time"]
    lead = problem.leader.id
    if ref["optimum"] is not None and "length" in out and lead in paths:
        out["optimum"] = ref["optimum"]
        # a run accepted inside the goal tolerance is graded at the goal point
        done = completion_length(problem, lead, paths[lead])
        if done:
            out["goal_completion"] = done
            out["length_to_goal"] = out["length"] + done
        out["ratio_to_optimum"] = out.get("length_to_goal", out["length"]) / ref["optimum"]
    elif ref["reference_error"] is not None:
        out["reference_error"] = ref["reference_error"]
    return out


def team_reference(problem: Problem) -> dict[str, Result]:
    """The candidate plans of ``reference="team"``: the ``formation-nlp`` preset's
    ``team_candidates`` (the team heuristics and the NLP polished from each), whose front
    grades every plan of the problem (:func:`optplan.team_grading.with_team_reference`)."""
    backend: Any = get_solver("formation-nlp")  # optplan.formation.formation_nlp.FormationNLP
    return backend.team_candidates(problem)


def sum_reference(problem: Problem) -> Result:
    """The team plan that grades the sum of arrivals of robots with their own goals under
    ``reference="team"``: the ``ccbs`` preset's (the optimal sum within its roadmap model;
    :func:`optplan.mapf_grading.with_sum_reference`)."""
    return get_solver("ccbs").solve(problem)


def time_reference(problem: Problem, robot_id: str) -> Any:
    """The reference in time of ``reference=True``: the ``time-bracket`` preset's bracket on
    ``robot_id``'s earliest arrival at its grading level (deterministic: no time limit), its
    plan's arrival the upper side and its ``bound`` the lower side
    (:func:`optplan.time_grading.with_time_reference`)."""
    backend: Any = get_solver("time-bracket")  # optplan.exact.time_bracket.TimeBracket
    return backend.reference(problem, robot_id)


def without_own_limit(backend: Backend, time_limit: float | None) -> Backend:
    """``backend`` without its own ``time_limit`` (hybrid presets: 60 s) when the caller has
    one (``solve(time_limit=...)``, a run that solves it as one of its stages): the caller's
    limit then bounds it, not the preset's.  ``backend`` itself when ``time_limit`` is None
    or the backend has no such option."""
    if time_limit is None or "time_limit" not in {f.name for f in dataclasses.fields(backend)}:
        return backend
    out = object.__new__(type(backend))  # a copy: no new checks or stages (within the limit)
    return out.__dict__.update(vars(backend), time_limit=None) or out


def _stop_outcome(res: Result, reason: str, wall: float) -> tuple[Status, str]:
    """``res``'s status and message; after a stop by ``solve``'s callback or limit (``reason``)
    ``solved`` iff its best path is feasible and reaches the goal, and what stopped it."""
    if not reason:
        return res.status, res.message
    m, what = res.metrics, "time limit" if reason == "time_limit" else "callback"
    return (Status.solved if (m.get("feasible") and m.get("reached")) else Status.approximate,
            (f"stopped by the {what} after {wall:.3f} s; " + res.message).rstrip("; "))


def solve(problem: Problem | str, solver: str | Path | Backend, /, *,
          rng: int | np.random.Generator | None = None,
          init: dict[str, np.ndarray] | np.ndarray | None = None,
          callback: Callable[[Progress], Any] | None = None,
          time_limit: float | None = None,
          reference: bool | str = False,
          **overrides: Any) -> Result:
    """Solve ``problem`` with ``solver`` and grade the result with the shared validator.

    Parameters
    ----------
    problem : Problem or str
        A :class:`Problem` or a catalogue name / ``.toml`` path.
    solver : str, Path or Backend
        Preset name, backend name, ``.toml`` preset path or a backend object.
    rng : int, numpy.random.Generator or None
        All randomness flows from it; the seed used is recorded in ``Result.seed``.
    init : dict or array, optional
        Paths from an earlier stage (``robot id -> (n, 2)``); a bare array means the leader.
    callback : callable, optional
        ``callback(progress)`` every iteration/step; raising ``StopIteration`` stops early; any
        other exception propagates unchanged.
    time_limit : float, optional
        Seconds (> 0).  The run stops at the first poll of the deadline after the limit (every
        backend polls it at least once per bounded step of every phase that grows with its
        options) and returns its best result with ``stop_reason = "time_limit"``
        (docs/api.md, "Time limits"); it replaces a backend's own (hybrid presets: 60 s).
    reference : bool
        Also compute the certified optimum of the known static map (:func:`reference_optimum`,
        cached per problem): ``metrics["optimum"]``, ``metrics["ratio_to_optimum"]`` and
        ``metrics["reference_time"]`` (seconds of the references in this call: the optimum
        when not cached, the grading in time and the team reference; not part of
        ``wall_time``: the call took ``wall_time + metrics["reference_time"]``), or
        ``metrics["reference_error"]`` when there is no certified optimum.  On a problem with
        moving obstacles, also the grading in time of every robot
        (:func:`optplan.time_grading.with_time_reference`): ``arrival_time``,
        ``schedule_arrival`` (the fastest timing of the plan's own path), ``time_reference``
        (the upper side of the ``time-bracket`` preset's bracket, or the plan's own arrival
        at the goal point when it is valid and earlier), ``time_lower_bound`` (its lower
        side) and the ratios of the
        arrival to each; ``time_per_robot`` for a team.  ``reference="team"`` also grades a
        team plan against the front of the best known team plans of the problem (cached on
        it; :func:`optplan.team_grading.with_team_reference`): ``arrival_ratio_to_team``,
        ``formation_rmse_ratio_to_team``, the certified ``team_arrival_lower_bound`` and
        the references' own figures; robots with their own goals (no formation) are graded
        by their sum of arrivals against ``ccbs``'s plan
        (:func:`optplan.mapf_grading.with_sum_reference`): ``sum_of_arrivals``,
        ``sum_reference``, the certified ``sum_lower_bound`` and the ratios to both.
    **overrides
        Replace preset options (unknown names raise ``ValueError``).

    Returns
    -------
    Result
        Its ``wall_time`` is what the call took, from entry to return (problem loading, the
        backend, the validator included), without the optional reference.
    """
    t_entry = time.perf_counter()
    prob = load_problem(problem)
    backend = get_solver(solver, **overrides)
    gen, seed = make_rng(rng)
    if init is not None:
        init = check_init(prob, init)
    if reference not in (True, False, "team"):
        raise ValueError(f"reference must be True, False or 'team', got {reference!r}")
    if time_limit is not None and (isinstance(time_limit, bool) or not isinstance(
            time_limit, (int, float)) or not (0 < time_limit < math.inf)):
        raise ValueError(f"time_limit must be a number of seconds > 0, got {time_limit!r}")
    backend = without_own_limit(backend, time_limit)
    stop = {"reason": ""}
    t0 = time.perf_counter()
    start = clock()  # the deadline's clock (module global: tests replace it)
    cb = callback
    if time_limit is not None or callback is not None:
        def cb(progress: Progress) -> None:
            if callback is not None:
                try:
                    callback(progress)
                except StopIteration:
                    stop["reason"] = "callback"
                    raise
            if time_limit is not None and clock() - start >= time_limit:
                stop["reason"] = "time_limit"
                raise StopIteration
    res = backend.solve(prob, rng=gen, init=init, callback=cb)
    status, message = _stop_outcome(res, stop["reason"], time.perf_counter() - t0)
    metrics = dict(res.metrics)
    t_ref = 0.0
    if reference:
        t1 = time.perf_counter()
        metrics = with_reference(metrics, prob, res.paths, reference_optimum(prob))
        t2 = time.perf_counter()
        graded = with_time_reference(metrics, prob, res.paths, res.times, time_reference)
        if reference == "team":
            graded = with_team_reference(graded, prob, res, team_reference)
            graded = with_sum_reference(graded, prob, res, sum_reference)
        t3 = time.perf_counter()
        if graded is not metrics:  # the grading in time or the team reference ran
            graded["reference_time"] = metrics["reference_time"] + (t3 - t2)
        metrics, t_ref = graded, t3 - t1
    out = dataclasses.replace(res, solver=backend.preset or backend.name, backend=backend.name,
                              seed=seed, metrics=metrics, status=status, message=message,
                              stop_reason=stop["reason"] or res.stop_reason, scenario=prob)
    # what the caller waited for, from entry to return (loading, validation and this
    # bookkeeping included), less the optional reference (its own figure: reference_time)
    return dataclasses.replace(out, wall_time=time.perf_counter() - t_entry - t_ref)
