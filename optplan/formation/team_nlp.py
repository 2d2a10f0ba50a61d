r"""The joint trajectory NLP of a team (CasADi + IPOPT): the model and one solve.

Direct transcription with a free final time: the positions :math:`X^i_k` of every robot
:math:`i` at :math:`N + 1` times :math:`t_k = k T / N` (:math:`T` a variable).  Coordinates are
the map's local frame divided by its diagonal, times are divided by the warm start's arrival
:math:`T_0`, so IPOPT's tolerances mean the same on every map.

Constraints
    * :math:`X^i_0` = the robot's start; the leader's :math:`X^L_N` = its goal;
    * speed: :math:`\lVert X^i_{k+1} - X^i_k \rVert \le v_i T / N`;
    * static obstacles: the separating hyperplanes of the waypoint NLP
      (:mod:`optplan.exact.nlp`: exact for convex pieces on whole segments), for every
      (robot, step, piece) pair within ``prune`` of the warm start;
    * moving obstacles at their known motion (a piecewise-linear interpolant of the track in
      :math:`t_k`), on every grid interval: a separating line :math:`a` (:math:`\lVert a
      \rVert \le 1`) with :math:`a^\top (X^i_k - m_j(t_k)) \ge \rho_{ij} + w_j T / (2N)`
      at both ends of the interval, :math:`\rho_{ij}` the robot's radius plus the obstacle's
      (a polygon: its circumscribed circle about the reference point), :math:`w_j` the
      obstacle's largest speed.  Both move linearly on the interval up to the obstacle's
      deviation from its chord (at most :math:`w_j T / (2N)` at a knot of its track inside the
      interval), so the whole interval is clear; the exact continuous-time validator has the
      last word.  Only intervals within ``prune`` (plus two steps' travel) of the warm start
      are constrained;
    * separation: the same separating lines for every pair of robots (their relative motion
      is linear on each interval: exact), at distance :math:`d` = the formation's safety
      distance (at least :math:`r_i + r_j`; on the first interval at most the start's);
    * each follower within :math:`L / 8` of its slot at the last step.

Cost
    :math:`T / T_0 + w \cdot E`, with :math:`E` the mean over steps and followers of
    :math:`\lVert X^f_k - s_f(k) \rVert^2 / \bar L^2`: the squared distance of each follower
    from its L-phi slot (:mod:`optplan.formation.slots`; the leader's heading is the direction
    of its next step, smoothed near zero) relative to the mean slot distance :math:`\bar L`.
    ``w`` trades arrival against formation keeping.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.exact.nlp_model import IterCallback
from optplan.exact.nlp_pieces import Pieces, init_hyperplanes, select_pairs

__all__ = ["TeamModel", "MoverTable", "solve_team_nlp"]


@dataclass(frozen=True)
class MoverTable:
    """A moving obstacle for the NLP: its track (times scaled by ``T0``, points local and
    scaled), radius (scaled) and largest speed (scaled units per scaled time)."""

    times: np.ndarray
    points: np.ndarray
    radius: float
    speed: float


@dataclass(frozen=True)
class TeamModel:
    """What one solve needs, in scaled units (module docstring).

    Attributes
    ----------
    X0 : ndarray ``(R, N + 1, 2)``
        The warm start (robot order: leader first, then the followers of ``L``/``phi``).
    radius, speed : ndarray ``(R,)``
        Radii and speed limits (scaled: map diagonals per ``T0``).
    goal : ndarray ``(2,)``
        The leader's goal.
    L, phi : ndarray ``(R - 1,)``
        The followers' slots.
    separation : float
        Required distance between robot centres (scaled).
    pieces : list of Pieces
        Per robot, the convex static pieces in the *local* frame (unscaled).
    scale : float
        The map diagonal (local coordinates / scale = NLP coordinates).
    movers : list of MoverTable
    w_formation, prune : float
        The cost weight and the pair pruning distance (scaled).
    t_max : float
        Upper bound of ``T`` (scaled; ``1`` is the warm start's arrival).
    """

    X0: np.ndarray
    radius: np.ndarray
    speed: np.ndarray
    goal: np.ndarray
    L: np.ndarray
    phi: np.ndarray
    separation: float
    pieces: list[Pieces]
    scale: float
    movers: list[MoverTable]
    w_formation: float
    prune: float
    t_max: float


def _heading(D: Any, eps: float) -> Any:
    """Unit-ish direction of each step (rows of ``D``), smoothed near zero."""
    import casadi as ca

    n = ca.sqrt(ca.sum2(D * D) + eps * eps)
    return D / ca.repmat(n, 1, 2)


def _formation_error(X: list[Any], m: TeamModel, N: int) -> Any:
    """Mean squared slot error (relative to the mean slot distance), module docstring."""
    import casadi as ca

    if len(X) < 2:
        return 0
    D = X[0][1:, :] - X[0][:-1, :]
    eps = 1e-3 * float(m.speed[0]) / N
    H = _heading(ca.vertcat(D, D[-1, :]), eps)  # (N + 1, 2)
    hx, hy = H[:, 0], H[:, 1]
    err = 0
    for f in range(len(m.L)):
        c, s, L = np.cos(m.phi[f]), np.sin(m.phi[f]), float(m.L[f])
        sx = X[0][:, 0] - L * (hx * c + hy * s)
        sy = X[0][:, 1] - L * (hy * c - hx * s)
        ex, ey = X[f + 1][1:, 0] - sx[1:], X[f + 1][1:, 1] - sy[1:]
        err = err + ca.sum1(ex * ex + ey * ey)
    lbar = float(np.mean(m.L)) if len(m.L) else 1.0
    return err / (N * len(m.L) * lbar * lbar)


def _static(opti: Any, Xi: Any, x0: np.ndarray, pieces: Pieces, scale: float, prune: float
            ) -> int:
    """The separating-hyperplane constraints of one robot, all pairs in one block of rows;
    returns the number of pairs."""
    import casadi as ca

    path = x0 * scale
    mask = select_pairs(path, pieces, prune * scale)
    seg, piece = np.nonzero(mask)
    K = len(seg)
    if K == 0:
        return 0
    a0, c0 = init_hyperplanes(path, pieces, seg, piece, pieces.clear)
    A = opti.variable(K, 2)
    C = opti.variable(K)
    opti.set_initial(A, a0)
    opti.set_initial(C, c0 / scale)
    V = np.vstack([pieces.verts[j] / scale for j in piece])
    own = np.repeat(np.arange(K), [len(pieces.verts[j]) for j in piece]).tolist()
    opti.subject_to(ca.sum2(V * A[own, :]) - ca.reshape(C[own], len(own), 1) <= 0)
    clear = pieces.clear[piece] / scale
    for P in (Xi[seg.tolist(), :], Xi[(seg + 1).tolist(), :]):
        opti.subject_to(ca.sum2(P * A) - C >= clear)
    opti.subject_to(ca.sum2(A * A) <= 1)
    return K


def _interp(name: str, mv: MoverTable, t_hi: float) -> tuple[Any, Any]:
    """Linear interpolants of a track's two coordinates (jumps nudged apart: a grid must be
    strictly increasing)."""
    import casadi as ca

    t = np.asarray(mv.times, float).copy()
    p = np.asarray(mv.points, float)
    keep = np.concatenate([[True], np.diff(t) > 0]) if len(t) > 1 else np.array([True])
    nudge = 1e-9 * max(t_hi, 1.0)
    for k in np.flatnonzero(~keep):
        t[k] = t[k - 1] + nudge
    t = np.maximum.accumulate(t + np.arange(len(t)) * 0.0)
    if len(t) == 1:
        t, p = np.array([t[0], t[0] + max(t_hi, 1.0)]), np.vstack([p, p])
    t = np.concatenate([[min(t[0], 0.0) - 1.0], t, [max(t[-1], t_hi) + 1.0]])
    p = np.vstack([p[:1], p, p[-1:]])
    t = np.maximum.accumulate(t)
    fx = ca.interpolant(f"{name}_x", "linear", [t.tolist()], p[:, 0].tolist())
    fy = ca.interpolant(f"{name}_y", "linear", [t.tolist()], p[:, 1].tolist())
    return fx, fy


def _separate(opti: Any, rel0: Any, rel1: Any, need: Any, guess: np.ndarray) -> None:
    """Separating lines for relative motions that are linear on their intervals (one row
    each of ``rel0``, ``rel1``: the relative positions at the interval's two ends): a
    unit-bounded ``a`` per row with ``a . rel >= need`` at both ends, hence on the whole
    interval (``a . rel - need`` is affine along it, ``|a| <= 1``)."""
    import casadi as ca

    A = opti.variable(guess.shape[0], 2)
    n = np.hypot(guess[:, 0], guess[:, 1])
    unit = np.where(n[:, None] > 0, guess / np.where(n > 0, n, 1.0)[:, None], [1.0, 0.0])
    opti.set_initial(A, unit)
    opti.subject_to(ca.sum2(rel0 * A) >= need)
    opti.subject_to(ca.sum2(rel1 * A) >= need)
    opti.subject_to(ca.sum2(A * A) <= 1)


def _movers(opti: Any, X: list[Any], T: Any, m: TeamModel) -> int:
    """The moving-obstacle constraints (module docstring); returns their number."""
    import casadi as ca

    R, N1, _ = m.X0.shape
    N = N1 - 1
    grid = np.arange(N1) / N
    count = 0
    for j, mv in enumerate(m.movers):
        fx, fy = _interp(f"m{j}", mv, m.t_max)
        tk = T * grid
        M = ca.horzcat(ca.vertcat(*[fx(tk[k]) for k in range(N1)]),
                       ca.vertcat(*[fy(tk[k]) for k in range(N1)]))
        M0 = np.stack([np.interp(grid, mv.times, mv.points[:, 0]),
                       np.interp(grid, mv.times, mv.points[:, 1])], axis=1)
        for i in range(R):
            rel0 = m.X0[i] - M0
            dist = np.hypot(rel0[:, 0], rel0[:, 1])
            reach = m.radius[i] + mv.radius + m.prune + 2.0 * (m.speed[i] + mv.speed) / N
            ks = np.flatnonzero(np.minimum(dist[:-1], dist[1:]) <= reach * m.t_max)
            if len(ks) == 0:
                continue
            need = m.radius[i] + mv.radius + mv.speed * T / (2 * N)
            rel = X[i] - M
            _separate(opti, rel[ks.tolist(), :], rel[(ks + 1).tolist(), :], need,
                      rel0[ks] + rel0[ks + 1])
            count += len(ks)
    return count


def solve_team_nlp(m: TeamModel, ipopt: dict[str, Any],
                   stop: Callable[[float], bool] | None = None
                   ) -> tuple[np.ndarray, float, dict]:
    """Solve the team NLP from its warm start.

    ``stop`` (optional) is called with the objective after every IPOPT iteration; IPOPT
    stops (``User_Requested_Stop``, its last iterate returned) when it returns True.

    Returns
    -------
    X : ndarray ``(R, N + 1, 2)``
        The robots' positions (scaled local coordinates).
    T : float
        The arrival time (scaled by ``T0``).
    info : dict
        IPOPT's ``return_status``, ``success``, ``iter_count``, the numbers of static pairs
        and of moving-obstacle rows.
    """
    import casadi as ca

    R, N1, _ = m.X0.shape
    N = N1 - 1
    opti = ca.Opti()
    X = [opti.variable(N1, 2) for _ in range(R)]
    T = opti.variable()
    opti.set_initial(T, 1.0)
    opti.subject_to(opti.bounded(1e-3, T, m.t_max))
    n_pairs = 0
    for i in range(R):
        opti.set_initial(X[i], m.X0[i])
        opti.subject_to(X[i][0, :] == m.X0[i, 0][None, :])
        D = (X[i][1:, :] - X[i][:-1, :]) * (N / float(m.speed[i]))  # in units of one step
        opti.subject_to(ca.sum2(D * D) <= T * T)
        n_pairs += _static(opti, X[i], m.X0[i], m.pieces[i], m.scale, m.prune)
    n_movers = _movers(opti, X, T, m)
    opti.subject_to(X[0][N, :] == m.goal[None, :])
    for i in range(R):
        for j in range(i + 1, R):
            first = min(m.separation, 0.999999 * float(np.hypot(*(m.X0[i, 0] - m.X0[j, 0]))))
            need = np.full(N, m.separation)
            need[0] = first
            E, E0 = X[i] - X[j], m.X0[i] - m.X0[j]
            _separate(opti, E[:N, :], E[1:, :], need, E0[:-1] + E0[1:])
    opti.subject_to(_final_slots(X, m) <= 0)
    opti.minimize(T + m.w_formation * _formation_error(X, m, N))
    plugin: dict[str, Any] = {"expand": True, "print_time": False}
    if stop is not None:
        cb = IterCallback.make(opti.nx, opti.ng, opti.np)
        cb.target = stop
        plugin["iteration_callback"] = cb
    opti.solver("ipopt", plugin, ipopt)
    try:
        sol = opti.solve()
        stats = sol.stats()
        Xs = np.stack([np.asarray(sol.value(x)) for x in X])
        Ts = float(sol.value(T))
    except RuntimeError:  # IPOPT did not converge: its last iterate, flagged
        stats = opti.stats()
        Xs = np.stack([np.asarray(opti.debug.value(x)) for x in X])
        Ts = float(opti.debug.value(T))
    info = {"return_status": stats.get("return_status", "?"),
            "success": bool(stats.get("success", False)),
            "iter_count": int(stats.get("iter_count", 0)), "static_pairs": n_pairs,
            "mover_rows": n_movers}
    return Xs, Ts, info


def _final_slots(X: list[Any], m: TeamModel) -> Any:
    """Each follower within ``L / 8`` of its slot at the last step (squared distance minus
    ``(L / 8)^2``, one row per follower): the validator counts a follower as arrived within
    ``L / 4``."""
    import casadi as ca

    if len(X) < 2:
        return ca.DM.zeros(1)
    h = X[0][-1, :] - X[0][-2, :]
    h = h / ca.sqrt(h @ h.T + (1e-3 * float(m.speed[0]) / (X[0].shape[0] - 1)) ** 2)
    rows = []
    for f in range(len(m.L)):
        c, s, L = np.cos(m.phi[f]), np.sin(m.phi[f]), float(m.L[f])
        slot = X[0][-1, :] - L * ca.horzcat(h[0] * c + h[1] * s, h[1] * c - h[0] * s)
        e = X[f + 1][-1, :] - slot
        rows.append(e @ e.T - (L / 8) ** 2)
    return ca.vertcat(*rows)
