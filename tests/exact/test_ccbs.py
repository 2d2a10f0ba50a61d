"""``ccbs``: continuous-time conflict-based search with the delta branching rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

import optplan as op
from optplan.exact.ccbs import CCBSOptions, ccbs_search
from optplan.exact.ccbs_conflicts import first_conflict, timeline_of
from optplan.exact.ccbs_roadmap import agent_models, roadmap_model
from optplan.exact.ccbs_sipp import AgentModel, Constraints, Plan, plan_agent
from optplan.geometry.timing.disc_conflict import CONTACT_REL_TOL
from optplan.problem import RoadmapGraph, parse_problem
from tests.exact.ccbs_oracle import joint_grid_optimum, sampled_separation

#: a corridor 0 - 1 - 2 - 3 - 4 along y = 0 (unit edges) with a pocket 5 above node 2
CORRIDOR = (np.array([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [2, 1]], float),
            np.array([[0, 1], [1, 2], [2, 3], [3, 4], [2, 5]]))
#: the swap's optimum: b drives into the pocket and out (6 s); a, trailing b's way up to the
#: pocket at the contact distance 0.6 (both 0.3 from node 2 at 45 degrees: 0.6 / sqrt(2) each),
#: arrives 2 x 0.6 / sqrt(2) = 0.6 sqrt(2) s late
SWAP_SUM = 6.0 + 4.0 + 0.6 * math.sqrt(2.0)
#: the plus-shaped crossing of :func:`test_three_robots_against_the_joint_grid_search`: c
#: crosses the centre first (2 s), b steps into a side arm and out (4 + 2 s), a trails it at
#: the contact distance 0.5 as in the swap (4 + 0.5 sqrt(2) s)
PLUS_SUM = 2.0 + 6.0 + 4.0 + 0.5 * math.sqrt(2.0)


def _problem(nodes, edges, robots, bounds=(-1, -1, 5, 2), movers=(), scale=1.0, shift=(0, 0),
             name="ccbs") -> op.Problem:
    """A problem on the roadmap ``(nodes, edges)``: ``robots`` are ``(id, start node, goal
    node, radius)``; coordinates and radii mapped by ``x -> scale x + shift``."""
    nodes = np.asarray(nodes, float) * scale + np.asarray(shift, float)
    x0, y0, x1, y1 = bounds
    sx, sy = shift
    p = parse_problem({
        "name": name,
        "bounds": [x0 * scale + sx, y0 * scale + sy, x1 * scale + sx, y1 * scale + sy],
        "robots": [{"id": rid, "start": nodes[s].tolist(), "goal": nodes[g].tolist(),
                    "radius": r * scale} for rid, s, g, r in robots],
        "dynamic_obstacles": list(movers)})
    return p.replaced(roadmap=RoadmapGraph(nodes, edges))


def _swap(**kw) -> op.Problem:
    return _problem(*CORRIDOR, [("a", 0, 4, 0.3), ("b", 4, 0, 0.3)], **kw)


def _check(res: op.Result, claim: op.Status = op.Status.optimal) -> None:
    """The plan is accepted by the validator and by dense sampling of the pair distances."""
    assert res.status is claim, res.message
    assert "within the roadmap model" in res.message
    m = res.metrics
    assert m["collisions"] == 0 and m["reached"]
    radii = {r.id: r.radius for r in res.scenario.robots}
    contact = 2 * max(radii.values())
    assert len(radii) < 2 or sampled_separation(res.paths, res.times) >= contact * (1 - 1e-8)
    assert m["team_lower_bound"] <= m["sum_of_arrivals"] * (1 + 1e-12)


def test_swap_on_a_corridor_with_a_pocket():
    res = op.solve(_swap(), "ccbs")
    _check(res)
    assert res.metrics["sum_of_arrivals"] == pytest.approx(SWAP_SUM, rel=1e-9)
    assert res.metrics["makespan"] == pytest.approx(6.0, rel=1e-9)
    assert res.metrics["open_lower_bound"] == pytest.approx(SWAP_SUM, rel=1e-9)
    assert res.metrics["team_lower_bound"] == pytest.approx(8.0)  # 4 + 4, each alone


@pytest.mark.parametrize("opts", [dict(cardinal=False, heuristic=False),
                                  dict(cardinal=True, heuristic=False), dict(gamma=0.2),
                                  dict(disjoint=False),
                                  dict(disjoint=False, cardinal=False, heuristic=False)])
def test_every_option_finds_the_same_optimum(opts):
    res = op.solve(_swap(), "ccbs", **opts)
    _check(res)
    assert res.metrics["sum_of_arrivals"] == pytest.approx(SWAP_SUM, rel=1e-9)


def test_makespan():
    res = op.solve(_swap(), "ccbs", objective="makespan")
    _check(res)
    assert res.metrics["makespan"] == pytest.approx(6.0, rel=1e-9)


def test_never_beaten_by_the_joint_grid_search():
    """The joint search on a 0.5 s grid is an upper bound of the continuous optimum."""
    nodes, edges = CORRIDOR
    grid = joint_grid_optimum(nodes, edges, [0, 4], [4, 0], [0.3, 0.3], 0.5, 20.0)
    res = op.solve(_swap(), "ccbs")
    assert res.metrics["sum_of_arrivals"] <= grid + 1e-9
    assert grid == pytest.approx(11.0)  # a waits a whole step: 1 s instead of 0.85 s


@pytest.mark.parametrize("disjoint", [False, True])
def test_three_robots_against_the_joint_grid_search(disjoint):
    """A plus-shaped crossing (centre 4) with robots crossing it and one heading for the
    centre: ccbs never does worse than the grid search, with or without disjoint
    splitting (the same optimum)."""
    nodes = np.array([[0, 0], [-1, 0], [1, 0], [0, -1], [0, 1], [2, 0], [-2, 0]], float)
    edges = np.array([[0, 1], [0, 2], [0, 3], [0, 4], [2, 5], [1, 6]])
    robots = [("a", 6, 5, 0.25), ("b", 5, 6, 0.25), ("c", 3, 4, 0.25)]
    p = _problem(nodes, edges, robots, bounds=(-3, -2, 3, 2))
    res = op.solve(p, "ccbs", disjoint=disjoint)
    _check(res)
    grid = joint_grid_optimum(nodes, edges, [6, 5, 3], [5, 6, 4], [0.25] * 3, 0.5, 30.0)
    assert res.metrics["sum_of_arrivals"] <= grid + 1e-9
    assert res.metrics["sum_of_arrivals"] == pytest.approx(PLUS_SUM, rel=1e-9)


def test_a_robot_holding_its_goal_makes_another_detour():
    """b sits on its goal (node 1) on a's straight way 0 -> 1 -> 2: a takes 0 -> 3 -> 2."""
    nodes = np.array([[0, 0], [1, 0], [2, 0], [1, 1]], float)
    edges = np.array([[0, 1], [1, 2], [0, 3], [2, 3]])
    p = _problem(nodes, edges, [("a", 0, 2, 0.3), ("b", 1, 1, 0.3)], bounds=(-1, -1, 3, 2))
    res = op.solve(p, "ccbs")
    _check(res)
    assert res.metrics["arrival_times"]["a"] == pytest.approx(2 * math.sqrt(2), rel=1e-9)
    assert res.metrics["arrival_times"]["b"] == 0.0


