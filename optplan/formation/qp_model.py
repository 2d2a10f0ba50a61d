r"""The formation QP's model: fixed layouts, per-step data and the cvxpy DPP model.

The QP itself (objective, CBF rows, bounds, speed cones) is stated in
:mod:`optplan.formation.formation_qp`.  The objective is expanded once: :math:`u^TQu + q^Tu`
with the constant :math:`Q = W + w_f\tau^2E^TE` (:math:`E` the formation-error Jacobian) and
the linear term :math:`q = -2Wu^{nom} + 2w_f\tau E^Tr`, so cvxpy passes :math:`Q` to Clarabel
as its quadratic term (no auxiliary variables or equality rows); the speed limits are
second-order cones on :math:`(v_{max,i}, u_i)` directly.  Every row family has a fixed shape
(a :class:`QPLayout`): rows that do not apply this step are padded (zero coefficients,
right-hand side :data:`BIG`).  All per-step numbers are one Parameter vector
(:meth:`QPData.theta`).  The model is DPP (``problem.is_dpp()`` is checked) and compiled once
per layout; it is solved through :class:`~optplan.formation.compiled_qp.CompiledQP`, the map
read off its compilation (:meth:`QPModel.solve`), and :meth:`QPModel.solve_cvxpy` is the
oracle that map is checked against.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from optplan.formation.compiled_qp import CompiledQP, QPSolution

__all__ = ["BIG", "QPData", "QPLayout", "QPModel", "QPSolution", "theta_size"]

#: Right-hand side of an inactive (all-zero) row.
BIG = 1e5
#: Clarabel statuses accepted as a solution (through cvxpy's pipeline, the oracle).
_OK = ("Solved", "AlmostSolved")


@dataclass(frozen=True, eq=False)
class QPLayout:
    """The fixed shapes of one QP model (a change rebuilds the model).

    Attributes
    ----------
    n : int
        Controlled robots.
    pairs : array ``(P, 2)`` of int
        Pattern of controlled pairs (rows padded / deactivated per step).
    K : int
        Obstacle rows per robot.
    n_ext : int
        Rows per controlled robot against external (known-velocity) robots.
    edges : array ``(F, 2)`` of int
        Formation edges ``(follower, leader)`` in controlled-robot indices; leader ``-1`` when
        it is external.
    weights : array ``(n,)``
        Weights :math:`w_i` of the nominal-velocity terms.
    vmax : array ``(n,)``
        Speed limits.
    """

    n: int
    pairs: np.ndarray
    K: int
    n_ext: int
    edges: np.ndarray
    weights: np.ndarray
    vmax: np.ndarray

    @property
    def P(self) -> int:
        return len(self.pairs)

    @property
    def F(self) -> int:
        return len(self.edges)

    @property
    def nK(self) -> int:
        return self.n * self.K

    @property
    def nE(self) -> int:
        return self.n * self.n_ext

    def jacobian(self) -> np.ndarray:
        """The formation-error Jacobian ``E`` ``(2F, 2n)``: ``E u = u_f - u_leader`` per edge."""
        E = np.zeros((2 * self.F, 2 * self.n))
        for k, (f, l) in enumerate(self.edges):
            E[2 * k: 2 * k + 2, 2 * f: 2 * f + 2] = np.eye(2)
            if l >= 0:
                E[2 * k: 2 * k + 2, 2 * l: 2 * l + 2] = -np.eye(2)
        return E


@dataclass
class QPData:
    """The numbers of one step, in the shapes of a :class:`QPLayout`.

    Rows: ``G u_i - G u_j <= bp`` (pairs), ``N u_i <= bo`` (obstacles, ``K`` per robot, robot
    ``k // K``), ``Ne u_i <= be`` (external robots, ``n_ext`` per robot), ``lo <= u <= hi``.
    An inactive row has zero coefficients and right-hand side :data:`BIG`.  Objective data:
    ``unom`` (nominal velocities) and ``r`` (formation error before the step, per edge).
    """

    unom: np.ndarray
    r: np.ndarray
    G: np.ndarray
    bp: np.ndarray
    N: np.ndarray
    bo: np.ndarray
    Ne: np.ndarray
    be: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def inactive(cls, layout: QPLayout) -> QPData:
        """Every row inactive, zero objective data, bounds at the speed limits."""
        n, v = layout.n, layout.vmax[:, None]
        return cls(unom=np.zeros((n, 2)), r=np.zeros((layout.F, 2)),
                   G=np.zeros((layout.P, 2)), bp=np.full(layout.P, BIG),
                   N=np.zeros((layout.nK, 2)), bo=np.full(layout.nK, BIG),
                   Ne=np.zeros((layout.nE, 2)), be=np.full(layout.nE, BIG),
                   lo=-np.repeat(v, 2, axis=1), hi=np.repeat(v, 2, axis=1))

    @property
    def active_pairs(self) -> int:
        return int(np.sum(self.bp < BIG))

    def theta(self, q: np.ndarray) -> np.ndarray:
        """The model's Parameter vector: ``q`` (the linear objective term), the bounds and the
        rows, each block flattened row-major (:data:`_THETA`)."""
        return np.concatenate([q, self.lo.ravel(), self.hi.ravel(), self.G.ravel(), self.bp,
                               self.N.ravel(), self.bo, self.Ne.ravel(), self.be])



class QPModel:
    """The cvxpy DPP model of one layout, solved by Clarabel.

    All per-step numbers enter through one Parameter vector :math:`\theta` (the linear
    objective term, the bounds and every row family, in the order of :meth:`QPData.theta`),
    so a step sets one Parameter value.

    Parameters
    ----------
    layout : QPLayout
    tau : float
        Time step.
    w_f, w_s : float
        Formation and slack weights.
    settings : dict
        Clarabel settings (``presolve_enable`` and ``chordal_decomposition_enable`` must be
        off for cvxpy to update the cached solver).
    soft : bool
        Obstacle rows with a slack (the fallback model) instead of hard.

    Raises
    ------
    CompileError
        When the map of cvxpy's compilation cannot be read off or verified
        (:meth:`CompiledQP.learn`).
    """

    def __init__(self, layout: QPLayout, tau: float, w_f: float, w_s: float,
                 settings: dict[str, Any], soft: bool = False):
        import cvxpy as cp

        self.layout, self.tau, self.w_f, self.settings, self.soft = layout, tau, w_f, settings, \
            soft
        L = layout
        n = L.n
        self._E = L.jacobian()
        self._W2 = np.repeat(L.weights, 2)
        Q = np.diag(self._W2) + w_f * tau**2 * (self._E.T @ self._E)
        self.theta = cp.Parameter(theta_size(L))
        part = _theta_parts(L, self.theta)
        self.u = cp.Variable(2 * n)  # (u_0x, u_0y, u_1x, ...): quad_form on the variable itself
        self.U = cp.reshape(self.u, (n, 2), order="C")
        obj = cp.quad_form(self.u, cp.psd_wrap(Q)) + part["q"] @ self.u
        cons = [self.U >= part["lo"], self.U <= part["hi"], cp.SOC(L.vmax, self.U, axis=1)]
        self.S = None
        if L.P:
            I, J = L.pairs[:, 0], L.pairs[:, 1]
            cons.append(cp.sum(cp.multiply(part["G"], self.U[I, :] - self.U[J, :]), axis=1)
                        <= part["bp"])
        if L.nK:
            rep = np.repeat(np.arange(n), L.K)
            lhs = cp.sum(cp.multiply(part["N"], self.U[rep, :]), axis=1)
            if soft:
                self.S = cp.Variable(L.nK, nonneg=True)
                cons.append(lhs <= part["bo"] + self.S)
                obj = obj + w_s * cp.sum(self.S)
            else:
                cons.append(lhs <= part["bo"])
        if L.nE:
            rep = np.repeat(np.arange(n), L.n_ext)
            cons.append(cp.sum(cp.multiply(part["Ne"], self.U[rep, :]), axis=1) <= part["be"])
        self.problem = cp.Problem(cp.Minimize(obj), cons)
        if not self.problem.is_dpp():
            raise RuntimeError("the formation QP must be DPP (a modelling error in optplan)")
        self._solver = cp.CLARABEL
        #: The per-step map, the one run-time path (:class:`CompileError` when not verified).
        self.compiled: CompiledQP = CompiledQP.learn(self)

    def linear_term(self, data: QPData) -> np.ndarray:
        """:math:`q = -2Wu^{nom} + 2w_f\tau E^Tr` (the objective's only per-step data)."""
        q = -2.0 * self._W2 * data.unom.ravel()
        if self.layout.F:
            q += 2.0 * self.w_f * self.tau * (self._E.T @ data.r.ravel())
        return q

    def solve(self, data: QPData) -> QPSolution:
        """Set the Parameter from ``data`` and solve through the :class:`CompiledQP` map (never
        raises on solver trouble)."""
        return self.compiled.solve(data.theta(self.linear_term(data)), self.soft)

    def solve_cvxpy(self, theta: np.ndarray, settings: dict[str, Any] | None = None
                    ) -> tuple[QPSolution, np.ndarray | None]:
        """The oracle: cvxpy's documented re-solve pipeline, ``get_problem_data`` (the cached DPP
        compilation applies the Parameter), ``SolvingChain.solve_via_data`` (cvxpy updates its
        cached Clarabel solver) and ``unpack_results``.  Returns the solution and Clarabel's
        raw ``x``.  Statuses are Clarabel's; ``settings`` (default: the model's) are Clarabel's
        settings for this solve.  Not a run-time path: the map is checked against
        it when it is learned, and the tests compare the two on random instances."""
        from cvxpy.error import SolverError

        opts = self.settings if settings is None else settings
        self.theta.value = theta
        p = self.problem
        try:
            pdata, chain, inverse = p.get_problem_data(self._solver, solver_opts=opts)
            raw = chain.solve_via_data(p, pdata, warm_start=True, verbose=False,
                                       solver_opts=opts)
            with warnings.catch_warnings():  # "may be inaccurate": the status says it
                warnings.simplefilter("ignore", UserWarning)
                p.unpack_results(raw, chain, inverse)
        except (SolverError, ValueError, ArithmeticError) as e:
            return QPSolution(None, f"error: {type(e).__name__}", math.nan, self.soft), None
        st = str(raw.status)
        if st not in _OK or self.u.value is None:
            return QPSolution(None, st, math.nan, self.soft), None
        slack = 0.0
        if self.S is not None:
            s = self.S.value  # cvxpy types Variable.value as optional
            assert s is not None, "a solved status (checked above) sets every Variable's value"
            slack = max(float(s.max()), 0.0)
        U = np.asarray(self.u.value).reshape(-1, 2)
        return (QPSolution(U, st, slack, self.soft, objective=float(raw.obj_val)),
                np.asarray(raw.x, float))

    def compiled_data(self, theta: np.ndarray) -> dict[str, Any]:
        """cvxpy's compiled Clarabel data (``P``, ``c``, ``A``, ``b``, ``dims``) at ``theta``."""
        self.theta.value = theta
        return self.problem.get_problem_data(self._solver, solver_opts=self.settings)[0]

    def feasible_theta(self, rng: np.random.Generator) -> np.ndarray:
        """A Parameter vector of random data at which ``u = 0`` is feasible (for checks)."""
        L = self.layout
        d = QPData.inactive(L)
        d.unom = rng.normal(size=d.unom.shape) * L.vmax[:, None]
        d.r = rng.normal(size=d.r.shape)
        d.G, d.bp = rng.normal(size=d.G.shape), rng.uniform(0.1, 1.0, L.P)
        d.N, d.bo = rng.normal(size=d.N.shape), rng.uniform(0.1, 1.0, L.nK)
        d.Ne, d.be = rng.normal(size=d.Ne.shape), rng.uniform(0.1, 1.0, L.nE)
        return d.theta(self.linear_term(d))



#: The blocks of the Parameter vector, in order: name -> (size function, shape function).
_THETA = (("q", lambda L: (2 * L.n,)), ("lo", lambda L: (L.n, 2)), ("hi", lambda L: (L.n, 2)),
          ("G", lambda L: (L.P, 2)), ("bp", lambda L: (L.P,)), ("N", lambda L: (L.nK, 2)),
          ("bo", lambda L: (L.nK,)), ("Ne", lambda L: (L.nE, 2)), ("be", lambda L: (L.nE,)))


def theta_size(layout: QPLayout) -> int:
    """Length of the Parameter vector of a layout."""
    return int(sum(np.prod(shape(layout)) for _, shape in _THETA))


def _theta_parts(layout: QPLayout, theta: Any) -> dict[str, Any]:
    """The blocks of the Parameter vector as cvxpy expressions of their shapes (row-major)."""
    import cvxpy as cp

    out, k = {}, 0
    for name, shape in _THETA:
        sh = shape(layout)
        m = int(np.prod(sh))
        block = theta[k: k + m]
        out[name] = cp.reshape(block, sh, order="C") if len(sh) == 2 else block
        k += m
    return out

