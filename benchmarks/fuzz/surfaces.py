"""The **path**, **crop**, **scen** and **arena** families: ROS path messages, ``import_map``'s
``crop=``, MovingAI ``.scen`` files and the Planner Arena export."""

from __future__ import annotations

import copy
import math
import random
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks.fuzz.checks import _classify_error, _cli_ok, _message_ok
from benchmarks.fuzz.core import Case, Outcome
from benchmarks.fuzz.databases import _db_bytes
from benchmarks.fuzz.maps import _pgm
from benchmarks.fuzz.values import _short

_PATH_NAME = "<fuzz-path>"
_NS = 1_000_000_000


def _path_msg(stamps: list[tuple[Any, Any]], head_stamp: bool = True) -> dict[str, Any]:
    """A ``nav_msgs/Path`` dict with one pose per ``(sec, nanosec)``."""
    head: dict[str, Any] = {"frame_id": "map"}
    if head_stamp:
        head["stamp"] = {"sec": 0, "nanosec": 0}
    return {"header": head, "poses": [
        {"header": {"frame_id": "map", "stamp": {"sec": s, "nanosec": ns}},
         "pose": {"position": {"x": float(k), "y": 0.5 * k, "z": 0.0},
                  "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
        for k, (s, ns) in enumerate(stamps)]}


def _first_bad_stamp(stamps: list[tuple[Any, Any]]) -> int | None:
    """The index of the first pose whose stamp is out of range or before the previous one."""
    last = -1
    for k, (s, ns) in enumerate(stamps):
        if not (type(s) is int and type(ns) is int and 0 <= s < 2**31 and 0 <= ns < _NS):
            return k
        if s * _NS + ns < last:
            return k
        last = s * _NS + ns
    return None


def _path_variants(rng: random.Random) -> list[tuple[str, Any, tuple[str, ...], bool]]:
    """nav_msgs/Path dicts: (what, message, keys, must it be rejected)."""
    ok = [(0, 0), (1, 0), (2, 500_000_000)]
    out: list[tuple[str, Any, tuple[str, ...], bool]] = [
        ("intact", _path_msg(ok), (), False),
        ("equal stamps (a jump)", _path_msg([(0, 0), (1, 0), (1, 0)]), (), False),
        ("no header stamp", _path_msg(ok, head_stamp=False), (), False),
        ("largest stamp", _path_msg([(2**31 - 1, _NS - 1)]), (), False),
        ("empty path", _path_msg([]), ("poses",), False)]
    for what, st in (("decreasing sec", [(0, 0), (2, 0), (1, 0)]),
                     ("decreasing nanosec", [(1, 5), (1, 4)]),
                     ("sec -1", [(0, 0), (-1, 0)]), ("sec 2**31", [(0, 0), (2**31, 0)]),
                     ("sec 2**64", [(0, 0), (2**64, 0)]), ("nanosec 1e9", [(0, _NS)]),
                     ("nanosec -1", [(0, 0), (1, -1)]), ("sec 1.5", [(0, 0), (1.5, 0)]),
                     ("sec 1.0", [(1.0, 0)]), ("sec True", [(0, 0), (True, 0)]),
                     ("sec '1'", [(0, 0), ("1", 0)]), ("sec None", [(None, 0)]),
                     ("nanosec nan", [(0, math.nan)]), ("sec inf", [(0, 0), (math.inf, 0)])):
        k = _first_bad_stamp(st)
        out.append((what, _path_msg(st), (f"poses[{k}].header.stamp",), True))
    m = _path_msg(ok)
    m["header"]["stamp"] = {"sec": -1, "nanosec": 0}
    out.append(("header stamp sec -1", m, ("header.stamp",), True))

    def edit(what: str, f: Callable[[dict], Any], keys: tuple[str, ...]) -> None:
        m = _path_msg(ok)
        f(m)
        out.append((what, m, keys, True))

    p1 = "poses[1]"
    edit("pose without stamp", lambda m: m["poses"][1]["header"].pop("stamp"),
         (f"{p1}.header.stamp",))
    edit("pose without header", lambda m: m["poses"][1].pop("header"), (f"{p1}.header",))
    edit("unknown pose key", lambda m: m["poses"][1].__setitem__("twist", {}), (f"{p1}.twist",))
    edit("frame_id 5", lambda m: m["header"].__setitem__("frame_id", 5), ("header.frame_id",))
    edit("no header", lambda m: m.pop("header"), ("header",))
    edit("poses a string", lambda m: m.__setitem__("poses", "abc"), ("poses",))
    edit("poses None", lambda m: m.__setitem__("poses", None), ("poses",))
    edit("poses a dict", lambda m: m.__setitem__("poses", {"a": 1}), ("poses",))
    for v in (math.nan, math.inf, -math.inf, "1", None, True, [1.0]):
        edit(f"position.x {_short(v)}",
             lambda m, v=v: m["poses"][1]["pose"]["position"].__setitem__("x", v),
             (f"{p1}.pose.position.x",))
    edit("tilted orientation", lambda m: m["poses"][1]["pose"].__setitem__(
        "orientation", {"x": 0.7, "y": 0.0, "z": 0.0, "w": 0.7}), (f"{p1}.pose.orientation",))
    edit("zero quaternion", lambda m: m["poses"][1]["pose"].__setitem__(
        "orientation", {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}), (f"{p1}.pose.orientation",))
    out.append(("root a list", [1, 2], ("<root>",), True))
    for k in range(24):  # random stamp sequences, some out of range or decreasing
        st = [(rng.choice([0, 1, 2, 3, rng.randint(-2, 6), 2**31 - 1, 2**31]),
               rng.choice([0, 1, _NS - 1, rng.randrange(_NS), _NS, -1]))
              for _ in range(rng.randint(2, 6))]
        bad = _first_bad_stamp(st)
        keys = (f"poses[{bad}].header.stamp",) if bad is not None else ()
        out.append((f"random stamps {k}", _path_msg(st), keys, bad is not None))
    return out


def path_cases(seed: int = 0) -> list[Case]:
    """``nav_msgs/Path`` messages read with :func:`optplan.maps.read_path_msg`, and paths
    written with :func:`~optplan.maps.timed_path_msg` read back."""
    rng = random.Random(seed)
    out = [Case("path", f"path/{k + 1:04d}/{what}", what, {"msg": msg}, keys, must)
           for k, (what, msg, keys, must) in enumerate(_path_variants(rng))]
    for k in range(6):
        n = rng.randint(1, 6)
        times = sorted(rng.choice([0.0, 0.5, 1.0, rng.uniform(0, 9), 1e-9 * k]) for _ in range(n))
        pts = [[rng.uniform(-50, 50), rng.uniform(-50, 50)] for _ in range(n)]
        out.append(Case("path", f"path/{len(out) + 1:04d}/written {k}", f"written {k}",
                        {"write": [pts, times]}))
    return out


def _check_timed_path(case: Case, tp: Any) -> Outcome:
    """An accepted path: finite points, one per pose, non-decreasing times in ROS's range."""
    import numpy as np

    n = len(case.data["msg"]["poses"]) if "msg" in case.data else len(case.data["write"][1])
    t = np.asarray(tp.times, dtype=float)
    bad = (len(tp.points) != n or len(t) != n or not np.isfinite(tp.points).all()
           or not np.isfinite(t).all() or (t < 0).any() or (t > 2.0**31).any()
           or (np.diff(t) < 0).any())
    if bad or case.must_reject:
        return Outcome(case, "silently accepted", f"read {n} poses, times {t.tolist()[:8]}")
    return Outcome(case, "accepted and solved", f"{n} poses")


def run_path(case: Case, tmp: Path) -> Outcome:
    import numpy as np

    from optplan.maps import read_path_msg, timed_path_msg

    d = case.data
    try:
        if "write" in d:
            pts, times = d["write"]
            msg = timed_path_msg(np.asarray(pts, dtype=float), np.asarray(times, dtype=float))
        else:
            msg = copy.deepcopy(d["msg"])
        tp = read_path_msg(msg, name=_PATH_NAME)
    except Exception as e:  # noqa: BLE001
        return Outcome(case, *_classify_error(e, case, _PATH_NAME))
    return _check_timed_path(case, tp)


#: the crop map: 12 x 10 cells of 1 m, unknown (grey) but for a free block of 8 x 6 cells whose
#: world box is (2, 2)-(10, 8) (the bounds when cropped; (0, 0)-(12, 10) when not)
_CROP_SHAPE, _CROP_ROWS, _CROP_COLS = (10, 12), (2, 8), (2, 10)
_CROPPED, _UNCROPPED = (2.0, 2.0, 10.0, 8.0), (0.0, 0.0, 12.0, 10.0)


def _crop_pgm() -> bytes:
    h, w = _CROP_SHAPE
    px = bytearray([128] * (h * w))  # 128: unknown in trinary mode
    for r in range(*_CROP_ROWS):
        for c in range(*_CROP_COLS):
            px[r * w + c] = 254
    return _pgm(w, h, body=bytes(px))


def crop_cases() -> list[Case]:
    """``import_map(..., crop=...)`` on a map with an unknown margin: every switch value
    (``"auto"``, bools, ``numpy.bool_``) and values that are not one (numbers, 0 and 1
    included, strings, None, ...); an accepted value must crop exactly when it says so."""
    import numpy as np

    good: list[tuple[Any, str, bool]] = [
        ("auto", "occupied", True), ("auto", "free", False), (True, "occupied", True),
        (False, "occupied", False), (np.True_, "occupied", True),
        (np.False_, "occupied", False), (True, "free", True), (np.False_, "free", False)]
    bad: list[Any] = [0, 1, 0.0, 1.0, -1, 2, math.nan, np.int64(0), np.int8(1),
                      np.float64(0.0), np.float32(1.0), "yes", "no", "True", "false", "on",
                      "off", "", "AUTO", None, [True], [], {}, b"auto", 1 + 0j]
    out = [Case("crop", f"crop/{k + 1:04d}/crop={v!r} unknown={u}", f"crop={v!r} unknown={u}",
                {"crop": v, "unknown": u, "cropped": c})
           for k, (v, u, c) in enumerate(good)]
    out += [Case("crop", f"crop/{len(out) + k + 1:04d}/crop={v!r}", f"crop={v!r}",
                 {"crop": v, "unknown": "occupied"}, ("crop",), True)
            for k, v in enumerate(bad)]
    # the import's other numbers at their extremes (a raw GEOSException at 1e-300 once)
    out += [Case("crop", f"crop/{len(out) + k + 1:04d}/resolution={v!r}", f"resolution={v!r}",
                 {"crop": "auto", "unknown": "occupied", "resolution": v}, ("resolution",),
                 True) for k, v in enumerate((1e-300, 5e-324, 1e300, -1.0, math.nan))]
    return out


def run_crop(case: Case, tmp: Path) -> Outcome:
    import numpy as np

    from optplan.maps import ReadOptions, Robots, import_map

    d = case.data
    (tmp / "m.pgm").write_bytes(_crop_pgm())
    path = tmp / "m.pgm"
    try:
        read = ReadOptions(resolution=d.get("resolution", 1.0), crop=d["crop"],
                           unknown=d["unknown"])
        prob = import_map(path, Robots(radius=0.1, start=(3.0, 5.0), goal=(9.0, 5.0)),
                          read=read)
    except Exception as e:  # noqa: BLE001
        return Outcome(case, *_classify_error(e, case, str(path)))
    bounds = tuple(float(b) for b in prob.bounds)
    if case.must_reject:
        return Outcome(case, "silently accepted", f"imported, bounds {bounds}")
    want = _CROPPED if d["cropped"] else _UNCROPPED
    if not np.allclose(bounds, want):
        return Outcome(case, "silently accepted", f"bounds {bounds}, expected {want} "
                       f"({'cropped' if d['cropped'] else 'not cropped'})")
    return Outcome(case, "accepted and solved", f"bounds {bounds}")


#: the .scen family's map: 6 x 4 cells, a wall cell at (2, 1) (column, row from the top)
_SCEN_MAP = "type octile\nheight 4\nwidth 6\nmap\n......\n..@...\n......\n......\n"
_SCEN_LINE = "0\tm.map\t6\t4\t{sx}\t{sy}\t{gx}\t{gy}\t{opt}"


def _scen(*lines: str, version: str | None = "version 1") -> str:
    return "".join(f"{ln}\n" for ln in ([version] if version else []) + list(lines))


def _scen_variants() -> list[tuple[str, bytes, bytes, tuple[str, ...], bool, int]]:
    """(what, .scen bytes, .map bytes, keys, must it be rejected, lines when accepted)."""
    ln = _SCEN_LINE.format(sx=0, sy=0, gx=5, gy=3, opt="6.24264069")
    ln2 = _SCEN_LINE.format(sx=1, sy=3, gx=4, gy=0, opt="4.24264069")
    mp = _SCEN_MAP.encode()
    out: list[tuple[str, bytes, bytes, tuple[str, ...], bool, int]] = [
        ("intact", _scen(ln, ln2).encode(), mp, (), False, 2),
        ("version 1.0", _scen(ln, version="version 1.0").encode(), mp, (), False, 1),
        ("no version line", _scen(ln, version=None).encode(), mp, (), False, 1),
        ("UTF-8 BOM", b"\xef\xbb\xbf" + _scen(ln).encode(), mp, (), False, 1),
        ("UTF-8 BOM in the map", _scen(ln).encode(), b"\xef\xbb\xbf" + mp, (), False, 1),
        ("CRLF", _scen(ln, ln2).replace("\n", "\r\n").encode(), mp, (), False, 2),
        ("blank lines", ("\n" + _scen(ln, "", ln2) + "\n\n").encode(), mp, (), False, 2),
        ("trailing blanks", _scen(ln + " \t ").encode(), mp, (), False, 1),
        ("spaces, no tabs", _scen(ln.replace("\t", " ")).encode(), mp, (), False, 1)]

    def bad(what: str, text: str | bytes, keys: tuple[str, ...], m: bytes = mp) -> None:
        out.append((what, text if isinstance(text, bytes) else text.encode(), m, keys, True, 0))

    for v in ("version 2", "version 1 extra", "version", "version 0.9", "version x",
              "VERSION 3"):
        bad(v, _scen(ln, version=v), ("line 1",))
    bad("trailing text", _scen(ln + "\tfrom a paper"), ("line 2",))
    bad("trailing text after a blank", _scen(ln + " extra"), ("line 2",))
    bad("8 fields", _scen(ln.rsplit("\t", 1)[0]), ("line 2",))
    bad("10 fields", _scen(ln + "\t7"), ("line 2",))
    for field, sub in (("width", "six"), ("start_x", "1.5"), ("opt", "abc")):
        bad(f"{field} not a number", _scen(ln.replace("\t6\t" if field == "width" else
                                                      "\t0\t0\t" if field == "start_x" else
                                                      "6.24264069",
                                                      f"\t{sub}\t" if field == "width" else
                                                      f"\t{sub}\t0\t" if field == "start_x"
                                                      else sub, 1)), ("line 2",))
    for what, kw in (("width 0", {"w": 0}), ("height -1", {"h": -1}),
                     ("start x = width", {"sx": 6}), ("goal y -1", {"gy": -1}),
                     ("start on the wall", {"sx": 2, "sy": 1}),
                     ("map size differs", {"w": 7}), ("optimal nan", {"opt": "nan"}),
                     ("optimal inf", {"opt": "inf"}), ("optimal -1", {"opt": "-1"}),
                     ("optimal 1e400", {"opt": "1e400"})):
        f = {"sx": 0, "sy": 0, "gx": 5, "gy": 3, "opt": "6.24264069", "w": 6, "h": 4, **kw}
        line = f"0\tm.map\t{f['w']}\t{f['h']}\t{f['sx']}\t{f['sy']}\t{f['gx']}\t{f['gy']}" \
               f"\t{f['opt']}"
        bad(what, _scen(line), ("line 2",))
    bad("two maps", _scen(ln, ln2.replace("m.map", "other.map")), ("line 3",))
    bad("missing map", _scen(ln.replace("m.map", "nope.map")), ("map",))
    bad("not UTF-8", b"version 1\n\xff\xfe" + ln.encode(), ("not UTF-8",))
    bad("empty file", "", ("<file>",))
    bad("version line only", _scen(), ("<file>",))
    bad("binary", b"\x00\x01\x02" * 20, ("line 1", "not UTF-8"))
    return out


def scen_cases() -> list[Case]:
    """MovingAI ``.scen`` files (with their ``.map``) read with
    :func:`optplan.maps.read_scen`."""
    return [Case("scen", f"scen/{k + 1:04d}/{what}", what,
                 {"files": {"m.scen": text, "m.map": mp}, "lines": n}, keys, must)
            for k, (what, text, mp, keys, must, n) in enumerate(_scen_variants())]


def run_scen(case: Case, tmp: Path) -> Outcome:
    from optplan.maps import read_scen

    for name, content in case.data["files"].items():
        (tmp / name).write_bytes(content)
    path = tmp / "m.scen"
    try:
        probs = read_scen(path)
    except Exception as e:  # noqa: BLE001
        return Outcome(case, *_classify_error(e, case, str(path)))
    if case.must_reject or len(probs) != case.data["lines"]:
        return Outcome(case, "silently accepted", f"{len(probs)} problems")
    return Outcome(case, "accepted and solved", f"{len(probs)} problems")


def arena_cases() -> list[Case]:
    """``export_arena`` (and ``optplan export-arena``) of results databases with damaged rows,
    without runs, and onto bad destinations; an export must load as an OMPL database with
    every run, and nothing (no ``.tmp``) may be left behind by a failed one."""
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-arena-"))
    out: list[Case] = []

    def add(what: str, db: bytes | None, keys: tuple[str, ...], must: bool,
            dest: str = "new", names: str = "db", runs: int = 3) -> None:
        out.append(Case("arena", f"arena/{len(out) + 1:04d}/{what}", what,
                        {"bytes": db, "dest": dest, "names": names, "runs": runs}, keys, must))

    try:
        good = _db_bytes(tmp)
        add("intact", good, (), False)
        add("into a missing folder", good, (), False, dest="deep")
        add("over an existing file", good, (), False, dest="existing")
        add("no runs", _db_bytes(tmp, runs=0), ("holds no runs", "no runs to export"), True,
            runs=0)
        add("onto a directory", good, ("is a directory", "file name"), True, dest="dir",
            names="out")
        add("onto itself", good, ("would replace the results database",), True, dest="same",
            names="out")
        add("missing database", None, ("no such results database",), True)
        add("a text file", b"not a database\n" * 40, ("not an optplan results database",), True)
        for col, val in (("length", "'abc'"), ("wall_time", "'x'"), ("seed", "'s'"),
                         ("success", "'maybe'"), ("collisions", "'many'"),
                         ("config", "'not json'"), ("config", "'[1]'"),
                         ("config", "'{\"time_limit\": \"soon\"}'"), ("options", "'{'"),
                         ("length", "X'00ff'")):
            add(f"row 2 {col} = {val}", _db_bytes(tmp, lambda con, c=col, v=val: con.execute(
                f"UPDATE runs SET {c} = {v} WHERE id = 2")), ("row id 2",), True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def _arena_dest(case: Case, tmp: Path, db: Path) -> Path:
    kind = case.data["dest"]
    if kind == "dir":
        (tmp / "arena.db").mkdir()
    elif kind == "existing":
        (tmp / "arena.db").write_bytes(b"old contents")
    return {"same": db, "deep": tmp / "x" / "y" / "arena.db"}.get(kind, tmp / "arena.db")


def _arena_loads(path: Path, runs: int) -> str | None:
    """Why ``path`` is not an OMPL benchmark database with ``runs`` runs (None when it is)."""
    import sqlite3

    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        need = {"experiments", "plannerConfigs", "enums", "runs", "progress"}
        if not need <= tables:
            return f"tables {sorted(tables)}"
        n_exp = con.execute("SELECT count(*) FROM experiments").fetchone()[0]
        n_runs = con.execute("SELECT count(*) FROM runs").fetchone()[0]
    finally:
        con.close()
    return None if n_exp >= 1 and n_runs == runs else f"{n_exp} experiments, {n_runs} runs"


def run_arena(case: Case, tmp: Path) -> Outcome:
    from optplan.bench.summary import export_arena

    d = case.data
    db = tmp / "r.sqlite"
    if d["bytes"] is not None:
        db.write_bytes(d["bytes"])
    dest = _arena_dest(case, tmp, db)
    named = str(db if d["names"] == "db" else dest)
    try:
        export_arena(db, dest)
        outcome = None
    except FileNotFoundError as e:  # documented, for a missing database
        ok, why = _message_ok(str(e), case.keys, named)
        outcome = Outcome(case, "clear error" if ok else "unclear message", f"{why}: {e}")
    except Exception as e:  # noqa: BLE001
        outcome = Outcome(case, *_classify_error(e, case, named))
        if outcome.category == "clear error":
            ok, why = _cli_ok(["export-arena", str(db), str(dest)], case, named)
            if not ok:
                outcome = Outcome(case, "unclear message", why)
    left = sorted(str(p.relative_to(tmp)) for p in tmp.rglob("*.tmp"))
    if left:
        return Outcome(case, "crash", f"left behind: {left}")
    if outcome is not None:
        return outcome
    if case.must_reject:
        return Outcome(case, "silently accepted", f"exported {dest}")
    why = _arena_loads(dest, d["runs"])
    if why:
        return Outcome(case, "silently accepted", f"the export does not load: {why}")
    return Outcome(case, "accepted and solved", "exported and loaded")
