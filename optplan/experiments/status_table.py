"""Print the status of every catalogue scene with every preset (seed 0) as a TSV table.

    python -m optplan.experiments.status_table > runs/statuses.tsv

Columns: problem, solver, status, collisions, message (first 160 characters).  Used to list,
in docs/changes.md, every scene whose status changed between two versions (run the same script
in both checkouts and compare).
"""

from __future__ import annotations

import sys

import optplan as op


def main() -> None:
    print("problem\tsolver\tstatus\tcollisions\tmessage")
    for name in op.list_problems():
        for solver in op.list_solvers():
            try:
                res = op.solve(name, solver, rng=0)
                row = (res.status.value, str(res.metrics.get("collisions", "")),
                       res.message.replace("\t", " ").replace("\n", " ")[:160])
            except ValueError as e:  # a refused input (e.g. no [formation]) is an outcome
                row = ("error", "", f"{type(e).__name__}: {e}"[:160])
            print("\t".join((name, solver, *row)))
            sys.stdout.flush()


if __name__ == "__main__":
    main()
