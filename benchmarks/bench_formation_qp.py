"""Per-step time of the formation QP's solve path (the cvxpy DPP model solved by Clarabel).

Runs ``formation-qp`` on generated grid formations of 3, 30 and 100 robots (spacing 12,
neighbour radius 20, a few random discs; ``length_scale`` pinned to 1, the generator's units)
for ``--steps`` control steps and times, per step, only the **solve path**: writing the step's
Parameter vector into the solver (the compiled map, the rows the speed cones imply dropped,
Clarabel updated in place) and Clarabel's solve, history column ``qp_solve_time``.  Sensing,
the row builders and the post-processing (history column ``qp_time``, "whole step") are printed
beside it for context, not timed against the target.

The first step builds and compiles the model and is excluded (reported as "build").  Targets
(issue 18): 0.5 / 1.5 / 4 ms per step at 3 / 30 / 100 robots, for the median.  With
``--repeat k`` each size is run ``k`` times; the table gives the median over all steps of all
runs and the worst single step.  The machine is shared: the load average is printed before
each size.

``--refinement both`` also runs every size with Clarabel's iterative refinement switched on
(the shipped setting is off, :func:`optplan.formation.formation_qp.qp_settings`) and prints the
solve path of both settings and the largest difference between the two runs' trajectories.

``--oracle`` (issue 24) re-solves every recorded step of one run per size both ways, through
the compiled map (the one run-time path) and through cvxpy's re-solve pipeline (the oracle,
:meth:`optplan.formation.qp_model.QPModel.solve_cvxpy`), and prints both medians and the largest
difference of the velocities.

    python benchmarks/bench_formation_qp.py [--steps 80] [--sizes 3,30,100] [--repeat 3]
                                            [--refinement off|on|both] [--oracle]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time

import numpy as np

import optplan as op
import optplan.formation.formation_qp as fq
from optplan.generators import formation_scene

TARGET_MS = {3: 0.5, 30: 1.5, 100: 4.0}


def scene(n: int) -> op.Problem:
    """The benchmark scene of ``n`` robots (``length_scale`` pinned to 1)."""
    prob = formation_scene(n, "grid", spacing=12.0, obstacles=max(2, n // 10), seed=n)
    return dataclasses.replace(prob, scale=1.0, _cache={})


#: the shipped Clarabel settings (None in versions before they were a function: the
#: benchmark then measures that version's own settings, see the docs' "before" table)
_SHIPPED = getattr(fq, "qp_settings", None)


def _refined(opts):
    return {**_SHIPPED(opts), "iterative_refinement_enable": True}


def run(n: int, steps: int, refinement: bool = False) -> dict:
    prob = scene(n)
    solver = op.get_solver("formation-qp", path_solver="visgraph", max_steps=steps,
                           neighbor_radius=20.0)
    if refinement and _SHIPPED is None:
        raise SystemExit("--refinement on/both needs optplan.formation.formation_qp.qp_settings")
    if _SHIPPED is not None:
        fq.qp_settings = _refined if refinement else _SHIPPED
    try:
        res = solver.solve(prob, rng=np.random.default_rng(0))
    finally:
        if _SHIPPED is not None:
            fq.qp_settings = _SHIPPED
    h, ex = res.history, res.extras
    return {"solve": np.asarray(h["qp_solve_time"])[1:] * 1e3,
            "step": np.asarray(h["qp_time"])[1:] * 1e3,
            "build": float(h["qp_time"][0]) * 1e3,
            "pairs": int(np.nanmax(h["qp_pairs"])), "failures": int(ex["qp_failures"]),
            "slack_steps": int(ex["slack_steps"]), "rebuilds": int(ex["rebuilds"]),
            "min_sep_ok": bool(res.metrics.get("min_separation", np.inf)
                               >= prob.formation.safety_distance - 1e-6),
            "paths": res.paths, "retries": int(ex.get("qp_retries", 0)),
            "iters": (np.asarray(h["qp_iterations"])[1:] if "qp_iterations" in h
                      else np.zeros(0))}


def oracle(n: int, steps: int) -> str:
    """One run; every step's Parameter vector re-solved by the compiled map and by cvxpy."""
    import optplan.formation.qp_model as qm

    seen, orig = [], qm.QPModel.solve

    def record(self, data):
        seen.append((self, data.theta(self.linear_term(data))))
        return orig(self, data)

    qm.QPModel.solve = record
    try:
        op.get_solver("formation-qp", path_solver="visgraph", max_steps=steps,
                      neighbor_radius=20.0).solve(scene(n), rng=np.random.default_rng(0))
    finally:
        qm.QPModel.solve = orig
    tc, tp, dev = [], [], 0.0
    for m, theta in seen:
        t0 = time.perf_counter()
        a = m.compiled.solve(theta, m.soft)
        t1 = time.perf_counter()
        b, _ = m.solve_cvxpy(theta)
        tp.append(time.perf_counter() - t1)
        tc.append(t1 - t0)
        if a.U is not None and b.U is not None:
            dev = max(dev, float(np.abs(a.U - b.U).max()))
    return (f"| {n} | {len(seen)} | {np.median(tc) * 1e3:.2f} | {np.median(tp) * 1e3:.2f} | "
            f"{np.median(tp) / np.median(tc):.1f} | {dev:.1e} |")


