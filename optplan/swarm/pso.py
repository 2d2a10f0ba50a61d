"""Standard global-best particle swarm optimisation (paper §II.C, eqs 1-2).

Velocity and position updates, for particle ``i`` and coordinate ``d``::

    v_id^{k+1} = w v_id^k + c1 eps (p_id^k - x_id^k) + c2 eta (p_gd^k - x_id^k)     (1)
    x_id^{k+1} = x_id^k + v_id^{k+1}                                                (2)

with ``eps, eta ~ U(0, 1)`` drawn per particle and coordinate every iteration, ``p_i`` the
particle's best position and ``p_g`` the swarm's best.  The paper prints ``x_gd`` in the social
term of eq 1; that is a typo for ``x_id`` (the textbook PSO, and the only reading in which the
social term pulls particle ``i`` toward ``p_g``).  Encoding and fitness (eqs 31-33,
:mod:`optplan.swarm.core`), the velocity update and bounds handling
(:mod:`optplan.swarm.operators`) and the driver (:mod:`optplan.swarm.backend`) are shared with
MPSO and IPSO.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.solver import option
from optplan.swarm.backend import SwarmBackend, SwarmState
from optplan.swarm.core import SwarmSpace, evaluate_swarm
from optplan.swarm.operators import handle_bounds, velocity_update

__all__ = ["PSO", "pso_step"]


def pso_step(state: SwarmState, w: float, c1: float, c2: float, vmax: np.ndarray,
             rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Eqs 1-2 for the whole swarm: returns the new ``(X, V)`` (bounds not yet handled).

    ``eps`` then ``eta`` ~ U(0, 1) per particle and coordinate are drawn from ``rng``; the
    velocity is :func:`optplan.swarm.operators.velocity_update` with gbest as the one guide,
    clamped to ``vmax`` per coordinate (``inf``: none).
    """
    P, D = state.X.shape
    eps = rng.random((P, D))
    eta = rng.random((P, D))
    V = velocity_update(state.V, state.X, state.pbest, state.gbest[None, :],
                        np.zeros(P, np.int64), (float(w), float(c1), float(c2)), eps, eta,
                        vmax, np.empty((P, D)))
    return state.X + V, V  # eq 2


@dataclass(frozen=True, kw_only=True)
class PSO(SwarmBackend):
    """Standard PSO with constant inertia weight (eqs 1-2) on the waypoint encoding.

    Parameters
    ----------
    w : float
        Inertia weight of eq 1 (paper §VI.A: 0.5).
    n_particles, k_max, c1, c2, n_waypoints, v_max, bounds_mode, init_mode, penalty_weight, \
penetration_weight, roadmap_samples, roadmap_boundary, roadmap_medial, roadmap_neighbours, \
corridors
        Shared swarm options, see :class:`optplan.swarm.backend.SwarmBackend`.
    """

    name: ClassVar[str] = "pso"

    w: float = option(0.5, lo=0.0, hi=2.0)

    def _move(self, space: SwarmSpace, state: SwarmState, rng: np.random.Generator,
              step: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Eqs 1-2 at the constant ``w``, then the bounds: the new ``(X, V)``.  ``step``: the
        position moves by ``step * V`` instead of ``V`` (MPSO's ``step_scale`` reading)."""
        X, V = pso_step(state, self.w, self.c1, self.c2, self._vmax(space), rng)
        if step is not None:
            X = state.X + step * V
        return handle_bounds(X, V, space.lo, space.hi, self.bounds_mode, rng)

    def _iterate(self, space: SwarmSpace, state: SwarmState, run: Any, k: int,
                 rng: np.random.Generator) -> dict[str, Any]:
        X, V = self._move(space, state, rng)
        ev = evaluate_swarm(X, space)
        state.V = V
        state.absorb(X, ev)
        state.n_eval += len(X)
        return {"w": self.w}
