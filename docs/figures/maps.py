"""The figure of docs/maps.md: an imported ROS map, cropped, with the planners' paths
(headless; run from anywhere).

    python docs/figures/maps.py                 # into runs/maps-figures/
    python docs/figures/maps.py --out docs/img  # refresh the docs' figure

Writes a ROS ``map_server`` map (``office.yaml`` + ``office.pgm``, drawn here, the same bytes on
every run: a 9 x 6 m office of two rooms, a corridor, furniture and pillars mapped at 5 cm in a
20 x 16 m image of unknown cells, as a SLAM node saves a small mapped area; a temporary
directory, or :func:`write_office_map`), imports it with :func:`optplan.maps.import_map`
(``crop="auto"`` crops it: the unknown margin is far above 25 % of the image), solves one
query across the office with ``visgraph``, ``ipso`` and ``hybrid-qp`` (seed ``--seed``) and
writes ``maps-ros-cropped.png``: on the left
the whole image in world coordinates with the box the import cropped to, on the right the
cropped scenario (:func:`optplan.plot.plot_problem`) with the three paths, each labelled with
its status and length.  It prints one line per planner, then each planner's outcome over
seeds ``0 .. --seeds - 1`` (solved share, median and worst ratio to the certified optimum over
the solved runs).
"""

from __future__ import annotations

import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from figure_io import parser, save

import optplan as op

