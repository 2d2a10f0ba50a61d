"""Corner pinches: pieces touching at one point, at the bounds wall and away from it.

Issue 42, item 1: two rectangles meeting at one corner, each touching a map edge, with the
only way through that corner.  ``visgraph`` and ``sipp`` said ``infeasible`` for a point robot
although the pinch rule (docs/geometry.md: a robot of radius ``r <= eps`` passes a point where
solids touch) lets it through.  The bounds wall joins the two pieces into one solid, whose
rings (two holes, or a hole and the exterior) then meet at the pinch vertex; read ring by ring
that vertex is reflex, so the tangent graph had no node there and a path that turns at the
pinch was lost.

Every scene below is solved at each of the four rotations of the map (so the pinch sits at
each edge and each map corner), for every radius of :data:`RADII`, by ``visgraph`` and by
``sipp`` (no movers), and compared with

* the independent oracle of :mod:`tests.geometry.oracles` (shapely ``unary_union`` of the raw
  obstacles and of the complement of the bounds; a plain visibility graph for a point robot,
  a polygonal bracket for a disc), and
* the analytic answer: the pinch is open exactly for ``r <= eps``, and then the shortest path
  is ``|start - pinch| + |pinch - goal|`` (both legs are free by construction).

The fast paths (sight lines, the built graph searched compiled) give the same lengths as
the lazy search, and no convex piece of a solid has an edge of length 0 (a pinch vertex is
inserted once into a piece edge through it).

Metamorphic checks: translating the scene by ``(5e5, 5e6)``, scaling it (radius included) by
``1e-3`` and ``1e3``, and adding an obstacle far outside the map change no status and scale
every length.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

import optplan as op
from optplan.geometry import Frame
from optplan.geometry.tangent.tangent_graph import TangentGraph, shortest_path
from tests.geometry.oracles import path_is_free, plain_visibility_length, polygonal_bracket

BOUNDS = (0.0, 0.0, 100.0, 100.0)
EPS = Frame.from_bounds(BOUNDS).eps  # 1.4e-7: radii up to it are point robots
RADII = (0.0, 1e-9, 1e-7, 1e-5, 1e-3)
SOLVERS = ("visgraph", "sipp")


def _box(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


#: name -> (polygons, start, goal, pinch, enclosed).  ``pinch``: the point the point robot's
#: shortest path turns at (both legs free); ``enclosed``: the pinch is the only way, so a disc
#: (r > eps) has no path.  Drawn for the bottom edge / the lower-left corner; rotated below.
SCENES = {
    # the scene: a barrier from the bottom edge to the top edge, two rectangles meeting
    # at one corner near the bottom edge
    "across": ([_box(40, 0, 50, 20), _box(50, 20, 60, 100)], (20, 60), (80, 10), (50, 20),
               True),
    # two rectangles cutting off the lower-left map corner, each touching one of its edges
    "corner": ([_box(0, 30, 30, 40), _box(30, 0, 40, 30)], (20, 10), (80, 60), (30, 30), True),
    # a diamond touching the bottom edge at a vertex, a bar closing the pocket on its left:
    # the pinch is between an obstacle and the bounds wall itself
    "wall-edge": ([[(50, 0), (70, 20), (50, 40), (30, 20)], _box(0, 20, 40, 25)], (10, 10),
                  (90, 10), (50, 0), True),
    # a kite touching the lower-left map corner at a vertex, a bar closing the pocket below it
    "wall-corner": ([[(0, 0), (40, 20), (40, 40), (20, 40)], _box(40, 0, 50, 30)], (30, 5),
                    (5, 60), (0, 0), True),
    # controls away from the edges: the barrier one unit off them (a disc goes round)
    "off-edge": ([_box(40, 1, 50, 20), _box(50, 20, 60, 99)], (20, 60), (80, 10), (50, 20),
                 False),
    # a pocket closed by four rectangles, one pinch, far from the edges
    "pocket": ([_box(20, 20, 30, 60), _box(30, 60, 80, 70), _box(70, 20, 80, 60),
                _box(20, 10, 80, 20)], (50, 40), (30, 90), (30, 60), True),
    # two squares sharing a corner (two separate solids' corners: the rule before the fix)
    "squares": ([_box(30, 30, 50, 50), _box(50, 50, 70, 70)], (35, 60), (60, 45), (50, 50),
                False),
}


def _rot(p, k: int) -> tuple[float, float]:
    """``p`` turned by ``k`` quarter turns about the map's centre (exact for integers)."""
    x, y = float(p[0]), float(p[1])
    for _ in range(k):
        x, y = 100.0 - y, x
    return x, y


def _scene(name: str, k: int):
    polys, start, goal, pinch, enclosed = SCENES[name]
    return ([[_rot(p, k) for p in poly] for poly in polys], _rot(start, k), _rot(goal, k),
            _rot(pinch, k), enclosed)


def _problem(polys, start, goal, r: float, bounds=BOUNDS) -> op.Problem:
    return op.parse_problem({
        "name": "pinch", "bounds": list(bounds),
        "robots": [{"id": "r", "start": list(start), "goal": list(goal), "radius": r}],
        "obstacles": [{"type": "polygon", "name": f"p{i}", "vertices": [list(q) for q in poly]}
                      for i, poly in enumerate(polys)]})


