"""``optplan import-map``: an occupancy map -> a scenario TOML."""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any, TextIO

from optplan.cli.common import PROG, CLIError


def _xy(text: str, flag: str) -> tuple[float, ...]:
    try:
        vals = tuple(float(t) for t in text.replace(",", " ").split())
    except ValueError:
        vals = ()
    if len(vals) != 2 or not all(math.isfinite(v) for v in vals):
        raise CLIError(f"{flag}: expected X,Y (two numbers), got {text!r}")
    return vals


def cmd_import_map(args: argparse.Namespace, out: TextIO) -> int:
    from optplan.catalog import find_map
    from optplan.maps import (
        MAX_CELLS,
        PolygonOptions,
        ReadOptions,
        Robots,
        SceneOptions,
        import_map,
        to_toml,
    )

    path = find_map(args.map)
    starts = [_xy(s, "--start") for s in args.start]
    goals = [_xy(g, "--goal") for g in args.goal]
    if len(starts) != len(goals):
        raise CLIError(f"give one --goal per --start (got {len(starts)} and {len(goals)})")
    if args.robot and len(args.robot) != len(starts):
        raise CLIError(f"give one --robot per --start (got {len(args.robot)} and {len(starts)})")
    origin = None
    if args.origin is not None:
        try:
            origin = [float(t) for t in args.origin.replace(",", " ").split()]
        except ValueError:
            origin = []
        if len(origin) not in (2, 3):
            raise CLIError(f"--origin: expected X,Y or X,Y,YAW, got {args.origin!r}")
    robots = Robots(start=starts, goal=goals, radius=args.radius, ids=args.robot or None,
                    max_speed=args.max_speed)
    read = ReadOptions(
        resolution=args.resolution, origin=origin, negate=True if args.negate else None,
        mode=args.mode, occupied_thresh=args.occupied_thresh, free_thresh=args.free_thresh,
        unknown=args.unknown, crop={"auto": "auto", "on": True, "off": False}[args.crop],
        max_cells=MAX_CELLS if args.max_cells is None else args.max_cells)
    polygons = PolygonOptions(grow=args.grow, simplify=args.simplify, join=args.join)
    info: dict[str, Any] = {}
    t0 = time.perf_counter()
    prob = import_map(path, robots, read=read, polygons=polygons,
                      scene=SceneOptions(name=args.name), fill_unreachable=not args.keep_holes,
                      info=info)
    dt = time.perf_counter() - t0
    header = (f"Imported from {path} by 'optplan import-map' (grow {args.grow:g} cells, "
              f"simplify {args.simplify:g} cells, unknown = {args.unknown}).")
    text = to_toml(prob, header)
    if not args.out:
        out.write(text)
        return 0
    dest = Path(args.out)
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_text(text, encoding="utf-8")
    c = info["cells"]
    print(f"{path}: {c['occupied']} occupied, {c['unknown']} unknown, {c['free']} free cells "
          f"-> {info['polygons']} polygons, {info['vertices']} vertices "
          f"({info['holes_filled']} unreachable holes filled) in {dt * 1e3:.0f} ms", file=out)
    crop = info["crop"]
    if crop["cropped"]:
        (r0, r1), (c0, c1) = crop["rows"], crop["cols"]
        print(f"cropped to the known cells: rows {r0}..{r1 - 1}, columns {c0}..{c1 - 1} of "
              f"{crop['shape'][0]} x {crop['shape'][1]} ({crop['margin']:.0%} of the image was "
              f"unknown margin); bounds {list(prob.bounds)}", file=out)
    print(f"wrote {dest} (try: {PROG} solve {dest} visgraph)", file=out)
    return 0
