"""Mutation ("population-variation") PSO: the paper's comparison baseline MPSO (§VI.A).

The paper only names the method and two parameters, the mutation threshold ``p_t = 0.8`` and
the refined-search coefficient ``delta = 0.056``; it gives no equations.  The reading
implemented here is the common one:

* standard PSO moves (eqs 1-2, constant ``w``);
* **mutation**: after each move, each particle with probability ``1 - p_t`` (drawn as
  ``rand > p_t``) has one uniformly chosen coordinate reset to a uniform value within the map
  (the widely copied "adaptive mutation" PSO template);
* **refined search** (``refine_mode = "gbest_local"``, default, reading A): every iteration
  ``n_refine`` trial points ``gbest + delta * range * xi``, ``xi ~ U(-1, 1)^D``, are evaluated
  together with the swarm; a trial better than gbest becomes gbest and replaces the worst
  particle (greedy).  The alternative reading B (``refine_mode = "step_scale"``) scales the
  position step instead, ``x^{k+1} = x^k + delta * v^{k+1}`` (the template uses 0.5 there).

Do not confuse this ``delta`` with the fitness penalty weight (``penalty_weight``, eq 32).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.solver import option
from optplan.swarm.backend import SwarmState
from optplan.swarm.core import SwarmSpace, evaluate_swarm
from optplan.swarm.operators import handle_bounds
from optplan.swarm.pso import PSO

__all__ = ["MPSO", "mutate_one_coordinate", "refine_trials"]

REFINE_MODES = ("gbest_local", "step_scale")


def mutate_one_coordinate(X: np.ndarray, lo: np.ndarray, hi: np.ndarray, p_t: float,
                          rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Reset one random coordinate of each particle with ``rand > p_t`` to ``U(lo, hi)``.

    Returns the new positions and the boolean mask of mutated particles.
    """
    P: int  # numpy types shape entries as Any: the int picks rng's array overloads
    D: int
    P, D = X.shape
    hit = rng.random(P) > p_t
    dims = rng.integers(0, D, size=P)
    vals = lo[dims] + (hi[dims] - lo[dims]) * rng.random(P)
    Xn = X.copy()
    rows = np.flatnonzero(hit)
    Xn[rows, dims[rows]] = vals[rows]
    return Xn, hit


def refine_trials(gbest: np.ndarray, span: np.ndarray, delta: float, n: int,
                  rng: np.random.Generator) -> np.ndarray:
    """``n`` trial points ``gbest + delta * span * U(-1, 1)^D`` (reading A of ``delta``)."""
    return gbest[None, :] + delta * span[None, :] * rng.uniform(-1.0, 1.0, (n, gbest.size))


@dataclass(frozen=True, kw_only=True)
class MPSO(PSO):
    """PSO with one-coordinate mutation and a greedy refined search around gbest: a
    :class:`optplan.swarm.pso.PSO` (its move of eqs 1-2 and its options, the shared swarm
    options of :class:`optplan.swarm.backend.SwarmBackend` among them) with the options below.

    Parameters
    ----------
    w : float
        Constant inertia weight of eq 1 (paper §VI.A: 0.5).
    p_t : float
        Mutation threshold: a particle mutates when ``U(0,1) > p_t`` (paper: 0.8, i.e. with
        probability 0.2).
    delta : float
        Refined-search coefficient (paper: 0.056): half-width of the trial box around gbest as
        a fraction of the map range (``gbest_local``) or the position step scale
        (``step_scale``).
    refine_mode : {"gbest_local", "step_scale"}
        Reading of ``delta`` (module docstring).
    n_refine : int
        Trial points per iteration for ``gbest_local`` (evaluated in the same batch as the
        swarm).
    """

    name: ClassVar[str] = "mpso"
    p_t: float = option(0.8, lo=0.0, hi=1.0)
    delta: float = option(0.056, lo=0.0, hi=10.0, lo_open=True)
    refine_mode: str = option("gbest_local", choices=REFINE_MODES)
    n_refine: int = option(1, lo=0, hi=10_000)

    def _iterate(self, space: SwarmSpace, state: SwarmState, run: Any, k: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        X, V = self._move(space, state, rng,
                          step=self.delta if self.refine_mode == "step_scale" else None)
        X, hit = mutate_one_coordinate(X, space.lo, space.hi, self.p_t, rng)
        P = len(X)
        n_ref = self.n_refine if self.refine_mode == "gbest_local" else 0
        batch = X
        if n_ref:
            T = refine_trials(state.gbest, space.span, self.delta, n_ref, rng)
            T, _ = handle_bounds(T, np.zeros_like(T), space.lo, space.hi, self.bounds_mode, rng)
            batch = np.vstack([X, T])
        ev = evaluate_swarm(batch, space)  # one crossing test for swarm + trials
        state.n_eval += len(batch)
        state.V = V
        sw = ev.take(slice(0, P))
        state.absorb(X, sw)
        accepted = 0
        if n_ref:
            tr = ev.take(slice(P, None))
            j = int(np.argmin(tr.cost))
            if tr.cost[j] < state.gbest_f:
                accepted = 1
                worst = int(np.argmax(state.F))
                x = T[j:j + 1]
                state.V[worst] = 0.0
                state.absorb(x, tr.take(slice(j, j + 1)), slots=np.array([worst]))
            else:
                state.offer(T, tr)
        state.stats["mutations"] = state.stats.get("mutations", 0) + int(hit.sum())
        state.stats["refine_accepted"] = state.stats.get("refine_accepted", 0) + accepted
        return {"w": self.w, "mutations": int(hit.sum()), "refine_accepted": accepted}
