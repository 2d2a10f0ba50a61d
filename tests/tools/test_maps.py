"""Occupancy-grid import (optplan.maps): ROS map_server YAML, bare images, MovingAI.

* classification as map_server (negate 0/1, trinary/scale/raw, unknown cells);
* conservative polygons: every obstacle cell square inside, no more than the growth plus the
  simplification tolerance outside; a visgraph path on the import is collision-free on the
  grid itself (exact distance to every obstacle cell square, and cell by cell along the path);
* MovingAI .map + .scen: a batch whose any-angle optima are at most the octile grid lengths;
* write_toml round trips; the shipped maps reproduce their catalogue scenes;
* every bad input raises ProblemError naming the file and the key.
"""

from __future__ import annotations

import heapq
import math
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from PIL import Image
from shapely.geometry import LineString, box

import optplan as op
from optplan import ProblemError
from optplan.maps import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    Grid,
    PolygonOptions,
    ReadOptions,
    Robots,
    classify,
    exact_union,
    grid_polygons,
    import_map,
    read_grid,
    read_image,
    read_ros_yaml,
    read_scen,
    read_scen_entries,
    scen_octile_length,
    to_toml,
    write_batch,
    write_toml,
)

ROOT = Path(__file__).resolve().parents[2]
RES = 0.05
ORIGIN = (-3.2, 1.7)
RADIUS = 0.12

# --------------------------------------------------------------------------------------
# a generated ROS map: 4 x 3 m at 5 cm, walls, a slanted wall, a closed box, speckle, unknown
# --------------------------------------------------------------------------------------


def truth_cells() -> np.ndarray:
    """FREE/OCCUPIED/UNKNOWN of the test map, row 0 at the top (60 rows x 80 columns)."""
    h, w = 60, 80
    c = np.full((h, w), FREE, dtype=np.uint8)
    c[0, :] = c[-1, :] = OCCUPIED
    c[:, 0] = c[:, -1] = OCCUPIED
    c[10:40, 20:23] = OCCUPIED          # a vertical wall
    c[45:48, 5:50] = OCCUPIED           # a horizontal wall
    yy, xx = np.mgrid[0:h, 0:w]
    c[np.abs((yy - 5) - 0.6 * (xx - 40)) < 1.2] = OCCUPIED  # a slanted wall (staircase)
    c[np.abs(xx - 40) + np.abs(yy - 5) > 70] = FREE          # keep it inside the map
    c[0, :] = OCCUPIED
    c[8:20, 55:70] = OCCUPIED           # a room with a free inside (a hole)
    c[10:18, 57:68] = FREE
    c[13, 60] = OCCUPIED                # speckle inside the room
    c[30:38, 60:75] = UNKNOWN           # an unknown region
    c[25, 10] = c[26, 11] = OCCUPIED    # two cells touching at a corner
    c[5, 5] = OCCUPIED
    return c


def pixels(cells: np.ndarray, negate: bool) -> np.ndarray:
    """map_saver-style grey levels (free 254, occupied 0, unknown 205); negate inverts."""
    px = np.choose(cells, [254, 0, 205]).astype(np.uint8)
    return (255 - px).astype(np.uint8) if negate else px


def write_ros(tmp: Path, cells: np.ndarray, *, negate: bool = False, suffix: str = ".png",
              origin=ORIGIN, yaw: float = 0.0, extra: str = "", stem: str = "map") -> Path:
    img = tmp / f"{stem}{suffix}"
    Image.fromarray(pixels(cells, negate), mode="L").save(img)
    y = tmp / f"{stem}.yaml"
    y.write_text(f"image: {img.name}\nresolution: {RES}\norigin: [{origin[0]}, {origin[1]}, "
                 f"{yaw}]\nnegate: {int(negate)}\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
                 f"{extra}", encoding="utf-8")
    return y


def free_point(grid: Grid, row: int, col: int) -> list[float]:
    return grid.cell_centre(row, col).tolist()


START_RC, GOAL_RC = (52, 8), (30, 45)   # below the horizontal wall -> right of the vertical one


def _robots(grid: Grid) -> Robots:
    """The test map's robot (radius ``RADIUS``) from ``START_RC`` to ``GOAL_RC``."""
    return Robots(start=free_point(grid, *START_RC), goal=free_point(grid, *GOAL_RC),
                  radius=RADIUS)


@pytest.fixture(scope="module")
def ros_map(tmp_path_factory) -> Path:
    return write_ros(tmp_path_factory.mktemp("ros"), truth_cells())


# --------------------------------------------------------------------------------------
# reading and classification
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("negate", [False, True])
@pytest.mark.parametrize("suffix", [".png", ".pgm"])
def test_ros_yaml_classifies_as_map_server(tmp_path, negate, suffix):
    cells = truth_cells()
    g = read_ros_yaml(write_ros(tmp_path, cells, negate=negate, suffix=suffix))
    assert g.cells.shape == cells.shape and np.array_equal(g.cells, cells)
    assert g.resolution == RES and g.origin == (ORIGIN[0], ORIGIN[1], 0.0)
    assert g.bounds == pytest.approx((-3.2, 1.7, -3.2 + 4.0, 1.7 + 3.0))


