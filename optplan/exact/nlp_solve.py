"""The IPOPT driver of the waypoint NLP: one solve, and the multi-round pair-adding loop.

:func:`solve_waypoint_nlp` takes the initial path to the map's local frame, resamples it to
``N`` segments, keeps the pairs near it (:func:`~optplan.exact.nlp_pieces.select_pairs`) and
solves (:func:`solve_once`, on the compiled model of :mod:`optplan.exact.nlp_model`); after
each solve every (segment, piece) distance is checked exactly and the violated pruned pairs
are added for a re-solve, at most ``max_rounds`` solves, the last one with every pair
(:func:`next_mask`).  The maths is in the :mod:`optplan.exact.nlp` module docstring.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optplan.exact.nlp_model import build_model, pair_rows
from optplan.exact.nlp_pieces import (
    SAFETY_REL,
    Pieces,
    init_hyperplanes,
    obstacle_pieces,
    pair_distances,
    select_pairs,
)
from optplan.geometry import Frame
from optplan.geometry.collision import path_lengths, resample_path
from optplan.metrics import evaluate
from optplan.problem import Problem, Robot

__all__ = ["MAX_SEGMENTS", "NLPSettings", "NLPOutcome", "solve_once", "next_mask",
           "solve_waypoint_nlp"]

#: hard cap on the number of segments (longer initial guesses are resampled by arc length).
MAX_SEGMENTS = 400


def _bucket(n: int, step: int) -> int:
    return max(step, int(math.ceil(n / step)) * step)


def _is_count(v: Any) -> bool:
    """An integer >= 1 (a bool is not one)."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool) and bool(v >= 1)


