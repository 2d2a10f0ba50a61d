"""The Clarabel adapter of the formation QP: cones, settings, the resident solver, statuses.

Every native Clarabel status (``clarabel.SolverStatus``, Clarabel 0.11) has an explicit meaning
for optplan in :data:`STATUS`, in the manner of cvxpy's Clarabel interface
(``cvxpy/reductions/solvers/conic_solvers/clarabel_conif.py``, ``STATUS_MAP``):

* ``accepted``: a solution the formation QP uses (``Solved``, ``AlmostSolved``);
* ``certificate``: Clarabel proved the data infeasible (primal or dual, exactly or
  almost), so solving again cannot help;
* ``numerical``: the solver stopped without a solution or a certificate (iteration or time
  limit, numerical error, insufficient progress, not run, interrupted); without iterative
  refinement such a solve is repeated once with it (:meth:`ResidentSolver.solve`).

A status this map does not know (a newer Clarabel) counts as ``numerical``.  In every case other
than ``accepted`` the formation QP reports the native status string and, after its slack
fallback, stops the robots safely (:mod:`optplan.formation.formation_qp`).

This is a module of optplan (``optplan.formation.clarabel``); ``import clarabel`` below is the
solver package (absolute imports).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

__all__ = ["STATUS", "ACCEPTED", "CERTIFICATE", "NUMERICAL", "ERRORS", "meaning", "accepted",
           "ResidentSolver", "Run"]

ACCEPTED = "accepted"
CERTIFICATE = "certificate"
NUMERICAL = "numerical"

#: Every native Clarabel status -> its meaning for optplan (see the module doc).
STATUS: dict[str, str] = {
    "Solved": ACCEPTED,
    "AlmostSolved": ACCEPTED,
    "PrimalInfeasible": CERTIFICATE,
    "DualInfeasible": CERTIFICATE,
    "AlmostPrimalInfeasible": CERTIFICATE,
    "AlmostDualInfeasible": CERTIFICATE,
    "MaxIterations": NUMERICAL,
    "MaxTime": NUMERICAL,
    "NumericalError": NUMERICAL,
    "InsufficientProgress": NUMERICAL,
    "Unsolved": NUMERICAL,
    "CallbackTerminated": NUMERICAL,
}

#: Exceptions of a Clarabel build or solve treated as solver trouble (a safe stop, no raise).
ERRORS = (ValueError, RuntimeError, ArithmeticError)


def meaning(status: str) -> str:
    """The meaning of a native status string (``numerical`` when unknown)."""
    return STATUS.get(status, NUMERICAL)


def accepted(status: str) -> bool:
    """Whether the formation QP uses the solution of a solve with this status."""
    return meaning(status) == ACCEPTED


class Run(NamedTuple):
    """One solve: Clarabel's solution (None on a solver error), the status string (native, or
    ``"error: <exception>"``) and whether it was repeated with iterative refinement."""

    solution: Any
    status: str
    retried: bool


class ResidentSolver:
    """One ``clarabel.DefaultSolver`` kept between steps, updated in place.

    ``DefaultSolver.update`` (which needs ``presolve_enable`` and
    ``chordal_decomposition_enable`` off) is used while the caller's ``key`` (the kept rows) is
    that of the last build; otherwise a new solver is built.

    Parameters
    ----------
    P : scipy.sparse.csc_matrix
        The constant quadratic term (upper triangle).
    soc : list of int
        Sizes of the second-order cones (after the zero and non-negative cones).
    settings : dict
        ``clarabel.DefaultSettings`` attributes.
    """

    def __init__(self, P: Any, soc: list[int], settings: dict[str, Any]):
        self.P, self.soc, self.settings = P, list(soc), settings
        #: solves repeated with iterative refinement after a numerical stop without it
        self.retries = 0
        self._solver: Any = None
        self._key: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the resident solver (the next solve builds one)."""
        self._solver = None

    def solve(self, key: np.ndarray, q: np.ndarray, values: np.ndarray, b: np.ndarray,
              assemble: Any) -> Run:
        """Solve with linear term ``q``, the constraint matrix's values ``values`` (on the
        pattern of the resident solver) and right-hand side ``b``.

        ``assemble() -> (A, n_zero, n_nonneg)`` gives the CSC matrix and the cone sizes when a
        solver has to be built.  A ``numerical`` status without iterative refinement is solved
        once more, built afresh with it (the next call builds again); never raises on solver
        trouble.
        """
        try:
            if self._solver is not None and self._key is not None \
                    and np.array_equal(key, self._key):
                self._solver.update(q=q, A=values, b=b)
            else:
                self._build(key, q, b, assemble)
            sol = self._solver.solve()
        except ERRORS as e:
            return self._error(e)
        st = str(sol.status)
        if meaning(st) != NUMERICAL or self.settings.get("iterative_refinement_enable", True):
            return Run(sol, st, False)
        try:
            self._build(key, q, b, assemble, {"iterative_refinement_enable": True})
            sol = self._solver.solve()
        except ERRORS as e:
            return self._error(e)
        self.retries += 1
        self._solver = None
        return Run(sol, str(sol.status), True)

    def _error(self, e: BaseException) -> Run:
        self._solver = None
        return Run(None, f"error: {type(e).__name__}", False)

    def _build(self, key: np.ndarray, q: np.ndarray, b: np.ndarray, assemble: Any,
               extra: dict[str, Any] | None = None) -> None:
        import clarabel

        A, z, l = assemble()
        cones = ([clarabel.ZeroConeT(z)] if z else []) + (
            [clarabel.NonnegativeConeT(l)] if l else []) + [
            clarabel.SecondOrderConeT(k) for k in self.soc]
        st = clarabel.DefaultSettings()
        for k, v in {**self.settings, **(extra or {})}.items():
            setattr(st, k, v)
        self._solver = clarabel.DefaultSolver(self.P, q, A, b, cones, st)
        self._key = key
