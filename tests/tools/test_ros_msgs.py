"""ROS-shaped data without ROS: a result's timed path as ``nav_msgs/Path`` (API and
``optplan export-path``), an in-memory ``nav_msgs/OccupancyGrid`` as a grid."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

import optplan as op
from optplan import cli
from optplan.catalog import find_map
from optplan.maps import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    Robots,
    import_map,
    occupancy_grid_msg,
    path_msg,
    read_occupancy_grid,
    read_path_msg,
    read_ros_yaml,
    timed_path_msg,
)
from optplan.maps.ros_msgs import headings
from optplan.metrics import time_stamps
from optplan.problem import ProblemError


@pytest.fixture(scope="module")
def visgraph_result():
    return op.solve("paper-env1", "visgraph")


def _check_shape(msg: dict, frame: str, n: int) -> None:
    assert set(msg) == {"header", "poses"} and len(msg["poses"]) == n
    assert msg["header"]["frame_id"] == frame
    assert msg["header"]["stamp"] == msg["poses"][0]["header"]["stamp"]
    for ps in msg["poses"]:
        assert set(ps) == {"header", "pose"} and ps["header"]["frame_id"] == frame
        st = ps["header"]["stamp"]
        assert set(st) == {"sec", "nanosec"} and 0 <= st["nanosec"] < 10**9
        assert all(isinstance(v, int) for v in st.values())
        assert set(ps["pose"]) == {"position", "orientation"}
        assert ps["pose"]["position"]["z"] == 0.0
        q = ps["pose"]["orientation"]
        assert q["x"] == q["y"] == 0.0 and math.isclose(math.hypot(q["z"], q["w"]), 1.0)


def test_the_path_message_has_the_shape_of_nav_msgs_path(visgraph_result):
    res = visgraph_result
    msg = path_msg(res, frame_id="odom", start_time=100.25)
    _check_shape(msg, "odom", len(res.path))
    assert msg["header"]["stamp"] == {"sec": 100, "nanosec": 250_000_000}
    back = read_path_msg(msg)
    assert back.frame_id == "odom"
    np.testing.assert_array_equal(back.points, res.path)
    # a geometric path is stamped as the validator times it: at max speed from t = 0
    t = time_stamps(res.scenario_problem(), {"r1": res.path}, None)["r1"]
    np.testing.assert_allclose(back.times - 100.25, t, rtol=0, atol=1e-8)
    d = np.diff(res.path, axis=0)
    np.testing.assert_allclose(back.yaw[:-1], np.arctan2(d[:, 1], d[:, 0]), atol=1e-12)
    assert back.yaw[-1] == back.yaw[-2]


def test_a_simulated_trajectory_keeps_its_own_times():
    res = op.solve("trap-u", "sa-apf-paper", rng=0)
    assert res.times is not None
    back = read_path_msg(path_msg(res))
    np.testing.assert_allclose(back.times, res.times, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(back.points, res.path)


def test_headings_keep_the_last_direction_at_waits_and_the_end():
    pts = [(0, 0), (0, 0), (1, 0), (1, 1), (1, 1), (0, 1), (0, 1)]
    yaw = headings(pts)
    half = math.pi / 2
    np.testing.assert_allclose(yaw, [0, 0, half, half, math.pi, math.pi, math.pi])
    assert headings([(2.0, 3.0)]).tolist() == [0.0] and headings([(1, 1)] * 3).tolist() == [0] * 3
    msg = timed_path_msg(pts, [0, 1, 2, 3, 4, 5, 6])
    q = [p["pose"]["orientation"] for p in msg["poses"]]
    assert (q[3]["z"], q[3]["w"]) == pytest.approx((math.sin(half / 2), math.cos(half / 2)))
    assert (q[4]["z"], q[4]["w"]) == pytest.approx((1.0, 0.0), abs=1e-15)  # heading pi


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"start_time": -1.0}, r"start_time: stamps must lie in \[0, 2147483647\]"),
    ({"start_time": 2.0**31}, r"start_time: stamps must lie in \[0, 2147483647\]"),
    ({"frame_id": 3}, "frame_id: expected a string"),
])
def test_path_errors_name_the_argument(kwargs, match):
    with pytest.raises(ValueError, match=match):
        timed_path_msg([(0, 0), (1, 0)], [0, 1], **kwargs)


def test_unknown_robot_names_the_allowed_ids(visgraph_result):
    with pytest.raises(ValueError, match=r"robot: no robot 'zz' in the result \(allowed: r1\)"):
        path_msg(visgraph_result, "zz")


def test_export_path_round_trips_through_yaml_and_json(visgraph_result, tmp_path, capsys):
    res = visgraph_result
    res.save(tmp_path / "r.json")
    assert cli.main(["export-path", str(tmp_path / "r.json"), "--frame-id", "world"]) == 0
    from_yaml = yaml.safe_load(capsys.readouterr().out)
    assert from_yaml == path_msg(res, frame_id="world")
    out = tmp_path / "plan.json"
    assert cli.main(["export-path", str(tmp_path / "r.json"), "--out", str(out),
                     "--start-time", "5"]) == 0
    assert capsys.readouterr().out.startswith(f"wrote {out}: nav_msgs/Path of robot r1, "
                                              f"{len(res.path)} poses")
    back = read_path_msg(json.loads(out.read_text()))
    np.testing.assert_array_equal(back.points, res.path)
    assert back.times[0] == 5.0
    assert cli.main(["export-path", str(tmp_path / "r.json"), "--robot", "zz"]) == 2
    assert "--robot: no robot 'zz' in the result (allowed: r1)" in capsys.readouterr().err
    assert cli.main(["export-path", str(tmp_path / "r.json"), "--start-time", "nan"]) == 2
    assert "--start-time must be" in capsys.readouterr().err


def test_read_path_msg_names_the_bad_key():
    msg = timed_path_msg([(0, 0), (1, 0)], [0, 1])
    msg["poses"][1]["pose"]["orientation"] = {"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}
    with pytest.raises(ProblemError, match=r"poses\[1\]\.pose\.orientation: only rotations "
                                           r"about the z axis"):
        read_path_msg(msg)
    with pytest.raises(ProblemError, match=r"<nav_msgs/Path>: poses: missing required key"):
        read_path_msg({"header": {"frame_id": "map"}})


# -- nav_msgs/OccupancyGrid ------------------------------------------------------------------


def _grid_msg(data, width=3, height=2, resolution=0.5, origin=None) -> dict:
    origin = origin or {"position": {"x": 1.0, "y": 2.0, "z": 0.0},
                        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
    return {"header": {"frame_id": "map", "stamp": {"sec": 0, "nanosec": 0}},
            "info": {"resolution": resolution, "width": width, "height": height,
                     "origin": origin},
            "data": data}


def test_the_grid_rows_start_at_the_origin_cell():
    g = read_occupancy_grid(_grid_msg([0, 100, -1,
                                       50, 0, 19]))
    # row 0 of the data is the bottom row of the map, the last row of the grid (image order)
    assert g.cells.tolist() == [[UNKNOWN, FREE, FREE], [FREE, OCCUPIED, UNKNOWN]]
    assert (g.resolution, g.origin, g.width, g.height) == (0.5, (1.0, 2.0, 0.0), 3, 2)
    assert g.cell_of((1.25, 2.25)) == (1, 0)  # the origin cell
    assert g.cell_of((1.75, 2.25)) == (1, 1)  # data[1] = 100: occupied
    # the thresholds of map_server's raw mode: 50 is unknown, 19 free (< 19.6), 66 occupied
    assert read_occupancy_grid(_grid_msg([66] * 6)).cells.tolist() == [[OCCUPIED] * 3] * 2
    assert read_occupancy_grid(_grid_msg([50] * 6), occupied_thresh=0.4).cells[0, 0] == OCCUPIED


def test_a_rotated_origin_is_the_grid_yaw():
    yaw = 0.3
    origin = {"position": {"x": 0.0, "y": 0.0},
              "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}
    g = read_occupancy_grid(_grid_msg([0] * 6, origin=origin))
    assert g.origin[2] == pytest.approx(yaw)
    back = read_occupancy_grid(occupancy_grid_msg(g))
    assert back.origin == pytest.approx(g.origin) and (back.cells == g.cells).all()


def test_a_map_server_map_round_trips_through_the_message():
    g = read_ros_yaml(find_map("warehouse"))
    msg = occupancy_grid_msg(g)
    assert (msg["info"]["width"], msg["info"]["height"]) == (g.width, g.height)
    assert len(msg["data"]) == g.width * g.height and set(msg["data"]) == {-1, 0, 100}
    back = read_occupancy_grid(json.loads(json.dumps(msg)), name="/map")
    assert (back.cells == g.cells).all()
    assert (back.resolution, back.origin, back.source) == (g.resolution, g.origin, "/map")
    prob = import_map("ros-map", Robots(radius=0.3, start=(-11.0, -11.5), goal=(-9.0, 9.8)),
                      grid=back)
    assert op.solve(prob, "visgraph").status is op.Status.optimal


@pytest.mark.parametrize(("edit", "match"), [
    (lambda m: m.__setitem__("data", [0] * 5),
     r"data: 5 values, expected info.width x info.height = 3 x 2 = 6"),
    (lambda m: m["info"].__setitem__("resolution", 0.0), r"info.resolution: must be > 0"),
    (lambda m: m["info"].__setitem__("resolution", -0.05), r"info.resolution: must be > 0"),
    (lambda m: m["info"].__setitem__("resolution", "0.05"), r"info.resolution: expected a number"),
    (lambda m: m["data"].__setitem__(4, 101), r"data\[4\]: 101 is not an occupancy value: "
                                              r"expected an integer in -1..100"),
    (lambda m: m["data"].__setitem__(2, -2), r"data\[2\]: .*integer in -1..100"),
    (lambda m: m["data"].__setitem__(0, 0.5), r"data\[0\]: .*integer in -1..100"),
    (lambda m: m["data"].__setitem__(0, math.nan), r"data\[0\]: .*integer in -1..100"),
    (lambda m: m.__setitem__("data", "abcdef"), r"data: expected a sequence of int8 values"),
    (lambda m: m["info"]["origin"].__setitem__(
        "orientation", {"x": 0.7071, "y": 0.0, "z": 0.0, "w": 0.7071}),
     r"info.origin.orientation: only rotations about the z axis are supported"),
    (lambda m: m["info"]["origin"].__setitem__(
        "orientation", {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}),
     r"info.origin.orientation: a zero quaternion"),
    (lambda m: m["info"].__setitem__("width", 0), r"info.width: expected an integer in \[1, "),
    (lambda m: m["info"].__setitem__("height", True), r"info.height: expected an integer in"),
    (lambda m: m["info"].pop("origin"), r"info.origin: missing required key"),
    (lambda m: m["info"].__setitem__("resolutoin", 1), r"info.resolutoin: unknown key "
                                                       r"\(allowed: map_load_time, resolution"),
    (lambda m: m.pop("info"), r"info: missing required key"),
])
def test_bad_grids_name_the_key_and_the_allowed_values(edit, match):
    msg = _grid_msg([0, 100, -1, 50, 0, 19])
    edit(msg)
    with pytest.raises(ProblemError, match=r"^<nav_msgs/OccupancyGrid>: " + match):
        read_occupancy_grid(msg)


def test_int8_bytes_are_read_as_signed_values():
    g = read_occupancy_grid(_grid_msg(bytes([0, 100, 255, 0, 0, 0])))  # 255 is int8 -1
    assert g.cells[1].tolist() == [FREE, OCCUPIED, UNKNOWN]


# -- issue 42: what the readers accept ---------------------------------------------------


@pytest.mark.parametrize(("value", "shown"), [
    ("50", r"'50' \(str\)"), (True, r"True \(bool\)"), (None, r"None \(NoneType\)"),
    ([1], r"\[1\] \(list\)"), (np.bool_(False), r"(np\.)?False_? \(bool_?\)"),
])
def test_non_numeric_occupancy_values_are_errors(value, shown):
    data = [0, 100, -1, 50, 0, 19]
    data[3] = value
    with pytest.raises(ProblemError, match=r"^<nav_msgs/OccupancyGrid>: data\[3\]: " + shown
                       + r" is not a number: expected a sequence of int8 values"):
        read_occupancy_grid(_grid_msg(data))


def test_numeric_occupancy_values_of_any_type_are_read():
    want = read_occupancy_grid(_grid_msg([0, 100, -1, 50, 0, 19])).cells
    for data in ([0, 100.0, -1, np.int8(50), np.float32(0), 19],
                 np.array([0, 100, -1, 50, 0, 19], dtype=np.int8),
                 np.array([0, 100, -1, 50, 0, 19], dtype=object), (0, 100, -1, 50, 0, 19)):
        assert (read_occupancy_grid(_grid_msg(data)).cells == want).all()
    with pytest.raises(ProblemError, match=r"data: expected a sequence of int8 values .* got "
                                           r"an array of <U1"):
        read_occupancy_grid(_grid_msg(np.array(["0"] * 6)))
    with pytest.raises(ProblemError, match=r"data\[0\]: 1e\+300 is not an occupancy value"):
        read_occupancy_grid(_grid_msg([10**400] + [0] * 5))


@pytest.mark.parametrize("res", [np.float32(0.5), np.float64(0.5), np.int64(1), np.uint8(2)])
def test_a_numpy_resolution_round_trips(res):
    g = read_occupancy_grid(_grid_msg([0] * 6, resolution=res))
    assert type(g.resolution) is float and g.resolution == float(res)
    back = read_occupancy_grid(occupancy_grid_msg(g))
    assert back.resolution == g.resolution and (back.cells == g.cells).all()


@pytest.mark.parametrize(("res", "match"), [
    (1e-300, r"info\.resolution: 1e-300 makes the 3 x 2 cell map .* outside the supported "
             r"range \[1e-30, 1e\+30\]; for this map the resolution must lie in \[2\.77e-31, "
             r"2\.77e\+29\]"),
    (1e300, r"info\.resolution: 1e\+300 makes the 3 x 2 cell map"),
    (np.bool_(True), r"info\.resolution: expected a number, got (np\.)?True_?"),
])
def test_a_resolution_outside_the_range_is_an_error(res, match):
    with pytest.raises(ProblemError, match=r"^<nav_msgs/OccupancyGrid>: " + match):
        read_occupancy_grid(_grid_msg([0] * 6, resolution=res))


def test_an_origin_too_far_is_an_error():
    origin = {"position": {"x": 1e300, "y": 0.0},
              "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
    with pytest.raises(ProblemError, match=r"info\.origin: \[1e\+300, 0\.0, 0\.0\] puts the "
                                           r"centre of the map"):
        read_occupancy_grid(_grid_msg([0] * 6, origin=origin))


def test_the_cell_limit_holds_for_messages():
    """``max_cells`` is checked from ``info`` before ``data`` is converted."""
    msg = _grid_msg([0] * 6)
    assert read_occupancy_grid(msg, max_cells=6).cells.shape == (2, 3)
    with pytest.raises(ProblemError, match=r"info\.width: info\.width x info\.height: 3 x 2 = "
                                           r"6 cells, more than the limit of 5"):
        read_occupancy_grid(msg, max_cells=5)
    huge = _grid_msg([], width=9000, height=9000)  # the data is never looked at
    with pytest.raises(ProblemError, match=r"9000 x 9000 = 81,000,000 cells, more than the "
                                           r"limit of 67,108,864"):
        read_occupancy_grid(huge)
    with pytest.raises(ProblemError, match=r"max_cells: expected a positive integer"):
        read_occupancy_grid(msg, max_cells=0)


def _stamped(stamps) -> dict:
    msg = timed_path_msg([(0.0, 0.0)] * len(stamps), [0.0] * len(stamps))
    for ps, (sec, ns) in zip(msg["poses"], stamps):
        ps["header"]["stamp"] = {"sec": sec, "nanosec": ns}
    return msg


@pytest.mark.parametrize(("stamps", "match"), [
    ([(5, 0), (4, 999_999_999)], r"poses\[1\]\.header\.stamp: 4\.999999999 s is before the "
                                 r"previous pose's 5\.000000000 s: the stamps of a timed path "
                                 r"must be non-decreasing"),
    ([(-1, 0)], r"poses\[0\]\.header\.stamp\.sec: expected an integer in \[0, 2147483647\], "
                r"got -1"),
    ([(2**31, 0)], r"poses\[0\]\.header\.stamp\.sec: expected an integer in \[0, 2147483647\]"),
    ([(0, 1_000_000_000)], r"poses\[0\]\.header\.stamp\.nanosec: expected an integer in "
                           r"\[0, 999999999\], got 1000000000"),
    ([(0, -1)], r"poses\[0\]\.header\.stamp\.nanosec: expected an integer in \[0, 999999999\]"),
    ([(1.5, 0)], r"poses\[0\]\.header\.stamp\.sec: expected an integer .* got 1\.5"),
    ([(math.nan, 0)], r"poses\[0\]\.header\.stamp\.sec: expected an integer .* got nan"),
    ([(0, True)], r"poses\[0\]\.header\.stamp\.nanosec: expected an integer .* got True"),
])
def test_bad_stamps_name_the_pose_and_the_range(stamps, match):
    with pytest.raises(ProblemError, match=r"^<nav_msgs/Path>: " + match):
        read_path_msg(_stamped(stamps))


def test_stamps_equal_or_increasing_round_trip():
    """Non-decreasing stamps are read (equal stamps are a jump, as the writer allows), numpy
    integers too; a header stamp is checked the same way."""
    msg = timed_path_msg([(0, 0), (1, 0), (2, 0), (2, 0)], [0.0, 1.5, 1.5, 2.0],
                         start_time=7.0)
    back = read_path_msg(msg)
    np.testing.assert_allclose(back.times, [7.0, 8.5, 8.5, 9.0], rtol=0, atol=1e-9)
    assert read_path_msg(_stamped([(np.int32(3), np.int64(5)), (3, 5)])).times.tolist() == [
        3.000000005, 3.000000005]
    msg["header"]["stamp"] = {"sec": 0, "nanosec": 10**9}
    with pytest.raises(ProblemError, match=r"header\.stamp\.nanosec: expected an integer"):
        read_path_msg(msg)