def _is_weight(v: Any, inf_ok: bool = False) -> bool:
    """A real number >= 0, finite unless ``inf_ok`` (then ``+inf`` too; never ``nan``)."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        return False
    return bool(v >= 0) and (math.isfinite(v) or (inf_ok and v == math.inf))


@dataclass(frozen=True, kw_only=True)
class NLPSettings:
    """The solver settings of :func:`solve_waypoint_nlp` (the defaults are the ``nlp``
    backend's, :class:`~optplan.exact.nlp.WaypointNLP`).

    Parameters
    ----------
    n_segments : int
        Segments of the path (the initial path is resampled to them; a longer one keeps
        every vertex, see ``segment_bucket``); at most :data:`MAX_SEGMENTS` either way.
    prune_distance : float
        Pair pruning radius as a fraction of the map diagonal: a (segment, piece) pair is
        constrained when its initial slack is at most this; ``inf`` constrains every pair.
    max_rounds : int
        Maximum number of solves (a re-solve adds the violated pruned pairs; the last one has
        every pair).
    eps : float
        Length smoothing, a fraction of the map diagonal.
    spacing_weight : float
        Weight of the spacing regulariser (dimensionless).
    resolve_from : {"last", "init"}
        Start of a re-solve: the previous round's solution or the initial path again.
    segment_bucket : int
        An initial path with more than ``n_segments`` segments keeps every vertex, its
        segment count rounded up to a multiple of this.
    ipopt_options : mapping
        IPOPT options passed to CasADi's ``nlpsol`` (``print_level``, ``max_iter``, ...).

    Raises
    ------
    ValueError
        A setting out of its range; the message names the setting, its value and the range.
    """

    n_segments: int = 20
    prune_distance: float = 0.05
    max_rounds: int = 4
    eps: float = 1e-4
    spacing_weight: float = 1e-4
    resolve_from: str = "last"
    segment_bucket: int = 1
    ipopt_options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        checks = [(name, _is_count(getattr(self, name)), "an integer >= 1")
                  for name in ("n_segments", "max_rounds", "segment_bucket")]
        checks += [("prune_distance", _is_weight(self.prune_distance, inf_ok=True),
                    "a number >= 0 or inf"),
                   ("eps", _is_weight(self.eps), "a finite number >= 0"),
                   ("spacing_weight", _is_weight(self.spacing_weight), "a finite number >= 0"),
                   ("resolve_from", self.resolve_from in ("last", "init"),
                    "one of 'last', 'init'"),
                   ("ipopt_options", isinstance(self.ipopt_options, Mapping),
                    "a mapping of IPOPT option names to values")]
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"NLPSettings.{name} must be {allowed}, "
                                 f"got {getattr(self, name)!r}")


@dataclass
class NLPOutcome:
    """What :func:`solve_waypoint_nlp` returns (map units)."""

    path: np.ndarray
    length: float
    return_status: str
    success: bool
    iterations: int
    rounds: int
    n_pairs: int
    pruned: int
    solve_time: float
    build_time: float
    stats: list[dict]
    stopped: bool = False
    violation: float = 0.0


def solve_once(path0: np.ndarray, pieces: Pieces, mask: np.ndarray, *, scale: float,
                bounds, eps: float, w: float, ipopt_opts: tuple,
                on_iter: Callable[[float], bool] | None) -> tuple[np.ndarray, dict, float]:
    """One IPOPT solve from ``path0`` with the pairs in ``mask``; returns (path, stats, build).

    ``path0``, the pieces and ``bounds`` are local-frame coordinates; the NLP runs on them
    divided by ``scale`` (the map diagonal).  The returned path is local.
    """
    N = len(path0) - 1
    seg, piece = np.nonzero(mask)  # row-major: ordered by segment
    K = len(seg)
    nv = np.array([len(pieces.verts[j]) for j in piece], dtype=np.int64)
    # vertex rows per pair: the piece's vertex count rounded up to a multiple of 4 (the
    # extra rows are free); without them IPOPT's iterates change (2 of the 390 tails polishes
    # ended at another KKT point, 1e-5 in length), with them the paths are those of the
    # padded NLP before issue 18 (to 5e-12 relative)
    rows = np.maximum(4, -(-nv // 4) * 4) if K else nv
    tb = time.perf_counter()
    built = build_model(N, tuple(seg.tolist()), tuple(rows.tolist()), ipopt_opts,
                        on_iter is not None)
    build_time = time.perf_counter() - tb
    u = path0 / scale
    a0, c0 = init_hyperplanes(path0, pieces, seg, piece, pieces.clear)
    nvt = int(rows.sum())
    Vt = np.zeros((nvt, 2))
    vub = np.full(nvt, np.inf)
    o = 0
    for k, j in enumerate(piece):
        vj = pieces.verts[j] / scale
        Vt[o: o + len(vj)] = vj
        Vt[o + len(vj): o + rows[k]] = vj[-1]
        vub[o: o + len(vj)] = 0.0
        o += rows[k]
    clear = pieces.clear[piece] / scale
    # bounds on x
    x0b, y0b, x1b, y1b = bounds
    lo = np.array([x0b, y0b]) / scale
    hi = np.array([x1b, y1b]) / scale
    nW = max(N - 1, 0)
    lbx = np.r_[np.tile(lo, nW), np.full(K * 2, -1.0), np.full(K, -np.inf)]
    ubx = np.r_[np.tile(hi, nW), np.full(K * 2, 1.0), np.full(K, np.inf)]
    x0 = np.r_[np.clip(u[1:-1], lo, hi).ravel(), a0.ravel(), c0 / scale]
    # constraint bounds in the built order: vertex rows, first and second endpoint rows,
    # norm rows, then permuted pair by pair
    lbg = np.r_[np.full(nvt, -np.inf), clear, clear, np.full(K, -np.inf)]
    ubg = np.r_[vub, np.full(2 * K, np.inf), np.ones(K)]
    perm = pair_rows(rows) if K else []
    lbg, ubg = lbg[perm], ubg[perm]
    par = np.r_[u[0], u[-1], eps, w, Vt.ravel()]
    if built.callback is not None:
        built.callback.target = on_iter
    sol = built.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=par)
    if built.callback is not None:
        built.callback.target = None
    st = dict(built.solver.stats())
    xs = np.asarray(sol["x"]).ravel()
    if not np.all(np.isfinite(xs)):
        xs = x0
        st["return_status"] = st.get("return_status", "") + " (non-finite iterate)"
        st["success"] = False
    Wsol = xs[: 2 * nW].reshape(nW, 2)
    out = np.vstack([path0[0], Wsol * scale, path0[-1]])
    info = {k: st.get(k) for k in ("return_status", "success", "iter_count")}
    info.update(t_wall=sum(float(v) for k, v in st.items() if k.startswith("t_wall_")),
                n_pairs=int(K), vertex_rows=nvt, n_seg=N, build_time=build_time)
    return out, info, build_time



@dataclass
class _Rounds:
    """Running totals of the solves of :func:`solve_waypoint_nlp`."""

    stats: list[dict] = field(default_factory=list)
    build: float = 0.0
    solve_t: float = 0.0
    iters: int = 0
    status: str = "not_run"
    success: bool = False
    rounds: int = 0

    def add(self, info: dict, elapsed: float, build_time: float) -> None:
        """Account for one solve (``elapsed`` includes its build time ``build_time``)."""
        self.solve_t += elapsed - build_time
        self.build += build_time
        self.stats.append(info)
        self.iters += int(info.get("iter_count") or 0)
        self.status, self.success = str(info["return_status"]), bool(info["success"])


def _local_start(frame: Frame, robot: Robot, init_path: np.ndarray, n_segments: int,
                 segment_bucket: int) -> np.ndarray:
    """The initial path in the local frame, from the robot's start to its goal, resampled to
    ``N`` segments (a longer path keeps every vertex, its segment count rounded up to a
    multiple of ``segment_bucket``, at most ``MAX_SEGMENTS``)."""
    start = frame.local(robot.start)
    goal = None if robot.goal is None else frame.local(robot.goal)
    p = frame.local(np.asarray(init_path, float).reshape(-1, 2))
    if np.hypot(*(p[0] - start)) > frame.eps:
        p = np.vstack([start, p])
    if goal is not None and np.hypot(*(p[-1] - goal)) > frame.eps:
        p = np.vstack([p, goal])
    # a longer initial path keeps every vertex; its segment count is rounded up to a multiple
    # of segment_bucket (warm starts of similar length then share one compiled structure)
    n_eff = n_segments if len(p) - 1 <= n_segments else _bucket(len(p) - 1, segment_bucket)
    n_eff = min(n_eff, MAX_SEGMENTS)
    path = resample_path(p, n_eff)
    path[0] = start
    if goal is not None:
        path[-1] = goal
    return path


def _to_world(frame: Frame, robot: Robot, q: np.ndarray) -> np.ndarray:
    """A local path in world coordinates, with the robot's start and goal bit for bit."""
    out = frame.world(q)
    out[0] = robot.start
    if robot.goal is not None:
        out[-1] = robot.goal
    return out


def next_mask(path: np.ndarray, pieces: Pieces, mask: np.ndarray, full: bool, *,
              tol_chk: float, prune_abs: float, validator_objects: Callable[[], bool]
              ) -> tuple[str, np.ndarray, float]:
    """What follows a solve that ended at ``path`` (local) with the pairs ``mask``.

    Returns ``(kind, mask, violation)``: ``"stop"`` when no pruned pair is violated and either
    a kept pair is (IPOPT's own tolerance), every pair was already constrained (``full``), or
    the shared validator accepts the path (``validator_objects()`` is False) or cannot be
    helped (every pair kept); ``"full"`` with every pair when the validator objects;
    ``"added"`` with the violated pruned pairs and those within ``prune_abs`` of the new
    segments.  ``violation`` is the largest clearance deficit over all pairs.
    """
    slack = pair_distances(path, pieces)
    bad = slack < -tol_chk
    viol = float(max(0.0, -slack.min()))
    missing = bad & ~mask
    if missing.any():
        return "added", mask | missing | (slack <= prune_abs), viol
    if bad.any() or full:
        return "stop", mask, viol
    objects = validator_objects()
    if not objects or mask.all():
        return "stop", mask, viol
    return "full", np.ones_like(mask), viol  # validator objects: constrain every pair


def solve_waypoint_nlp(
    problem: Problem,
    robot: Robot,
    init_path: np.ndarray,
    settings: NLPSettings = NLPSettings(),
    *,
    known_only: bool = True,
    margin: float = 0.0,
    on_iter: Callable[[float], bool] | None = None,
) -> NLPOutcome:
    """Solve the waypoint NLP for ``robot`` from ``init_path`` (world coordinates in and out).

    The initial path is taken to the map's local frame once; the NLP, the pair checks and the
    hyperplanes work there, and the solution is taken back to world coordinates at the end
    (start and goal are the robot's, bit for bit).  Multi-round: solve with the pruned pairs,
    check every (segment, piece) distance exactly, add the violated pairs (and those near the
    new segments) and re-solve (at most ``settings.max_rounds`` solves), from the previous
    round's solution (``resolve_from = "last"``) or from the initial guess (``"init"``).

    Parameters
    ----------
    problem : Problem
    robot : Robot
        The robot planned (its start and goal end the path).
    init_path : array ``(n, 2)``
        The initial guess, world coordinates (the start and goal are added when missing).
    settings : NLPSettings
        The solver settings (default: the ``nlp`` backend's defaults).
    known_only : bool
        Avoid the known obstacles only (temporary ones ignored).
    margin : float
        Extra clearance on top of the robot radius (map units).
    on_iter : callable, optional
        ``on_iter(f)`` is called with the objective every IPOPT iteration; returning True
        stops IPOPT.

    Returns
    -------
    NLPOutcome
        The path (world coordinates) and the record of the solves.

    Raises
    ------
    TypeError
        ``settings`` is no :class:`NLPSettings`.
    """
    if not isinstance(settings, NLPSettings):
        raise TypeError(f"settings must be an NLPSettings, got {type(settings).__name__}")
    pieces = obstacle_pieces(problem, robot, known_only=known_only, margin=margin)
    frame = problem.frame
    scale = frame.length
    path = _local_start(frame, robot, init_path, settings.n_segments,
                        settings.segment_bucket)
    n_eff = len(path) - 1
    opts = tuple(sorted(settings.ipopt_options.items()))
    prune = settings.prune_distance
    prune_abs = prune * scale if math.isfinite(prune) else np.inf
    mask = select_pairs(path, pieces, prune_abs) if pieces.n else np.zeros((n_eff, 0), bool)
    tol_chk = 0.5 * SAFETY_REL * scale
    stopped = False
    viol = 0.0
    full = False
    start_path = path
    view = problem.known_view() if known_only else problem
    log = _Rounds()

    def validator_objects() -> bool:
        m = evaluate(view, {robot.id: _to_world(frame, robot, path)})
        return m["static_collisions"] != 0

    while log.rounds < settings.max_rounds:
        log.rounds += 1
        t0 = time.perf_counter()
        new, info, bt = solve_once(start_path, pieces, mask, scale=scale,
                                   bounds=frame.local_bounds, eps=settings.eps,
                                   w=settings.spacing_weight,
                                   ipopt_opts=opts, on_iter=on_iter)
        log.add(info, time.perf_counter() - t0, bt)
        path = new
        if log.status == "User_Requested_Stop":
            stopped = True
            break
        if pieces.n == 0:
            viol = 0.0
            break
        kind, mask, viol = next_mask(path, pieces, mask, full, tol_chk=tol_chk,
                                     prune_abs=prune_abs, validator_objects=validator_objects)
        if kind == "stop":
            break
        if kind == "full":
            full = True
            continue
        if settings.resolve_from == "last":
            start_path = path
        if log.rounds == settings.max_rounds - 1:
            mask = np.ones_like(mask)  # the last solve gets every pair
            full = True
    length = float(path_lengths(path))
    return NLPOutcome(path=_to_world(frame, robot, path), length=length,
                      return_status=log.status, success=log.success, iterations=log.iters,
                      rounds=log.rounds, n_pairs=int(mask.sum()),
                      pruned=int(mask.size - mask.sum()), solve_time=log.solve_t,
                      build_time=log.build, stats=log.stats, stopped=stopped, violation=viol)
