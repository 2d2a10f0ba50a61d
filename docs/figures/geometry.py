"""The figure of docs/geometry.md: solids and the bounds wall (headless; run from anywhere).

    python docs/figures/geometry.py                 # into runs/geometry-figures/
    python docs/figures/geometry.py --out docs/img  # refresh the docs' figure

Writes ``geometry-solids.png`` into ``--out`` (default ``runs/geometry-figures``): three certified
(``visgraph``) paths, drawn with :mod:`optplan.plot`:

1. a wall drawn as two touching rectangles, a point robot: the straight line along the seam
   (what optplan 0.4 certified) and the certified path around the wall;
2. a wall drawn to the top edge, a robot of radius 1: the optimum runs between the wall's lower
   end and the bottom edge, touching both;
3. squares touching at corners only (pinch points): a point robot passes them, a robot of
   radius 1 goes round.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from figure_io import parser, save

import optplan as op

__all__ = ["main", "scenes"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "geometry-figures"


def _scene(name: str, rects: Sequence[tuple[float, float, float, float]], r: float,
           start: tuple[float, float], goal: tuple[float, float]) -> op.Problem:
    return op.parse_problem({
        "name": name, "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": list(start), "goal": list(goal), "radius": r}],
        "obstacles": [{"type": "rectangle", "name": f"{name}-{k}", "min": [x0, y0],
                       "max": [x1, y1]} for k, (x0, y0, x1, y1) in enumerate(rects)]})


def scenes() -> list[tuple[str, op.Problem]]:
    """The three panels' problems (title, problem); the third panel has two radii."""
    seam = _scene("seam", [(45, 10, 50, 90), (50, 10, 55, 90)], 0.0, (50, 4), (50, 96))
    edge = _scene("edge", [(45, 4, 55, 100)], 1.0, (10, 50), (90, 50))
    pinch = [(20 + 15 * k, 70 - 15 * k, 35 + 15 * k, 85 - 15 * k) for k in range(4)]
    return [("two touching rectangles, point robot", seam),
            ("a wall drawn to the top edge, r = 1", edge),
            ("squares touching at corners, r = 0", _scene("pinch", pinch, 0.0, (15, 15),
                                                         (90, 90))),
            ("squares touching at corners, r = 1", _scene("pinch", pinch, 1.0, (15, 15),
                                                         (90, 90)))]


def main(argv: list[str] | None = None) -> int:
    a = parser("python docs/figures/geometry.py", __doc__, DEFAULT_OUT, dpi=100).parse_args(argv)
    from optplan import plot

    fig = plot.new_figure(size=(16.0, 4.6), layout="constrained")
    for k, (title, prob) in enumerate(scenes()):
        ax = fig.add_subplot(1, 4, k + 1)
        res = op.solve(prob, "visgraph")
        plot.plot_result(res, ax=ax, legend=None)
        if k == 0:  # what 0.4 certified: straight along the seam
            ax.plot([50, 50], [4, 96], ls="--", color="tab:red", lw=1.2,
                    label="0.4: along the seam")
            ax.legend(loc="lower right", fontsize=7)
        m = res.metrics
        ax.set_title(f"{title}\n{res.status}, optimum {m['optimum']:.2f}", fontsize=9)
        ax.set_xlim(0, 100)
        ax.set_ylim(0, 100)
        ax.set_xticks(np.linspace(0, 100, 3))
        ax.set_yticks(np.linspace(0, 100, 3))
    save(fig, a.out / "geometry-solids.png", a.dpi)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
