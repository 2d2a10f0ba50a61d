r"""Exact formation keeping: one convex QP per control step with CBF safety rows.

Model (single integrators :math:`x_i^+ = x_i + \tau u_i`, :math:`\tau` = ``dt``)
-------------------------------------------------------------------------------
Controlled robots :math:`i` (the followers, and the leader when ``leader_in_qp``) choose
velocities :math:`u_i`; robots outside the QP (the leader when a hybrid planner drives it) move
with known velocities :math:`u_j`.

.. math::

   \min_{u}\ \sum_i w_i\|u_i - u_i^{nom}\|^2
     + w_f\sum_{f}\|x_f + \tau u_f - (x_L + \tau u_L) - o_f(\theta_L)\|^2

subject to, for every pair of robots closer than ``neighbor_radius`` (with
:math:`d = x_i - x_j`, :math:`h = \|d\|^2 - D_s^2`, :math:`D_s` the formation's
``safety_distance``),

.. math:: -d^T u_i + d^T u_j \le \tfrac{\gamma}{2} h,

for every robot and each of its ``max_obstacles`` nearest sensed obstacles (nearest boundary point
:math:`c`, distance :math:`\delta`, unit normal :math:`n = (x_i - c)/\delta`, obstacle velocity
:math:`v_o`, :math:`h_o = \delta - r_i - m`)

.. math:: -n^T u_i \le \gamma h_o - n^T v_o,

position bounds :math:`x_i + \tau u_i \in [\ell + r_i, \mathrm{hi} - r_i]` (relaxed to
"do not move further out" when already outside), and :math:`\|u_i\| \le v_{max,i}`.  The
formation offsets :math:`o_f` are the L-phi slots (:mod:`optplan.formation.leader_follower`), with
the eq 52 angle adaptation when ``adapt_phi``.  :math:`u^{nom}` is the pilot's command for the
leader (weight ``w_leader``) and the leader's command (feed-forward) for each follower (weight 1).

Obstacle rows are hard.  When they have no common point with the other rows (a robot already
inside its margin, or a moving obstacle closing faster than the rows allow) the step is solved
again with a slack :math:`s_k \ge 0` on every obstacle row and the exact penalty
:math:`w_s\sum_k s_k` in the objective (the *slack fallback*, counted in
``stats["slack_steps"]``, its largest slack in ``stats["max_slack"]``, per step in the history
column ``qp_slack``).

Discrete-time exactness (derived).  With :math:`\gamma\tau \le 1` the pair rows are *sufficient*
for :math:`h^+ \ge (1-\gamma\tau)h`: :math:`h^+ = h + 2\tau d^T\Delta u + \tau^2\|\Delta u\|^2`
and the dropped term is non-negative.  So a pair that is safe now is safe after the step whenever
the QP's solution is applied, for any step length.  For a convex obstacle the half-plane
:math:`n^T(y - c) \le 0` contains the obstacle, so the obstacle row likewise keeps clearance
:math:`\ge r_i + m` (up to the reported slack).  ``neighbor_radius`` is raised to at least
:math:`D_s + 2\tau v_{max}` so no unconstrained pair can close the gap in one step.

Implementation (one implementation: a cvxpy DPP model solved by Clarabel)
------------------------------------------------------------------------
The objective is expanded once: :math:`u^TQu + q^Tu` with the constant
:math:`Q = W + w_f\tau^2E^TE` (:math:`E` the formation-error Jacobian) and the linear term
:math:`q = -2Wu^{nom} + 2w_f\tau E^Tr`, so cvxpy passes :math:`Q` to Clarabel as its quadratic
term (no auxiliary variables or equality rows); the speed limits are second-order cones on
:math:`(v_{max,i}, u_i)` directly.  Every row family has a fixed shape (a :class:`QPLayout`):
pair rows on a pattern of the pairs within ``1.5 * neighbor_radius``, ``max_obstacles`` rows per
robot, one row per robot and external robot; rows that do not apply this step are padded (zero
coefficients, right-hand side ``BIG``).  All per-step numbers are one Parameter vector
(:meth:`QPData.theta`).  The model is DPP (``problem.is_dpp()`` is checked) and compiled once per
layout.

Per step, cvxpy is out of the loop (:class:`CompiledQP`): a DPP problem's compiled solver data
is affine in its Parameters, and that map is read off cvxpy's compilation
(``Problem.get_problem_data``, documented as enough to call the solver directly) when the model
is built, verified against a further compilation and against cvxpy's own re-solve.  A step
evaluates the map, drops the inequality rows the speed cones already imply
(:math:`\sum_i\|a_i\|v_{max,i} \le b`: the padded rows, far pairs, walls out of reach; the
feasible set and the solution are unchanged) and gives the rest to Clarabel, updated in place with
``DefaultSolver.update`` (``presolve_enable`` and ``chordal_decomposition_enable`` off) while the
kept rows stay the same.  If the map cannot be read off or verified, every step goes through
cvxpy's documented re-solve pipeline instead (``get_problem_data`` on the cached compilation ->
``SolvingChain.solve_via_data(warm_start=True)`` -> ``unpack_results``;
:meth:`QPModel.solve_cvxpy`), the same model and the same solution, only slower.

Units: the QP is posed in units of the scene's ``length_scale`` (positions, radii, speeds, the
safety distance, the obstacle data and the bounds divided by it, the solution multiplied back);
``margin``, ``neighbor_radius`` and ``sensing_range`` are multiples of it.  Its numbers,
Clarabel's tolerances and the solution therefore do not depend on the unit the scene is drawn in.
Clarabel runs without iterative refinement (:func:`qp_settings`); a solve that ends with a
numerical status is repeated once with it (``stats["qp_retries"]``).

A new pair inside ``neighbor_radius`` outside the pattern, or a change of the controlled robots,
rebuilds the model (``stats["rebuilds"]``).  A Clarabel status other than ``Solved`` /
``AlmostSolved`` after the fallback, or a solver error, gives a safe stop (all controlled robots
hold still), counted in ``stats["qp_failures"]``; nothing is raised.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp

from optplan.formation.leader_follower import (
    PilotedFormation,
    adapted_angle,
    run_formation,
    slot_positions,
)
from optplan.interfaces import FormationBackend
from optplan.problem import Problem
from optplan.result import Result
from optplan.sim import SimState
from optplan.solver import make_rng, option

__all__ = ["FormationQP", "QPData", "QPLayout", "QPModel", "QPSolver", "QPSolution",
           "QPStepRecord", "QPFormationController", "qp_summary"]

#: Right-hand side of an inactive (all-zero) row.
BIG = 1e5
#: Clarabel statuses accepted as a solution.
_OK = ("Solved", "AlmostSolved")


# --------------------------------------------------------------------------------------
# the QP: fixed layout, per-step data, the cvxpy model
# --------------------------------------------------------------------------------------


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


@dataclass
class QPSolution:
    """What one solve returned: ``U`` ``(n, 2)`` or ``None``, the status, the largest slack
    (0 unless the slack fallback was used), whether it was, whether the solve was repeated
    with iterative refinement (:func:`qp_settings`) and Clarabel's iteration count (-1: not
    known, the cvxpy pipeline)."""

    U: np.ndarray | None
    status: str
    slack: float = 0.0
    fallback: bool = False
    retried: bool = False
    iterations: int = -1


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
    """

    def __init__(self, layout: QPLayout, tau: float, w_f: float, w_s: float,
                 settings: dict[str, Any], soft: bool = False, fast: bool = True):
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
        #: The per-step map (None: every step goes through cvxpy's pipeline).
        self.compiled: CompiledQP | None = CompiledQP.learn(self) if fast else None

    def linear_term(self, data: QPData) -> np.ndarray:
        """:math:`q = -2Wu^{nom} + 2w_f\tau E^Tr` (the objective's only per-step data)."""
        q = -2.0 * self._W2 * data.unom.ravel()
        if self.layout.F:
            q += 2.0 * self.w_f * self.tau * (self._E.T @ data.r.ravel())
        return q

    def solve(self, data: QPData) -> QPSolution:
        """Set the Parameter from ``data`` and re-solve (never raises on solver trouble).

        Through the :class:`CompiledQP` map when it could be read off cvxpy's compiled data
        (:attr:`compiled`), else through cvxpy's re-solve pipeline (:meth:`solve_cvxpy`).
        """
        theta = data.theta(self.linear_term(data))
        if self.compiled is not None:
            return self.compiled.solve(theta, self.soft)
        return self.solve_cvxpy(theta)[0]

    def solve_cvxpy(self, theta: np.ndarray) -> tuple[QPSolution, np.ndarray | None]:
        """cvxpy's documented re-solve pipeline: ``get_problem_data`` (the cached DPP
        compilation applies the Parameter), ``SolvingChain.solve_via_data`` (cvxpy updates its
        cached Clarabel solver) and ``unpack_results``.  Returns the solution and Clarabel's
        raw ``x``.  Statuses are Clarabel's."""
        from cvxpy.error import SolverError

        self.theta.value = theta
        p = self.problem
        try:
            pdata, chain, inverse = p.get_problem_data(self._solver, solver_opts=self.settings)
            raw = chain.solve_via_data(p, pdata, warm_start=True, verbose=False,
                                       solver_opts=self.settings)
            with warnings.catch_warnings():  # "may be inaccurate": the status says it
                warnings.simplefilter("ignore", UserWarning)
                p.unpack_results(raw, chain, inverse)
        except (SolverError, ValueError, ArithmeticError) as e:
            return QPSolution(None, f"error: {type(e).__name__}", math.nan, self.soft), None
        st = str(raw.status)
        if st not in _OK or self.u.value is None:
            return QPSolution(None, st, math.nan, self.soft), None
        slack = max(float(self.S.value.max()), 0.0) if self.S is not None else 0.0
        U = np.asarray(self.u.value).reshape(-1, 2)
        return QPSolution(U, st, slack, self.soft), np.asarray(raw.x, float)

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


