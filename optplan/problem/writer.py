"""A problem back to the scenario format (:func:`problem_to_dict`) and the similarity
transform of a whole scene (:func:`transform_problem`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely
import shapely.affinity

from optplan.problem.model import DynamicObstacle, Follower, Formation, Obstacle, Problem, Robot
from optplan.problem.roadmap import RoadmapGraph

# --------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------


def ring_points(ring) -> list[list[float]]:
    """Vertices of a shapely ring as ``[[x, y], ...]`` without the closing repeat."""
    return [[float(x), float(y)] for x, y in list(ring.coords)[:-1]]


def _robot_to_dict(r: Robot) -> dict[str, Any]:
    """The ``[[robots]]`` table of ``r``."""
    t: dict[str, Any] = {"id": r.id, "start": [float(v) for v in r.start]}
    if r.goal is not None:
        t["goal"] = [float(v) for v in r.goal]
    t["radius"] = float(r.radius)
    t["max_speed"] = float(r.max_speed)
    return t


def _obstacle_to_dict(o: Obstacle) -> dict[str, Any]:
    """The ``[[obstacles]]`` table of ``o``."""
    t: dict[str, Any] = {"type": o.kind, "name": o.name}
    if o.is_circle:
        center, radius = o.disc()
        t["center"] = [float(v) for v in center]
        t["radius"] = float(radius)
    elif o.kind == "rectangle":
        x0, y0, x1, y1 = o.polygon().bounds
        t["min"], t["max"] = [x0, y0], [x1, y1]
    else:
        poly = o.polygon()
        t["vertices"] = ring_points(poly.exterior)
        if poly.interiors:
            t["holes"] = [ring_points(h) for h in poly.interiors]
    if not o.known:
        t["known"] = False
    return t


def _dynamic_to_dict(d: DynamicObstacle) -> dict[str, Any]:
    """The ``[[dynamic_obstacles]]`` table of ``d``."""
    t: dict[str, Any] = {"type": d.kind, "name": d.name}
    if d.kind == "circle":
        t["radius"] = d.circle_radius()
    else:
        t["vertices"] = ring_points(d.local_geometry.exterior)
    t["waypoints"] = [[float(x), float(y)] for x, y in d.waypoints]
    t["times"] = [float(x) for x in d.times]
    if d.velocity is not None:
        t["velocity"] = [float(v) for v in d.velocity]
    else:
        t["after"] = d.after
    return t


def _header_to_dict(problem: Problem) -> dict[str, Any]:
    """The top-level keys of ``problem``'s scenario table (before ``[formation]``)."""
    out: dict[str, Any] = {"name": problem.name}
    if problem.description:
        out["description"] = problem.description
    if problem.source:
        out["source"] = problem.source
    if problem.tags:
        out["tags"] = list(problem.tags)
    out["bounds"] = [float(v) for v in problem.bounds]
    if problem.goal_tolerance is not None:
        out["goal_tolerance"] = float(problem.goal_tolerance)
    if problem.scale is not None:
        out["length_scale"] = float(problem.scale)
    if problem.sensing_range is not None:
        out["sensing"] = {"range": float(problem.sensing_range)}
    return out


def problem_to_dict(problem: Problem) -> dict[str, Any]:
    """The scenario table of ``problem``: what :func:`parse_problem` reads back into an equal
    problem (every key of the TOML format it uses; numbers as Python floats)."""
    out = _header_to_dict(problem)
    if problem.formation is not None:
        f = problem.formation
        out["formation"] = {
            "leader": f.leader, "safety_distance": float(f.safety_distance),
            "followers": [{"id": x.id, "L": float(x.L), "phi": float(x.phi)}
                          for x in f.followers]}
    out["robots"] = [_robot_to_dict(r) for r in problem.robots]
    obstacles = [_obstacle_to_dict(o) for o in problem.obstacles]
    if obstacles:
        out["obstacles"] = obstacles
    dyn = [_dynamic_to_dict(d) for d in problem.dynamic_obstacles]
    if dyn:
        out["dynamic_obstacles"] = dyn
    if problem.roadmap is not None:
        out["roadmap"] = {"nodes": problem.roadmap.nodes.tolist(),
                          "edges": problem.roadmap.edges.tolist()}
    return out


def round_decimals(x, decimals: int) -> np.ndarray:
    """``x`` rounded to ``decimals`` decimal places: ``rint(x * 10**d) / 10**d``, so a value
    written with at most ``d`` decimals maps to itself exactly (the canonical frame)."""
    ten = 10.0 ** int(decimals)
    return np.rint(np.asarray(x, dtype=float) * ten) / ten


def transform_problem(problem: Problem, scale: float = 1.0, shift=(0.0, 0.0), *,
                      decimals: int | None = None) -> Problem:
    """``problem`` with every length scaled by ``scale`` about the origin, then shifted.

    Positions (the roadmap's nodes too), sizes, radii, speeds, formation distances, tolerances
    and sensing range scale (times do not), so every answer of a scale- and
    translation-invariant method is the same up to the scale (the metamorphic tests use it).
    With ``decimals``, every transformed coordinate and length is then rounded to that many
    decimal places (the canonical frame, :mod:`optplan.canonical`).  The caches of the copy
    are empty.
    """
    import dataclasses

    s = float(scale)
    if not (s > 0 and math.isfinite(s)):
        raise ValueError(f"scale must be a finite number > 0, got {scale!r}")
    off = np.asarray(shift, dtype=float).reshape(2)
    def rnd(x):
        return x if decimals is None else round_decimals(x, decimals)

    def length(v):
        return None if v is None else float(rnd(v * s))

    def vec(v):  # a displacement or velocity: scaled, not shifted
        return None if v is None else rnd(np.asarray(v, float) * s)

    def pt(p):
        return None if p is None else rnd(np.asarray(p, float) * s + off)

    def geom(g, shifted=True):
        if g is None:
            return None
        return shapely.transform(g, (lambda c: rnd(c * s + off)) if shifted
                                 else (lambda c: rnd(c * s)))

    robots = tuple(dataclasses.replace(r, start=pt(r.start), goal=pt(r.goal),
                                       radius=length(r.radius), max_speed=length(r.max_speed))
                   for r in problem.robots)
    obstacles = tuple(dataclasses.replace(
        o, geometry=geom(o.geometry), center=pt(o.center), radius=length(o.radius))
        for o in problem.obstacles)
    dyn = tuple(dataclasses.replace(
        d, local_geometry=geom(d.local_geometry, shifted=False), waypoints=pt(d.waypoints),
        velocity=vec(d.velocity), radius=length(d.radius)) for d in problem.dynamic_obstacles)
    form = problem.formation
    if form is not None:
        form = Formation(form.leader, tuple(Follower(f.id, length(f.L), f.phi)
                                            for f in form.followers),
                         length(form.safety_distance))
    lo, hi = pt(problem.bounds[:2]), pt(problem.bounds[2:])
    roadmap = problem.roadmap
    if roadmap is not None:  # rounded as the robots' ends are: they stay on its nodes
        roadmap = roadmap.transformed(s, off)
        if decimals is not None:
            roadmap = RoadmapGraph(rnd(roadmap.nodes), roadmap.edges)
    return dataclasses.replace(
        problem, bounds=(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])),
        robots=robots, obstacles=obstacles, dynamic_obstacles=dyn, formation=form,
        roadmap=roadmap,
        goal_tolerance=length(problem.goal_tolerance),
        sensing_range=length(problem.sensing_range), scale=length(problem.scale),
        _cache={})
