"""Figures of docs/solvers/formation.md: both formation solvers on paper-formation and
paper-warehouse (trajectories, formation snapshots, formation error over time).

    python docs/figures/formation.py                  # into runs/
    python docs/figures/formation.py --out docs/img   # the docs' figures

Writes ``formation-<scene>.png`` per scene (seed 0, leader reference by ``visgraph``) into
``--out`` (default ``runs/``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, cast

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from figure_io import parser, save  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

import optplan as op  # noqa: E402

if TYPE_CHECKING:
    from shapely.geometry import Polygon

SCENES = ("paper-formation", "paper-warehouse")
SOLVERS = (("leader-follower-paper", "leader-follower-paper (eqs 39-52)"),
           ("formation-qp", "formation-qp (CBF QP)"))


def draw(ax, prob: op.Problem, res: op.Result, title: str, n_snap: int = 10) -> None:
    if res.times is None:
        raise ValueError(f"{res.solver} on {prob.name}: the result has no time stamps")
    times = res.times
    for o in prob.obstacles:
        colour = "0.25" if o.known else "0.6"
        if o.is_circle:  # exact centre and radius (circles have no polygon geometry)
            # a circle's center and radius are set (Obstacle's invariant)
            ax.add_patch(Circle(tuple(cast(np.ndarray, o.center)), cast(float, o.radius),
                                color=colour, alpha=0.8, lw=0))
        else:  # a polygon or rectangle: geometry is set (Obstacle's invariant)
            x, y = cast("Polygon", o.geometry).exterior.xy
            ax.fill(x, y, color=colour, alpha=0.8, lw=0)
    for d in prob.dynamic_obstacles:
        for t in times[:: max(1, len(times) // 8)]:
            x, y = d.geometry_at(t).exterior.xy
            ax.plot(x, y, color="m", lw=0.5, alpha=0.6)
    ref = res.extras.get("reference")
    if ref is not None:
        ax.plot(ref[:, 0], ref[:, 1], "--", color="c", lw=0.8, label="reference")
    colours = ("tab:blue", "tab:orange", "tab:green")
    ids = list(res.paths)
    for k, rid in enumerate(ids):
        p = res.paths[rid]
        ax.plot(p[:, 0], p[:, 1], color=colours[k % 3], lw=1.2, label=rid)
    n = len(times)
    for k in np.linspace(0, n - 1, n_snap).astype(int):
        P = np.array([res.paths[i][k] for i in ids])
        ax.plot(np.r_[P[:, 0], P[0, 0]], np.r_[P[:, 1], P[0, 1]], ":", color="k", lw=0.7)
    x0, y0, x1, y1 = prob.bounds
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    m = res.metrics
    ax.set_title(f"{title}\n{res.status.value}: RMSE {m.get('formation_rmse', np.nan):.1f}, "
                 f"min sep {m.get('min_separation', np.nan):.1f}, "
                 f"collisions {m['collisions']}", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")


def main(argv: list[str] | None = None) -> None:
    ap = parser("python docs/figures/formation.py", __doc__, Path("runs"))
    ap.add_argument("--scenes", default=",".join(SCENES))
    args = ap.parse_args(argv)
    for scene in args.scenes.split(","):
        prob = op.load_problem(scene)
        fig, axes = plt.subplots(1, 3, figsize=(15, 5.2),
                                 gridspec_kw={"width_ratios": [1, 1, 0.9]})
        for ax, (solver, label) in zip(axes[:2], SOLVERS):
            res = op.solve(prob, solver, rng=0, path_solver="visgraph")
            draw(ax, prob, res, f"{scene}: {label}")
            fe = res.history["formation_error"]
            if res.times is None:
                raise ValueError(f"{solver} on {scene}: the result has no time stamps")
            axes[2].plot(res.times[: len(fe)], fe, label=label, lw=1)
        axes[2].set_xlabel("time (s)")
        axes[2].set_ylabel("worst follower distance to its slot")
        axes[2].set_title("formation error (controller frame)", fontsize=9)
        axes[2].legend(fontsize=7)
        fig.tight_layout()
        save(fig, args.out / f"formation-{scene}.png", 90)


if __name__ == "__main__":
    main()
