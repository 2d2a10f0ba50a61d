"""Two independently planned robots swapping the ends of an empty field, with and without the
``sense_robots`` option of ``apf`` / ``sa-apf`` (beyond the paper).

Prints the table quoted in docs/solvers/apf.md ("Several robots");
``tests/potential/test_apf.py`` asserts the statuses.

    python -m optplan.experiments.apf_multi_robot
"""

from __future__ import annotations

import optplan as op
from optplan.generators import swap_scene


def outcome(res: op.Result) -> str:
    return f"{res.status.value}: {res.message} (min separation {res.metrics['min_separation']:.1f})"


def main() -> None:
    print("| case | solver | `sense_robots = false` | `sense_robots = true` |")
    print("|---|---|---|---|")
    for label, dy in [("head-on (same line)", 0.0), ("2 units apart", 2.0)]:
        for solver in ("apf-paper", "sa-apf-paper"):
            cells = [outcome(op.solve(swap_scene(dy), solver, rng=0, sense_robots=s))
                     for s in (False, True)]
            print(f"| {label} | `{solver}` | {cells[0]} | {cells[1]} |")


if __name__ == "__main__":
    main()
