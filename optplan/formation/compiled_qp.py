r"""The formation QP's one run-time solve path: cvxpy's compiled data as an affine map.

A DPP problem's compiled solver data is affine in its Parameters.  :meth:`CompiledQP.learn` reads
that map off the cvxpy model (:class:`~optplan.formation.qp_model.QPModel`) once per layout and
verifies it; every step then evaluates it and hands the data to Clarabel through the adapter
:mod:`optplan.formation.clarabel`.  cvxpy's own re-solve pipeline
(:meth:`~optplan.formation.qp_model.QPModel.solve_cvxpy`) is not a run-time path: it is the
oracle the map is verified against when it is learned, and the tests' oracle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import scipy.sparse as sp

from optplan.formation import clarabel as cl

__all__ = ["CompiledQP", "QPSolution", "CompileError", "CvxpyModel"]


class CvxpyModel(Protocol):
    """What :meth:`CompiledQP.learn` reads off the cvxpy model
    (:class:`~optplan.formation.qp_model.QPModel`, which solves through the map it learns).

    Attributes
    ----------
    theta : cvxpy.Parameter
        The model's one Parameter vector.
    settings : dict
        Clarabel's settings of the model.
    soft : bool
        Whether the model has the slack variables.
    layout : QPLayout
        The model's fixed shapes (``layout.vmax``: the robots' speed bounds).
    """

    theta: Any
    settings: dict[str, Any]
    soft: bool
    layout: Any

    def compiled_data(self, theta: np.ndarray) -> dict[str, Any]: ...

    def feasible_theta(self, rng: np.random.Generator) -> np.ndarray: ...

    def solve_cvxpy(self, theta: np.ndarray, settings: dict[str, Any] | None = None
                    ) -> tuple[QPSolution, np.ndarray | None]: ...


@dataclass
class QPSolution:
    """What one solve returned: ``U`` ``(n, 2)`` or ``None``, the status, the largest slack
    (0 unless the slack fallback was used), whether it was, whether the solve was repeated
    with iterative refinement (:func:`~optplan.formation.formation_qp.qp_settings`) and
    Clarabel's iteration count (-1: not known, the cvxpy pipeline)."""

    U: np.ndarray | None
    status: str
    slack: float = 0.0
    fallback: bool = False
    retried: bool = False
    iterations: int = -1
    #: Clarabel's objective value (NaN when not known): only compared when the map is checked
    objective: float = math.nan



class CompileError(RuntimeError):
    """cvxpy's compilation of the formation QP could not be read off as an affine map or the
    map disagrees with cvxpy's own solve (a modelling error in optplan, or a cvxpy whose
    compiled data has another form)."""


#: Iteration cap of the check solves when the model's own cap does not solve the check instance.
CHECK_ITER = 200


def _require(ok: bool, why: str) -> None:
    if not ok:
        raise CompileError(f"formation QP: {why}")


