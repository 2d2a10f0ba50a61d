"""The ``optplan`` command: list, show, solve, bench, validate, plot, animate.

This package is the only part of optplan that prints.  Bad input (unknown names, malformed
scenarios or options, missing files) ends with a one-line ``optplan: error: ...`` on stderr and
exit status 2; pass ``--traceback`` (before the command) to see the Python traceback instead.
matplotlib is imported only by the commands that draw.

Run ``optplan -h`` or ``optplan COMMAND -h`` for the options; ``docs/cli.md`` has examples.
"""

from __future__ import annotations

from optplan.cli.app import main
from optplan.cli.catalogue import cmd_list as cmd_list
from optplan.cli.catalogue import cmd_show as cmd_show
from optplan.cli.catalogue import cmd_show_solver as cmd_show_solver
from optplan.cli.common import PROG as PROG
from optplan.cli.common import CLIError as CLIError
from optplan.cli.common import parse_set
from optplan.cli.figures import FIG_SUFFIXES as FIG_SUFFIXES
from optplan.cli.figures import MAX_DPI as MAX_DPI
from optplan.cli.figures import cmd_animate as cmd_animate
from optplan.cli.figures import cmd_plot as cmd_plot
from optplan.cli.map_import import cmd_import_map as cmd_import_map
from optplan.cli.parser import build_parser as build_parser
from optplan.cli.solving import _result_lines as _result_lines
from optplan.cli.solving import cmd_solve as cmd_solve
from optplan.cli.sweep import MAX_SEEDS as MAX_SEEDS
from optplan.cli.sweep import cmd_bench as cmd_bench
from optplan.cli.sweep import cmd_report as cmd_report
from optplan.cli.sweep import cmd_validate as cmd_validate

__all__ = ["main", "parse_set"]
