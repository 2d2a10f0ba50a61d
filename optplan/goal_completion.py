"""Grading a run that stops inside the goal tolerance: its shortest continuation to the goal.

The validator accepts a run whose end lies within the goal tolerance of the goal
(:meth:`~optplan.problem.Problem.goal_tol`: the robot's radius unless the scenario says
otherwise), but every reference is for the goal *point*: the certified shortest path, the
time references and the lower bound on the arrival.  Compared as they are, a run that stops a
radius short of the goal would look up to a radius better than the optimum.

**The rule.**  A run is graded as if it went on from where it is accepted to the goal point by
the shortest continuation:

* **length**: ``length_to_goal = length + goal_completion``, ``goal_completion`` being the exact
  shortest distance (the tangent graph of the same known map as the optimum) from the path's
  last point to the goal.  The path followed by that continuation is a path to the goal point,
  so ``length_to_goal >= optimum`` for every collision-free path (the triangle inequality of
  shortest distances); ``ratio_to_optimum = length_to_goal / optimum``.
* **arrival**: ``arrival_at_goal`` is the time at which the robot, leaving the point where it
  first enters the goal tolerance at its arrival time, reaches the goal point along the
  shortest continuation (on the whole static map) at ``max_speed``.  That completed motion is
  checked by the validator against the static map and, in continuous time, the moving
  obstacles.  When it is valid it is a motion to the goal point, so it can beat neither the true
  earliest arrival nor its certified lower bound; when the continuation meets a moving obstacle
  the arrival has no grade against the references (``goal_completion_status`` says why).

A run that ends on the goal point is graded as before (``goal_completion = 0``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.geometry.collision.polyline import cumulative_length
from optplan.problem import Problem

__all__ = ["Completion", "completion_length", "completed_arrival"]


def _continuation(problem: Problem, robot_id: str, end: np.ndarray, known_only: bool
                  ) -> tuple[float, np.ndarray | None]:
    """The exact shortest distance and a polyline from ``end`` to the robot's goal."""
    from optplan.geometry.tangent.tangent_graph import tangent_graph

    robot = problem.robot(robot_id)
    goal = np.asarray(robot.goal, float)
    if np.array_equal(end, goal):
        return 0.0, np.vstack([end, goal])
    graph = tangent_graph(problem.obstacle_set(robot.radius, known_only=known_only))
    res = graph.shortest_path(end, goal)
    if res.polyline is None or not res.info.get("certified", True):
        return math.inf, None
    return float(res.length), np.asarray(res.polyline, float)


def completion_length(problem: Problem, robot_id: str, path: Any) -> float | None:
    """``goal_completion`` (module docstring): the exact shortest distance on the known static
    map from the last point of ``path`` to the goal of ``robot_id``; ``None`` when the path
    does not end within the goal tolerance (an unreached run is not completed), ``inf`` when
    no path joins them."""
    robot = problem.robot(robot_id)
    pts = np.asarray(path, float)
    if robot.goal is None or len(pts) == 0:
        return None
    end = pts[-1]
    if np.hypot(*(end - robot.goal)) > problem.goal_tol(robot) + problem.frame.eps:
        return None
    return _continuation(problem, robot_id, end, known_only=True)[0]


@dataclass(frozen=True)
class Completion:
    """A run's arrival at the goal point (module docstring).

    Attributes
    ----------
    arrival : float or None
        ``arrival_at_goal``: the time the completed motion reaches the goal point; ``None``
        when there is none (no continuation, or it meets a moving obstacle).
    distance : float
        Length of the continuation from the point of arrival to the goal point.
    valid : bool
        Whether the completed motion (the plan up to its arrival and the continuation) is
        accepted by the validator against the static map and the moving obstacles.
    status : str
        ``"at goal"``, ``"completed"``, or why there is no arrival at the goal point.
    """

    arrival: float | None
    distance: float
    valid: bool
    status: str


def completed_arrival(problem: Problem, robot_id: str, path: np.ndarray, stamps: np.ndarray,
                      end: int) -> Completion:
    """The arrival at the goal point of ``robot_id``'s plan (``path`` with time ``stamps``)
    whose ``end``-th point is the first within the goal tolerance (module docstring)."""
    from optplan.metrics import time_checks

    robot = problem.robot(robot_id)
    e, t = path[end], float(stamps[end])
    dist, line = _continuation(problem, robot_id, e, known_only=False)
    if line is None:
        return Completion(None, dist, False, "no path joins the point of arrival to the goal")
    tail = t + cumulative_length(line) / robot.max_speed
    pts = np.vstack([path[:end + 1], line[1:]])
    times = np.concatenate([stamps[:end + 1], tail[1:]])
    oset = problem.obstacle_set(robot.radius)
    own = path[:end + 1] if end > 0 else path[[0, 0]]
    plan, cont = oset.crossings(own[None]).count[0], oset.crossings(line[None]).count[0]
    hits = time_checks(problem, {robot_id: pts}, {robot_id: times})["contacts"]
    late = [c for c in hits if c["time"] > t]
    plan_ok = plan == 0 and len(late) == len(hits) and bool(np.all(problem.frame.in_bounds(pts)))
    if plan_ok and cont == 0 and not late:
        return Completion(float(tail[-1]), dist, True, "at goal" if dist == 0.0 else "completed")
    if not plan_ok:  # graded as it is, informational: the plan is not valid anyway
        return Completion(float(tail[-1]), dist, False,
                          "completed; the plan itself is not valid")
    why = (f"meets {late[0]['other']} at t = {late[0]['time']:.6g} s" if late else
           "crosses a static obstacle")
    return Completion(None, dist, False,
                      f"the shortest continuation to the goal point at max_speed {why}")