def test_relabelling_translating_and_scaling():
    """The same sum with the robots listed the other way and the map moved; space scaled by
    3 at the same speed (times scale by 3)."""
    base = op.solve(_swap(), "ccbs").metrics["sum_of_arrivals"]
    nodes, edges = CORRIDOR
    flipped = _problem(nodes, edges, [("b", 4, 0, 0.3), ("a", 0, 4, 0.3)])
    moved = _swap(shift=(1e3, -250.0))
    scaled = _swap(scale=3.0)
    for p, factor in ((flipped, 1.0), (moved, 1.0), (scaled, 3.0)):
        res = op.solve(p, "ccbs")
        _check(res)
        assert res.metrics["sum_of_arrivals"] == pytest.approx(factor * base, rel=1e-9)


def test_moving_obstacles_are_hard_constraints():
    """A disc sweeping down x = 3 at t in [1, 3] blocks a's way along the corridor: a waits for
    it to pass, and the validator (which sees the mover) accepts the plan."""
    nodes = CORRIDOR[0][:5]
    edges = CORRIDOR[1][:4]
    mover = {"type": "circle", "radius": 0.3, "waypoints": [[3, 1.5], [3, -1.5]],
             "times": [1.0, 4.0]}
    p = _problem(nodes, edges, [("a", 0, 4, 0.3)], bounds=(-1, -2, 5, 2), movers=[mover])
    res = op.solve(p, "ccbs")
    _check(res)
    assert res.metrics["dynamic_contacts"] == 0
    assert res.metrics["sum_of_arrivals"] > 4.0 + 0.1


