"""The figures of ``docs/solvers/hybrid.md``, written into ``runs/`` (or ``--out``).

Everything is drawn by :mod:`optplan.plot` (the functions behind ``optplan plot`` and
``optplan animate``) from results computed here with fixed seeds::

    python docs/figures/hybrid.py [--seed 0] [--out runs]
    python docs/figures/hybrid.py --out docs/img      # regenerate the docs

Legends are placed outside the axes (they covered the warehouse's top-right corner).

Figures:

* ``hybrid-three-way.png``: paper Figs 28-30 on ``paper-hybrid``: IPSO alone (``ipso``),
  SA-APF alone, hybrid (global path dashed, inflection points as diamonds).
* ``hybrid-paper-hybrid.gif``: the hybrid run on ``paper-hybrid`` with the moving obstacles.
* ``hybrid-formation.png`` / ``.gif``: ``hybrid-paper`` on ``paper-formation`` (Fig. 32).
* ``hybrid-warehouse.png`` / ``.gif``: ``hybrid-paper`` on ``paper-warehouse`` (Fig. 34).
* ``hybrid-formation-error.png``: follower position error (distance to the L-phi slot) and
  the separation over time for both formation runs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from figure_io import parser, save

import optplan as op
from optplan.metrics import formation_errors
from optplan.plot import animate, new_figure, plot_result

OVER: dict = {}  # stage overrides (--global-solver)


def three_way(seed: int, out: Path) -> None:
    prob = op.load_problem("paper-hybrid")
    fig = new_figure(size=(16.5, 5.8))
    axes = fig.subplots(1, 3)
    # "IPSO alone" is the hybrids' global stage run by itself: the ``ipso`` preset (the
    # literal ``ipso-paper`` never finds a collision-free path, docs/solvers/pso.md), as in
    # ``optplan bench --tag hybrid``.
    for ax, (label, solver) in zip(axes, [("IPSO alone", "ipso"),
                                          ("SA-APF alone", "sa-apf-paper"),
                                          ("hybrid", "hybrid-paper")]):
        if solver == "ipso" and OVER:
            solver = OVER["global_solver"]
        res = op.solve(prob, solver, rng=seed, **(OVER if solver == "hybrid-paper" else {}))
        plot_result(res, problem=prob, ax=ax, snapshot_every=0)
        m = res.metrics
        ax.set_title(f"{label} ({solver}): {res.status.value}\nlength {m['length']:.1f}, "
                     f"collisions {m['collisions']}", fontsize=10)
        if solver == "hybrid-paper":
            gif = out / "hybrid-paper-hybrid.gif"
            animate(res, gif, problem=prob, fps=10, max_frames=100)
            print(f"wrote {gif}")
    fig.tight_layout()
    save(fig, out / "hybrid-three-way.png", 90)


def formation(seed: int, out: Path) -> dict[str, op.Result]:
    runs = {}
    for scene, stem in (("paper-formation", "hybrid-formation"),
                        ("paper-warehouse", "hybrid-warehouse")):
        prob = op.load_problem(scene)
        res = op.solve(prob, "hybrid-paper", rng=seed, **OVER)
        runs[scene] = res
        if res.times is None:
            raise ValueError(f"hybrid-paper on {scene}: the result has no time stamps")
        fig = new_figure(size=(9.5, 7.0), layout="constrained")
        ax = fig.subplots()
        plot_result(res, problem=prob, ax=ax, snapshot_every=max(1, len(res.times) // 10),
                    legend="outside")
        save(fig, out / f"{stem}.png", 90)
        gif = out / f"{stem}.gif"
        animate(res, gif, problem=prob, fps=10, max_frames=120)
        print(f"wrote {gif}")
    return runs


def formation_error(runs: dict[str, op.Result], out: Path) -> None:
    fig = new_figure(size=(11, 6.5))
    axes = fig.subplots(2, len(runs), squeeze=False)
    for j, (scene, res) in enumerate(runs.items()):
        prob = op.load_problem(scene)
        form = prob.formation
        if form is None:
            raise ValueError(f"{scene}: not a formation scene")
        fe = formation_errors(prob, res.paths)["position"]
        t = res.times
        if t is None:
            raise ValueError(f"hybrid-paper on {scene}: the result has no time stamps")
        print(f"{scene}: largest follower slot error " + ", ".join(
            f"{f.id} {fe[:, k].max():.1f} at t = {t[int(np.argmax(fe[:, k]))]:.1f} s"
            for k, f in enumerate(form.followers)))
        ax = axes[0, j]
        for k, f in enumerate(form.followers):
            ax.plot(t, fe[:, k], label=f"{f.id} (L = {f.L:g})")
        ax.set_title(f"{scene}: follower distance to its slot", fontsize=10)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("error (map units)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        ids = list(res.paths)
        P = np.stack([res.paths[i] for i in ids], axis=1)
        ax = axes[1, j]
        for a in range(len(ids)):
            for b in range(a + 1, len(ids)):
                ax.plot(t, np.hypot(*(P[:, a] - P[:, b]).T), label=f"{ids[a]}-{ids[b]}")
        ax.axhline(form.safety_distance, color="r", ls="--", lw=1,
                   label="safety distance")
        ax.set_title(f"{scene}: pairwise separation", fontsize=10)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("distance (map units)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    save(fig, out / "hybrid-formation-error.png", 90)


def main(argv: list[str] | None = None) -> int:
    ap = parser("python docs/figures/hybrid.py", __doc__, Path("runs"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--global-solver", default=None,
                    help="override the hybrids' global stage and the IPSO-alone panel")
    a = ap.parse_args(argv)
    if a.global_solver:
        OVER["global_solver"] = a.global_solver
    three_way(a.seed, a.out)
    formation_error(formation(a.seed, a.out), a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
