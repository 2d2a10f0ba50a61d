"""Reproduction of the paper's Tables 2 and 3: PSO vs MPSO vs IPSO on two maps.

``optplan bench --tag pso-comparison [--seeds 30] [--out runs]``

Runs every solver on ``paper-env1`` and ``paper-env2`` with the same seeds ``0..N-1`` and
prints, per map and method: best / median / worst length of the returned path (collision-free
runs only), success rate (validator: collision-free and reaching the goal), median wall time,
median "optimal number of iterations" (first iteration whose best fitness is within 0.1 % of
the final best of the swarm iterations; ``swarm.converged_iteration``) and the ratio to the
certified optimum from ``visgraph``, in one table (:func:`table`), the paper's numbers
(shortest length / running time / optimal iterations) beside ours.  A solver
``name[key=value,...]`` is a preset with option overrides: the default rows
(:data:`DEFAULT_SOLVERS`) are the faithful presets, the paper's IPSO with the other reading
of its crossover, the paper's IPSO with the minimal fixes, the variant ``ipso`` and each of
its additions ablated.  The convergence figure (median feasible-best length per iteration,
paper Figs 19 and 23) is written with matplotlib's Agg backend as ``pso_convergence.png``
into the folder ``--out`` (default ``runs/``, never into the repository's docs).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import optplan as op

__all__ = ["main", "run", "table", "PAPER", "DEFAULT_SOLVERS"]

#: Paper Tables 2-3: shortest path length (cm), running time (s), optimal number of iterations.
PAPER = {
    "paper-env1": {"pso": (892.13, 5.4, 97), "mpso": (801.54, 3.8, 70),
                   "ipso": (737.31, 2.5, 46)},
    "paper-env2": {"pso": (968.91, 9.2, 144), "mpso": (874.03, 7.1, 99),
                   "ipso": (753.03, 4.9, 72)},
}
#: The rows of the table: the faithful presets, the paper's IPSO with the other reading of its
#: crossover, the paper's IPSO with the minimal fixes (eq 24 on the step and the text's linear
#: inertia, nothing added), the documented variant ``ipso`` and each of its additions ablated.
DEFAULT_SOLVERS = [
    "pso-paper", "mpso-paper", "ipso-paper", "ipso-paper[crossover=blend]",
    "ipso-paper[position_update=step,inertia=linear]", "ipso",
    "ipso[init_mode=sorted]", "ipso[corridors=1]", "ipso[roadmap_boundary=0]",
    "ipso[roadmap_medial=0]", "ipso[islands=1]", "ipso[endgame=islands]",
    "ipso[tighten_rounds=0]", "ipso[penetration_weight=0]", "ipso[k_max=200]", "ipso[k_max=0]",
]
#: What each row is (the table's second column).
LABELS = {
    "pso-paper": "PSO as printed (eqs 1-2)",
    "mpso-paper": "MPSO as described (p_t, delta)",
    "ipso-paper": "IPSO as printed (eqs 17-29, fragment-swap crossover)",
    "ipso-paper[crossover=blend]": "IPSO as printed, crossover = eqs 25-28 on whole particles",
    "ipso-paper[position_update=step,inertia=linear]":
        "paper IPSO + minimal fixes (eq 24 on the step, linear inertia)",
    "ipso": "the variant ipso (all additions)",
    "ipso[init_mode=sorted]": "ipso without the roadmap seeds",
    "ipso[corridors=1]": "ipso with one roadmap corridor",
    "ipso[roadmap_boundary=0]": "ipso without boundary / corner samples",
    "ipso[roadmap_medial=0]": "ipso without medial-axis samples",
    "ipso[islands=1]": "ipso with one island",
    "ipso[endgame=islands]": "ipso, end-game on the island bests only",
    "ipso[tighten_rounds=0]": "ipso without the end-game",
    "ipso[penetration_weight=0]": "ipso without the penetration gradient",
    "ipso[k_max=200]": "ipso with the paper's 200 iterations",
    "ipso[k_max=0]": "ipso without swarm iterations",
}


def parse_solver(spec: str) -> tuple[str, dict]:
    """``"name"`` or ``"name[key=value,...]"`` (an ablation of a preset) -> (name, overrides).

    Values are parsed as int, float, true/false, or kept as strings.
    """
    if "[" not in spec:
        return spec, {}
    name, rest = spec.split("[", 1)
    over: dict = {}
    for item in rest.rstrip("]").split(","):
        if not item.strip():
            continue
        k, v = (x.strip() for x in item.split("=", 1))
        val: object = v
        if v.lower() in ("true", "false"):
            val = v.lower() == "true"
        else:
            for cast in (int, float):
                try:
                    val = cast(v)
                    break
                except ValueError:
                    pass
        over[k] = val
    return name, over


def run(maps: list[str], solvers: list[str], seeds: int) -> dict:
    """All runs: ``{map: {"optimum": L*, solver: [dict per seed]}}``."""
    out: dict = {}
    for m in maps:
        prob = op.load_problem(m)
        ref = op.solve(prob, "visgraph")
        out[m] = {"optimum": float(ref.metrics["length"]), "runs": {}}
        for s in solvers:
            name, over = parse_solver(s)
            op.solve(prob, name, rng=0, **over)  # warm (not timed): compiled code, caches
            rows = []
            for seed in range(seeds):
                r = op.solve(prob, name, rng=seed, **over)
                h = r.history
                rows.append({
                    "seed": seed, "success": r.success, "length": float(r.metrics["length"]),
                    "wall": r.wall_time, "conv": r.extras["converged_iteration"],
                    "curve": np.asarray(h["feasible_best_length"], dtype=float),
                    "n_eval": r.n_eval,
                })
            out[m]["runs"][s] = rows
    return out


def _paper_cells(m: str, s: str) -> str:
    """The paper's printed length / time / iterations for the method of row ``s``."""
    base = s.split("[")[0].replace("-paper", "")
    paper = PAPER.get(m, {}).get(base) if s.split("[")[0].endswith("-paper") else None
    return f"{paper[0]:.2f} | {paper[1]:.1f} | {paper[2]}" if paper else "- | - | -"