def _outside(margin: float = 50.0) -> Polygon:
    """The oracle's bounds wall: the complement of the open bounds, ``margin`` wide."""
    x0, y0, x1, y1 = BOUNDS
    return Polygon(_box(x0 - margin, y0 - margin, x1 + margin, y1 + margin),
                   [_box(x0, y0, x1, y1)])


_ORACLE: dict = {}


def _oracle(name: str, k: int, r: float) -> tuple[float, float]:
    """The oracle's optimum (a point robot: ``lo == hi``) or bracket (a disc)."""
    key = (name, k, r <= EPS, r)
    if key not in _ORACLE:
        polys, start, goal, _, _ = _scene(name, k)
        solids = [Polygon(p) for p in polys] + [_outside()]
        if r <= EPS:
            v = plain_visibility_length(solids, start, goal)
            _ORACLE[key] = (v, v)
        else:
            _ORACLE[key] = polygonal_bracket(solids, r, start, goal)
    return _ORACLE[key]


def _length(res) -> float:
    return float(res.metrics.get("optimum", res.metrics["length"]))


@pytest.mark.parametrize("name", sorted(SCENES))
@pytest.mark.parametrize("k", range(4))
def test_corner_pinch_against_the_oracle(name: str, k: int) -> None:
    polys, start, goal, pinch, enclosed = _scene(name, k)
    through = math.dist(start, pinch) + math.dist(pinch, goal)
    for r in RADII:
        lo, hi = _oracle(name, k, r)
        # the oracle agrees with the pinch rule
        if r <= EPS:
            assert lo == pytest.approx(min(through, lo), rel=1e-12)
            assert lo == pytest.approx(through, rel=1e-12) or not enclosed
        elif enclosed:
            assert math.isinf(lo), (name, k, r, lo)
        prob = _problem(polys, start, goal, r)
        for solver in SOLVERS:
            res = op.solve(prob, solver)
            case = (name, k, r, solver, res.status, lo, hi)
            if math.isinf(lo):
                assert res.status == "infeasible", case
                continue
            # sipp certifies its arrival time, not the arcs of its polyline: a disc going
            # round a corner may be ``solved``; visgraph is always ``optimal`` here
            assert res.status == "optimal" or (solver == "sipp" and res.status == "solved"), case
            assert res.metrics["feasible"] and res.metrics["static_collisions"] == 0, case
            length = _length(res)
            # a radius within the tolerance goes round the pinch on arcs of radius r
            tol = 1e-9 * lo + 8 * math.pi * r
            assert lo - tol <= length <= hi + tol, (*case, length)
            assert path_is_free(res.paths["r"], [Polygon(p) for p in polys] + [_outside()],
                                r, 1e-7), case


def _transformed(polys, start, goal, r, scale=1.0, shift=(0.0, 0.0), far=False):
    def f(p):
        return (p[0] * scale + shift[0], p[1] * scale + shift[1])

    b = BOUNDS
    bounds = (*f(b[:2]), *f(b[2:]))
    extra = [_box(1e11, 1e11, 1e11 + 10, 1e11 + 10)] if far else []
    return _problem([[f(q) for q in p] for p in polys] + extra, f(start), f(goal), r * scale,
                    bounds)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_corner_pinch_metamorphic(name: str) -> None:
    """Translate, scale (radius included), add a far obstacle: same status, scaled length."""
    polys, start, goal, _, _ = _scene(name, 1)
    for r in (0.0, 1e-7, 1e-3):
        base = op.solve(_problem(polys, start, goal, r), "visgraph")
        ref = _length(base) if base.status == "optimal" else math.inf
        for scale, shift, far in ((1.0, (5e5, 5e6), False), (1e-3, (0.0, 0.0), False),
                                  (1e3, (0.0, 0.0), False), (1.0, (0.0, 0.0), True)):
            res = op.solve(_transformed(polys, start, goal, r, scale, shift, far), "visgraph")
            case = (name, r, scale, shift, far, base.status, res.status)
            assert res.status == base.status, case
            if math.isfinite(ref):
                assert _length(res) == pytest.approx(ref * scale, rel=1e-9), case


@pytest.mark.parametrize("name", sorted(SCENES))
def test_corner_pinch_fast_paths_agree(name: str) -> None:
    """Sight lines and the built (compiled) graph find the pinch as the lazy search does; the
    edge table has a normal for every edge."""
    for k in range(4):
        polys, start, goal, _, _ = _scene(name, k)
        for r in (0.0, 1e-7, 1e-3):
            oset = _problem(polys, start, goal, r).obstacle_set(r)
            assert np.isfinite(oset.table).all(), (name, k, r)
            ref = shortest_path(oset, start, goal).length
            for sightlines in (False, True):
                g = TangentGraph(oset, sightlines=sightlines)
                for _ in range(2):  # lazy, then built
                    length = g.shortest_path(start, goal).length
                    assert length == ref or length == pytest.approx(ref, rel=1e-9), \
                        (name, k, r, sightlines, g.chains is not None)
                    g.build()
