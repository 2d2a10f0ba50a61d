"""Grading a team plan against the team optimum (``op.solve(..., reference="team")``)."""

from __future__ import annotations

import pytest

import optplan as op
from tests.formation.test_formation_nlp import L, _team
from tests.geometry.time_scenes import time_scene


def test_a_team_plan_is_graded_against_the_nlp_warm_started_from_it():
    p = _team(obstacles=[{"type": "circle", "center": [50, 50], "radius": 4.0}])
    res = op.solve(p, "leader-follower-paper", rng=0, reference="team")
    m = res.metrics
    assert m["team_reference_status"] == "solved"
    # the reference starts from the plan and never ends worse than it
    assert m["arrival_ratio_to_team"] >= 1 - 1e-6
    assert m["formation_rmse"] >= m["team_formation_rmse_reference"] - 1e-3 * L
    assert m["separation_ratio_to_team"] == pytest.approx(
        m["min_separation"] / m["team_min_separation_reference"])


def test_no_formation_no_team_reference():
    m = op.solve(time_scene([]), "visgraph", reference="team").metrics
    assert m["team_reference_status"] == "no formation"
    assert "arrival_ratio_to_team" not in m


def test_reference_must_be_a_known_mode():
    with pytest.raises(ValueError, match="reference must be True, False or 'team'"):
        op.solve(time_scene([]), "visgraph", reference="teams")