class CompiledQP:
    """The per-step solve with cvxpy out of the loop: cvxpy's compiled data as an affine map.

    A DPP problem's compiled solver data is an affine function of its Parameters (that is what
    cvxpy caches).  :meth:`learn` reads that map off :meth:`QPModel.compiled_data` at
    :math:`\\theta = 0` and three random Parameter vectors, assuming that every entry of the
    data (``c``, ``A``, ``b``) depends on at most one Parameter entry (true for this model), and
    accepts it only when it predicts the fourth compilation exactly and its Clarabel solve
    agrees with cvxpy's own pipeline (:meth:`QPModel.solve_cvxpy`); otherwise the model keeps
    the pipeline.

    Each step evaluates the map (``c0 + c1 * theta[j]``), drops the inequality rows that the
    speed cones already imply (:math:`a^Tu \\le b` with
    :math:`\\sum_i \\|a_i\\|\\,v_{max,i} \\le b`: every padded row, far pairs, walls out of
    reach; the feasible set is unchanged, so is the solution) and hands the rest to Clarabel:
    ``DefaultSolver.update`` when the kept rows are those of the last step, else a new
    ``DefaultSolver`` (counted in :attr:`builds`).
    """

    def __init__(self, P: Any, cones: dict[str, Any], pattern: tuple[np.ndarray, np.ndarray],
                 affine: tuple[np.ndarray, np.ndarray, np.ndarray], sizes: tuple[int, int, int],
                 u_off: int, vmax: np.ndarray, settings: dict[str, Any]):
        self.P, self.cones, self.settings = P, cones, settings
        self.rows, self.cols = pattern
        self.c0, self.c1, self.j = affine
        self.nx, self.nnz, self.m = sizes
        self.n, self.u_off = len(vmax), u_off
        self.builds = 0
        #: solves repeated with iterative refinement after a numerical failure without it
        self.retries = 0
        n, rows, cols = self.n, self.rows, self.cols
        is_u = (cols >= u_off) & (cols < u_off + 2 * n)
        self._droppable = np.zeros(self.m, bool)
        self._droppable[cones["zero"]: cones["zero"] + cones["nonneg"]] = True
        self._droppable &= np.bincount(rows[~is_u], minlength=self.m) == 0
        grp, self._gid = np.unique(rows * n + np.where(is_u, (cols - u_off) // 2, 0),
                                   return_inverse=True)
        self._g_row, self._g_vmax = grp // n, np.asarray(vmax, float)[grp % n]
        self._other = np.r_[0:u_off, u_off + 2 * n: self.nx].astype(np.int64)
        self._keep: np.ndarray | None = None
        self._solver: Any = None

    # -- reading the map off cvxpy ----------------------------------------------------------
    @classmethod
    def learn(cls, model: QPModel) -> CompiledQP | None:
        """The map of ``model``'s compilation, or None when it cannot be read off and verified."""
        rng = np.random.default_rng(20240601)
        m = theta_size(model.layout)
        probes = [np.zeros(m)] + [rng.uniform(1.0, 2.0, m) * rng.choice([-1.0, 1.0], m)
                                  for _ in range(3)]
        data = [model.compiled_data(t) for t in probes]
        dims = data[1]["dims"]
        if dims.exp or dims.psd or getattr(dims, "p3d", None) or getattr(dims, "pnd", None):
            return None
        A1 = sp.csc_matrix(data[1]["A"])
        A1.sort_indices()
        pattern = (A1.indices.astype(np.int64),
                   np.repeat(np.arange(A1.shape[1]), np.diff(A1.indptr)))
        v = [_flat(d, pattern) for d in data]
        P = sp.triu(sp.csc_matrix(data[1]["P"])).tocsc()
        if any(x is None for x in v) or any(
                abs(sp.triu(sp.csc_matrix(d["P"])) - P).sum() > 0 for d in data):
            return None  # an entry off the pattern, or a quadratic term that varies
        affine = _affine_fit(probes, v)
        if affine is None:
            return None
        sizes = (len(data[1]["c"]), len(pattern[0]), A1.shape[0])
        cones = {"zero": dims.zero, "nonneg": dims.nonneg, "soc": list(dims.soc)}
        theta = model.feasible_theta(rng)
        ref, x = model.solve_cvxpy(theta)
        u_off = _offset(x, ref.U)
        if u_off is None:
            return None
        out = cls(P, cones, pattern, affine, sizes, u_off, model.layout.vmax, model.settings)
        got = out.solve(theta, model.soft)
        scale = 1e-5 * (1.0 + float(np.abs(ref.U).max()))
        if got.U is None or not np.allclose(got.U, ref.U, atol=scale):
            return None
        return out

    # -- one step ----------------------------------------------------------------------------
    def rows_needed(self, Av: np.ndarray, b: np.ndarray) -> np.ndarray:
        """False for the inequality rows the speed cones imply."""
        g = np.bincount(self._gid, weights=Av * Av, minlength=len(self._g_row))
        bound = np.bincount(self._g_row, weights=np.sqrt(g) * self._g_vmax, minlength=self.m)
        return ~(self._droppable & (bound <= b + 1e-12 * (1.0 + np.abs(b))))

    def solve(self, theta: np.ndarray, soft: bool = False) -> QPSolution:
        vals = self.c0 + self.c1 * np.append(theta, 0.0)[self.j]
        q, Av, b = vals[: self.nx], vals[self.nx: self.nx + self.nnz], vals[self.nx + self.nnz:]
        keep = self.rows_needed(Av, b)
        ent = keep[self.rows]
        try:
            if self._solver is not None and np.array_equal(keep, self._keep):
                self._solver.update(q=q, A=Av[ent], b=b[keep])
            else:
                self._build(q, Av, b, keep, ent)
            sol = self._solver.solve()
        except (ValueError, RuntimeError, ArithmeticError) as e:  # solver trouble: safe stop
            self._solver = None
            return QPSolution(None, f"error: {type(e).__name__}", math.nan, soft)
        st = str(sol.status)
        retried = False
        if st not in _OK and "Infeasible" not in st and not self.settings.get(
                "iterative_refinement_enable", True):
            # numerical trouble without iterative refinement: the same data once more with it
            # (counted in ``retries``); the next step builds the solver afresh
            try:
                self._build(q, Av, b, keep, ent, {"iterative_refinement_enable": True})
                sol = self._solver.solve()
            except (ValueError, RuntimeError, ArithmeticError) as e:
                self._solver = None
                return QPSolution(None, f"error: {type(e).__name__}", math.nan, soft)
            self.retries += 1
            self._solver = None
            st, retried = str(sol.status), True
        if st not in _OK:
            return QPSolution(None, st, math.nan, soft, retried=retried)
        x = np.asarray(sol.x, float)
        U = x[self.u_off: self.u_off + 2 * self.n].reshape(-1, 2)
        slack = max(float(x[self._other].max()), 0.0) if soft and len(self._other) else 0.0
        return QPSolution(U, st, slack, soft, retried=retried, iterations=int(sol.iterations))

    def _build(self, q: np.ndarray, Av: np.ndarray, b: np.ndarray, keep: np.ndarray,
               ent: np.ndarray, extra: dict[str, Any] | None = None) -> None:
        import clarabel

        rows = (np.cumsum(keep) - 1)[self.rows[ent]]
        indptr = np.r_[0, np.cumsum(np.bincount(self.cols[ent], minlength=self.nx))]
        A = sp.csc_matrix((Av[ent], rows, indptr), shape=(int(keep.sum()), self.nx))
        z, l = self.cones["zero"], int(keep[self.cones["zero"]: self.cones["zero"]
                                            + self.cones["nonneg"]].sum())
        cones = ([clarabel.ZeroConeT(z)] if z else []) + (
            [clarabel.NonnegativeConeT(l)] if l else []) + [
            clarabel.SecondOrderConeT(k) for k in self.cones["soc"]]
        st = clarabel.DefaultSettings()
        for k, v in {**self.settings, **(extra or {})}.items():
            setattr(st, k, v)
        self._solver = clarabel.DefaultSolver(self.P, q, A, b[keep], cones, st)
        self._keep = keep
        self.builds += 1


def _flat(d: dict[str, Any], pattern: tuple[np.ndarray, np.ndarray]) -> np.ndarray | None:
    """``c``, the values of ``A`` on the pattern and ``b`` as one vector (None when ``A`` has
    an entry off the pattern)."""
    A = sp.csr_matrix(d["A"])
    at = np.asarray(A[pattern[0], pattern[1]]).ravel()
    if not np.isclose(abs(A).sum(), np.abs(at).sum(), rtol=1e-12, atol=0.0):
        return None
    return np.concatenate([np.asarray(d["c"], float).ravel(), at,
                           np.asarray(d["b"], float).ravel()])


def _affine_fit(probes: list[np.ndarray], v: list[np.ndarray]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(c0, c1, j)`` with ``v = c0 + c1 * theta[j]`` (``j = len(theta)``: constant) from the
    probes ``theta = 0, t1, t2`` (identifying ``j`` by the ratio ``t1[j] / t2[j]``), checked on
    ``t3``; None when the data is not of that form."""
    m = len(probes[0])
    v0, v1, v2, v3 = v
    scale = 1e-10 * (1.0 + max(float(np.abs(x).max()) for x in v))
    d1, d2 = v1 - v0, v2 - v0
    varies = (np.abs(d1) > scale) | (np.abs(d2) > scale)
    ratio = probes[1] / probes[2]
    order = np.argsort(ratio)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = d1[varies] / d2[varies]
    pos = np.clip(np.searchsorted(ratio[order], r), 1, max(m - 1, 1))
    cand = np.stack([order[pos - 1], order[np.minimum(pos, m - 1)]])
    best = cand[np.argmin(np.abs(ratio[cand] - r), axis=0), np.arange(len(r))]
    j = np.full(len(v0), m, np.int64)
    j[varies] = best
    c1 = np.zeros(len(v0))
    c1[varies] = d1[varies] / probes[1][best]
    if not np.allclose(v0 + c1 * np.append(probes[3], 0.0)[j], v3, rtol=1e-9, atol=scale):
        return None
    return v0, c1, j


def _offset(x: np.ndarray | None, U: np.ndarray | None) -> int | None:
    """Where the robots' velocities sit in Clarabel's ``x``."""
    if x is None or U is None:
        return None
    u = U.ravel()
    tol = 1e-9 * (1.0 + float(np.abs(u).max()))
    hits = [o for o in range(len(x) - len(u) + 1) if np.allclose(x[o: o + len(u)], u, atol=tol)]
    return hits[0] if len(hits) == 1 else None


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


class QPSolver:
    """The hard model of a layout, and its slack fallback (built on first use)."""

    def __init__(self, layout: QPLayout, tau: float, w_f: float, w_s: float,
                 settings: dict[str, Any]):
        self.layout = layout
        self._args = (tau, w_f, w_s, settings)
        self.hard = QPModel(layout, *self._args)
        self.soft: QPModel | None = None

    def solve(self, data: QPData) -> QPSolution:
        sol = self.hard.solve(data)
        if sol.U is None and self.layout.nK and np.any(data.bo < BIG):
            if self.soft is None:
                self.soft = QPModel(self.layout, *self._args, soft=True)
            retried = sol.retried
            sol = self.soft.solve(data)
            sol.retried = sol.retried or retried
        return sol


# --------------------------------------------------------------------------------------
# the controller: one builder per row family into one QPData
# --------------------------------------------------------------------------------------


@dataclass
class _Step:
    """Who is controlled this step and what is known about the others."""

    ctrl: list[int]  # state indices of the controlled robots
    lead: int  # state index of the leader
    ext: list[int]  # state indices of robots with known velocities
    u_ext: dict[int, np.ndarray]  # their velocities
    u_lead: np.ndarray  # the leader's command (feed-forward of the followers)
    heading: float  # the formation frame
    u_lead_nom: np.ndarray | None  # the pilot's command when the leader is controlled


@dataclass
class _Geometry:
    """Positions and sizes of the controlled robots at this step."""

    dt: float
    X: np.ndarray  # every robot
    xc: np.ndarray  # controlled robots
    radii: np.ndarray
    vmax: np.ndarray
    R_nb: float  # neighbour radius used this step
    Ds: float
    li: int | None  # controlled index of the leader, None when external
    edges: np.ndarray  # (F, 2)
    near: np.ndarray | None = None  # sensed nearest obstacle points (n, n_obs, 2)
    dist: np.ndarray | None = None  # and distances (n, n_obs)
    xc_map: np.ndarray | None = None  # the controlled robots in map units (sensing)


@dataclass
class QPStepRecord:
    """The QP's own history columns for the step just taken."""

    status: str
    ok: bool
    time: float
    solve_time: float
    slack: float
    pairs: int
    fallback: bool
    iterations: int = -1

    def columns(self) -> dict[str, Any]:
        return {"qp_status": self.status, "qp_ok": self.ok, "qp_time": self.time,
                "qp_solve_time": self.solve_time, "qp_slack": self.slack,
                "qp_pairs": self.pairs, "qp_fallback": self.fallback,
                "qp_iterations": self.iterations}


class QPFormationController:
    """Per-step data assembly around :class:`QPSolver`
    (a :class:`~optplan.interfaces.FollowerController`).

    Attributes
    ----------
    stats : dict
        ``qp_solves``, ``qp_failures`` (safe stops), ``slack_steps`` (steps solved by the slack
        fallback), ``max_slack``, ``rebuilds``, ``solve_times`` (s, whole step),
        ``statuses`` (count per Clarabel status), ``compiled`` (the current model is solved
        through :class:`CompiledQP`, else through cvxpy's pipeline).
    last : QPStepRecord or None
        The record of the last step (the QP's history columns).
    """

    def __init__(self, problem: Problem, opts: FormationQP):
        if problem.formation is None:
            raise ValueError(f"problem {problem.name!r} has no [formation]")
        self.problem, self.o = problem, opts
        #: the QP's length unit (problem.length_scale): lengths are divided by it
        self.ell = float(problem.length_scale)
        self.form = problem.formation
        self.spec = {f.id: f for f in self.form.followers}
        self.solver: QPSolver | None = None
        self._key: tuple | None = None
        self._in_pattern = np.zeros(0, bool)  # per pair of np.triu_indices(n, 1)
        self._robots = {r.id: r for r in problem.robots}
        self._team_key: tuple | None = None
        self._team: tuple = ()
        self.last: QPStepRecord | None = None
        self.stats: dict[str, Any] = {"qp_failures": 0, "qp_solves": 0, "rebuilds": 0,
                                      "qp_retries": 0,
                                      "slack_steps": 0, "max_slack": 0.0, "solve_times": [],
                                      "statuses": {}, "compiled": False}
        self._settings = qp_settings(opts)

    # -- FollowerController: the leader is external (driven by someone else) ----------------
    def velocities(self, state: SimState, leader_index: int, follower_indices: list[int],
                   leader_heading: float) -> np.ndarray:
        ul = state.leader_command(leader_index)
        return self.step(state, _Step(list(follower_indices), leader_index, [leader_index],
                                      {leader_index: ul}, ul, leader_heading, None))

    def joint(self, state: SimState, u_lead_nom: np.ndarray, heading: float) -> np.ndarray:
        """Every robot in the QP, the leader's nominal command from its pilot."""
        ctrl = list(range(len(state.ids)))
        return self.step(state, _Step(ctrl, 0, [], {}, u_lead_nom, heading, u_lead_nom))

    # -- one step -------------------------------------------------------------------------
    def step(self, state: SimState, s: _Step) -> np.ndarray:
        """Velocities of the controlled robots ``s.ctrl`` (state indices), map units.

        The QP is assembled and solved in units of ``length_scale`` (:attr:`ell`)."""
        t0 = time.perf_counter()
        e = self.ell
        s = dataclasses.replace(
            s, u_ext={j: np.asarray(u, float) / e for j, u in s.u_ext.items()},
            u_lead=np.asarray(s.u_lead, float) / e,
            u_lead_nom=None if s.u_lead_nom is None else np.asarray(s.u_lead_nom, float) / e)
        geo = self._geometry(state, s)
        solver = self._solver_for(state, s, geo)
        data = QPData.inactive(solver.layout)
        self._pair_rows(data, geo, solver.layout)
        self._external_rows(data, geo, s)
        self._sense(state, geo)
        self._obstacle_rows(data, state, geo)
        self._bounds(data, geo, s)
        self._objective(data, state, geo, s)
        t1 = time.perf_counter()
        sol = solver.solve(data)
        t_solve = time.perf_counter() - t1
        U = self._command(sol, geo) * e
        self._record(sol, data, time.perf_counter() - t0, t_solve)
        return U

    def _geometry(self, state: SimState, s: _Step) -> _Geometry:
        key = (tuple(s.ctrl), s.lead, tuple(state.ids))
        if key != self._team_key:  # the robots' sizes and the formation edges, once
            rob = [self._robots[state.ids[i]] for i in s.ctrl]
            li = s.ctrl.index(s.lead) if s.lead in s.ctrl else None
            edges = [(k, -1 if li is None else li) for k, i in enumerate(s.ctrl)
                     if state.ids[i] in self.spec]
            e = self.ell
            self._team = (np.array([r.radius for r in rob]) / e,
                          np.array([r.max_speed for r in rob]) / e,
                          li, np.array(edges, int).reshape(-1, 2), np.triu_indices(len(s.ctrl), 1))
            self._team_key = key
        radii, vmax, li, edges, _ = self._team
        Ds = self.form.safety_distance / self.ell
        R_nb = max(self.o.neighbor_radius, Ds + 2 * state.dt * float(vmax.max()) * 1.05)
        X = state.positions / self.ell
        return _Geometry(state.dt, X, X[s.ctrl], radii, vmax, R_nb, Ds, li, edges,
                         xc_map=state.positions[s.ctrl])

    def _solver_for(self, state: SimState, s: _Step, geo: _Geometry) -> QPSolver:
        """The cached solver, rebuilt when the robots or the pair pattern no longer fit."""
        n = len(s.ctrl)
        iu, ju = self._team[4]
        dd = np.hypot(*(geo.xc[iu] - geo.xc[ju]).T) if n > 1 else np.zeros(0)
        key = (tuple(s.ctrl), tuple(s.ext))
        if (self.solver is not None and key == self._key
                and np.all(self._in_pattern[dd <= geo.R_nb])):
            return self.solver
        self._in_pattern = dd <= 1.5 * geo.R_nb
        w = np.ones(n)
        if geo.li is not None:
            w[geo.li] = self.o.w_leader
        pairs = np.stack([iu[self._in_pattern], ju[self._in_pattern]], axis=1)
        layout = QPLayout(n, pairs.reshape(-1, 2), self.o.max_obstacles, len(s.ext), geo.edges,
                          w, geo.vmax)
        self.solver = QPSolver(layout, state.dt, self.o.w_f, self.o.w_s, self._settings)
        self._key = key
        self.stats["rebuilds"] += 1
        self.stats["compiled"] = self.solver.hard.compiled is not None
        return self.solver

    def _pair_rows(self, data: QPData, geo: _Geometry, layout: QPLayout) -> None:
        """CBF rows of the controlled pairs in the pattern that are within the radius."""
        if not layout.P:
            return
        pr = layout.pairs
        d = geo.xc[pr[:, 0]] - geo.xc[pr[:, 1]]
        dist = np.hypot(d[:, 0], d[:, 1])
        on = dist <= geo.R_nb
        data.G[on] = -d[on]
        data.bp[on] = 0.5 * self.o.gamma * (dist[on] ** 2 - geo.Ds**2)

    def _external_rows(self, data: QPData, geo: _Geometry, s: _Step) -> None:
        """CBF rows against robots with known velocities (moved to the right-hand side)."""
        n, g = len(s.ctrl), self.o.gamma
        for e, j in enumerate(s.ext):
            d = geo.xc - geo.X[j][None, :]
            dist = np.hypot(d[:, 0], d[:, 1])
            on = dist <= geo.R_nb
            rows = np.arange(n) * len(s.ext) + e
            data.Ne[rows[on]] = -d[on]
            data.be[rows[on]] = 0.5 * g * (dist[on] ** 2 - geo.Ds**2) - d[on] @ s.u_ext[j]

    def _sense(self, state: SimState, geo: _Geometry) -> None:
        """One sensing query for the obstacle rows and eq 52 (clearance up to rho_0_f)."""
        o, fld = self.o, state.field
        if fld.n and (o.max_obstacles or o.adapt_phi):
            rng = max(self._sensing_range(), o.rho_0_f + float(geo.radii.max()))
            near, dist = fld.nearest(geo.xc_map, state.t, max_range=rng * self.ell)
            geo.near, geo.dist = near / self.ell, dist / self.ell

    def _sensing_range(self) -> float:
        """The rows' sensing range in units of ``length_scale``."""
        if self.o.sensing_range:
            return self.o.sensing_range
        if self.problem.sensing_range:
            return self.problem.sensing_range / self.ell
        return 100.0

    def _obstacle_rows(self, data: QPData, state: SimState, geo: _Geometry) -> None:
        """CBF rows of each robot's ``max_obstacles`` nearest sensed obstacles."""
        K, fld = self.o.max_obstacles, state.field
        if not K or geo.dist is None:
            return
        n, g, dt = len(geo.xc), self.o.gamma, state.dt
        vel = (fld.offsets(state.t + dt) - fld.offsets(state.t)) / (dt * self.ell)
        order = np.argsort(geo.dist, axis=1)[:, :K]
        sense = self._sensing_range()
        ar = np.arange(n)
        for kk in range(min(K, fld.n)):
            ob = order[:, kk]
            dk = geo.dist[ar, ob]
            v = geo.xc - geo.near[ar, ob]
            nv = np.hypot(v[:, 0], v[:, 1])
            ok = (dk <= sense) & (nv > 1e-9)
            nrm = v / np.where(ok, nv, 1.0)[:, None]
            h = dk - geo.radii - self.o.margin
            rows = ar * K + kk
            data.N[rows[ok]] = -nrm[ok]
            data.bo[rows[ok]] = g * h[ok] - np.sum(nrm[ok] * vel[ob[ok]], axis=1)

    def _bounds(self, data: QPData, geo: _Geometry, s: _Step) -> None:
        """Stay in the arena (or do not move further out), within the speed limit."""
        x0, y0, x1, y1 = np.asarray(self.problem.bounds, float) / self.ell
        dt, r, v = geo.dt, geo.radii[:, None], geo.vmax[:, None]
        lo = np.minimum((np.array([x0, y0])[None, :] + r - geo.xc) / dt, 0.0)
        hi = np.maximum((np.array([x1, y1])[None, :] - r - geo.xc) / dt, 0.0)
        data.lo, data.hi = np.maximum(lo, -v), np.minimum(hi, v)
        if geo.li is not None and s.u_lead_nom is not None and not np.any(s.u_lead_nom):
            data.lo[geo.li] = data.hi[geo.li] = 0.0  # the pilot holds the leader (at its goal)

    def _objective(self, data: QPData, state: SimState, geo: _Geometry, s: _Step) -> None:
        """Nominal velocities and the formation error before the step (eq 52 slots)."""
        data.unom[:] = s.u_lead[None, :]
        if geo.li is not None and s.u_lead_nom is not None:
            data.unom[geo.li] = s.u_lead_nom
        if not len(geo.edges):
            return
        fidx = geo.edges[:, 0]
        spec = [self.spec[state.ids[s.ctrl[f]]] for f in fidx]
        Lv = np.array([f.L for f in spec]) / self.ell
        Phi = np.array([f.phi for f in spec])
        if self.o.adapt_phi:
            rho = (np.min(geo.dist[fidx], axis=1) - geo.radii[fidx] if geo.dist is not None
                   else np.inf)
            Phi = adapted_angle(Phi, rho, self.o.rho_0_f, self.o.c_phi)
        data.r = geo.xc[fidx] - slot_positions(geo.X[s.lead], s.heading, Lv, Phi)
        if geo.li is None:
            data.r = data.r - state.dt * s.u_lead[None, :]

    def _command(self, sol: QPSolution, geo: _Geometry) -> np.ndarray:
        if sol.U is None:
            return np.zeros((len(geo.xc), 2))  # safe stop
        U = sol.U
        # tiny solver overshoot of the speed limit: scale down (keeps the rows, module doc)
        sp = np.hypot(U[:, 0], U[:, 1])
        U = U * np.minimum(1.0, geo.vmax / np.maximum(sp, 1e-12))[:, None]
        U[sp < 1e-6 * geo.vmax] = 0.0  # solver noise: a still robot stays still
        return U

    def _record(self, sol: QPSolution, data: QPData, el: float, t_solve: float) -> None:
        ok = sol.U is not None
        st = self.stats
        st["qp_solves"] += 1
        st["qp_failures"] += int(not ok)
        st["slack_steps"] += int(ok and sol.fallback)
        st["qp_retries"] += int(sol.retried)
        if ok:
            st["max_slack"] = max(st["max_slack"], sol.slack)
        st["statuses"][sol.status] = st["statuses"].get(sol.status, 0) + 1
        st["solve_times"].append(el)
        self.last = QPStepRecord(sol.status, ok, el, t_solve, sol.slack if ok else math.nan,
                                 data.active_pairs, sol.fallback, sol.iterations)


@dataclass(frozen=True, kw_only=True)
class FormationQP(PilotedFormation, FormationBackend):
    """Formation keeping by one cvxpy/Clarabel QP per step with CBF safety rows.

    The QP is posed in units of the scene's :attr:`~optplan.problem.Problem.length_scale`
    (positions, radii, speeds and the obstacle data divided by it, the solution multiplied
    back), so its numbers, its solver tolerances and its solution do not depend on the unit
    the scene is drawn in.

    Parameters
    ----------
    w_f : float
        Weight of the formation error after the step (1/s^2 relative to the velocity term).
    w_leader : float
        Weight of the leader's deviation from its pilot command (with ``leader_in_qp``).
    w_s : float
        Linear weight of the obstacle-row slack in the slack fallback (exact penalty).
    gamma : float
        CBF gain (1/s), linear class-K function; must satisfy ``gamma * dt <= 1``.
    margin : float
        Extra obstacle clearance kept by the obstacle rows beyond the radius (x length_scale).
    neighbor_radius : float
        Pairs closer than this get CBF rows (x length_scale; raised to ``D_s + 2 dt v_max``
        at least).
    max_obstacles : int
        Obstacle rows per robot (its nearest sensed obstacles).
    sensing_range : float
        Obstacle sensing range for the rows (x length_scale; 0: the scenario's ``[sensing]``
        range, else 100 x length_scale).
    leader_in_qp : bool
        The leader's velocity is a QP variable too (its pilot command is the nominal); so the
        leader waits for blocked followers and is itself filtered.
    max_iter : int
        Clarabel iteration cap per solve.
    tol : float
        Clarabel ``tol_gap_abs``, ``tol_gap_rel`` and ``tol_feas`` (the QP is in units of
        ``length_scale``, so the tolerance is relative to the scene's size).
    k, eta, rho_0, n, adapt_phi, rho_0_f, c_phi, pilot, path_solver, v_factor, ref_spacing,
    lookahead, tau_h, dt, max_steps, settle_tol
        See :class:`~optplan.formation.leader_follower.PilotedFormation` (the leader's pilot,
        eq 52 and the run settings).
    """

    name: ClassVar[str] = "formation-qp"
    w_f: float = option(4.0, lo=0.0, lo_open=True)
    w_leader: float = option(10.0, lo=0.0, lo_open=True)
    w_s: float = option(1e4, lo=0.0, lo_open=True)
    gamma: float = option(1.0, lo=0.0, lo_open=True)
    margin: float = option(0.5, lo=0.0, scale=True)
    neighbor_radius: float = option(30.0, lo=0.0, lo_open=True, scale=True)
    max_obstacles: int = option(3, lo=0, hi=64)
    sensing_range: float = option(0.0, lo=0.0, scale=True)
    leader_in_qp: bool = option(True)
    max_iter: int = option(50, lo=1, hi=10_000)
    tol: float = option(1e-7, lo=1e-12, hi=1e-2)

    def check(self) -> None:
        """``gamma * dt <= 1`` (discrete-time CBF), then the shared stage resolution."""
        if self.gamma * self.dt > 1 + 1e-12:
            raise ValueError(f"options 'gamma' * 'dt' of backend {self.name!r} must be <= 1 "
                             f"(discrete-time CBF), got {self.gamma} * {self.dt}")
        super().check()

    def followers_controller(self, problem: Problem,
                             rng: np.random.Generator) -> QPFormationController:
        """The QP as a :class:`~optplan.interfaces.FollowerController` (the leader is driven
        by the caller; :class:`~optplan.interfaces.FormationBackend`)."""
        return QPFormationController(problem, self)

    def solve(self, problem, /, *, rng=None, init=None, callback=None) -> Result:
        rng = make_rng(rng)[0]
        ctl = self.followers_controller(problem, rng)
        res = run_formation(self, problem, ctl, rng=rng, init=init, callback=callback,
                            joint=ctl.joint if self.leader_in_qp else None,
                            step_columns=lambda: ctl.last.columns() if ctl.last else {},
                            extras=lambda: qp_summary(ctl.stats))
        n_fail = ctl.stats["qp_failures"]
        if not n_fail:
            return res
        return dataclasses.replace(res, message=res.message
                                   + f"; {n_fail} QP failure(s) -> safe stop")


def qp_settings(opts: FormationQP) -> dict[str, Any]:
    """Clarabel's settings for the formation QP.

    ``presolve_enable`` and ``chordal_decomposition_enable`` are off so that the resident
    solver can be updated in place.  ``iterative_refinement_enable`` is off: on the benchmark's
    steps (3, 30 and 100 robots) the solutions agree with the refined ones to 1e-10 and each
    solve takes about a quarter less time (docs/solvers/formation.md, "QP speed"); a solve that
    ends with a numerical status (not an infeasibility certificate) is repeated once with
    refinement on (:class:`CompiledQP`, ``extras["qp_retries"]``).
    """
    return {"presolve_enable": False, "chordal_decomposition_enable": False,
            "iterative_refinement_enable": False, "verbose": False,
            "max_iter": opts.max_iter, "tol_gap_abs": opts.tol, "tol_gap_rel": opts.tol,
            "tol_feas": opts.tol}


def qp_summary(stats: dict[str, Any]) -> dict[str, Any]:
    """The QP's statistics for ``Result.extras`` (backend statistics, not metrics)."""
    times = np.asarray(stats["solve_times"])
    return {"qp_failures": stats["qp_failures"], "qp_solves": stats["qp_solves"],
            "slack_steps": stats["slack_steps"], "max_slack": stats["max_slack"],
            "rebuilds": stats["rebuilds"], "qp_compiled": stats["compiled"],
            "qp_retries": stats["qp_retries"],
            "qp_median_ms": float(np.median(times) * 1e3) if len(times) else math.nan}

