"""Small scenes for the references in time: a 10 x 10 map, one robot from (1, 5) to (9, 5)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from optplan.problem import Problem, parse_problem

SQUARE = [[-1, -1], [1, -1], [1, 1], [-1, 1]]


def scaled_mover(m: dict, pt: Callable[[Sequence[float]], list[float]], scale: float) -> dict:
    """A ``[[dynamic_obstacles]]`` table in space and time scaled by ``scale``: its points
    mapped by ``pt``, its times, radius and vertices multiplied (speeds unchanged)."""
    m = dict(m)
    m["waypoints"] = [pt(p) for p in m["waypoints"]]
    if "times" in m:
        m["times"] = [t * scale for t in m["times"]]
    if "radius" in m:
        m["radius"] = m["radius"] * scale
    if "vertices" in m:
        m["vertices"] = [[x * scale, y * scale] for x, y in m["vertices"]]
    return m


def time_scene(movers, obstacles=(), scale=1.0, shift=(0.0, 0.0), speed=1.0) -> Problem:
    """A 10 x 10 map (robot from (1, 5) to (9, 5), radius 0.2), scaled in space by ``scale``
    and in time by ``scale`` too (speeds unchanged), then translated by ``shift``."""
    sx, sy = shift

    def pt(p):
        return [p[0] * scale + sx, p[1] * scale + sy]

    dyn = [scaled_mover(m, pt, scale) for m in movers]
    obs = [{"type": "circle", "center": pt(o[0]), "radius": o[1] * scale} for o in obstacles]
    return parse_problem({
        "name": "t", "bounds": [sx, sy, sx + 10 * scale, sy + 10 * scale],
        "robots": [{"id": "r", "start": pt([1, 5]), "goal": pt([9, 5]), "radius": 0.2 * scale,
                    "max_speed": speed}],
        "obstacles": obs, "dynamic_obstacles": dyn})
