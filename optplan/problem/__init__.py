"""Problem model and the TOML scenario format (problems/README.md).

* :mod:`~optplan.problem.model`: the immutable :class:`Problem` and its parts (robots, static
  and moving obstacles, the formation), the exact engine behind :meth:`Problem.obstacle_set`;
* :mod:`~optplan.problem.scenario`: :func:`parse_problem` and :func:`read_problem`, the
  scenario format with every key checked (:mod:`~optplan.problem.context`,
  :mod:`~optplan.problem.parse_obstacles`); every error raises :class:`ProblemError` naming
  the file and the key;
* :mod:`~optplan.problem.writer`: :func:`problem_to_dict` and :func:`transform_problem`.
"""

from optplan.problem.model import (
    CIRCLE_QUAD_SEGS,
    CLOSE_REL,
    MAX_ASPECT,
    MAX_COORD,
    MAX_FILE_BYTES,
    MAX_POINTS,
    MAX_REL_SPEED,
    MAX_TIME,
    MIN_REL_PERIOD,
    MIN_REL_SPEED,
    POINT_GOAL_TOL_REL,
    REFERENCE_DIAGONAL,
    DynamicObstacle,
    Follower,
    Formation,
    Obstacle,
    Problem,
    ProblemError,
    Robot,
)
from optplan.problem.roadmap import RoadmapGraph
from optplan.problem.scenario import parse_problem, read_problem
from optplan.problem.writer import problem_to_dict, ring_points, round_decimals, transform_problem

__all__ = [
    "ProblemError",
    "Robot",
    "Obstacle",
    "DynamicObstacle",
    "Follower",
    "Formation",
    "Problem",
    "RoadmapGraph",
    "parse_problem",
    "read_problem",
    "problem_to_dict",
    "transform_problem",
    "ring_points",
    "round_decimals",
    "CIRCLE_QUAD_SEGS",
    "CLOSE_REL",
    "MAX_ASPECT",
    "MAX_COORD",
    "MAX_FILE_BYTES",
    "MAX_POINTS",
    "MAX_REL_SPEED",
    "MAX_TIME",
    "MIN_REL_PERIOD",
    "MIN_REL_SPEED",
    "POINT_GOAL_TOL_REL",
    "REFERENCE_DIAGONAL",
]