def load() -> str:
    return ", ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=80)
    ap.add_argument("--sizes", default="3,30,100")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--refinement", choices=("off", "on", "both"), default="off",
                    help="Clarabel's iterative refinement (shipped: off)")
    ap.add_argument("--oracle", action="store_true",
                    help="compare the compiled map with cvxpy's pipeline (issue 24)")
    a = ap.parse_args(argv)
    if a.oracle:
        print("| robots | steps | compiled map median ms | cvxpy pipeline median ms | ratio "
              "| max velocity difference |")
        print("|---:|---:|---:|---:|---:|---:|")
        for n in a.sizes.split(","):
            print(oracle(int(n), a.steps))
        return
    modes = {"off": [False], "on": [True], "both": [False, True]}[a.refinement]
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores (shared); python "
          f"{platform.python_version()}; {a.steps} steps per run, {a.repeat} run(s) per size\n")
    print("| robots | refinement | load average (1, 5, 15 min) | solve path median ms | p90 ms "
          "| worst ms | target ms | met | whole step median ms | build ms | active pair rows "
          "| Clarabel iterations median / max | rebuilds | slack steps | retries | QP failures "
          "| min sep >= D_s |")
    print("|---:|---|---|---:|---:|---:|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---|")
    diffs = {}
    for n, refine in [(int(x), m) for x in a.sizes.split(",") for m in modes]:
        la = load()
        runs = [run(n, a.steps, refine) for _ in range(a.repeat)]
        diffs.setdefault(n, []).append(runs[0]["paths"])
        solve = np.concatenate([r["solve"] for r in runs])
        step = np.concatenate([r["step"] for r in runs])
        med = float(np.median(solve))
        target = TARGET_MS.get(n, float("nan"))
        it = np.concatenate([r["iters"] for r in runs])
        its = f"{np.median(it):.0f} / {it.max()}" if len(it) else "-"
        label = "on" if refine else ("off" if _SHIPPED is not None else "on (Clarabel default)")
        print(f"| {n} | {label} | {la} | {med:.2f} | "
              f"{np.percentile(solve, 90):.2f} | "
              f"{solve.max():.2f} | {target:g} | {'yes' if med <= target else 'no'} | "
              f"{np.median(step):.2f} | {np.median([r['build'] for r in runs]):.0f} | "
              f"{max(r['pairs'] for r in runs)} | {its} | {max(r['rebuilds'] for r in runs)} | "
              f"{sum(r['slack_steps'] for r in runs)} | {sum(r['retries'] for r in runs)} | "
              f"{sum(r['failures'] for r in runs)} | {all(r['min_sep_ok'] for r in runs)} |")
    if a.refinement == "both":
        dev = {n: max(float(np.abs(p[0][k] - p[1][k]).max()) for k in p[0])
               for n, p in diffs.items()}
        print("\nlargest distance between the robots' positions with and without refinement "
              "(same step, map units): " + ", ".join(f"{n} robots {d:.1e}" for n, d in dev.items()))


if __name__ == "__main__":
    main()
