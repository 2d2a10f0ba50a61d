r"""Improved PSO of the paper (§III.B, eqs 17-33): adaptive inertia, tanh position factor,
GA selection/crossover/mutation.

Per iteration (update from the paper's ``k`` to ``k + 1``; our 1-based iteration ``it`` uses
``k = it - 1``):

1. **Adaptive inertia weight** (eqs 17-21)::

       w(k)    = 1 / (1 + exp(alpha * dw(k-1)))          (17)
       alpha   = ln((1 - w_max) / w_max)                  (18)
       dw      = delta * beta                             (19)
       delta   = (w_max - w_min) / k_max                  (20)
       beta    = (V_{k-1} + V_k) / (2 V_{k-1})            (21)

   ``V_k`` is read as the swarm's mean velocity norm ``mean_i ||v_i^k||`` after the k-th move
   (``beta = 1`` while it is undefined, i.e. before two moves or when ``V_{k-1} = 0``).
   *Ambiguity.*  Taken literally (``inertia = "paper"``), ``dw = delta * beta`` is about
   ``0.0035`` for the paper's settings, so ``w(k) = 1/(1 + exp(alpha dw))`` stays at about
   ``0.50``: eq 17 maps ``dw in [0, 1]`` onto ``[0.5, w_max]`` and ``w_min`` never enters.
   The text around the equations ("if dw = delta, w decreases linearly"; ``beta > 1`` gives a
   stronger reduction) describes instead ``w(k) = w(k-1) - dw(k-1)`` from ``w_max`` to
   ``w_min``; that is ``inertia = "linear"`` (clipped to ``[w_min, w_max]``).
2. **Velocity** (eq 22): eq 1 with ``w(k)`` (:func:`optplan.swarm.operators.velocity_update`).
3. **Position** (eqs 23-24)::

       psi(k)  = 1 - tanh(k / (k_max + 1))               (23)
       x^{k+1} = psi(k) * R * x^k + v^{k+1}              (24)

   with the random search factor ``R ~ U(0, 1)`` drawn per particle and coordinate (like
   ``eps`` and ``eta``).  *Ambiguity.*  Multiplying an absolute position by ``psi R < 1``
   pulls every particle toward the coordinate origin (a corner of the paper's maps): the
   result depends on where the origin is.  ``position_update = "paper"`` keeps eq 24 as
   printed; ``"frame"`` applies ``psi R`` to the waypoints' lateral offsets from the
   start-goal line (frame-independent: a pull toward the straight line); ``"step"`` applies it
   to the step, ``x^{k+1} = x^k + psi R v^{k+1}``, which is what the text motivates ("a larger
   search step early, a smaller one later").
4. **GA** (eqs 25-29), on the swarm as evaluated before the move: the ``A`` best particles
   are paired in rank order (1st with 2nd, ...).  Corresponding waypoints closer than
   ``crossover_tol * diag`` are *shared* ("locally identical path information").  The text
   says the pair then swaps the path fragment between shared points, and that a pair with no
   identical fragment is not crossed: ``crossover = "swap"`` (``ipso-paper``) exchanges the
   waypoints between the first two shared waypoints (or the first one and the goal),
   velocities likewise (:func:`~optplan.swarm.ga.shared_fragment`,
   :func:`~optplan.swarm.ga.swap_fragments`).  The equations printed after that sentence are
   arithmetic crossovers of whole vectors,
   ``crossover = "blend"`` (pairs with at least one shared waypoint)::

       child_1(x) = p_c parent_1(x) + (1 - p_c) parent_2(x)       (25)
       child_2(x) = (1 - p_c) parent_1(x) + p_c parent_2(x)       (26)

   and the same for velocities (27-28), ``p_c ~ U(0, 1)`` per pair (drawn only for
   ``"blend"``).  **Mutation** (eq 29):
   each child gets a candidate ``child + C_k``; the better of the two (lower cost: the paper's
   "higher fitness" means better) is kept.  ``C_k`` is undefined in the paper; here
   ``C_k ~ N(0, (mutation_scale * range * psi(k))^2)`` per coordinate, so the mutation shrinks
   with the position factor.  The children (with their velocities) take the slots of the
   worst particles of the moved swarm ("weakly adapted individuals die out"); their personal
   best is reset to themselves.  Swarm, children and mutants are scored in one batch.
5. Fitness: eqs 30-33, see :mod:`optplan.swarm.core`.

Implementation: the per-iteration steps (the GA operators of :mod:`optplan.swarm.ga`,
:func:`~optplan.swarm.ga.ga_pairs` and the crossover of
:func:`~optplan.swarm.ga.ga_children`, and :func:`move`, :func:`advance`, :func:`absorb`) are
compiled with numba (the only implementation); every random number is drawn in Python from the
run's generator, in this order per iteration: ``p_c`` (one per crossed pair, ``"blend"``
only), the mutation noise ``(children, D)``, then ``eps, eta, R`` as one ``(3, P, D)`` draw
(and, with ``bounds_mode = "random"``, the re-draws of the bounds handling).

Beyond the paper (options, all off in ``ipso-paper``): islands, roadmap seeding with
several homotopy classes (``init_mode = "roadmap"``, ``corridors``) and the end-game
(``tighten_rounds``, ``endgame``, :mod:`optplan.swarm.endgame`); see :class:`IPSO`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import types

from optplan.geometry.compiled import F1, F2, F3, FA2, I1, argsort_stable, compiled, f8, i8, inlined
from optplan.solver import option
from optplan.swarm.backend import MAX_PARTICLES, SwarmBackend, SwarmState
from optplan.swarm.core import PathBuffer, SwarmSpace, evaluate_paths
from optplan.swarm.endgame import endgame_candidates, tighten_best
from optplan.swarm.ga import ga_children, ga_pairs
from optplan.swarm.operators import BOUND_CODES, bound_rows, redraw_out, velocity_update

__all__ = [
    "IPSO",
    "IPSORun",
    "inertia_alpha",
    "inertia_delta",
    "velocity_ratio",
    "inertia_weight",
    "position_factor",
    "move",
    "advance",
    "absorb",
    "island_bests",
]

INERTIA_MODES = ("paper", "linear")
POSITION_MODES = ("paper", "step", "frame")
ENDGAME_MODES = ("islands", "classes")
CROSSOVER_MODES = ("blend", "swap")

_NO_DRAW = np.zeros(0)


# --------------------------------------------------------------------------------------
# the paper's equations
# --------------------------------------------------------------------------------------


def inertia_alpha(w_max: float) -> float:
    """Eq 18: ``alpha = ln((1 - w_max) / w_max)``."""
    return math.log((1.0 - w_max) / w_max)


def inertia_delta(w_max: float, w_min: float, k_max: int) -> float:
    """Eq 20: ``delta = (w_max - w_min) / k_max``."""
    return (w_max - w_min) / max(k_max, 1)


def velocity_ratio(v_prev: float | None, v_cur: float) -> float:
    """Eq 21: ``beta = (V_{k-1} + V_k) / (2 V_{k-1})``; 1 when ``V_{k-1}`` is 0 or undefined."""
    if v_prev is None or not (v_prev > 0 and math.isfinite(v_prev) and math.isfinite(v_cur)):
        return 1.0
    return (v_prev + v_cur) / (2.0 * v_prev)


def inertia_weight(dw: float, w_max: float) -> float:
    """Eq 17: ``w = 1 / (1 + exp(alpha * dw))`` with ``alpha`` from eq 18.

    ``dw = 1`` gives ``w_max``; ``dw = 0`` gives 0.5.
    """
    return 1.0 / (1.0 + math.exp(inertia_alpha(w_max) * dw))


def position_factor(k: float | np.ndarray, k_max: int) -> float | np.ndarray:
    """Eq 23: ``psi(k) = 1 - tanh(k / (k_max + 1))`` (a Python float for a scalar ``k``)."""
    if isinstance(k, (int, float)):
        return 1.0 - math.tanh(k / (k_max + 1.0))
    return 1.0 - np.tanh(np.asarray(k, dtype=float) / (k_max + 1.0))


# --------------------------------------------------------------------------------------
# the compiled steps of one iteration
# --------------------------------------------------------------------------------------



#: ``swarm``: ``X, V, pbest`` (positions, a view into the batch; velocities; personal bests)
_SWARM = types.Tuple((FA2, F2, F2))
#: ``motion``: ``psi, mode, start, goal`` (eqs 23-24: the position factor and update mode)
_MOTION = types.Tuple((f8, i8, F1, F1))


@inlined  # one call site (advance)
def move(swarm, guides, leader, coef, U, vmax, motion, out):
    """Eqs 22-24 for the whole swarm ``(X, V, pbest)``: ``V^{k+1}`` into ``out_V`` (eq 22
    with the weights ``coef = (w, c1, c2)``, ``eps = U[0]``, ``eta = U[1]``), then
    ``X^{k+1}`` into ``out_X`` (``out = (out_X, out_V)``) with ``psi(k) R``, ``R = U[2]``
    (``motion = (psi, mode, start, goal)``)::

        mode 0 ("paper"):  x^{k+1} = psi R x^k + v^{k+1}                      (24)
        mode 1 ("step"):   x^{k+1} = x^k + psi R v^{k+1}
        mode 2 ("frame"):  x^{k+1} = foot + psi R (x^k - foot) + v^{k+1}, foot = the
                           waypoint's projection on the start-goal line

    Bounds are not handled here.
    """
    X, V, pbest = swarm
    psi, mode, start, goal = motion
    out_X, out_V = out
    velocity_update(V, X, pbest, guides, leader, coef, U[0], U[1], vmax, out_V)
    P, D = X.shape
    ux = goal[0] - start[0]
    uy = goal[1] - start[1]
    uu = ux * ux + uy * uy
    for i in range(P):
        for j in range(0, D, 2):
            for d in range(j, j + 2):
                R = U[2, i, d] * psi  # psi(k) R, eq 23
                if mode == 0:  # eq 24 as printed
                    out_X[i, d] = R * X[i, d] + out_V[i, d]
                elif mode == 1:  # on the step
                    out_X[i, d] = R * out_V[i, d] + X[i, d]
                else:  # on the lateral offset from the start-goal line
                    t = 0.0
                    if uu > 0:
                        t = ((X[i, j] - start[0]) * ux + (X[i, j + 1] - start[1]) * uy) / uu
                    foot = start[d - j] + t * (ux if d == j else uy)
                    out_X[i, d] = (X[i, d] - foot) * R + foot + out_V[i, d]


@compiled(_SWARM, F2, I1, types.UniTuple(f8, 3), F3, F1, _MOTION, i8,
          types.Tuple((F1, F1, i8)), types.Tuple((FA2, F2)))
def advance(swarm, guides, leader, coef, U, vmax, motion, m, bounds, out):
    """The pre-evaluation part of one iteration after the GA (:func:`ga_children` wrote the
    ``m`` mutants and children to rows ``P .. P + 2m`` of the batch ``B``, ``out = (B,
    V_new)``): the move of ``swarm = (X, V, pbest)`` (:func:`move`, rows ``:P`` and
    ``V_new``), then bounds handling of swarm and mutants (``bounds = (lo, hi, bound_code)``,
    see :func:`optplan.swarm.operators.bound_rows`; velocities of reflected coordinates
    reversed, of clipped ones zeroed).  Returns the out-of-bounds mask (for ``random`` mode,
    whose re-draws the caller makes) and whether any coordinate is out."""
    B, V_new = out
    lo, hi, bound_code = bounds
    P = swarm[0].shape[0]
    move(swarm, guides, leader, coef, U, vmax, motion, (B[:P], V_new))
    out, anyout = bound_rows(B[:P + m], lo, hi, bound_code)
    if anyout:
        for i in range(P):
            for d in range(V_new.shape[1]):
                if out[i, d]:
                    V_new[i, d] = -V_new[i, d] if bound_code == 1 else 0.0
    return out, anyout


@inlined  # one call site (absorb)
def _worst_slots(F, isl, n_islands):
    """Slots of the worst particles: the r-th child of island i takes the r-th worst particle
    of island i (``isl`` sorted by island; one island: the worst of the whole swarm)."""
    P = F.shape[0]
    m_i = P // n_islands
    slots = np.empty(isl.shape[0], np.int64)
    q = 0
    for i in range(n_islands):
        order = argsort_stable(F[i * m_i:(i + 1) * m_i])[::-1]
        r = 0
        while q < isl.shape[0] and isl[q] == i:
            slots[q] = order[min(r, m_i - 1)] + i * m_i
            r += 1
            q += 1
    return slots


@compiled(_SWARM, F1, types.Tuple((F1, F1, I1)), FA2, i8, F2, I1, i8)
def absorb(swarm, pbest_f, scores, B, m, cv, isl, n_islands):
    """Memories of ``swarm = (X, V, pbest)`` (and ``pbest_f``) after the evaluation of the
    batch ``B`` (swarm ``:P``, mutants, children; ``scores = (cost, length, count)`` per
    row), in place: the best scored row and the shortest collision-free row (their positions are
    copied out *before* any slot changes), the personal bests of the moved swarm ``X``, then
    eq 29 (the better of mutant ``B[P + r]`` and child ``B[P + m + r]``) and the replacement of
    the worst particles of each child's island by the kept children.

    Returns ``(F, mutants kept, best row, its position, shortest feasible row or -1, its
    position)``.
    """
    X, V, pbest = swarm
    cost, length, count = scores
    P = X.shape[0]
    n = P + 2 * m
    j_best = np.argmin(cost[:n])
    best_x = B[j_best].copy()
    j_feas = -1
    for r in range(n):
        if count[r] == 0 and (j_feas < 0 or length[r] < length[j_feas]):
            j_feas = r
    feas_x = B[max(j_feas, 0)].copy()
    F = cost[:P].copy()
    D = X.shape[1]
    for i in range(P):
        if F[i] < pbest_f[i]:
            for d in range(D):  # element loops, not row assignments (module docstring)
                pbest[i, d] = X[i, d]
            pbest_f[i] = F[i]
    kept = 0
    if m > 0:
        use_m = cost[P:P + m] < cost[P + m:P + 2 * m]  # eq 29, greedy
        o = np.empty(isl.shape[0], np.int64)  # the pairs by island, stable (counting sort)
        q = 0
        for i in range(n_islands):
            for r in range(isl.shape[0]):
                if isl[r] == i:
                    o[q] = r
                    q += 1
        slots = _worst_slots(F, isl[o], n_islands)
        for q in range(m):
            r = o[q]
            row = P + r if use_m[r] else P + m + r
            s = slots[q]
            for d in range(D):  # the weakly adapted individuals die out
                X[s, d] = B[row, d]
                V[s, d] = cv[r, d]
                pbest[s, d] = B[row, d]
            F[s] = cost[row]
            pbest_f[s] = cost[row]
            kept += use_m[r]
    return F, kept, j_best, best_x, j_feas, feas_x


def island_bests(pbest_f: np.ndarray, n_islands: int) -> np.ndarray:
    """Index of each island's best personal best (islands = blocks of consecutive particles;
    the first on ties)."""
    m_i = len(pbest_f) // n_islands
    return (pbest_f[:n_islands * m_i].reshape(n_islands, m_i).argmin(axis=1)
            + m_i * np.arange(n_islands, dtype=np.int64))



# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass(eq=False)
class IPSORun:
    """Constants and algorithm state of one IPSO run (one robot); see :class:`IPSO`."""

    buffer: PathBuffer
    vmax: np.ndarray
    mut_sigma: np.ndarray
    n_islands: int
    n_select: int
    tol2: float
    position_code: int
    seeds: list
    leader: np.ndarray
    island_idx: np.ndarray
    ones: np.ndarray
    w: float
    v_prev: float | None = None
    v_cur: float = 0.0
    crossovers: int = 0
    mutations_kept: int = 0

    def stats(self) -> dict[str, Any]:
        """The public per-robot counters (``extras["per_robot"]``)."""
        return {"w": self.w, "crossovers": self.crossovers,
                "mutations_kept": self.mutations_kept}


@dataclass(frozen=True, kw_only=True)
class IPSO(SwarmBackend):
    """Improved PSO (paper eqs 17-33).

    Parameters
    ----------
    w_max, w_min : float
        Bounds of the adaptive inertia weight (paper: 0.9 and 0.2), eqs 17-21.
    inertia : {"paper", "linear"}
        ``"paper"``: eq 17 literally (w stays near 0.5); ``"linear"``: the text's reading
        ``w(k) = w(k-1) - delta beta`` from w_max toward w_min (module docstring).
    position_update : {"paper", "step", "frame"}
        Eq 24 as printed (absolute coordinates), on the step, or in the start-goal frame
        (module docstring).
    A : int
        Number of best particles selected for crossover (even; the paper does not give it);
        at most the whole swarm is selected (``A / islands`` per island, at most its size).
    crossover : {"blend", "swap"}
        The GA crossover of a selected pair.  ``"swap"`` (``ipso-paper``): the paper's text,
        "intercept the locally identical path information in two particles ... swapping each
        other": the waypoints between the pair's first two shared waypoints (or between the
        first shared one and the goal) are exchanged (:func:`optplan.swarm.ga.shared_fragment`,
        :func:`optplan.swarm.ga.swap_fragments`), velocities likewise; a pair without such a
        fragment is not crossed.  ``"blend"``: eqs 25-28 on the whole particles
        (``p_c ~ U(0, 1)`` per pair), for the pairs with at least one shared waypoint.
    crossover_tol : float
        Two corresponding waypoints are *shared* ("locally identical path information") when
        they are closer than ``crossover_tol * map diagonal``; ``inf`` shares every waypoint
        (``"blend"``: every pair crosses).
    mutation_scale : float
        Standard deviation of the mutation ``C_k`` of eq 29 as a fraction of the map range,
        multiplied by ``psi(k)``.
    islands : int
        Beyond the paper (diversity): the swarm is split into this many equal islands of
        consecutive particles, each following its own island best in eq 22 instead of the
        global best, each running its own GA (its ``A / islands`` best are crossed and replace
        its worst): independent sub-swarms scored in one batch, which keep several homotopy
        classes alive.  1 = the paper's single global best.  The number used is the largest
        divisor of ``n_particles`` that is at most ``islands`` and leaves at least 2 particles
        per island.
    tighten_rounds : int
        Beyond the paper (the end-game): after the ``k_max`` iterations,
        :func:`optplan.swarm.refine.tighten` (deterministic corner cutting + string pulling,
        at most this many rounds) is applied to the candidates of ``endgame``; the shortest
        result is returned (one extra history row).  The returned path then has as many
        vertices as the tightening needs (more than ``n_waypoints`` around rounded corners).
        0: no end-game.
    endgame : {"islands", "classes"}
        Candidates of the end-game: ``"islands"``: the best collision-free particle and every
        island's best; ``"classes"``: those and the roadmap corridors, reduced to the
        shortest candidate of each homotopy class (by signature), so that every class the run
        has seen is compared after tightening.
    endgame_margin : float
        Beyond the paper: after a quick coarse tightening of every end-game candidate, those
        within this fraction of the best (at most :data:`optplan.swarm.endgame.ENDGAME_KEEP`)
        are tightened in full.
    n_particles, k_max, c1, c2, n_waypoints, v_max, bounds_mode, init_mode, penalty_weight, \
