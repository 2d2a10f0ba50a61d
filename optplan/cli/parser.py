"""The ``optplan`` argument parser: every command and its options."""

from __future__ import annotations

import argparse
import re

from optplan.cli.catalogue import cmd_list, cmd_show, cmd_show_solver
from optplan.cli.common import PROG
from optplan.cli.figures import cmd_animate, cmd_plot
from optplan.cli.map_gen import cmd_gen_map
from optplan.cli.map_import import cmd_import_map
from optplan.cli.ros_export import cmd_export_path
from optplan.cli.solving import cmd_solve
from optplan.cli.sweep import cmd_bench, cmd_export_arena, cmd_report


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

    s = sub.add_parser("list", help="list catalogue problems and solver presets")
    s.add_argument("what", nargs="?", choices=["problems", "solvers"],
                   help="only problems or only solvers")
    s.add_argument("--tag", help="problems carrying this tag / solvers of this backend")
    s.set_defaults(func=cmd_list)

    s = sub.add_parser("show-solver",
                       help="a solver's options: value, default, allowed values, meaning")
    s.add_argument("solver", help="preset name, backend name or .toml preset")
    s.set_defaults(func=cmd_show_solver)

    s = sub.add_parser("show", help="describe a problem and its certified optimum")
    s.add_argument("problem", help="catalogue name or .toml path")
    s.add_argument("--out", help="write a PNG of the map")
    s.add_argument("--dpi", type=int, default=120, help="PNG resolution (default 120)")
    s.set_defaults(func=cmd_show)

    s = sub.add_parser("solve", help="solve one problem with one solver")
    s.add_argument("problem", help="catalogue name or .toml path")
    s.add_argument("solver", help="preset name, backend name or .toml preset")
    s.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    s.add_argument("--time-limit", type=float, default=None, metavar="S",
                   help="stop after S seconds and return the best result so far")
    s.add_argument("--no-reference", action="store_true",
                   help="do not compute the certified optimum (no ratio to optimum)")
    s.add_argument("--team-reference", action="store_true",
                   help="also grade a team plan against the joint trajectory NLP warm-started "
                        "from it (formation-nlp; a local optimum)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override an option; VALUE is a TOML literal (repeatable)")
    s.add_argument("--json", metavar="FILE", help="save the Result as JSON")
    s.add_argument("--plot", metavar="PNG", help="save a picture of the result")
    s.set_defaults(func=cmd_solve)

    s = sub.add_parser(
        "bench", help="problems x solvers x seeds, or a named experiment (--tag)",
        description="Run problems x solvers x seeds (common seeds across solvers). With "
                    "--tag NAME: if optplan.experiments.NAME exists, the remaining arguments "
                    "go to its main(); otherwise the problems tagged NAME are benchmarked.")
    s.add_argument("--problems",
                   help="comma-separated problem names, .toml paths or MovingAI .scen files "
                        "(one problem per .scen line)")
    s.add_argument("--radius", type=float, default=None, metavar="R",
                   help="robot radius of the problems read from .scen files (map units; "
                        "default 0: point robots)")
    s.add_argument("--buckets", metavar="SPEC",
                   help="the buckets of the .scen files to run, e.g. 0-5,9 (ranges inclusive; "
                        "default: every bucket)")
    s.add_argument("--solvers", help="comma-separated solver names, or 'all' (every preset)")
    s.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 (default 10)")
    s.add_argument("--workers", type=int, default=1, help="processes (default 1: inline)")
    s.add_argument("--out", default="runs/bench", help="output directory (default runs/bench)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override an option of every solver (TOML literal; repeatable)")
    s.add_argument("--tag", help="experiment name or problem tag")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.add_argument("--db", metavar="FILE.sqlite",
                   help="store every run in this SQLite file as it finishes; rerunning the "
                        "same command resumes (finished problem/solver/seed cells are skipped)")
    s.add_argument("--time-limit", type=float, default=None, metavar="S",
                   help="seconds per run: the solver stops at its first iteration after S; a "
                        "run still going at S + max(1, S/2) is stopped by the harness")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on an existing Dask cluster (e.g. tcp://host:8786; needs "
                        "dask[distributed])")
    s.add_argument("--dask-local", type=int, default=None, metavar="N",
                   help="run on a Dask LocalCluster of N worker processes")
    s.set_defaults(func=cmd_bench)

    s = sub.add_parser("report", help="HTML + PNG report of a bench results database",
                       description="Write a static HTML page (no server) with PNG plots per "
                                   "problem from a database written by 'optplan bench --db': "
                                   "outcome and success rate, length / optimum and wall-time "
                                   "box plots per solver, convergence curves, summary tables.")
    s.add_argument("db", help="results database (SQLite) written by 'optplan bench --db'")
    s.add_argument("--out", default="report", help="output directory (default report)")
    s.add_argument("--dpi", type=int, default=100, help="PNG resolution (default 100)")
    s.set_defaults(func=cmd_report)

    s = sub.add_parser("export-arena",
                       help="a bench results database as an OMPL benchmark database "
                            "(Planner Arena)",
                       description="Write a database written by 'optplan bench --db' in OMPL's "
                                   "benchmark database schema, to open in Planner Arena "
                                   "(pip install plannerarena): one experiment per problem, "
                                   "one planner configuration per solver and its options.")
    s.add_argument("db", help="results database (SQLite) written by 'optplan bench --db'")
    s.add_argument("out", help="OMPL benchmark database to write (replaced if it exists)")
    s.set_defaults(func=cmd_export_arena)

    s = sub.add_parser("validate", add_help=False,
                       help="certify a solver against the exact references "
                            "(optplan.experiments.validate; 'optplan validate -h')")
    s.set_defaults(func=None)

    s = sub.add_parser("plot", help="draw a saved result (JSON) as a PNG, SVG or PDF")
    s.add_argument("result", help="result JSON written by 'optplan solve --json'")
    s.add_argument("--out", required=True,
                   help="figure to write: .png, .svg or .pdf (the suffix picks the format)")
    s.add_argument("--dpi", type=float, default=100, help="PNG resolution (default 100)")
    s.add_argument("--snapshot-every", type=int, default=None, metavar="K",
                   help="formation snapshot every K steps (0: none; default about 8 per run)")
    s.add_argument("--problem", help="problem name or .toml path (default: the result's)")
    s.set_defaults(func=cmd_plot)

    s = sub.add_parser("animate", help="animate a saved result (JSON) as a GIF")
    s.add_argument("result", help="result JSON written by 'optplan solve --json'")
    s.add_argument("--out", required=True, help="GIF to write")
    s.add_argument("--dpi", type=float, default=80, help="frame resolution (default 80)")
    s.add_argument("--fps", type=float, default=10, help="frames per second (default 10)")
    s.add_argument("--max-frames", type=int, default=150, help="frame limit (default 150)")
    s.add_argument("--problem", help="problem name or .toml path (default: the result's)")
    s.set_defaults(func=cmd_animate)

    s = sub.add_parser(
        "export-path", help="a saved result's timed path as a ROS nav_msgs/Path (YAML/JSON)",
        description="Write one robot's path of a result JSON ('optplan solve --json') as a "
                    "nav_msgs/Path message: a header with frame_id and stamp, one PoseStamped "
                    "per point with its time stamp and its heading as a quaternion. No ROS "
                    "installation needed; 'ros2 topic pub /plan nav_msgs/msg/Path' reads the "
                    "YAML.")
    s.add_argument("result", help="result JSON written by 'optplan solve --json'")
    s.add_argument("--robot", metavar="ID", help="robot id (default: the leader)")
    s.add_argument("--frame-id", default="map", help="frame of every header (default map)")
    s.add_argument("--start-time", type=float, default=0.0, metavar="S",
                   help="stamp of t = 0, seconds (default 0)")
    s.add_argument("--format", choices=["yaml", "json"],
                   help="output format (default: json for an --out ending in .json, else yaml)")
    s.add_argument("--out", metavar="FILE", help="file to write (default: stdout)")
    s.set_defaults(func=cmd_export_path)

    s = sub.add_parser(
        "import-map", help="turn an occupancy map into a scenario TOML",
        description="Import a ROS map_server YAML (+ image), a bare PNG/PGM image (with "
                    "--resolution and --origin) or a MovingAI .map as a scenario: obstacle "
                    "cells become conservative polygons (every cell inside; docs/maps.md). "
                    "MAP may also name a shipped map (problems/maps/), e.g. 'warehouse'.")
    # values such as "-11,-11.5" are points, not options (argparse only knows "-11" and "-1.5")
    s._negative_number_matcher = re.compile(r"^-\d+$|^-\d*\.\d+$|^-\d*\.?\d*(e-?\d+)?[, ]")
    s.add_argument("map", help="map file (.yaml, .png/.pgm/..., .map) or shipped map name")
    s.add_argument("--radius", type=float, required=True, help="robot radius (map units)")
    s.add_argument("--start", action="append", required=True, metavar="X,Y",
                   help="start of a robot (repeat for several robots)")
    s.add_argument("--goal", action="append", required=True, metavar="X,Y",
                   help="goal of a robot (one per --start)")
    s.add_argument("--robot", action="append", metavar="ID",
                   help="robot id (one per --start; default r1, r2, ...)")
    s.add_argument("--max-speed", type=float, default=1.0, metavar="V",
                   help="speed limit of every robot (map units / s, default 1)")
    s.add_argument("--out", metavar="TOML", help="scenario file to write (default: stdout)")
    s.add_argument("--name", help="scenario name (default: the map file's stem; for map.yaml "
                                  "its directory's name)")
    s.add_argument("--resolution", type=float, metavar="RES",
                   help="cell size of a bare image or MovingAI map (map units per cell)")
    s.add_argument("--origin", metavar="X,Y[,YAW]",
                   help="world pose of the lower-left corner of a bare image or .map")
    s.add_argument("--negate", action="store_true", help="bare image: dark pixels are free")
    s.add_argument("--mode", choices=["trinary", "scale", "raw"],
                   help="bare image: map_server mode (default trinary)")
    s.add_argument("--occupied-thresh", type=float, metavar="P",
                   help="bare image: occupied above this probability (default 0.65)")
    s.add_argument("--free-thresh", type=float, metavar="P",
                   help="bare image: free below this probability (default 0.196)")
    s.add_argument("--unknown", choices=["occupied", "free"], default="occupied",
                   help="what unknown cells are (default occupied)")
    s.add_argument("--grow", type=float, default=0.5, metavar="CELLS",
                   help="growth of the cell union before simplifying (cells, default 0.5)")
    s.add_argument("--simplify", type=float, default=0.5, metavar="CELLS",
                   help="Douglas-Peucker tolerance (cells, default 0.5; reduced where the "
                        "simplified polygon would not cover every cell)")
    s.add_argument("--join", choices=["round", "mitre"], default="round",
                   help="growth corners: round (Euclidean, default) or mitre (square)")
    s.add_argument("--keep-holes", action="store_true",
                   help="keep free holes no start or goal lies in (default: fill them)")
    s.add_argument("--crop", choices=["auto", "on", "off"], default="auto",
                   help="crop the map to its known cells (default auto: when the unknown "
                        "margin outside them is more than 25 %% of the image and --unknown "
                        "is occupied)")
    s.add_argument("--max-cells", type=int, metavar="N",
                   help="largest map read, in cells (default 67108864 = 8192 x 8192)")
    s.set_defaults(func=cmd_import_map)

    s = sub.add_parser(
        "gen-map", help="write a seeded MovingAI benchmark map (.map) and its queries (.scen)",
        description="Generate a MovingAI-format map of a family (random, room, maze, street) "
                    "and a .scen of start/goal pairs between mutually reachable free cells, "
                    "with octile optimal lengths (A*, 8-connected, no corner cutting).")
    s.add_argument("kind", choices=["random", "room", "maze", "street"], help="map family")
    s.add_argument("size", type=int, help="cells per side (8..2048; 32..1024 typical)")
    s.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    s.add_argument("--out", required=True, metavar="DIR", help="directory to write into")
    s.add_argument("--queries", type=int, default=100, metavar="N",
                   help="lines of the .scen (default 100)")
    s.add_argument("--density", type=float, default=0.2, metavar="D",
                   help="random maps: blocked share, 0..0.4 (default 0.2)")
    s.add_argument("--name", help="file stem (default <kind>-<size>-<size>[-<density %%>]"
                                  "-seed<S>)")
    s.set_defaults(func=cmd_gen_map)
    return p
