"""The RVO2 world of backend ``orca``: the scene as RVO2 polygons and agents (through pyrvo).

RVO2 (van den Berg, Guy, Lin and Manocha) knows two things: disc *agents* and polygonal
*obstacles*.  :func:`build_world` puts a problem into one ``pyrvo.RVOSimulator``:

* every static obstacle (temporary ones too: a local planner senses them) as RVO2 obstacles:
  a polygon as given, its exterior counter-clockwise (an obstacle) and each hole clockwise (a
  free region inside it, RVO2's rule for a "negative" obstacle); non-convex polygons as they are
  (RVO2 classifies each vertex); a circle as the regular polygon *circumscribed* about it
  (:func:`circle_polygon`), which contains the circle, so the approximation only adds obstacle;
* the bounds as a wall: the bounds rectangle listed clockwise (the agents keep inside it);
* every moving obstacle as an agent whose position and velocity are prescribed each step
  (:class:`Movers`): a circle with its radius, a polygon as the disc of its smallest enclosing
  circle about the vertices (a disc that contains the polygon).

RVO2 computes in single precision, so the world is posed in a local frame
(:class:`LocalFrame`): coordinates relative to the centre of the bounds in units of the problem's
``length_scale``, speeds in ``length_scale`` per second, times unchanged.  The same scene drawn
at another scale then gives RVO2 the same numbers.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from optplan.geometry.timing import mover_pieces
from optplan.problem import DynamicObstacle, Problem

__all__ = ["LocalFrame", "Movers", "circle_polygon", "obstacle_polygons", "require_pyrvo",
           "build_world", "AgentParams"]

#: What to install when pyrvo is missing.
INSTALL_HINT = "pip install 'optplan[orca]' (or pip install pyrvo)"


def require_pyrvo() -> Any:
    """The ``pyrvo`` module (Python bindings of RVO2).

    Raises
    ------
    ImportError
        Naming the package and how to install it, when it cannot be imported.
    """
    try:
        return importlib.import_module("pyrvo")
    except ImportError as e:
        raise ImportError(f"backend 'orca' needs the package 'pyrvo' (RVO2's Python bindings), "
                          f"which cannot be imported ({e}): {INSTALL_HINT}") from None


@dataclass(frozen=True)
class LocalFrame:
    """World <-> RVO2 coordinates: ``local = (world - centre) / unit``.

    Attributes
    ----------
    centre : ndarray ``(2,)``
        The centre of the problem's bounds (world).
    unit : float
        The problem's ``length_scale`` (world length of one local unit).
    """

    centre: np.ndarray
    unit: float

    @classmethod
    def of(cls, problem: Problem) -> LocalFrame:
        """The local frame of ``problem`` (centre of its bounds, its ``length_scale``)."""
        x0, y0, x1, y1 = problem.bounds
        return cls(np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)]), float(problem.length_scale))

    def local(self, points: Any) -> np.ndarray:
        """World points ``(..., 2)`` in local coordinates."""
        return (np.asarray(points, dtype=float) - self.centre) / self.unit

    def world(self, points: Any) -> np.ndarray:
        """Local points ``(..., 2)`` in world coordinates."""
        return np.asarray(points, dtype=float) * self.unit + self.centre


def circle_polygon(center: np.ndarray, radius: float, sides: int) -> np.ndarray:
    """The regular ``sides``-gon circumscribed about a circle, counter-clockwise.

    Its vertices are at ``radius / cos(pi / sides)`` from the centre, so every edge touches the
    circle and the polygon contains it.

    Parameters
    ----------
    center : ndarray ``(2,)``
    radius : float
    sides : int
        At least 3.

    Returns
    -------
    ndarray ``(sides, 2)``
    """
    ang = 2.0 * np.pi * np.arange(sides) / sides
    rc = float(radius) / np.cos(np.pi / sides)
    return np.asarray(center, dtype=float) + rc * np.stack([np.cos(ang), np.sin(ang)], axis=1)


def _ring(coords: Any, frame: LocalFrame) -> np.ndarray | None:
    """A closed shapely ring as RVO2 vertices: local, the closing vertex dropped, repeated
    vertices (equal in single precision) removed; ``None`` when fewer than two remain."""
    pts = frame.local(np.asarray(coords, dtype=float)[:-1]).astype(np.float32)
    keep = np.any(pts != np.roll(pts, 1, axis=0), axis=1)
    pts = pts[keep]
    return pts.astype(float) if len(pts) >= 2 else None


def _polygon_rings(poly: Polygon, frame: LocalFrame) -> list[np.ndarray]:
    """A polygon's exterior counter-clockwise and its holes clockwise, as RVO2 vertex lists."""
    p = orient(poly, sign=1.0)
    rings = [_ring(p.exterior.coords, frame)] + [_ring(h.coords, frame) for h in p.interiors]
    return [r for r in rings if r is not None]


