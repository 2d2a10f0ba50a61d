"""Touching and overlapping obstacles are one solid: the certified optimum and the validator
against an independent oracle (shapely ``unary_union`` of the raw obstacles and a plain
visibility graph or a fine polygonal bracket on it, :mod:`oracles`), and metamorphic tests
(splitting an obstacle into touching pieces, or merging touching pieces, changes nothing)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient
from shapely.ops import split

import optplan as op
from optplan.geometry import Frame, obstacle_set
from optplan.geometry.tangent.tangent_graph import shortest_path
from optplan.problem import Obstacle, parse_problem
from tests.geometry.oracles import path_is_free, plain_visibility_length, polygonal_bracket

BOUNDS = (0.0, 0.0, 100.0, 100.0)
FRAME = Frame.from_bounds(BOUNDS)
EPS = FRAME.eps
START, GOAL = (2.0, 2.0), (98.0, 98.0)
RADII = (0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.7, 2.0)


def polygon(geom, name: str = "p") -> Obstacle:
    return Obstacle("polygon", orient(geom, 1.0), name=name)


# --------------------------------------------------------------------------------------
# random maps made of touching and overlapping pieces
# --------------------------------------------------------------------------------------


def grid_cells(rng: np.random.Generator) -> list[Polygon]:
    """Occupied cells of a random 8 x 8 grid over [10, 90]^2, one square obstacle per cell:
    shared edges, shared corners (pinch points) and long walls of many pieces."""
    occ = rng.random((8, 8)) < rng.uniform(0.2, 0.45)
    return [shapely.box(10 + 10 * i, 10 + 10 * j, 20 + 10 * i, 20 + 10 * j)
            for i, j in zip(*np.nonzero(occ))]


def split_walls(rng: np.random.Generator) -> list[Polygon]:
    """Random walls, each split into 2-4 strips at random (float) cut positions, plus random
    rectangles that overlap them or lie inside them."""
    out: list[Polygon] = []
    for _ in range(int(rng.integers(2, 5))):
        x0, y0 = rng.uniform(10, 70, 2)
        horizontal = rng.random() < 0.5
        length, width = rng.uniform(15, 30), rng.uniform(1, 4)
        cuts = np.sort(rng.uniform(0, length, int(rng.integers(1, 4))))
        edges = np.r_[0.0, cuts, length]
        for a, b in zip(edges[:-1], edges[1:]):
            if b - a <= 0:
                continue
            out.append(shapely.box(x0 + a, y0, x0 + b, y0 + width) if horizontal else
                       shapely.box(x0, y0 + a, x0 + width, y0 + b))
    for _ in range(int(rng.integers(1, 4))):
        base = out[int(rng.integers(len(out)))]
        bx0, by0, bx1, by1 = base.bounds
        cx, cy = rng.uniform(bx0, bx1), rng.uniform(by0, by1)
        w, h = rng.uniform(0.2, 6, 2)
        box = shapely.box(cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)
        if box.within(shapely.box(8, 8, 92, 92)):
            out.append(box)  # overlapping, or contained when small
    return out


def shared_corners(rng: np.random.Generator) -> list[Polygon]:
    """Diagonal chains of squares touching at corners only, crossing the map."""
    out = []
    s = rng.uniform(6, 12)
    x, y = rng.uniform(10, 30), rng.uniform(60, 80)
    while x + s < 92 and y - s > 8:
        out.append(shapely.box(x, y - s, x + s, y))
        x, y = x + s, y - s
    return out


MAKERS = {"grid": grid_cells, "strips": split_walls, "corners": shared_corners}


def oracle_length(polys: list[Polygon], r: float, start=START, goal=GOAL
                  ) -> tuple[float, float]:
    """The oracle's optimum (lo == hi for a point robot; a radius within the tolerance is a
    point robot, docs/geometry.md) or its bracket for a disc."""
    if r <= EPS:
        v = plain_visibility_length(polys, start, goal)
        return v, v
    return polygonal_bracket(polys, r, start, goal)


def _radii(seed: int) -> tuple[float, ...]:
    """Two radii per map, every radius of :data:`RADII` over four seeds: one within the
    tolerance (a point robot) and one disc (tiny or ordinary)."""
    return (RADII[seed % 3], RADII[3 + seed % 4])


def _check_against_oracle(kind: str, seed: int, radii) -> None:
    rng = np.random.default_rng(1000 * len(kind) + seed)
    polys = MAKERS[kind](rng)
    for r in radii:
        oset = obstacle_set([polygon(p, f"p{k}") for k, p in enumerate(polys)], r, FRAME)
        res = shortest_path(oset, START, GOAL)
        lo, hi = oracle_length(polys, r)
        if math.isinf(lo):
            assert res.polyline is None, (kind, seed, r)
            continue
        assert res.polyline is not None, (kind, seed, r, res.info.get("reason"))
        tol = 1e-9 * max(lo, 1.0)
        assert lo - tol <= res.length <= hi + tol, (kind, seed, r, res.length, lo, hi)
        assert oset.crossings(res.polyline[None]).count[0] == 0
        assert path_is_free(res.polyline, polys, r, 1e-7)


@pytest.mark.parametrize("kind", sorted(MAKERS))
@pytest.mark.parametrize("seed", range(4))
def test_touching_pieces_against_the_union_oracle(kind: str, seed: int) -> None:
    _check_against_oracle(kind, seed, _radii(seed))


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(MAKERS))
@pytest.mark.parametrize("seed", range(4, 40))
def test_touching_pieces_against_the_union_oracle_many_maps(kind: str, seed: int) -> None:
    _check_against_oracle(kind, seed, RADII)


@pytest.mark.parametrize("r", RADII)
def test_a_wall_of_two_touching_rectangles_is_one_wall(r: float) -> None:
    """Two rectangles sharing an edge: no robot drives along or through the seam."""
    left, right = shapely.box(45, 10, 50, 90), shapely.box(50, 10, 55, 90)
    oset = obstacle_set([polygon(left, "a"), polygon(right, "b")], r, FRAME)
    through = np.array([[50.0, 5.0], [50.0, 95.0]])
    across = np.array([[40.0, 50.0], [60.0, 50.0]])
    assert oset.crossings(through[None]).count[0] == 1
    assert oset.crossings(across[None]).count[0] == 1
    assert oset.solid_name(0) == "a (one solid with 'b')"
    res = shortest_path(oset, (50.0, 5.0), (50.0, 95.0))
    lo, hi = ((math.hypot(5, 5) * 2 + 80,) * 2 if r <= EPS
              else polygonal_bracket([left, right], r, (50.0, 5.0), (50.0, 95.0)))
    assert lo * (1 - 1e-9) <= res.length <= hi * (1 + 1e-9) + 2 * math.pi * r


def test_pinch_point_is_open_for_a_point_robot_only() -> None:
    """Squares sharing one corner: a point robot (r <= eps) passes the corner, as the oracle
    agrees; a disc of radius > eps does not."""
    a, b = shapely.box(30, 30, 50, 50), shapely.box(50, 50, 70, 70)
    seg = np.array([[40.0, 60.0], [60.0, 40.0]])
    for r in (0.0, 1e-12, 1e-9):
        oset = obstacle_set([polygon(a), polygon(b)], r, FRAME)
        assert oset.crossings(seg[None]).count[0] == 0
        assert path_is_free(seg, [a, b], r, 1e-7)
    for r in (1e-6, 1e-3, 1.0):
        oset = obstacle_set([polygon(a), polygon(b)], r, FRAME)
        assert oset.crossings(seg[None]).count[0] == 1
        assert not path_is_free(seg, [a, b], r, 1e-7)


def test_a_hole_touching_its_outer_ring_at_a_point() -> None:
    """A courtyard whose diamond-shaped hole touches the outer ring at one vertex: a point
    robot leaves through the pinch point, a disc has no way out."""
    outer = shapely.box(20, 20, 80, 80)
    hole = Polygon([(50, 80), (35, 65), (50, 50), (65, 65)])
    ring = Polygon(outer.exterior.coords, [hole.exterior.coords])
    assert ring.is_valid
    inside, outside = (50.0, 66.0), (50.0, 95.0)
    for r, reachable in ((0.0, True), (0.5, False)):
        oset = obstacle_set([polygon(ring)], r, FRAME)
        res = shortest_path(oset, inside, outside)
        assert (res.polyline is not None) is reachable
        if reachable:
            assert res.length == pytest.approx(29.0, rel=1e-12)


def test_split_into_touching_pieces_or_merged_changes_nothing() -> None:
    """Metamorphic: cut every obstacle by random lines into touching pieces (and, the other
    way, merge the cells of a grid map into one polygon): the same optimum, the same
    validator verdicts and clearances on random polylines."""
    rng = np.random.default_rng(7)
    for trial in range(6):
        if trial % 2:
            whole = [shapely.unary_union(grid_cells(rng))]
            whole = [orient(g, 1.0) for g in shapely.get_parts(whole[0])]
            pieces = [p for g in whole for p in _cut(g, rng)]
        else:
            whole = [orient(g, 1.0) for g in shapely.get_parts(
                shapely.unary_union(split_walls(rng)))]
            pieces = [p for g in whole for p in _cut(g, rng)]
        paths = rng.uniform(0, 100, (40, 4, 2))
        for r in (0.0, 1e-9, 0.8):
            sa = obstacle_set([polygon(g) for g in whole], r, FRAME)
            sb = obstacle_set([polygon(g) for g in pieces], r, FRAME)
            ra, rb = shortest_path(sa, START, GOAL), shortest_path(sb, START, GOAL)
            assert (ra.polyline is None) == (rb.polyline is None)
            if ra.polyline is not None:
                assert rb.length == pytest.approx(ra.length, rel=1e-9)
            ca, cb = sa.crossings(paths), sb.crossings(paths)
            assert np.array_equal(ca.count > 0, cb.count > 0)
            # clearance down to -r (contact); deeper values are a depth bound that depends
            # on the decomposition, not a distance
            np.testing.assert_allclose(np.maximum(sb.clearance(paths), -r),
                                       np.maximum(sa.clearance(paths), -r), atol=1e-9)


def _cut(g: Polygon, rng: np.random.Generator) -> list[Polygon]:
    """``g`` cut by up to three random lines through its bounding box."""
    parts = [g]
    x0, y0, x1, y1 = g.bounds
    for _ in range(int(rng.integers(1, 4))):
        p = rng.uniform([x0, y0], [x1, y1])
        ang = rng.uniform(0, math.pi)
        d = 2 * math.hypot(x1 - x0, y1 - y0) * np.array([math.cos(ang), math.sin(ang)])
        line = shapely.LineString([p - d, p + d])
        parts = [q for part in parts for q in shapely.get_parts(split(part, line))
                 if isinstance(q, Polygon) and q.area > 0]
    return [orient(q, 1.0) for q in parts]


def _problem(polys: list[Polygon], r: float, temporary: tuple[int, ...] = ()) -> op.Problem:
    return parse_problem({
        "name": "touching", "bounds": list(BOUNDS),
        "robots": [{"id": "r", "start": list(START), "goal": list(GOAL), "radius": r,
                    "max_speed": 2.0}],
        "obstacles": [{"type": "polygon", "name": f"p{k}", "known": k not in temporary,
                       "vertices": np.asarray(p.exterior.coords)[:-1].tolist()}
                      for k, p in enumerate(polys)]})


SWARM = {"n_particles": 20, "k_max": 30}


@pytest.mark.parametrize("solver, options", [
    ("visgraph", {}), ("ipso", SWARM), ("pso-paper", SWARM), ("ipso-paper", SWARM),
    ("nlp-ipopt", {}), ("sa-apf", {"max_steps": 1500}), ("apf-paper", {"max_steps": 1500}),
])
def test_every_verdict_agrees_with_the_oracle(solver: str, options: dict) -> None:
    """Solvers on grid maps of touching cells (the bounds a wall): the validator's static
    verdict on every returned path equals the oracle's, so every success is accepted by the
    oracle; ``optimal`` equals the oracle's optimum; and some run of every solver succeeds."""
    successes = 0
    for seed in range(3):
        polys = grid_cells(np.random.default_rng(50 + seed))
        for r in (0.0, 1.0):
            res = op.solve(_problem(polys, r), solver, rng=seed, **options)
            free = path_is_free(res.paths["r"], [*polys, outside_bounds()], r, 1e-7)
            assert free == (res.metrics["static_collisions"] == 0), (solver, seed, r)
            successes += res.success
            if res.success:
                assert free
            if res.status is op.Status.optimal and (r == 0.0 or seed == 0):  # brackets cost
                lo, hi = oracle_length([*polys, outside_bounds()], r)
                assert lo * (1 - 1e-9) <= res.metrics["optimum"] <= hi * (1 + 1e-9)
    assert successes > 0


