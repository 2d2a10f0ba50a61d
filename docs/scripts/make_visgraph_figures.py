"""Regenerate the figure of docs/solvers/visgraph.md (headless; run from the repository root).

    .venv/bin/python docs/scripts/make_visgraph_figures.py

Writes docs/img/visgraph-paper-env.png: the certified (arc-exact) shortest paths on paper-env1
and paper-env2 over the true obstacles, drawn with optplan.plot.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import optplan as op  # noqa: E402
from optplan import plot  # noqa: E402

IMG = Path(__file__).resolve().parents[1] / "img"


def main() -> None:
    IMG.mkdir(exist_ok=True)
    fig = plot.new_figure(size=(11.0, 5.5))
    for k, name in enumerate(("paper-env1", "paper-env2")):
        ax = fig.add_subplot(1, 2, k + 1)
        res = op.solve(name, "visgraph")
        plot.plot_result(res, ax=ax)
        m = res.metrics
        ax.set_title(f"{name}: {res.status}\nexact optimum {m['optimum']:.3f}, "
                     f"returned polyline {m['length']:.3f}", fontsize=10)
    fig.tight_layout()
    out = IMG / "visgraph-paper-env.png"
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
