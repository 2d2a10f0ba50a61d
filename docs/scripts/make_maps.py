"""Generate the shipped occupancy-grid maps, their catalogue scenes and the docs figure.

    .venv/bin/python docs/scripts/make_maps.py            # maps, scenes, figure, timings
    .venv/bin/python docs/scripts/make_maps.py --no-figure

Writes (deterministic; run from anywhere):

* ``problems/maps/warehouse.png`` + ``warehouse.yaml``: a 40 x 30 m warehouse at 5 cm
  (800 x 600 cells), origin (-20, -15): outer walls, twelve rack blocks in six rows with 2.4 m
  aisles and a 3 m cross aisle, building columns, pallets in the staging area, a slanted
  conveyor, an unmapped (unknown) cage and a little lidar speckle;
* ``problems/maps/office.png`` + ``office.yaml``: a 30 x 20 m office floor at 5 cm
  (600 x 400 cells), origin (-5, -3): an unknown outside, walls, a corridor with rooms and
  0.9 m doors, a closed service shaft, a meeting table, desks in an open-plan area;
* ``problems/warehouse-grid.toml``, ``problems/office-floor.toml``: the maps imported with
  :func:`optplan.maps.import_map` (radius 0.3 m robots) and written with
  :func:`optplan.maps.write_toml`; the warehouse adds a forklift driving the cross aisle;
* ``docs/img/maps-warehouse.png``: the imported warehouse with its ``visgraph`` paths.

The images are ROS ``map_saver`` style: free 254, occupied 0, unknown 205 (``negate: 0``,
``mode: trinary``, thresholds 0.65 / 0.196).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from PIL import Image

import optplan as op
from optplan.maps import import_map, write_toml

ROOT = Path(__file__).resolve().parents[2]
MAPS = ROOT / "problems" / "maps"
IMG = ROOT / "docs" / "img"
FREE_PX, OCC_PX, UNK_PX = 254, 0, 205
RES = 0.05
RADIUS = 0.3

YAML = """image: {image}
resolution: {res}
origin: [{ox}, {oy}, 0.0]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
mode: trinary
"""


class Canvas:
    """An image in world coordinates (metres): row 0 at the top, ``origin`` the lower-left."""

    def __init__(self, width_m: float, height_m: float, origin: tuple[float, float]):
        self.w, self.h = round(width_m / RES), round(height_m / RES)
        self.ox, self.oy = origin
        self.px = np.full((self.h, self.w), FREE_PX, dtype=np.uint8)
        yy, xx = np.mgrid[0:self.h, 0:self.w]
        self.cx = self.ox + (xx + 0.5) * RES  # cell centres
        self.cy = self.oy + (self.h - yy - 0.5) * RES

    def rect(self, x0: float, y0: float, x1: float, y1: float, v: int = OCC_PX) -> None:
        """Cells whose centres lie in ``[x0, x1] x [y0, y1]``."""
        m = (self.cx >= x0) & (self.cx <= x1) & (self.cy >= y0) & (self.cy <= y1)
        self.px[m] = v

    def band(self, a: tuple[float, float], b: tuple[float, float], width: float,
             v: int = OCC_PX) -> None:
        """Cells within ``width / 2`` of the segment ``a b``."""
        a_, b_ = np.asarray(a, float), np.asarray(b, float)
        d = b_ - a_
        t = np.clip(((self.cx - a_[0]) * d[0] + (self.cy - a_[1]) * d[1]) / (d @ d), 0, 1)
        dist = np.hypot(self.cx - a_[0] - t * d[0], self.cy - a_[1] - t * d[1])
        self.px[dist <= width / 2] = v

    def walls(self, x0: float, y0: float, x1: float, y1: float, t: float) -> None:
        """A closed rectangular wall of thickness ``t`` whose outer edge is the rectangle."""
        self.rect(x0, y0, x1, y0 + t)
        self.rect(x0, y1 - t, x1, y1)
        self.rect(x0, y0, x0 + t, y1)
        self.rect(x1 - t, y0, x1, y1)

    def save(self, stem: str) -> Path:
        MAPS.mkdir(parents=True, exist_ok=True)
        Image.fromarray(self.px, mode="L").save(MAPS / f"{stem}.png", optimize=True)
        y = MAPS / f"{stem}.yaml"
        y.write_text(YAML.format(image=f"{stem}.png", res=RES, ox=self.ox, oy=self.oy),
                     encoding="utf-8")
        return y


# --------------------------------------------------------------------------------------
# the maps
# --------------------------------------------------------------------------------------

#: Rack rows of the warehouse: lower edges (m); racks are 1.2 m deep, aisles 2.4 m.
RACK_Y = [-7.0 + 3.6 * k for k in range(6)]


def warehouse() -> Path:
    c = Canvas(40.0, 30.0, (-20.0, -15.0))
    c.px[:] = UNK_PX  # outside the building: never seen by the lidar
    c.rect(-19.75, -14.75, 19.75, 14.75, FREE_PX)
    c.walls(-19.75, -14.75, 19.75, 14.75, 0.25)
    for y0 in RACK_Y:  # two rack blocks per row, cross aisle |x| < 1.5
        c.rect(-14.0, y0, -1.5, y0 + 1.2)
        c.rect(1.5, y0, 14.0, y0 + 1.2)
    for x in (-17.0, 17.0):  # building columns
        for y in (-10.0, -3.0, 4.0, 11.0):
            c.rect(x - 0.2, y - 0.2, x + 0.2, y + 0.2)
    for x0, y0 in ((-12.0, -13.5), (-9.5, -13.5), (-7.0, -13.5), (6.0, -13.8), (8.5, -13.8),
                   (-4.0, -11.0)):  # pallets in the staging area
        c.rect(x0, y0, x0 + 1.2, y0 + 1.0)
    c.band((15.8, -6.0), (18.6, 9.0), 0.5)  # a slanted conveyor along the east wall
    c.rect(-19.5, 9.5, -15.0, 14.5, UNK_PX)  # a caged area the map never saw
    c.walls(-19.5, 9.5, -15.0, 14.5, 0.1)
    rng = np.random.default_rng(15)
    free = np.argwhere(c.px == FREE_PX)
    for r, q in free[rng.choice(len(free), size=12, replace=False)]:
        c.px[r, q] = OCC_PX  # lidar speckle: single occupied cells
    return c.save("warehouse")


def office() -> Path:
    c = Canvas(30.0, 20.0, (-5.0, -3.0))
    c.px[:] = UNK_PX
    t = 0.15
    x0, y0, x1, y1 = -4.0, -2.0, 24.0, 16.0
    c.rect(x0, y0, x1, y1, FREE_PX)
    c.walls(x0, y0, x1, y1, t)
    # corridor 6 <= y <= 8 from the west wall to the open-plan area (x >= 16)
    c.rect(x0, 6.0 - t, 16.0, 6.0)
    c.rect(x0, 8.0, 16.0, 8.0 + t)
    c.rect(16.0 - t, y0, 16.0, 6.0)       # open-plan area's west wall, south part
    c.rect(16.0 - t, 8.0, 16.0, y1)       # ... north part; the corridor opens into it
    for xs in (0.0, 4.0, 8.0, 12.0):     # room partitions, north and south
        c.rect(xs - t / 2, 8.0, xs + t / 2, y1)
        c.rect(xs - t / 2, y0, xs + t / 2, 6.0)
    doors_n = [(-2.5, True), (1.5, True), (5.5, True), (9.5, False), (13.5, True)]
    doors_s = [(-2.5, True), (1.5, True), (5.5, False), (9.5, True), (13.5, True)]
    for x, open_ in doors_n:               # 0.9 m doors in the corridor walls
        if open_:
            c.rect(x - 0.45, 8.0 - 0.01, x + 0.45, 8.0 + t + 0.01, FREE_PX)
    for x, open_ in doors_s:
        if open_:
            c.rect(x - 0.45, 6.0 - t - 0.01, x + 0.45, 6.0 + 0.01, FREE_PX)
    c.walls(6.2, 0.5, 7.8, 3.5, t)         # a service shaft inside the closed south room
    c.rect(9.0, 11.0, 11.0, 13.0)          # table of the (closed) meeting room
    c.rect(1.2, 12.0, 2.8, 12.8)           # a desk in a north office
    c.rect(-3.85, 10.5, -3.2, 15.85)       # a long cabinet along the west wall
    for dx in (18.0, 21.0):                # desk clusters in the open-plan area
        for dy in (0.0, 4.0, 11.0):
            c.rect(dx, dy, dx + 1.6, dy + 1.6)
    c.band((16.3, 9.0), (19.0, 9.6), 0.3)  # a slanted reception counter
    c.rect(22.5, 7.2, 23.85, 8.0, UNK_PX)  # a glass panel the lidar saw through: unknown
    return c.save("office")


# --------------------------------------------------------------------------------------
# the catalogue scenes
# --------------------------------------------------------------------------------------

HEADER = ("Generated by docs/scripts/make_maps.py from {map} with optplan.maps.import_map\n"
          "(grow {grow} cells, simplify {simp} cells): do not edit by hand, rerun the script.")

FORKLIFT = {
    "type": "polygon", "name": "forklift",
    "vertices": [[-0.6, -1.2], [0.6, -1.2], [0.6, 1.2], [-0.6, 1.2]],
    "waypoints": [[0.0, -11.5], [0.0, 12.5]], "times": [0.0, 20.0], "after": "bounce",
}


def build_scenes() -> dict[str, tuple[op.Problem, Path, dict]]:
    """The catalogue scenes imported from the shipped maps: name -> (problem, map, info)."""
    wh = MAPS / "warehouse.yaml"
    of = MAPS / "office.yaml"
    info_w: dict = {}
    pw = import_map(
        wh, radius=RADIUS, start=[(-11.0, -11.5), (11.0, -11.0)],
        goal=[(-9.0, 9.8), (9.0, 6.2)], robot_id=["amr1", "amr2"], max_speed=1.0,
        name="warehouse-grid", tags=["map", "warehouse", "metres"],
        description="40 x 30 m warehouse occupancy grid at 5 cm (ROS map_server YAML + PNG, "
                    "origin (-20, -15)): six rack rows, columns, pallets, a slanted conveyor, "
                    "an unknown cage; two 0.3 m AMRs from the staging area into the aisles, a "
                    "forklift on the cross aisle",
        source="optplan design: problems/maps/warehouse.yaml imported by "
               "optplan.maps.import_map (docs/scripts/make_maps.py)",
        dynamic_obstacles=[FORKLIFT], info=info_w)
    info_o: dict = {}
    po = import_map(
        of, radius=RADIUS, start=[(-2.5, 7.0), (22.5, 2.5)], goal=[(14.0, 12.5), (2.0, 2.0)],
        robot_id=["r1", "r2"], max_speed=1.0, name="office-floor",
        tags=["map", "office", "metres"],
        description="30 x 20 m office floor occupancy grid at 5 cm (ROS map_server YAML + "
                    "PNG, origin (-5, -3)): corridor, rooms with 0.9 m doors (the free floor is "
                    "a hole of the wall polygon), closed rooms filled, desks; two 0.3 m robots",
        source="optplan design: problems/maps/office.yaml imported by optplan.maps.import_map "
               "(docs/scripts/make_maps.py)",
        info=info_o)
    return {"warehouse-grid": (pw, wh, info_w), "office-floor": (po, of, info_o)}


def scenes() -> dict[str, tuple[Path, dict]]:
    """Write the catalogue scenes; name -> (written path, import info)."""
    out = {}
    for name, (prob, src, info) in build_scenes().items():
        path = ROOT / "problems" / f"{name}.toml"
        write_toml(prob, path, HEADER.format(map=src.relative_to(ROOT), grow=0.5, simp=0.5))
        out[name] = (path, info)
    return out


def figure(name: str = "warehouse-grid") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    from optplan import plot

    IMG.mkdir(exist_ok=True)
    prob = op.load_problem(name)
    res = op.solve(prob, "visgraph")
    fig = plot.new_figure(size=(10.0, 7.8))
    ax = fig.add_subplot(1, 1, 1)
    plot.plot_result(res, problem=prob, ax=ax, snapshot_every=0)
    lens = res.metrics.get("lengths_exact", {})
    ax.set_title(f"{name}: {res.status.value}; exact optima "
                 + ", ".join(f"{k} {v:.2f} m" for k, v in lens.items()), fontsize=10)
    handles, labels = ax.get_legend_handles_labels()
    if handles:  # outside the map, below it
        ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.07), ncols=5,
                  fontsize=8, frameon=False)
    fig.tight_layout()
    out = IMG / "maps-warehouse.png"
    fig.savefig(out, dpi=110)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-figure", action="store_true")
    args = ap.parse_args()
    for y in (warehouse(), office()):
        print(f"wrote {y.relative_to(ROOT)} (+ {y.with_suffix('.png').name})")
    for path, info in scenes().values():
        prob = op.load_problem(path)
        t = time.perf_counter()
        res = op.solve(prob, "visgraph")
        dt = time.perf_counter() - t
        print(f"wrote {path.relative_to(ROOT)}: {info['polygons']} polygons, "
              f"{info['vertices']} vertices, {info['holes_filled']} unreachable holes filled; "
              f"visgraph {res.status.value} in {dt * 1e3:.0f} ms, lengths "
              + ", ".join(f"{k} {v:.3f}" for k, v in res.metrics["lengths_exact"].items()))
    if not args.no_figure:
        print(f"wrote {figure().relative_to(ROOT)}")


if __name__ == "__main__":
    main()
