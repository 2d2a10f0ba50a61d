"""Reproduction of the paper's Tables 2 and 3: PSO vs MPSO vs IPSO on two maps.

``optplan bench --tag pso-comparison [--seeds 30] [--out runs/pso_convergence.png]``

Runs every solver on ``paper-env1`` and ``paper-env2`` with the same seeds ``0..N-1`` and
prints, per map and method: best / median / worst length of the returned path (collision-free
runs only), success rate (validator: collision-free and reaching the goal), median wall time,
median "optimal number of iterations" (first iteration whose best fitness is within 0.1 % of
the final best of the swarm iterations; ``swarm.converged_iteration``), the certified optimum
from ``visgraph``, the median ratio to it and the number of runs within 1 % of it.  The
paper's numbers (shortest length / running time / optimal iterations) are printed next to
ours.  A solver ``name[key=value,...]`` is a preset with option overrides (the default list
has three variants of ``ipso``: with the paper's 200 iterations, without the roadmap seeds
and without the end-game tightening).  The convergence figure (median feasible-best length
per iteration, paper Figs 19 and 23) is written with matplotlib's Agg backend, by default
into ``runs/`` (never into the repository tree).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import optplan as op

__all__ = ["main", "run", "PAPER"]

#: Paper Tables 2-3: shortest path length (cm), running time (s), optimal number of iterations.
PAPER = {
    "paper-env1": {"pso": (892.13, 5.4, 97), "mpso": (801.54, 3.8, 70),
                   "ipso": (737.31, 2.5, 46)},
    "paper-env2": {"pso": (968.91, 9.2, 144), "mpso": (874.03, 7.1, 99),
                   "ipso": (753.03, 4.9, 72)},
}
DEFAULT_SOLVERS = ["pso-paper", "mpso-paper", "ipso-paper", "ipso", "ipso[k_max=200]",
                   "ipso[init_mode=sorted]", "ipso[tighten_rounds=0]"]


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


def _table(m: str, data: dict) -> str:
    opt = data["optimum"]
    lines = [
        f"### {m} (certified optimum, visgraph: {opt:.2f})",
        "",
        "| method | best | median | worst | success | median time (ms) | median iters to "
        "converge | median ratio to optimum | within 1 % | paper: length / time (s) / iters |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s, rows in data["runs"].items():
        ok = [r for r in rows if r["success"]]
        L = np.array([r["length"] for r in ok]) if ok else np.array([np.nan])
        wall = np.median([r["wall"] for r in rows]) * 1e3
        conv = np.median([r["conv"] for r in rows])
        base = s.replace("-paper", "")
        paper = PAPER.get(m, {}).get(base) if s.endswith("-paper") else None
        ptxt = f"{paper[0]:.2f} / {paper[1]:.1f} / {paper[2]}" if paper else "-"
        if ok:
            stats = (f"{L.min():.2f} | {np.median(L):.2f} | {L.max():.2f}",
                     f"{np.median(L) / opt:.4f}")
        else:
            stats = ("- | - | -", "-")
        near = sum(r["success"] and r["length"] <= 1.01 * opt for r in rows)
        lines.append(f"| {s} | {stats[0]} | {len(ok)}/{len(rows)} | {wall:.0f} | {conv:.0f} | "
                     f"{stats[1]} | {near}/{len(rows)} | {ptxt} |")
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
    ap.add_argument("--out", default="runs/pso_convergence.png",
                    help="convergence figure (PNG; default runs/pso_convergence.png)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = run(args.maps, args.solvers, args.seeds)
    print(f"PSO / MPSO / IPSO comparison (paper Tables 2-3): {args.seeds} common seeds, "
          f"machine: {os.cpu_count()} cores, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {np.__version__}")
    print("Lengths in map units (the paper's cm); success = collision-free and at the goal "
          "(shared validator); best/median/worst over successful runs.")
    print()
    for m in args.maps:
        print(_table(m, res[m]))
        print()
    plot(res, args.out)
    print(f"convergence figure: {args.out}  (total {time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
