"""An exact tangent-graph path from its circles: its length and its drawing.

The exact path of :mod:`optplan.geometry.tangent.tangent_graph` runs along arcs of the grown
obstacles; a polyline that replaces every arc by a *circumscribed* polyline (vertices outside
the circle, every chord tangent to it) stays ``>= r`` from the arc's obstacle.  A path is
defined by its start, its goal and the circles it follows with their senses
(:func:`exact_path`): both searches (the lazy A* and the compiled one over the built graph)
report those, and its length and polyline are computed from them here, one way, so that the
two give the same bits for the same path.
"""

from __future__ import annotations

import math

import numpy as np

from optplan.geometry.tangent.circles import ANGLE_TOL, Circles
from optplan.geometry.tangent.tangent_edges import arc_sweep, tangent_normal

__all__ = ["arc_polyline", "exact_path", "rebuild_polyline", "world_polyline"]


def exact_path(C: Circles, zs: complex, zg: complex, visits: list[tuple[int, int]],
               arc_step: float) -> tuple[float, np.ndarray, list]:
    """Length, polyline and waypoints of the path from ``zs`` to ``zg`` (local complex) that
    follows the circles ``visits`` (``(circle, sense)`` in order) of ``C``.

    Each tangent is recomputed from its two ends (module
    :mod:`~optplan.geometry.tangent.tangent_edges`: normal, tangent points ``c - s rho n``,
    length ``sqrt(d^2 - delta^2)``; the ends are circles of radius 0), each arc from its
    arrival and departure angles (:func:`~optplan.geometry.tangent.tangent_edges.arc_sweep`);
    the length sums, in path order, the first tangent, then per circle its arc ``rho * sweep``
    and the next tangent (the order in which the lazy search adds them up).  A circle the
    path only touches (an arc of at most ``ANGLE_TOL``) is not a visit: the tangents on
    either side of it are one line, made as one tangent.

    Returns
    -------
    length : float
    z : ndarray (complex)
        The polyline (local frame): the start, per circle its arc as :func:`arc_polyline`
        (inner vertices) between the arrival and the departure point, the goal.
    waypoints : list
        Per circle ``(centre, rho, arrival angle, sweep, sense)``.
    """
    c = np.array([v[0] for v in visits], np.int64)
    s = np.array([v[1] for v in visits], np.int64)
    while True:  # until no circle is passed straight (see below)
        cen = np.concatenate([[zs], C.center[c], [zg]])
        rho = np.concatenate([[0.0], C.rho[c], [0.0]])
        sen = np.concatenate([[1], s, [1]])
        D = cen[1:] - cen[:-1]
        dd = np.abs(D)
        delta = sen[1:] * rho[1:] - sen[:-1] * rho[:-1]
        nl = tangent_normal(D, dd, delta)
        za, zd = -sen[1:-1] * nl[:-1], -sen[1:-1] * nl[1:]
        th_a = np.arctan2(za.imag, za.real)  # arrivals on the circles
        th_d = np.arctan2(zd.imag, zd.real)  # departures from them
        sweep = arc_sweep(C, c, s, th_a, th_d) if len(c) else np.zeros(0)
        # a circle left where it is reached (no arc) is only touched: the tangents before
        # and after it are one line, the tangent from the circle before it to the one after
        # it (the searches may or may not stop at collinear vertices: the path is the same)
        keep = ~(sweep <= ANGLE_TOL)
        if keep.all():
            break
        c, s = c[keep], s[keep]
    p_dep = cen[:-1] - sen[:-1] * rho[:-1] * nl
    p_arr = cen[1:] - sen[1:] * rho[1:] * nl
    seg = np.sqrt(np.maximum(dd ** 2 - delta ** 2, 0.0))
    length = float(seg[0])
    pts, wps = [zs, p_arr[0]], []
    for k in range(len(c)):
        r, sw, th = float(rho[k + 1]), float(sweep[k]), float(th_a[k])
        length = length + r * sw + float(seg[k + 1])
        if r > 0 and sw > 0:
            pts.extend(arc_polyline(cen[k + 1], r, th, sw * int(s[k]), arc_step)[1:-1])
        wps.append((cen[k + 1], r, th, sw, int(s[k])))
        pts += [p_dep[k + 1], p_arr[k + 1]]
    return length, np.array(pts), wps


def arc_polyline(c: complex, rho: float, theta0: float, sweep: float,
                 step: float = math.pi / 36) -> np.ndarray:
    """Circumscribed polyline of the arc of circle ``(c, rho)`` from angle ``theta0`` over the
    signed angle ``sweep``: the two arc ends on the circle, inner vertices at radius
    ``rho / cos(delta / 2)`` so that every chord is tangent to the circle (complex array)."""
    m = max(1, int(math.ceil(abs(sweep) / step)))
    dl = sweep / m
    ang = theta0 + (np.arange(m) + 0.5) * dl
    inner = c + rho / math.cos(dl / 2) * np.exp(1j * ang)
    return np.concatenate([[c + rho * np.exp(1j * theta0)], inner,
                           [c + rho * np.exp(1j * (theta0 + sweep))]])


def rebuild_polyline(waypoints: list, frame, robot, step: float) -> np.ndarray:
    """The world polyline of a path's ``waypoints`` (``TangentPath.waypoints``) from the
    robot's start to its goal, its arcs drawn with chords of at most ``step`` radians."""
    pts = [complex(*frame.local(robot.start))]
    for c, rho, th, sweep, s in waypoints:
        arc = arc_polyline(c, rho, th, sweep * s, step)
        pts.extend(arc if rho > 0 else arc[:1])
    pts.append(complex(*frame.local(robot.goal)))
    return world_polyline(frame, np.array(pts), robot.start, robot.goal)


def world_polyline(frame, z: np.ndarray, start, goal) -> np.ndarray:
    """The world polyline ``(m, 2)`` of the local points ``z`` (complex) of a path from
    ``start`` to ``goal`` (world): a point equal to the one before it dropped, the ends set
    to ``start`` and ``goal`` exactly."""
    poly = frame.world(np.ascontiguousarray(z, complex).view(float).reshape(-1, 2))
    keep = np.ones(len(poly), bool)
    step = poly[1:] != poly[:-1]
    keep[1:] = step[:, 0] | step[:, 1]
    poly = poly[keep]
    poly[0], poly[-1] = np.asarray(start, float), np.asarray(goal, float)
    return poly