__all__ = ["write_office_map", "main", "SOLVERS", "START", "GOAL"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "maps-figures"
#: the planners drawn, in drawing order
SOLVERS = ("visgraph", "ipso", "hybrid-qp")
#: the query: from the left room's upper corner, through the corridor, to the right room (m)
START, GOAL = (-4.0, 2.4), (4.3, 0.6)
RADIUS = 0.2
#: colour, line width, opacity: the optimum wide and pale under the others (ipso's path nearly
#: coincides with it)
_STYLE = {"visgraph": ("#1b7837", 4.5, 0.45), "ipso": ("#1f77b4", 1.6, 1.0),
          "hybrid-qp": ("#ff7f0e", 1.2, 1.0)}

#: image size (rows, columns) at 5 cm: 16 x 20 m; the office's free floor is 6 x 9 m
_SHAPE, _RES = (320, 400), 0.05
_UNKNOWN, _FREE, _WALL = 205, 254, 0


def _office() -> np.ndarray:
    """The PGM's pixels (row 0 at the top): unknown, the office's walls and free floor,
    an inner wall with a door, a corridor wall, furniture and pillars."""
    img = np.full(_SHAPE, _UNKNOWN, dtype=np.uint8)
    r0, c0, h, w = 100, 110, 124, 184  # the office with its outer wall, 6.2 x 9.2 m
    img[r0:r0 + h, c0:c0 + w] = _WALL
    img[r0 + 2:r0 + h - 2, c0 + 2:c0 + w - 2] = _FREE
    img[r0 + 2:r0 + 84, c0 + 90:c0 + 94] = _WALL      # inner wall, rooms left and right ...
    img[r0 + 100:r0 + h - 2, c0 + 90:c0 + 94] = _WALL  # ... with a 0.8 m door
    img[r0 + 84:r0 + 88, c0 + 2:c0 + 70] = _WALL      # the left room's corridor wall
    img[r0 + 84:r0 + 88, c0 + 110:c0 + w - 2] = _WALL  # the right room's, open on the left
    for r, c, dh, dw in ((r0 + 20, c0 + 20, 16, 36), (r0 + 50, c0 + 46, 14, 14),
                         (r0 + 30, c0 + 120, 30, 12), (r0 + 14, c0 + 150, 12, 22),
                         (r0 + 56, c0 + 140, 10, 26)):  # desks, a cupboard, tables
        img[r:r + dh, c:c + dw] = _WALL
    for r, c in ((r0 + 104, c0 + 40), (r0 + 104, c0 + 140)):  # pillars in the corridor
        img[r:r + 6, c:c + 6] = _WALL
    img[r0 + 8:r0 + 12, c0 + 60:c0 + 64] = _UNKNOWN  # a spot the scan never saw
    return img


def write_office_map(directory: str | Path) -> Path:
    """Write ``office.pgm`` and ``office.yaml`` (``map_server`` format, origin at the image's
    lower-left corner, ``(-10, -8)``) into ``directory``; the YAML's path."""
    from PIL import Image

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    Image.fromarray(_office(), mode="L").save(d / "office.pgm")
    y = d / "office.yaml"
    y.write_text("image: office.pgm\nresolution: 0.05\norigin: [-10.0, -8.0, 0.0]\n"
                 "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
    return y


def _draw_image(ax: Any, info: dict[str, Any]) -> None:
    """The whole image in world coordinates and the box the import cropped to."""
    img = _office()
    x0, y0 = -10.0, -8.0
    x1, y1 = x0 + _SHAPE[1] * _RES, y0 + _SHAPE[0] * _RES
    ax.imshow(img, cmap="gray", vmin=0, vmax=255, extent=(x0, x1, y0, y1),
              interpolation="nearest")
    (ra, rb), (ca, cb) = info["crop"]["rows"], info["crop"]["cols"]
    bx0, bx1 = x0 + ca * _RES, x0 + cb * _RES
    by0, by1 = y1 - rb * _RES, y1 - ra * _RES
    ax.plot([bx0, bx1, bx1, bx0, bx0], [by0, by0, by1, by1, by0], color="#d95f02", lw=1.5,
            label="cropped to")
    ax.set_title(f"office.pgm: {_SHAPE[1] * _RES:g} x {_SHAPE[0] * _RES:g} m, "
                 f"{100 * info['crop']['margin']:.0f} % outside the known cells", fontsize=10)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="lower right", fontsize=8)


def main(argv: list[str] | None = None) -> int:
    ap = parser("python docs/figures/maps.py", __doc__, DEFAULT_OUT, dpi=100)
    ap.add_argument("--seed", type=int, default=0, help="seed of ipso and hybrid-qp (default 0)")
    ap.add_argument("--seeds", type=int, default=10,
                    help="seeds of the printed outcome table (default 10)")
    a = ap.parse_args(argv)
    if a.seeds < 1:
        ap.error(f"--seeds must be >= 1, got {a.seeds}")
    from optplan import plot
    from optplan.maps import Robots, import_map

    info: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:  # the map is written, then imported
        prob = import_map(write_office_map(tmp), Robots(radius=RADIUS, start=START, goal=GOAL),
                          info=info)
    fig = plot.new_figure(size=(13.0, 4.6), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=[1.0, 1.25])
    _draw_image(left, info)
    plot.plot_problem(prob, ax=right, labels=False)
    right.plot(*START, "o", color="black", ms=7, label="start")
    right.plot(*GOAL, "*", color="black", ms=11, label="goal")
    for name in SOLVERS:
        res = op.solve(prob, name, rng=a.seed, reference=True)
        p = np.asarray(res.paths[prob.leader.id], dtype=float)
        length = res.metrics.get("length", float("nan"))
        ratio = res.metrics.get("ratio_to_optimum", float("nan"))
        colour, lw, alpha = _STYLE[name]
        right.plot(p[:, 0], p[:, 1], "-", color=colour, lw=lw, alpha=alpha, zorder=7,
                   label=f"{name}: {res.status.value}, {length:.2f} m")
        print(f"{name:10s} {res.status.value:9s} length {length:.3f} m, ratio {ratio:.4f}, "
              f"collisions {res.metrics.get('collisions', 0)}, {res.wall_time:.2f} s")
    right.set_title(f"imported and cropped: {prob.name}, bounds "
                    f"{', '.join(f'{v:g}' for v in prob.bounds)}", fontsize=10)
    right.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    save(fig, a.out / "maps-ros-cropped.png", a.dpi)
    print()
    _outcomes(prob, a.seeds)
    return 0


def _outcomes(prob: op.Problem, seeds: int) -> None:
    """Print each planner's solved share, median and worst ratio over ``seeds`` seeds."""
    print(f"| planner | solved (seeds 0..{seeds - 1}) | ratio median | ratio worst | statuses |")
    print("|---|---:|---:|---:|---|")
    for name in SOLVERS:
        runs = [op.solve(prob, name, rng=k, reference=True) for k in range(seeds)]
        ok = [r.metrics["ratio_to_optimum"] for r in runs if r.success]
        count = Counter(r.status.value for r in runs)
        statuses = ", ".join(f"{s} {n}" for s, n in sorted(count.items()))
        med, worst = (f"{np.median(ok):.4f}", f"{max(ok):.4f}") if ok else ("-", "-")
        print(f"| {name} | {len(ok)}/{seeds} | {med} | {worst} | {statuses} |")


if __name__ == "__main__":
    raise SystemExit(main())