class CompiledQP:
    """The per-step solve with cvxpy out of the loop: cvxpy's compiled data as an affine map.

    A DPP problem's compiled solver data is an affine function of its Parameters (that is what
    cvxpy caches).  :meth:`learn` reads that map off :meth:`QPModel.compiled_data` at
    :math:`\\theta = 0` and three random Parameter vectors, assuming that every entry of the
    data (``c``, ``A``, ``b``) depends on at most one Parameter entry (true for this model), and
    accepts it only when it predicts the fourth compilation exactly and its Clarabel solve
    agrees with cvxpy's own pipeline (:meth:`QPModel.solve_cvxpy`, the oracle); otherwise it raises
    :class:`CompileError`.

    Each step evaluates the map (``c0 + c1 * theta[j]``), drops the inequality rows that the
    speed cones already imply (:math:`a^Tu \\le b` with
    :math:`\\sum_i \\|a_i\\|\\,v_{max,i} \\le b`: every padded row, far pairs, walls out of
    reach; the feasible set is unchanged, so is the solution) and hands the rest to Clarabel:
    ``DefaultSolver.update`` when the kept rows are those of the last step, else a new
    ``DefaultSolver`` (:class:`~optplan.formation.clarabel.ResidentSolver`, its ``builds``).
    """

    def __init__(self, P: Any, cones: dict[str, Any], pattern: tuple[np.ndarray, np.ndarray],
                 affine: tuple[np.ndarray, np.ndarray, np.ndarray], sizes: tuple[int, int, int],
                 u_off: int, vmax: np.ndarray, settings: dict[str, Any]):
        self.P, self.cones = P, cones
        self.rows, self.cols = pattern
        self.c0, self.c1, self.j = affine
        self.nx, self.nnz, self.m = sizes
        self.n, self.u_off = len(vmax), u_off
        #: the resident Clarabel solver (its ``retries`` and ``settings``)
        self.clarabel = cl.ResidentSolver(P, cones["soc"], settings)
        n, rows, cols = self.n, self.rows, self.cols
        is_u = (cols >= u_off) & (cols < u_off + 2 * n)
        self._droppable = np.zeros(self.m, bool)
        self._droppable[cones["zero"]: cones["zero"] + cones["nonneg"]] = True
        self._droppable &= np.bincount(rows[~is_u], minlength=self.m) == 0
        grp, self._gid = np.unique(rows * n + np.where(is_u, (cols - u_off) // 2, 0),
                                   return_inverse=True)
        self._g_row, self._g_vmax = grp // n, np.asarray(vmax, float)[grp % n]
        self._other = np.r_[0:u_off, u_off + 2 * n: self.nx].astype(np.int64)

    # -- reading the map off cvxpy ----------------------------------------------------------
    @classmethod
    def learn(cls, model: CvxpyModel) -> CompiledQP:
        """The verified map of ``model``'s compilation (:class:`CompileError` when it cannot be
        read off or disagrees with cvxpy's own solve)."""
        rng = np.random.default_rng(20240601)
        m = int(model.theta.size)
        probes = [np.zeros(m)] + [rng.uniform(1.0, 2.0, m) * rng.choice([-1.0, 1.0], m)
                                  for _ in range(3)]
        data = [model.compiled_data(t) for t in probes]
        dims = data[1]["dims"]
        _require(not (dims.exp or dims.psd or getattr(dims, "p3d", None)
                      or getattr(dims, "pnd", None)), "cones other than zero, nonneg, SOC")
        A1 = sp.csc_matrix(data[1]["A"])
        A1.sort_indices()
        pattern = (A1.indices.astype(np.int64),
                   np.repeat(np.arange(A1.shape[1]), np.diff(A1.indptr)))
        v = [x for x in (_flat(d, pattern) for d in data) if x is not None]
        _require(len(v) == len(data), "an entry of A off the common pattern")
        P = sp.triu(sp.csc_matrix(data[1]["P"])).tocsc()
        _require(all(abs(sp.triu(sp.csc_matrix(d["P"])) - P).sum() == 0 for d in data),
                 "a quadratic term that varies with the Parameter")
        affine = _affine_fit(probes, v)
        _require(affine is not None, "data not of the form c0 + c1 * theta[j]")
        sizes = (len(data[1]["c"]), len(pattern[0]), A1.shape[0])
        cones = {"zero": dims.zero, "nonneg": dims.nonneg, "soc": list(dims.soc)}
        return cls._verified(model, rng, P, cones, pattern, affine, sizes)

    @classmethod
    def _verified(cls, model: CvxpyModel, rng: np.random.Generator, *args: Any) -> CompiledQP:
        """The map, after its solve of a random feasible instance agrees with the oracle's.

        When the check does not solve with the model's settings (an iteration cap too low for
        the check instance, e.g. ``max_iter = 1``), it is repeated with a cap of
        :data:`CHECK_ITER` and the resident solver starts afresh with the model's settings."""
        theta = model.feasible_theta(rng)
        out, why = cls._check(model, theta, args, model.settings)
        if out is None:
            st = {**model.settings, "max_iter": max(CHECK_ITER, model.settings.get("max_iter", 0))}
            out, why = cls._check(model, theta, args, st)
            if out is None:
                raise CompileError(f"formation QP: {why}")
            out.clarabel.settings = model.settings
            out.clarabel.reset()
        return out

    @classmethod
    def _check(cls, model: CvxpyModel, theta: np.ndarray, args: tuple,
               settings: dict[str, Any]) -> tuple[CompiledQP | None, str]:
        ref, x = model.solve_cvxpy(theta, settings)
        u_off = _offset(x, ref.U)
        if u_off is None:
            return None, f"the oracle's solve ({ref.status}) does not locate u"
        P, cones, pattern, affine, sizes = args
        out = cls(P, cones, pattern, affine, sizes, u_off, model.layout.vmax, settings)
        got = out.solve(theta, model.soft)
        if not _agree(got, ref, settings):
            return None, f"the map's solve ({got.status}) differs from the oracle's ({ref.status})"
        return out, ""

    # -- one step ----------------------------------------------------------------------------
    def rows_needed(self, Av: np.ndarray, b: np.ndarray) -> np.ndarray:
        """False for the inequality rows the speed cones imply."""
        g = np.bincount(self._gid, weights=Av * Av, minlength=len(self._g_row))
        bound = np.bincount(self._g_row, weights=np.sqrt(g) * self._g_vmax, minlength=self.m)
        return ~(self._droppable & (bound <= b + 1e-12 * (1.0 + np.abs(b))))

    def solve(self, theta: np.ndarray, soft: bool = False) -> QPSolution:
        """One step at Parameter vector ``theta`` (``soft``: the slack model's slack is read)."""
        vals = self.c0 + self.c1 * np.append(theta, 0.0)[self.j]
        q, Av, b = vals[: self.nx], vals[self.nx: self.nx + self.nnz], vals[self.nx + self.nnz:]
        keep = self.rows_needed(Av, b)
        ent = keep[self.rows]
        run = self.clarabel.solve(keep, q, Av[ent], b[keep],
                                  lambda: self._assemble(Av, keep, ent))
        if run.solution is None:
            return QPSolution(None, run.status, math.nan, soft)
        if not cl.accepted(run.status):
            return QPSolution(None, run.status, math.nan, soft, retried=run.retried)
        sol = run.solution
        x = np.asarray(sol.x, float)
        U = x[self.u_off: self.u_off + 2 * self.n].reshape(-1, 2)
        slack = max(float(x[self._other].max()), 0.0) if soft and len(self._other) else 0.0
        return QPSolution(U, run.status, slack, soft, retried=run.retried,
                          iterations=int(sol.iterations), objective=float(sol.obj_val))

    def _assemble(self, Av: np.ndarray, keep: np.ndarray,
                  ent: np.ndarray) -> tuple[sp.csc_matrix, int, int]:
        """The kept rows as a CSC matrix, and the sizes of the zero and non-negative cones."""
        rows = (np.cumsum(keep) - 1)[self.rows[ent]]
        indptr = np.r_[0, np.cumsum(np.bincount(self.cols[ent], minlength=self.nx))]
        A = sp.csc_matrix((Av[ent], rows, indptr), shape=(int(keep.sum()), self.nx))
        z, l = self.cones["zero"], int(keep[self.cones["zero"]: self.cones["zero"]
                                            + self.cones["nonneg"]].sum())
        return A, z, l


def _agree(got: QPSolution, ref: QPSolution, settings: dict[str, Any]) -> bool:
    """The map's and the oracle's solutions of the same instance agree: the same velocities to
    1e-5 (relative), or, both solved, the same objective to ten times the gap tolerance (on a
    speed-cone boundary the velocities of two solves to tolerance ``tol`` differ by up to
    about ``sqrt(tol)``)."""
    if got.U is None or ref.U is None:
        return False
    scale = 1e-5 * (1.0 + float(np.abs(ref.U).max()))
    if np.allclose(got.U, ref.U, atol=scale):
        return True
    tol = 10.0 * settings.get("tol_gap_abs", 1e-8)
    return abs(got.objective - ref.objective) <= tol * (1.0 + abs(ref.objective))


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

