"""Drawing the arcs of an exact tangent-graph path: circumscribed polylines.

The exact path of :mod:`optplan.geometry.tangent.tangent_graph` runs along arcs of the grown
obstacles; a polyline that replaces every arc by a *circumscribed* polyline (vertices outside
the circle, every chord tangent to it) stays ``>= r`` from the arc's obstacle.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["arc_polyline", "rebuild_polyline"]


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
    z = np.array(pts)
    poly = frame.world(np.stack([z.real, z.imag], axis=1))
    keep = np.r_[True, np.any(np.diff(poly, axis=0) != 0, axis=1)]
    poly = poly[keep]
    poly[0], poly[-1] = robot.start, robot.goal
    return poly
