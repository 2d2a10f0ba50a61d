"""Figures of docs/solvers/apf.md: each trap and both paper environments, apf vs sa-apf.

Run: ``python docs/figures/apf.py [--seed 0] [--out runs]`` (writes
``apf-traps.png``, ``apf-env1.png`` and ``apf-env2.png`` into ``--out``; ``--out docs/img``
regenerates the docs' figures).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from figure_io import parser, save

import optplan as op
from optplan.plot import new_figure, plot_problem

STYLE = {"apf-paper": ("tab:red", "basic APF"), "sa-apf-paper": ("tab:blue", "SA-APF")}


def _times(r: op.Result) -> np.ndarray:
    """``r.times`` (the APF presets time-stamp their paths)."""
    if r.times is None:
        raise ValueError(f"{r.solver} on {r.problem}: the result has no time stamps")
    return r.times


def draw(ax, name: str, seed: int = 0) -> None:
    prob = op.load_problem(name)
    results = {s: op.solve(prob, s, rng=seed) for s in STYLE}
    t_end = max(float(_times(r)[-1]) for r in results.values())
    plot_problem(prob, ax=ax, t_end=t_end, labels=False)
    for s, r in results.items():
        c, lab = STYLE[s]
        p = r.path
        ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=1.4,
                label=f"{lab}: {r.status.value}")
        ax.plot(*p[-1], "o", color=c, ms=4)
        for m in r.extras.get("minima", {}).get(prob.leader.id, [])[:1]:
            ax.plot(*m, "x", color=c, ms=8, mew=2)
    ax.set_title(name, fontsize=10)
    ax.legend(loc="lower left", fontsize=7)


def main(argv: list[str] | None = None) -> int:
    ap = parser("python docs/figures/apf.py", __doc__, Path("runs"))
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    fig = new_figure(size=(11, 6.4))
    axes = fig.subplots(2, 2)
    for ax, name in zip(axes.ravel(), ["trap-saddle", "trap-gnron", "trap-channel", "trap-u"]):
        draw(ax, name, a.seed)
    fig.tight_layout()
    save(fig, a.out / "apf-traps.png", 90)
    for name in ("paper-apf-env1", "paper-apf-env2"):
        fig = new_figure(size=(6, 6))
        draw(fig.subplots(), name, a.seed)
        fig.tight_layout()
        save(fig, a.out / f"apf-{name.removeprefix('paper-apf-')}.png", 90)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
