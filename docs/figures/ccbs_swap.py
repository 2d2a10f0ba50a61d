"""The figure of docs/solvers/ccbs.md: a swap solved by ``ccbs`` (headless; run from anywhere).

    python docs/figures/ccbs_swap.py                 # into runs/ccbs-figures/
    python docs/figures/ccbs_swap.py --out docs/img  # refresh the docs' figure

Writes ``ccbs-swap.png`` into ``--out`` (default ``runs/ccbs-figures``): two discs swap ends
of a corridor with a side pocket; left, the roadmap with the robots at the closest approach
of the optimal plan; right, their distance against time with the contact distance.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from figure_io import parser, save  # noqa: E402

import optplan as op  # noqa: E402
from optplan.geometry.timing import positions_at  # noqa: E402
from optplan.problem import RoadmapGraph, parse_problem  # noqa: E402

__all__ = ["main", "swap_problem"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "ccbs-figures"


def swap_problem() -> op.Problem:
    """The corridor 0 - 1 - 2 - 3 - 4 with a pocket above node 2; a and b swap ends."""
    nodes = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [2, 1]], float)
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [2, 5]])
    p = parse_problem({"name": "ccbs-swap", "bounds": [-0.5, -0.6, 4.5, 1.6],
                       "robots": [{"id": "a", "start": [0, 0], "goal": [4, 0], "radius": 0.3},
                                  {"id": "b", "start": [4, 0], "goal": [0, 0], "radius": 0.3}]})
    return p.replaced(roadmap=RoadmapGraph(nodes, edges))


def main(argv: Sequence[str] | None = None) -> Path:
    a = parser("python docs/figures/ccbs_swap.py", __doc__, DEFAULT_OUT).parse_args(argv)
    p = swap_problem()
    res = op.solve(p, "ccbs")
    g = p.roadmap
    assert g is not None
    t = np.linspace(0.0, float(res.times[-1]), 2001)
    pos = {k: positions_at(res.times, v, t) for k, v in res.paths.items()}
    dist = np.hypot(*(pos["a"] - pos["b"]).T)
    k = int(np.argmin(dist))
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 3.6),
                                   gridspec_kw={"width_ratios": [1.4, 1]})
    for i, j in g.edges:
        ax0.plot(*g.nodes[[i, j]].T, "-", color="0.75", lw=6, solid_capstyle="round", zorder=0)
    ax0.plot(*g.nodes.T, "o", color="0.4", ms=4)
    for rid, color in (("a", "tab:blue"), ("b", "tab:orange")):
        ax0.plot(*res.paths[rid].T, "-", color=color, lw=1.2, label=f"{rid}'s path")
        ax0.add_patch(plt.Circle(pos[rid][k], 0.3, color=color, alpha=0.45))
    ax0.set_aspect("equal")
    ax0.set_xlim(-0.5, 4.5)
    ax0.set_ylim(-0.6, 1.6)
    ax0.set_title(f"closest approach, t = {t[k]:.3f} s (discs touch)")
    ax0.legend(loc="upper right", fontsize=8)
    ax1.plot(t, dist, color="tab:green", label="distance of the centres")
    ax1.axhline(0.6, ls=":", color="tab:red", label="contact distance 0.6")
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("distance")
    m = res.metrics
    ax1.set_title(f"sum of arrivals {m['sum_of_arrivals']:.4f} s (a {m['arrival_times']['a']:.3f}"
                  f", b {m['arrival_times']['b']:.3f})", fontsize=9)
    ax1.legend(fontsize=8)
    fig.tight_layout()
    return save(fig, a.out / "ccbs-swap.png", 110)


if __name__ == "__main__":
    main()
