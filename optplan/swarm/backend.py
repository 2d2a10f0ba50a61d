"""The driver shared by the swarm backends ``pso``, ``mpso`` and ``ipso``: their common
options (:class:`SwarmBackend`), the state of one run (:class:`SwarmState`) and the
convergence bookkeeping.

:meth:`SwarmBackend.solve` plans each planned robot in turn on the known view: the initial
swarm (:mod:`optplan.swarm.operators`, seeded by :func:`optplan.swarm.roadmap.roadmap_corridors`
with ``init_mode = "roadmap"``), then ``k_max`` calls of the backend's
:meth:`SwarmBackend._iterate`, then the optional post-iteration steps of
:meth:`SwarmBackend._finish` (one history row each, not counted as iterations).  The answer
is a backend's final path, else the best collision-free particle ever seen, else gbest.

Convergence bookkeeping
    The "optimal number of iterations" of the paper's Tables 2-3 is defined here as the first
    iteration whose best fitness is within 0.1 % of the final best of the swarm iterations
    (:func:`converged_iteration`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Status, notify
from optplan.solver import Backend, make_rng, option
from optplan.swarm.core import (
    EVAL_SEGMENTS,
    Interrupted,
    SwarmEval,
    SwarmSpace,
    as_particle,
    decode,
    evaluate_swarm,
    make_space,
)
from optplan.swarm.operators import BOUNDS_MODES, INIT_MODES, initial_swarm
from optplan.swarm.roadmap import MAX_NEIGHBOURS, roadmap_corridors

__all__ = ["SwarmState", "SwarmBackend", "new_state", "converged_iteration", "MAX_PARTICLES",
           "MAX_SAMPLES"]

#: The largest ``n_particles`` (200 x the paper's 50): with the largest ``n_waypoints`` (200)
#: one position array is 32 MB and one iteration a bounded step (docs/solvers/pso.md,
#: "Options").
MAX_PARTICLES = 10_000

#: The largest ``roadmap_samples``, ``roadmap_boundary`` and ``roadmap_medial`` (14 to 125 x
#: the defaults): a roadmap of at most ~15,000 nodes (docs/solvers/pso.md, "Options").
MAX_SAMPLES = 5_000


def converged_iteration(best: np.ndarray, rel: float = 1e-3) -> int:
    """First iteration whose best is within ``rel`` (0.1 %) of the final best.

    ``best`` is the per-iteration best fitness (index = iteration, 0 = initial swarm).
    """
    b = np.asarray(best, dtype=float)
    if b.size == 0:
        return 0
    final = b[-1]
    ok = b <= final + rel * abs(final)
    return int(np.argmax(ok))



# --------------------------------------------------------------------------------------
# state and the shared driver
# --------------------------------------------------------------------------------------


@dataclass(eq=False)
class SwarmState:
    """Mutable state of one swarm run (positions, velocities, memories, bookkeeping).

    ``stats`` holds the backend's public counters (reported in ``extras["per_robot"]``);
    ``final_path`` is an answer that is not a particle (e.g. a tightened path with more
    vertices than ``n_waypoints``), set by a backend's :meth:`SwarmBackend._finish`.
    """

    X: np.ndarray
    V: np.ndarray
    F: np.ndarray
    pbest: np.ndarray
    pbest_f: np.ndarray
    gbest: np.ndarray
    gbest_f: float
    gbest_count: int
    feas_len: float = math.inf
    feas_x: np.ndarray | None = None
    n_eval: int = 0
    final_path: np.ndarray | None = None
    stats: dict = field(default_factory=dict)

    def absorb(self, X: np.ndarray, ev: SwarmEval, slots: np.ndarray | None = None) -> None:
        """Take evaluated positions ``X`` (into ``slots``, default all) and update memories."""
        idx = np.arange(len(self.F)) if slots is None else slots
        self.X[idx] = X
        self.F[idx] = ev.cost
        better = ev.cost < self.pbest_f[idx]
        if better.any():
            b = idx[better]
            self.pbest[b] = X[better]
            self.pbest_f[b] = ev.cost[better]
        self.offer(X, ev)

    def offer(self, X: np.ndarray, ev: SwarmEval) -> None:
        """Update gbest and the feasible best with candidate positions (no slot changes)."""
        self.offer_gbest(X, ev)
        self.offer_feasible(X, ev)

    def offer_gbest(self, X: np.ndarray, ev: SwarmEval, n: int | None = None) -> None:
        """Replace gbest by the best candidate (of the first ``n``) if it has a lower fitness."""
        j = int(np.argmin(ev.cost if n is None else ev.cost[:n]))
        if ev.cost[j] < self.gbest_f:
            self.gbest = X[j].copy()
            self.gbest_f = float(ev.cost[j])
            self.gbest_count = int(ev.count[j])

    def offer_feasible(self, X: np.ndarray, ev: SwarmEval) -> None:
        """Replace the best collision-free position by a shorter collision-free candidate."""
        feas = ev.count == 0
        if np.count_nonzero(feas):
            lens = np.where(feas, ev.length, np.inf)
            k = int(np.argmin(lens))
            if lens[k] < self.feas_len:
                self.feas_len = float(lens[k])
                self.feas_x = X[k].copy()


def new_state(X: np.ndarray, V: np.ndarray, ev: SwarmEval, *, own: bool = False) -> SwarmState:
    """The state of a swarm at ``X`` with velocities ``V`` and fitness ``ev`` (the personal
    bests are a copy of ``X``).  ``own``: ``X`` and ``V`` are handed over (the state uses them
    instead of copies: no needless copy of a large swarm)."""
    j = int(np.argmin(ev.cost))
    st = SwarmState(X=X if own else X.copy(), V=V if own else V.copy(), F=ev.cost.copy(),
                    pbest=X.copy(), pbest_f=ev.cost.copy(), gbest=X[j].copy(),
                    gbest_f=float(ev.cost[j]), gbest_count=int(ev.count[j]), n_eval=len(X))
    st.offer(X, ev)
    return st


@dataclass(frozen=True, kw_only=True)
class SwarmBackend(Backend):
    """Options shared by ``pso``, ``mpso`` and ``ipso`` (see the subclasses for the rest).

    Parameters
    ----------
    n_particles : int
        Swarm size (paper §VI.A: n = 50).
    k_max : int
        Number of iterations (paper: k_max = 200).
    c1, c2 : float
        Cognitive and social acceleration coefficients of eq 1 / eq 22 (paper: 1.5, 1.5).
    n_waypoints : int
        Intermediate waypoints per path; the particle has 2 n_waypoints coordinates.  Not given
        in the paper; 4 is enough for the paper maps (their optima have <= 4 bends) and keeps
        the swarm fast; an optimum with more bends needs a larger value.
    v_max : float
        Velocity clamp per coordinate as a fraction of the map range (0.2 = 20 %); ``inf``
        disables the clamp.  Not in the paper.
    bounds_mode : {"reflect", "clip", "random"}
        Handling of coordinates that leave the map (see :mod:`optplan.swarm.operators`).
    init_mode : {"sorted", "uniform", "line", "roadmap"}
        Initial swarm (see :mod:`optplan.swarm.operators`).
    penalty_weight : float or None
        ``delta`` of eq 32 per crossing, in units of the problem's ``length_scale`` (map units
        on the paper's maps, where it is 1); ``None`` = ``(n_waypoints + 1) * diag``, the
        smallest round value making every collision-free path beat every colliding one.
    penetration_weight : float
        Weight of the inside-obstacle length added to the fitness (beyond the paper; 0 in the
        ``-paper`` presets).
    roadmap_samples, roadmap_boundary, roadmap_medial : int
        Beyond the paper, the roadmap of ``init_mode = "roadmap"``
        (:func:`optplan.swarm.roadmap.build_roadmap`): uniform samples, obstacle-based samples
        (half along the boundary edges, half around the corners,
        :func:`optplan.swarm.samples.boundary_samples`) and medial-axis retractions
        (:func:`optplan.swarm.samples.medial_samples`).
    roadmap_neighbours : int
        Nearest neighbours each roadmap node is connected to (besides its Yao edges and the
        pairs of corner nodes); 0 connects every pair of nodes (a roadmap of at most 1,024
        nodes; a larger one gets the largest value, 64).
    corridors : int
        Homotopy classes taken from the roadmap (beyond the paper): its ``corridors`` shortest
        walks of distinct classes (:func:`optplan.swarm.roadmap.roadmap_corridors`); the
        shortest seed the particles (one per island of ``ipso``), ``ipso``'s end-game compares
        all of them.
    """

    name: ClassVar[str] = "swarm"

    n_particles: int = option(50, lo=2, hi=MAX_PARTICLES)
    k_max: int = option(200, lo=0, hi=1_000_000)
    c1: float = option(1.5, lo=0.0, hi=10.0)
    c2: float = option(1.5, lo=0.0, hi=10.0)
    n_waypoints: int = option(4, lo=1, hi=200)
    v_max: float = option(0.2, lo=0.0, lo_open=True, inf_ok=True)
    bounds_mode: str = option("reflect", choices=BOUNDS_MODES)
    init_mode: str = option("sorted", choices=INIT_MODES)
    penalty_weight: float | None = option(None, lo=0.0, scale=True)
    penetration_weight: float = option(0.0, lo=0.0)
    roadmap_samples: int = option(40, lo=0, hi=MAX_SAMPLES)
    roadmap_boundary: int = option(360, lo=0, hi=MAX_SAMPLES)
    roadmap_medial: int = option(200, lo=0, hi=MAX_SAMPLES)
    roadmap_neighbours: int = option(25, lo=0, hi=MAX_NEIGHBOURS)
    corridors: int = option(30, lo=1, hi=1000)

    # -- hooks for subclasses ------------------------------------------------------
    def _start(self, space: SwarmSpace, state: SwarmState, seeds: list[np.ndarray],
               rng: np.random.Generator) -> Any:
        """Called once after the initial evaluation; returns the backend's per-run object
        (constants and algorithm state), passed to :meth:`_iterate` and :meth:`_finish`.
        ``seeds`` are the roadmap corridors (``init_mode = "roadmap"``, else empty)."""
        return None

    def _iterate(self, space: SwarmSpace, state: SwarmState, run: Any, k: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        """One iteration ``k`` (1-based); returns extra history columns."""
        raise NotImplementedError

    def _finish(self, space: SwarmSpace, state: SwarmState, run: Any,
                rng: np.random.Generator):
        """Optional steps after the ``k_max`` iterations (a generator of history columns).

        Each yielded dict adds one history row (numbered on from ``k_max``); these rows are not
        counted in ``Result.n_iter``.
        """
        return iter(())

    def _stats(self, run: Any) -> dict[str, Any]:
        """The backend's public per-robot counters of a run (``extras["per_robot"]``)."""
        return {}

    # -- shared helpers --------------------------------------------------------------
    def _vmax(self, space: SwarmSpace) -> np.ndarray:
        """Velocity clamp per coordinate (``inf`` everywhere when there is none)."""
        if math.isinf(self.v_max):
            return np.full(space.dim, math.inf)
        return self.v_max * space.span

    def _initial(self, space: SwarmSpace, init_path: np.ndarray | None,
                 rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
        """Initial positions and the roadmap corridors that seeded some of them."""
        X = self._initial_swarm(space, rng)
        seeds: list[np.ndarray] = []
        if self.init_mode == "roadmap":
            seeds = roadmap_corridors(space, self.corridors, rng, n_samples=self.roadmap_samples,
                                      k_neighbours=self.roadmap_neighbours,
                                      boundary=self.roadmap_boundary,
                                      medial=self.roadmap_medial)
            blocks = self._seed_blocks(len(seeds))
            for i, pth in enumerate(seeds[:blocks]):  # one per block of particles
                X[i * self.n_particles // blocks] = as_particle(pth, space)
        if init_path is not None and len(init_path) >= 2:
            X[0] = as_particle(init_path, space)
        return X, seeds

    def _initial_swarm(self, space: SwarmSpace, rng: np.random.Generator) -> np.ndarray:
        """:func:`initial_swarm`; with a deadline (``space.poll``) and more than
        :data:`~optplan.swarm.core.EVAL_SEGMENTS` coordinates, drawn in blocks of rows with a
        poll between two (the same positions: each row's draws are consecutive in the
        stream).  When the poll asks to stop, the rows not drawn repeat the first (the
        evaluation stops at its own first poll)."""
        P, D = self.n_particles, space.dim
        rows = max(1, EVAL_SEGMENTS // D)
        if space.poll is None or P <= rows:
            return initial_swarm(space, P, self.init_mode, rng)
        X = np.empty((P, D))
        for c in range(0, P, rows):
            X[c:c + rows] = initial_swarm(space, min(rows, P - c), self.init_mode, rng)
            if c + rows < P and space.poll():
                X[c + rows:] = X[0]
                break
        return X

    def _seed_blocks(self, n_seeds: int) -> int:
        """How many roadmap corridors the initial swarm holds (one per block of consecutive
        particles): all of them, at most one per particle."""
        return min(n_seeds, self.n_particles)

    # -- the driver --------------------------------------------------------------------
    def _run_robot(self, problem: Problem, robot: Robot, rng: np.random.Generator,
                   init_path: np.ndarray | None, callback, t0: float, it_offset: int):
        pw = self.penalty_weight
        at = {"k": 0, "best": math.inf}

        def poll() -> bool:  # the deadline, between two passes of a large evaluation
            return notify(callback, Progress(iteration=it_offset + int(at["k"]),
                                             best_cost=at["best"], n_eval=0,
                                             elapsed=time.perf_counter() - t0,
                                             info={"robot": robot.id}))

        space = make_space(problem, robot, self.n_waypoints,
                           penalty_weight=None if pw is None else pw * problem.length_scale,
                           penetration_weight=self.penetration_weight,
                           poll=None if callback is None else poll)
        X, seeds = self._initial(space, init_path, rng)
        V = np.zeros_like(X)
        try:
            ev, cut = evaluate_swarm(X, space), False
        except Interrupted as e:  # the rows not scored are never feasible
            ev, cut = e.ev, True
        state = new_state(X, V, ev, own=True)  # X and V are this run's own
        run = self._start(space, state, seeds, rng)
        rows: list[dict[str, Any]] = []

        def record(k: int, extra: dict[str, Any]) -> bool:
            # F.sum() / n is what np.mean computes (same pairwise sum), without its wrapper
            row = {"iteration": k, "best_cost": state.gbest_f,
                   "feasible_best_length": state.feas_len if state.feas_x is not None
                   else math.nan,
                   "n_eval": state.n_eval, "time": time.perf_counter() - t0,
                   "mean_cost": float(state.F.sum() / len(state.F)), **extra}
            rows.append(row)
            if callback is None:
                return False
            return notify(callback, Progress(iteration=it_offset + k, best_cost=state.gbest_f,
                                             n_eval=state.n_eval,
                                             elapsed=time.perf_counter() - t0,
                                             info={"robot": robot.id,
                                                   "feasible_best_length": row[
                                                       "feasible_best_length"]}))

        stopped = record(0, {}) or cut
        k = 0
        while not stopped and k < self.k_max:
            k += 1
            at["k"], at["best"] = k, state.gbest_f
            try:
                extra = self._iterate(space, state, run, k, rng)
            except Interrupted:  # the state is the one of iteration k - 1
                k, stopped = k - 1, True
                break
            stopped = record(k, extra)
        iterations = k
        state.stats.update(self._stats(run))
        if not stopped:
            for extra in self._finish(space, state, run, rng):
                k += 1
                if record(k, extra):
                    stopped = True
                    break
        return space, state, rows, stopped, iterations

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None):
        t0 = time.perf_counter()
        rng = make_rng(rng)[0]
        view = problem.known_view()
        paths: dict[str, np.ndarray] = {}
        per_robot: dict[str, Any] = {}
        all_rows: list[list[dict[str, Any]]] = []
        n_eval, n_iter, stopped_any, all_ok = 0, 0, False, True
        cost = 0.0
        msgs = []
        for robot in view.planned_robots:
            if robot.goal is None:
                continue
            ip = None if not init else init.get(robot.id)
            space, st, rows, stopped, iters = self._run_robot(view, robot, rng, ip, callback,
                                                              t0, n_iter)
            all_rows.append(rows)
            n_eval += st.n_eval
            n_iter += iters
            stopped_any |= stopped
            # the answer: a final path (end-game), else the best collision-free particle ever
            # seen, else gbest
            ok = st.final_path is not None or st.feas_x is not None
            all_ok &= ok
            if st.final_path is not None:
                paths[robot.id] = st.final_path
            else:
                x = st.feas_x if st.feas_x is not None else st.gbest
                paths[robot.id] = decode(x[None], space)[0]
            # over the swarm iterations (a final tightening row is not an iteration)
            best = np.array([r["best_cost"] for r in rows[:iters + 1]])
            cost += st.feas_len if ok else st.gbest_f
            per_robot[robot.id] = {
                "converged_iteration": converged_iteration(best),
                "final_best_cost": st.gbest_f,
                "feasible_best_length": st.feas_len if ok else None,
                "crossings": st.gbest_count,
                "penalty_weight": space.penalty_weight,
                **st.stats,
            }
            if not ok:
                msgs.append(f"{robot.id}: no collision-free particle found "
                            f"({st.gbest_count} crossing(s) in gbest)")
        hist = _merge_rows(all_rows)
        first: dict[str, Any] = next(iter(per_robot.values()), {})
        extras = {
            "converged_iteration": first.get("converged_iteration", 0),
            "per_robot": per_robot,
            "stopped_early": stopped_any,
        }
        msg = "; ".join(msgs) or (
            f"{self.name}: best collision-free path after {n_iter} iteration(s)"
            + (" (stopped by callback)" if stopped_any else ""))
        return self.finish(problem, paths, claim=Status.solved if all_ok else Status.approximate,
                           cost=cost, message=msg, n_iter=n_iter, n_eval=n_eval,
                           history=hist, extras=extras, wall_time=time.perf_counter() - t0)


def _merge_rows(all_rows: list[list[dict[str, Any]]]) -> History:
    """One history: a single robot's rows, or per-iteration sums over several robots."""
    hist = History()
    if not all_rows:
        return hist
    if len(all_rows) == 1:  # columns in first-seen order, nan where a row lacks one
        rows = all_rows[0]
        keys = list(dict.fromkeys(k for r in rows for k in r))
        return History({k: [r.get(k, np.nan) for r in rows] for k in keys})
    n = max(len(r) for r in all_rows)
    for i in range(n):
        rows = [r[min(i, len(r) - 1)] for r in all_rows]
        hist.append(iteration=i, best_cost=sum(r["best_cost"] for r in rows),
                    feasible_best_length=sum(r["feasible_best_length"] for r in rows),
                    n_eval=sum(r["n_eval"] for r in rows), time=rows[-1]["time"],
                    mean_cost=sum(r["mean_cost"] for r in rows))
    return hist