def test_a_temporary_obstacle_touching_a_known_one_closes_the_gap() -> None:
    """A door drawn as a temporary obstacle in a gap of a known wall: with it, the wall is one
    solid for the validator (no seam at either side of the door)."""
    polys = [shapely.box(48, 0, 52, 40), shapely.box(48, 40, 52, 60), shapely.box(48, 60, 52, 100)]
    prob = _problem(polys, 0.0, temporary=(1,))
    seam = np.array([[40.0, 40.0], [60.0, 40.0]])  # along the wall/door seam
    assert prob.obstacle_set(0.0, known_only=True).crossings(seam[None]).count[0] == 0
    full = prob.obstacle_set(0.0)
    assert full.crossings(seam[None]).count[0] == 1
    along = np.array([[50.0, 0.0], [50.0, 100.0]])
    assert full.crossings(along[None]).count[0] == 1  # one solid, counted once


# --------------------------------------------------------------------------------------
# the bounds are a wall
# --------------------------------------------------------------------------------------


def outside_bounds(margin: float = 50.0) -> Polygon:
    """The oracle's bounds wall: the complement of the open bounds, ``margin`` wide."""
    x0, y0, x1, y1 = BOUNDS
    return Polygon(shapely.box(x0 - margin, y0 - margin, x1 + margin, y1 + margin).exterior,
                   [shapely.box(x0, y0, x1, y1).exterior.coords])


