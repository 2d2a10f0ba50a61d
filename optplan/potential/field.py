r"""The potential field of the APF family (paper §II.E eqs 3-6, §IV.B eqs 34-37): pure maths.

Mathematics
-----------
-----------
Attraction (eqs 3-4), with :math:`\rho_g = \lVert X - X_g \rVert`:

.. math::  U_{att} = \tfrac12 k \rho_g^2, \qquad F_{att} = -\nabla U_{att} = k (X_g - X).

(The paper prints :math:`k(X - X_g)` for eq 4; the negative gradient points *to* the goal, and
that is what the paper's Fig. 3 and eq 9 use.)

Repulsion of one obstacle (eqs 5-6 for the basic method, eq 34 for the improved one), with
:math:`\rho` the clearance between the robot disc and the obstacle's nearest boundary point:

.. math::  U_{rep} = \tfrac12 \eta \Big(\frac1\rho - \frac1{\rho_0}\Big)^2 \rho_g^{\,n},
           \qquad \rho \le \rho_0,

and zero beyond :math:`\rho_0`.  :math:`n = 0` is eq 5; :math:`n > 0` is eq 34.  Its negative
gradient is (eqs 35-37; eq 6 when :math:`n = 0`)

.. math::  F_{rep} = \eta\Big(\frac1\rho-\frac1{\rho_0}\Big)\frac{\rho_g^{\,n}}{\rho^2}\,\hat n_{OR}
           + \frac n2 \eta \Big(\frac1\rho-\frac1{\rho_0}\Big)^2 \rho_g^{\,n-1}\,\hat n_{RG},

:math:`\hat n_{OR}` the unit vector obstacle -> robot, :math:`\hat n_{RG}` robot -> goal.  The
clearance is clamped, :math:`\rho \ge \rho_{min}`, so forces stay finite.

Length unit.  Every length above is measured in the problem's length unit
:math:`\lambda` = :attr:`optplan.problem.Problem.length_scale` (1 on the paper's scenes): the
field is evaluated on :math:`\tilde x = x/\lambda` and distances divided by :math:`\lambda`
(:func:`evaluate_field`), the length options (``rho_0``, ``rho_min``, ``l``, ``sense_range``,
and SA-APF's ``sa_step``, ``rollout``) are multiples of :math:`\lambda`, so a scene drawn
:math:`s` times larger gives the same trajectory times :math:`s` (docs/solvers/apf.md).

The motion (eqs 12-13) and the local-minimum tests (eq 38) are in
:mod:`optplan.potential.controller`; the units of :math:`\eta` of the basic planner in
:mod:`optplan.potential.apf`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optplan.sim import ObstacleField

__all__ = [
    "FieldParams",
    "attractive_potential",
    "attractive_force",
    "repulsive_potential",
    "repulsive_force",
    "evaluate_field",
]


def attractive_potential(x: np.ndarray, goal: np.ndarray, k: float) -> np.ndarray:
    """Eq 3: :math:`U_{att} = \\tfrac12 k \\lVert X - X_g\\rVert^2`; ``x`` is ``(..., 2)``."""
    d = np.asarray(x, dtype=float) - np.asarray(goal, dtype=float)
    return 0.5 * k * np.sum(d * d, axis=-1)


def attractive_force(x: np.ndarray, goal: np.ndarray, k: float) -> np.ndarray:
    """Eq 4: :math:`F_{att} = -\\nabla U_{att} = k (X_g - X)`, shape ``(..., 2)``."""
    return k * (np.asarray(goal, dtype=float) - np.asarray(x, dtype=float))


def repulsive_potential(rho: np.ndarray, rho_g: np.ndarray, eta: float, rho_0: float,
                        n: float = 0.0) -> np.ndarray:
    """Eq 5 (``n = 0``) / eq 34: repulsive potential of each obstacle.

    Parameters
    ----------
    rho : array
        Clearance robot-obstacle (already clamped to ``rho_min`` by the caller; ``inf`` = unseen).
    rho_g : array
        Distance robot-goal (broadcast against ``rho``).
    eta, rho_0, n : float
        Gain (eq 5), influence distance (map units), goal-distance exponent (eq 34).
    """
    rho = np.asarray(rho, dtype=float)
    inside = rho <= rho_0
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(inside, 1.0 / rho - 1.0 / rho_0, 0.0)
    gn = np.power(np.asarray(rho_g, dtype=float), n) if n != 0 else 1.0
    return np.where(inside, 0.5 * eta * a * a * gn, 0.0)


def repulsive_force(x: np.ndarray, near: np.ndarray, rho: np.ndarray, goal: np.ndarray,
                    eta: float, rho_0: float, n: float = 0.0) -> np.ndarray:
    """Eq 6 (``n = 0``) / eqs 35-37: repulsive force of each obstacle, shape ``(..., 2)``.

    ``F_rep1`` (eq 36) points from the obstacle's nearest point to the robot; ``F_rep2``
    (eq 37) points from the robot to the goal and vanishes for ``n = 0``.

    Parameters
    ----------
    x : array ``(..., 2)``
        Robot position(s).
    near : array ``(..., 2)``
        Nearest obstacle boundary point for each obstacle (``nan`` where unseen).
    rho : array ``(...)``
        Clamped clearance (``> 0``); obstacles with ``rho > rho_0`` contribute nothing.
    goal : array ``(2,)``
    """
    x = np.asarray(x, dtype=float)
    rho = np.asarray(rho, dtype=float)
    inside = rho <= rho_0
    v = x - near
    nv = np.hypot(v[..., 0], v[..., 1])
    g = np.asarray(goal, dtype=float) - x
    rg = np.hypot(g[..., 0], g[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):  # masked out below
        n_or = np.where((inside & (nv > 1e-12))[..., None], v / nv[..., None], 0.0)
        a = np.where(inside, 1.0 / rho - 1.0 / rho_0, 0.0)
        f1 = np.where(inside, eta * a / rho ** 2, 0.0)
        if n != 0:
            f1 = f1 * rg ** n
            far = rg > 1e-12
            n_rg = np.where(far[..., None], g / rg[..., None], 0.0)
            f2 = np.where(inside & far, 0.5 * n * eta * a * a * np.power(rg, n - 1.0), 0.0)
    F = f1[..., None] * n_or
    if n != 0:
        F = F + f2[..., None] * n_rg
    return F


@dataclass(frozen=True)
class FieldParams:
    """Everything the potential needs: gains, exponent, clamp, robot radius, sensing range.

    ``rho_0``, ``rho_min``, ``radius`` and ``sense_range`` are map lengths; ``unit`` is the
    problem's length unit (:attr:`optplan.problem.Problem.length_scale`): the potential is
    evaluated on positions and distances divided by it, so ``k`` and ``eta`` are per length
    unit and the field of a scene drawn ``s`` times larger is the same field.
    """

    k: float
    eta: float
    rho_0: float
    n: float
    rho_min: float
    radius: float
    sense_range: float
    unit: float = 1.0


def evaluate_field(points: np.ndarray, goal: np.ndarray, fld: ObstacleField, t: float,
                   p: FieldParams) -> dict[str, np.ndarray]:
    """Total potential and force at ``points`` ``(P, 2)`` for obstacles sensed from each point.

    Only (point, obstacle) pairs inside the sensing range are evaluated (the geometry core's
    bounding-circle screen behind :meth:`ObstacleField.nearest` discards the rest), so the cost
    barely grows with obstacles out of range.  Positions and distances are divided by
    ``p.unit`` before eqs 3-6 / 34-37 are applied: ``U`` is dimensionless and ``F`` is
    :math:`-\\nabla_{\\tilde x} U` with :math:`\\tilde x = x / \\text{unit}` (its direction is
    that of :math:`-\\nabla_x U`).  Returns a dict with ``U``, ``U_att``, ``U_rep`` ``(P,)``,
    ``F`` ``(P, 2)`` and ``clearance`` ``(P,)`` (min raw clearance robot disc - obstacle in
    map units, unclamped; ``inf`` if none is sensed), plus the sensor readings ``near``
    ``(P, n, 2)`` and ``dist`` ``(P, n)`` (map units).
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    P = len(pts)
    goal = np.asarray(goal, dtype=float)
    near, dist = fld.nearest(pts, t, max_range=p.sense_range)
    u = float(p.unit)
    g = (goal - pts) / u
    rho_g = np.hypot(g[:, 0], g[:, 1])
    u_att = 0.5 * p.k * rho_g * rho_g
    F = p.k * g
    u_rep: np.ndarray = np.zeros(P)  # np.bincount with weights: float64
    cmin = np.full(P, np.inf)
    r_idx, o_idx = np.nonzero(dist <= p.rho_0 + p.radius)  # pairs inside the influence range
    if len(r_idx):
        clear = dist[r_idx, o_idx] - p.radius
        np.minimum.at(cmin, r_idx, clear)
        rho = np.maximum(clear, p.rho_min) / u
        rho_0 = p.rho_0 / u
        x = pts[r_idx] / u
        rg = rho_g[r_idx]
        ur = repulsive_potential(rho, rg, p.eta, rho_0, p.n)
        f = repulsive_force(x, near[r_idx, o_idx] / u, rho, goal / u, p.eta, rho_0, p.n)
        u_rep = np.bincount(r_idx, weights=ur, minlength=P)
        F = F + np.stack([np.bincount(r_idx, weights=f[:, 0], minlength=P),
                          np.bincount(r_idx, weights=f[:, 1], minlength=P)], axis=1)
    return {"U": u_att + u_rep, "U_att": u_att, "U_rep": u_rep, "F": F, "clearance": cmin,
            "near": near, "dist": dist}

