"""The shipped occupancy-grid maps, their catalogue scenes and the docs figures.

    python -m optplan.experiments.maps_scenes                   # into runs/maps/
    python -m optplan.experiments.maps_scenes --out DIR         # into DIR
    python -m optplan.experiments.maps_scenes --install         # the shipped files (below)
    python -m optplan.experiments.maps_scenes --install --scenes warehouse-grid,warehouse-team

Generates (deterministic; run from anywhere), into ``--out`` (default ``runs/maps``: the maps in
``maps/``, the scenes and the figures beside them) or, with ``--install``, into the repository
(``problems/maps/``, ``problems/``, ``docs/img/``):

* ``warehouse.png`` + ``warehouse.yaml``: a 40 x 30 m warehouse at 5 cm (800 x 600 cells),
  origin (-20, -15): outer walls, twelve rack blocks in six rows with 2.4 m aisles and a 3 m
  cross aisle, building columns, pallets in the staging area, a slanted conveyor, an unmapped
  (unknown) cage and a little lidar speckle;
* ``office.png`` + ``office.yaml``: a 30 x 20 m office floor at 5 cm (600 x 400 cells), origin
  (-5, -3): an unknown outside, walls, a corridor with rooms and 0.9 m doors, a closed service
  shaft, a meeting table, desks in an open-plan area;
* the catalogue scenes ``warehouse-grid``, ``warehouse-team`` and ``office-floor``: the maps
  imported with :func:`optplan.maps.import_map` (0.3 m robots) and written with
  :func:`optplan.maps.write_toml`; ``warehouse-grid`` adds a forklift driving the cross aisle;
  ``warehouse-team`` (:func:`warehouse_team`) is a three-robot leader-follower team
  (``[formation]``) crossing the staging area while a forklift comes down the cross aisle;
* the figures ``maps-warehouse.png`` (the imported warehouse with its ``visgraph`` paths) and
  ``maps_warehouse_team.png`` (``formation-qp`` and ``leader-follower-paper`` on
  ``warehouse-team``).

It prints, per scene, the polygon and vertex counts, the ``visgraph`` run time and optima, and for
``warehouse-team`` the status, formation RMSE, minimum separation and clearance of both formation
presets (the numbers quoted in docs/maps.md and docs/solvers/formation.md).

The images are ROS ``map_saver`` style: free 254, occupied 0, unknown 205 (``negate: 0``,
``mode: trinary``, thresholds 0.65 / 0.196).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

import optplan as op
from optplan.maps import Robots, SceneOptions, import_map, write_toml

#: The repository checkout (the shipped maps and scenes live in problems/).
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

    def save(self, stem: str, maps: Path) -> Path:
        maps.mkdir(parents=True, exist_ok=True)
        Image.fromarray(self.px, mode="L").save(maps / f"{stem}.png", optimize=True)
        y = maps / f"{stem}.yaml"
        y.write_text(YAML.format(image=f"{stem}.png", res=RES, ox=self.ox, oy=self.oy),
                     encoding="utf-8")
        return y


# --------------------------------------------------------------------------------------
# the maps
# --------------------------------------------------------------------------------------

#: Rack rows of the warehouse: lower edges (m); racks are 1.2 m deep, aisles 2.4 m.
RACK_Y = [-7.0 + 3.6 * k for k in range(6)]


def warehouse(maps: Path = MAPS) -> Path:
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
    return c.save("warehouse", maps)


def office(maps: Path = MAPS) -> Path:
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
    return c.save("office", maps)


# --------------------------------------------------------------------------------------
# the catalogue scenes
# --------------------------------------------------------------------------------------

MODULE = "python -m optplan.experiments.maps_scenes"
HEADER = ("Generated by {module} from {map} with optplan.maps.import_map\n"
          "(grow {grow} cells, simplify {simp} cells): do not edit by hand, rerun the script.")

FORKLIFT = {
    "type": "polygon", "name": "forklift",
    "vertices": [[-0.6, -1.2], [0.6, -1.2], [0.6, 1.2], [-0.6, 1.2]],
    "waypoints": [[0.0, -11.5], [0.0, 12.5]], "times": [0.0, 20.0], "after": "bounce",
}

#: warehouse-team: the forklift comes down the cross aisle at 1.75 m/s, crosses the team's
#: lane about 4 m ahead of the leader and parks at the south end of the aisle.
TEAM_FORKLIFT = {
    "type": "polygon", "name": "forklift",
    "vertices": [[-0.6, -1.2], [0.6, -1.2], [0.6, 1.2], [-0.6, 1.2]],
    "waypoints": [[0.0, 6.0], [0.0, -11.5]], "times": [0.0, 10.0], "after": "hold",
}

#: warehouse-team: leader start and goal (m), formation distance L (m), angles (rad).
TEAM_START, TEAM_GOAL = (-11.0, -8.6), (11.0, -8.6)
TEAM_L, TEAM_PHI = 1.5, (0.5, -0.5)


def _robots(start: list, goal: list, ids: list[str]) -> Robots:
    """The scenes' robots: 0.3 m (``RADIUS``), 1 m/s."""
    return Robots(start=start, goal=goal, radius=RADIUS, ids=ids, max_speed=1.0)