def edge_maps(rng: np.random.Generator) -> list[Polygon]:
    """Walls drawn from an edge into the map (some split into strips), rectangles crossing an
    edge, and an obstacle leaving a corridor of random width to an edge."""
    out: list[Polygon] = []
    for _ in range(int(rng.integers(1, 4))):
        side, t = int(rng.integers(4)), rng.uniform(20, 80)
        depth, w = rng.uniform(20, 75), rng.uniform(2, 6)
        a, b = (0.0, depth) if side < 2 else (100.0 - depth, 100.0)
        cut = rng.uniform(a, b) if rng.random() < 0.5 else None
        spans = [(a, b)] if cut is None else [(a, cut), (cut, b)]
        for lo, hi in spans:
            out.append(shapely.box(t, lo, t + w, hi) if side % 2 else
                       shapely.box(lo, t, hi, t + w))
    for _ in range(int(rng.integers(0, 3))):  # crossing an edge
        c = rng.uniform(20, 80)
        out.append(shapely.box(c, -10, c + rng.uniform(3, 10), rng.uniform(3, 15))
                   if rng.random() < 0.5 else
                   shapely.box(rng.uniform(85, 97), c, 110, c + rng.uniform(3, 10)))
    gap, c = rng.uniform(0.3, 6.0), rng.uniform(25, 75)
    out.append(shapely.box(c, 100 - gap - 8, c + 8, 100 - gap))  # a corridor to the top edge
    return out


