"""Paper-fidelity checks of the hybrid planner (docs/solvers/hybrid.md, "Fidelity notes").

``python -m optplan.experiments.hybrid_fidelity [--seeds 5] [--ipso-seeds 30] [--skip ...]``

Prints four markdown tables:

1. **Leader influence distance** (option ``leader_rho_0`` of ``hybrid``): ``hybrid-paper``
   with the leader's SA-APF at the preset's 20 (eq 34, ``sa-apf-paper``) and at the paper's
   formation-pilot value 100 (eq 41), on ``paper-warehouse``, ``paper-formation`` and
   ``paper-hybrid`` (``--seeds`` seeds; medians).
2. **Sub-goal switching in sight** (option ``reach_visible`` of ``hybrid``, beyond the paper):
   ``hybrid-paper`` with it off (the preset) and on, on the paper's scenes and the metre-scale
   ones (``--seeds`` seeds).
3. **Literal IPSO on the known maps**: ``ipso-paper`` on ``problem.known_view()`` of
   ``paper-hybrid`` and ``paper-warehouse`` (``--ipso-seeds`` seeds): how many of its paths
   are collision-free on the map it plans on.
4. **Eq 52 near an obstacle** (rho < 1/20): one follower of a leader-follower pair next to a
   wall on its outer or inner side at clearance rho; the desired angle ratio phi_d / Phi the
   code uses (rho clamped at 1/c), the literal eq 52 value, and the component of the
   follower's command toward the wall (negative: away from it), with the ``safety`` layer on
   (the ``leader-follower-paper`` preset) and off.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeVar

import numpy as np

import optplan as op
from optplan.experiments import option_groups, option_sweep, sections_main

__all__ = ["reach_visible_rows", "format_reach_visible", "leader_rho_0_rows",
           "format_leader_rho_0", "ipso_paper_known_rows",
           "format_ipso_paper_known", "eq52_scene", "eq52_probe", "eq52_rows", "format_eq52",
           "main"]

RHO_SCENES = ("paper-warehouse", "paper-formation", "paper-hybrid")
RHO_VALUES = (None, 100.0)  # None: the local planner's own rho_0 (sa-apf-paper: 20)
IPSO_SCENES = ("paper-hybrid", "paper-warehouse")
VISIBLE_SCENES = ("paper-env1", "paper-env2", "paper-hybrid", "paper-warehouse",
                  "paper-formation", "warehouse-grid", "office-floor")


_B = TypeVar("_B", bound=op.Backend)


def _backend(preset: str, cls: type[_B], **overrides: Any) -> _B:
    """``op.get_solver(preset, **overrides)``, checked to be a ``cls`` (the backend the tables
    read options of)."""
    solver = op.get_solver(preset, **overrides)
    if not isinstance(solver, cls):
        raise TypeError(f"preset {preset!r}: expected a {cls.__name__} backend, got "
                        f"{type(solver).__name__}")
    return solver


def _med(xs: Sequence[float]) -> float:
    a = np.asarray([x for x in xs if math.isfinite(x)], dtype=float)
    return float(np.median(a)) if len(a) else math.nan


def _outcome_cells(rs: list[dict[str, Any]], time_to_goal: bool = False) -> str:
    """The cells of the runs ``rs``: successes, median length and collisions (and time to goal),
    total SA escapes."""
    medians = [("length", ".1f"), ("collisions", "g")] + [("time_to_goal", ".1f")] * time_to_goal
    return " | ".join([f"{sum(r['success'] for r in rs)}/{len(rs)}",
                       *(format(_med([r[k] for r in rs]), f) for k, f in medians),
                       f"{sum(r['escapes'] for r in rs)}"])


def leader_rho_0_rows(seeds: Sequence[int], scenes: Sequence[str] = RHO_SCENES
                      ) -> list[dict[str, Any]]:
    """``hybrid-paper`` with ``leader_rho_0`` = the preset's and 100, per scene and seed."""
    def cells(prob: op.Problem, res: op.Result) -> dict[str, Any]:
        lead = prob.leader.id
        return {"length": float(res.metrics["lengths"][lead]),
                "collisions": int(res.metrics["collisions"]),
                "time_to_goal": float(res.extras.get("time_to_goal", math.nan)),
                "escapes": int(res.extras["local_stats"][lead]["escapes"])}

    return option_sweep("hybrid-paper", "leader_rho_0", RHO_VALUES, seeds, scenes, cells)


