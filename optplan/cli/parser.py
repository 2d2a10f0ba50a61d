"""The ``optplan`` argument parser: every command and its options.

:data:`COMMANDS` lists the commands in the order of ``optplan -h``, each with its handler, its
``add_parser`` keywords and its arguments; :func:`build_parser` adds them in one loop.  An
argument several commands take is written once (``_PROBLEM``, ``_RESULT``, ...).
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from typing import Any, TextIO

from optplan.cli.catalogue import cmd_list, cmd_show, cmd_show_solver
from optplan.cli.common import PROG
from optplan.cli.figures import cmd_animate, cmd_plot
from optplan.cli.map_gen import cmd_gen_map
from optplan.cli.map_import import cmd_import_map
from optplan.cli.mapf_import import cmd_import_mapf
from optplan.cli.ros_export import cmd_export_path
from optplan.cli.solving import cmd_solve
from optplan.cli.sweep import cmd_bench, cmd_export_arena, cmd_report

#: one ``add_argument`` call: its flags and keywords
Arg = tuple[tuple[str, ...], dict[str, Any]]
#: a command's handler: the parsed arguments and the output stream -> the exit status
Handler = Callable[[argparse.Namespace, TextIO], int]


def _arg(*flags: str, **kw: Any) -> Arg:
    """The flags and keywords of one ``add_argument`` call."""
    return flags, kw


def _dpi(kind: type, default: float, what: str = "PNG") -> Arg:
    """The ``--dpi`` option of a command that draws (``what``: the image it sets)."""
    return _arg("--dpi", type=kind, default=default,
                help=f"{what} resolution (default {default})")


_PROBLEM = _arg("problem", help="catalogue name or .toml path")
_SOLVER = _arg("solver", help="preset name, backend name or .toml preset")
_SEED = _arg("--seed", type=int, default=0, help="random seed (default 0)")
_DB = _arg("db", help="results database (SQLite) written by 'optplan bench --db'")
_RESULT = _arg("result", help="result JSON written by 'optplan solve --json'")
_RESULT_PROBLEM = _arg("--problem", help="problem name or .toml path (default: the result's)")

_BENCH = [
    _arg("--problems", help="comma-separated problem names, .toml paths or MovingAI .scen files "
                            "(one problem per .scen line)"),
    _arg("--radius", type=float, default=None, metavar="R",
         help="robot radius of the problems read from .scen files (map units; default 0: point "
              "robots)"),
    _arg("--buckets", metavar="SPEC",
         help="the buckets of the .scen files to run, e.g. 0-5,9 (ranges inclusive; default: "
              "every bucket)"),
    _arg("--solvers", help="comma-separated solver names, or 'all' (every preset)"),
    _arg("--seeds", type=int, default=10, help="seeds 0..N-1 (default 10)"),
    _arg("--workers", type=int, default=1, help="processes (default 1: inline)"),
    _arg("--out", default="runs/bench", help="output directory (default runs/bench)"),
    _arg("--set", action="append", metavar="KEY=VALUE",
         help="override an option of every solver (TOML literal; repeatable)"),
    _arg("--tag", help="experiment name or problem tag"),
    _arg("--quiet", action="store_true", help="no progress bar"),
    _arg("--db", metavar="FILE.sqlite",
         help="store every run in this SQLite file as it finishes; rerunning the same command "
              "resumes (finished problem/solver/seed cells are skipped)"),
    _arg("--time-limit", type=float, default=None, metavar="S",
         help="seconds per run: the solver stops at its first iteration after S; a run still "
              "going at S + max(1, S/2) is stopped by the harness"),
    _arg("--scheduler", metavar="ADDRESS",
         help="run on an existing Dask cluster (e.g. tcp://host:8786; needs dask[distributed])"),
    _arg("--dask-local", type=int, default=None, metavar="N",
         help="run on a Dask LocalCluster of N worker processes"),
]

_IMPORT_MAP = [
    _arg("map", help="map file (.yaml, .png/.pgm/..., .map) or shipped map name"),
    _arg("--radius", type=float, required=True, help="robot radius (map units)"),
    _arg("--start", action="append", required=True, metavar="X,Y",
         help="start of a robot (repeat for several robots)"),
    _arg("--goal", action="append", required=True, metavar="X,Y",
         help="goal of a robot (one per --start)"),
    _arg("--robot", action="append", metavar="ID",
         help="robot id (one per --start; default r1, r2, ...)"),
    _arg("--max-speed", type=float, default=1.0, metavar="V",
         help="speed limit of every robot (map units / s, default 1)"),
    _arg("--out", metavar="TOML", help="scenario file to write (default: stdout)"),
    _arg("--name", help="scenario name (default: the map file's stem; for map.yaml its "
                        "directory's name)"),
    _arg("--resolution", type=float, metavar="RES",
         help="cell size of a bare image or MovingAI map (map units per cell)"),
    _arg("--origin", metavar="X,Y[,YAW]",
         help="world pose of the lower-left corner of a bare image or .map"),
    _arg("--negate", action="store_true", help="bare image: dark pixels are free"),
    _arg("--mode", choices=["trinary", "scale", "raw"],
         help="bare image: map_server mode (default trinary)"),
    _arg("--occupied-thresh", type=float, metavar="P",
         help="bare image: occupied above this probability (default 0.65)"),
    _arg("--free-thresh", type=float, metavar="P",
         help="bare image: free below this probability (default 0.196)"),
    _arg("--unknown", choices=["occupied", "free"], default="occupied",
         help="what unknown cells are (default occupied)"),
    _arg("--grow", type=float, default=0.5, metavar="CELLS",
         help="growth of the cell union before simplifying (cells, default 0.5)"),
    _arg("--simplify", type=float, default=0.5, metavar="CELLS",
         help="Douglas-Peucker tolerance (cells, default 0.5; reduced where the simplified "
              "polygon would not cover every cell)"),
    _arg("--join", choices=["round", "mitre"], default="round",
         help="growth corners: round (Euclidean, default) or mitre (square)"),
    _arg("--keep-holes", action="store_true",
         help="keep free holes no start or goal lies in (default: fill them)"),
    _arg("--crop", choices=["auto", "on", "off"], default="auto",
         help="crop the map to its known cells (default auto: when the unknown margin outside "
              "them is more than 25 %% of the image and --unknown is occupied)"),
    _arg("--max-cells", type=int, metavar="N",
         help="largest map read, in cells (default 67108864 = 8192 x 8192)"),
]

_IMPORT_MAPF = [
    _arg("graph", nargs="?", help="GraphML roadmap (Continuous-CBS format)"),
    _arg("tasks", nargs="?", help="its task file (<agent start_id=.. goal_id=../>)"),
    _arg("--map", metavar="X.map", help="a MovingAI map (instead of GRAPH TASKS; with --scen)"),
    _arg("--scen", metavar="X.scen", help="the MovingAI .scen whose first lines are the agents"),
    _arg("--agents", type=int, metavar="K", help="the first K agents (default: all)"),
    _arg("--radius", type=float, metavar="R",
         help="robot radius (the graph's units, cells on a grid; default sqrt(2)/4, "
              "Continuous-CBS's)"),
    _arg("--max-speed", type=float, default=1.0, metavar="V",
         help="speed of every robot (units / s, default 1)"),
    _arg("--connectedness", type=int, choices=[2, 3, 4, 5], default=2,
         help="grid moves: 2 (4-connected, default), 3 (8), 4 (16), 5 (32 neighbours)"),
    _arg("--merge-duplicates", action="store_true",
         help="read roadmap nodes at the same place as one node (default: an error)"),
    _arg("-o", "--out", metavar="TOML", help="scenario file to write (default: stdout)"),
    _arg("--name", help="scenario name (default: from the file names)"),
]

#: command -> (handler, ``add_parser`` keywords, arguments), in the order of ``optplan -h``
#: (``validate``'s handler is None: the CLI hands its arguments to optplan.experiments.validate)
COMMANDS: dict[str, tuple[Handler | None, dict[str, Any], list[Arg]]] = {
    "list": (cmd_list, {"help": "list catalogue problems and solver presets"}, [
        _arg("what", nargs="?", choices=["problems", "solvers"],
             help="only problems or only solvers"),
        _arg("--tag", help="problems carrying this tag / solvers of this backend"),
    ]),
    "show-solver": (cmd_show_solver, {
        "help": "a solver's options: value, default, allowed values, meaning"}, [_SOLVER]),
    "show": (cmd_show, {"help": "describe a problem and its certified optimum"}, [
        _PROBLEM, _arg("--out", help="write a PNG of the map"), _dpi(int, 120),
    ]),
    "solve": (cmd_solve, {"help": "solve one problem with one solver"}, [
        _PROBLEM, _SOLVER, _SEED,
        _arg("--time-limit", type=float, default=None, metavar="S",
             help="stop after S seconds and return the best result so far"),
        _arg("--no-reference", action="store_true",
             help="do not compute the certified optimum (no ratio to optimum)"),
        _arg("--team-reference", action="store_true",
             help="also grade a team plan against the problem's team reference (the best "
                  "known team plans, formation-nlp polished from each heuristic; robots with "
                  "their own goals: ccbs's sum of arrivals) and its certified lower bound"),
        _arg("--set", action="append", metavar="KEY=VALUE",
             help="override an option; VALUE is a TOML literal (repeatable)"),
        _arg("--json", metavar="FILE", help="save the Result as JSON"),
        _arg("--plot", metavar="PNG", help="save a picture of the result"),
        _arg("--progress", action="store_true",
             help="print the solver's progress on stderr (time-bracket: the bracket closing)"),
    ]),
    "bench": (cmd_bench, {
        "help": "problems x solvers x seeds, or a named experiment (--tag)",
        "description": "Run problems x solvers x seeds (common seeds across solvers). With "
                       "--tag NAME: if optplan.experiments.NAME exists, the remaining "
                       "arguments go to its main(); otherwise the problems tagged NAME are "
                       "benchmarked."}, _BENCH),
    "report": (cmd_report, {
        "help": "HTML + PNG report of a bench results database",
        "description": "Write a static HTML page (no server) with PNG plots per problem from a "
                       "database written by 'optplan bench --db': outcome and success rate, "
                       "length / optimum and wall-time box plots per solver, convergence "
                       "curves, summary tables."}, [
        _DB, _arg("--out", default="report", help="output directory (default report)"),
        _dpi(int, 100),
    ]),
    "export-arena": (cmd_export_arena, {
        "help": "a bench results database as an OMPL benchmark database (Planner Arena)",
        "description": "Write a database written by 'optplan bench --db' in OMPL's benchmark "
                       "database schema, to open in Planner Arena (pip install plannerarena): "
                       "one experiment per problem, one planner configuration per solver and "
                       "its options."}, [
        _DB, _arg("out", help="OMPL benchmark database to write (replaced if it exists)"),
    ]),
    "validate": (None, {
        "add_help": False,
        "help": "certify a solver against the exact references "
                "(optplan.experiments.validate; 'optplan validate -h')"}, []),
    "plot": (cmd_plot, {"help": "draw a saved result (JSON) as a PNG, SVG or PDF"}, [
        _RESULT,
        _arg("--out", required=True,
             help="figure to write: .png, .svg or .pdf (the suffix picks the format)"),
        _dpi(float, 100),
        _arg("--snapshot-every", type=int, default=None, metavar="K",
             help="formation snapshot every K steps (0: none; default about 8 per run)"),
        _RESULT_PROBLEM,
    ]),
    "animate": (cmd_animate, {"help": "animate a saved result (JSON) as a GIF"}, [
        _RESULT, _arg("--out", required=True, help="GIF to write"), _dpi(float, 80, "frame"),
        _arg("--fps", type=float, default=10, help="frames per second (default 10)"),
        _arg("--max-frames", type=int, default=150, help="frame limit (default 150)"),
        _RESULT_PROBLEM,
    ]),
    "export-path": (cmd_export_path, {
        "help": "a saved result's timed path as a ROS nav_msgs/Path (YAML/JSON)",
        "description": "Write one robot's path of a result JSON ('optplan solve --json') as a "
                       "nav_msgs/Path message: a header with frame_id and stamp, one "
                       "PoseStamped per point with its time stamp and its heading as a "
                       "quaternion. No ROS installation needed; 'ros2 topic pub /plan "
                       "nav_msgs/msg/Path' reads the YAML."}, [
        _RESULT,
        _arg("--robot", metavar="ID", help="robot id (default: the leader)"),
        _arg("--frame-id", default="map", help="frame of every header (default map)"),
        _arg("--start-time", type=float, default=0.0, metavar="S",
             help="stamp of t = 0, seconds (default 0)"),
        _arg("--format", choices=["yaml", "json"],
             help="output format (default: json for an --out ending in .json, else yaml)"),
        _arg("--out", metavar="FILE", help="file to write (default: stdout)"),
    ]),
    "import-map": (cmd_import_map, {
        "help": "turn an occupancy map into a scenario TOML",
        "description": "Import a ROS map_server YAML (+ image), a bare PNG/PGM image (with "
                       "--resolution and --origin) or a MovingAI .map as a scenario: obstacle "
                       "cells become conservative polygons (every cell inside; docs/maps.md). "
                       "MAP may also name a shipped map (problems/maps/), e.g. 'warehouse'."},
                   _IMPORT_MAP),
    "import-mapf": (cmd_import_mapf, {
        "help": "turn a multi-agent path-finding instance into a scenario TOML with a roadmap",
        "description": "Import a continuous-time MAPF instance: a GraphML roadmap and its task "
                       "file as Continuous-CBS reads them (GRAPH TASKS), or a MovingAI grid "
                       "(--map X.map --scen X.scen: the .scen's first lines are the agents, "
                       "the free cells' centres the roadmap). The robots keep to the "
                       "roadmap's straight edges (docs/mapf.md)."}, _IMPORT_MAPF),
    "gen-map": (cmd_gen_map, {
        "help": "write a seeded MovingAI benchmark map (.map) and its queries (.scen)",
        "description": "Generate a MovingAI-format map of a family (random, room, maze, "
                       "street) and a .scen of start/goal pairs between mutually reachable free "
                       "cells, with octile optimal lengths (A*, 8-connected, no corner "
                       "cutting)."}, [
        _arg("kind", choices=["random", "room", "maze", "street"], help="map family"),
        _arg("size", type=int, help="cells per side (8..2048; 32..1024 typical)"),
        _SEED,
        _arg("--out", required=True, metavar="DIR", help="directory to write into"),
        _arg("--queries", type=int, default=100, metavar="N",
             help="lines of the .scen (default 100)"),
        _arg("--density", type=float, default=0.2, metavar="D",
             help="random maps: blocked share, 0..0.4 (default 0.2)"),
        _arg("--name", help="file stem (default <kind>-<size>-<size>[-<density %%>]-seed<S>)"),
    ]),
}

#: import-map's points such as "-11,-11.5" are values, not options (argparse only knows
#: "-11" and "-1.5" as negative numbers)
_POINT = re.compile(r"^-\d+$|^-\d*\.\d+$|^-\d*\.?\d*(e-?\d+)?[, ]")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="optplan: optimisation-centric path planning for robot teams.",
        epilog="Run 'optplan COMMAND -h' for a command's options.",
    )
    p.add_argument("--traceback", action="store_true",
                   help="show Python tracebacks instead of one-line errors")
    from optplan import __version__

    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for name, (func, keywords, args) in COMMANDS.items():
        s = sub.add_parser(name, **keywords)
        if name == "import-map":
            s._negative_number_matcher = _POINT
        for flags, kw in args:
            s.add_argument(*flags, **kw)
        s.set_defaults(func=func)
    return p
