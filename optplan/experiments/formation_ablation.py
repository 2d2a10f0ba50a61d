"""Ablation of the leader-follower preset's safety layer on paper-warehouse.

Prints the table quoted in docs/solvers/formation.md: each combination of the ``safety`` and
``recovery`` options over the 5 seeded variants of ``optplan bench --tag formation`` (seed 0 is
the scene as written, seeds 1-4 jitter the moving obstacles' phases; leader reference by
``visgraph``).

    python -m optplan.experiments.formation_ablation
"""

from __future__ import annotations

import argparse

import numpy as np

import optplan as op
from optplan.generators import jitter_phases


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="paper-warehouse")
    a = ap.parse_args(argv)
    base = op.load_problem(a.scene)
    print("| `safety` | `recovery` | success | min separation (median) | formation RMSE (median) "
          "| first failure (seed 0 message) |")
    print("|---|---|---:|---:|---:|---|")
    for safety in (False, True):
        for recovery in (False, True):
            ok, sep, rmse, msg = 0, [], [], ""
            for seed in range(5):
                prob = base if seed == 0 else jitter_phases(base, np.random.default_rng(seed))
                res = op.solve(prob, "leader-follower-paper", rng=seed, path_solver="visgraph",
                               safety=safety, recovery=recovery)
                ok += res.success
                sep.append(res.metrics.get("min_separation", np.nan))
                rmse.append(res.metrics.get("formation_rmse", np.nan))
                if seed == 0:
                    msg = "-" if res.success else res.message.replace("|", "/")
            print(f"| {str(safety).lower()} | {str(recovery).lower()} | {ok}/5 | "
                  f"{np.median(sep):.2f} | {np.median(rmse):.2f} | {msg} |")


if __name__ == "__main__":
    main()
