"""The figures of docs/solvers/formation-nlp.md (headless; run from anywhere).

    python docs/figures/team.py                 # into runs/team-figures/
    python docs/figures/team.py --out docs/img  # refresh the docs' figures

Writes into ``--out`` (default ``runs/team-figures``):

* ``team-nlp-warehouse.png``: ``paper-warehouse``, seed 0: the ``hybrid-qp`` team plan and the
  ``formation-nlp`` plan warm-started from it, side by side (:func:`optplan.plot.plot_result`);
* ``team-nlp-tradeoff.png``: the same warm start polished with ``w_formation`` from 0 to 1e4:
  arrival against formation RMSE (the trade-off the weight sets); it prints the points.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from figure_io import parser, save  # noqa: E402

import optplan as op  # noqa: E402
from optplan.plot import plot_result  # noqa: E402

__all__ = ["main", "WEIGHTS"]

DEFAULT_OUT = Path("runs") / "team-figures"
#: the weights of the trade-off figure
WEIGHTS = (0.0, 1.0, 10.0, 100.0, 1000.0, 10000.0)


def _end(res: op.Result) -> float:
    """The last time stamp of a timed plan."""
    return float(np.asarray(res.times)[-1])


def main(argv: Sequence[str] | None = None) -> int:
    """Draw both figures into ``--out``."""
    args = parser("python docs/figures/team.py", __doc__, DEFAULT_OUT).parse_args(argv)
    prob = op.load_problem("paper-warehouse")
    warm = op.solve(prob, "hybrid-qp", rng=0)
    nlp = op.get_solver("formation-nlp").reference(prob, warm)  # type: ignore[attr-defined]
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.5))
    for ax, res, title in ((axes[0], warm, "hybrid-qp"), (axes[1], nlp, "formation-nlp")):
        plot_result(res, problem=prob, ax=ax, legend="corner")
        ax.set_title(f"{title}: end {_end(res):.1f} s, formation RMSE "
                     f"{res.metrics['formation_rmse']:.2f}")
    fig.tight_layout()
    save(fig, args.out / "team-nlp-warehouse.png", 100)
    pts = []
    for w in WEIGHTS:
        r = op.get_solver("formation-nlp", w_formation=w).reference(  # type: ignore[attr-defined]
            prob, warm)
        pts.append((w, _end(r), float(r.metrics["formation_rmse"]),
                    bool(r.extras.get("kept_warm_start"))))
        print(f"w_formation {w:g}: end {pts[-1][1]:.2f} s, formation RMSE {pts[-1][2]:.3f}"
              f"{' (kept the warm start)' if pts[-1][3] else ''}")
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot([p[1] for p in pts], [p[2] for p in pts], "o-", color="C1")
    for w, t, e, _ in pts:
        ax.annotate(f"w = {w:g}", (t, e), textcoords="offset points", xytext=(6, 4),
                    fontsize=8)
    ax.plot([_end(warm)], [warm.metrics["formation_rmse"]], "s", color="C0",
            label="warm start (hybrid-qp)")
    ax.set_xlabel("end of the plan (s): the leader at its goal, the followers at their slots")
    ax.set_ylabel("formation RMSE")
    ax.set_title("paper-warehouse: arrival against formation keeping")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, args.out / "team-nlp-tradeoff.png", 100)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
