"""The figure of docs/time.md: the (arc length, time) plane of a path (headless).

    python docs/figures/time_plane.py                 # into runs/time-figures/
    python docs/figures/time_plane.py --out docs/img  # refresh the docs' figure

Writes ``time-st-plane.png``: on the left the scene (a robot's two-segment path, a sliding door
and two discs crossing it, one of them bouncing), on the right the (arc length, time) plane of
that path: the forbidden regions (drawn from their exact sections at 800 arc lengths), the
full-speed line from the start and the fastest schedule of
:func:`optplan.geometry.timing.schedule.fastest_schedule` (full speed, waits where the regions
demand).
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
from optplan.geometry.timing.schedule import fastest_schedule  # noqa: E402
from optplan.geometry.timing.st_regions import path_regions, sections  # noqa: E402

__all__ = ["scene", "main"]

DEFAULT_OUT = Path("runs") / "time-figures"
PATH = np.array([[1.0, 5.0], [5.0, 6.5], [11.0, 5.0]])


def scene() -> op.Problem:
    """The figure's scene: a door closing on the second segment, two crossing discs."""
    return op.parse_problem({
        "name": "time-figure", "bounds": [0.0, 0.0, 12.0, 10.0],
        "robots": [{"id": "r", "start": PATH[0].tolist(), "goal": PATH[-1].tolist(),
                    "radius": 0.25, "max_speed": 1.0}],
        "dynamic_obstacles": [
            {"type": "polygon", "name": "door",
             "vertices": [[-0.5, -0.6], [0.5, -0.6], [0.5, 0.6], [-0.5, 0.6]],
             "waypoints": [[8, 9.5], [8, 5.8], [8, 5.8], [8, 9.5]], "times": [2, 5, 10, 11]},
            {"type": "circle", "name": "crosser", "radius": 0.5,
             "waypoints": [[3, 1], [3, 9]], "times": [-1, 4], "after": "bounce"},
            {"type": "circle", "name": "fast", "radius": 0.4, "waypoints": [[6, 0.5]],
             "times": [0.0], "velocity": [0.4, 1.6]}]})


def _plane(ax, prob: op.Problem, t_max: float) -> None:
    """Shade the forbidden regions of ``PATH`` in the (s, t) plane."""
    reg = path_regions(list(prob.dynamic_obstacles), PATH, prob.leader.radius, t_max)
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(PATH, axis=0).T))])
    colors = plt.get_cmap("tab10")
    for s in np.linspace(0.0, cum[-1], 800):
        sig = np.clip(s - reg.s0, 0.0, reg.ell)
        ok = (s >= reg.s0) & (s <= reg.s0 + reg.ell)
        lo, hi = sections(reg, sig)
        for k in np.flatnonzero(ok & ~np.isnan(lo)):
            ax.plot([s, s], [reg.ta[k] + lo[k], reg.ta[k] + hi[k]], lw=1.2, alpha=0.35,
                    color=colors(int(reg.mover[k])), solid_capstyle="butt")
    for x in cum[1:-1]:
        ax.axvline(x, color="0.6", lw=0.8, ls=":")


def main(argv: Sequence[str] | None = None) -> int:
    """Draw the figure into ``--out``."""
    args = parser("python docs/figures/time_plane.py", __doc__, DEFAULT_OUT).parse_args(argv)
    prob = scene()
    sch = fastest_schedule(prob, PATH)
    if sch.status != "scheduled" or sch.path is None or sch.times is None:
        raise SystemExit(f"no schedule: {sch.message}")
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8))
    for d in prob.dynamic_obstacles:
        tr = d.position(np.linspace(0, sch.times[-1], 300))
        left.plot(tr[:, 0], tr[:, 1], lw=1, ls="--", label=f"{d.name} (track)")
    left.plot(PATH[:, 0], PATH[:, 1], "k-", lw=2, label="the robot's path")
    left.set_aspect("equal")
    left.set_xlim(0, 12)
    left.set_ylim(0, 10)
    left.set_title("scene")
    left.legend(loc="lower right", fontsize=8)
    s_sched = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(sch.path, axis=0).T))])
    t_max = float(sch.times[-1]) + 2.0
    _plane(right, prob, t_max)
    right.plot(s_sched, sch.times, "k-", lw=2, label=f"fastest schedule ({sch.arrival:.2f} s)")
    right.plot([0, s_sched[-1]], [0, s_sched[-1] / prob.leader.max_speed], "k:", lw=1,
               label="full speed from t = 0")
    right.set_xlabel("arc length s")
    right.set_ylabel("time t (s)")
    right.set_ylim(0, t_max)
    right.set_title("(arc length, time) plane: forbidden regions and the schedule")
    right.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    out = save(fig, args.out / "time-st-plane.png", 110)
    print(f"{out}: arrival {sch.arrival:.4f} s, {len(sch.times)} points")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
