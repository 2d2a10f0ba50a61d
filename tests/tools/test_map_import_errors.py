"""Import quality of life (issue 27, item 4): cropping to the map's extent, scene names, what
the MovingAI readers tolerate, and the errors (file and line) for what is wrong.

* ``crop="auto"`` crops a map whose unknown margin (the cells outside the bounding box of the
  known cells) is more than ``CROP_MARGIN`` of the image, only then, and stays conservative;
* a scene is named after its file, a ``map.yaml`` after its directory;
* blank lines anywhere in a ``.scen``, white space around fields, CRLF, and text after a
  ``.map`` grid are read;
* a ``.scen`` line naming another map, a ``nan``/negative/infinite optimum, a cell outside the
  map, a grid row beyond ``height``, a header width of 1e12 and an image above the pixel limit
  are errors naming the file and the line (or key), raised before anything large is allocated.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import shapely
from PIL import Image

import optplan as op
from optplan import ProblemError
from optplan.maps import (
    CROP_MARGIN,
    FREE,
    MAX_CELLS,
    OCCUPIED,
    UNKNOWN,
    Grid,
    ReadOptions,
    Robots,
    import_map,
    read_grid,
    read_scen,
    read_scen_entries,
    scene_name,
)

RES = 0.05


def _ros(tmp: Path, cells: np.ndarray, name: str = "map", origin: str = "[-2.0, -1.0, 0.0]"
         ) -> Path:
    """A map_server map (PGM + YAML) of the cells (free 254, occupied 0, unknown 205)."""
    tmp.mkdir(parents=True, exist_ok=True)
    px = np.choose(cells, [254, 0, 205]).astype(np.uint8)
    Image.fromarray(px, mode="L").save(tmp / f"{name}.pgm")
    y = tmp / f"{name}.yaml"
    y.write_text(f"image: {name}.pgm\nresolution: {RES}\norigin: {origin}\n", encoding="utf-8")
    return y


def arena(margin: int) -> np.ndarray:
    """A 20 x 30 walled room with a wall inside, in ``margin`` unknown cells on every side
    (and one more column on the right)."""
    room = np.full((20, 30), FREE, dtype=np.uint8)
    room[0, :] = room[-1, :] = OCCUPIED
    room[:, 0] = room[:, -1] = OCCUPIED
    room[4:16, 14] = OCCUPIED
    c = np.full((20 + 2 * margin, 30 + 2 * margin + 1), UNKNOWN, dtype=np.uint8)
    c[margin:margin + 20, margin:margin + 30] = room
    return c


def _centre(grid: Grid, row: int, col: int) -> list[float]:
    return grid.cell_centre(row, col).tolist()


# --------------------------------------------------------------------------------------
# cropping
# --------------------------------------------------------------------------------------


def test_auto_crop_on_a_large_unknown_margin(tmp_path):
    cells = arena(25)                         # 70 x 81 image, the room 20 x 30: 89 % margin
    y = _ros(tmp_path / "lab", cells)
    g = read_grid(y)
    s, t = _centre(g, 25 + 10, 25 + 5), _centre(g, 25 + 10, 25 + 25)
    info: dict = {}
    prob = import_map(y, Robots(radius=0.05, start=s, goal=t), info=info)
    crop = info["crop"]
    assert crop["cropped"] and crop["rows"] == [25, 45] and crop["cols"] == [25, 55]
    assert crop["margin"] == pytest.approx(1 - 600 / (70 * 81)) and crop["margin"] > CROP_MARGIN
    # the bounds are the room's cells, in world coordinates (origin + 25 cells, rows from the top)
    x0, y0 = -2.0 + 25 * RES, -1.0 + (70 - 45) * RES
    assert prob.bounds == pytest.approx((x0, y0, x0 + 30 * RES, y0 + 20 * RES), abs=1e-12)
    assert "cropped from 81 x 70" in prob.description
    assert info["cells"]["unknown"] == 0
    # still conservative: every occupied cell square of the uncropped grid is covered
    union = shapely.union_all([o.geometry for o in prob.obstacles])
    occ = g.squares(g.cells == OCCUPIED)
    assert occ.difference(union).area <= 1e-12 * occ.area
    # the same optimum as without cropping (the margin was an obstacle either way)
    full = import_map(y, Robots(radius=0.05, start=s, goal=t), read=ReadOptions(crop=False))
    assert full.bounds == pytest.approx(g.bounds)
    a = op.solve(prob, "visgraph").metrics["length"]
    b = op.solve(full, "visgraph").metrics["length"]
    assert a == pytest.approx(b, rel=1e-9)


def test_auto_crop_only_above_the_threshold_and_with_unknown_as_obstacles(tmp_path):
    cells = arena(2)                          # 24 x 35 image: 29 % margin, above 25 %
    y = _ros(tmp_path / "small", cells)
    g = read_grid(y)
    s, t = _centre(g, 12, 7), _centre(g, 12, 27)
    info: dict = {}
    import_map(y, Robots(radius=0.05, start=s, goal=t), info=info)
    assert info["crop"]["cropped"]
    cells = arena(1)                          # 22 x 33 image: 17 % margin, not cropped
    y = _ros(tmp_path / "tiny", cells)
    g = read_grid(y)
    s, t = _centre(g, 11, 6), _centre(g, 11, 26)
    prob = import_map(y, Robots(radius=0.05, start=s, goal=t), info=info)
    assert not info["crop"]["cropped"] and info["crop"]["margin"] < CROP_MARGIN
    assert prob.bounds == pytest.approx(g.bounds)
    assert import_map(y, Robots(radius=0.05, start=s, goal=t),
                      read=ReadOptions(crop=True)).bounds != \
        pytest.approx(g.bounds)
    # unknown = free: the margin is free space, auto keeps it; crop=True drops it
    y = _ros(tmp_path / "wide", arena(25))
    g = read_grid(y)
    s, t = _centre(g, 35, 30), _centre(g, 2, 2)  # the goal in the unknown margin
    prob = import_map(y, Robots(radius=0.05, start=s, goal=t), read=ReadOptions(unknown="free"),
                      info=info)
    assert not info["crop"]["cropped"] and prob.bounds == pytest.approx(g.bounds)
    with pytest.raises(ProblemError, match=r"map\.yaml: robots\[0\]\.goal: .* outside the "
                                           r"known part of the map .*crop=False"):
        import_map(y, Robots(radius=0.05, start=s, goal=t),
                   read=ReadOptions(unknown="free", crop=True))
    with pytest.raises(ProblemError, match=r"map\.yaml: crop: expected 'auto', True or False"):
        import_map(y, Robots(radius=0.05, start=s, goal=s), read=ReadOptions(crop="yes"))


def test_crop_of_a_rotated_map_keeps_the_cells_in_place(tmp_path):
    y = _ros(tmp_path / "rot", arena(25), origin="[1.0, 2.0, 0.5]")
    g = read_grid(y)
    s, t = _centre(g, 35, 30), _centre(g, 35, 50)
    prob = import_map(y, Robots(radius=0.05, start=s, goal=t))
    union = shapely.union_all([o.geometry for o in prob.obstacles])
    occ = g.squares(g.cells == OCCUPIED)
    assert occ.difference(union).area <= 1e-9 * occ.area
    room = g.squares(g.cells != UNKNOWN)
    assert shapely.box(*prob.bounds).equals_exact(shapely.box(*room.bounds), 1e-9)


def test_cli_crop_options(tmp_path, capsys):
    from optplan.cli import main

    y = _ros(tmp_path / "lab", arena(25))
    g = read_grid(y)
    s, t = _centre(g, 35, 30), _centre(g, 35, 50)
    args = ["import-map", str(y), "--radius", "0.05", "--start", f"{s[0]},{s[1]}", "--goal",
            f"{t[0]},{t[1]}", "--out", str(tmp_path / "a.toml")]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "cropped to the known cells: rows 25..44, columns 25..54 of 70 x 81 (89% " in out
    prob = op.read_problem(tmp_path / "a.toml")
    assert prob.name == "lab" and prob.bounds[2] - prob.bounds[0] == pytest.approx(1.5)
    assert main([*args, "--crop", "off"]) == 0
    assert "cropped" not in capsys.readouterr().out
    assert op.read_problem(tmp_path / "a.toml").bounds == pytest.approx(g.bounds)
    assert main([*args, "--max-cells", "1000"]) == 2
    err = capsys.readouterr().err
    assert "map.yaml: image: image" in err and "81 x 70 = 5,670 cells, more than the limit " \
                                                 "of 1,000" in err


# --------------------------------------------------------------------------------------
# names
# --------------------------------------------------------------------------------------


def test_scenes_are_named_after_their_file(tmp_path):
    assert scene_name(tmp_path / "turtlebot3_world" / "map.yaml") == "turtlebot3_world"
    assert scene_name(tmp_path / "lab 2" / "maps" / "map.yaml") == "lab-2"
    assert scene_name("office.yaml") == "office" and scene_name("x/random-32-32-20.map") == \
        "random-32-32-20"
    y = _ros(tmp_path / "turtlebot3_world", arena(1))
    g = read_grid(y)
    prob = import_map(y, Robots(radius=0.05, start=_centre(g, 11, 6), goal=_centre(g, 11, 26)))
    assert prob.name == "turtlebot3_world"
    assert all(o.name.startswith("turtlebot3_world-") for o in prob.obstacles)


# --------------------------------------------------------------------------------------
# MovingAI: what is tolerated
# --------------------------------------------------------------------------------------

MAP = "type octile\nheight 4\nwidth 6\nmap\n@@@@@@\n@..T.@\n@....@\n@@@@@@\n"
LINES = ["0\tarena.map\t6\t4\t1\t1\t4\t2\t3.41421356", "1\tarena.map\t6\t4\t1\t2\t4\t1\t3.41421356"]


@pytest.fixture()
def movingai(tmp_path) -> Path:
    (tmp_path / "arena.map").write_text(MAP, encoding="ascii")
    return tmp_path


def test_scen_blank_and_trailing_lines_are_read(movingai):
    clean = movingai / "clean.scen"
    clean.write_text("version 1\n" + "\n".join(LINES) + "\n", encoding="utf-8")
    messy = movingai / "messy.scen"
    messy.write_text("\n  \nversion 1\r\n\r\n" + LINES[0] + " \t\r\n\n\t\n" + LINES[1]
                     + "\t\n\n\n   \n", encoding="utf-8")
    a, b = read_scen_entries(clean), read_scen_entries(messy)
    assert [(e.start, e.goal, e.optimal_length) for e in a] == \
        [(e.start, e.goal, e.optimal_length) for e in b]
    assert [e.line for e in b] == [5, 8]
    assert [q.name for q in read_scen(messy)] == ["messy-5", "messy-8"]


def test_text_after_a_map_grid_is_ignored(movingai):
    m = movingai / "cited.map"
    body = MAP.replace("\n", "  \r\n")  # CRLF and trailing blanks on every line
    m.write_bytes(body.encode("ascii") + "\nFrom the MovingAI benchmarks, \u00a9 2012 N. "
                  "Sturtevant (CC BY).\n\n@@@@\n".encode())
    assert np.array_equal(read_grid(m).cells, read_grid(movingai / "arena.map").cells)


# --------------------------------------------------------------------------------------
# MovingAI: errors naming the file and the line
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("line, pattern", [
    ("0\tother.map\t6\t4\t1\t1\t4\t2\t3.4", r"bad\.scen: line 3: names the map 'other\.map', "
                                             r"line 2 names 'arena\.map'"),
    ("0\tarena.map\t6\t4\t1\t1\t4\t2\tnan", r"bad\.scen: line 3: optimal length 'nan': "
                                             r"expected a finite number >= 0"),
    ("0\tarena.map\t6\t4\t1\t1\t4\t2\t-3.5", r"bad\.scen: line 3: optimal length '-3\.5'"),
    ("0\tarena.map\t6\t4\t1\t1\t4\t2\tinf", r"bad\.scen: line 3: optimal length 'inf'"),
    ("0\tarena.map\t6\t4\t6\t1\t4\t2\t3.4", r"bad\.scen: line 3: start cell \(6, 1\) lies "
                                             r"outside the 6 x 4 map"),
    ("0\tarena.map\t6\t4\t1\t1\t4\t-1\t3.4", r"bad\.scen: line 3: goal cell \(4, -1\) lies "
                                              r"outside the 6 x 4 map"),
    ("0\tarena.map\t0\t4\t0\t0\t0\t0\t0", r"bad\.scen: line 3: map size 0 x 4"),
    ("0\tarena.map\t6\t4\t1\t1\t4\t2", r"bad\.scen: line 3: expected 9 fields"),
    ("0\tarena.map\t6\t4\t1\tone\t4\t2\t3", r"bad\.scen: line 3: non-numeric field"),
])
def test_scen_line_errors(movingai, line, pattern):
    bad = movingai / "bad.scen"
    bad.write_text(f"version 1\n{LINES[0]}\n{line}\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=pattern):
        read_scen(bad)


def test_scen_line_whose_disc_overlaps_an_obstacle(tmp_path):
    """A later line (checked after one distance query for all lines) whose start cell is
    free but too close to a wall for the robot's disc: that line is named."""
    (tmp_path / "hall.map").write_text("type octile\nheight 5\nwidth 7\nmap\n@@@@@@@\n"
                                       "@.....@\n@.....@\n@.....@\n@@@@@@@\n", encoding="ascii")
    scen = tmp_path / "hall.scen"
    scen.write_text("version 1\n0\thall.map\t7\t5\t3\t2\t4\t2\t1\n"
                    "0\thall.map\t7\t5\t1\t1\t3\t2\t2.4\n", encoding="utf-8")
    assert len(read_scen(scen, radius=0.2)) == 2
    with pytest.raises(ProblemError, match=r"hall\.scen:3: robots\[0\]\.start: .* inflated "
                                           r"by the robot radius 0\.45"):
        read_scen(scen, radius=0.45)


