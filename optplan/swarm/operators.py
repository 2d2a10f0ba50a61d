"""Particle operators of the swarm planners: the one PSO velocity update, bounds handling and
the initial swarm.

Velocity update (eq 1, and eq 22 of IPSO)
    :func:`velocity_update` is the one PSO velocity update of the package (``pso``, ``mpso``
    and ``ipso`` call it), compiled with numba; the random factors are drawn by the caller
    from the run's ``rng``.

Bounds handling (option ``bounds_mode``)
    ``"reflect"`` (default): a coordinate beyond a bound is mirrored back into the map and the
    velocity component is reversed; ``"clip"``: put on the bound, velocity component zeroed;
    ``"random"``: the coordinate is re-drawn uniformly in the bounds, velocity zeroed.

Initialisation (option ``init_mode``)
    ``"uniform"``: waypoints uniform in the map; ``"sorted"`` (default): uniform, then ordered
    along the start->goal direction (no initial back-tracking zig-zags); ``"line"``: on the
    straight line plus Gaussian noise of ``0.1 * diag``; ``"roadmap"`` (beyond the paper):
    ``"sorted"``, then particles seeded with the ``corridors`` shortest start-goal paths of
    distinct homotopy classes of one sparse random roadmap
    (:func:`optplan.swarm.roadmap.roadmap_corridors`, placed by the driver,
    :class:`optplan.swarm.backend.SwarmBackend`), one per block of consecutive particles (one
    per island of ``ipso``).  An ``init`` path (from an earlier stage) seeds particle 0
    (:func:`optplan.geometry.collision.polyline.resample_path`: exact when it has at most ``n``
    bends).
"""

from __future__ import annotations

import numpy as np
from numba import types

from optplan.geometry.compiled import F1, F2, FA2, I1, compiled, f8, i8
from optplan.swarm.core import SwarmSpace

__all__ = [
    "BOUNDS_MODES",
    "INIT_MODES",
    "BOUND_CODES",
    "velocity_update",
    "bound_rows",
    "redraw_out",
    "bound_positions",
    "bounce_velocity",
    "handle_bounds",
    "initial_swarm",
]

BOUNDS_MODES = ("reflect", "clip", "random")
INIT_MODES = ("sorted", "uniform", "line", "roadmap")

#: Compiled helpers (numba; cached on disk after the first run, see docs/solvers/pso.md).
@compiled(F2, FA2, F2, F2, I1, types.UniTuple(f8, 3), F2, F2, F1, F2)
def velocity_update(V, X, pbest, guides, leader, coef, eps, eta, vmax, out):
    """Eq 1 (PSO) and eq 22 (IPSO) for the whole swarm, written into ``out`` (returned),
    with the weights ``coef = (w, c1, c2)``::

        v_id <- w v_id + c1 eps_id (p_id - x_id) + c2 eta_id (g_d - x_id)      (1), (22)

    then clamped to ``[-vmax_d, vmax_d]`` (``inf``: no clamp).  ``g`` is particle ``i``'s
    guide ``guides[leader[i]]``: the global best (one guide, every leader 0) or its island's
    best.  ``eps``, ``eta`` ~ U(0, 1) per particle and coordinate are drawn by the caller from
    the run's generator.  ``out`` may be ``V``.
    """
    w, c1, c2 = coef
    P, D = X.shape
    for i in range(P):
        g = leader[i]
        for d in range(D):
            x = X[i, d]
            v = (w * V[i, d] + (c1 * eps[i, d]) * (pbest[i, d] - x)
                 + (c2 * eta[i, d]) * (guides[g, d] - x))
            v = min(v, vmax[d])
            out[i, d] = max(v, -vmax[d])
    return out


