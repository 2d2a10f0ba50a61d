"""The exact arc test of the tangent graph (``optplan.geometry.tangent.circles.ArcChecker``)
and the crowded-circles guard of ``graph = "auto"``.

``ArcChecker`` tests an arc only against the boundary edges and circles its k-d trees find
near the arc; the oracle tests every arc against every edge of every convex piece (the
internal diagonals too) and every circle obstacle, with the same closed-form distances: on
arcs that start at a free point (as every arc the searches test does), the verdicts must be
equal, arc for arc, on catalogue maps, on a circle-obstacle map and on a polygon of 2,000
vertices round a small circle (crowded circles).

The sight lines' budget: past it the expansion raises ``OverBudget``; within it the
candidates are those of an unbounded run.  ``graph = "auto"`` on a map whose build would run
past its budget searches lazily (``graph.crowded``) and answers what ``"lazy"`` and
``"built"`` answer.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.geometry.tangent import circles as circ
from optplan.geometry.tangent import tangent_graph as tg
from optplan.geometry.tangent.sightlines import OverBudget
from optplan.problem import parse_problem, shared


def _crowded(n: int) -> op.Problem:
    """A 100 x 100 field, a robot of radius 2 and a polygon of ``n`` vertices round a circle
    of radius 6 beside its straight path (and a box across it)."""
    ring = [[50 + 6 * math.cos(2 * math.pi * k / n), 30 + 6 * math.sin(2 * math.pi * k / n)]
            for k in range(n)]
    return parse_problem({
        "name": f"crowded-{n}", "bounds": [0, 0, 100, 100],
        "robots": [{"id": "r", "start": [10, 20], "goal": [90, 40], "radius": 2.0}],
        "obstacles": [{"type": "polygon", "name": "ring", "vertices": ring},
                      {"type": "polygon", "name": "box",
                       "vertices": [[70, 20], [75, 20], [75, 45], [70, 45]]},
                      {"type": "circle", "name": "c", "center": [25, 50], "radius": 4.0}],
    })


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
        d = circ._arc_seg_dist(C.center[i], C.rho[i], start, sweep[k], P, E)
        dc = circ._point_arc_dist(cc, C.center[i], C.rho[i], start, sweep[k]) - cr
        out[k] = not ((d < lim).any() or (dc < lim).any())
    return out


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


@pytest.mark.parametrize("name", ["paper-env2", "paper-warehouse", "warehouse-grid",
                                  "paper-apf-env2", "crowded-2000"])
def test_arc_verdicts_equal_the_all_items_oracle(name):
    p = _crowded(2000) if name == "crowded-2000" else op.load_problem(name)
    r = p.planned_robots[0]
    graph = tg.TangentGraph(p.obstacle_set(r.radius, known_only=True))
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


def test_the_sightline_budget():
    p = _crowded(1200)
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
        p = _crowded(1500)
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