def test_classify_modes_and_thresholds():
    grey = np.array([[0.0, 60.0, 100.0, 205.0, 230.0, 254.0]])[:, :, None]
    # p = (255 - v) / 255: 1.0, 0.76, 0.61, 0.196, 0.098, 0.004
    tri = classify(grey, None)
    assert tri.tolist() == [[OCCUPIED, OCCUPIED, UNKNOWN, UNKNOWN, FREE, FREE]]
    assert classify(255 - grey, None, negate=True).tolist() == tri.tolist()
    # the thresholds are strict, as in map_server: 205 is unknown with free_thresh 0.196
    assert classify(np.array([[[205.0]]]), None, free_thresh=0.197)[0, 0] == FREE
    # trinary averages alpha in (map_server quirk); scale mode does not
    rgb = np.array([[[0.0, 0.0, 0.0]]])
    opaque = np.array([[255.0]])
    assert classify(rgb, opaque, mode="trinary")[0, 0] == OCCUPIED  # p = 0.75
    assert classify(rgb, opaque, mode="trinary", occupied_thresh=0.8)[0, 0] == UNKNOWN
    assert classify(rgb, opaque, mode="scale", occupied_thresh=0.8)[0, 0] == OCCUPIED
    # raw: the value is the occupancy percentage; > 100 is unknown
    raw = np.array([[[0.0], [10.0], [50.0], [100.0], [255.0]]]).reshape(1, 5, 1)
    assert classify(raw, None, mode="raw").tolist() == [[FREE, FREE, UNKNOWN, OCCUPIED,
                                                         UNKNOWN]]


def test_rgb_and_alpha_images(tmp_path):
    cells = truth_cells()
    px = pixels(cells, False)
    rgba = np.dstack([px, px, px, np.full_like(px, 255)])
    Image.fromarray(rgba, mode="RGBA").save(tmp_path / "m.png")
    (tmp_path / "m.yaml").write_text("image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\n"
                                     "mode: scale\n", encoding="utf-8")
    assert np.array_equal(read_ros_yaml(tmp_path / "m.yaml").cells, cells)


# --------------------------------------------------------------------------------------
# conservative polygons
# --------------------------------------------------------------------------------------


def _union(problem: op.Problem):
    return shapely.union_all([o.geometry for o in problem.obstacles])


@pytest.mark.parametrize("grow, simplify, join", [(0.5, 0.5, "round"), (0.5, 0.25, "round"),
                                                   (0.3, 0.8, "round"), (0.5, 0.5, "mitre"),
                                                   (0.0, 0.0, "round")])
def test_polygons_cover_every_obstacle_cell_and_little_more(ros_map, grow, simplify, join):
    g = read_ros_yaml(ros_map)
    info: dict = {}
    prob = import_map(ros_map, _robots(g),
                      polygons=PolygonOptions(grow=grow, simplify=simplify, join=join),
                      fill_unreachable=False, info=info)
    U = g.squares()                      # exact union of the occupied and unknown squares
    S = _union(prob)
    tol = 1e-9 * prob.extent
    # every obstacle cell lies inside: its corners and centre, and by area
    mask = g.obstacle_mask()
    rows, cols = np.nonzero(mask)
    for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0.5)):
        pts = g.cell_to_world(np.column_stack([cols + dx, g.height - rows - 1 + dy]))
        d = shapely.distance(S, shapely.points(pts))
        assert np.all(d <= tol), f"{np.sum(d > tol)} cell points outside the polygons"
    assert U.difference(S).area <= 1e-9 * U.area
    # no more than U + disc((grow + simplify) cells) (mitre: sqrt(2) grow)
    reach = ((math.sqrt(2) if join == "mitre" else 1.0) * grow + simplify) * RES
    assert S.difference(U.buffer(reach + tol, quad_segs=32)).area <= 1e-9 * U.area
    extra = S.area - U.area
    assert extra >= -1e-9
    assert extra <= U.buffer(reach, quad_segs=32).area - U.area + 1e-9
    if simplify == 0:
        assert info["fallbacks"] == 0
    # the free room inside the closed box is a hole of its polygon
    assert any(o.geometry.interiors for o in prob.obstacles)


def test_free_cells_away_from_obstacles_stay_free(ros_map):
    """A free cell centre farther than grow + simplify + 1/2 cell from every obstacle cell is
    outside the polygons (the import does not eat free space)."""
    g = read_ros_yaml(ros_map)
    prob = import_map(ros_map, _robots(g), fill_unreachable=False)
    S, U = _union(prob), g.squares()
    rows, cols = np.nonzero(g.cells == FREE)
    pts = shapely.points(g.cell_to_world(np.column_stack([cols + 0.5,
                                                          g.height - rows - 0.5])))
    far = shapely.distance(U, pts) > (0.5 + 0.5 + 1e-6) * RES
    assert far.sum() > 0.5 * len(rows)
    assert not np.any(shapely.intersects(S, pts[far]))


def test_grid_polygons_components_and_diagonal_touch():
    m = np.zeros((6, 6), bool)
    m[1, 1] = m[2, 2] = True           # touch at a corner: one 8-connected component
    m[4, 4] = True
    st: dict = {}
    polys = grid_polygons(m, grow=0.5, simplify=0.5, stats=st)
    assert st["components"] == 2 and len(polys) == 2
    u = exact_union(m)
    assert shapely.union_all(polys).covers(u)
    # the exact union is exact: integer vertices, area = cell count
    assert u.area == 3
    assert grid_polygons(np.zeros((3, 3), bool)) == []
    with pytest.raises(ValueError, match="needs grow > 0"):
        grid_polygons(m, grow=0.0, simplify=0.5)


