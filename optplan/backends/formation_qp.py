r"""Exact formation keeping: one convex QP per control step with CBF safety rows (domain-notes §3).

Model (single integrators :math:`x_i^+ = x_i + \tau u_i`, :math:`\tau` = ``dt``)
-------------------------------------------------------------------------------
Controlled robots :math:`i` (the followers, and the leader when ``leader_in_qp``) choose
velocities :math:`u_i`; robots outside the QP (the leader when a hybrid planner drives it) move
with known velocities :math:`u_j`.

.. math::

   \min_{u,\,s\ge0}\ \sum_i w_i\|u_i - u_i^{nom}\|^2
     + w_f\sum_{f}\|x_f + \tau u_f - (x_L + \tau u_L) - o_f(\theta_L)\|^2
     + w_s\sum_k s_k

subject to, for every pair of robots closer than ``neighbor_radius`` (with
:math:`d = x_i - x_j`, :math:`h = \|d\|^2 - D_s^2`, :math:`D_s` the formation's
``safety_distance``),

.. math:: -d^T u_i + d^T u_j \le \tfrac{\gamma}{2} h,

for every robot and each of its ``max_obstacles`` nearest sensed obstacles (nearest boundary point
:math:`c`, distance :math:`\delta`, unit normal :math:`n = (x_i - c)/\delta`, obstacle velocity
:math:`v_o`, :math:`h_o = \delta - r_i - m`)

.. math:: -n^T u_i \le \gamma h_o - n^T v_o + s_k,

position bounds :math:`x_i + \tau u_i \in [\ell + r_i, \mathrm{hi} - r_i]` (relaxed to
"do not move further out" when already outside), and :math:`\|u_i\| \le v_{max,i}`.  The
formation offsets :math:`o_f` are the L-phi slots (:mod:`optplan.backends.leader_follower`), with
the eq 52 angle adaptation when ``adapt_phi``.  :math:`u^{nom}` is the pilot's command for the
leader (weight ``w_leader``) and the leader's command (feed-forward) for each follower (weight 1).

Discrete-time exactness (derived).  With :math:`\gamma\tau \le 1` the pair rows are *sufficient*
for :math:`h^+ \ge (1-\gamma\tau)h`: :math:`h^+ = h + 2\tau d^T\Delta u + \tau^2\|\Delta u\|^2`
and the dropped term is non-negative.  So a pair that is safe now is safe after the step whenever
the QP's solution is applied, for any step length.  For a convex obstacle the half-plane
:math:`n^T(y - c) \le 0` contains the obstacle, so the obstacle row likewise keeps clearance
:math:`\ge r_i + m` (up to the reported slack).  ``neighbor_radius`` is raised to at least
:math:`D_s + 2\tau v_{max}` so no unconstrained pair can close the gap in one step.

Implementation.  The problem is built once in cvxpy with Parameters (DPP:
``problem.is_dcp(dpp=True)``), fixed shapes and padded rows (inactive rows: zero coefficients,
right-hand side ``BIG``), and re-solved with Clarabel with ``presolve_enable = False`` and
``chordal_decomposition_enable = False`` so cvxpy *updates* the cached solver instead of
rebuilding it (``qp_interface = "cvxpy"``).  ``qp_interface = "direct"`` assembles the same
matrices with a fixed sparsity pattern and calls ``clarabel.DefaultSolver.update`` itself, which
removes cvxpy's per-solve overhead (twin-tested against the cvxpy path).  Pair rows use a pattern
of the pairs within ``1.5 * neighbor_radius``; when a new pair comes within ``neighbor_radius``
the QP is rebuilt (counted in ``stats["rebuilds"]``).  A solver status other than optimal /
almost optimal, or an exception, falls back to a safe stop (all controlled robots hold still),
counted in ``stats["qp_failures"]``; nothing is raised.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp

from optplan.backends.leader_follower import (
    PilotedFormation,
    adapted_angle,
    run_formation,
    slot_positions,
)
from optplan.problem import Problem
from optplan.sim import SimState
from optplan.solver import check_choice, check_int, check_range, make_rng

__all__ = ["FormationQP", "QPCore", "QPFormationController"]

BIG = 1e5
_OK_CVXPY = ("optimal", "optimal_inaccurate")
_OK_CLARABEL = ("Solved", "AlmostSolved")


class QPCore:
    """The QP of one step with fixed shapes (built once, re-solved with new data).

    Parameters
    ----------
    n : int
        Controlled robots.
    pairs : (P, 2) int array
        Pattern of controlled pairs (rows padded/deactivated per step).
    K : int
        Obstacle slots per robot.
    n_ext : int
        Rows per controlled robot against external (known-velocity) robots.
    edges : (F, 2) int array
        Formation edges ``(follower, leader)``; leader ``-1`` when it is external.
    """

    def __init__(self, n: int, pairs: np.ndarray, K: int, n_ext: int, edges: np.ndarray,
                 weights: np.ndarray, vmax: np.ndarray, tau: float, w_f: float, w_s: float,
                 interface: str, settings: dict[str, Any]):
        self.n, self.K, self.n_ext, self.tau = n, K, n_ext, tau
        self.pairs = np.asarray(pairs, int).reshape(-1, 2)
        self.edges = np.asarray(edges, int).reshape(-1, 2)
        self.w, self.vmax, self.w_f, self.w_s = weights, vmax, w_f, w_s
        self.interface, self.settings = interface, settings
        self.P = len(self.pairs)
        self.F = len(self.edges)
        self.nK = n * K
        self.nE = n * n_ext
        # E: formation error Jacobian (2F x 2n)
        E = np.zeros((2 * self.F, 2 * n))
        for k, (f, l) in enumerate(self.edges):
            E[2 * k: 2 * k + 2, 2 * f: 2 * f + 2] = np.eye(2)
            if l >= 0:
                E[2 * k: 2 * k + 2, 2 * l: 2 * l + 2] = -np.eye(2)
        self.E = E
        self._build_cvxpy()
        if interface == "direct":
            self._build_direct()

    # -- cvxpy model (always built: it is the specification and the DPP check) -------------
    def _build_cvxpy(self) -> None:
        import cvxpy as cp

        n, P, nK, nE, F = self.n, self.P, self.nK, self.nE, self.F
        self.U = cp.Variable((n, 2))
        self.S = cp.Variable(nK) if nK else None
        self.p_unom = cp.Parameter((n, 2))
        self.p_r = cp.Parameter((max(F, 1), 2))
        self.p_G = cp.Parameter((max(P, 1), 2))
        self.p_bp = cp.Parameter(max(P, 1))
        self.p_N = cp.Parameter((max(nK, 1), 2))
        self.p_bo = cp.Parameter(max(nK, 1))
        self.p_Ne = cp.Parameter((max(nE, 1), 2))
        self.p_be = cp.Parameter(max(nE, 1))
        self.p_lo = cp.Parameter((n, 2))
        self.p_hi = cp.Parameter((n, 2))
        sw = np.sqrt(self.w)[:, None] * np.ones((1, 2))
        obj = cp.sum_squares(cp.multiply(sw, self.U - self.p_unom))
        cons = [self.U >= self.p_lo, self.U <= self.p_hi,
                cp.norm(self.U, 2, axis=1) <= self.vmax]
        if F:
            fi, li = self.edges[:, 0], self.edges[:, 1]
            err = self.p_r + self.tau * self.U[fi, :]
            if np.any(li >= 0):
                M = np.zeros((F, n))
                M[np.arange(F)[li >= 0], li[li >= 0]] = 1.0
                err = err - self.tau * (M @ self.U)
            obj = obj + self.w_f * cp.sum_squares(err)
        if P:
            I, J = self.pairs[:, 0], self.pairs[:, 1]
            cons.append(cp.sum(cp.multiply(self.p_G, self.U[I, :] - self.U[J, :]), axis=1)
                        <= self.p_bp)
        if nK:
            rep = np.repeat(np.arange(n), self.K)
            cons += [cp.sum(cp.multiply(self.p_N, self.U[rep, :]), axis=1)
                     <= self.p_bo + self.S, self.S >= 0]
            obj = obj + self.w_s * cp.sum(self.S)
        if nE:
            rep = np.repeat(np.arange(n), self.n_ext)
            cons.append(cp.sum(cp.multiply(self.p_Ne, self.U[rep, :]), axis=1) <= self.p_be)
        self.problem = cp.Problem(cp.Minimize(obj), cons)
        assert self.problem.is_dcp(dpp=True), "formation QP must be DPP"
        # zero-size padding parameters still need values
        for p in (self.p_r, self.p_G, self.p_N, self.p_Ne):
            p.value = np.zeros(p.shape)
        for p in (self.p_bp, self.p_bo, self.p_be):
            p.value = np.full(p.shape, BIG)

    # -- direct Clarabel model (same matrices, own fixed sparsity pattern) ----------------
    def _build_direct(self) -> None:
        import clarabel

        n, P, nK, nE = self.n, self.P, self.nK, self.nE
        nx = 2 * n + nK
        W = np.repeat(self.w, 2)
        Puu = 2 * (np.diag(W) + self.w_f * self.tau**2 * self.E.T @ self.E)
        Pm = np.zeros((nx, nx))
        Pm[: 2 * n, : 2 * n] = Puu
        self._Pm = sp.csc_matrix(np.triu(Pm))
        rows, cols, tag = [], [], []  # tag: index into the per-step value vector
        r = 0
        # pair rows: value slots 0..4P-1 as (G0, G1, -G0, -G1)
        for p, (i, j) in enumerate(self.pairs):
            rows += [r, r, r, r]
            cols += [2 * i, 2 * i + 1, 2 * j, 2 * j + 1]
            tag += [4 * p, 4 * p + 1, 4 * p + 2, 4 * p + 3]
            r += 1
        base = 4 * P
        for k in range(nK):  # obstacle rows: N0, N1 at robot k // K, then -1 on the slack
            i = k // self.K
            rows += [r, r, r]
            cols += [2 * i, 2 * i + 1, 2 * n + k]
            tag += [base + 2 * k, base + 2 * k + 1, -1]
            r += 1
        base2 = base + 2 * nK
        for k in range(nE):
            i = k // self.n_ext
            rows += [r, r]
            cols += [2 * i, 2 * i + 1]
            tag += [base2 + 2 * k, base2 + 2 * k + 1]
            r += 1
        self._n_var_vals = base2 + 2 * nE
        const_vals = []
        for k in range(nK):  # -s <= 0
            rows.append(r)
            cols.append(2 * n + k)
            tag.append(-2)
            r += 1
        for sgn in (1.0, -1.0):  # u <= hi ; -u <= -lo
            for c in range(2 * n):
                rows.append(r)
                cols.append(c)
                tag.append(-3 if sgn > 0 else -2)
                r += 1
        self._m_lin = r
        for i in range(n):  # SOC rows: [vmax; u_i]: s = b - A x with A = [0; -I]
            rows += [r + 1, r + 2]
            cols += [2 * i, 2 * i + 1]
            tag += [-2, -2]
            r += 3
        self._m = r
        tag = np.array(tag)
        const_vals = np.where(tag == -1, -1.0, np.where(tag == -2, -1.0, 1.0))
        nnz = len(rows)
        order_mat = sp.csc_matrix((np.arange(1, nnz + 1, dtype=float), (rows, cols)),
                                  shape=(self._m, nx))
        self._perm = order_mat.data.astype(int) - 1  # CSC slot -> COO entry
        self._tag = tag
        self._vals = const_vals.astype(float)
        self._A = order_mat.copy()
        self._A.data = self._vals[self._perm]
        self._b = np.zeros(self._m)
        self._q = np.zeros(nx)
        self._q[2 * n:] = self.w_s
        cones = [clarabel.NonnegativeConeT(self._m_lin)] + [clarabel.SecondOrderConeT(3)] * n
        st = clarabel.DefaultSettings()
        for k, v in self.settings.items():
            setattr(st, k, v)
        self._cones, self._st = cones, st
        self._solver = None

    # -- one solve ------------------------------------------------------------------------
    def solve(self, unom, r, G, bp, N, bo, Ne, be, lo, hi) -> tuple[np.ndarray | None, str,
                                                                    float]:
        """Solve with new data; returns ``(U or None, status, max_slack)``."""
        if self.interface == "direct":
            return self._solve_direct(unom, r, G, bp, N, bo, Ne, be, lo, hi)
        import cvxpy as cp

        self.p_unom.value = unom
        if self.F:
            self.p_r.value = r
        if self.P:
            self.p_G.value, self.p_bp.value = G, bp
        if self.nK:
            self.p_N.value, self.p_bo.value = N, bo
        if self.nE:
            self.p_Ne.value, self.p_be.value = Ne, be
        self.p_lo.value, self.p_hi.value = lo, hi
        try:
            self.problem.solve(solver=cp.CLARABEL, warm_start=True, **self.settings)
        except Exception as e:  # noqa: BLE001 - solver failure -> safe stop
            return None, f"error: {type(e).__name__}", float("nan")
        st = str(self.problem.status)
        if st not in _OK_CVXPY or self.U.value is None:
            return None, st, float("nan")
        slack = float(self.S.value.max()) if self.nK else 0.0
        return np.asarray(self.U.value), st, max(slack, 0.0)

    def _solve_direct(self, unom, r, G, bp, N, bo, Ne, be, lo, hi):
        import clarabel

        n = self.n
        W = np.repeat(self.w, 2)
        q = self._q
        q[: 2 * n] = -2 * W * unom.ravel()
        if self.F:
            q[: 2 * n] += 2 * self.w_f * self.tau * (self.E.T @ r.ravel())
        v = self._vals
        tag = self._tag
        dyn = np.zeros(self._n_var_vals)
        if self.P:
            dyn[: 4 * self.P] = np.hstack([G, -G]).ravel()
        if self.nK:
            dyn[4 * self.P: 4 * self.P + 2 * self.nK] = N.ravel()
        if self.nE:
            dyn[4 * self.P + 2 * self.nK:] = Ne.ravel()
        m = tag >= 0
        v[m] = dyn[tag[m]]
        self._A.data = v[self._perm]
        b = self._b
        k = 0
        b[k: k + self.P] = bp
        k += self.P
        b[k: k + self.nK] = bo
        k += self.nK
        b[k: k + self.nE] = be
        k += self.nE
        b[k: k + self.nK] = 0.0
        k += self.nK
        b[k: k + 2 * n] = hi.ravel()
        k += 2 * n
        b[k: k + 2 * n] = -lo.ravel()
        k += 2 * n
        b[k::3] = self.vmax
        try:
            if self._solver is None:
                self._solver = clarabel.DefaultSolver(self._Pm, q, self._A, b, self._cones,
                                                      self._st)
            else:
                self._solver.update(q=q, A=self._A.data, b=b)
            sol = self._solver.solve()
        except Exception as e:  # noqa: BLE001
            self._solver = None
            return None, f"error: {type(e).__name__}", float("nan")
        st = str(sol.status)
        if st not in _OK_CLARABEL:
            return None, st, float("nan")
        x = np.asarray(sol.x)
        slack = float(x[2 * n:].max()) if self.nK else 0.0
        return x[: 2 * n].reshape(n, 2), st, max(slack, 0.0)


class QPFormationController:
    """Per-step data assembly around :class:`QPCore` (a FollowerController, interfaces.md)."""

    def __init__(self, problem: Problem, opts: FormationQP):
        if problem.formation is None:
            raise ValueError(f"problem {problem.name!r} has no [formation]")
        self.problem, self.o = problem, opts
        self.form = problem.formation
        self.spec = {f.id: f for f in self.form.followers}
        self.core: QPCore | None = None
        self._key: tuple | None = None
        self.stats: dict[str, Any] = {"qp_failures": 0, "qp_solves": 0, "rebuilds": 0,
                                      "max_slack": 0.0, "solve_times": [], "statuses": {}}

    # FollowerController interface: the leader is external (driven by someone else)
    def velocities(self, state: SimState, leader_index: int, follower_indices: list[int],
                   leader_heading: float) -> np.ndarray:
        ul = np.asarray(state.memory.get("leader_velocity", state.velocities[leader_index]),
                        float)
        U = self.step(state, list(follower_indices), leader_index, [leader_index], {
            leader_index: ul}, ul, leader_heading, None)
        return U

    def step(self, state: SimState, ctrl: list[int], lead: int, ext: list[int],
             u_ext: dict[int, np.ndarray], u_lead: np.ndarray, heading: float,
             u_lead_nom: np.ndarray | None) -> np.ndarray:
        """Velocities of the controlled robots ``ctrl`` (state indices)."""
        t0 = time.perf_counter()
        o, prob = self.o, self.problem
        dt = o.dt
        X = state.positions
        ids = state.ids
        n = len(ctrl)
        rob = [prob.robot(ids[i]) for i in ctrl]
        radii = np.array([r.radius for r in rob])
        vmax = np.array([r.max_speed for r in rob])
        Ds = self.form.safety_distance
        R_nb = max(o.neighbor_radius, Ds + 2 * dt * float(vmax.max()) * 1.05)
        xc = X[ctrl]
        # --- pair pattern and rebuild check ---
        iu, ju = np.triu_indices(n, 1)
        dd = np.hypot(*(xc[iu] - xc[ju]).T) if n > 1 else np.zeros(0)
        active = dd <= R_nb
        pair_set = {(int(a), int(b)) for a, b in zip(iu[active], ju[active])}
        edges = []
        for k, i in enumerate(ctrl):
            if ids[i] in self.spec:
                edges.append((k, ctrl.index(lead) if lead in ctrl else -1))
        key = (tuple(ctrl), tuple(ext))
        if self.core is None or key != self._key or not pair_set <= self._pattern:
            patt = dd <= 1.5 * R_nb
            self._pattern = {(int(a), int(b)) for a, b in zip(iu[patt], ju[patt])}
            pairs = np.array(sorted(self._pattern), int).reshape(-1, 2)
            w = np.ones(n)
            if lead in ctrl:
                w[ctrl.index(lead)] = o.w_leader
            settings = {"presolve_enable": False, "chordal_decomposition_enable": False,
                        "verbose": False, "max_iter": o.max_iter, "tol_gap_abs": o.tol,
                        "tol_gap_rel": o.tol, "tol_feas": o.tol}
            self.core = QPCore(n, pairs, o.max_obstacles, len(ext), np.array(edges, int),
                               w, vmax, dt, o.w_f, o.w_s, o.qp_interface, settings)
            self._key = key
            self._pair_index = {tuple(p): k for k, p in enumerate(pairs)}
            self.stats["rebuilds"] += 1
        core = self.core
        g = o.gamma
        # --- pair rows ---
        G = np.zeros((core.P, 2))
        bp = np.full(core.P, BIG)
        if core.P:
            pr = core.pairs
            d = xc[pr[:, 0]] - xc[pr[:, 1]]
            dist = np.hypot(d[:, 0], d[:, 1])
            on = dist <= R_nb
            G[on] = -d[on]
            bp[on] = 0.5 * g * (dist[on] ** 2 - Ds**2)
        # --- external robots (known velocity) ---
        nE = core.nE
        Ne = np.zeros((nE, 2))
        be = np.full(nE, BIG)
        for e, j in enumerate(ext):
            d = xc - X[j][None, :]
            dist = np.hypot(d[:, 0], d[:, 1])
            on = dist <= R_nb
            rows = np.arange(n) * len(ext) + e
            Ne[rows[on]] = -d[on]
            be[rows[on]] = 0.5 * g * (dist[on] ** 2 - Ds**2) - d[on] @ u_ext[j]
        # --- obstacle rows ---
        K = o.max_obstacles
        N = np.zeros((n * K, 2))
        bo = np.full(n * K, BIG)
        fld = state.field
        sense = o.sensing_range or prob.sensing_range or 100.0
        near = dist = None
        if fld.n and (K or o.adapt_phi):  # one sensing query serves the rows and eq 52
            # eq 52 needs the clearance (distance - radius) up to rho_0_f
            near, dist = fld.nearest(xc, state.t,
                                     max_range=max(sense, o.rho_0_f + float(radii.max())))
        if K and fld.n:
            vel = (fld.offsets(state.t + dt) - fld.offsets(state.t)) / dt  # (n_obs, 2)
            order = np.argsort(dist, axis=1)[:, :K]
            for kk in range(min(K, fld.n)):
                ob = order[:, kk]
                dk = dist[np.arange(n), ob]
                ok = dk <= sense
                c = near[np.arange(n), ob]
                v = xc - c
                nv = np.hypot(v[:, 0], v[:, 1])
                ok &= nv > 1e-9
                nrm = v / np.where(ok, nv, 1.0)[:, None]
                h = dk - radii - o.margin
                rows = np.arange(n) * K + kk
                N[rows[ok]] = -nrm[ok]
                bo[rows[ok]] = g * h[ok] - np.sum(nrm[ok] * vel[ob[ok]], axis=1)
        # --- bounds ---
        x0, y0, x1, y1 = prob.bounds
        lo = np.minimum((np.array([x0, y0])[None, :] + radii[:, None] - xc) / dt, 0.0)
        hi = np.maximum((np.array([x1, y1])[None, :] - radii[:, None] - xc) / dt, 0.0)
        lo = np.maximum(lo, -vmax[:, None])
        hi = np.minimum(hi, vmax[:, None])
        if lead in ctrl and u_lead_nom is not None and not np.any(u_lead_nom):
            li = ctrl.index(lead)  # the pilot holds the leader (at its goal): keep it still
            lo[li] = hi[li] = 0.0
        # --- objective data ---
        unom = np.repeat(u_lead[None, :], n, axis=0)
        if lead in ctrl and u_lead_nom is not None:
            unom[ctrl.index(lead)] = u_lead_nom
        fol = [ids[ctrl[f]] for f, _ in edges]
        Lv = np.array([self.spec[i].L for i in fol])
        Phi = np.array([self.spec[i].phi for i in fol])
        fidx = np.array([f for f, _ in edges], int)
        if o.adapt_phi and len(fol):
            rho = (np.min(dist[fidx], axis=1) - radii[fidx]) if dist is not None else np.inf
            Phi = adapted_angle(Phi, rho, o.rho_0_f, o.c_phi)
        xl = X[lead]
        r = np.zeros((len(fol), 2))
        if len(fol):
            slots = slot_positions(xl, heading, Lv, Phi)
            r = xc[fidx] - slots
            if lead not in ctrl:
                r = r - dt * u_lead[None, :]
        U, status, slack = core.solve(unom, r, G, bp, N, bo, Ne, be, lo, hi)
        ok = U is not None
        if not ok:
            self.stats["qp_failures"] += 1
            U = np.zeros((n, 2))  # safe stop
        else:
            # tiny solver overshoot of the speed limit: scale down (keeps rows, see doc)
            sp_ = np.hypot(U[:, 0], U[:, 1])
            U = U * np.minimum(1.0, vmax / np.maximum(sp_, 1e-12))[:, None]
            U[sp_ < 1e-6 * vmax] = 0.0  # solver noise: a still robot stays still
        self.stats["qp_solves"] += 1
        self.stats["max_slack"] = max(self.stats["max_slack"], slack if ok else 0.0)
        self.stats["statuses"][status] = self.stats["statuses"].get(status, 0) + 1
        el = time.perf_counter() - t0
        self.stats["solve_times"].append(el)
        state.memory["qp_row"] = {"qp_status": status, "qp_ok": ok, "qp_time": el,
                                  "qp_slack": slack if ok else np.nan,
                                  "qp_pairs": int(np.sum(bp < BIG))}
        return U


@dataclass(frozen=True, kw_only=True)
class FormationQP(PilotedFormation):
    """Formation keeping by one cvxpy/Clarabel QP per step with CBF safety rows.

    Parameters
    ----------
    w_f : float
        Weight of the formation error after the step (1/s^2 relative to the velocity term).
    w_leader : float
        Weight of the leader's deviation from its pilot command (with ``leader_in_qp``).
    w_s : float
        Linear weight of the obstacle-row slack (exact penalty; reported in ``max_slack``).
    gamma : float
        CBF gain (1/s), linear class-K function; must satisfy ``gamma * dt <= 1``.
    margin : float
        Extra obstacle clearance (map units) kept by the obstacle rows beyond the radius.
    neighbor_radius : float
        Pairs closer than this get CBF rows (raised to ``D_s + 2 dt v_max`` at least).
    max_obstacles : int
        Obstacle rows per robot (its nearest sensed obstacles).
    sensing_range : float
        Obstacle sensing range for the rows (0: the scenario's ``[sensing]`` range, else 100).
    leader_in_qp : bool
        The leader's velocity is a QP variable too (its pilot command is the nominal); so the
        leader waits for blocked followers and is itself filtered.
    qp_interface : str
        ``"cvxpy"`` (cvxpy Parameters, cached Clarabel solver updated) or ``"direct"``
        (same matrices assembled here, ``clarabel.DefaultSolver.update``).
    max_iter : int
        Clarabel iteration cap per solve.
    tol : float
        Clarabel ``tol_gap_abs``, ``tol_gap_rel`` and ``tol_feas``.
    k, eta, rho_0, n, adapt_phi, rho_0_f, c_phi, pilot, path_solver, v_factor, ref_spacing,
    lookahead, tau_h, dt, max_steps, settle_tol
        The leader's pilot, eq 52 and run settings
        (:class:`~optplan.backends.leader_follower.PilotedFormation`).
    """

    name: ClassVar[str] = "formation-qp"
    contract_problem: ClassVar[str] = "formation-open-field"
    contract_overrides: ClassVar[dict] = {"path_solver": "visgraph", "max_steps": 150,
                                          "dt": 1.0, "gamma": 1.0, "qp_interface": "direct"}
    w_f: float = 4.0
    w_leader: float = 10.0
    w_s: float = 1e4
    gamma: float = 1.0
    margin: float = 0.5
    neighbor_radius: float = 30.0
    max_obstacles: int = 3
    sensing_range: float = 0.0
    leader_in_qp: bool = True
    qp_interface: str = "cvxpy"
    max_iter: int = 50
    tol: float = 1e-7

    def __post_init__(self) -> None:
        self._check_pilot_options()
        for f in ("w_f", "w_leader", "w_s", "gamma", "neighbor_radius"):
            check_range(self, f, 0, lo_open=True)
        for f in ("margin", "sensing_range"):
            check_range(self, f, 0)
        check_int(self, "max_obstacles", 0, 64)
        check_int(self, "max_iter", 1, 10_000)
        check_range(self, "tol", 1e-12, 1e-2)
        check_choice(self, "qp_interface", ("cvxpy", "direct"))
        if self.gamma * self.dt > 1 + 1e-12:
            raise ValueError(f"options 'gamma' * 'dt' of backend {self.name!r} must be <= 1 "
                             f"(discrete-time CBF), got {self.gamma} * {self.dt}")
        if not isinstance(self.leader_in_qp, bool):
            raise ValueError(f"option 'leader_in_qp' of backend {self.name!r} must be true or "
                             "false")

    def followers_controller(self, problem: Problem,
                             rng: np.random.Generator) -> QPFormationController:
        """The QP as a FollowerController (the leader is driven by the caller)."""
        return QPFormationController(problem, self)

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        rng = make_rng(rng)[0]
        ctl = self.followers_controller(problem, rng)
        joint = None
        if self.leader_in_qp:
            n_all = 1 + len(problem.formation.followers) if problem.formation else 1

            def joint(state: SimState, ul: np.ndarray, heading: float) -> np.ndarray:
                ctrl = list(range(n_all))
                return ctl.step(state, ctrl, 0, [], {}, ul, heading, ul)

        res = run_formation(self, problem, ctl, rng=rng, init=init, callback=callback,
                            joint=joint)
        st = ctl.stats
        times = np.asarray(st["solve_times"])
        extra = {"qp_failures": st["qp_failures"], "qp_solves": st["qp_solves"],
                 "max_slack": st["max_slack"], "rebuilds": st["rebuilds"],
                 "qp_median_ms": float(np.median(times) * 1e3) if len(times) else math.nan}
        res.metrics.update(extra)
        msg = res.message + (f"; {st['qp_failures']} QP failure(s) -> safe stop"
                             if st["qp_failures"] else "")
        import dataclasses

        return dataclasses.replace(res, message=msg)
