r"""ORCA's velocity programs, for an avoidance that a moving obstacle does not share.

RVO2 (and its Python binding pyrvo) builds, for every agent and step, one half-plane of
permitted velocities per neighbour (an *ORCA line*: a point and a direction, the permitted
side on the left) and solves a small program: the velocity closest to the preferred one
inside every half-plane and the max-speed disc (van den Berg, Guy, Lin and Manocha,
"Reciprocal n-body collision avoidance", ISRR 2011, eqs (5)-(6)); when that is infeasible, the
velocity that least violates the agents' half-planes while keeping the obstacles' ones (their
section 5.3).  Every neighbour agent is assumed to *reciprocate*: the line of a neighbour is
placed at ``v + u / 2``, where ``v`` is the agent's velocity and ``u`` the smallest change of
the relative velocity that leaves the truncated velocity obstacle, so each agent takes half
the avoidance.  A moving obstacle keeps its prescribed velocity and takes none: against it the
robot must take all of it, the line at ``v + u``, i.e. the point ``p`` of RVO2's line moved to
``2 p - v`` (the same direction).  pyrvo fixes the half, so :func:`orca_velocity` solves the
program again on RVO2's own lines with those of the moving obstacles moved.

This is a hand-written port of RVO2's ``linearProgram1``-``linearProgram3`` (the incremental
2-D linear program of de Berg et al. with the max-speed disc), in double precision; it is
needed for fidelity (the library offers no per-neighbour share), and it is tested against
RVO2 itself: on RVO2's unmodified lines it returns RVO2's velocity (``tests/formation``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["orca_velocity", "full_share"]

#: RVO2's ``RVO_EPSILON``: lines closer to parallel than this are treated as parallel.
EPS = 1e-5


def _det(ax: float, ay: float, bx: float, by: float) -> float:
    """The 2-D cross product ``a x b``."""
    return ax * by - ay * bx


def _lp1(pts: np.ndarray, dirs: np.ndarray, n: int, radius: float, opt: np.ndarray,
         direction: bool) -> np.ndarray | None:
    """The optimum on line ``n`` within the disc and lines ``0..n-1`` (``None``: empty)."""
    p, d = pts[n], dirs[n]
    dot = float(p @ d)
    disc = dot * dot + radius * radius - float(p @ p)
    if disc < 0.0:
        return None
    t_left, t_right = -dot - math.sqrt(disc), -dot + math.sqrt(disc)
    for i in range(n):
        den = _det(d[0], d[1], dirs[i, 0], dirs[i, 1])
        num = _det(dirs[i, 0], dirs[i, 1], p[0] - pts[i, 0], p[1] - pts[i, 1])
        if abs(den) <= EPS:
            if num < 0.0:
                return None
            continue
        if den >= 0.0:
            t_right = min(t_right, num / den)
        else:
            t_left = max(t_left, num / den)
        if t_left > t_right:
            return None
    if direction:
        t = t_right if float(opt @ d) > 0.0 else t_left
    else:
        t = min(max(float(d @ (opt - p)), t_left), t_right)
    return p + t * d


def _lp2(pts: np.ndarray, dirs: np.ndarray, radius: float, opt: np.ndarray, direction: bool
         ) -> tuple[int, np.ndarray]:
    """RVO2's ``linearProgram2``: the index of the first line it fails on (``len``: none)
    and the result so far."""
    if direction:
        res = opt * radius
    elif float(opt @ opt) > radius * radius:
        res = opt / math.hypot(*opt) * radius
    else:
        res = opt.copy()
    for i in range(len(pts)):
        if _det(dirs[i, 0], dirs[i, 1], pts[i, 0] - res[0], pts[i, 1] - res[1]) > 0.0:
            got = _lp1(pts, dirs, i, radius, opt, direction)
            if got is None:
                return i, res
            res = got
    return len(pts), res


def _projected(pts: np.ndarray, dirs: np.ndarray, n_obst: int, i: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """The lines of ``linearProgram3``'s sub-program for line ``i``: the obstacles' lines and
    the bisectors of line ``i`` with each earlier agent line."""
    out_p, out_d = list(pts[:n_obst]), list(dirs[:n_obst])
    pi, di = pts[i], dirs[i]
    for j in range(n_obst, i):
        dj = dirs[j]
        det = _det(di[0], di[1], dj[0], dj[1])
        if abs(det) <= EPS:
            if float(di @ dj) > 0.0:
                continue
            point = 0.5 * (pi + pts[j])
        else:
            point = pi + _det(dj[0], dj[1], pi[0] - pts[j, 0], pi[1] - pts[j, 1]) / det * di
        dd = dj - di
        out_p.append(point)
        out_d.append(dd / math.hypot(*dd))
    return np.reshape(out_p, (-1, 2)), np.reshape(out_d, (-1, 2))


def _lp3(pts: np.ndarray, dirs: np.ndarray, n_obst: int, begin: int, radius: float,
         res: np.ndarray) -> np.ndarray:
    """RVO2's ``linearProgram3``: the least violation of the agents' lines."""
    dist = 0.0
    for i in range(begin, len(pts)):
        if _det(dirs[i, 0], dirs[i, 1], pts[i, 0] - res[0], pts[i, 1] - res[1]) > dist:
            pp, pd = _projected(pts, dirs, n_obst, i)
            fail, got = _lp2(pp, pd, radius, np.array([-dirs[i, 1], dirs[i, 0]]), True)
            if fail >= len(pp):  # else: round-off, keep the current result (as RVO2 does)
                res = got
            dist = _det(dirs[i, 0], dirs[i, 1], pts[i, 0] - res[0], pts[i, 1] - res[1])
    return res


def orca_velocity(points: np.ndarray, directions: np.ndarray, n_obst: int, max_speed: float,
                  preferred: np.ndarray) -> np.ndarray:
    """The ORCA velocity of one agent: RVO2's programs on the given lines.

    Parameters
    ----------
    points, directions : numpy.ndarray
        The ORCA lines, ``(k, 2)`` each (directions of unit length; permitted side on the
        left), the obstacles' first.
    n_obst : int
        How many of the lines are the obstacles' (kept hard when the program is infeasible).
    max_speed : float
        The radius of the speed disc.
    preferred : numpy.ndarray
        The preferred velocity ``(2,)``.

    Returns
    -------
    numpy.ndarray
        The velocity ``(2,)``: the closest to ``preferred`` in every half-plane and the disc,
        or, when none is, the least violation of the agents' lines (RVO2's rule).
    """
    pts = np.asarray(points, float).reshape(-1, 2)
    dirs = np.asarray(directions, float).reshape(-1, 2)
    pref = np.asarray(preferred, float)
    fail, res = _lp2(pts, dirs, float(max_speed), pref, False)
    if fail < len(pts):
        res = _lp3(pts, dirs, int(n_obst), fail, float(max_speed), res)
    return res


def full_share(point: np.ndarray, velocity: np.ndarray, share: float) -> np.ndarray:
    """The point of an ORCA line placed by RVO2 at ``v + u / 2``, moved to ``v + share u``
    (``share = 1``: the whole avoidance, against a neighbour that does not reciprocate)."""
    v = np.asarray(velocity, float)
    return v + 2.0 * share * (np.asarray(point, float) - v)