def test_simplification_keeps_vertex_counts_small(ros_map):
    g = read_ros_yaml(ros_map)
    exact: dict = {}
    simple: dict = {}
    coarse: dict = {}
    import_map(ros_map, _robots(g), polygons=PolygonOptions(grow=0.0, simplify=0.0),
               fill_unreachable=False, info=exact)
    import_map(ros_map, _robots(g), fill_unreachable=False, info=simple)
    import_map(ros_map, _robots(g), polygons=PolygonOptions(grow=1.0, simplify=1.0),
               fill_unreachable=False, info=coarse)
    assert simple["vertices"] < 0.7 * exact["vertices"]
    # one-cell steps of the slanted wall are straightened by a one-cell tolerance
    assert coarse["vertices"] < 0.4 * exact["vertices"]
    assert coarse["tolerance_min"] == 1.0


@pytest.mark.parametrize("negate", [False, True])
def test_visgraph_path_is_collision_free_on_the_grid(tmp_path, negate):
    y = write_ros(tmp_path, truth_cells(), negate=negate)
    g = read_ros_yaml(y)
    prob = import_map(y, _robots(g))
    res = op.solve(prob, "visgraph")
    assert res.status.value == "optimal", res.message
    path = res.paths["r1"]
    tol = 1e-9 * prob.extent
    # exact: distance from the polyline to every obstacle cell square
    squares = g.squares()
    assert shapely.distance(LineString(path), squares) >= RADIUS - tol
    # cell by cell along the densely sampled path: the obstacle squares near each sample
    seg = np.diff(path, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(*seg.T) / (RES / 4)).astype(int))
    samples = np.vstack([path[k] + np.linspace(0, 1, n[k], endpoint=False)[:, None] * seg[k]
                         for k in range(len(seg))] + [path[-1:]])
    mask = g.obstacle_mask()
    reach = int(math.ceil(RADIUS / RES)) + 1
    worst = math.inf
    for p in samples:
        r, c = g.cell_of(p)
        r0, r1 = max(0, r - reach), min(g.height, r + reach + 1)
        c0, c1 = max(0, c - reach), min(g.width, c + reach + 1)
        rr, cc = np.nonzero(mask[r0:r1, c0:c1])
        for i, j in zip(rr + r0, cc + c0):
            x0, y0 = g.cell_to_world([j, g.height - i - 1])[0]
            d = shapely.distance(box(x0, y0, x0 + RES, y0 + RES), shapely.Point(p))
            worst = min(worst, d)
    assert worst >= RADIUS - tol
    assert res.metrics["collisions"] == 0


def test_unknown_free_option(ros_map):
    g = read_ros_yaml(ros_map)
    inside_unknown = free_point(g, 34, 67)
    robots = Robots(radius=0.05, start=inside_unknown, goal=free_point(g, *GOAL_RC))
    with pytest.raises(ProblemError, match=r"robots\[0\]\.start: .* unknown cell"):
        import_map(ros_map, robots)
    prob = import_map(ros_map, robots, read=ReadOptions(unknown="free"))
    S = _union(prob)
    assert not S.contains(shapely.Point(inside_unknown))
    assert S.covers(g.squares(g.obstacle_mask("free")))


def test_fill_unreachable_holes(ros_map):
    g = read_ros_yaml(ros_map)
    a: dict = {}
    b: dict = {}
    filled = import_map(ros_map, _robots(g), info=a)
    kept = import_map(ros_map, _robots(g), fill_unreachable=False, info=b)
    assert a["holes_filled"] >= 1 and b["holes_filled"] == 0
    assert a["vertices"] < b["vertices"] and a["polygons"] < b["polygons"]  # the speckle goes
    assert _union(filled).covers(_union(kept))
    # a robot inside the room keeps its hole
    room = free_point(g, 11, 58)
    p = import_map(ros_map, Robots(radius=0.02, start=room, goal=free_point(g, 16, 66)))
    assert any(o.geometry.interiors for o in p.obstacles)
    assert op.solve(p, "visgraph").status.value == "optimal"


def test_rotated_origin_yaw(tmp_path):
    cells = truth_cells()
    yaw = math.pi / 6
    y = write_ros(tmp_path, cells, yaw=yaw)
    g = read_ros_yaml(y)
    assert g.origin[2] == pytest.approx(yaw)
    prob = import_map(y, _robots(g), fill_unreachable=False)
    S, U = _union(prob), g.squares()
    assert U.difference(S).area <= 1e-9 * U.area
    # the corners of the bounding box outside the rotated image are obstacles (unknown)
    outside = box(*prob.bounds).difference(g.outline)
    assert S.covers(outside.buffer(-1e-9))
    assert op.solve(prob, "visgraph").status.value == "optimal"


# --------------------------------------------------------------------------------------
# bare images
# --------------------------------------------------------------------------------------


def test_bare_png_with_resolution_and_origin(tmp_path, ros_map):
    cells = truth_cells()
    png = tmp_path / "plan.png"
    Image.fromarray(pixels(cells, False), mode="L").save(png)
    g = read_ros_yaml(ros_map)
    robots = _robots(g)
    a = import_map(png, robots, read=ReadOptions(resolution=RES, origin=ORIGIN))
    b = import_map(ros_map, robots)
    assert a.bounds == b.bounds
    assert [o.geometry.wkt for o in a.obstacles] == [o.geometry.wkt for o in b.obstacles]
    # the same plan drawn negated
    Image.fromarray(pixels(cells, True), mode="L").save(tmp_path / "neg.pgm")
    c = import_map(tmp_path / "neg.pgm", robots,
                   read=ReadOptions(resolution=RES, origin=ORIGIN, negate=True))
    assert [o.geometry.wkt for o in c.obstacles] == [o.geometry.wkt for o in b.obstacles]
    # origin shifts every coordinate
    shifted = Robots(radius=RADIUS, start=[robots.start[0] + 10, robots.start[1] - 5],
                     goal=[robots.goal[0] + 10, robots.goal[1] - 5])
    d = import_map(png, shifted,
                   read=ReadOptions(resolution=RES, origin=(ORIGIN[0] + 10, ORIGIN[1] - 5)))
    moved = shapely.affinity.translate(_union(a), 10, -5)
    assert _union(d).symmetric_difference(moved).area <= 1e-9 * moved.area


