"""The option objects of ``import_map`` and ``read_scen`` (optplan.maps.options): defaults, frozen
values, and errors naming the map, the option, the value and what is allowed."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from optplan import ProblemError
from optplan.maps import (
    MAX_CELLS,
    SCEN_POLYGONS,
    PolygonOptions,
    ReadOptions,
    Robots,
    SceneOptions,
    import_map,
    read_scen,
)

MAP = "type octile\nheight 4\nwidth 6\nmap\n......\n.@@...\n......\n......\n"
SCEN = "version 1\n0\tm.map\t6\t4\t0\t0\t5\t3\t5.82842712\n"
ROBOT = Robots(start=(0.5, 0.5), goal=(5.5, 3.5), radius=0.1)


@pytest.fixture
def movingai(tmp_path: Path) -> Path:
    (tmp_path / "m.map").write_text(MAP, encoding="ascii")
    (tmp_path / "m.scen").write_text(SCEN, encoding="utf-8")
    return tmp_path / "m.map"


def test_the_defaults_are_the_commands():
    assert (PolygonOptions().grow, PolygonOptions().simplify, PolygonOptions().join) == \
        (0.5, 0.5, "round")
    read = ReadOptions()
    assert (read.unknown, read.crop, read.max_cells, read.resolution) == \
        ("occupied", "auto", MAX_CELLS, None)
    assert SceneOptions().tags == ("map",) and SceneOptions().dynamic_obstacles == ()
    assert (ROBOT.ids, ROBOT.max_speed) == (None, 1.0)
    assert (SCEN_POLYGONS.grow, SCEN_POLYGONS.simplify, SCEN_POLYGONS.join) == \
        (0.25, 0.2, "round")


def test_options_are_frozen_and_keyword_only():
    with pytest.raises(dataclasses.FrozenInstanceError):
        ROBOT.radius = 0.2  # type: ignore[misc]
    with pytest.raises(TypeError):
        PolygonOptions(1.0)  # type: ignore[misc]
    with pytest.raises(TypeError, match="radius"):
        Robots(start=(0, 0), goal=(1, 1))  # type: ignore[call-arg]


def test_the_options_reach_the_problem(movingai):
    prob = import_map(movingai, Robots(start=[(1.0, 1.0), (11.0, 1.0)],
                                       goal=[(11.0, 7.0), (9.0, 7.0)], radius=0.1,
                                       ids=["a", "b"], max_speed=2.0),
                      read=ReadOptions(resolution=2.0, origin=(0.0, 0.0)),
                      polygons=PolygonOptions(grow=0.5, simplify=0.0, join="mitre"),
                      scene=SceneOptions(name="opts", tags=["x"], goal_tolerance=0.5,
                                         sensing_range=3.0))
    assert prob.name == "opts" and list(prob.tags) == ["x"]
    assert (prob.goal_tolerance, prob.sensing_range) == (0.5, 3.0)
    assert [r.id for r in prob.robots] == ["a", "b"]
    assert all(r.max_speed == 2.0 for r in prob.robots)
    assert prob.bounds == (0.0, 0.0, 12.0, 8.0)
    assert "grow=0.5 cells, simplify=0 cells" in prob.source
    assert prob.obstacles[0].geometry.bounds == (1.0, 3.0, 7.0, 7.0)  # mitre: a rectangle


@pytest.mark.parametrize(("options", "match"), [
    ({"polygons": PolygonOptions(grow=-1)}, r"grow: must be >= 0 \(cells\), got -1$"),
    ({"polygons": PolygonOptions(simplify=5)}, r"simplify: 5 cells is coarser than the map; "
                                               r"use at most 4$"),
    ({"polygons": PolygonOptions(join="square")}, r"join: expected 'round' or 'mitre', got "
                                                  r"'square'$"),
    ({"read": ReadOptions(unknown="maybe")}, r"unknown: expected 'occupied' or 'free', got "
                                             r"'maybe'$"),
    ({"read": ReadOptions(max_cells=0)}, r"max_cells: expected a positive integer"),
    ({"read": ReadOptions(crop=1)}, r"crop: expected 'auto', True or False, got 1"),
    ({"robots": Robots(start=(0.5, 0.5), goal=(5.5, 3.5), radius=-1.0)},
     r"radius: must be >= 0, got -1\.0$"),
    ({"robots": Robots(start=(0.5, 0.5), goal=(5.5, 3.5), radius=0.1, ids=["a", "b"])},
     r"robot: 2 robot id\(s\) for 1 start\(s\)$"),
])
def test_a_bad_option_names_the_map_the_option_and_the_value(movingai, options, match):
    robots = options.pop("robots", ROBOT)
    with pytest.raises(ProblemError, match=r"m\.map: " + match):
        import_map(movingai, robots, **options)


@pytest.mark.parametrize(("key", "value", "cls"), [
    ("robots", {"start": (0.5, 0.5)}, "Robots"),
    ("read", {"resolution": 1.0}, "ReadOptions"),
    ("polygons", {"grow": 1.0}, "PolygonOptions"),
    ("scene", "name", "SceneOptions"),
])
def test_an_option_of_the_wrong_class_is_named(movingai, key, value, cls):
    kwargs = {"robots": ROBOT, key: value}
    with pytest.raises(ProblemError, match=rf"m\.map: {key}: expected an optplan\.maps\.{cls}, "
                                           rf"got {type(value).__name__}$"):
        import_map(movingai, **kwargs)


def test_read_scen_takes_polygon_options(movingai):
    default = read_scen(movingai.with_suffix(".scen"))
    assert read_scen(movingai.with_suffix(".scen"), polygons=SCEN_POLYGONS)[0].source == \
        default[0].source
    assert "grow=0.25, simplify=0.2 cells" in default[0].source
    coarse = read_scen(movingai.with_suffix(".scen"),
                       polygons=PolygonOptions(grow=0.4, simplify=0.0, join="mitre"))
    assert "grow=0.4, simplify=0 cells" in coarse[0].source
    assert coarse[0].obstacles[0].geometry.area > default[0].obstacles[0].geometry.area
    with pytest.raises(ProblemError, match=r"m\.scen: polygons: expected an "
                                           r"optplan\.maps\.PolygonOptions, got dict$"):
        read_scen(movingai.with_suffix(".scen"), polygons={"grow": 0.25})  # type: ignore[arg-type]
