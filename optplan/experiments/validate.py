r"""``optplan validate PROBLEM --solver S --seeds N``: how far is a heuristic from the optimum?

For each seed the heuristic ``S`` (default ``ipso-paper``) is run, its path is polished by the
exact waypoint NLP (``nlp-ipopt``, warm-started from the heuristic's path), and both are
compared with the certified ``visgraph`` optimum of the same (known) map:

* **within-homotopy gap** :math:`(L_\text{heur} - L_\text{NLP}) / L_\text{NLP}`: how much shorter
  the heuristic's path gets without changing which side of each obstacle it passes
  (IPOPT is local: the NLP keeps the initial guess's homotopy class);
* **homotopy gap** :math:`(L_\text{NLP} - L^*) / L^*`: what is left, the price of the
  homotopy class the heuristic chose (zero, up to the NLP's discretisation, when the class is
  the optimal one);
* **total gap** :math:`(L_\text{heur} - L^*) / L^*`.

The ``optimal class`` column says whether the heuristic's (and the NLP's) path is in the optimum's
homotopy class ("-" for an infeasible path, whose class is undefined),
decided topologically: the closed loop "heuristic path, then the optimum backwards" must
wind zero times around every obstacle of the known map (one interior point per convex piece and
the centre of every circle of the exact collision engine, :meth:`Problem.obstacle_set`; a
feasible path never enters an obstacle, so it cannot pass between two points of one obstacle,
nor between obstacles closer than the robot's diameter).  The optimum ``L*`` is the exact
(segments + arcs) length of the tangent-graph path, ``metrics["length_exact"]`` of
``visgraph``, not the length of its circumscribed polyline.

Python::

    from optplan.experiments.validate import validate, format_table
    rows = validate("paper-env1", solver="ipso-paper", seeds=30)
    print(format_table(rows))
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import tomllib
from typing import Any

import numpy as np

from optplan.catalog import load_problem
from optplan.geometry.collision import same_homotopy
from optplan.goal_completion import completion_length
from optplan.problem import Problem
from optplan.result import Result
from optplan.solver import Backend, get_solver, solve

__all__ = ["validate", "format_table", "format_time_table", "format_team_table", "summarize",
           "main", "TIME_COLUMNS", "TEAM_COLUMNS"]


def _pct(a: float, b: float) -> float:
    if not (math.isfinite(a) and math.isfinite(b)) or b <= 0:
        return float("nan")
    return 100.0 * (a - b) / b


def validate(problem: Problem | str, solver: str | Backend = "ipso-paper", seeds: int = 30, *,
             nlp: str | Backend = "nlp-ipopt", first_seed: int = 0,
             solver_options: dict | None = None, nlp_options: dict | None = None,
             reference: str | Backend = "visgraph") -> list[dict[str, Any]]:
    """Heuristic vs NLP polish vs certified optimum, one row per seed.

    Parameters
    ----------
    problem : Problem or str
        Scenario (catalogue name or path).
    solver : str or Backend
        The heuristic (preset, backend name or object).
    seeds : int
        Number of seeds ``first_seed .. first_seed + seeds - 1``.
    nlp : str or Backend
        The polisher, warm-started from each heuristic path (default ``nlp-ipopt``).
    solver_options, nlp_options : dict, optional
        Option overrides for the heuristic / the NLP.
    reference : str or Backend
        The certified optimum (default ``visgraph``), solved once.

    Returns
    -------
    list of dict
        Per seed: ``seed``, ``heuristic_status``, ``L_heuristic``, ``t_heuristic`` (s),
        ``nlp_status``, ``L_nlp``, ``t_nlp`` (s), ``kept_init``, ``L_opt``,
        ``within_gap_pct``, ``homotopy_gap_pct``, ``total_gap_pct``, ``optimal_class``
        (the heuristic's path is feasible and in the optimum's homotopy class),
        ``nlp_optimal_class`` (the same for the NLP's path), ``heuristic_feasible``,
        ``nlp_feasible``; on a problem with moving obstacles also the heuristic's grades in
        time (:data:`TIME_COLUMNS`, :mod:`optplan.time_grading`): its arrival, the fastest
        timing of its own path, the ``sipp`` reference, the certified lower bound and the
        ratios of the arrival to them; on a problem with a formation the grades against the
        team optimum (:data:`TEAM_COLUMNS`, :mod:`optplan.team_grading`).
    """
    prob = load_problem(problem)
    heur = get_solver(solver, **(solver_options or {}))
    pol = get_solver(nlp, **(nlp_options or {}))
    ref = solve(prob, reference)
    rid = prob.leader.id
    # the exact optimum (segments + arcs) when the reference reports it, else its polyline
    L_opt = (float(ref.metrics.get("length_exact", ref.metrics["length"]))
             if rid in ref.paths else float("nan"))
    oset = prob.obstacle_set(prob.leader.radius, known_only=True)
    rows = []
    for seed in range(first_seed, first_seed + seeds):
        t0 = time.perf_counter()
        mode: bool | str = ("team" if prob.formation is not None
                            else bool(prob.dynamic_obstacles))
        h: Result = solve(prob, heur, rng=seed, reference=mode)
        th = time.perf_counter() - t0
        t0 = time.perf_counter()
        n: Result = solve(prob, pol, rng=seed, init={rid: h.paths[rid]})
        tn = time.perf_counter() - t0
        # a run accepted inside the goal tolerance is graded to the goal point
        # (optplan.goal_completion): its length plus the shortest continuation
        done = _completion(prob, rid, h)
        Lh = float(h.metrics["length"]) + (done or 0.0)
        Ln = float(n.metrics["length"]) + (_completion(prob, rid, n) or 0.0)
        hf = bool(h.metrics["feasible"] and h.metrics["reached"])
        nf = bool(n.metrics["feasible"] and n.metrics["reached"])
        has_ref = rid in ref.paths and ref.success
        cls = hf and has_ref and same_homotopy(h.paths[rid], ref.paths[rid], oset)
        ncls = nf and has_ref and same_homotopy(n.paths[rid], ref.paths[rid], oset)
        info = n.extras.get("ipopt", {}).get(rid, {})
        rows.append({
            "seed": seed,
            "heuristic_status": h.status.value,
            "L_heuristic": Lh,
            "goal_completion": done,
            "t_heuristic": th,
            "nlp_status": n.status.value,
            "L_nlp": Ln,
            "L_nlp_raw": float(info.get("nlp_length", Ln)),
            "t_nlp": tn,
            "kept_init": bool(info.get("kept_init", False)),
            "L_opt": L_opt,
            "within_gap_pct": _pct(Lh, Ln),
            "homotopy_gap_pct": _pct(Ln, L_opt),
            "total_gap_pct": _pct(Lh, L_opt),
            "optimal_class": bool(cls),
            "nlp_optimal_class": bool(ncls),
            "heuristic_feasible": hf,
            "nlp_feasible": nf,
            **_time_columns(h),
            **_team_columns(h),
        })
    return rows


#: The grading in time copied into a row (problems with moving obstacles).
TIME_COLUMNS = ("arrival_time", "arrival_at_goal", "schedule_arrival", "time_reference",
                "time_lower_bound",
                "arrival_ratio_to_schedule", "arrival_ratio_to_reference",
                "arrival_ratio_to_lower")


#: The grading against the team optimum copied into a row (problems with a formation).
TEAM_COLUMNS = ("team_arrival_reference", "arrival_ratio_to_team", "formation_rmse",
                "team_formation_rmse_reference", "formation_rmse_ratio_to_team",
                "min_separation", "team_min_separation_reference", "separation_ratio_to_team")


def _team_columns(h: Result) -> dict[str, Any]:
    """The heuristic's grades against the team optimum (:mod:`optplan.team_grading`)."""
    if "team_reference_status" not in h.metrics:
        return {}
    return {k: (float("nan") if h.metrics.get(k) is None else float(h.metrics[k]))
            for k in TEAM_COLUMNS}


def _completion(prob: Problem, rid: str, res: Result) -> float | None:
    """The shortest continuation of ``res``'s path from its end to the goal point, when it
    ends inside the goal tolerance (:func:`optplan.goal_completion.completion_length`)."""
    return completion_length(prob, rid, res.paths[rid]) if rid in res.paths else None


def _time_columns(h: Result) -> dict[str, Any]:
    """The heuristic's grades in time (:mod:`optplan.time_grading`), NaN where missing."""
    if "arrival_time" not in h.metrics:
        return {}
    return {k: (float("nan") if h.metrics.get(k) is None else float(h.metrics[k]))
            for k in TIME_COLUMNS}


def _med(rows: list[dict], key: str) -> float:
    v = np.array([r[key] for r in rows], float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else float("nan")


def summarize(rows: list[dict]) -> dict[str, Any]:
    """Medians over all seeds and over the seeds in the optimal homotopy class."""
    opt = [r for r in rows if r["nlp_optimal_class"]]
    return {
        "n": len(rows),
        "n_optimal_class": len(opt),
        "n_heuristic_optimal_class": sum(r["optimal_class"] for r in rows),
        "n_heuristic_feasible": sum(r["heuristic_feasible"] for r in rows),
        "n_nlp_feasible": sum(r["nlp_feasible"] for r in rows),
        "n_nlp_longer": sum(r["L_nlp"] > r["L_heuristic"] * (1 + 1e-12) for r in rows
                            if r["heuristic_feasible"]),
        "median_L_heuristic": _med(rows, "L_heuristic"),
        "median_L_nlp": _med(rows, "L_nlp"),
        "median_within_gap_pct": _med(rows, "within_gap_pct"),
        "median_homotopy_gap_pct": _med(rows, "homotopy_gap_pct"),
        "median_total_gap_pct": _med(rows, "total_gap_pct"),
        "n_optimal_class_feasible_heuristic": sum(r["heuristic_feasible"] for r in opt),
        "median_total_gap_pct_optimal_class": _med(
            [r for r in opt if r["heuristic_feasible"]], "total_gap_pct"),
        "median_nlp_gap_pct_optimal_class": _med(opt, "homotopy_gap_pct"),
        "median_t_heuristic": _med(rows, "t_heuristic"),
        "median_t_nlp": _med(rows, "t_nlp"),
        "L_opt": rows[0]["L_opt"] if rows else float("nan"),
    }


def _cls(same: bool, feasible: bool) -> str:
    return "-" if not feasible else ("yes" if same else "no")


def _f(x: float, nd: int = 3) -> str:
    return "-" if not math.isfinite(x) else f"{x:.{nd}f}"


def format_table(rows: list[dict], title: str | None = None) -> str:
    """Markdown table of the rows plus a median row and a summary."""
    out = []
    if title:
        out.append(title)
        out.append("")
    out.append("| seed | heuristic | L heuristic | L NLP | within-homotopy gap % | L optimum "
               "| homotopy gap % | total gap % | optimal class heur/NLP | NLP status | t heur ms "
               "| t NLP ms |")
    out.append("|---:|---|---:|---:|---:|---:|---:|---:|:-:|---|---:|---:|")
    for r in rows:
        st = r["nlp_status"] + (" (kept init)" if r["kept_init"] else "")
        out.append(
            f"| {r['seed']} | {r['heuristic_status']} | {_f(r['L_heuristic'])} "
            f"| {_f(r['L_nlp'])} | {_f(r['within_gap_pct'])} | {_f(r['L_opt'])} "
            f"| {_f(r['homotopy_gap_pct'])} | {_f(r['total_gap_pct'])} "
            f"| {_cls(r['optimal_class'], r['heuristic_feasible'])}/"
            f"{_cls(r['nlp_optimal_class'], r['nlp_feasible'])} | {st} "
            f"| {r['t_heuristic'] * 1e3:.0f} | {r['t_nlp'] * 1e3:.0f} |")
    s = summarize(rows)
    out.append(
        f"| **median** | | {_f(s['median_L_heuristic'])} | {_f(s['median_L_nlp'])} "
        f"| {_f(s['median_within_gap_pct'])} | {_f(s['L_opt'])} "
        f"| {_f(s['median_homotopy_gap_pct'])} | {_f(s['median_total_gap_pct'])} "
        f"| {s['n_heuristic_optimal_class']}/{s['n_optimal_class']} (of {s['n']}) | "
        f"| {s['median_t_heuristic'] * 1e3:.0f} "
        f"| {s['median_t_nlp'] * 1e3:.0f} |")
    out.append("")
    out.append(
        "Gaps in % (within-homotopy: of L NLP; homotopy and total: of L optimum); "
        "`optimal class` = path in the optimum's homotopy class (heuristic/NLP; median "
        "row: counts).  "
        f"Heuristic feasible in {s['n_heuristic_feasible']}/{s['n']} seeds, NLP in "
        f"{s['n_nlp_feasible']}/{s['n']}; NLP longer than its initial guess in "
        f"{s['n_nlp_longer']} seeds.  Where the NLP path is in the optimum's homotopy class "
        f"({s['n_optimal_class']} seeds): median gap to the optimum "
        f"{_f(s['median_total_gap_pct_optimal_class'])} % before (over the "
        f"{s['n_optimal_class_feasible_heuristic']} feasible heuristic paths) and "
        f"{_f(s['median_nlp_gap_pct_optimal_class'], 4)} % after the NLP polish.")
    if rows and "arrival_time" in rows[0]:
        out += ["", *format_time_table(rows)]
    if rows and "arrival_ratio_to_team" in rows[0]:
        out += ["", *format_team_table(rows)]
    return "\n".join(out)


def _seed_table(rows: list[dict], head: str, cols: tuple[str, ...], note: str) -> list[str]:
    """A Markdown table of ``cols`` per seed (``head``: its named columns), a median row and
    ``note`` under it."""
    out = [f"| seed | {head} |", "|---:|" + "---:|" * len(cols)]
    for r in rows:
        out.append(f"| {r['seed']} | " + " | ".join(_f(r[k]) for k in cols) + " |")
    out.append("| **median** | " + " | ".join(_f(_med(rows, k)) for k in cols) + " |")
    return [*out, "", note]


def format_team_table(rows: list[dict]) -> list[str]:
    """The team plan beside the team optimum (``formation-nlp`` warm-started from it)."""
    return _seed_table(
        rows, "arrival ratio | RMSE | RMSE (NLP) | ratio | min sep. | min sep. (NLP) | ratio",
        ("arrival_ratio_to_team", "formation_rmse", "team_formation_rmse_reference",
         "formation_rmse_ratio_to_team", "min_separation", "team_min_separation_reference",
         "separation_ratio_to_team"),
        "Ratios of the team plan to the joint trajectory NLP warm-started from it (a local "
        "optimum, never worse than the plan): arrival and formation RMSE >= 1 measure what a "
        "local improvement gains; a separation ratio below 1 means the NLP keeps the robots "
        "further apart.")


def format_time_table(rows: list[dict]) -> list[str]:
    """The arrival of the heuristic beside the references in time, one row per seed and a
    median row (the lines of a Markdown table)."""
    return _seed_table(
        rows, "arrival s | fastest timing of its path s | ratio | at goal s | reference s | "
        "ratio | lower bound s | ratio",
        ("arrival_time", "schedule_arrival", "arrival_ratio_to_schedule", "arrival_at_goal",
         "time_reference", "arrival_ratio_to_reference", "time_lower_bound",
         "arrival_ratio_to_lower"),
        "Arrival of the heuristic's plan as executed (inside the goal tolerance) and its ratio "
        "to the fastest timing of the same path (exact); its arrival at the goal point "
        "(completed by the shortest continuation at full speed) and the ratios of it to the "
        "reference (the upper side of the time bracket, a valid plan never later than `sipp`, "
        "or the plan itself when it is valid and earlier) and to the lower bound (the "
        "bracket's lower side, certified for every motion).")


def _parse_set(items: list[str] | None) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for it in items or []:
        if "=" not in it:
            raise SystemExit(f"--set expects KEY=VALUE, got {it!r}")
        k, v = it.split("=", 1)
        try:
            out[k.strip()] = tomllib.loads(f"x = {v}")["x"]
        except tomllib.TOMLDecodeError:
            out[k.strip()] = v
    return out


def main(argv: list[str] | None = None) -> int:
    """``optplan validate PROBLEM --solver S --seeds N``: print the gap table."""
    ap = argparse.ArgumentParser(
        prog="optplan validate",
        description="Compare a heuristic's path lengths with the NLP polish (same homotopy "
                    "class) and the certified visgraph optimum, seed by seed.")
    ap.add_argument("problem", help="problem name or .toml path")
    ap.add_argument("--solver", default="ipso-paper", help="heuristic (default ipso-paper)")
    ap.add_argument("--seeds", type=int, default=30, help="number of seeds (default 30)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--nlp", default="nlp-ipopt", help="polisher preset (default nlp-ipopt)")
    ap.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="override an option of the heuristic (TOML literal; repeatable)")
    ap.add_argument("--nlp-set", action="append", metavar="KEY=VALUE",
                    help="override an option of the NLP (TOML literal; repeatable)")
    args = ap.parse_args(argv)
    rows = validate(args.problem, args.solver, args.seeds, nlp=args.nlp,
                    first_seed=args.first_seed, solver_options=_parse_set(args.set),
                    nlp_options=_parse_set(args.nlp_set))
    title = (f"### {args.problem}: {args.solver} vs {args.nlp} vs visgraph "
             f"({args.seeds} seeds)")
    sys.stdout.write(format_table(rows, title) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
