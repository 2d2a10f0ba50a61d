r"""Exact waypoint NLP (CasADi + IPOPT): a local optimum of path length with whole-segment
collision constraints (docs/solvers/nlp.md).

Mathematics
-----------
Decision variables are the interior waypoints :math:`p_1, \dots, p_{N-1}` of a polyline with
:math:`N` segments; :math:`p_0` = start and :math:`p_N` = goal are fixed, every waypoint lies in
the map bounds.  The objective is the smoothed length plus a tiny spacing regulariser

.. math::

    f(p) = \sum_{i=0}^{N-1} \sqrt{\lVert \Delta_i \rVert^2 + \varepsilon^2}
           + w N \sum_{i=1}^{N-1} \lVert \Delta_i - \Delta_{i-1} \rVert^2 ,
    \qquad \Delta_i = p_{i+1} - p_i ,

(coordinates in the map's local frame divided by the map diagonal, so :math:`\varepsilon` and
:math:`w` are dimensionless); the *reported* length is the plain polyline length.

Collision avoidance is imposed on whole segments.  Every obstacle is cut into convex pieces
:math:`O_j = \mathrm{conv}\{v_{j1}, \dots, v_{jm}\}` with a clearance :math:`d_j`; for every
kept (segment :math:`i`, piece :math:`j`) pair there is a separating hyperplane
:math:`(a_{ij}, c_{ij})`:

.. math::

    a_{ij}^\top v_{jk} \le c_{ij} \;\; \forall k, \qquad
    a_{ij}^\top p_i \ge c_{ij} + d_j, \qquad a_{ij}^\top p_{i+1} \ge c_{ij} + d_j, \qquad
    \lVert a_{ij} \rVert^2 \le 1 .

Because :math:`a^\top y - c` is affine and :math:`\lVert a \rVert \le 1`, it is a lower bound
of :math:`\mathrm{dist}(y, O_j)`; holding at both endpoints it holds on the whole segment.
Conversely two convex sets at distance :math:`\ge d` admit such a hyperplane, so the
constraint is *exact* for convex pieces (the separating-hyperplane form of OBCA duality:
Zhang, Liniger & Borrelli 2021).  A disc (centre :math:`o`, radius :math:`R`) is the
one-vertex piece :math:`\{o\}` with clearance :math:`R + d`: :math:`a^\top (p - o) \ge R + d`.

Clearance
    The true disc-robot problem: the raw polygons with clearance = robot radius, circles natively
    (:math:`\lVert x - c \rVert \ge R + r`), plus ``margin`` and a numerical safety of
    ``SAFETY_REL`` x map diagonal (``1e-6 L``, far above the validator's tolerance
    ``eps = 1e-9 L``, so an IPOPT point that meets its constraints to IPOPT's tolerance is
    accepted by the validator).  The geometry is the exact engine's
    (:meth:`Problem.obstacle_set`): its local, clipped shapes are the input of the pieces.

Local frame
    Everything is computed in the map's local frame (:attr:`Problem.frame`: coordinates
    relative to the centre of the bounds), subtracted once when the pieces and the initial path
    are built and added back to the returned waypoints.  The NLP variables are local
    coordinates divided by the map diagonal ``L``, so a map at UTM coordinates solves like the
    same map at the origin (IPOPT's tolerances are absolute in its variables).

Convex decomposition
    :func:`optplan.geometry.convex_decompose` (the one decomposition of optplan: convex
    polygons are one piece, others the Hertel-Mehlhorn merge of a constrained Delaunay
    triangulation, holes included).

Pair pruning
    Only pairs whose piece lies within ``prune_distance`` (fraction of the map diagonal) of the
    *initial* segment, beyond the piece's clearance, are constrained.  After each solve every
    (segment, piece) distance is computed exactly by the collision engine
    (:meth:`ObstacleSet.pair_geometry` on an :class:`~optplan.geometry.ObstacleSet` whose
    obstacles are the NLP's convex pieces: the engine fan-splits a piece into items of at most
    four vertices, and the distance to the piece is the smallest over its items); a violated
    pruned pair is added (with the pairs near the new segments) and the NLP re-solved, up to
    ``max_rounds`` solves; the last one constrains every pair.  A re-solve starts from the
    previous round's solution (``resolve_from = "last"``, default: it already satisfies the kept
    pairs, so IPOPT only clears the added ones; from overlapping heuristic guesses this halves
    the iterations and more often keeps the optimal homotopy class) or from the initial guess
    again (``"init"``).  If the shared validator still objects, all pairs are added.

Structure re-use
    The NLP is built once per structure ``(N, the kept pairs' segments, vertex rows per pair,
    IPOPT options)`` with ``casadi.nlpsol`` on SX symbols (``expand = True``); the constraint
    vector is flat, indexed by the kept (segment, piece) pairs, each segment with as many pairs
    as it has (no empty slots padded to the busiest segment's count: they stayed in IPOPT's
    KKT system as free rows and made every iteration slower).  The piece vertices are
    *parameters* and the clearances *bounds*, so seeds and warm starts with the same pairs
    re-use one compiled solver; any other set of pairs is a new (vectorised) build.

Warm start
    ``init`` (any path, e.g. an IPSO or visgraph result) keeps all its vertices and gains
    collinear points on its longest segments, proportionally to arc length, until it has ``N``
    segments (``N = max(n_segments, len(init) - 1)``, rounded up to a multiple of 8 when the
    ``init`` is longer).  Each hyperplane starts at the best of
    the candidate normals that contain the optimal separating direction of a segment and a
    convex piece (the piece's edge normals, the segment's normals, the directions from the
    piece's vertices to the segment's endpoints), with ``c`` in the middle of the gap.
    Without ``init`` the start is the arc-exact tangent-graph path
    (:func:`optplan.geometry.tangent.tangent_graph.problem_shortest_path`, ``init_from =
    "visgraph"``) or the straight line (``"straight"``).  IPOPT is local: the homotopy class is the
    initial guess's.

Statuses
    IPOPT ``Solve_Succeeded`` is a KKT point: locally optimal in the initial guess's homotopy
    class.  It is claimed ``optimal`` only when it lies in the homotopy class of the certified
    optimum of the same map (:mod:`optplan.geometry.collision.homotopy`) *and* that optimum confirms
    its length within :data:`optplan.result.OPTIMAL_REL_TOL` (1e-9); otherwise ``solved``, with
    "locally optimal (KKT)", the gap (also ``extras["ipopt"][robot]["optimum_gap"]``) and the
    reason in the message: chords around the optimum's arcs, or the safety clearance at a
    corner, keep a KKT point 1e-6 to 1e-4 above the optimum (docs/solvers/nlp.md).  Acceptable
    level / iteration or time limit / user stop -> claim ``solved``; IPOPT infeasibility or
    failure -> ``approximate`` with the IPOPT message; start or goal within ``r`` of an
    obstacle, or no path at all (tangent graph) -> ``infeasible``.
    The backend never decides feasibility: the shared validator grades every claim
    (:meth:`Backend.finish`).  Guard: with a caller's ``init``, if IPOPT returns a path that the
    validator rejects or that is longer, the (validator-feasible) initial guess is returned
    instead, as ``solved`` with a message; the NLP's own length stays in ``extras``.  (The
    backend's own visgraph start is not guarded: its result is the NLP optimum, reported as is.)

Modules
    :mod:`optplan.exact.nlp_pieces` (convex pieces, exact pair distances, pruning, hyperplane
    warm start), :mod:`optplan.exact.nlp_model` (the CasADi model and its cached builds),
    :mod:`optplan.exact.nlp_solve` (one IPOPT solve and the multi-round driver),
    :mod:`optplan.exact.nlp_status` (claims, certificate, guard) and this module (the backend).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.deadline import Deadline
from optplan.exact.nlp_pieces import blocked_end
from optplan.exact.nlp_solve import MAX_SEGMENTS, NLPOutcome, NLPSettings, solve_waypoint_nlp
from optplan.exact.nlp_status import combine_claims, guard, ipopt_claim, outcome_message
from optplan.geometry.collision import path_lengths
from optplan.geometry.tangent import problem_shortest_path
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Result, Status, notify
from optplan.solver import Backend, option

__all__ = ["WaypointNLP", "SEGMENT_BUCKET"]

#: A caller's ``init`` with more than ``n_segments`` segments gets a multiple of this many
#: (one compiled NLP per structure: the warm starts of one map then share one or two builds).
SEGMENT_BUCKET = 8


class IterProgress:
    """IPOPT's iterations as :class:`~optplan.result.Progress` to the caller's callback.

    Called with the objective every IPOPT iteration; returns True (stop IPOPT) when the
    callback asks to stop.  An exception of the callback is kept in ``raised`` (CasADi would
    swallow it and print its internals): IPOPT stops cleanly and ``solve`` re-raises it
    unchanged.  ``best`` is the best path length so far (one planned robot).
    """

    def __init__(self, callback: Callable[[Progress], Any] | None, t0: float):
        self.callback, self.t0 = callback, t0
        self.it = 0
        self.stop = False
        self.best = math.inf
        self.raised: list[BaseException] = []

    def __call__(self, f: float) -> bool:
        self.it += 1
        try:
            stop = notify(self.callback, Progress(iteration=self.it, best_cost=self.best,
                                                  n_eval=self.it,
                                                  elapsed=time.perf_counter() - self.t0,
                                                  info={"objective": f}))
        except BaseException as e:  # noqa: BLE001 - re-raised after IPOPT returns
            self.raised.append(e)
            stop = True
        self.stop = self.stop or stop
        return stop


@dataclass(frozen=True, kw_only=True)
class WaypointNLP(Backend):
    r"""Waypoint NLP with separating-hyperplane segment constraints, solved by IPOPT.

    Locally optimal path length in the homotopy class of the initial guess
    (see the module docstring for the maths).

    Parameters
    ----------
    n_segments : int
        :math:`N`, number of path segments (waypoints between start and goal: :math:`N-1`).
        An initial guess with more segments raises :math:`N` to keep all its vertices (for a
        caller's ``init``, to the next multiple of ``SEGMENT_BUCKET``, 8, so that similar warm
        starts share one build).
    margin : float
        Extra clearance on top of the robot radius, in units of the problem's
        ``length_scale`` (map units on the paper's maps): the NLP avoids the true polygons and
        circles by ``r + margin * length_scale``, plus a safety of ``SAFETY_REL`` x the map
        diagonal.
    init_from : {"visgraph", "straight"}
        Initial guess when no ``init`` is given: the arc-exact tangent-graph path (the
        ``visgraph`` polyline) or the straight start-goal line.
    prune_distance : float
        Pair pruning radius as a fraction of the map diagonal: a (segment, piece) pair is
        constrained when its initial slack ``dist - clearance`` is at most this; ``inf``
        constrains every pair (no pruning).
    max_rounds : int
        Maximum number of solves (re-solves happen when a pruned pair turns out violated).
    resolve_from : {"last", "init"}
        Start of a re-solve: the previous round's solution (default; it already satisfies the
        kept pairs, so IPOPT only has to clear the added ones: ~2x fewer iterations from
        infeasible heuristic guesses) or the initial guess again.
    eps : float
        :math:`\varepsilon`, length smoothing, fraction of the map diagonal.
    spacing_weight : float
        :math:`w`, weight of the spacing regulariser (dimensionless).
    see_temporary : bool
        Also avoid temporary (``known = false``) obstacles (default: the known map, like the
        other global path solvers).
    guard : bool
        Never return a path longer (or less feasible) than the initial guess.
    max_iter : int
        IPOPT ``max_iter``.
    tol : float
        IPOPT ``tol`` (scaled NLP error).
    acceptable_tol : float
        IPOPT ``acceptable_tol``.
    mu_strategy : {"monotone", "adaptive"}
        IPOPT barrier update strategy (``adaptive`` wanders off warm starts here).
    mu_init : float
        IPOPT initial barrier parameter (small: the warm start is near-optimal).
    bound_push : float
        IPOPT ``bound_push`` = ``bound_frac`` = ``slack_bound_push`` = ``slack_bound_frac``:
        how far the warm start is moved into the interior (small keeps it where it is).
    print_level : int
        IPOPT ``print_level`` (0 = silent).
    time_limit : float or None
        Seconds (> 0, default 60; ``None``: none), polled at every IPOPT iteration: the run
        stops there with IPOPT's last iterate, graded by the validator (with a caller's
        ``init`` and ``guard``, never worse than it; ``stop_reason = "time_limit"``).
        ``solve(time_limit=S)`` replaces it.
    """

    name: ClassVar[str] = "nlp"
    certifies: ClassVar[bool] = True
    n_segments: int = option(20, lo=1, hi=MAX_SEGMENTS)
    margin: float = option(0.0, lo=0.0, scale=True)
    init_from: str = option("visgraph", choices=("visgraph", "straight"))
    prune_distance: float = option(0.05, lo=0.0, inf_ok=True)
    max_rounds: int = option(4, lo=1, hi=50)
    resolve_from: str = option("last", choices=("init", "last"))
    eps: float = option(1e-4, lo=0.0, hi=1e-2)
    spacing_weight: float = option(1e-4, lo=0.0, hi=1.0)
    see_temporary: bool = option(False)
    guard: bool = option(True)
    max_iter: int = option(500, lo=1, hi=100_000)
    tol: float = option(1e-8, lo=0.0, hi=1.0, lo_open=True)
    acceptable_tol: float = option(1e-6, lo=0.0, hi=1.0, lo_open=True)
    mu_strategy: str = option("monotone", choices=("adaptive", "monotone"))
    mu_init: float = option(1e-7, lo=0.0, hi=1e3, lo_open=True)
    bound_push: float = option(1e-6, lo=0.0, hi=0.5, lo_open=True)
    print_level: int = option(0, lo=0, hi=12)
    time_limit: float | None = option(60.0, lo=0.0, lo_open=True, inf_ok=True, none_ok=True)

    def ipopt_options(self) -> dict:
        """The IPOPT options passed to ``nlpsol`` (plugin level ``expand``/``print_time`` too)."""
        return {"print_level": self.print_level, "sb": "yes", "max_iter": self.max_iter,
                "tol": self.tol, "acceptable_tol": self.acceptable_tol,
                "mu_strategy": self.mu_strategy, "mu_init": self.mu_init,
                "bound_push": self.bound_push, "bound_frac": self.bound_push,
                "slack_bound_push": self.bound_push, "slack_bound_frac": self.bound_push}

    def _nlp_settings(self, segment_bucket: int) -> NLPSettings:
        """This backend's options as the settings of :func:`solve_waypoint_nlp`."""
        return NLPSettings(n_segments=self.n_segments, prune_distance=self.prune_distance,
                           max_rounds=self.max_rounds, eps=self.eps,
                           spacing_weight=self.spacing_weight, resolve_from=self.resolve_from,
                           segment_bucket=segment_bucket, ipopt_options=self.ipopt_options())

    def _initial(self, problem: Problem, robot: Robot, init
                 ) -> tuple[np.ndarray | None, str, Status]:
        """(initial path, its source, status if there is none)."""
        if init is not None and robot.id in init:
            return np.asarray(init[robot.id], float).reshape(-1, 2), "init", Status.solved
        if self.init_from == "visgraph":
            res = problem_shortest_path(problem, robot, known_only=not self.see_temporary)
            if res.polyline is None:
                # the walled tangent graph is complete: no path is a proof
                return (None, res.info.get("reason", "the tangent graph has no path"),
                        Status.infeasible)
            return res.polyline, "visgraph", Status.solved
        if robot.goal is None:
            raise ValueError(f"robot {robot.id!r} has no goal to plan to")
        return np.vstack([robot.start, robot.goal]), "straight", Status.solved


    def _outcome(self, problem: Problem, robot: Robot, out: NLPOutcome, guess: np.ndarray,
                 source: str, known_only: bool, info: dict[str, Any]
                 ) -> tuple[np.ndarray, Status, str]:
        """The path, claim and message of one robot's NLP result ``out``: certified against
        the optimum when IPOPT succeeded, and (``guard``, an ``init`` guess) the initial guess
        kept when the NLP path is infeasible or longer.  Notes go into ``info``."""
        view = problem if not known_only else problem.known_view()
        claim = ipopt_claim(problem, robot, out, known_only, info)
        msg = outcome_message(robot, out, info)
        if self.guard and source == "init":
            return guard(view, robot, out.path, guess, claim, msg, source, info)
        return out.path, claim, msg

    def _plan_robot(self, problem: Problem, robot: Robot, init: dict[str, np.ndarray] | None,
                    known_only: bool, margin: float, prog: IterProgress,
                    report: bool, infos: dict[str, Any]
                    ) -> tuple[np.ndarray, Status, str, NLPOutcome | None]:
        """One robot's (path, claim, message, NLP outcome or None when no NLP was solved);
        its IPOPT record goes into ``infos[robot.id]``."""
        if prog.stop:
            return (np.vstack([robot.start, robot.start]), Status.approximate,
                    f"{robot.id}: not planned (stopped by callback)", None)
        guess, source, why_none = self._initial(problem, robot, init)
        if guess is None:
            return np.vstack([robot.start, robot.start]), why_none, f"{robot.id}: {source}", None
        which = blocked_end(problem, robot, known_only, margin)
        if which:
            return (np.vstack([robot.start, robot.start]), Status.infeasible,
                    f"{robot.id}: {which} lies within the robot radius of an obstacle", None)
        try:
            out = solve_waypoint_nlp(
                problem, robot, guess,
                self._nlp_settings(SEGMENT_BUCKET if source == "init" else 1),
                known_only=known_only, margin=margin, on_iter=prog if report else None)
            if prog.raised:
                raise prog.raised[0]
        except RuntimeError as e:  # CasADi / IPOPT numerical failure -> failed status
            if prog.raised:
                raise
            return guess, Status.failed, f"{robot.id}: NLP failed ({type(e).__name__}: {e})", None
        infos[robot.id] = {
            "rounds": out.stats, "return_status": out.return_status,
            "iterations": out.iterations, "n_pairs": out.n_pairs, "pruned": out.pruned,
            "solve_time": out.solve_time, "build_time": out.build_time,
            "init_source": source, "init_length": path_lengths(guess),
            "nlp_length": out.length, "max_violation": out.violation,
        }
        path, claim, msg = self._outcome(problem, robot, out, guess, source, known_only,
                                         infos[robot.id])
        return path, claim, msg, out

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t0 = time.perf_counter()
        known_only = not self.see_temporary
        margin = self.margin * problem.length_scale  # the option is in length_scale units
        paths: dict[str, np.ndarray] = {}
        msgs: list[str] = []
        claims: list[Status] = []
        extras: dict[str, Any] = {"ipopt": {}}
        hist = History()
        limit = Deadline(callback, self.time_limit)
        prog = IterProgress(limit.forward, t0)
        for robot in problem.planned_robots:
            path, claim, msg, out = self._plan_robot(problem, robot, init, known_only, margin,
                                                     prog, limit.forward is not None,
                                                     extras["ipopt"])
            paths[robot.id] = path
            claims.append(claim)
            msgs.append(msg)
            if out is None:
                continue
            if len(problem.planned_robots) == 1:
                prog.best = min(prog.best, float(path_lengths(path)))
            hist.append(iteration=prog.it or out.iterations, best_cost=float(path_lengths(path)),
                        n_eval=out.iterations, time=time.perf_counter() - t0,
                        robot=robot.id, rounds=out.rounds)
        claim = combine_claims(claims, prog.stop)
        lead = problem.leader.id if problem.leader.id in paths else next(iter(paths))
        opt = extras["ipopt"].get(lead, {}).get("optimum")
        return limit.mark(self.finish(
            problem, paths, claim=claim, cost=float(path_lengths(paths[lead])),
            message="; ".join(msgs),
            metrics_extra=None if opt is None else {"optimum": opt},
            n_iter=sum(e["iterations"] for e in extras["ipopt"].values()),
            n_eval=sum(e["iterations"] for e in extras["ipopt"].values()),
            history=hist, extras=extras, wall_time=time.perf_counter() - t0))
