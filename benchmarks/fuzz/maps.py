"""The **map** family: ROS ``map_server`` YAML and images, bare images, MovingAI ``.map`` files
and in-memory ``nav_msgs/OccupancyGrid`` dicts, and their runner."""

from __future__ import annotations

import copy
import io
import json
import math
import random
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error, _cli_ok
from benchmarks.fuzz.core import Case, Outcome
from benchmarks.fuzz.values import _short

_GRID_NAME = "<fuzz-grid>"


def _pgm(w: int = 4, h: int = 3, maxval: int = 255, body: bytes | None = None) -> bytes:
    """A binary PGM (P5): a free map with one occupied cell, or ``body`` as its pixels."""
    if body is None:
        px = bytearray([254 if maxval >= 254 else maxval] * (w * h))
        if px:
            px[len(px) // 2] = 0
        body = bytes(px)
    return f"P5\n{w} {h}\n{maxval}\n".encode() + body


def _png() -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    im = Image.new("L", (5, 4), 254)
    im.putpixel((2, 1), 0)
    im.save(buf, format="PNG")
    return buf.getvalue()


_ROS_YAML = {"image": "m.pgm", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "negate": 0,
             "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary"}


def _yaml_text(d: dict[str, Any]) -> bytes:
    """YAML of ``d``, each value in JSON's flow syntax (valid YAML)."""
    return "".join(f"{k}: {json.dumps(v)}\n" for k, v in d.items()).encode()


def _ros_variants() -> list[tuple[str, dict[str, Any] | bytes, tuple[str, ...], bool]]:
    """(what, YAML keys or raw bytes, keys an error must name, must it be rejected)."""
    out: list[tuple[str, dict[str, Any] | bytes, tuple[str, ...], bool]] = [
        ("intact", {}, (), False), ("origin [x, y]", {"origin": [1.0, -2.0]}, (), False),
        ("rotated origin", {"origin": [0.0, 0.0, 0.5]}, (), False),
        ("resolution 5e-2 (YAML 1.2)", b"resolution: 5e-2\n", (), False)]
    for key, bad in (("resolution", [0, -1, "abc", [1], None, True, 1e400, 1e-300, 5e-324,
                                     1e300]),
                     ("origin", [[0], [0, 0, 0, 0], "a b", [None, 0], [1e400, 0], 3]),
                     ("negate", [2, "yes", -1, 0.5]),
                     ("occupied_thresh", [1.5, -0.1, "x", 1e400]),
                     ("free_thresh", [0.9, -1, None]),
                     ("mode", ["trinari", 3, ""]),
                     ("image", ["missing.pgm", "", 5, None, "."])):
        for v in bad:
            out.append((f"{key} = {v!r}", {key: v}, (key,), True))
    out += [("unknown key", {"negat": 1}, ("negat",), True),
            ("no image", {"image": ...}, ("image",), True),
            ("no resolution", {"resolution": ...}, ("resolution",), True),
            ("no origin", {"origin": ...}, ("origin",), True),
            ("YAML list", b"- 1\n- 2\n", ("<root>",), True),
            ("YAML syntax", b"image: [m.pgm\n", ("invalid YAML",), True),
            ("not UTF-8", b"\xff\xfeimage: m.pgm\n", ("cannot read file", "invalid YAML",
                                                      "image", "not UTF-8"), True),
            ("empty file", b"", ("<root>",), True)]
    return out


def _image_variants() -> list[tuple[str, bytes, bool]]:
    """(what, the image the YAML names, must it be rejected)."""
    png = _png()
    return [("PGM maxval 0", _pgm(maxval=0), True), ("PGM maxval 70000", _pgm(maxval=70000), True),
            ("PGM width 0", _pgm(w=0), True), ("PGM truncated", _pgm()[:-5], True),
            ("PGM header only", b"P5\n4 3\n255\n", True), ("garbage", b"not an image" * 9, True),
            ("empty image", b"", True), ("PNG truncated", png[: len(png) // 2], True),
            ("PNG", png, False), ("16-bit PGM", _pgm(maxval=65535, body=b"\xff\xfe" * 12), False)]


def _movingai_variants() -> list[tuple[str, bytes, tuple[str, ...], bool]]:
    ok = "type octile\nheight 3\nwidth 4\nmap\n@@@@\n@..@\n@@@@\n"
    keys = ("height", "width", "map", "type", "line", "not a MovingAI map")
    return [("intact .map", ok.encode(), (), False),
            ("UTF-8 BOM", b"\xef\xbb\xbf" + ok.encode(), (), False),
            ("CRLF", ok.replace("\n", "\r\n").encode(), (), False),
            ("trailing blanks on rows", ok.replace("@..@", "@..@  ").encode(), (), False),
            ("a citation after the grid", (ok + "Sturtevant 2012, grid benchmarks\n").encode(),
             (), False),
            ("a grid row after the grid", (ok + "@@@@\n").encode(), keys, True),
            ("BOM, then not UTF-8", b"\xef\xbb\xbf\xff\xfe" + ok.encode(), keys + (
                "not UTF-8",), True),
            ("height mismatch", ok.replace("height 3", "height 4").encode(), keys, True),
            ("width mismatch", ok.replace("width 4", "width 5").encode(), keys, True),
            ("unknown terrain", ok.replace("..", ".X").encode(), keys, True),
            ("no map line", ok.replace("map\n", "").encode(), keys, True),
            ("height 0", ok.replace("height 3", "height 0").encode(), keys, True),
            ("height -3", ok.replace("height 3", "height -3").encode(), keys, True),
            ("no header", b"@@@@\n@..@\n", keys, True), ("binary", b"\x00\xff" * 10, keys, True),
            ("empty .map", b"", keys, True)]


def _grid_msg_variants(rng: random.Random) -> list[tuple[str, Any, tuple[str, ...], bool]]:
    """nav_msgs/OccupancyGrid dicts: (what, message, keys, must it be rejected)."""
    def msg(**info: Any) -> dict[str, Any]:
        base: dict[str, Any] = {
            "resolution": 0.5, "width": 3, "height": 2,
            "origin": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
        base.update(info)
        return {"header": {"frame_id": "map"}, "info": base,
                "data": [0, 100, -1, 0, 0, 50]}

    out: list[tuple[str, Any, tuple[str, ...], bool]] = [("intact message", msg(), (), False)]
    tilted = {"position": {"x": 0.0, "y": 0.0}, "orientation": {"x": 0.7, "y": 0.0, "z": 0.0,
                                                                "w": 0.7}}
    yawed = {"position": {"x": 1.0, "y": 2.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.4,
                                                               "w": 0.9}}
    out.append(("rotated about z", msg(origin=yawed), (), False))
    import numpy as np

    out += [("resolution numpy.float32", msg(resolution=np.float32(0.5)), (), False),
            ("resolution numpy.float64", msg(resolution=np.float64(0.5)), (), False),
            ("resolution numpy.int64", msg(resolution=np.int64(1)), (), False)]
    for v in (1e-300, 5e-324, 1e300, np.float32(0.0), np.float64(math.inf)):
        out.append((f"info.resolution = {_short(v)}", msg(resolution=v), ("info.resolution",),
                    True))
    for what, data in (("data int8 array", np.array([0, 100, -1, 0, 0, 50], dtype=np.int8)),
                       ("data bytes", bytes([0, 100, 255, 0, 0, 50])),
                       ("data numpy ints", [np.int8(0), np.int64(100), -1, 0, 0, 50])):
        m = msg()
        m["data"] = data
        out.append((what, m, (), False))
    out.append(("81M cells (9001 x 9001)", {"big": [9001, 9001]}, ("info.width",), True))
    for key, v in (("resolution", 0.0), ("resolution", -1.0), ("resolution", math.nan),
                   ("resolution", "0.5"), ("width", 0), ("width", 2.5), ("height", True),
                   ("height", -2), ("width", 2**40), ("origin", tilted), ("origin", [0, 0]),
                   ("origin", {"position": {"x": 0.0}}), ("resoluton", 1.0)):
        out.append((f"info.{key} = {_short(v)}", msg(**{key: v}), (f"info.{key}",), True))
    for what, data, key in (("data short", [0] * 5, "data"), ("data long", [0] * 7, "data"),
                            ("data 101", [0, 101, 0, 0, 0, 0], "data[1]"),
                            ("data -2", [0, 0, -2, 0, 0, 0], "data[2]"),
                            ("data 0.5", [0.5] * 6, "data[0]"),
                            ("data nan", [math.nan] * 6, "data[0]"),
                            ("data string", "abcdef", "data"), ("data dict", {"a": 1}, "data"),
                            ("data nested", [[0, 0, 0], [0, 0, 0]], "data"),
                            ("data '50'", [0, "50", 0, 0, 0, 0], "data[1]"),
                            ("data True", [0, 0, True, 0, 0, 0], "data[2]"),
                            ("data numpy '50'", np.array(["0", "50", "0", "0", "0", "0"]),
                             "data"),
                            ("data None", None, "data")):
        m = msg()
        m["data"] = data
        out.append((what, m, (key,), True))
    for k in range(20):  # random values, some out of range
        m = msg()
        m["data"] = [rng.choice([-1, 0, 100, rng.randint(-130, 130)]) for _ in range(6)]
        bad = any(not -1 <= v <= 100 for v in m["data"])
        out.append((f"random data {k}", m, ("data",), bad))
    out += [("root list", [1, 2], ("<root>",), True), ("no info", {"data": []}, ("info",), True),
            ("no data", {"info": msg()["info"]}, ("data",), True)]
    return out


def map_cases(seed: int = 0) -> list[Case]:
    """ROS map_server YAML + image, bare images, MovingAI maps and OccupancyGrid messages."""
    rng = random.Random(seed)
    out: list[Case] = []

    def add(what: str, data: dict[str, Any], keys: tuple[str, ...], must: bool) -> None:
        out.append(Case("map", f"map/{len(out) + 1:04d}/{what}", what, data, keys, must))

    for what, edit, keys, must in _ros_variants():
        if isinstance(edit, bytes):
            text = edit if what != "resolution 5e-2 (YAML 1.2)" else \
                _yaml_text({k: v for k, v in _ROS_YAML.items() if k != "resolution"}) + edit
        else:
            d = {k: v for k, v in {**_ROS_YAML, **edit}.items() if v is not ...}
            text = _yaml_text(d)
        add(f"ROS YAML {what}", {"files": {"m.yaml": text, "m.pgm": _pgm()}, "open": "m.yaml"},
            keys, must)
    for what, img, must in _image_variants():
        name = "m.png" if "PNG" in what else "m.pgm"
        add(f"ROS image {what}", {"files": {"m.yaml": _yaml_text({**_ROS_YAML, "image": name}),
                                            name: img}, "open": "m.yaml"}, ("image",), must)
        add(f"bare image {what}", {"files": {name: img}, "open": name, "resolution": 0.1},
            ("image",), must)
    import numpy as np

    for what, res, must in (("resolution 1e-300", 1e-300, True), ("resolution 1e300", 1e300, True),
                            ("resolution numpy.float32", np.float32(0.1), False)):
        add(f"bare image {what}", {"files": {"m.pgm": _pgm()}, "open": "m.pgm",
                                   "resolution": res}, ("resolution",), must)
    for what, text, keys, must in _movingai_variants():
        add(f"MovingAI {what}", {"files": {"m.map": text}, "open": "m.map"}, keys, must)
    for what, msg, keys, must in _grid_msg_variants(rng):
        add(f"OccupancyGrid {what}", {"msg": msg}, keys, must)
    return out


def run_map(case: Case, tmp: Path) -> Outcome:
    from optplan.maps import read_grid, read_occupancy_grid

    d = case.data
    if "msg" in d:
        msg = copy.deepcopy(d["msg"])
        if isinstance(msg, dict) and "big" in msg:  # made here: 81 MB would not go in a pipe
            import numpy as np

            w, h = msg["big"]
            msg = {"header": {"frame_id": "map"}, "data": np.zeros(w * h, dtype=np.int8),
                   "info": {"resolution": 0.05, "width": w, "height": h, "origin": {
                       "position": {"x": 0.0, "y": 0.0, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}
        try:
            read_occupancy_grid(msg, name=_GRID_NAME)
        except Exception as e:  # noqa: BLE001
            return Outcome(case, *_classify_error(e, case, _GRID_NAME))
        return _accepted(case, "read")
    for name, content in d["files"].items():
        (tmp / name).write_bytes(content)
    path = tmp / d["open"]
    try:
        read_grid(path, resolution=d.get("resolution"))
    except Exception as e:  # noqa: BLE001
        cat, det = _classify_error(e, case, str(path))
        if cat == "clear error":
            argv = ["import-map", str(path), "--radius", "0.01", "--start", "0.07,0.07",
                    "--goal", "0.12,0.07"]
            if d.get("resolution"):
                argv += ["--resolution", str(d["resolution"])]
            ok, why = _cli_ok(argv, case, str(path))
            if not ok:
                return Outcome(case, "unclear message", why)
        return Outcome(case, cat, det)
    return _accepted(case, "read")


def _accepted(case: Case, how: str) -> Outcome:
    if case.must_reject:
        return Outcome(case, "silently accepted", how)
    return Outcome(case, "accepted and solved", how)
