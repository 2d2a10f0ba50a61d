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
2. **Velocity** (eq 22): eq 1 with ``w(k)``.
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
   are paired in rank order (1st with 2nd, ...).  A pair is crossed only when it shares
   "locally identical path information", read as: at least one pair of corresponding
   waypoints closer than ``crossover_tol * diag`` (``inf``: always cross).  Children::

       child_1(x) = p_c parent_1(x) + (1 - p_c) parent_2(x)       (25)
       child_2(x) = (1 - p_c) parent_1(x) + p_c parent_2(x)       (26)

   and the same for velocities (27-28), ``p_c ~ U(0, 1)`` per pair.  **Mutation** (eq 29):
   each child gets a candidate ``child + C_k``; the better of the two (lower cost: the paper's
   "higher fitness" means better) is kept.  ``C_k`` is undefined in the paper; here
   ``C_k ~ N(0, (mutation_scale * range * psi(k))^2)`` per coordinate, so the mutation shrinks
   with the position factor.  The children (with their velocities) take the slots of the
   worst particles of the moved swarm ("weakly adapted individuals die out"); their personal
   best is reset to themselves.  Swarm, children and mutants are scored in one batch.
5. Fitness: eqs 30-33, see :mod:`optplan.backends.swarm`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.backends.swarm import (
    PathBuffer,
    SwarmBackend,
    SwarmSpace,
    SwarmState,
    bounce_velocity,
    bound_positions,
    decode,
    evaluate_paths,
    evaluate_swarm,
    snap_targets,
    tighten,
)
from optplan.solver import check_choice, check_int, check_range

__all__ = [
    "IPSO",
    "inertia_alpha",
    "inertia_delta",
    "velocity_ratio",
    "inertia_weight",
    "position_factor",
    "crossover",
    "greedy_mutation",
    "redistribute_candidates",
    "snap_candidates",
]

INERTIA_MODES = ("paper", "linear")
POSITION_MODES = ("paper", "frame", "step")


def inertia_alpha(w_max: float) -> float:
    """Eq 18: ``alpha = ln((1 - w_max) / w_max)``."""
    return math.log((1.0 - w_max) / w_max)


def inertia_delta(w_max: float, w_min: float, k_max: int) -> float:
    """Eq 20: ``delta = (w_max - w_min) / k_max``."""
    return (w_max - w_min) / max(k_max, 1)


def velocity_ratio(v_prev: float, v_cur: float) -> float:
    """Eq 21: ``beta = (V_{k-1} + V_k) / (2 V_{k-1})``; 1 when ``V_{k-1}`` is 0 or undefined."""
    if not (v_prev > 0 and math.isfinite(v_prev) and math.isfinite(v_cur)):
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


