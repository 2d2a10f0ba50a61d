"""The figure of docs/solvers/visgraph.md (headless; run from anywhere).

    python docs/figures/visgraph.py                 # into runs/visgraph-figures/
    python docs/figures/visgraph.py --out docs/img  # refresh the docs' figure

Writes into ``--out`` (default ``runs/visgraph-figures``; the docs' copies in ``docs/img/``
change only when ``--out`` names that folder):

* ``visgraph-paper-env.png``: the certified (arc-exact) shortest paths on ``paper-env1`` and
  ``paper-env2`` over the true obstacles, drawn with :mod:`optplan.plot`;
* ``visgraph-chains.png``: the built graph of ``paper-env1`` (its free tangents, the
  departure points chained along the circles) and a query's path through it.
"""

from __future__ import annotations

from pathlib import Path

from figure_io import parser, save

import optplan as op

__all__ = ["main"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "visgraph-figures"


def main(argv: list[str] | None = None) -> int:
    a = parser("python docs/figures/visgraph.py", __doc__, DEFAULT_OUT, dpi=100).parse_args(argv)
    from optplan import plot

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
    save(fig, a.out / "visgraph-paper-env.png", a.dpi)
    save(_chains_figure(), a.out / "visgraph-chains.png", a.dpi)
    return 0


def _chains_figure():
    """The built tangent graph of ``paper-env1`` for its robot's radius, and one query."""
    import numpy as np
    from matplotlib.collections import LineCollection

    from optplan import plot
    from optplan.geometry.tangent.tangent_graph import TangentGraph

    prob = op.catalog.load_problem("paper-env1")
    r = prob.leader
    oset = prob.obstacle_set(r.radius, known_only=True)
    graph = TangentGraph(oset).build()
    ch = graph.chains
    fr = oset.frame
    fig = plot.new_figure(size=(10.0, 7.0), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    plot.plot_problem(prob, ax=ax)
    C = graph.circles  # each tangent's arrival point on its circle
    arrival = C.center[ch.a_circle] + C.rho[ch.a_circle] * np.exp(1j * ch.a_theta)
    seg = np.stack([fr.world(np.stack([z.real, z.imag], 1)) for z in (ch.point, arrival)],
                   axis=1)
    ax.add_collection(LineCollection(list(seg), colors="0.55", linewidths=0.35, zorder=1,
                                     label=f"free tangents ({ch.n_edges})"))
    dep = fr.world(np.stack([ch.point.real, ch.point.imag], 1))
    ax.plot(dep[:, 0], dep[:, 1], ".", ms=2.5, color="tab:orange", zorder=2,
            label="departure points (the nodes)")
    res = graph.shortest_path(r.start, r.goal)
    ax.plot(res.polyline[:, 0], res.polyline[:, 1], "-", color="tab:blue", lw=2.2, zorder=3,
            label=f"shortest path {res.length:.3f}")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.set_title("paper-env1: the built tangent graph (chains of departure points) and one "
                 "query", fontsize=10)
    return fig


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
