"""The figure of docs/time.md: the time bracket closing (headless; run from anywhere).

    python docs/figures/time_bracket.py                 # into runs/time-figures/
    python docs/figures/time_bracket.py --out docs/img  # refresh the docs' figure

Writes ``time-bracket.png`` into ``--out`` (default ``runs/time-figures``): the door scene
(:func:`optplan.time_families.door_scene`) solved by ``time-bracket`` with ``gap_tol = 0`` and
the given ``--time-limit``; left, the map with the plan of the upper side; right, the upper
and lower sides of the bracket against the seconds spent, one step per level, with ``sipp``'s
arrival.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from figure_io import parser, save  # noqa: E402

import optplan as op  # noqa: E402
from optplan.plot import plot_problem  # noqa: E402
from optplan.time_families import door_scene  # noqa: E402

__all__ = ["main"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "time-figures"


def main(argv: Sequence[str] | None = None) -> Path:
    ap = parser("python docs/figures/time_bracket.py", __doc__, DEFAULT_OUT)
    ap.add_argument("--time-limit", type=float, default=10.0)
    a = ap.parse_args(argv)
    p = door_scene()
    sipp = op.solve(p, "sipp")
    res = op.solve(p, "time-bracket", gap_tol=0.0, time_limit=a.time_limit)
    levels = res.extras["time_bracket"]["levels"]
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.2),
                                   gridspec_kw={"width_ratios": [1.5, 1]})
    plot_problem(p, ax=ax0)
    ax0.plot(*res.paths["r"].T, "-", color="tab:green", lw=1.5, label="upper side's plan")
    ax0.plot(*sipp.paths["r"].T, ":", color="tab:gray", lw=1.2, label="sipp's plan")
    ax0.legend(loc="lower left", fontsize=8)
    ax0.set_title("the door scene")
    t = [lv["seconds"] for lv in levels]
    ax1.step(t, [lv["upper"] for lv in levels], where="post", color="tab:green",
             label="upper (valid plan)")
    ax1.step(t, [lv["lower"] for lv in levels], where="post", color="tab:blue",
             label="lower (certified bound)")
    ax1.axhline(sipp.metrics["arrival_time"], ls=":", color="tab:gray", label="sipp")
    for lv in levels:
        ax1.annotate(str(lv["level"]), (lv["seconds"], lv["upper"]), fontsize=7,
                     xytext=(2, 3), textcoords="offset points")
    ax1.set_xscale("log")
    ax1.set_xlabel("seconds (log)")
    ax1.set_ylabel("arrival (s)")
    ax1.set_title(f"the bracket per level: gap {100 * res.metrics['arrival_gap']:.2f} %")
    ax1.legend(fontsize=8)
    fig.tight_layout()
    return save(fig, a.out / "time-bracket.png", 110)


if __name__ == "__main__":
    main()
