"""Formation backends: declared options, scale invariance, the warehouse-team scene.

The same scene drawn 100 x smaller or larger (:func:`optplan.problem.transform_problem`) must
give the same status and path lengths that scale within 1 % for both formation presets, on the
paper's formation scene, the open field and the metre-scale warehouse team.
"""

from __future__ import annotations

import dataclasses
from functools import cache

import pytest
import shapely

import optplan as op
from optplan.cli import main as cli_main
from optplan.formation.formation_qp import FormationQP
from optplan.formation.leader_follower import LeaderFollower
from optplan.formation.pilot import PilotedFormation
from optplan.options import describe_options, option_spec
from optplan.problem import transform_problem

PRESETS = ("leader-follower-paper", "formation-qp")
SCENES = ("paper-formation", "formation-open-field", "warehouse-team")
SCALES = (0.01, 100.0)

#: options that are lengths in map units (each must be declared scale=True)
LENGTHS = {"rho_0", "rho_0_f", "ref_spacing", "lookahead", "d_0", "rho_f", "sep_margin",
           "clear_margin", "margin", "neighbor_radius", "sensing_range"}


# ---------------------------------------------------------------- declared options ------


@pytest.mark.parametrize("cls", [LeaderFollower, FormationQP])
def test_every_option_is_declared_and_documented(cls):
    rows = describe_options(cls)
    assert rows, cls
    for r in rows:
        assert r["allowed"] != "(undeclared)", r["name"]
        assert r["meaning"], f"{cls.name}: option {r['name']!r} has no meaning in the docstring"
    scaled = {f.name for f in dataclasses.fields(cls)
              if option_spec(f) is not None and option_spec(f).scale}
    assert scaled == LENGTHS & {r["name"] for r in rows}
    for r in rows:  # the docstring says so too
        assert ("x length_scale" in r["meaning"]) == (r["name"] in scaled), r["name"]


def test_no_contract_classvars_and_no_per_field_validation():
    for cls in (PilotedFormation, LeaderFollower, FormationQP):
        assert "contract_problem" not in vars(cls) and "contract_overrides" not in vars(cls)
        assert "__post_init__" not in vars(cls)  # Backend.__post_init__: options, then check()


def test_show_solver_prints_every_option_with_range_and_meaning(capsys):
    assert cli_main(["show-solver", "formation-qp"]) == 0
    text = capsys.readouterr().out
    for r in describe_options(FormationQP):
        assert f"  {r['name']} " in text
    assert "a number in (0, inf) (x length_scale)" in text  # neighbor_radius
    assert "an integer in [0, 64]" in text  # max_obstacles
    assert "Extra obstacle clearance kept by the obstacle rows" in text  # margin's meaning


@pytest.mark.parametrize("kw, match", [
    ({"margin": -1.0}, r"option 'margin' of backend 'formation-qp' must be a number in \[0, "),
    ({"neighbor_radius": 0.0}, r"option 'neighbor_radius' .* \(0, inf\) \(x length_scale\)"),
    ({"max_obstacles": 65}, r"option 'max_obstacles' .* an integer in \[0, 64\]"),
    ({"tol": 1.0}, r"option 'tol' .* \[1e-12, 0.01\]"),
    ({"leader_in_qp": 1}, r"option 'leader_in_qp' .* true or false"),
    ({"gamma": 3.0}, r"options 'gamma' \* 'dt' of backend 'formation-qp' must be <= 1"),
    ({"v_factor": 0.0}, r"option 'v_factor' .* \(0, 1\]"),
    ({"max_steps": 0}, r"option 'max_steps' .* an integer in \[1, 1e\+07\]"),
])
def test_formation_qp_option_errors(kw, match):
    with pytest.raises(ValueError, match=match):
        op.get_solver("formation-qp", **kw)


@pytest.mark.parametrize("kw, match", [
    ({"sep_margin": float("inf")}, r"option 'sep_margin' .* \[0, inf\) \(x length_scale\)"),
    ({"speed_sides": 5}, r"option 'speed_sides' .* an integer in \[6, 256\]"),
    ({"trail_far": 0.2}, r"option 'trail_far' .* \[0.5, inf\)"),
    ({"k_f": 3.0}, r"options 'k_f' \* 'dt' of backend 'leader-follower' must be <= 1"),
    ({"A": 0}, r"option 'A' .* \(0, inf\)"),
])
def test_leader_follower_option_errors(kw, match):
    with pytest.raises(ValueError, match=match):
        op.get_solver("leader-follower-paper", **kw)


# ---------------------------------------------------------------- scale invariance ------


@cache
def outcome(scene: str, solver: str, scale: float) -> tuple[str, float, float]:
    """``(status, total path length / scale, formation RMSE / scale)``."""
    prob = transform_problem(op.load_problem(scene), scale)
    r = op.solve(prob, solver, rng=0)
    total = sum(float(v) for v in r.metrics["lengths"].values())
    return r.status.value, total / scale, float(r.metrics["formation_rmse"]) / scale


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("solver", PRESETS)
def test_scale_invariance(scene, solver):
    st1, len1, rmse1 = outcome(scene, solver, 1.0)
    assert st1 == "solved", (scene, solver, st1)
    for k in SCALES:
        st, length, rmse = outcome(scene, solver, k)
        assert st == st1, f"{solver} on {scene} x {k:g}: {st!r}, at scale 1 {st1!r}"
        assert length == pytest.approx(len1, rel=0.01), (scene, solver, k)
        assert rmse == pytest.approx(rmse1, rel=0.02, abs=1e-3 * len1 / 100), (scene, solver, k)


# ---------------------------------------------------------------- warehouse team --------


def test_warehouse_team_scene():
    prob = op.load_problem("warehouse-team")
    assert "metres" in prob.tags and prob.length_scale == 0.1
    assert prob.bounds == (-20.0, -15.0, 20.0, 15.0)
    assert [d.name for d in prob.dynamic_obstacles] == ["forklift"]
    assert len(prob.formation.followers) == 2 and prob.formation.safety_distance == 0.75
    grid = op.load_problem("warehouse-grid")  # the same imported map
    assert len(prob.obstacles) == len(grid.obstacles)
    assert all(a.geometry.equals_exact(b.geometry, 0.0)
               for a, b in zip(prob.obstacles, grid.obstacles, strict=True))


@pytest.mark.parametrize("solver", PRESETS)
def test_warehouse_team_solved_safely(solver):
    prob = op.load_problem("warehouse-team")
    res = op.solve(prob, solver, rng=0)
    m = res.metrics
    assert res.status.value == "solved", res.message
    assert m["collisions"] == 0 and m["reached"]
    assert m["min_separation"] >= prob.formation.safety_distance
    assert m["min_clearance"] > 0 and m["min_clearance_dynamic"] > 0
    # the forklift crossed the team's lane: within the sensing range of the team at some step
    fork = prob.dynamic_obstacles[0]
    lead = res.paths["leader"]
    gaps = [fork.geometry_at(t).distance(shapely.Point(*p))
            for t, p in zip(res.times, lead)]
    assert min(gaps) < prob.sensing_range
    if solver == "formation-qp":
        assert res.extras["qp_failures"] == 0 and res.extras["slack_steps"] == 0