def test_the_budget_gives_the_effort_status_and_a_lower_bound():
    res = op.solve(_swap(), "ccbs", max_expansions=1)
    assert res.status is op.Status.failed
    m = res.metrics
    assert "max_expansions" in res.message and "open-list lower bound" in res.message
    assert m["team_lower_bound"] <= m["open_lower_bound"] <= SWAP_SUM * (1 + 1e-12)
    assert m["expansions"] == 1


def test_the_roadmap_model_without_a_roadmap():
    """Two robots swap around a square obstacle in the plane (no roadmap given): the graph is
    the visibility graph of the grown corners, the plan valid, and only ``solved``: the model
    is not the problem's (the plane), and the sum is above the bound over all motions."""
    p = parse_problem({
        "name": "square", "bounds": [0, 0, 10, 10],
        "obstacles": [{"type": "rectangle", "min": [4, 4], "max": [6, 6]}],
        "robots": [{"id": "a", "start": [1, 5], "goal": [9, 5], "radius": 0.4},
                   {"id": "b", "start": [9, 5], "goal": [1, 5], "radius": 0.4}]})
    graph = roadmap_model(p)
    assert len(graph) == 2 + 4  # the two ends (each a start and a goal), four grown corners
    res = op.solve(p, "ccbs")
    _check(res, op.Status.solved)
    assert "not a certified optimum" in res.message
    assert res.metrics["sum_of_arrivals"] > res.metrics["team_lower_bound"]
    assert res.metrics["roadmap_nodes"] == 6


def test_the_pure_driver_reports_overlapping_goals():
    p = _problem(*CORRIDOR, [("a", 0, 2, 0.3), ("b", 4, 5, 0.8)])
    out = ccbs_search(p.roadmap.nodes, agent_models(p, p.roadmap, math.inf), CCBSOptions())
    assert out.status == "goals_overlap" and out.plans is None


def test_bad_options_are_named():
    with pytest.raises(ValueError, match="objective"):
        op.get_solver("ccbs", objective="mean")
    with pytest.raises(ValueError, match="gamma"):
        op.get_solver("ccbs", gamma=1.0)


def test_the_time_limit_gives_the_effort_status(monkeypatch):
    """A clock that jumps past the limit at the first progress report: the search stops at
    that poll, returns no plan and says so (no wall time measured); ``solve``'s limit makes
    it ``approximate`` (the robots at their starts), the preset's own ``failed``."""
    from optplan import solver

    state = {"now": 0.0}
    monkeypatch.setattr(solver, "clock", lambda: state["now"])

    def jump(progress):
        state["now"] = 1e9

    res = op.solve(_swap(), "ccbs", time_limit=5.0, callback=jump)
    assert res.status is op.Status.approximate and res.stop_reason == "time_limit"
    own = op.solve(_swap(), op.get_solver("ccbs", time_limit=1e-12))  # past at the first poll
    assert own.status is op.Status.failed and own.stop_reason == "time_limit"
    for r in (res, own):
        assert "without a solution" in r.message
        m = r.metrics
        assert m["team_lower_bound"] <= m["open_lower_bound"] <= SWAP_SUM * (1 + 1e-12)


def _random_plan(rng: np.random.Generator, pts: np.ndarray) -> Plan:
    """A random walk over the points ``pts`` (a complete graph) at unit speed, with random
    waits, the last node held for ever."""
    path = [int(rng.integers(len(pts)))]
    for _ in range(int(rng.integers(1, 5))):
        path.append(int(rng.choice([v for v in range(len(pts)) if v != path[-1]])))
    arrive, depart, t = [0.0], [], 0.0
    for u, v in zip(path, path[1:]):
        t += float(rng.choice([0.0, rng.uniform(0, 2)]))
        depart.append(t)
        t += float(np.hypot(*(pts[v] - pts[u])))
        arrive.append(t)
    return Plan(tuple(path), tuple(arrive), (*depart, math.inf))


