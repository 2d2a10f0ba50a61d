"""Figures of docs/solvers/apf.md: each trap and both paper environments, apf vs sa-apf.

Run: ``.venv/bin/python docs/scripts/make_apf_figures.py`` (writes ``docs/img/apf-*.png``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import optplan as op  # noqa: E402
from optplan.plot import plot_problem  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "img"
STYLE = {"apf-paper": ("tab:red", "basic APF"), "sa-apf-paper": ("tab:blue", "SA-APF")}


def draw(ax, name: str, seed: int = 0) -> None:
    prob = op.load_problem(name)
    results = {s: op.solve(prob, s, rng=seed) for s in STYLE}
    t_end = max(float(r.times[-1]) for r in results.values())
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


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.4))
    for ax, name in zip(axes.ravel(), ["trap-saddle", "trap-gnron", "trap-channel", "trap-u"]):
        draw(ax, name)
    fig.tight_layout()
    fig.savefig(OUT / "apf-traps.png", dpi=90)
    plt.close(fig)
    for name in ("paper-apf-env1", "paper-apf-env2"):
        fig, ax = plt.subplots(figsize=(6, 6))
        draw(ax, name)
        fig.tight_layout()
        fig.savefig(OUT / f"apf-{name.removeprefix('paper-apf-')}.png", dpi=90)
        plt.close(fig)
    print("wrote", ", ".join(sorted(str(p.name) for p in OUT.glob("apf-*.png"))))


if __name__ == "__main__":
    main()