def crossover(x1: np.ndarray, x2: np.ndarray, v1: np.ndarray, v2: np.ndarray,
              pc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Eqs 25-28 for a batch of pairs: ``pc`` has one value per pair (shape ``(m,)``).

    Returns ``(child1_x, child2_x, child1_v, child2_v)``, each the stated convex combination.
    """
    p = np.asarray(pc, dtype=float)[:, None]
    dx = x1 - x2
    dx *= p
    dv = v1 - v2
    dv *= p
    # p x1 + (1 - p) x2 = x2 + p (x1 - x2); (1 - p) x1 + p x2 = x1 - p (x1 - x2)
    return x2 + dx, x1 - dx, v2 + dv, v1 - dv


def greedy_mutation(cost_child: np.ndarray, cost_mutant: np.ndarray) -> np.ndarray:
    """Eq 29: True where the mutant ``child + C_k`` is kept (strictly better), else the child."""
    return np.asarray(cost_mutant) < np.asarray(cost_child)


def redistribute_candidates(x: np.ndarray, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """For each waypoint ``i`` of particle ``x``: drop it and re-insert a waypoint at the
    midpoint of the longest segment of what remains.  Returns ``(n, 2n)`` candidates.

    A waypoint the path does not need (e.g. collinear) can so move to where one is missing
    (a second vertex around a wide corner); the re-inserted midpoint leaves the path unchanged.
    Beyond the paper (option ``redistribute``).
    """
    W = x.reshape(-1, 2)
    n = len(W)
    if n < 2:
        return x[None, :].copy()
    keep = np.array([[j for j in range(n) if j != i] for i in range(n)])  # (n, n-1)
    Wd = W[keep]  # (n, n-1, 2)
    full = np.concatenate([np.broadcast_to(start, (n, 1, 2)), Wd,
                           np.broadcast_to(goal, (n, 1, 2))], axis=1)  # (n, n+1, 2)
    seg = np.hypot(*np.diff(full, axis=1).transpose(2, 0, 1))  # (n, n)
    j = np.argmax(seg, axis=1)
    r = np.arange(n)
    mid = 0.5 * (full[r, j] + full[r, j + 1])
    out = np.empty((n, n + 2, 2))
    out[:, : n + 1] = full
    # insert mid after point j: shift the tail by one
    idx = np.arange(n + 2)[None, :]
    src = np.where(idx <= j[:, None], idx, idx - 1)
    out = full[r[:, None], np.clip(src, 0, n)]
    out[r, j + 1] = mid
    return out[:, 1:-1].reshape(n, -1)


def snap_candidates(x: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """``n + 1`` candidates: waypoint ``i`` moved onto its nearest target, and all at once."""
    W = x.reshape(-1, 2)
    n = len(W)
    d = np.hypot(W[:, None, 0] - targets[None, :, 0], W[:, None, 1] - targets[None, :, 1])
    near = targets[np.argmin(d, axis=1)]  # (n, 2)
    C = np.repeat(W[None], n + 1, axis=0)
    C[np.arange(n), np.arange(n)] = near
    C[n] = near
    return C.reshape(n + 1, -1)


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
    position_update : {"paper", "frame", "step"}
        Eq 24 as printed (absolute coordinates), in the start-goal frame, or on the step
        (module docstring).
    A : int
        Number of best particles selected for crossover (even; the paper does not give it).
    crossover_tol : float
        Pairs cross only if some corresponding waypoints are closer than
        ``crossover_tol * map diagonal`` ("locally identical path information"); ``inf``
        crosses every pair.
    mutation_scale : float
        Standard deviation of the mutation ``C_k`` of eq 29 as a fraction of the map range,
        multiplied by ``psi(k)``.
    redistribute : bool
        Beyond the paper: every iteration also score the :func:`redistribute_candidates` of
        gbest (same batch); one that is not worse replaces gbest and the worst particle.
    snap : bool
        Beyond the paper: every iteration also score, for each waypoint of gbest, the move
        of that waypoint onto the nearest convex obstacle corner, moved out to the robot
        radius plus 1e-6 of the map size (:func:`optplan.backends.swarm.snap_targets`), plus
        all waypoints snapped at once; shortest paths bend only there.  A better candidate
        replaces gbest and the worst particle.
    local_trials : int
        Beyond the paper: every iteration also score this many Gaussian trials around gbest
        with an adaptive step (x2 after a success, x0.8 otherwise); a better one replaces
        gbest and the worst particle.
    islands : int
        Beyond the paper (diversity): the swarm is split into this many equal islands of
        consecutive particles, each following its own island best in eq 22 instead of the
        global best (GA and the beyond-the-paper moves still use the whole swarm and gbest).
        Each island also runs its own GA (its ``A / islands`` best are crossed and replace its
        worst) and the beyond-the-paper moves visit one island's best per iteration (round
        robin), so the islands are independent sub-swarms scored in one batch: they keep
        several homotopy classes alive.  1 = the paper's single global best.  The number used
        is the largest divisor of ``n_particles`` that is at most ``islands`` and leaves at
        least 2 particles per island.
    tighten_rounds : int
        Beyond the paper: after the ``k_max`` iterations, :func:`optplan.backends.swarm.tighten`
        (deterministic corner cutting + string pulling, at most this many rounds) is applied to
        the best collision-free particle and to every island's best; the shortest result is
        returned (one extra history row).  The returned path then has as many vertices as the
        tightening needs (more than ``n_waypoints`` around rounded corners).
    n_particles, k_max, c1, c2, n_waypoints, v_max, bounds_mode, init_mode, penalty_weight, \
penetration_weight
        Shared swarm options, see :class:`optplan.backends.swarm.SwarmBackend`.
    """

    name: ClassVar[str] = "ipso"
    contract_problem: ClassVar[str] = "open-field"
    contract_overrides: ClassVar[dict] = {"n_particles": 10, "k_max": 10, "A": 4}

    w_max: float = 0.9
    w_min: float = 0.2
    inertia: str = "paper"
    position_update: str = "paper"
    A: int = 10
    crossover_tol: float = 0.05
    mutation_scale: float = 0.05
    redistribute: bool = False
    snap: bool = False
    local_trials: int = 0
    islands: int = 1
    tighten_rounds: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range(self, "w_max", 0.0, 1.0, lo_open=True, hi_open=True)
        check_range(self, "w_min", 0.0, 1.0)
        if self.w_min > self.w_max:
            raise ValueError(f"option 'w_min' of backend 'ipso' must be <= w_max "
                             f"({self.w_max}), got {self.w_min!r}")
        check_choice(self, "inertia", INERTIA_MODES)
        check_choice(self, "position_update", POSITION_MODES)
        check_int(self, "A", 0, 100_000)
        if self.A % 2:
            raise ValueError(f"option 'A' of backend 'ipso' must be an even integer, "
                             f"got {self.A!r}")
        check_range(self, "crossover_tol", 0.0, math.inf)
        check_range(self, "mutation_scale", 0.0, 10.0)
        if not isinstance(self.redistribute, bool):
            raise ValueError(f"option 'redistribute' of backend 'ipso' must be true or false, "
                             f"got {self.redistribute!r}")
        if not isinstance(self.snap, bool):
            raise ValueError(f"option 'snap' of backend 'ipso' must be true or false, "
                             f"got {self.snap!r}")
        check_int(self, "local_trials", 0, 100_000)
        check_int(self, "tighten_rounds", 0, 100_000)
        check_int(self, "islands", 1, 10_000)

    # ---------------------------------------------------------------------------------
    def _start(self, space: SwarmSpace, state: SwarmState, rng: np.random.Generator) -> None:
        state.stats.update(w=self.w_max, vnorms=[0.0], crossovers=0, mutations_kept=0,
                           local_sigma=0.01, local_accepted=0, redistributed=0, snapped=0)
        if self.snap:
            state.stats["_snap"] = snap_targets(space, 1e-6 * space.diag)
        state.stats["_ones"] = np.ones(space.dim)
        state.stats["_vmax"] = self._vmax(space)  # constant over the run
        state.stats["_c12"] = np.array([self.c1, self.c2])[:, None, None]
        state.stats["_mut_sigma"] = self.mutation_scale * space.span
        # rows scored per iteration: swarm, children, mutants, beyond-the-paper candidates
        n = space.n_waypoints
        extra = (n if self.redistribute else 0) + (n + 1 if self.snap else 0) + self.local_trials
        state.stats["_buffer"] = PathBuffer(space, self.n_particles + 2 * self.A + extra)
        if self._n_islands > 1:
            self._update_islands(state)

    @property
    def _n_islands(self) -> int:
        """Islands actually used (see the ``islands`` option)."""
        return max(i for i in range(1, min(self.islands, self.n_particles // 2, self.n_particles)
                                    + 1) if self.n_particles % i == 0) if self.islands > 1 else 1

    def _update_islands(self, state: SwarmState) -> None:
        """Each island's best personal best (islands = blocks of consecutive particles)."""
        I = self._n_islands
        m = len(state.pbest_f) // I
        j = np.argmin(state.pbest_f.reshape(I, m), axis=1) + m * np.arange(I)
        state.stats["_island_idx"] = j
        state.stats["_social"] = np.repeat(state.pbest[j], m, axis=0)

    def _selection_size(self, P: int) -> int:
        """Particles selected for crossover per island: ``A / islands``, at most the island
        size, rounded down to even."""
        A = min(self.A // self._n_islands, P // self._n_islands)
        return A - A % 2

    def _inertia(self, state: SwarmState) -> float:
        vn = state.stats["vnorms"]
        beta = velocity_ratio(vn[-2], vn[-1]) if len(vn) >= 2 else 1.0
        dw = inertia_delta(self.w_max, self.w_min, self.k_max) * beta
        if self.inertia == "paper":
            return inertia_weight(dw, self.w_max)
        if len(vn) < 2:  # first move: w(0) = w_max
            return self.w_max
        return float(min(max(state.stats["w"] - dw, self.w_min), self.w_max))

    def _move(self, space: SwarmSpace, state: SwarmState, w: float, k: int,
              rng: np.random.Generator, out: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Eqs 22-24 for the whole swarm: ``(X^{k+1}, V^{k+1})`` before bounds handling.

        ``eps``, ``eta`` and ``R`` ~ U(0, 1) per particle and coordinate (one draw).  The new
        positions are written into ``out`` when given.
        """
        P, D = state.X.shape
        U = rng.random((3, P, D))
        X = state.X
        U[:2] *= state.stats["_c12"]  # c1 eps, c2 eta
        V = state.V * w
        T = state.pbest - X
        T *= U[0]
        V += T
        social = state.stats["_social"] if self._n_islands > 1 else state.gbest
        np.subtract(social, X, out=T)
        T *= U[1]
        V += T  # eq 22
        vmax = state.stats["_vmax"]
        if vmax is not None:
            np.minimum(V, vmax, out=V)
            np.maximum(V, -vmax, out=V)
        R = U[2]
        R *= position_factor(k, self.k_max)  # psi(k) R, eq 23
        Xn = np.empty_like(X) if out is None else out
        if self.position_update == "paper":
            np.multiply(R, X, out=Xn)
            Xn += V  # eq 24 as printed
        elif self.position_update == "step":
            np.multiply(R, V, out=Xn)
            Xn += X
        else:  # lateral offsets from the start-goal line
            s, g = space.start, space.goal
            u = g - s
            uu = float(u @ u)
            W = X.reshape(P, -1, 2)
            tpar = ((W - s) @ u) / uu if uu > 0 else np.zeros(W.shape[:2])
            foot = (s + tpar[..., None] * u).reshape(P, D)
            np.subtract(X, foot, out=Xn)
            Xn *= R
            Xn += foot
            Xn += V
        return Xn, V

    def _children(self, space: SwarmSpace, state: SwarmState, k: int,
                  rng: np.random.Generator, out: np.ndarray):
        """Selection, crossover (eqs 25-28) and the mutation candidates ``child + C_k``.

        Writes the ``m`` mutants (bounds not yet handled) into ``out[:m]`` and the children
        into ``out[m:2m]``; returns ``(m, children's velocities, island of each child)``, with
        ``m = 0`` when no pair crosses.  With islands, each island selects its own
        ``A / islands`` best (rounded down to even).
        """
        I = self._n_islands
        P = len(state.F)
        m_i = P // I
        A = self._selection_size(P)
        if A < 2:
            return 0, None, None
        if I == 1:
            order = state.F.argsort(kind="stable")[:A]
        else:
            order = (np.argsort(state.F.reshape(I, m_i), axis=1, kind="stable")[:, :A]
                     + m_i * np.arange(I)[:, None]).reshape(-1)
        isl = np.repeat(np.arange(I), A // 2) if I > 1 else None
        xs = state.X[order]  # rank order: pairs (1st, 2nd), (3rd, 4th), ...
        x1, x2 = xs[0::2], xs[1::2]
        pairs = order.reshape(-1, 2)
        if math.isfinite(self.crossover_tol):
            dx = x1 - x2
            dx *= dx
            d2 = dx[:, 0::2] + dx[:, 1::2]  # squared waypoint distances, (pairs, n)
            gate = np.minimum.reduce(d2, axis=1) <= (self.crossover_tol * space.diag) ** 2
            if np.count_nonzero(gate) < len(gate):
                x1, x2, pairs = x1[gate], x2[gate], pairs[gate]
                isl = isl[gate] if isl is not None else None
        h = len(pairs)
        if h == 0:
            return 0, None, None
        m = 2 * h
        pc = rng.random(h)
        vs = state.V[pairs.reshape(-1)]
        c1x, c2x, c1v, c2v = crossover(x1, x2, vs[0::2], vs[1::2], pc)  # eqs 25-28
        CX = out[m:2 * m]
        CX[:h] = c1x
        CX[h:] = c2x
        CV = np.concatenate([c1v, c2v])
        MX = rng.standard_normal((m, out.shape[1]))
        MX *= state.stats["_mut_sigma"] * position_factor(k, self.k_max)
        np.add(MX, CX, out=out[:m])  # child + C_k
        return m, CV, (np.concatenate([isl, isl]) if isl is not None else None)

    def _absorb(self, st: SwarmState, X: np.ndarray, V: np.ndarray, cost: np.ndarray,
                B: np.ndarray, m: int, CV: np.ndarray | None, isl: np.ndarray | None
                ) -> tuple[np.ndarray, int]:
        """Personal bests of the moved swarm ``X`` (rows ``:P`` of ``cost``), then eq 29 (the
        better of child and mutant, rows ``P + m + r`` and ``P + r`` of ``B`` / ``cost``) and
        the replacement of the worst particles by the kept children, in place.

        Returns ``(F, number of mutants kept)``.
        """
        P = len(X)
        F = cost[:P].copy()
        better = F < st.pbest_f
        np.copyto(st.pbest, X, where=better[:, None])
        np.minimum(st.pbest_f, F, out=st.pbest_f)
        if not m:
            return F, 0
        cm, cc = cost[P:P + m], cost[P + m:P + 2 * m]
        use_m = cm < cc  # eq 29, greedy
        kept = int(np.count_nonzero(use_m))
        KX = np.where(use_m[:, None], B[P:P + m], B[P + m:P + 2 * m])
        kc = np.where(use_m, cm, cc)
        if self._n_islands > 1:
            o = np.argsort(isl, kind="stable")
            KX, CV, kc, isl = KX[o], CV[o], kc[o], isl[o]
            slots = self._worst_slots(F, isl)
        else:
            slots = self._worst_slots(F, np.zeros(m, np.int64))
        X[slots] = KX  # the weakly adapted individuals die out
        V[slots] = CV
        F[slots] = kc
        st.pbest[slots] = KX
        st.pbest_f[slots] = kc
        return F, kept

    def _worst_slots(self, F: np.ndarray, isl: np.ndarray) -> np.ndarray:
        """Slots of the worst particles: the r-th child of island i takes the r-th worst
        particle of island i (children sorted by island)."""
        I = self._n_islands
        if I == 1:
            return F.argsort(kind="stable")[::-1][:len(isl)]
        m_i = len(F) // I
        worst = np.argsort(F.reshape(I, m_i), axis=1, kind="stable")[:, ::-1]
        first = np.searchsorted(isl, isl)  # isl is sorted
        rank = np.arange(len(isl)) - first
        return worst[isl, np.minimum(rank, m_i - 1)] + m_i * isl

    def _iterate(self, space: SwarmSpace, state: SwarmState, it: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        st = state
        k = it - 1
        w = self._inertia(st)
        P = len(st.F)
        buf = st.stats["_buffer"]
        B = buf.X(it)  # this iteration's batch: swarm, mutants, children, extra candidates
        mode = self.bounds_mode
        m, CV, isl = self._children(space, st, k, rng, B[P:])
        X, V = self._move(space, st, w, k, rng, out=B[:P])
        out = bound_positions(B[:P + m], space.lo, space.hi, mode, rng)  # swarm, mutants
        if out is not None:
            V = bounce_velocity(V, out[:P], mode)
        main = P + 2 * m
        # beyond-the-paper moves around the global best; with islands, around one island's
        # best per iteration (round robin), so that no island is pulled into another's class
        if self._n_islands > 1:
            focus_isl = it % self._n_islands
            focus = st.pbest[st.stats["_island_idx"][focus_isl]]
        else:
            focus_isl, focus = 0, st.gbest
        extra = []
        pos = main
        if self.redistribute or self.snap or self.local_trials:
            if self.redistribute:
                extra.append(("redistributed", redistribute_candidates(
                    focus, space.start, space.goal)))
            if self.snap and len(st.stats["_snap"]):
                extra.append(("snapped", snap_candidates(focus, st.stats["_snap"])))
            if self.local_trials:
                T = focus + (st.stats["local_sigma"] * space.span) * rng.standard_normal(
                    (self.local_trials, space.dim))
                bound_positions(T, space.lo, space.hi, mode, rng)
                extra.append(("local_accepted", T))
            for _, C in extra:
                B[pos:pos + len(C)] = C
                pos += len(C)
        batch = B[:pos]
        ev = evaluate_paths(buf.paths(it)[:pos], space)  # one collision test for all rows
        cost = ev.cost
        st.n_eval += pos
        # the moved swarm and its memories; the children replace the worst particles
        F, kept = self._absorb(st, X, V, cost, B, m, CV, isl)
        st.X, st.V, st.F = X, V, F
        # gbest and the best collision-free particle over everything scored (a rejected
        # mutant costs at least as much as its child, so it never wins alone)
        st.offer_gbest(batch, ev, n=main)
        st.offer_feasible(batch, ev)
        pos = main
        m_i = P // self._n_islands
        for key, C in extra:
            n_c = len(C)
            q = int(np.argmin(cost[pos:pos + n_c])) + pos
            pos += n_c
            ref = float(st.pbest_f[st.stats["_island_idx"][focus_isl]]) if self._n_islands > 1 \
                else st.gbest_f
            tol = 1e-12 * max(1.0, abs(ref))
            ok = cost[q] <= ref + tol if key == "redistributed" else cost[q] < ref
            if key == "local_accepted":
                f = 2.0 if ok else 0.8
                st.stats["local_sigma"] = min(max(st.stats["local_sigma"] * f, 1e-6), 0.1)
            if ok:
                st.stats[key] += 1
                worst = focus_isl * m_i + int(np.argmax(st.F[focus_isl * m_i:
                                                               (focus_isl + 1) * m_i]))
                st.X[worst] = st.pbest[worst] = batch[q]
                st.V[worst] = 0.0
                st.F[worst] = st.pbest_f[worst] = cost[q]
                if self._n_islands > 1:
                    st.stats["_island_idx"][focus_isl] = worst
                if cost[q] <= st.gbest_f + tol:
                    st.gbest = batch[q].copy()
                    st.gbest_f = float(cost[q])
                    st.gbest_len = float(ev.length[q])
                    st.gbest_count = int(ev.count[q])
        if self._n_islands > 1:
            self._update_islands(st)
        vnorm = float(np.add.reduce(np.sqrt((V * V) @ st.stats["_ones"]))) / P
        st.stats["vnorms"] = [st.stats["vnorms"][-1], vnorm]
        st.stats["w"] = w
        st.stats["crossovers"] += m // 2
        st.stats["mutations_kept"] += kept
        return {"w": w, "psi": position_factor(k, self.k_max), "children": m,
                "mean_speed": vnorm}

    def _finish(self, space: SwarmSpace, state: SwarmState, rng: np.random.Generator):
        """Beyond the paper: :func:`~optplan.backends.swarm.tighten` the best collision-free
        particle and every island's best; the shortest result is the answer."""
        if not self.tighten_rounds:
            return
        st = state
        starts = [st.feas_x] if st.feas_x is not None else []
        if self._n_islands > 1:
            starts += list(st.pbest[st.stats["_island_idx"]])
        if not starts:
            return
        X = np.array(starts)
        ev = evaluate_swarm(X, space)
        st.n_eval += len(X)
        best_path, best_len = None, math.inf
        for x in X[ev.count == 0]:
            path, n = tighten(decode(x[None], space)[0], space, rounds=self.tighten_rounds)
            st.n_eval += n
            L = float(np.hypot(*np.diff(path, axis=0).T).sum())
            if L < best_len:
                best_path, best_len = path, L
        if best_path is not None and best_len < st.feas_len:
            st.stats["_final_path"] = best_path
            st.stats["tightened_from"] = st.feas_len
            st.feas_len = best_len
            if best_len < st.gbest_f:
                st.gbest_f, st.gbest_len, st.gbest_count = best_len, best_len, 0
        yield {"tightened": best_len}