@compiled(FA2, F1, F1, i8)
def bound_rows(X, lo, hi, code):
    """Bounds handling of the rows of ``X`` into ``[lo, hi]``, in place: ``code`` 1 =
    ``reflect``, 2 = ``clip``, 0 = ``random`` (nothing moves here: the caller re-draws the
    coordinates of the returned mask, :func:`redraw_out`).  Returns the out-of-bounds mask and
    whether any coordinate was out.  Coordinates inside are never changed, not even in the
    last bit (the mirror is ``2 clip(x) - x``)."""
    P, D = X.shape
    out = np.zeros((P, D), np.bool_)
    anyout = False
    for i in range(P):
        for d in range(D):
            x = X[i, d]
            c = min(max(x, lo[d]), hi[d])
            if c == x:
                continue
            out[i, d] = True
            anyout = True
            if code == 2:
                X[i, d] = c
            elif code == 1:
                y = 2.0 * c - x  # mirror at the crossed bound
                if min(max(y, lo[d]), hi[d]) != y:
                    # far out (beyond a whole span): mirror repeatedly, triangle wave of
                    # period 2 span
                    span = hi[d] - lo[d]
                    u = np.mod(y - lo[d], 2.0 * span)
                    y = lo[d] + (2.0 * span - u if u > span else u)
                X[i, d] = y
    return out, anyout


BOUND_CODES = {"random": 0, "reflect": 1, "clip": 2}


def redraw_out(X: np.ndarray, out: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               rng: np.random.Generator) -> None:
    """``random`` bounds mode: re-draw the coordinates of the mask ``out`` uniformly in the
    bounds (one ``rng.random(X.shape)`` draw), in place."""
    fresh = lo + (hi - lo) * rng.random(X.shape)
    np.copyto(X, fresh, where=out)


def bound_positions(X: np.ndarray, lo: np.ndarray, hi: np.ndarray, mode: str,
                    rng: np.random.Generator) -> np.ndarray | None:
    """Bring positions back into ``[lo, hi]`` per dimension, **in place**.

    Returns the mask of the coordinates that were out (None when none was).  Modes: module
    docstring (:func:`bound_rows`, :func:`redraw_out`).
    """
    out, anyout = bound_rows(X, lo, hi, BOUND_CODES[mode])
    if not anyout:
        return None
    if mode == "random":
        redraw_out(X, out, lo, hi, rng)
    return out


def handle_bounds(X: np.ndarray, V: np.ndarray, lo: np.ndarray, hi: np.ndarray, mode: str,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Bring positions back into ``[lo, hi]`` per dimension and adapt the velocities.

    Returns new ``(X, V)`` (the inputs are not modified): ``reflect`` reverses the velocity
    component of a reflected coordinate, ``clip`` and ``random`` zero it
    (:func:`bound_positions`).
    """
    Xn = np.array(X, dtype=float)
    out = bound_positions(Xn, lo, hi, mode, rng)
    if out is None:
        return Xn, V
    return Xn, bounce_velocity(V, out, mode)


def bounce_velocity(V: np.ndarray, out: np.ndarray, mode: str) -> np.ndarray:
    """Velocities after bounds handling: reversed (``reflect``) or zeroed where ``out``."""
    return np.where(out, -V, V) if mode == "reflect" else np.where(out, 0.0, V)


def initial_swarm(space: SwarmSpace, n_particles: int, mode: str,
                  rng: np.random.Generator) -> np.ndarray:
    """Initial positions ``(n_particles, 2n)`` (modes: module docstring; ``roadmap`` starts
    from ``sorted``, its seeds are placed by the driver)."""
    n, D = space.n_waypoints, space.dim
    if mode == "line":
        frac = np.arange(1, n + 1) / (n + 1)
        base = (space.start[None, :] + frac[:, None] * (space.goal - space.start)[None, :])
        X = base.reshape(-1)[None, :] + 0.1 * space.diag * rng.standard_normal((n_particles, D))
        X = np.clip(X, space.lo, space.hi)
    else:
        X = space.lo + space.span * rng.random((n_particles, D))
        if mode in ("sorted", "roadmap") and n > 1:
            W = X.reshape(n_particles, n, 2)
            axis = space.goal - space.start
            proj = (W - space.start) @ axis
            order = np.argsort(proj, axis=1, kind="stable")
            X = np.take_along_axis(W, order[..., None], axis=1).reshape(n_particles, D)
    return X
