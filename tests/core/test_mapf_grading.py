"""Grading robots with their own goals by their sum of arrivals against ``ccbs``
(optplan.mapf_grading, ``reference="team"``)."""

from __future__ import annotations

import numpy as np
import pytest

import optplan as op
from optplan.mapf_grading import applies
from optplan.problem import RoadmapGraph, parse_problem


def _swap() -> op.Problem:
    """Two robots swapping ends of a corridor with a side pocket (a roadmap): one must step
    aside and wait for the other."""
    p = parse_problem({
        "name": "pocket", "bounds": [-1, -2, 5, 1],
        "robots": [{"id": "a", "start": [0, 0], "goal": [4, 0], "radius": 0.3},
                   {"id": "b", "start": [4, 0], "goal": [0, 0], "radius": 0.3}]})
    nodes = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [2, -1.0]])
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [2, 5]])
    return p.replaced(roadmap=RoadmapGraph(nodes, edges))


def test_every_valid_plan_is_at_least_the_reference_and_the_bound():
    p = _swap()
    assert applies(p)
    graded = {s: op.solve(p, s, rng=0, reference="team").metrics for s in ("ccbs", "orca")}
    c = graded["ccbs"]
    assert c["sum_reference"] == pytest.approx(c["sum_of_arrivals"], rel=1e-9)
    assert c["sum_ratio_to_reference"] == pytest.approx(1.0, rel=1e-9)
    for m in graded.values():
        assert m["sum_lower_bound"] == pytest.approx(8.0)  # two straight runs of 4 at speed 1
        if m["sum_of_arrivals"] is not None and not m["collisions"]:
            assert m["sum_ratio_to_reference"] >= 1 - 1e-9
            assert m["sum_ratio_to_lower"] >= 1 - 1e-9


def test_a_plan_below_the_reference_replaces_it():
    """The roadmap bends where the plane does not: a valid plan that goes straight has the
    smaller sum, is the better upper bound, and is graded 1, saying so."""
    p = parse_problem({
        "name": "bend", "bounds": [-1, -1, 5, 8],
        "robots": [{"id": "a", "start": [0, 0], "goal": [4, 0], "radius": 0.3},
                   {"id": "b", "start": [0, 6], "goal": [4, 6], "radius": 0.3}]})
    nodes = np.array([[0, 0], [2, 2], [4, 0], [0, 6], [4, 6.0]])
    p = p.replaced(roadmap=RoadmapGraph(nodes, np.array([[0, 1], [1, 2], [3, 4]])))
    ref = op.solve(p, "ccbs").metrics["sum_of_arrivals"]
    assert ref == pytest.approx(4 * np.sqrt(2) + 4)  # a along the bend, b straight
    m = op.solve(p, "visgraph", reference="team").metrics  # both straight, in the plane
    assert m["sum_of_arrivals"] == pytest.approx(8.0) and m["collisions"] == 0
    assert m["sum_reference"] == m["sum_of_arrivals"] and m["sum_ratio_to_reference"] == 1.0
    assert "this plan" in m["sum_reference_source"]
    assert m["sum_ratio_to_lower"] == pytest.approx(1.0)


def test_a_formation_or_a_single_robot_is_not_graded_by_sums():
    one = parse_problem({"name": "one", "bounds": [0, 0, 5, 5],
                         "robots": [{"id": "a", "start": [1, 1], "goal": [4, 4], "radius": 0.2}]})
    assert not applies(one)
    assert "sum_of_arrivals" not in op.solve(one, "visgraph", reference="team").metrics
    assert not applies(op.load_problem("paper-formation"))
