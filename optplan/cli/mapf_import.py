"""``optplan import-mapf``: a multi-agent path-finding instance -> a scenario TOML with a
``[roadmap]`` (Continuous-CBS GraphML + tasks, or a MovingAI ``.map`` + ``.scen``)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, TextIO

from optplan.cli.common import PROG, CLIError


def _read(args: argparse.Namespace, info: dict[str, Any]) -> tuple[Any, str]:
    """The problem of the files the arguments name, and a line saying what was read."""
    from optplan.maps import read_movingai_mapf, read_roadmap_mapf

    grid = args.map is not None or args.scen is not None
    if grid:
        if args.graph is not None or args.map is None or args.scen is None:
            raise CLIError("give either GRAPH TASKS (a GraphML roadmap and its task file) or "
                           "--map X.map --scen X.scen (a MovingAI grid), not both")
        if args.merge_duplicates:
            raise CLIError("--merge-duplicates is for GraphML roadmaps, not MovingAI grids")
        prob = read_movingai_mapf(args.map, args.scen, agents=args.agents, radius=args.radius,
                                  connectedness=args.connectedness, max_speed=args.max_speed,
                                  info=info)
        return prob, (f"{args.map}: {info['nodes']} free cells, {info['edges']} edges "
                      f"({args.connectedness}-connectedness: {info['blocked']} of "
                      f"{info['candidates']} moves blocked for the radius "
                      f"{prob.robots[0].radius:g})")
    if args.graph is None or args.tasks is None:
        raise CLIError("give GRAPH TASKS (a GraphML roadmap and its task file) or --map X.map "
                       "--scen X.scen (a MovingAI grid)")
    if args.connectedness != 2:
        raise CLIError("--connectedness is for MovingAI grids, not GraphML roadmaps")
    kw = {} if args.radius is None else {"radius": args.radius}
    prob = read_roadmap_mapf(args.graph, args.tasks, agents=args.agents,
                             max_speed=args.max_speed, merge_duplicates=args.merge_duplicates,
                             info=info, **kw)
    notes = [f"edge weights that are not the Euclidean length: {info['weights_off']} (ignored: "
             "the robots drive the straight edges)"] if info["weights_off"] else []
    if info["one_way"]:
        notes.append(f"one-way edges read as two-way: {info['one_way']}")
    if info["merged"]:
        notes.append(f"nodes merged into another at the same place: {info['merged']}")
    return prob, (f"{args.graph}: {info['nodes']} nodes, {info['edges']} edges"
                  + "".join(f"; {n}" for n in notes))


def cmd_import_mapf(args: argparse.Namespace, out: TextIO) -> int:
    """Read the instance, write its scenario TOML (``--out``, else standard output) and say
    what was read."""
    from optplan.maps import to_toml

    info: dict[str, Any] = {}
    prob, line = _read(args, info)
    if args.name:
        prob = prob.replaced(keep=("frame",), name=args.name)
    header = f"Imported by 'optplan import-mapf': {prob.source}."
    text = to_toml(prob, header)
    if args.out:
        dest = Path(args.out)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_text(text, encoding="utf-8")
        print(line, file=out)
        print(f"wrote {dest}: {len(prob.robots)} agents, radius {prob.robots[0].radius:g} "
              f"(try: {PROG} show {dest})", file=out)
    else:
        out.write(text)
    return 0