penetration_weight, roadmap_samples, roadmap_boundary, roadmap_medial, roadmap_neighbours, \
corridors
        Shared swarm options, see :class:`optplan.swarm.backend.SwarmBackend`.
    """

    name: ClassVar[str] = "ipso"
    w_max: float = option(0.9, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    w_min: float = option(0.2, lo=0.0, hi=1.0)
    inertia: str = option("paper", choices=INERTIA_MODES)
    position_update: str = option("paper", choices=POSITION_MODES)
    A: int = option(10, lo=0, hi=MAX_PARTICLES)
    crossover: str = option("blend", choices=CROSSOVER_MODES)
    crossover_tol: float = option(0.05, lo=0.0, inf_ok=True)
    mutation_scale: float = option(0.05, lo=0.0, hi=10.0)
    islands: int = option(1, lo=1, hi=MAX_PARTICLES // 2)
    tighten_rounds: int = option(0, lo=0, hi=100_000)
    endgame: str = option("islands", choices=ENDGAME_MODES)
    endgame_margin: float = option(0.005, lo=0.0, hi=10.0)

    def check(self) -> None:
        """``w_min <= w_max``; ``A`` even (the selected particles are paired)."""
        if self.w_min > self.w_max:
            raise ValueError(f"option 'w_min' of backend 'ipso' must be <= w_max "
                             f"({self.w_max}), got {self.w_min!r}")
        if self.A % 2:
            raise ValueError(f"option 'A' of backend 'ipso' must be an even integer, "
                             f"got {self.A!r}")

    @property
    def n_islands(self) -> int:
        """Islands actually used (see the ``islands`` option)."""
        top = min(self.islands, self.n_particles // 2)
        return max((i for i in range(1, top + 1) if self.n_particles % i == 0), default=1)

    def _selection_size(self) -> int:
        """Particles selected for crossover per island: ``A / islands``, at most the island
        size, rounded down to even."""
        I = self.n_islands
        A = min(self.A // I, self.n_particles // I)
        return A - A % 2

    def _seed_blocks(self, n_seeds: int) -> int:
        """Roadmap corridors placed in the initial swarm: the shortest ones, one per island
        (the end-game compares all of them); with one island all, spread over the swarm."""
        if self.n_islands > 1:
            return min(n_seeds, self.n_islands)
        return super()._seed_blocks(n_seeds)

    # ---------------------------------------------------------------------------------
    def _start(self, space: SwarmSpace, state: SwarmState, seeds: list[np.ndarray],
               rng: np.random.Generator) -> IPSORun:
        I = self.n_islands
        P = self.n_particles
        tol = self.crossover_tol * space.diag
        run = IPSORun(
            # swarm, mutants, children: at most I n_select of each (A beyond that selects none)
            buffer=PathBuffer(space, P + 2 * I * self._selection_size()),
            vmax=self._vmax(space), mut_sigma=self.mutation_scale * space.span,
            n_islands=I, n_select=self._selection_size(),
            tol2=tol * tol if math.isfinite(tol) else math.inf,
            position_code=POSITION_MODES.index(self.position_update), seeds=list(seeds),
            leader=np.arange(P) // (P // I) if I > 1 else np.zeros(P, np.int64),
            island_idx=island_bests(state.pbest_f, I), ones=np.ones(space.dim), w=self.w_max)
        return run

    def _inertia(self, run: IPSORun) -> float:
        """Eqs 17-21 (``inertia = "paper"``) or the linear reading."""
        beta = velocity_ratio(run.v_prev, run.v_cur)
        dw = inertia_delta(self.w_max, self.w_min, self.k_max) * beta
        if self.inertia == "paper":
            return inertia_weight(dw, self.w_max)
        if run.v_prev is None:  # first move: w(0) = w_max
            return self.w_max
        return float(min(max(run.w - dw, self.w_min), self.w_max))

    def _iterate(self, space: SwarmSpace, state: SwarmState, run: IPSORun, it: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        st = state
        k = it - 1
        w = self._inertia(run)
        psi = position_factor(k, self.k_max)
        P, D = st.X.shape
        B = run.buffer.X(it)  # this iteration's batch: swarm, mutants, children
        # GA selection on the swarm as evaluated before the move (eqs 25-26)
        swap = self.crossover == "swap"
        pairs, isl, frag = ga_pairs(st.F, st.X, run.n_islands, run.n_select, run.tol2, swap)
        h = len(pairs)
        m = 2 * h
        pc = rng.random(h) if h and not swap else _NO_DRAW
        noise = rng.standard_normal((m, D)) if h else _NO_DRAW.reshape(0, 1)
        U = rng.random((3, P, D))
        guides = st.pbest[run.island_idx] if run.n_islands > 1 else st.gbest[None]
        V = np.empty_like(st.V)
        # crossover, mutants, move, bounds (eqs 22-29 up to the evaluation)
        cv = ga_children(st.X, st.V, pairs, pc, noise, run.mut_sigma * psi, B[P:], frag, swap)
        out, anyout = advance(
            (st.X, st.V, st.pbest), guides, run.leader, (float(w), float(self.c1),
                                                         float(self.c2)), U, run.vmax,
            (float(psi), run.position_code, space.start, space.goal), m,
            (space.lo, space.hi, BOUND_CODES[self.bounds_mode]), (B, V))
        if anyout and self.bounds_mode == "random":
            redraw_out(B[:P + m], out, space.lo, space.hi, rng)
        main = P + 2 * m
        ev = evaluate_paths(run.buffer.paths(it)[:main], space)  # one collision test
        st.n_eval += main
        # memories, eq 29, the children replace the worst particles
        F, kept, jb, bx, jf, fx = absorb((B[:P], V, st.pbest), st.pbest_f,
                                         (ev.cost, ev.length, ev.count), B, m, cv,
                                         np.concatenate((isl, isl)), run.n_islands)
        st.X, st.V, st.F = B[:P], V, F
        if ev.cost[jb] < st.gbest_f:
            st.gbest, st.gbest_f, st.gbest_count = bx, float(ev.cost[jb]), int(ev.count[jb])
        if jf >= 0 and ev.length[jf] < st.feas_len:
            st.feas_x, st.feas_len = fx, float(ev.length[jf])
        if run.n_islands > 1:
            run.island_idx = island_bests(st.pbest_f, run.n_islands)
        vnorm = float(np.add.reduce(np.sqrt((V * V) @ run.ones))) / P
        run.v_prev, run.v_cur, run.w = run.v_cur, vnorm, w
        run.crossovers += h
        run.mutations_kept += kept
        return {"w": w, "psi": psi, "children": m, "mean_speed": vnorm}

    def _stats(self, run: IPSORun) -> dict[str, Any]:
        return run.stats()


    # -- beyond the paper: the end-game (optplan.swarm.endgame) --------------------------
    def _finish(self, space: SwarmSpace, state: SwarmState, run: IPSORun,
                rng: np.random.Generator):
        """Beyond the paper: :func:`~optplan.swarm.endgame.tighten_best` of the end-game
        candidates (:func:`~optplan.swarm.endgame.endgame_candidates`: a few rounds for all of
        them, then the full ``tighten_rounds`` for those within ``endgame_margin`` of the
        best); the shortest result is the answer."""
        if not self.tighten_rounds:
            return
        st = state
        cand, n = endgame_candidates(
            space, st.feas_x, st.pbest[run.island_idx] if run.n_islands > 1 else (),
            run.seeds if self.endgame == "classes" else (), self.endgame == "classes")
        st.n_eval += n
        if not cand:
            return
        path, best_len, n_cand, n = tighten_best(cand, space, self.tighten_rounds,
                                                 self.endgame_margin)
        st.n_eval += n
        if path is None:
            return
        if best_len < st.feas_len:
            st.final_path = path
            st.stats["tightened_from"] = st.feas_len
            st.feas_len = best_len
            if best_len < st.gbest_f:
                st.gbest_f, st.gbest_count = best_len, 0
        st.stats["endgame_candidates"] = n_cand
        yield {"tightened": best_len}