def _scene(map_file: str, name: str, tags: list[str], description: str,
           **keys: Any) -> SceneOptions:
    """A catalogue scene's keys; its source names the shipped map it is imported from."""
    return SceneOptions(name=name, tags=tags, description=description,
                        source=f"optplan design: problems/maps/{map_file} imported by "
                               f"optplan.maps.import_map ({MODULE})", **keys)


def warehouse_team(wh: Path, info: dict | None = None) -> op.Problem:
    """``warehouse-team``: the warehouse map with a leader and two followers (``[formation]``).

    Three 0.3 m robots (1 m/s) in a wedge (L = 1.5 m, phi = +-0.5 rad, safety distance
    0.75 m) drive 22 m east through the staging area south of the racks, between the rack
    row and the pallets, across the cross aisle, while a forklift comes down the cross aisle,
    crosses their lane and parks at its south end.  ``length_scale = 0.1``: the robots are a
    tenth of the paper warehouse's (radius 3, L = 21, D_s = 7.5, 10 units/s), so the presets'
    distance-like options mean the same relative to the robots.
    """
    from optplan.problem import parse_problem, problem_to_dict

    scene = _scene(
        "warehouse.yaml", "warehouse-team", ["map", "warehouse", "metres", "formation"],
        "40 x 30 m warehouse occupancy grid at 5 cm (the map of warehouse-grid) with a "
        "three-robot leader-follower team (0.3 m robots, L = 1.5 m, phi = +-0.5, safety "
        "distance 0.75 m) driving 22 m east through the staging area between the racks and the "
        "pallets; a forklift comes down the cross aisle, crosses the team's lane ahead of it and "
        "parks", goal_tolerance=0.1, sensing_range=4.0, dynamic_obstacles=[TEAM_FORKLIFT])
    lead = import_map(wh, _robots([TEAM_START], [TEAM_GOAL], ["leader"]), scene=scene, info=info)
    d = problem_to_dict(lead)
    d["length_scale"] = 0.1
    x, y = TEAM_START
    for k, phi in enumerate(TEAM_PHI, start=1):  # followers start in their slots (heading 0)
        d["robots"].append({"id": f"f{k}", "radius": RADIUS, "max_speed": 1.0,
                            "start": [x - TEAM_L * float(np.cos(phi)),
                                      y + TEAM_L * float(np.sin(phi))]})
    d["formation"] = {"leader": "leader", "safety_distance": 0.75,
                      "followers": [{"id": f"f{k}", "L": TEAM_L, "phi": phi}
                                    for k, phi in enumerate(TEAM_PHI, start=1)]}
    return parse_problem(d, where="warehouse-team")


def build_scenes(maps: Path = MAPS) -> dict[str, tuple[op.Problem, Path, dict]]:
    """The catalogue scenes imported from the maps in ``maps``: name -> (problem, map, info)."""
    wh = maps / "warehouse.yaml"
    of = maps / "office.yaml"
    info_w: dict = {}
    pw = import_map(wh, _robots([(-11.0, -11.5), (11.0, -11.0)], [(-9.0, 9.8), (9.0, 6.2)],
                                ["amr1", "amr2"]),
                    scene=_scene("warehouse.yaml", "warehouse-grid", ["map", "warehouse", "metres"],
                                 "40 x 30 m warehouse occupancy grid at 5 cm (ROS map_server YAML "
                                 "+ PNG, origin (-20, -15)): six rack rows, columns, pallets, a "
                                 "slanted conveyor, an unknown cage; two 0.3 m AMRs from the "
                                 "staging area into the aisles, a forklift on the cross aisle",
                                 dynamic_obstacles=[FORKLIFT]),
                    info=info_w)
    info_t: dict = {}
    pt = warehouse_team(wh, info_t)
    info_o: dict = {}
    po = import_map(of, _robots([(-2.5, 7.0), (22.5, 2.5)], [(14.0, 12.5), (2.0, 2.0)],
                                ["r1", "r2"]),
                    scene=_scene("office.yaml", "office-floor", ["map", "office", "metres"],
                                 "30 x 20 m office floor occupancy grid at 5 cm (ROS map_server "
                                 "YAML + PNG, origin (-5, -3)): corridor, rooms with 0.9 m doors "
                                 "(the free floor is a hole of the wall polygon), closed rooms "
                                 "filled, desks; two 0.3 m robots"),
                    info=info_o)
    return {"warehouse-grid": (pw, wh, info_w), "warehouse-team": (pt, wh, info_t),
            "office-floor": (po, of, info_o)}


