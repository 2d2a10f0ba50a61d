"""Statuses of the waypoint NLP: IPOPT's return status, the certificate, the guard.

IPOPT ``Solve_Succeeded`` is a KKT point: locally optimal in the initial guess's homotopy
class, claimed ``optimal`` only when it lies in the homotopy class of the certified optimum
and that optimum confirms its length (:func:`certify`); acceptable level / iteration or time
limit / user stop -> ``solved``; anything else -> ``approximate`` (:func:`ipopt_claim`).  With
a caller's ``init``, the guard keeps the initial guess when the NLP path is infeasible or longer
(:func:`guard`).  The backend never decides feasibility: the shared validator grades every
claim.  Details in the :mod:`optplan.exact.nlp` module docstring.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from optplan.exact.nlp_solve import NLPOutcome
from optplan.geometry.collision import path_lengths, same_homotopy
from optplan.geometry.tangent import problem_shortest_path
from optplan.metrics import evaluate
from optplan.problem import Problem, Robot
from optplan.result import Status, confirms_optimum, optimum_gap

__all__ = ["certify", "ipopt_claim", "outcome_message", "guard", "combine_claims"]

_SUCCESS = {"Solve_Succeeded"}
_SOLVED = {
    "Solved_To_Acceptable_Level",
    "Maximum_Iterations_Exceeded",
    "Maximum_CpuTime_Exceeded",
    "Maximum_WallTime_Exceeded",
    "User_Requested_Stop",
    "Search_Direction_Becomes_Too_Small",
    "Feasible_Point_Found",
}
#: worst first: the claim of a multi-robot result is its robots' worst.
_ORDER = [Status.failed, Status.infeasible, Status.approximate, Status.solved, Status.optimal]


def certify(problem: Problem, robot: Robot, path: np.ndarray,
            known_only: bool) -> tuple[Status, str, float | None]:
    """``optimal`` when the KKT path is in the certified optimum's homotopy class and the
    optimum confirms its length (:func:`~optplan.result.confirms_optimum`), else ``solved``
    with "locally optimal", the gap and the reason; and the optimum (``None``: none)."""
    ref = problem_shortest_path(problem, robot, known_only)  # cached: the visgraph init
    if ref.polyline is None or not ref.info.get("certified"):
        return Status.solved, "locally optimal (KKT); no certified optimum to compare", None
    length, opt = float(path_lengths(path)), ref.length
    same = same_homotopy(path, ref.polyline, problem.obstacle_set(robot.radius, known_only))
    if same and confirms_optimum(length, opt):
        return Status.optimal, "", opt
    why = ("another homotopy class than the certified optimum" if not same else
           "in the optimum's homotopy class (chords and the safety clearance keep it above)")
    return Status.solved, (f"locally optimal (KKT): {100 * optimum_gap(length, opt):.2g} % "
                           f"above the certified optimum {opt:.6g}, {why}"), opt


def ipopt_claim(problem: Problem, robot: Robot, out: NLPOutcome, known_only: bool,
                info: dict[str, Any]) -> Status:
    """The claim of IPOPT's result ``out``: certified (:func:`certify`) when IPOPT succeeded
    (the optimum, its gap and the certificate's note go into ``info``), ``solved`` for the
    acceptable endings, else ``approximate``."""
    if out.success and out.return_status in _SUCCESS:
        claim, note, opt = certify(problem, robot, out.path, known_only)
        if opt is not None:
            info.update(optimum=opt, optimum_gap=optimum_gap(out.length, opt))
        if note:
            info["certificate"] = note
        return claim
    if out.return_status in _SOLVED:
        return Status.solved
    return Status.approximate


def outcome_message(robot: Robot, out: NLPOutcome, info: dict[str, Any]) -> str:
    """``"<robot>: IPOPT <status> after <n> iterations[ in <k> rounds][; certificate]"``."""
    msg = f"{robot.id}: IPOPT {out.return_status} after {out.iterations} iterations"
    if out.rounds > 1:
        msg += f" in {out.rounds} rounds"
    if "certificate" in info:
        msg += "; " + info["certificate"]
    return msg


def guard(view: Problem, robot: Robot, path: np.ndarray, guess: np.ndarray, claim: Status,
          msg: str, source: str, info: dict[str, Any]) -> tuple[np.ndarray, Status, str]:
    """The initial guess instead of the NLP ``path`` when the guess is validator-feasible and
    the NLP path is not, or is longer (then ``solved``, a note in the message and
    ``info["kept_init"]``); else ``(path, claim, msg)`` unchanged."""
    m_new = evaluate(view, {robot.id: path})
    m_old = evaluate(view, {robot.id: guess})
    ok_new = m_new["feasible"] and m_new["reached"]
    ok_old = m_old["feasible"] and m_old["reached"]
    l_new, l_old = m_new["length"], m_old["length"]
    if ok_old and (not ok_new or l_new > l_old * (1 + 1e-12)):
        why = "infeasible" if not ok_new else f"longer ({l_new:.6f} > {l_old:.6f})"
        info["kept_init"] = True
        return guess, Status.solved, msg + f"; NLP path {why}: kept the initial guess ({source})"
    return path, claim, msg


def combine_claims(claims: list[Status], stopped: bool) -> Status:
    """The worst of the robots' claims (``failed`` for none); never ``optimal`` after a stop."""
    claim = min(claims, key=_ORDER.index) if claims else Status.failed
    if stopped and claim is Status.optimal:
        claim = Status.solved
    return claim
