"""Print the status of every catalogue scene with every preset (seed 0) as a TSV table.

    python -m optplan.experiments.status_table [--seed 0] > runs/statuses.tsv

Columns: problem, solver, status, collisions, message (first 160 characters).  Used to list,
in docs/changes.md, every scene whose status changed between two versions (run the same script
in both checkouts and compare).
"""

from __future__ import annotations

import argparse
import sys

import optplan as op


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m optplan.experiments.status_table",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0, help="seed of every run (0)")
    a = ap.parse_args(argv)
    if a.seed < 0:
        ap.error(f"--seed must be >= 0, got {a.seed}")
    print("problem\tsolver\tstatus\tcollisions\tmessage")
    for name in op.list_problems():
        for solver in op.list_solvers():
            try:
                res = op.solve(name, solver, rng=a.seed)
                row = (res.status.value, str(res.metrics.get("collisions", "")),
                       res.message.replace("\t", " ").replace("\n", " ")[:160])
            except ValueError as e:  # a refused input (e.g. no [formation]) is an outcome
                row = ("error", "", f"{type(e).__name__}: {e}"[:160])
            print("\t".join((name, solver, *row)))
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