def scenes(out: Path, maps: Path = MAPS, names: list[str] | None = None
           ) -> dict[str, tuple[Path, dict]]:
    """Write the catalogue scenes (``names``, default all) into ``out``; name -> (path, info)."""
    res = {}
    for name, (prob, src, info) in build_scenes(maps).items():
        if names is not None and name not in names:
            continue
        path = out / f"{name}.toml"
        where = src.relative_to(ROOT) if src.is_relative_to(ROOT) else src
        write_toml(prob, path, HEADER.format(module=MODULE, map=where, grow=0.5, simp=0.5))
        res[name] = (path, info)
    return res


def figure(out: Path, name: str = "warehouse-grid") -> Path:
    """The imported warehouse with its ``visgraph`` paths (``out/maps-warehouse.png``)."""
    import matplotlib

    matplotlib.use("Agg")
    from optplan import plot

    out.mkdir(parents=True, exist_ok=True)
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
    path = out / "maps-warehouse.png"
    fig.savefig(path, dpi=110)
    return path


#: The formation presets run on warehouse-team (seed 0, their own settings).
TEAM_SOLVERS = ("formation-qp", "leader-follower-paper")


def team_runs(prob: op.Problem) -> dict[str, op.Result]:
    """Both formation presets on ``warehouse-team`` (seed 0, preset settings)."""
    return {s: op.solve(prob, s, rng=0) for s in TEAM_SOLVERS}


def team_table(runs: dict[str, op.Result]) -> str:
    """Markdown table of the warehouse-team runs (the numbers quoted in the docs)."""
    out = ["| solver | status | formation RMSE (m) | min separation (m; D_s 0.75) | "
           "min clearance static / moving (m) | collisions | time to goal (s) | wall (s) |",
           "|---|---|---:|---:|---:|---:|---:|---:|"]
    for s, r in runs.items():
        m = r.metrics
        out.append(f"| {s} | {r.status.value} | {m.get('formation_rmse', np.nan):.3f} | "
                   f"{m.get('min_separation', np.nan):.3f} | "
                   f"{m.get('min_clearance', np.nan):.3f} / "
                   f"{m.get('min_clearance_dynamic', np.nan):.3f} | {m['collisions']} | "
                   f"{r.extras.get('time_to_goal', np.nan):.1f} | {r.wall_time:.1f} |")
    return "\n".join(out)


def team_figure(out: Path, prob: op.Problem, runs: dict[str, op.Result]) -> Path:
    """``out/maps_warehouse_team.png``: both presets' runs on warehouse-team (the staging
    area), robots and formation links every 8 s."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from optplan import plot

    out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(len(runs), 1, figsize=(12.5, 3.9 * len(runs)), layout="constrained")
    for ax, (s, r) in zip(np.atleast_1d(axes), runs.items()):
        if r.times is None:
            raise ValueError(f"{s} on {prob.name}: the result has no time stamps")
        every = max(1, int(round(8.0 / float(np.median(np.diff(r.times))))))
        plot.plot_result(r, problem=prob, ax=ax, snapshot_every=every, legend="outside")
        ax.set_xlim(-14.5, 14.0)
        ax.set_ylim(-13.0, -5.0)
        m = r.metrics
        ax.set_title(f"warehouse-team: {s}: {r.status.value}, formation RMSE "
                     f"{m.get('formation_rmse', np.nan):.2f} m, min separation "
                     f"{m.get('min_separation', np.nan):.2f} m, collisions {m['collisions']}",
                     fontsize=9)
    path = out / "maps_warehouse_team.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/maps",
                    help="folder for the maps (maps/), scenes and figures (default runs/maps)")
    ap.add_argument("--install", action="store_true",
                    help="write the shipped files: problems/maps/, problems/*.toml, docs/img/")
    ap.add_argument("--scenes", default=None,
                    help="comma-separated scenes to write (default: all)")
    ap.add_argument("--no-figure", action="store_true")
    args = ap.parse_args(argv)
    if args.install:
        maps, scene_dir, img = MAPS, ROOT / "problems", IMG
    else:
        out = Path(args.out)
        maps, scene_dir, img = out / "maps", out, out
    for y in (warehouse(maps), office(maps)):
        print(f"wrote {y} (+ {y.with_suffix('.png').name})")
    names = args.scenes.split(",") if args.scenes else None
    for name, (path, info) in scenes(scene_dir, maps, names).items():
        prob = op.load_problem(path)
        t = time.perf_counter()
        res = op.solve(prob, "visgraph")
        dt = time.perf_counter() - t
        print(f"wrote {path}: {info['polygons']} polygons, "
              f"{info['vertices']} vertices, {info['holes_filled']} unreachable holes filled; "
              f"visgraph {res.status.value} in {dt * 1e3:.0f} ms, lengths "
              + ", ".join(f"{k} {v:.3f}" for k, v in res.metrics["lengths_exact"].items()))
        if name == "warehouse-team":
            runs = team_runs(prob)
            print(f"\n{name} (seed 0, preset settings; length_scale {prob.length_scale:g}):\n")
            print(team_table(runs) + "\n")
            if not args.no_figure:
                print(f"wrote {team_figure(img, prob, runs)}")
    if not args.no_figure:
        print(f"wrote {figure(img)}")


if __name__ == "__main__":
    main()
