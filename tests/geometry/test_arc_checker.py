"""The exact arc test of the tangent graph (``optplan.geometry.tangent.circles.ArcChecker``,
the compiled ``optplan.geometry.collision.arc_kernel``) and the crowded-circles guard of
``graph = "auto"``.

The kernel tests an arc only against the boundary edges and circles near the arc (screened by
their distance to the arc's midpoint, listed by the arc test's own grid on large maps).  Two
independent oracles:

* a numpy transcription of the closed forms (below), testing every arc against every edge of
  every convex piece (the internal diagonals too) and every circle obstacle: on arcs that
  start at a free point (as every arc the searches test does) the verdicts must be equal, arc
  for arc, on catalogue maps, on a circle-obstacle map and on a polygon of 2,000 vertices
  round a small circle (crowded circles);
* shapely: the arc sampled densely, its distance to the obstacle region (circles as polygons
  of 1,024 sides): every verdict the sampling decides (the distance farther than ``1e-4`` from
  ``r - eps``) must be the kernel's.

The sight lines' budget: past it the expansion raises ``OverBudget``; within it the
candidates are those of an unbounded run.  ``graph = "auto"`` on a map whose build would run
past its budget searches lazily (``graph.crowded``) and answers what ``"lazy"`` and
``"built"`` answer.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

import optplan as op
from benchmarks.bench_crowded import crowded
from optplan.geometry.collision import arc_kernel
from optplan.geometry.collision.arc_kernel import arcs_free
from optplan.geometry.tangent import circles as circ
from optplan.geometry.tangent import tangent_graph as tg
from optplan.geometry.tangent.sightlines import OverBudget
from optplan.problem import parse_problem, shared


def _in_arc(phi, start, sweep):
    return np.mod(phi - start, 2 * math.pi) <= sweep + 1e-9


def _point_arc_dist(q, c, rho, start, sweep):
    """Distance from points ``q`` to CCW arcs (complex, broadcast)."""
    v = q - c
    p0, p1 = c + rho * np.exp(1j * start), c + rho * np.exp(1j * (start + sweep))
    return np.where(_in_arc(np.angle(v), start, sweep), np.abs(np.abs(v) - rho),
                    np.minimum(np.abs(q - p0), np.abs(q - p1)))


def _point_seg_dist(q, P, E):
    t = np.clip(((q - P) * E.conj()).real / np.maximum(np.abs(E) ** 2, 1e-300), 0.0, 1.0)
    return np.abs(q - (P + t * E))


def _arc_seg_dist(c, rho, start, sweep, P, E):
    """Distance between CCW arcs and segments ``P -> P + E``: the arc's and the segment's
    ends, the arc points whose radius is normal to the segment, the crossings."""
    p0, p1 = c + rho * np.exp(1j * start), c + rho * np.exp(1j * (start + sweep))
    d = np.minimum.reduce([_point_seg_dist(p0, P, E), _point_seg_dist(p1, P, E),
                           _point_arc_dist(P, c, rho, start, sweep),
                           _point_arc_dist(P + E, c, rho, start, sweep)])
    L = np.abs(E)
    u = E / np.maximum(L, 1e-300)
    for sgn in (1.0, -1.0):
        x = c + sgn * rho * 1j * u
        t = ((x - P) * u.conj()).real
        ok = (t >= 0) & (t <= L) & _in_arc(np.angle(sgn * 1j * u), start, sweep)
        d = np.where(ok, np.minimum(d, np.abs(((x - P) * u.conj()).imag)), d)
    w = P - c
    b = (w * u.conj()).real
    h2 = b * b - (np.abs(w) ** 2 - rho * rho)
    for t in (-b - np.sqrt(np.maximum(h2, 0)), -b + np.sqrt(np.maximum(h2, 0))):
        ok = (h2 >= 0) & (t >= 0) & (t <= L) & _in_arc(np.angle(P + t * u - c), start, sweep)
        d = np.where(ok, 0.0, d)
    return d


def _brute(arcs: circ.ArcChecker, idx, th, sweep, sense) -> np.ndarray:
    """Every arc against every piece edge (diagonals too) and every circle obstacle."""
    S, C = arcs.oset, arcs.circles
    P, E = S.table[0].ravel(), S.table[1].ravel()
    cc, cr = S.item_center[S.n_pieces:], S.circle_radius
    lim = S.radius - S.eps
    out = np.ones(len(idx), bool)
    for k in range(len(idx)):
        i = idx[k]
        if C.rho[i] == 0:
            continue
        start = th[k] if sense[k] > 0 else th[k] - sweep[k]
        d = _arc_seg_dist(C.center[i], C.rho[i], start, sweep[k], P, E)
        dc = _point_arc_dist(cc, C.center[i], C.rho[i], start, sweep[k]) - cr
        out[k] = not ((d < lim).any() or (dc < lim).any())
    return out


def _random_arcs_against_shapely(S, rng: np.random.Generator, m: int):
    """``m`` random arcs (local frame) that start at a free point, the kernel's verdicts and
    the distance from each arc (sampled every 1e-3 rad) to the obstacle region (circles as
    polygons of 1,024 sides) by shapely."""
    shapes = [g if not isinstance(g, tuple) else
              shapely.Point(g[0], g[1]).buffer(g[2], quad_segs=256) for _, g in S.shapes]
    region = shapely.union_all(shapes)
    x0, y0, x1, y1 = S.frame.local_bounds
    c = rng.uniform(x0, x1, 4 * m) + 1j * rng.uniform(y0, y1, 4 * m)
    rho = rng.uniform(0.05, 0.3, 4 * m) * max(x1 - x0, y1 - y0)
    start = rng.uniform(-math.pi, math.pi, 4 * m)
    sweep = np.where(rng.random(4 * m) < 0.3, rng.uniform(0, 0.2, 4 * m),
                     rng.uniform(0, 2 * math.pi, 4 * m))
    p0 = c + rho * np.exp(1j * start)
    free = shapely.distance(shapely.points(p0.real, p0.imag), region) >= S.radius
    c, rho, start, sweep = c[free][:m], rho[free][:m], start[free][:m], sweep[free][:m]
    d = np.empty(len(c))
    for k in range(len(c)):
        a = start[k] + np.linspace(0.0, sweep[k], max(2, int(sweep[k] / 1e-3) + 2))
        z = c[k] + rho[k] * np.exp(1j * a)
        d[k] = shapely.LineString(np.stack([z.real, z.imag], 1)).distance(region)
    return arcs_free(S, c, rho, start, sweep), d


def _free_start_arcs(graph: tg.TangentGraph, rng: np.random.Generator, m: int):
    """``m`` random arcs (circle, start angle, sweep, sense) whose start points are free."""
    C, S = graph.circles, graph.oset
    idx = rng.integers(0, C.n, 4 * m)
    # in the circle's normal cone (where a path touches it) or anywhere
    th = np.where(rng.random(4 * m) < 0.7, C.lo[idx] + C.width[idx] * rng.random(4 * m),
                  rng.uniform(-math.pi, math.pi, 4 * m))
    p = C.center[idx] + C.rho[idx] * np.exp(1j * th)
    ok = S.frame.world(np.stack([p.real, p.imag], 1))
    free = np.array([S.segment_free(q[None], q[None])[0] for q in ok])
    idx, th = idx[free][:m], th[free][:m]
    # short and long sweeps: a few degrees to more than a half turn
    sweep = np.where(rng.random(len(idx)) < 0.5, rng.uniform(0, 0.2, len(idx)),
                     rng.uniform(0, 4.0, len(idx)))
    sense = rng.choice([-1, 1], len(idx))
    return idx, th, sweep, sense


@pytest.mark.parametrize("grid", [False, True])
@pytest.mark.parametrize("name", ["paper-env2", "paper-warehouse", "warehouse-grid",
                                  "paper-apf-env2", "crowded-2000"])
def test_arc_verdicts_equal_the_all_items_oracle(name, grid, monkeypatch):
    p = crowded(2000) if name == "crowded-2000" else op.load_problem(name)
    r = p.planned_robots[0]
    S = p.obstacle_set(r.radius, known_only=True)
    # both screens: every entry against every arc, and the arc test's own grid
    monkeypatch.setattr(arc_kernel, "ARC_GRID_FROM", 0 if grid else 10**9)
    S._cache.pop("arc_grid", None)
    assert arc_kernel.arc_grid(S)[0] == grid
    graph = tg.TangentGraph(S)
    idx, th, sweep, sense = _free_start_arcs(graph, np.random.default_rng(3), 400)
    assert len(idx) >= 100
    got = graph.arcs.free_many(idx, th, sweep, sense)
    want = _brute(graph.arcs, idx, th, sweep, sense)
    np.testing.assert_array_equal(got, want)
    assert 0 < got.sum() < len(got)  # both verdicts occur
    # one arc at a time (the lazy search's calls): the same verdicts
    one = [graph.arcs.free(int(i), [t], [s], int(g))[0]
           for i, t, s, g in zip(idx[:50], th[:50], sweep[:50], sense[:50])]
    np.testing.assert_array_equal(one, got[:50])


@pytest.mark.parametrize("name", ["paper-env2", "warehouse-grid", "crowded-2000"])
def test_arc_verdicts_agree_with_shapely(name):
    p = crowded(2000) if name == "crowded-2000" else op.load_problem(name)
    S = p.obstacle_set(p.planned_robots[0].radius, known_only=True)
    got, d = _random_arcs_against_shapely(S, np.random.default_rng(5), 300)
    lim = S.radius - S.eps
    sure = np.abs(d - lim) > 1e-4 * max(1.0, S.radius)
    assert sure.sum() >= 0.95 * len(d) >= 0.95 * 300
    np.testing.assert_array_equal(got[sure], d[sure] >= lim)
    assert 0.1 * sure.sum() < got[sure].sum() < 0.9 * sure.sum()  # both verdicts occur


def test_an_arc_through_a_gap_and_its_mutation():
    """Analytic: a robot of radius 1 rounds a point obstacle's circle; a square whose edge
    lies 0.5 beyond the arc blocks it, one 1.5 beyond does not; an arc that ends before the
    square is free."""
    for gap, free in ((0.5, False), (1.5, True)):
        p = parse_problem({
            "name": "gap", "bounds": [-20, -20, 20, 20],
            "robots": [{"id": "r", "start": [-10, 0], "goal": [10, 0], "radius": 1.0}],
            "obstacles": [{"type": "circle", "name": "c", "center": [0, 0], "radius": 2.0},
                          {"type": "polygon", "name": "sq", "vertices": [
                              [-1, 3 + gap], [1, 3 + gap], [1, 6], [-1, 6]]}]})
        graph = tg.TangentGraph(p.obstacle_set(1.0, known_only=True))
        C = graph.circles
        i = int(np.flatnonzero(C.full)[0])  # the circle obstacle's circle: radius 3
        assert C.rho[i] == pytest.approx(3.0)
        # a quarter turn through the top (angle pi / 2), and one that stops at pi / 4
        over = graph.arcs.free(i, [math.pi / 4], [math.pi / 2], 1)[0]
        short = graph.arcs.free(i, [-math.pi / 4], [math.pi / 4], 1)[0]
        assert over == free
        assert short


def test_the_sightline_budget():
    p = crowded(1200)
    graph = tg.TangentGraph(p.obstacle_set(2.0, known_only=True), sightlines=True)
    sight = graph.sightlines
    src = np.stack([graph.circles.center.real, graph.circles.center.imag], 1)[:300]
    counts, flat = sight.candidates_flat(src, 0.0, 4 * math.pi)
    views = sight.views
    assert views > 300
    again = sight.candidates_flat(src, 0.0, 4 * math.pi, budget=views)  # just enough
    np.testing.assert_array_equal(again[0], counts)
    np.testing.assert_array_equal(again[1], flat)
    with pytest.raises(OverBudget):
        sight.candidates_flat(src, 0.0, 4 * math.pi, budget=views // 2)


def test_auto_searches_crowded_maps_lazily(monkeypatch):
    """A map whose build would run past its sight-line budget is searched lazily by
    ``auto``, with the answer of ``lazy`` and ``built``; with a budget it fits, ``auto``
    builds it."""
    answers = {}
    for graph, base in (("auto", 0), ("lazy", 0), ("built", 0), ("auto-fits", None)):
        shared.clear()
        monkeypatch.setattr(tg, "VIEWS_BASE", 10**12 if base is None else base)
        monkeypatch.setattr(tg, "VIEWS_PER_CIRCLE", 100)
        p = crowded(1500)
        res = op.solve(p, "visgraph", graph=graph.split("-")[0])
        g = tg.tangent_graph(p.obstacle_set(2.0, known_only=True))
        assert g.circles.n >= tg.SIGHTLINES_MIN
        if graph == "auto":
            assert g.crowded and g.chains is None
        if graph in ("built", "auto-fits"):
            assert not g.crowded and g.chains is not None
        assert res.status == op.Status.optimal
        answers[graph] = (res.metrics["lengths_exact"]["r"], res.paths["r"].tobytes())
    assert len(set(answers.values())) == 1
