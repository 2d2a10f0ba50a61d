"""optplan: optimisation-centric planning for robot teams in 2-D workspaces.

>>> import optplan as op
>>> res = op.solve("open-field", "visgraph")
>>> res.status.value, round(res.metrics["ratio_to_optimum"], 6)
('optimal', 1.0)
"""

from optplan.catalog import list_problems, load_problem
from optplan.metrics import evaluate
from optplan.problem import Problem, ProblemError, parse_problem, read_problem
from optplan.result import History, Progress, Result, ResultFileError, Status
from optplan.solver import Backend, get_solver, list_backends, list_solvers, register, solve

__version__ = "0.4.0"

__all__ = [
    "Backend",
    "History",
    "Problem",
    "ProblemError",
    "Progress",
    "Result",
    "ResultFileError",
    "Status",
    "evaluate",
    "get_solver",
    "list_backends",
    "list_problems",
    "list_solvers",
    "load_problem",
    "parse_problem",
    "read_problem",
    "register",
    "solve",
]