# --------------------------------------------------------------------------------------
# MovingAI .map + .scen
# --------------------------------------------------------------------------------------


def movingai_grid(rng: np.random.Generator, h: int = 24, w: int = 32) -> list[str]:
    g = np.full((h, w), ".")
    g[0, :] = g[-1, :] = "@"
    g[:, 0] = g[:, -1] = "@"
    for _ in range(14):
        r, c = rng.integers(1, h - 4), rng.integers(1, w - 6)
        g[r:r + rng.integers(1, 4), c:c + rng.integers(1, 6)] = rng.choice(["@", "T"])
    g[5:18, 15] = "@"
    g[rng.integers(1, h - 1, 25), rng.integers(1, w - 1, 25)] = "T"
    return ["".join(row) for row in g]


def octile(rows: list[str], s: tuple[int, int], t: tuple[int, int]) -> float:
    """MovingAI octile distance (8-connected, no corner cutting) from cell s to t (x, y)."""
    h, w = len(rows), len(rows[0])

    def free(x, y):
        return 0 <= x < w and 0 <= y < h and rows[y][x] in ".GS"

    dist = {s: 0.0}
    pq = [(0.0, s)]
    while pq:
        d, (x, y) = heapq.heappop(pq)
        if (x, y) == t:
            return d
        if d > dist[(x, y)]:
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if (dx, dy) == (0, 0) or not free(x + dx, y + dy):
                    continue
                if dx and dy and not (free(x + dx, y) and free(x, y + dy)):
                    continue
                nd = d + (math.sqrt(2) if dx and dy else 1.0)
                if nd < dist.get((x + dx, y + dy), math.inf):
                    dist[(x + dx, y + dy)] = nd
                    heapq.heappush(pq, (nd, (x + dx, y + dy)))
    return math.inf


@pytest.fixture(scope="module")
def movingai(tmp_path_factory) -> tuple[Path, Path, list[str], list[tuple]]:
    d = tmp_path_factory.mktemp("movingai")
    rng = np.random.default_rng(7)
    rows = movingai_grid(rng)
    h, w = len(rows), len(rows[0])
    (d / "maps").mkdir()
    m = d / "maps" / "arena.map"
    m.write_text(f"type octile\nheight {h}\nwidth {w}\nmap\n" + "\n".join(rows) + "\n",
                 encoding="ascii")
    free = [(x, y) for y in range(h) for x in range(w) if rows[y][x] == "."]
    pairs = []
    while len(pairs) < 8:
        s, t = (free[i] for i in rng.choice(len(free), 2, replace=False))
        L = octile(rows, s, t)
        if math.isfinite(L) and L > 5:
            pairs.append((s, t, L))
    lines = ["version 1"] + [f"{k // 4}\tmaps/arena.map\t{w}\t{h}\t{s[0]}\t{s[1]}\t{t[0]}\t"
                             f"{t[1]}\t{L:.8f}" for k, (s, t, L) in enumerate(pairs)]
    scen = d / "arena.map.scen"
    scen.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return m, scen, rows, pairs


def test_movingai_map_reads_top_row_first(movingai):
    m, _, rows, _ = movingai
    g = read_grid(m)
    assert g.cells.shape == (len(rows), len(rows[0])) and g.resolution == 1.0
    for y in (0, 3, 10):
        for x in (0, 5, 16):
            assert (g.cells[y, x] == OCCUPIED) == (rows[y][x] != ".")
    # cell (x, y) is centred at (x + 0.5, H - y - 0.5)
    assert g.cell_centre(2, 3).tolist() == [3.5, len(rows) - 2.5]


def test_movingai_scen_batch_is_shorter_than_octile(movingai, tmp_path):
    m, scen, rows, pairs = movingai
    entries = read_scen_entries(scen)
    assert [(e.start, e.goal) for e in entries] == [(s, t) for s, t, _ in pairs]
    probs = read_scen(scen)
    assert len(probs) == len(pairs)
    assert [q.name for q in probs] == [f"arena-{k + 2}" for k in range(len(pairs))]
    assert all(q.obstacles is probs[0].obstacles for q in probs)  # imported once
    for prob, (s, t, L) in zip(probs, pairs):
        assert scen_octile_length(prob) == pytest.approx(L, abs=1e-7)
        res = op.solve(prob, "visgraph")
        assert res.status.value == "optimal", (prob.name, res.message)
        opt = res.metrics["length_exact"]
        straight = math.hypot(t[0] - s[0], t[1] - s[1])
        # any-angle among cells grown by < 1/2 cell: never longer than the grid path
        assert straight - 1e-9 <= opt <= L + 1e-9, (prob.name, opt, L)
    # the batch runs through the bench harness as scenario files
    paths = write_batch(probs[:3], tmp_path / "batch")
    from optplan.bench import run_grid

    rows_ = run_grid([str(p) for p in paths], ["visgraph"], seeds=1)
    assert [r["status"] for r in rows_] == ["optimal"] * 3
    assert [r["length"] for r in rows_] == pytest.approx(
        [op.solve(p, "visgraph").metrics["length"] for p in probs[:3]], rel=1e-9)