@pytest.mark.parametrize("seed", range(4))
def test_first_conflict_against_dense_sampling(seed):
    """The vectorised first conflict of two random plans (moves, waits, the goal held) is the
    first sampled time the discs overlap, on one of the conflict's actions, one a move."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 4, (6, 2))
    checked = 0
    for _ in range(25):
        plans = [_random_plan(rng, pts), _random_plan(rng, pts)]
        c = first_conflict(0, 1, timeline_of(pts, plans[0]), timeline_of(pts, plans[1]), 1.0)
        ts = np.linspace(0.0, 30.0, 60001)
        pos = [np.c_[np.interp(ts, *_stamps(p, pts, 0)), np.interp(ts, *_stamps(p, pts, 1))]
               for p in plans]
        inside = np.hypot(*(pos[0] - pos[1]).T) < 1.0
        if not inside.any():
            assert c is None or c.act_i.t0 > 30.0 or c.act_j.t0 > 30.0
            continue
        first = ts[np.argmax(inside)]
        assert c is not None and c.time == pytest.approx(first, abs=ts[1] - ts[0])
        assert c.act_i.is_move or c.act_j.is_move or c.time == 0.0
        for a in (c.act_i, c.act_j):
            assert a.t0 <= c.time <= a.t1
        checked += 1
    assert checked >= 5


def _stamps(plan: Plan, pts: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """The stamps and one coordinate of ``plan``'s polyline (the hold's end far away)."""
    ts, xs = [], []
    for k, v in enumerate(plan.nodes):
        ts.append(plan.arrive[k])
        ts.append(plan.depart[k] if math.isfinite(plan.depart[k]) else 1e3)
        xs += [pts[v][axis]] * 2
    return np.array(ts), np.array(xs)


def _corridor_robot() -> AgentModel:
    """One robot (radius 0.3, speed 1) on :data:`CORRIDOR` from node 0 to node 4."""
    nodes, edges = CORRIDOR
    nbrs: list[list[tuple[int, float]]] = [[] for _ in nodes]
    for a, b in edges:
        length = float(np.hypot(*(nodes[b] - nodes[a])))
        nbrs[a].append((int(b), length))
        nbrs[b].append((int(a), length))
    return AgentModel(nodes, nbrs, 0, 4, 0.3, 1.0)


@pytest.mark.parametrize(("windows", "arrival"), [
    ([], 4.0),
    ([(2, 5, 0.0, 10.0)], 6.0),  # into the pocket on the way: 2 s more
    ([(2, 5, 5.0, 10.0)], 9.0),  # at node 2 at t = 2, waits to 5, pocket and back: 7, then 2 s
    ([(5, 2, 0.0, 3.5)], 6.0),  # in the pocket at 3, out at once
    ([(5, 2, 0.0, 2.5)], None),  # the pocket is 3 s away
    # 1 -> 2 at 1 (its window opens at 1), back 2 -> 1 at 2, 1 -> 2 again at 3: 6 s; the
    # departures meet the windows in the other order than their openings
    ([(2, 1, 0.0, 5.0), (1, 2, 1.0, 5.0)], 6.0),
])
def test_the_low_level_meets_positive_constraints(windows, arrival):
    """Disjoint splitting's positive constraints in the low level: every required departure
    is in the plan, at the least arrival (hand-derived)."""
    cons = Constraints()
    for w in windows:
        cons.add_positive(*w)
    plan = plan_agent(_corridor_robot(), cons)
    if arrival is None:
        assert plan is None
        return
    assert plan is not None and plan.cost == pytest.approx(arrival, rel=1e-12)
    for u, v, lo, hi in windows:
        assert any(a == u and b == v and lo <= t < hi for a, b, t in
                   zip(plan.nodes, plan.nodes[1:], plan.depart))


#: a straight line of unit edges 0 - 1 - 2 - 3 along y = 0 (speed 1: one second an edge)
LINE = np.array([[0, 0], [1, 0], [2, 0], [3, 0]], float)


def test_a_move_into_a_waiting_robots_node_passes_it_until_it_can_be_away():
    """i drives 0 -> 1 over [0, 1] while j waits at node 1 over [0, 5] (contact 0.6).  The
    move alone passes node 1 over (0.4, 1); every plan making the move is still within 0.6
    of node 1 until 1.6, whatever it does next: the pass is (0.4, 1.6), delta = 0.6."""
    from optplan.exact.ccbs_conflicts import Action, Conflict, branch
    c = Conflict(0, 1, Action(0, 1, 0.0, 1.0), Action(1, 1, 0.0, 5.0), 0.4)
    (ki, ui, vi, lo_i, hi_i), (kj, uj, _, lo_j, hi_j) = branch(LINE, c, 0.6, 0.5)
    r = 0.6 * (1 - CONTACT_REL_TOL)  # the branching distance
    assert (ki, ui, vi, lo_i) == ("edge", 0, 1, 0.0)
    assert hi_i == pytest.approx(0.5 * 2 * r, rel=1e-12)  # gamma of the pass (1 - r, 1 + r)
    assert (kj, uj) == ("vertex", 1)
    assert (lo_j, hi_j) == (pytest.approx(1 - r + 0.5 * 2 * r, rel=1e-12),
                            pytest.approx(1 + r, rel=1e-12))


def test_a_move_against_a_goal_hold_is_branched_once():
    """j holds its goal (node 1) from 0.0 for ever: i never departs 0 -> 1 from 0 on, or j
    finally arrives once every plan of i's move can be away from node 1 (1 + r)."""
    from optplan.exact.ccbs_conflicts import Action, Conflict, branch
    c = Conflict(0, 1, Action(0, 1, 0.0, 1.0), Action(1, 1, 0.0, math.inf), 0.4)
    ci, cj = branch(LINE, c, 0.6, 0.5)
    r = 0.6 * (1 - CONTACT_REL_TOL)
    assert ci == ("edge", 0, 1, 0.0, math.inf)
    assert cj[:3] == ("hold", 1, 1) and cj[3] == pytest.approx(1 + r, rel=1e-12)