def test_scen_cell_outside_the_map_file(movingai):
    """A line consistent in itself, for a bigger map than the file: the line is named."""
    bad = movingai / "big.scen"
    bad.write_text("version 1\n0\tarena.map\t60\t40\t50\t1\t4\t2\t3.4\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=r"big\.scen: line 2: the scenario is for a 60 x 40"):
        read_scen(bad)


@pytest.mark.parametrize("text, pattern", [
    (MAP + "@....@\n", r"x\.map: line 9: a grid row after the 4 rows the header's height gives"),
    (MAP + "\n\n@@@@@@\nsome text\n", r"x\.map: line 11: a grid row after the 4 rows"),
    (MAP.replace("width 6", "width 1e12"), r"x\.map: line 3: width: expected a positive "
                                           r"integer, got '1e12'"),
    (MAP.replace("width 6", "width 1000000000000"),
     r"x\.map: line 3: 1000000000000 x 4 = 4,000,000,000,000 cells, more than the limit of "
     r"67,108,864 \(max_cells"),
    (MAP.replace("height 4", "height 9999999999999999999999"), r"x\.map: line 3: 6 x "
                                                               r"9999999999999999999999 = "),
    (MAP.replace("@..T.@", "@..\u00e9.@"), r"x\.map: line 6: non-ASCII byte at "
                                           r"column 4"),
])
def test_map_errors_name_the_line(tmp_path, text, pattern):
    m = tmp_path / "x.map"
    m.write_bytes(text.encode("utf-8"))
    tracemalloc.start()
    try:
        with pytest.raises(ProblemError, match=pattern):
            read_grid(m)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5_000_000  # nothing of the header's size was allocated


def test_image_too_large_to_decode(tmp_path):
    """A PGM whose header says 10,000 x 10,000 (no pixel data): rejected from its header,
    before Pillow decodes (or its decompression-bomb check warns about) anything."""
    big = tmp_path / "big.pgm"
    big.write_bytes(b"P5\n10000 10000\n255\n" + b"\0" * 64)
    y = tmp_path / "big.yaml"
    y.write_text("image: big.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", encoding="utf-8")
    assert 10000 * 10000 > MAX_CELLS
    with pytest.raises(ProblemError, match=r"big\.yaml: image: image '.*big\.pgm': 10000 x "
                                           r"10000 = 100,000,000 cells, more than the limit"):
        read_grid(y)
    with pytest.raises(ProblemError, match=r"big\.pgm: image: image .* more than the limit"):
        import_map(big, Robots(radius=0.1, start=(1, 1), goal=(2, 2)),
                   read=ReadOptions(resolution=0.05))
    # the limit is an option: a small image under a smaller limit
    small = tmp_path / "s.png"
    Image.fromarray(np.full((30, 40), 254, dtype=np.uint8), mode="L").save(small)
    assert read_grid(small, resolution=1.0, max_cells=1200).cells.shape == (30, 40)
    with pytest.raises(ProblemError, match=r"s\.png: image: .*40 x 30 = 1,200 cells, more "
                                           r"than the limit of 1,199"):
        read_grid(small, resolution=1.0, max_cells=1199)
    m = tmp_path / "m.map"
    m.write_text(MAP, encoding="ascii")
    with pytest.raises(ProblemError, match=r"m\.map: line 3: 6 x 4 = 24 cells, more than "
                                           r"the limit of 23"):
        import_map(m, Robots(radius=0.1, start=(1.5, 2.5), goal=(4.5, 1.5)),
                   read=ReadOptions(max_cells=23))


# --------------------------------------------------------------------------------------
# issue 42: crop switches, the cell limit of an in-memory grid, a byte order mark
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(("crop", "cropped"), [
    (True, True), (np.True_, True), (False, False), (np.False_, False), ("auto", True)])
def test_crop_takes_bools_of_either_kind(tmp_path, crop, cropped):
    y = _ros(tmp_path / "lab", arena(25))
    g = read_grid(y)
    s, t = _centre(g, 35, 30), _centre(g, 35, 50)
    info: dict = {}
    prob = import_map(y, Robots(radius=0.05, start=s, goal=t), read=ReadOptions(crop=crop),
                      info=info)
    assert info["crop"]["cropped"] is cropped
    assert (prob.bounds != g.bounds) is cropped


@pytest.mark.parametrize("crop", [0, 0.0, 1, 1.0, np.int64(0), np.float64(0.0), 0.25])
def test_a_number_is_not_a_crop_switch(tmp_path, crop):
    y = _ros(tmp_path / "lab", arena(25))
    g = read_grid(y)
    s, t = _centre(g, 35, 30), _centre(g, 35, 50)
    with pytest.raises(ProblemError, match=rf"lab/map\.yaml: crop: expected 'auto', True or "
                                           rf"False, got .*{type(crop).__name__}; a number is "
                                           rf"not accepted: crop is a switch, not a margin"):
        import_map(y, Robots(radius=0.05, start=s, goal=t), read=ReadOptions(crop=crop))


def test_the_cell_limit_holds_for_an_in_memory_grid():
    """``import_map(grid=...)`` checks ``max_cells`` as the readers do (an 81 M-cell grid is
    refused by default, before any geometry; a broadcast array: nothing is allocated)."""
    big = Grid(np.broadcast_to(np.uint8(FREE), (9000, 9000)), 1.0, source="big")
    robots = Robots(radius=0.0, start=(0.5, 0.5), goal=(1.5, 0.5))
    with pytest.raises(ProblemError, match=r"^mem: grid: the grid: 9000 x 9000 = 81,000,000 "
                                           r"cells, more than the limit of 67,108,864"):
        import_map("mem", robots, grid=big)
    small = Grid(np.zeros((4, 6), dtype=np.uint8), 1.0)
    prob = import_map("mem", robots, read=ReadOptions(max_cells=24), grid=small)
    assert prob.bounds == (0.0, 0.0, 6.0, 4.0)
    with pytest.raises(ProblemError, match=r"mem: grid: the grid: 6 x 4 = 24 cells, more "
                                           r"than the limit of 23"):
        import_map("mem", robots, read=ReadOptions(max_cells=23), grid=small)
    with pytest.raises(ProblemError, match=r"mem: grid: expected an optplan\.maps\.Grid, got "
                                           r"ndarray"):
        import_map("mem", robots, grid=small.cells)


@pytest.mark.parametrize(("cells", "match"), [
    (np.zeros(4, dtype=np.uint8), r"cells: expected a 2-D integer array"),
    (np.zeros((0, 3), dtype=np.uint8), r"cells: expected a 2-D integer array"),
    (np.full((2, 2), 0.5), r"cells: expected a 2-D integer array"),
    (np.full((2, 2), 3, dtype=np.uint8), r"cells: values 3\.\.3: expected FREE"),
])
def test_bad_cells_of_an_in_memory_grid(cells, match):
    with pytest.raises(ProblemError, match=r"^<grid>: " + match):
        Grid(cells, 1.0)


def test_a_byte_order_mark_before_a_map_is_dropped(tmp_path):
    m = tmp_path / "bom.map"
    m.write_bytes(b"\xef\xbb\xbf" + MAP.encode("ascii"))
    plain = tmp_path / "plain.map"
    plain.write_text(MAP, encoding="ascii")
    g, ref = read_grid(m), read_grid(plain)
    assert (g.cells == ref.cells).all() and g.cells.shape == (4, 6)
    # only at the start of the file: elsewhere it is an unexpected header line
    m.write_bytes(b"type octile\n\xef\xbb\xbfheight 4\nwidth 6\nmap\n" + MAP.encode()[33:])
    with pytest.raises(ProblemError, match=r"bom\.map: line 2: expected 'type T', 'height H'"):
        read_grid(m)