def test_movingai_scen_options_and_errors(movingai, tmp_path):
    m, scen, rows, pairs = movingai
    assert len(read_scen(scen, buckets=[0])) == 4 and len(read_scen(scen, limit=2)) == 2
    # a scaled map: resolution multiplies the octile length
    p = read_scen(scen, map_path=m, resolution=0.5, origin=(10, 20), limit=1)[0]
    assert scen_octile_length(p) == pytest.approx(pairs[0][2] * 0.5, abs=1e-7)
    assert p.bounds == (10.0, 20.0, 10 + 0.5 * len(rows[0]), 20 + 0.5 * len(rows))
    # a disc robot too big for the cells next to the walls: the line is named
    with pytest.raises(ProblemError, match=r"arena\.map\.scen:\d+: robots\[0\]\.(start|goal): "
                                           r".* inside obstacle"):
        read_scen(scen, radius=2.0)
    bad = tmp_path / "bad.scen"
    bad.write_text("version 1\n0\tarena.map\t10\t10\t1\t1\t2\t2\t1.4\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=r"bad\.scen: map: cannot find the map"):
        read_scen(bad)
    with pytest.raises(ProblemError, match=r"bad\.scen: line 2: the scenario is for a 10 x 10"):
        read_scen(bad, map_path=m)
    bad.write_text("version 1\n0\tarena.map\t10\t10\t1\t1\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=r"bad\.scen: line 2: expected 9 fields"):
        read_scen_entries(bad)
    blocked = next((x, y) for y, r in enumerate(rows) for x, ch in enumerate(r) if ch != ".")
    bad.write_text(f"version 1\n0\tarena.map\t{len(rows[0])}\t{len(rows)}\t{blocked[0]}\t"
                   f"{blocked[1]}\t{pairs[0][1][0]}\t{pairs[0][1][1]}\t3\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=r"line 2: start cell .* is blocked"):
        read_scen(bad, map_path=m)


def test_movingai_map_errors(tmp_path):
    m = tmp_path / "x.map"
    m.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n.X.\n", encoding="ascii")
    with pytest.raises(ProblemError, match=r"x\.map: line 6: unknown terrain 'X' at column 2"):
        read_grid(m)
    m.write_text("type octile\nheight 3\nwidth 3\nmap\n...\n...\n", encoding="ascii")
    with pytest.raises(ProblemError, match=r"x\.map: height: header says 3 rows"):
        read_grid(m)
    m.write_text("type octile\nwidth 3\nmap\n...\n", encoding="ascii")
    with pytest.raises(ProblemError, match=r"x\.map: height: missing"):
        read_grid(m)


# --------------------------------------------------------------------------------------
# writing scenarios
# --------------------------------------------------------------------------------------


def _same_problem(a: op.Problem, b: op.Problem) -> None:
    assert (a.name, a.bounds, a.description, a.source, a.tags, a.goal_tolerance,
            a.sensing_range) == (b.name, b.bounds, b.description, b.source, b.tags,
                                 b.goal_tolerance, b.sensing_range)
    for r, s in zip(a.robots, b.robots, strict=True):
        assert (r.id, r.radius, r.max_speed) == (s.id, s.radius, s.max_speed)
        assert np.array_equal(r.start, s.start)
        assert (r.goal is None and s.goal is None) or np.array_equal(r.goal, s.goal)
    for o, q in zip(a.obstacles, b.obstacles, strict=True):
        assert (o.kind, o.name, o.known) == (q.kind, q.name, q.known)
        if o.is_circle:
            assert np.array_equal(o.center, q.center) and o.radius == q.radius
        else:
            assert o.geometry.equals_exact(q.geometry, 0.0)
    for d, e in zip(a.dynamic_obstacles, b.dynamic_obstacles, strict=True):
        assert (d.kind, d.name, d.after, d.radius) == (e.kind, e.name, e.after, e.radius)
        assert np.array_equal(d.waypoints, e.waypoints) and np.array_equal(d.times, e.times)
        assert (d.velocity is None) == (e.velocity is None)
        assert d.local_geometry.equals_exact(e.local_geometry, 1e-12)
    assert (a.formation is None) == (b.formation is None)
    if a.formation:
        assert a.formation == b.formation


@pytest.mark.parametrize("name", ["paper-formation", "paper-apf-env1", "paper-hybrid",
                                  "paper-warehouse", "warehouse-grid", "office-floor"])
def test_write_toml_round_trips(tmp_path, name):
    a = op.load_problem(name)
    b = op.read_problem(write_toml(a, tmp_path / f"{name}.toml", header="a header\nline 2"))
    _same_problem(a, b)
    assert to_toml(a).startswith(f'name = "{name}"')


# --------------------------------------------------------------------------------------
# the shipped maps and their catalogue scenes
# --------------------------------------------------------------------------------------


def _make_maps():
    from optplan.experiments import maps_scenes

    return maps_scenes


def test_shipped_maps_reproduce_the_catalogue_scenes():
    from optplan.catalog import find_map, map_files

    assert {"warehouse", "office"} <= set(map_files())
    assert find_map("warehouse").name == "warehouse.yaml"
    built = _make_maps().build_scenes()
    for name, (prob, _src, info) in built.items():
        cat = op.load_problem(name)
        _same_problem(prob, cat)
        assert info["tolerance_min"] > 0 and info["vertices"] < 1000
        assert "map" in cat.tags and "metres" in cat.tags


def test_warehouse_grid_scene():
    g = read_ros_yaml(ROOT / "problems" / "maps" / "warehouse.yaml")
    assert g.resolution == 0.05 and (g.width, g.height) == (800, 600)
    assert g.origin[:2] != (0.0, 0.0) and np.any(g.cells == UNKNOWN)
    prob = op.load_problem("warehouse-grid")
    assert prob.bounds == (-20.0, -15.0, 20.0, 15.0)
    assert len(prob.robots) == 2 and all(r.radius == 0.3 for r in prob.robots)
    assert [d.name for d in prob.dynamic_obstacles] == ["forklift"]
    assert _union(prob).covers(g.squares().buffer(-1e-9))
    res = op.solve(prob, "visgraph")
    assert res.status.value == "optimal" and res.metrics["collisions"] == 0


def test_office_floor_scene_has_holes():
    g = read_ros_yaml(ROOT / "problems" / "maps" / "office.yaml")
    prob = op.load_problem("office-floor")
    assert any(o.geometry.interiors for o in prob.obstacles)
    assert _union(prob).covers(g.squares().buffer(-1e-9))
    res = op.solve(prob, "visgraph")
    assert res.status.value == "optimal" and res.metrics["collisions"] == 0


# --------------------------------------------------------------------------------------
# errors name the file and the key
# --------------------------------------------------------------------------------------


def _yaml(tmp_path: Path, body: str) -> Path:
    Image.fromarray(pixels(truth_cells(), False), mode="L").save(tmp_path / "m.png")
    y = tmp_path / "m.yaml"
    y.write_text(body, encoding="utf-8")
    return y


GOOD = "image: m.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"


@pytest.mark.parametrize("body, pattern", [
    (GOOD + "negat: 1\n", r"m\.yaml: negat: unknown key; did you mean 'negate'\?"),
    ("image: m.png\norigin: [0, 0, 0]\n", r"m\.yaml: resolution: missing required key"),
    ("resolution: 0.05\norigin: [0, 0, 0]\n", r"m\.yaml: image: missing required key"),
    (GOOD + "mode: trinery\n", r"m\.yaml: mode: unknown mode 'trinery'; did you mean 'trinary'"),
    (GOOD + "negate: 2\n", r"m\.yaml: negate: expected 0 or 1"),
    (GOOD + "occupied_thresh: 1.5\n", r"m\.yaml: occupied_thresh: must be in \[0, 1\]"),
    (GOOD + "free_thresh: 0.9\n", r"m\.yaml: free_thresh: must be <= occupied_thresh"),
    ("image: m.png\nresolution: -1\norigin: [0, 0, 0]\n", r"m\.yaml: resolution: must be > 0"),
    ("image: m.png\nresolution: 0.05\norigin: [0, 0, 0, 1]\n", r"m\.yaml: origin: expected"),
    ("image: m.png\nresolution: 0.05\norigin: [0, x, 0]\n", r"m\.yaml: origin\[1\]: expected"),
    ("image: nope.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n",
     r"m\.yaml: image: no such file .*nope\.pgm"),
    ("image: m.png\nresolution: [0.05\n", r"m\.yaml: invalid YAML at line"),
    ("- 1\n- 2\n", r"m\.yaml: <root>: expected a mapping"),
])
def test_yaml_errors(tmp_path, body, pattern):
    with pytest.raises(ProblemError, match=pattern):
        import_map(_yaml(tmp_path, body), Robots(radius=0.1, start=(1, 1), goal=(2, 2)))


def test_a_yaml_file_that_is_not_utf8_names_the_file(tmp_path):
    y = tmp_path / "m.yaml"
    y.write_bytes(b"\xff\xfeimage: m.png\n")
    with pytest.raises(ProblemError, match=r"m\.yaml: not UTF-8 text .* at byte 0"):
        read_ros_yaml(y)


def test_yaml_numbers_in_exponent_notation_are_numbers(tmp_path):
    """``5e-2`` is a float to ROS (YAML 1.2) and to optplan, not the string PyYAML's YAML 1.1
    resolver makes of it (it was rejected: "resolution: expected a number, got '5e-2'")."""
    body = "image: m.png\nresolution: 5e-2\norigin: [0, -1E+1, 0]\noccupied_thresh: 65e-2\n"
    g = read_ros_yaml(_yaml(tmp_path, body))
    ref = read_ros_yaml(_yaml(tmp_path, "image: m.png\nresolution: 0.05\norigin: [0, -10, 0]\n"))
    assert g.resolution == 0.05 and g.origin == (0.0, -10.0, 0.0)
    assert np.array_equal(g.cells, ref.cells)


@pytest.mark.parametrize("header", [b"P5\n2 2\n0\n", b"P5\n2 2\n70000\n", b"P5\n0 2\n255\n"])
def test_malformed_pgm_names_the_file(tmp_path, header):
    """Pillow's own complaints about a malformed image (``maxval 0``: a bare ValueError naming
    no file) come out as an error naming the map file and the key."""
    (tmp_path / "m.pgm").write_bytes(header + b"\0" * 8)
    y = tmp_path / "m.yaml"
    y.write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=r"m\.yaml: image: cannot read image .*m\.pgm"):
        read_ros_yaml(y)
    with pytest.raises(ProblemError, match=r"m\.pgm: .*cannot read image"):
        read_grid(tmp_path / "m.pgm", resolution=1.0)


def test_import_errors(tmp_path, ros_map):
    g = read_ros_yaml(ros_map)
    s, t = free_point(g, *START_RC), free_point(g, *GOAL_RC)
    with pytest.raises(ProblemError, match=r"nowhere\.yaml: no such map file"):
        import_map(tmp_path / "nowhere.yaml", Robots(radius=0.1, start=s, goal=t))
    (tmp_path / "x.xyz").write_text("", encoding="utf-8")
    with pytest.raises(ProblemError, match=r"x\.xyz: unknown map format '\.xyz'"):
        import_map(tmp_path / "x.xyz", Robots(radius=0.1, start=s, goal=t))
    png = tmp_path / "p.png"
    Image.fromarray(pixels(truth_cells(), False), mode="L").save(png)
    with pytest.raises(ProblemError, match=r"p\.png: resolution: required for a bare image"):
        import_map(png, Robots(radius=0.1, start=s, goal=t))
    (tmp_path / "broken.png").write_bytes(b"not a png")
    with pytest.raises(ProblemError, match=r"broken\.png: image: cannot read image"):
        import_map(tmp_path / "broken.png", Robots(radius=0.1, start=s, goal=t),
                   read=ReadOptions(resolution=0.1))
    with pytest.raises(ProblemError, match=r"map\.yaml: origin: given by the YAML file"):
        import_map(ros_map, Robots(radius=0.1, start=s, goal=t), read=ReadOptions(origin=(0, 0)))
    # start in an occupied cell, within the radius of an obstacle, outside the map
    wall = free_point(g, 20, 21)
    with pytest.raises(ProblemError, match=r"map\.yaml: robots\[0\]\.start: .* occupied cell "
                                           r"\(row 20, column 21\)"):
        import_map(ros_map, Robots(radius=0.1, start=wall, goal=t))
    near = [wall[0] + 2.5 * RES, wall[1]]
    with pytest.raises(ProblemError, match=r"map\.yaml: robots\[0\]\.start: .* inside obstacle"):
        import_map(ros_map, Robots(radius=0.2, start=near, goal=t))
    with pytest.raises(ProblemError, match=r"map\.yaml: robots\[0\]\.goal: .* outside the map"):
        import_map(ros_map, Robots(radius=0.1, start=s, goal=(100.0, 0.0)))
    with pytest.raises(ProblemError, match=r"map\.yaml: unknown: expected 'occupied' or 'free'"):
        import_map(ros_map, Robots(radius=0.1, start=s, goal=t),
                   read=ReadOptions(unknown="maybe"))
    with pytest.raises(ProblemError, match=r"map\.yaml: simplify: needs grow > 0"):
        import_map(ros_map, Robots(radius=0.1, start=s, goal=t),
                   polygons=PolygonOptions(grow=0.0))
    with pytest.raises(ProblemError, match=r"map\.yaml: goal: 1 start\(s\) but 2 goal\(s\)"):
        import_map(ros_map, Robots(radius=0.1, start=s, goal=[t, t]))
    with pytest.raises(ProblemError, match=r"map\.yaml: start: expected a point"):
        import_map(ros_map, Robots(radius=0.1, start=[1, 2, 3], goal=t))


# --------------------------------------------------------------------------------------
# the command line
# --------------------------------------------------------------------------------------


def test_cli_import_map(tmp_path, ros_map, capsys):
    from optplan.cli import main

    g = read_ros_yaml(ros_map)
    s, t = free_point(g, *START_RC), free_point(g, *GOAL_RC)
    out = tmp_path / "scene.toml"
    rc = main(["import-map", str(ros_map), "--radius", str(RADIUS), "--start",
               f"{s[0]},{s[1]}", "--goal", f"{t[0]},{t[1]}", "--robot", "amr",
               "--max-speed", "0.8", "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "polygons" in text and f"wrote {out}" in text
    prob = op.read_problem(out)
    assert prob.robots[0].id == "amr" and prob.robots[0].max_speed == 0.8
    assert prob.robots[0].start.tolist() == s  # negative coordinates pass through argparse
    assert op.solve(prob, "visgraph").status.value == "optimal"
    # stdout when no --out; a shipped map by name; an error is one line, status 2
    assert main(["import-map", "warehouse", "--radius", "0.3", "--start", "-11,-11.5",
                 "--goal", "-9,9.8"]) == 0
    assert capsys.readouterr().out.startswith("# Imported from")
    assert main(["import-map", str(ros_map), "--radius", "0.1", "--start",
                 f"{g.cell_centre(20, 21)[0]},{g.cell_centre(20, 21)[1]}", "--goal",
                 f"{t[0]},{t[1]}"]) == 2
    err = capsys.readouterr().err
    assert "map.yaml: robots[0].start:" in err and "occupied cell" in err
    assert main(["import-map", "warehous", "--radius", "0.3", "--start", "0,0",
                 "--goal", "1,1"]) == 2
    assert "did you mean 'warehouse'" in capsys.readouterr().err
    assert main(["import-map", str(ros_map), "--radius", "0.1", "--start", "1;2",
                 "--goal", "1,1"]) == 2
    assert "--start: expected X,Y" in capsys.readouterr().err


# --------------------------------------------------------------------------------------
# issue 42: the resolution and the origin must give a representable map
# --------------------------------------------------------------------------------------


def _tiny_yaml(tmp_path: Path, resolution: str, origin: str = "[0.0, 0.0, 0.0]") -> Path:
    """A 10 x 10 map_server map (a wall along the top) with the given YAML values."""
    px = np.full((10, 10), 254, dtype=np.uint8)
    px[0, :] = 0
    Image.fromarray(px, mode="L").save(tmp_path / "tiny.pgm")
    y = tmp_path / "tiny.yaml"
    y.write_text(f"image: tiny.pgm\nresolution: {resolution}\norigin: {origin}\n",
                 encoding="utf-8")
    return y


@pytest.mark.parametrize("res", ["1e-300", "1e-40", "1e+40", "1e300"])
def test_a_resolution_outside_the_range_names_the_file_key_value_and_range(tmp_path, res):
    from optplan.maps.checks import MAP_MAX_LENGTH, MAP_MIN_LENGTH

    y = _tiny_yaml(tmp_path, res)
    value = re.escape(repr(float(res)))
    span = re.escape(f"[{MAP_MIN_LENGTH:g}, {MAP_MAX_LENGTH:g}]")
    pattern = (rf"tiny\.yaml: resolution: {value} makes the 10 x 10 cell map .* outside the "
               rf"supported range {span}; for this map the resolution must lie in "
               rf"\[7\.07e-32, 7\.07e\+28\]")
    with pytest.raises(ProblemError, match=pattern):
        read_ros_yaml(y)
    with pytest.raises(ProblemError, match=pattern):
        import_map(y, Robots(radius=0.0, start=(0, 0), goal=(0, 0)))
    # an in-memory grid: the same check, naming its source
    with pytest.raises(ProblemError, match=r"^<grid>: resolution: .* outside the supported"):
        Grid(np.zeros((10, 10), dtype=np.uint8), float(res))


def test_the_cli_prints_the_resolution_error_not_an_internal_error(tmp_path, capsys):
    from optplan.cli import main

    y = _tiny_yaml(tmp_path, "1e-300")
    assert main(["import-map", str(y), "--radius", "0", "--start", "0,0", "--goal",
                 "0,0"]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and "GEOS" not in err
    assert "tiny.yaml: resolution: 1e-300 makes the 10 x 10 cell map" in err


def test_an_origin_too_far_for_the_map_size_is_an_error(tmp_path):
    y = _tiny_yaml(tmp_path, "1.0", "[1.0e+300, 0.0, 0.0]")
    with pytest.raises(ProblemError, match=r"tiny\.yaml: origin: \[1e\+300, 0\.0, 0\.0\] puts "
                                           r"the centre of the map .* more than 1e\+06 x its "
                                           r"diagonal"):
        read_ros_yaml(y)
    with pytest.raises(ProblemError, match=r"<grid>: origin: .* shift the origin"):
        Grid(np.zeros((2, 2), dtype=np.uint8), 1.0, (1e20, 0.0, 0.0))


@pytest.mark.parametrize("res", [1e-31, 5e-2, 7e28])
def test_maps_at_both_ends_of_the_range_import_cleanly(tmp_path, res):
    """The extreme resolutions accepted make a valid scenario without a numerical warning."""
    import warnings

    y = _tiny_yaml(tmp_path, repr(res))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        prob = import_map(y, Robots(radius=0.0, start=(5 * res, 5 * res),
                                    goal=(5 * res, 3 * res), max_speed=res))
    assert prob.bounds == pytest.approx((0.0, 0.0, 10 * res, 10 * res))
    assert len(prob.obstacles) == 1


@pytest.mark.parametrize("res", [np.float32(0.5), np.float64(0.5), np.int64(2), np.int32(1)])
def test_numpy_resolutions_are_numbers(tmp_path, res):
    png = tmp_path / "p.png"
    Image.fromarray(np.full((4, 6), 254, dtype=np.uint8), mode="L").save(png)
    g = read_grid(png, resolution=res, origin=(np.float32(1.0), np.int64(2)))
    assert type(g.resolution) is float and g.resolution == float(res)
    assert g.origin == (1.0, 2.0, 0.0) and g.bounds == (1.0, 2.0, 1.0 + 6 * float(res),
                                                       2.0 + 4 * float(res))
    assert Grid(g.cells, res).resolution == float(res)
    prob = import_map(png, Robots(radius=0.0, start=(float(res), float(res)),
                                  goal=(2 * float(res), float(res))),
                      read=ReadOptions(resolution=res))
    assert prob.bounds == pytest.approx((0.0, 0.0, 6 * float(res), 4 * float(res)))


@pytest.mark.parametrize("res", [True, np.bool_(True), "0.5", None])
def test_booleans_and_strings_are_not_resolutions(tmp_path, res):
    png = tmp_path / "p.png"
    Image.fromarray(np.full((4, 6), 254, dtype=np.uint8), mode="L").save(png)
    with pytest.raises(ProblemError, match=rf"p\.png: resolution: expected a number, got "
                                           rf"{re.escape(repr(res))}"):
        read_image(png, resolution=res)


@pytest.mark.parametrize("negate", [True, 1, np.True_, np.int64(1)])
def test_negate_takes_numpy_scalars_as_python_ones(tmp_path, negate):
    png = tmp_path / "p.png"
    px = np.full((4, 6), 254, dtype=np.uint8)
    px[0, :] = 0
    Image.fromarray(px, mode="L").save(png)
    ref = read_image(png, resolution=1.0, negate=True)
    assert (read_image(png, resolution=1.0, negate=negate).cells == ref.cells).all()
    with pytest.raises(ProblemError, match=r"p\.png: negate: expected 0 or 1, got "):
        read_image(png, resolution=1.0, negate=np.int64(2))