def test_a_move_from_the_node_another_robot_reaches_waits_until_it_can_be_away():
    """i drives 0 -> 1 over [0, 1]; j departs 1 -> 2 at 0.5.  The moves alone: i is unsafe
    until 0.1 (the gap 0.5 + s below 0.6), j from 0.4 until i's arrival at 1; j, still at
    node 1 before it departs, and i, no farther than t - 1 from node 1 after arriving,
    touch for every departure of j before 1 + 0.6."""
    from optplan.exact.ccbs_conflicts import Action, Conflict, branch
    c = Conflict(0, 1, Action(0, 1, 0.0, 1.0), Action(1, 2, 0.5, 1.5), 0.5)
    ci, cj = branch(LINE, c, 0.6, 0.5)
    r = 0.6 * (1 - CONTACT_REL_TOL)
    assert ci[:4] == ("edge", 0, 1, 0.0) and ci[4] == pytest.approx(r - 0.5, abs=1e-9)
    assert cj[:4] == ("edge", 1, 2, 0.5) and cj[4] == pytest.approx(1 + r, rel=1e-12)


@pytest.mark.parametrize(("start", "goal", "hold", "arrival", "nodes"), [
    (0, 3, 0.0, 3.0, (0, 1, 2, 3)),
    (0, 3, 5.0, 5.0, (0, 1, 2, 3)),  # waits before the last edge: arrives at 5
    (2, 2, 3.0, 3.0, (2, 1, 2)),  # at its goal from the start: leaves and comes back
])
def test_the_low_level_meets_the_hold_constraint(start, goal, hold, arrival, nodes):
    """The final arrival at the goal is at ``hold_from`` or later (hand-derived)."""
    nbrs: list[list[tuple[int, float]]] = [[] for _ in LINE]
    for a in range(3):
        nbrs[a].append((a + 1, 1.0))
        nbrs[a + 1].append((a, 1.0))
    cons = Constraints()
    cons.add_hold(hold)
    plan = plan_agent(AgentModel(LINE, nbrs, start, goal, 0.3, 1.0), cons)
    assert plan is not None and plan.cost == pytest.approx(arrival, rel=1e-12)
    assert plan.nodes[0] == start and plan.nodes[-1] == goal
    assert plan.nodes in (nodes, (2, 3, 2))  # the goal left on either side


@pytest.mark.parametrize("seed", range(8))
def test_rotations_on_a_lattice_never_beaten_and_the_same_under_every_option(seed):
    """Three robots on random nodes of a 3 x 3 lattice of unit edges (one edge removed at
    random) each drive to the next one's start: ``ccbs`` (one branching against a goal hold,
    extended passes, the authors' conflict order) is never beaten by the joint search on a
    0.5 s grid, and the plain search (earliest conflict, no heuristic, no disjoint splitting,
    another gamma) finds the same sum."""
    rng = np.random.default_rng(seed)
    nodes = np.array([[x, y] for y in range(3) for x in range(3)], float)
    edges = [(a, b) for a in range(9) for b in range(a + 1, 9)
             if np.hypot(*(nodes[a] - nodes[b])) == 1.0]
    edges.pop(int(rng.integers(len(edges))))
    starts = [int(v) for v in rng.choice(9, 3, replace=False)]
    goals = [starts[(k + 1) % 3] for k in range(3)]
    p = _problem(nodes, np.array(edges), [(name, s, g, 0.3) for name, s, g in
                                          zip("abc", starts, goals)], bounds=(-1, -1, 3, 3))
    res = op.solve(p, "ccbs")
    _check(res)
    total = res.metrics["sum_of_arrivals"]
    grid = joint_grid_optimum(nodes, np.array(edges), starts, goals, [0.3] * 3, 0.5, 30.0)
    assert total <= grid + 1e-9
    plain = op.solve(p, "ccbs", cardinal=False, heuristic=False, disjoint=False, gamma=0.3)
    assert plain.metrics["sum_of_arrivals"] == pytest.approx(total, rel=1e-9)