def _edge_case(seed: int) -> list[Polygon]:
    rng = np.random.default_rng(5000 + seed)
    while True:
        polys = edge_maps(rng)
        ends = shapely.MultiPoint([START, GOAL])
        if not any(p.distance(ends) < 2.5 for p in polys):
            return polys


def _oracle_in_bounds(polys: list[Polygon], r: float, start=START, goal=GOAL
                      ) -> tuple[float, float]:
    return oracle_length([*polys, outside_bounds()], r, start, goal)


@pytest.mark.parametrize("seed", range(8))
def test_the_bounds_are_a_wall_against_the_oracle(seed: int) -> None:
    """Walls touching the edge, obstacles crossing it, corridors to the edge narrower and wider
    than the robot, start and goal touching the edge (r = 2): visgraph equals the oracle,
    with the complement of the bounds as one more obstacle."""
    polys = _edge_case(seed)
    for r in (RADII[seed % 3], RADII[3 + seed % 2], 0.7, 2.0):
        oset = obstacle_set([polygon(p, f"p{k}") for k, p in enumerate(polys)], r, FRAME)
        res = shortest_path(oset, START, GOAL)
        lo, hi = _oracle_in_bounds(polys, r)
        if math.isinf(lo):
            assert res.polyline is None, (seed, r)
            continue
        assert res.polyline is not None and res.info["certified"], (seed, r, res.info)
        tol = 1e-9 * lo
        assert lo - tol <= res.length <= hi + tol, (seed, r, res.length, lo, hi)
        assert oset.crossings(res.polyline[None]).count[0] == 0
        assert path_is_free(res.polyline, [*polys, outside_bounds()], r, 1e-7)


