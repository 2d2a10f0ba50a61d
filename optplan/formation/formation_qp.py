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

Implementation (one implementation, one run-time path)
------------------------------------------------------
The model is one cvxpy DPP problem per layout (:mod:`optplan.formation.qp_model`: the objective
expanded to :math:`u^TQu + q^Tu`, fixed row shapes, one Parameter vector).  Per step cvxpy is
out of the loop (:mod:`optplan.formation.compiled_qp`): the compiled solver data of a DPP
problem is affine in its Parameters, and that map is read off cvxpy's compilation
(``Problem.get_problem_data``, documented as enough to call the solver directly) when the model
is built, checked against a further compilation and against cvxpy's own re-solve of a random
instance.  A step evaluates the map, drops the inequality rows the speed cones already imply
(:math:`\sum_i\|a_i\|v_{max,i} \le b`: the padded rows, far pairs, walls out of reach; the
feasible set and the solution are unchanged) and gives the rest to Clarabel
(:mod:`optplan.formation.clarabel`, updated in place with ``DefaultSolver.update`` while the
kept rows stay the same).  This is the only run-time path.  cvxpy's documented re-solve
pipeline (:meth:`QPModel.solve_cvxpy`) is the oracle: of the check above, and of the tests,
which solve random instances both ways.  A map that cannot be read off or checked is a
:class:`~optplan.formation.compiled_qp.CompileError` when the model is built (a modelling error,
like a model that is not DPP), never a silent switch to a slower path.

Units: the QP is posed in units of the scene's ``length_scale`` (positions, radii, speeds, the
safety distance, the obstacle data and the bounds divided by it, the solution multiplied back);
``margin``, ``neighbor_radius`` and ``sensing_range`` are multiples of it.  Its numbers,
Clarabel's tolerances and the solution therefore do not depend on the unit the scene is drawn in.
Clarabel runs without iterative refinement (:func:`qp_settings`); a solve that ends with a
numerical status is repeated once with it (``stats["qp_retries"]``).

A new pair inside ``neighbor_radius`` outside the pattern, or a change of the controlled robots,
rebuilds the model (``stats["rebuilds"]``).  A Clarabel status other than ``Solved`` /
``AlmostSolved`` (:data:`optplan.formation.clarabel.STATUS`) after the fallback, or a solver
error, gives a safe stop (all controlled robots
hold still), counted in ``stats["qp_failures"]``; nothing is raised.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.formation.compiled_qp import CompiledQP
from optplan.formation.leader_follower import adapted_angle
from optplan.formation.pilot import PilotedFormation, run_formation
from optplan.formation.qp_model import BIG, QPData, QPLayout, QPModel, QPSolution
from optplan.formation.slots import slot_positions
from optplan.interfaces import FormationBackend
from optplan.problem import Problem
from optplan.result import Result
from optplan.sim import SimState
from optplan.solver import make_rng, option
from optplan.units import Each, Record, Unit

__all__ = ["FormationQP", "QPData", "QPLayout", "QPModel", "QPSolver", "QPSolution",
           "QPStepRecord", "QPFormationController", "qp_summary", "qp_settings", "CompiledQP",
           "STATS_UNITS", "SUMMARY_UNITS"]

#: The units of :attr:`QPFormationController.stats`.  The QP is posed in units of
#: ``length_scale``, so its slack (a speed in those units) is dimensionless.
STATS_UNITS = Record({
    "qp_failures": Unit.DIMENSIONLESS, "qp_solves": Unit.DIMENSIONLESS,
    "rebuilds": Unit.DIMENSIONLESS, "qp_retries": Unit.DIMENSIONLESS,
    "slack_steps": Unit.DIMENSIONLESS, "max_slack": Unit.DIMENSIONLESS,
    "solve_times": Unit.WALL_TIME, "statuses": Each(Unit.DIMENSIONLESS),
    "compiled": Unit.DIMENSIONLESS})
#: The units of :func:`qp_summary` (the QP's statistics in the extras).
SUMMARY_UNITS = Record({
    "qp_failures": Unit.DIMENSIONLESS, "qp_solves": Unit.DIMENSIONLESS,
    "slack_steps": Unit.DIMENSIONLESS, "max_slack": Unit.DIMENSIONLESS,
    "rebuilds": Unit.DIMENSIONLESS, "qp_compiled": Unit.DIMENSIONLESS,
    "qp_retries": Unit.DIMENSIONLESS, "qp_median_ms": Unit.WALL_TIME})


# --------------------------------------------------------------------------------------
# the hard model and its slack fallback
# --------------------------------------------------------------------------------------


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
    xc_map: np.ndarray  # the controlled robots in map units (sensing)
    near: np.ndarray | None = None  # sensed nearest obstacle points (n, n_obs, 2)
    dist: np.ndarray | None = None  # and distances (n, n_obs)


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
        ``statuses`` (count per Clarabel status), ``compiled`` (a model was built: its steps
        go through :class:`CompiledQP`, the only run-time path).
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
                                      "statuses": {}, "compiled": False}  # STATS_UNITS
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
        if not K or geo.dist is None or geo.near is None:  # near and dist are sensed together
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
        Weight of the formation error after the step (1/s^2 relative to the velocity term),
        at most 1e6 (the QP's conditioning).
    w_leader : float
        Weight of the leader's deviation from its pilot command (with ``leader_in_qp``), at
        most 1e6.
    w_s : float
        Linear weight of the obstacle-row slack in the slack fallback (exact penalty), at
        most 1e9.
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
        See :class:`~optplan.formation.pilot.PilotedFormation` (the leader's pilot,
        eq 52 and the run settings).
    """

    name: ClassVar[str] = "formation-qp"
    stats_units: ClassVar[Record] = STATS_UNITS
    summary_units: ClassVar[Record] = SUMMARY_UNITS
    # weights relative to the unit weight of the followers' feed-forward term; beyond 1e6
    # (1e9 for the exact-penalty slack) the QP's conditioning defeats Clarabel's tolerances
    w_f: float = option(4.0, lo=0.0, lo_open=True, hi=1e6)
    w_leader: float = option(10.0, lo=0.0, lo_open=True, hi=1e6)
    w_s: float = option(1e4, lo=0.0, lo_open=True, hi=1e9)
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
    """The QP's statistics for ``Result.extras`` (backend statistics, not metrics; units:
    :data:`SUMMARY_UNITS`)."""
    times = np.asarray(stats["solve_times"])
    return {"qp_failures": stats["qp_failures"], "qp_solves": stats["qp_solves"],
            "slack_steps": stats["slack_steps"], "max_slack": stats["max_slack"],
            "rebuilds": stats["rebuilds"], "qp_compiled": stats["compiled"],
            "qp_retries": stats["qp_retries"],
            "qp_median_ms": float(np.median(times) * 1e3) if len(times) else math.nan}