def format_leader_rho_0(rows: list[dict[str, Any]]) -> str:
    from optplan.hybrid.planner import Hybrid

    rho_preset = _backend("hybrid-paper", Hybrid).stages["local_solver"].rho_0
    out = ["| scene | leader rho_0 | success | leader length | collisions | time to goal (s) "
           "| SA escapes (total) |", "|---|---|---|---|---|---|---|"]
    for scene, v, rs in option_groups(rows, "leader_rho_0", RHO_VALUES):
        lab = f"{rho_preset:g} (preset, eq 34)" if v is None else f"{v:g} (paper eq 41)"
        out.append(f"| {scene} | {lab} | {_outcome_cells(rs, time_to_goal=True)} |")
    return "\n".join(out)


def reach_visible_rows(seeds: Sequence[int], scenes: Sequence[str] = VISIBLE_SCENES
                       ) -> list[dict[str, Any]]:
    """``hybrid-paper`` with ``reach_visible`` off (the preset) and on, per scene and seed."""
    def cells(prob: op.Problem, res: op.Result) -> dict[str, Any]:
        st = res.extras["local_stats"]
        return {"length": float(sum(res.metrics["lengths"][d] for d in st)),
                "collisions": int(res.metrics["collisions"]),
                "escapes": int(sum(x["escapes"] for x in st.values()))}

    return option_sweep("hybrid-paper", "reach_visible", (False, True), seeds, scenes, cells)


def format_reach_visible(rows: list[dict[str, Any]]) -> str:
    out = ["| scene | reach_visible | success | median length (drivers) | median collisions | "
           "SA escapes (total) |", "|---|---|---|---|---|---|"]
    for scene, v, rs in option_groups(rows, "reach_visible", (False, True)):
        out.append(f"| {scene} | {'on' if v else 'off (preset)'} | {_outcome_cells(rs)} |")
    return "\n".join(out)


def ipso_paper_known_rows(seeds: Sequence[int], scenes: Sequence[str] = IPSO_SCENES
                          ) -> list[dict[str, Any]]:
    """``ipso-paper`` on each scene's known map: feasibility per seed."""
    rows = []
    for scene in scenes:
        known = op.load_problem(scene).known_view()
        for s in seeds:
            res = op.solve(known, "ipso-paper", rng=int(s))
            rows.append({"scene": scene, "seed": int(s), "feasible": bool(
                res.metrics["feasible"]), "status": res.status.value,
                "length": float(res.metrics["length"])})
    return rows


def format_ipso_paper_known(rows: list[dict[str, Any]]) -> str:
    out = ["| known map of | `ipso-paper` collision-free | median length |", "|---|---|---|"]
    for scene in dict.fromkeys(r["scene"] for r in rows):
        rs = [r for r in rows if r["scene"] == scene]
        out.append(f"| {scene} | {sum(r['feasible'] for r in rs)}/{len(rs)} "
                   f"| {_med([r['length'] for r in rs]):.1f} |")
    return "\n".join(out)