def obstacle_polygons(problem: Problem, frame: LocalFrame, sides: int) -> list[np.ndarray]:
    """Every static obstacle and the bounds wall as RVO2 vertex lists (local coordinates).

    Parameters
    ----------
    problem : Problem
    frame : LocalFrame
    sides : int
        Sides of the polygon circumscribed about a circle obstacle.

    Returns
    -------
    list of ndarray ``(m, 2)``
        Obstacles counter-clockwise, holes and the bounds clockwise (module docstring).
    """
    out: list[np.ndarray] = []
    for o in problem.static_obstacles():
        if o.is_circle:
            c, r = o.disc()
            poly = Polygon(circle_polygon(c, r, sides))
        else:
            poly = o.polygon()
        out.extend(_polygon_rings(poly, frame))
    x0, y0, x1, y1 = problem.bounds
    wall = np.array([[x0, y0], [x0, y1], [x1, y1], [x1, y0]], dtype=float)  # clockwise
    out.append(frame.local(wall))
    return out


class Movers:
    """The moving obstacles as discs with prescribed motion.

    Each is the disc of its circle, or of the smallest circle about its polygon's vertices
    (centre ``offset`` from the reference point that
    :meth:`~optplan.problem.DynamicObstacle.position` moves).  :meth:`at` gives the discs'
    centres and velocities at a time: the velocity of the linear piece of the track
    (:func:`optplan.geometry.timing.motion.mover_pieces`) the obstacle is on at that time.
    """

    def __init__(self, problem: Problem):
        self.dyn: list[DynamicObstacle] = list(problem.dynamic_obstacles)
        self.offset = np.zeros((len(self.dyn), 2))
        self.radius = np.zeros(len(self.dyn))
        for k, d in enumerate(self.dyn):
            if d.kind == "circle":
                self.radius[k] = d.circle_radius()
                continue
            g = d.local_geometry
            c = np.asarray(shapely.minimum_bounding_circle(g).centroid.coords[0], dtype=float)
            v = np.asarray(g.exterior.coords, dtype=float)
            self.offset[k] = c
            self.radius[k] = float(np.max(np.hypot(*(v - c).T)))

    def __len__(self) -> int:
        return len(self.dyn)

    def at(self, t: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Centres ``(M, 2)`` and velocities ``(M, 2)`` (world) of the discs at time ``t``.

        Parameters
        ----------
        t : float
            The time (s).
        dt : float
            The step (s): the pieces are looked up on ``[t, t + dt]``.
        """
        pos = np.zeros((len(self.dyn), 2))
        vel = np.zeros((len(self.dyn), 2))
        for k, d in enumerate(self.dyn):
            pos[k] = d.position(float(t)) + self.offset[k]
            ta, tb, _, w = mover_pieces(d, float(t), float(t) + float(dt))
            on = np.flatnonzero((ta <= t) & (t < tb))
            if len(on):
                vel[k] = w[on[0]]
        return pos, vel


@dataclass(frozen=True)
class AgentParams:
    """RVO2's agent parameters of the robots (local units; times in seconds).

    Attributes
    ----------
    neighbor_dist : float
        Neighbour distance (local units).
    max_neighbors : int
    time_horizon, time_horizon_obst : float
        ORCA's time horizons for agents and for obstacles (s).
    margin : float
        Added to every robot's radius (local units).
    """

    neighbor_dist: float
    max_neighbors: int
    time_horizon: float
    time_horizon_obst: float
    margin: float


def build_world(problem: Problem, robots: list, frame: LocalFrame, params: AgentParams,
                dt: float, sides: int, movers: Movers) -> tuple[Any, int]:
    """An ``RVOSimulator`` with the scene's obstacles, the robots, then the movers as agents.

    Parameters
    ----------
    problem : Problem
    robots : list of Robot
        The robots, agents ``0 .. R-1`` in this order (radius ``radius + margin``, maximum speed
        ``max_speed``, both in local units).
    frame : LocalFrame
    params : AgentParams
    dt : float
        RVO2's time step (s).
    sides : int
        Sides of the polygons circumscribed about circle obstacles.
    movers : Movers
        Agents ``R .. R+M-1``: no neighbours of their own (they are moved, not planned).

    Returns
    -------
    sim : pyrvo.RVOSimulator
    n_vertices : int
        The number of obstacle vertices given to RVO2.
    """
    rvo = require_pyrvo()
    sim = rvo.RVOSimulator()
    sim.set_time_step(float(dt))
    n_vertices = 0
    for ring in obstacle_polygons(problem, frame, sides):
        sim.add_obstacle([tuple(map(float, p)) for p in ring])
        n_vertices += len(ring)
    sim.process_obstacles()
    for r in robots:
        sim.add_agent(tuple(map(float, frame.local(r.start))), params.neighbor_dist,
                      params.max_neighbors, params.time_horizon, params.time_horizon_obst,
                      r.radius / frame.unit + params.margin, r.max_speed / frame.unit,
                      (0.0, 0.0))
    pos, _ = movers.at(0.0, dt)
    for k in range(len(movers)):
        sim.add_agent(tuple(map(float, frame.local(pos[k]))), 0.0, 0, params.time_horizon,
                      params.time_horizon_obst, float(movers.radius[k]) / frame.unit, 0.0,
                      (0.0, 0.0))
    return sim, n_vertices