def table(results: dict) -> str:
    """The one comparison table: a row per (map, method), ours beside the paper's numbers.

    Length and ratio: median and worst over the collision-free runs (``success`` says how many
    there are); time and iterations to the best (``swarm.converged_iteration``): median and
    worst over all runs.
    """
    lines = [
        "| map | method | what it is | success | length median | length worst | ratio median "
        "| ratio worst | time median (ms) | time worst (ms) | iters median | iters worst "
        "| paper length | paper time (s) | paper iters |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m, data in results.items():
        opt = data["optimum"]
        for s, rows in data["runs"].items():
            ok = [r for r in rows if r["success"]]
            wall = np.array([r["wall"] for r in rows]) * 1e3
            conv = np.array([r["conv"] for r in rows])
            if ok:
                L = np.array([r["length"] for r in ok])
                lc = (f"{np.median(L):.2f} | {L.max():.2f} | {np.median(L) / opt:.4f} "
                      f"| {L.max() / opt:.4f}")
            else:
                lc = "- | - | - | -"
            lines.append(
                f"| {m} | `{s}` | {LABELS.get(s, '')} | {len(ok)}/{len(rows)} | {lc} "
                f"| {np.median(wall):.0f} | {wall.max():.0f} | {np.median(conv):.0f} "
                f"| {conv.max()} | {_paper_cells(m, s)} |")
    return "\n".join(lines)


def plot(results: dict, out: str | Path) -> None:
    """Median (over seeds) feasible-best length per iteration, one panel per map."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    maps = list(results)
    fig, axes = plt.subplots(1, len(maps), figsize=(6.0 * len(maps), 4.2), squeeze=False)
    for ax, m in zip(axes[0], maps):
        opt = results[m]["optimum"]
        for s, rows in results[m]["runs"].items():
            n = max(len(r["curve"]) for r in rows)
            C = np.full((len(rows), n), np.nan)
            for i, r in enumerate(rows):
                C[i, : len(r["curve"])] = r["curve"]
            with np.errstate(all="ignore"):
                import warnings

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    med = np.nanmedian(C, axis=0)
            ax.plot(np.arange(n), med, label=s)
        ax.axhline(opt, color="k", ls="--", lw=1, label=f"optimum (visgraph) {opt:.1f}")
        ax.set_ylim(opt * 0.98, opt * 1.35)
        ax.set_xlabel("iteration")
        ax.set_ylabel("median best collision-free length")
        ax.set_title(m)
        ax.legend(fontsize=8)
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="optplan bench --tag pso-comparison",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30, help="seeds 0..N-1 (default 30)")
    ap.add_argument("--maps", nargs="+", default=["paper-env1", "paper-env2"])
    ap.add_argument("--solvers", nargs="+", default=DEFAULT_SOLVERS)
    ap.add_argument("--out", default="runs",
                    help="folder of the convergence figure pso_convergence.png (default runs)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    load_start = os.getloadavg()[0]
    res = run(args.maps, args.solvers, args.seeds)
    load_end = os.getloadavg()[0]
    print(f"PSO / MPSO / IPSO comparison (paper Tables 2-3): {args.seeds} common seeds, "
          f"machine: {os.cpu_count()} cores, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {np.__version__}; load average "
          f"{load_start:.2f} at the start, {load_end:.2f} at the end")
    print("Lengths in map units (the paper's cm); success = collision-free and at the goal "
          "(shared validator).")
    print("Certified optima (visgraph): " + ", ".join(
        f"{m} {res[m]['optimum']:.2f}" for m in args.maps) + "; ratio = length / optimum.")
    print("Length and ratio: median and worst over the collision-free runs; time and iterations "
          "to the best: median and worst over all runs.")
    print()
    print(table(res))
    print()
    out = Path(args.out) / "pso_convergence.png"
    plot(res, out)
    print(f"convergence figure: {out}  (total {time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