def eq52_scene(rho: float, side: str) -> tuple[op.Problem, np.ndarray]:
    """A leader at (100, 100) heading +x, follower f1 at its slot (L = 20, phi = pi/4) and a
    wall parallel to the leader's heading at clearance ``rho`` on the follower's ``outer``
    side (away from the leader's line) or ``inner`` side; returns the problem and the unit
    vector from the follower toward the wall."""
    f = np.array([100.0 - 20.0 / math.sqrt(2.0), 100.0 + 20.0 / math.sqrt(2.0)])
    r = 2.0
    if side == "outer":
        y0 = f[1] + r + rho
        box, n = [[f[0] - 10, y0], [f[0] + 10, y0], [f[0] + 10, y0 + 4], [f[0] - 10, y0 + 4]], 1.0
    elif side == "inner":
        y1 = f[1] - r - rho
        box, n = [[f[0] - 10, y1 - 4], [f[0] + 10, y1 - 4], [f[0] + 10, y1], [f[0] - 10, y1]], -1.0
    else:
        raise ValueError(f"side must be 'outer' or 'inner', got {side!r}")
    prob = op.parse_problem({
        "name": f"eq52-{side}-{rho:g}", "bounds": [0, 0, 200, 200], "length_scale": 1.0,
        "robots": [{"id": "leader", "start": [100, 100], "goal": [190, 100], "radius": r,
                    "max_speed": 5},
                   {"id": "f1", "start": f.tolist(), "radius": r, "max_speed": 5}],
        "formation": {"leader": "leader", "safety_distance": 5.0,
                      "followers": [{"id": "f1", "L": 20.0, "phi": math.pi / 4}]},
        "obstacles": [{"type": "polygon", "vertices": box}]})
    return prob, np.array([0.0, n])


def eq52_probe(rho: float, side: str, safety: bool) -> dict[str, Any]:
    """One follower command of ``leader-follower-paper`` (``recovery`` off) in
    :func:`eq52_scene`: the component toward the wall and the eq 52 ratios."""
    from optplan.formation.leader_follower import LeaderFollower, adapted_angle
    from optplan.sim import ObstacleField, SimState

    prob, n = eq52_scene(rho, side)
    fb = _backend("leader-follower-paper", LeaderFollower, safety=safety, recovery=False)
    ctrl = fb.followers_controller(prob, np.random.default_rng(0))
    P = np.array([prob.robot("leader").start, prob.robot("f1").start])
    st = SimState(0, 0.0, ["leader", "f1"], P, np.array([[5.0, 0.0], [5.0, 0.0]]),
                  ObstacleField(prob), dt=0.1)
    st.leader_velocity = np.array([5.0, 0.0])
    v = np.asarray(ctrl.velocities(st, 0, [1], 0.0), dtype=float)[0]
    c = fb.c_phi
    return {"rho": rho, "side": side, "safety": safety,
            "ratio_code": float(adapted_angle(1.0, rho, fb.rho_0_f, c)),
            "ratio_literal": math.log(c * rho) / math.log(c * fb.rho_0_f),
            "toward": float(v @ n), "speed": float(np.hypot(*v))}


def eq52_rows(rhos: Sequence[float] = (0.01, 0.04, 0.1, 1.0, 5.0)) -> list[dict[str, Any]]:
    return [eq52_probe(rho, side, safety) for safety in (True, False)
            for side in ("outer", "inner") for rho in rhos]


def format_eq52(rows: list[dict[str, Any]]) -> str:
    out = ["| safety layer | wall side | clearance rho | phi_d / Phi (code, rho >= 1/c) | "
           "literal eq 52 | follower command toward the wall |", "|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {'on' if r['safety'] else 'off'} | {r['side']} | {r['rho']:g} "
                   f"| {r['ratio_code']:.3f} | {r['ratio_literal']:.3f} | {r['toward']:.4g} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    return sections_main("optplan.experiments.hybrid_fidelity", __doc__, [
        ("--seeds", 5, "the leader_rho_0 table"),
        ("--ipso-seeds", 30, "the ipso-paper known-map table"),
    ], [
        ("rho", "Leader influence distance, hybrid-paper ({seeds} seeds, medians)",
         lambda a: format_leader_rho_0(leader_rho_0_rows(range(a.seeds)))),
        ("visible", "Sub-goal switching with the next sub-goal in sight, hybrid-paper "
                    "({seeds} seeds, medians)",
         lambda a: format_reach_visible(reach_visible_rows(range(a.seeds)))),
        ("ipso", "ipso-paper on the known maps ({ipso_seeds} seeds)",
         lambda a: format_ipso_paper_known(ipso_paper_known_rows(range(a.ipso_seeds)))),
        ("eq52", "Eq 52 near an obstacle (leader-follower-paper, recovery off; one command)",
         lambda a: format_eq52(eq52_rows())),
    ], argv)


if __name__ == "__main__":
    raise SystemExit(main())