def _edge_problem(obstacles: list[dict], r: float, start=(10.0, 50.0), goal=(90.0, 50.0)):
    return parse_problem({
        "name": "edge", "bounds": list(BOUNDS),
        "robots": [{"id": "r", "start": list(start), "goal": list(goal), "radius": r}],
        "obstacles": obstacles})


@pytest.mark.parametrize("r", (0.0, 1e-9, 1.0))
def test_a_wall_across_the_map_is_a_proof_of_infeasibility(r: float) -> None:
    """A wall from edge to edge (drawn in two touching pieces, one crossing the bounds):
    visgraph says infeasible, not failed, and a path along the edge is a collision."""
    prob = _edge_problem([{"type": "rectangle", "min": [45.0, -20.0], "max": [55.0, 40.0]},
                          {"type": "rectangle", "min": [45.0, 40.0], "max": [55.0, 100.0]}], r)
    res = op.solve(prob, "visgraph")
    assert res.status is op.Status.infeasible
    along = {"r": np.array([[10.0, 100.0], [90.0, 100.0]])}
    m = op.evaluate(prob, along)
    assert m["static_collisions"] >= 1 and not m["feasible"]


def test_the_optimum_runs_along_the_edge() -> None:
    """A wall drawn to the top edge with the way round along the bottom edge at distance
    3 - r (the analytic optimum of a disc touching the wall's corner and the edge)."""
    for r in (0.0, 1.0):
        prob = _edge_problem([{"type": "rectangle", "min": [45.0, 3.0], "max": [55.0, 100.0]}],
                             r, start=(10.0, 50.0), goal=(90.0, 50.0))
        res = op.solve(prob, "visgraph")
        assert res.status is op.Status.optimal
        lo, hi = _oracle_in_bounds([shapely.box(45, 3, 55, 100)], r, (10.0, 50.0),
                                   (90.0, 50.0))
        assert lo * (1 - 1e-9) <= res.metrics["optimum"] <= hi * (1 + 1e-9)
    # a corridor to the edge narrower than the robot closes the way
    prob = _edge_problem([{"type": "rectangle", "min": [45.0, 1.5], "max": [55.0, 100.0]}], 1.0)
    assert op.solve(prob, "visgraph").status is op.Status.infeasible


def test_a_path_closer_than_r_to_the_edge_collides_with_the_bounds() -> None:
    prob = _edge_problem([], 1.0)
    hug = {"r": np.array([[10.0, 50.0], [50.0, 99.5], [90.0, 50.0]])}
    m = op.evaluate(prob, hug)
    assert m["static_collisions"] == 2 and m["crossed"] == ["bounds"]  # both segments
    ok = {"r": np.array([[10.0, 50.0], [50.0, 99.0], [90.0, 50.0]])}  # touching: allowed
    assert op.evaluate(prob, ok)["static_collisions"] == 0
