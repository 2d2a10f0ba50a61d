"""The figure of docs/solvers/visgraph.md (headless; run from anywhere).

    python -m optplan.experiments.visgraph_figures                 # into runs/visgraph-figures/
    python -m optplan.experiments.visgraph_figures --out docs/img  # refresh the docs' figure

Writes ``visgraph-paper-env.png`` into ``--out`` (default ``runs/visgraph-figures``; the docs'
copy in ``docs/img/`` changes only when ``--out`` names that folder): the certified
(arc-exact) shortest paths on ``paper-env1`` and ``paper-env2`` over the true obstacles, drawn
with :mod:`optplan.plot`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import optplan as op

__all__ = ["main"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "visgraph-figures"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m optplan.experiments.visgraph_figures",
                                 description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT,
                    help=f"output folder (default {DEFAULT_OUT})")
    ap.add_argument("--dpi", type=float, default=100, help="PNG resolution (default 100)")
    a = ap.parse_args(argv)
    from optplan import plot

    a.out.mkdir(parents=True, exist_ok=True)
    # constrained layout: each panel's legend goes outside it, on its right (no map corner is
    # free of obstacles on these scenes)
    fig = plot.new_figure(size=(12.5, 5.5), layout="constrained")
    for k, name in enumerate(("paper-env1", "paper-env2")):
        ax = fig.add_subplot(1, 2, k + 1)
        res = op.solve(name, "visgraph")
        plot.plot_result(res, ax=ax)
        m = res.metrics
        ax.set_title(f"{name}: {res.status}\nexact optimum {m['optimum']:.3f}, "
                     f"returned polyline {m['length']:.3f}", fontsize=10)
    out = a.out / "visgraph-paper-env.png"
    fig.savefig(out, dpi=a.dpi)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
