r"""Hybrid planner: global path -> inflection points -> local planning -> formation (paper §V).

The paper's six steps (§V, Fig. 15) and how this backend realises them:

1. *Map.*  The scenario is the map; the global planner sees only ``problem.known_view()``
   (known static obstacles), the local planner senses everything (known, temporary and moving
   obstacles) through the simulator's :class:`~optplan.sim.ObstacleField`.
2. *Formation control.*  Followers are driven by the ``formation`` stage's
   ``followers_controller`` (a :class:`~optplan.interfaces.FormationBackend`: leader-follower
   L-phi with active avoidance, or the formation QP); ``formation = ""`` runs the leader alone.
3. *Global path.*  The ``global_solver`` stage's ``solve(problem.known_view())`` (IPSO in the
   paper, any path solver here).  An ``init`` path for a robot replaces this stage.
4. *Inflection points.*  :func:`inflection_points` scans the global path and keeps the vertices
   where it turns by more than ``angle_tol`` degrees; they become the sub-goals, followed by the
   final goal (:func:`subgoals`).
5. *Local planning.*  The leader is driven toward the current sub-goal by the
   ``local_solver`` stage's ``controller(problem, leader, rng)`` (a
   :class:`~optplan.interfaces.LocalPlanner`; SA-APF in the paper): the controller's
   ``velocity(state, index)`` is evaluated at every simulator step; the followers keep the
   formation around the leader at the same time, in one :func:`optplan.sim.simulate` run (the
   leader's command reaches their controller as ``state.leader_velocity``).

The stages are resolved when the backend is built (:attr:`Hybrid.stages`).
6. *Replanning.*  When the leader comes within ``reach_tol`` of an intermediate sub-goal the
   controller is ``reset`` to the next one; the run ends when the final goal is reached (and the
   followers have settled in their slots), on a collision, when the local planner gives up at
   the final goal, or at the step budget.

Inflection point (definition used here)
---------------------------------------
Let the global path be the polyline :math:`p_0, \dots, p_n` (consecutive duplicates removed)
and :math:`q` the last kept point (initially :math:`p_0`).  Vertex :math:`p_i`,
:math:`0 < i < n`, is an inflection (turning) point when the angle between the chord
:math:`p_i - q` and the outgoing segment :math:`p_{i+1} - p_i` exceeds ``angle_tol``:

.. math::

   \theta_i = \left|\operatorname{atan2}\big(c \times d,\; c \cdot d\big)\right| > \theta_{tol},
   \qquad c = p_i - q,\; d = p_{i+1} - p_i;

then :math:`q \leftarrow p_i`.  For a polyline with sharp corners this is exactly the set of
corners whose turning angle exceeds the tolerance; measuring against the chord from the last
kept point (rather than the incoming segment) also places sub-goals along gently curving, densely
sampled paths (a circular arc yields one sub-goal every :math:`\approx 2\theta_{tol}` of arc),
which a vertex-by-vertex test would skip entirely.

Choices where the paper is silent (documented in ``docs/solvers/hybrid.md``)
---------------------------------------------------------------------------
* A sub-goal is *reached* within ``reach_tol`` (default ``max(2 r, 2 v_max dt)``); the final
  goal within the scenario's goal tolerance.
* An intermediate sub-goal that lies inside a sensed temporary obstacle (distance to it below
  the robot radius, so the sub-goal is not a feasible position) is skipped as soon as the robot
  senses it; so is one the leader makes no progress toward for ``stall_steps`` steps, and one
  at which the local planner gives up.  At the final goal, giving up ends the run
  (status ``approximate``).
* The leader heading given to the formation controller is the direction of the leader's last
  non-zero commanded velocity; once the leader is at its goal it stops (zero velocity), and the
  run continues for at most ``settle_steps`` steps until every follower is within
  ``settle_tol`` (fraction of its ``L``) of its slot.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from optplan.canonical import canonical_problem, to_canonical, to_world
from optplan.interfaces import (
    FORMATION_BACKEND,
    LOCAL_PLANNER,
    PATH_SOLVER,
    FollowerController,
    LocalController,
    resolve_stage,
    stage_name,
)
from optplan.options import option
from optplan.potential.apf import RobotsAsObstacles
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Result, Status, notify
from optplan.sim import SimOutcome, SimState, simulate
from optplan.solver import Backend, make_rng

__all__ = ["Hybrid", "inflection_points", "subgoals", "turning_angles"]


# --------------------------------------------------------------------------------------
# pure functions (step 4)
# --------------------------------------------------------------------------------------


def _dedupe(path: np.ndarray, eps: float) -> np.ndarray:
    """Drop consecutive points closer than ``eps`` (keeps the first and the last point)."""
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        return p
    step = np.hypot(*np.diff(p, axis=0).T)
    keep = np.r_[True, step > eps]
    out = p[keep]
    if not np.array_equal(out[-1], p[-1]):
        out[-1] = p[-1]
    return out


def turning_angles(path: np.ndarray) -> np.ndarray:
    """Absolute turning angle (degrees) at every interior vertex, shape ``(n - 2,)``.

    The angle between the incoming and the outgoing segment directions: 0 for collinear
    points, 90 for a right-angle corner, 180 for a reversal.  Zero-length segments must have
    been removed (see :func:`inflection_points`).
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return np.zeros(0)
    a = p[1:-1] - p[:-2]
    b = p[2:] - p[1:-1]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.sum(a * b, axis=1)
    return np.degrees(np.abs(np.arctan2(cross, dot)))


def inflection_points(path: np.ndarray, angle_tol: float = 10.0, *,
                      return_index: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    r"""Inflection (turning) points of a polyline, paper §V step 4.

    Parameters
    ----------
    path : array, shape ``(n, 2)``
        The global path, first point = start, last point = goal.
    angle_tol : float
        Turning-angle tolerance :math:`\theta_{tol}` in degrees, ``0 <= angle_tol < 180``.
        A vertex is kept when the angle between the chord from the last kept point and the
        outgoing segment exceeds it (module docstring).
    return_index : bool
        Also return the indices of the kept vertices in the de-duplicated path.

    Returns
    -------
    points : array, shape ``(k, 2)``
        The inflection points in path order, excluding start and goal (``k`` may be 0).
    index : array of int, shape ``(k,)``
        Only with ``return_index``.

    Examples
    --------
    >>> inflection_points([[0, 0], [1, 0], [2, 0], [2, 1]], 10.0)
    array([[2., 0.]])
    """
    if not 0.0 <= float(angle_tol) < 180.0:
        raise ValueError(f"angle_tol must be in [0, 180) degrees, got {angle_tol!r}")
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    scale = max(1.0, float(np.abs(p).max())) if len(p) else 1.0
    p = _dedupe(p, 1e-9 * scale)
    kept: list[int] = []
    if len(p) >= 3:
        tol = math.radians(float(angle_tol))
        out_dir = np.diff(p, axis=0)  # outgoing segment of vertex i is out_dir[i]
        q = p[0]
        # a sequential scan: each decision depends on the last kept point (paths are short)
        for i in range(1, len(p) - 1):
            c = p[i] - q
            d = out_dir[i]
            ang = abs(math.atan2(c[0] * d[1] - c[1] * d[0], c[0] * d[0] + c[1] * d[1]))
            if ang > tol:
                kept.append(i)
                q = p[i]
    idx = np.asarray(kept, dtype=int)
    pts = p[idx] if len(idx) else np.zeros((0, 2))
    return (pts, idx) if return_index else pts


def subgoals(path: np.ndarray, goal: np.ndarray, angle_tol: float = 10.0,
             spacing: float = 0.0) -> np.ndarray:
    """The sub-goal sequence of step 4: the inflection points of ``path``, then ``goal``.

    With ``spacing > 0`` (an option beyond the paper) every leg of the polyline
    start -> inflection points -> goal is also split into equal pieces no longer than
    ``spacing`` (map units); the inflection points are kept.
    """
    pts = inflection_points(path, angle_tol)
    g = np.asarray(goal, dtype=float).reshape(1, 2)
    seq = np.vstack([pts, g])
    if spacing <= 0:
        return seq
    start = np.asarray(path, dtype=float).reshape(-1, 2)[0]
    prev = np.vstack([start[None], seq[:-1]])
    out = []
    for a, b in zip(prev, seq):
        # at most 100,000 pieces per leg: a tiny spacing cannot exhaust memory
        n = max(1, min(100_000, int(math.ceil(math.hypot(*(b - a)) / spacing))))
        f = np.arange(1, n + 1)[:, None] / n
        out.append(a + f * (b - a))
    return np.vstack(out)


# --------------------------------------------------------------------------------------
# the per-robot sub-goal tracker (steps 5-6)
# --------------------------------------------------------------------------------------


@dataclass
class _Driver:
    """A robot with its own goal, driven through its sub-goals by a local controller."""

    index: int
    robot: Robot
    goals: np.ndarray  # (k, 2), last = final goal
    controller: LocalController
    reach_tol: float
    goal_tol: float
    j: int = 0
    best: float = math.inf
    k_best: int = 0
    done: bool = False
    gave_up: bool = False
    heading: float = 0.0
    reached_at: list = field(default_factory=list)  # (sub-goal index, time, how)
    t_goal: float = math.nan

    @property
    def final(self) -> bool:
        return self.j == len(self.goals) - 1

    def advance(self, k: int, t: float, how: str) -> None:
        self.reached_at.append((self.j, float(t), how))
        self.j += 1
        self.best, self.k_best = math.inf, k
        self.controller.reset(self.goals[self.j].copy())


class _SubgoalTracker:
    """Step 6: moves every driving robot on to its next sub-goal.

    An intermediate sub-goal is left when it is reached (within ``reach_tol``; with
    ``reach_visible`` only once the next sub-goal is in sight, :meth:`next_visible`), sensed
    inside a temporary obstacle (``skip_blocked``) or not approached for ``stall_steps`` steps;
    the final goal is reached within the goal tolerance.  :meth:`update` is idempotent within a
    step.
    """

    def __init__(self, drivers: list[_Driver], *, skip_blocked: bool, stall_steps: int,
                 sensing: float | None, reach_visible: bool = False, unit: float = 1.0):
        self.drivers = drivers
        self.skip_blocked, self.stall_steps, self.sensing = skip_blocked, stall_steps, sensing
        self.reach_visible, self.unit = reach_visible, unit
        self._temp_mask: dict[int, np.ndarray] = {}

    @property
    def all_done(self) -> bool:
        return all(d.done for d in self.drivers)

    def update(self, state: SimState) -> None:
        for d in self.drivers:
            while not d.done and self._step(d, state):
                pass

    def _step(self, d: _Driver, state: SimState) -> bool:
        """One decision for driver ``d``; True when it moved on to another sub-goal."""
        dist = math.hypot(*(d.goals[d.j] - state.positions[d.index]))
        if d.final:
            if dist <= d.goal_tol:
                d.done, d.t_goal = True, float(state.t)
                d.reached_at.append((d.j, float(state.t), "reached"))
            return False
        how = ""
        if dist <= d.reach_tol and (not self.reach_visible or self.next_visible(d, state)):
            how = "reached"
        elif self.blocked(d, state):
            how = "blocked"
        elif dist < d.best - 0.1 * d.robot.radius:
            d.best, d.k_best = dist, state.k
        elif self.stall_steps and state.k - d.k_best > self.stall_steps:
            how = "stalled"
        if how:
            d.advance(state.k, state.t, how)
        return bool(how)

    def next_visible(self, d: _Driver, state: SimState) -> bool:
        """The straight segment from the robot to its next sub-goal keeps the robot disc clear
        of the known static obstacles (samples every half radius, at most 2000)."""
        if d.j + 1 >= len(d.goals):
            return True
        fld = state.field
        temp = self._temp(fld)
        known = ~temp[:fld.n_static]
        if not known.any():
            return True
        x = np.asarray(state.positions[d.index], dtype=float)
        g = d.goals[d.j + 1]
        r = d.robot.radius
        h = max(0.5 * r, 1e-3 * self.unit)
        n = int(min(2000, max(2, math.ceil(math.hypot(*(g - x)) / h) + 1)))
        pts = x + np.linspace(0.0, 1.0, n)[:, None] * (g - x)
        _, dist = fld.nearest(pts, state.t, max_range=r + h)
        return not bool(np.any(dist[:, :fld.n_static][:, known] < r))

    def _temp(self, fld: Any) -> np.ndarray:
        """Per obstacle of ``fld``: is it a temporary (``known = false``) static obstacle."""
        temp = self._temp_mask.get(id(fld))
        if temp is None:
            temp = np.array([not o.known for o in fld.static] + [False] * (fld.n - fld.n_static),
                            dtype=bool)
            self._temp_mask[id(fld)] = temp
        return temp

    def blocked(self, d: _Driver, state: SimState) -> bool:
        """The current sub-goal lies inside a sensed temporary obstacle."""
        fld = state.field
        if not self.skip_blocked or fld.n_static == 0:
            return False
        temp = self._temp(fld)
        if not temp.any():
            return False
        g = d.goals[d.j]
        if self.sensing is not None and math.hypot(*(g - state.positions[d.index])) > \
                self.sensing:
            return False
        _, dist = fld.nearest(g, state.t, max_range=d.robot.radius)
        return bool(np.any(dist[0][temp] < d.robot.radius))


class _StageCallback:
    """Forwards the stages' progress with a running iteration offset; remembers a stop."""

    def __init__(self, callback: Callable[[Progress], Any] | None, unit: float = 1.0):
        self.callback = callback
        self.offset = 0
        self.stopped = False
        self.unit = unit  # world length of a canonical unit (best_cost is a length)

    def __call__(self, p: Progress) -> None:
        info = {k: v * self.unit if k in _LENGTH_INFO else v for k, v in p.info.items()}
        q = Progress(p.iteration + self.offset, p.best_cost * self.unit, p.n_eval, p.elapsed,
                     info, p.sim_time)
        if notify(self.callback, q):
            self.stopped = True
            raise StopIteration

    @property
    def forward(self) -> Callable[[Progress], Any] | None:
        """What to pass to a stage: this object, or None without a callback."""
        return self if self.callback is not None else None


# --------------------------------------------------------------------------------------
# the policy (step 5): the drivers' local controllers and the followers' controller
# --------------------------------------------------------------------------------------


@dataclass
class _Team:
    """Who drives itself (with a goal) and who follows, in simulation order."""

    drivers: list[Robot]
    follower_ids: list[str]
    ids: list[str]
    use_formation: bool


class _HybridPolicy:
    """The simulator's policy, ``done`` test and progress cost of one hybrid run."""

    def __init__(self, opts: Hybrid, problem: Problem, team: _Team, drivers: list[_Driver],
                 tracker: _SubgoalTracker, fctrl: FollowerController | None):
        self.o, self.problem, self.team, self.drivers = opts, problem, team, drivers
        self.tracker, self.fctrl = tracker, fctrl
        lid = problem.leader.id
        self.lead = next((d for d in drivers if d.robot.id == lid), drivers[0])
        self.f_idx = [team.ids.index(f) for f in team.follower_ids] if fctrl else []
        form = problem.formation
        self.L = np.array([f.L for f in form.followers]) if fctrl else np.zeros(0)
        self.k_arrived: int | None = None
        self.gave_up: list[str] = []
        # several drivers (no formation between them): each one's local planner senses the
        # other drivers as discs where they are now, as run_local_planner does (sense_robots)
        planner = opts.stages["local_solver"]
        self.sense_others = len(drivers) > 1 and bool(getattr(planner, "sense_robots", True))
        self._d_idx = np.array([d.index for d in drivers], dtype=int)
        self._d_rad = np.array([d.robot.radius for d in drivers], dtype=float)

    def __call__(self, state: SimState) -> np.ndarray | None:
        u = np.zeros((len(self.team.ids), 2))
        for d in self.drivers:
            if d.done:
                continue
            v = self._drive(d, state)
            if v is None:
                return None
            u[d.index] = v
        if self.fctrl is not None and not self._followers(u, state):
            return None
        return u

    def _drive(self, d: _Driver, state: SimState) -> np.ndarray | None:
        """Driver ``d``'s command (capped, heading updated), or None when it gave up."""
        if self.sense_others:
            o = self._d_idx != d.index
            state = dataclasses.replace(state, field=RobotsAsObstacles(
                state.field, state.positions[self._d_idx[o]], self._d_rad[o]))
        v = d.controller.velocity(state, d.index)
        while v is None and not d.final:
            d.advance(state.k, state.t, "gave_up")
            v = d.controller.velocity(state, d.index)
        if v is None:
            d.gave_up = True
            self.gave_up.append(f"{d.robot.id}: local planner gave up at t={state.t:.2f}")
            return None
        v = np.asarray(v, dtype=float).reshape(2)
        if not np.all(np.isfinite(v)):
            d.gave_up = True
            self.gave_up.append(f"{d.robot.id}: local planner returned {v} at t={state.t:.2f}")
            return None
        sp = math.hypot(*v)
        cap = self.o.v_factor * d.robot.max_speed
        if self.fctrl is not None and sp > cap:
            v = v * (cap / sp)
        if sp * state.dt > 1e-9 * self.problem.length_scale:
            want = float(math.atan2(v[1], v[0]))
            if self.o.heading_rate > 0:
                dth = (want - d.heading + math.pi) % (2 * math.pi) - math.pi
                lim = self.o.heading_rate * state.dt
                want = d.heading + max(-lim, min(lim, dth))
            d.heading = want
        return v

    def _followers(self, u: np.ndarray, state: SimState) -> bool:
        """The followers' commands into ``u``; False on non-finite output."""
        li = self.lead.index
        state.leader_velocity = u[li].copy()
        uf = self.fctrl.velocities(state, li, self.f_idx, self.lead.heading)
        uf = np.asarray(uf, dtype=float).reshape(len(self.f_idx), 2)
        if not np.all(np.isfinite(uf)):
            self.gave_up.append(f"formation controller returned non-finite velocities at "
                                f"t={state.t:.2f}")
            return False
        u[self.f_idx] = uf
        return True

    def followers_settled(self, positions: np.ndarray) -> bool:
        if self.fctrl is None:
            return True
        slots = positions[self.lead.index] + self.problem.formation.slot_offsets(
            self.lead.heading)
        err = np.hypot(*(positions[self.f_idx] - slots).T)
        return bool(np.all(err <= self.o.settle_tol * self.L))

    def done(self, state: SimState) -> bool:
        self.tracker.update(state)
        if not self.tracker.all_done:
            return False
        if self.k_arrived is None:
            self.k_arrived = state.k
        return (self.followers_settled(state.positions)
                or state.k - self.k_arrived >= self.o.settle_steps)

    def progress_cost(self, state: SimState) -> float:
        return float(math.hypot(*(state.positions[self.lead.index] - self.lead.robot.goal)))


# --------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------


@dataclass
class _GlobalStage:
    """Step 3's outcome: a path per driving robot."""

    paths: dict[str, np.ndarray]
    result: Result | None = None
    wall_time: float = 0.0
    messages: list[str] = field(default_factory=list)


@dataclass(frozen=True, kw_only=True)
class Hybrid(Backend):
    r"""Hybrid planner of paper §V (Fig. 15): global path, inflection points, local planning.

    Parameters
    ----------
    global_solver : str or Backend
        Preset (or backend) planning each driving robot's path on ``problem.known_view()``
        (step 3): any solver (:data:`optplan.interfaces.PATH_SOLVER`).  Paper: IPSO; default
        ``"ipso"``, the documented variant, because the literal ``"ipso-paper"`` (eq 24) is
        not collision-free in every run (counts on the hybrid page).
    local_solver : str or Backend
        A :class:`~optplan.interfaces.LocalPlanner` whose ``controller(problem, robot_id,
        rng)`` drives the leader between sub-goals (step 5).  Paper: SA-APF,
        ``"sa-apf-paper"``.
    formation : str or Backend
        A :class:`~optplan.interfaces.FormationBackend` whose ``followers_controller(problem,
        rng)`` drives the followers (step 2/5): ``"leader-follower-paper"`` (paper),
        ``"formation-qp"``, or ``""`` to run the leader(s) alone.  Ignored for problems without
        a ``[formation]``.
    angle_tol : float
        Inflection-point tolerance :math:`\theta_{tol}` (degrees, ``[0, 180)``): a vertex of the
        global path is a sub-goal when the path turns there by more than this (step 4; see
        :func:`inflection_points`).
    leader_rho_0 : float or None
        Influence distance of the leader's local planner (x length_scale): replaces the
        ``local_solver``'s ``rho_0``.  ``None`` keeps the local planner's own (``sa-apf-paper``:
        20, eq 34); the paper's formation pilot (eq 41) uses 100.
    subgoal_spacing : float
        ``0`` (paper): the sub-goals are the inflection points and the goal.  ``> 0`` (an
        option beyond the paper): also split every leg between sub-goals into pieces no longer
        than this (x length_scale), see :func:`subgoals`.
    dt : float
        Simulation time step (s), ``(0, 10]``.
    max_steps : int
        Step budget of the whole run (including follower settling).
    reach_tol : float
        Distance (x length_scale) at which an intermediate sub-goal counts as reached (step 6);
        ``0`` means automatic, ``max(2 r, 2 v_max dt)`` with ``r``, ``v_max`` the robot's radius
        and speed.  The final goal uses the scenario's goal tolerance.
    reach_visible : bool
        ``False`` (paper): an intermediate sub-goal is reached within ``reach_tol``.  ``True``
        (beyond the paper): also require the straight segment to the next sub-goal to be clear
        of the known static obstacles, so the leader does not turn toward the next sub-goal
        before it has rounded the corner (the stall rule still skips it).
    stall_steps : int
        Skip an intermediate sub-goal after this many steps without getting closer to it by at
        least a tenth of the robot radius (``0`` disables; choice beyond the paper).
    skip_blocked : bool
        Skip an intermediate sub-goal found (by sensing) to lie inside a temporary obstacle.
    settle_steps : int
        Extra steps allowed, after the leader reached its goal, for the followers to settle.
    v_factor : float
        With followers, the leader's speed is capped at ``v_factor * max_speed`` so the
        followers have speed headroom to hold their slots in turns (``(0, 1]``; the same
        convention as the formation backends).  Without followers the leader uses its full
        speed.
    heading_rate : float
        ``0`` (paper): the formation frame turns with the leader's velocity direction at once.
        ``> 0`` (beyond the paper): the heading passed to the formation controller turns at
        most this fast (rad/s), so the slots swing round smoothly at sharp turns.
    settle_tol : float
        A follower has settled when within ``settle_tol * L`` of its slot (``(0, 1]``; a
        fraction of the formation distance ``L``, so it scales with the scene).
    stop_on_collision : bool
        Stop the simulation at the first contact (the result is then ``approximate``).

    Notes
    -----
    The three stage options are resolved when the backend is built (:attr:`stages`): a name
    that is no solver, or names a solver of the wrong kind (e.g. ``local_solver =
    "visgraph"``), raises ``ValueError`` naming the option, the kind expected and close
    matches.
    """

    name: ClassVar[str] = "hybrid"

    global_solver: Any = option("ipso", kind="any")
    local_solver: Any = option("sa-apf-paper", kind="any")
    formation: Any = option("leader-follower-paper", kind="any")
    leader_rho_0: float | None = option(None, lo=0.0, lo_open=True, scale=True)
    angle_tol: float = option(10.0, lo=0.0, hi=180.0, hi_open=True)
    subgoal_spacing: float = option(0.0, lo=0.0, scale=True)
    dt: float = option(0.1, lo=0.0, hi=10.0, lo_open=True)
    max_steps: int = option(20000, lo=1, hi=10_000_000)
    reach_tol: float = option(0.0, lo=0.0, scale=True)
    reach_visible: bool = option(False)
    stall_steps: int = option(300, lo=0, hi=10_000_000)
    skip_blocked: bool = option(True)
    settle_steps: int = option(400, lo=0, hi=10_000_000)
    settle_tol: float = option(0.1, lo=0.0, hi=1.0, lo_open=True)
    v_factor: float = option(0.75, lo=0.0, hi=1.0, lo_open=True)
    heading_rate: float = option(0.0, lo=0.0)
    stop_on_collision: bool = option(True)
    _stages: dict[str, Any] = field(init=False, repr=False, compare=False, default=None)

    def check(self) -> None:
        """Resolve the three stages (names of the wrong kind raise ``ValueError``) and check
        that ``leader_rho_0`` can be applied to the local planner."""
        local = resolve_stage(self.name, "local_solver", self.local_solver, LOCAL_PLANNER)
        if self.leader_rho_0 is not None:
            if not hasattr(local, "rho_0"):
                raise ValueError(f"option 'leader_rho_0' of backend 'hybrid': the local planner "
                                 f"{stage_name(self.local_solver)!r} has no option 'rho_0' "
                                 "(set leader_rho_0 = None to use it as it is)")
            prev = local
            try:
                local = dataclasses.replace(prev, rho_0=float(self.leader_rho_0))
            except ValueError as e:
                raise ValueError(f"option 'leader_rho_0' of backend 'hybrid': {e}") from None
            object.__setattr__(local, "_preset", getattr(prev, "_preset", None))
        stages = {
            "global_solver": resolve_stage(self.name, "global_solver", self.global_solver,
                                           PATH_SOLVER),
            "local_solver": local,
            "formation": (None if isinstance(self.formation, str) and self.formation == ""
                          else resolve_stage(self.name, "formation", self.formation,
                                             FORMATION_BACKEND)),
        }
        object.__setattr__(self, "_stages", stages)

    @property
    def stages(self) -> dict[str, Any]:
        """The resolved stages: ``global_solver`` (Backend), ``local_solver``
        (:class:`~optplan.interfaces.LocalPlanner`) and ``formation``
        (:class:`~optplan.interfaces.FormationBackend`, or None for ``formation = ""``)."""
        return self._stages

    def options(self) -> dict[str, Any]:
        out = super().options()
        for k in ("global_solver", "local_solver", "formation"):
            out[k] = stage_name(out[k])
        return out

    # ---------------------------------------------------------------------------------
    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        t_start = time.perf_counter()
        world, problem = problem, canonical_problem(problem)
        rng = make_rng(rng)[0]
        rng_global, rng_local, rng_form = rng.spawn(3)
        cb = _StageCallback(callback, problem.world_unit)
        team = self._team(problem)
        if init:
            init = {k: to_canonical(problem, v) for k, v in init.items()}
        glob = self._global_stage(problem, team, init, rng_global, cb, t_start)
        if isinstance(glob, dict):
            return self._world_result(world, problem, glob)
        drivers = self._drivers(problem, team, glob.paths, rng_local)
        fctrl = (self.stages["formation"].followers_controller(problem, rng_form)
                 if team.use_formation else None)
        tracker = _SubgoalTracker(drivers, skip_blocked=self.skip_blocked,
                                  stall_steps=self.stall_steps, sensing=problem.sensing_range,
                                  reach_visible=self.reach_visible, unit=problem.length_scale)
        policy = _HybridPolicy(self, problem, team, drivers, tracker, fctrl)
        try:
            out = simulate(problem, policy, ids=team.ids, dt=self.dt, max_steps=self.max_steps,
                           done=policy.done, stop_on_collision=self.stop_on_collision,
                           callback=cb.forward, progress_cost=policy.progress_cost)
        except (np.linalg.LinAlgError, FloatingPointError, ArithmeticError) as e:
            answer = self._early(problem, team.ids, glob.result,
                                 f"numerical failure in the simulation: {e}", t_start,
                                 Status.failed)
        else:
            answer = self._assemble(glob, policy, out, t_start)
        return self._world_result(world, problem, answer)

    def _world_result(self, world: Problem, image: Problem, answer: dict[str, Any]) -> Result:
        """The answer planned on the canonical ``image`` mapped back to ``world`` (x its unit;
        each path starts at the robot's exact start) and graded there by the validator."""
        u = image.world_unit
        paths = {}
        for rid, p in answer.pop("paths").items():
            p = np.array(p, dtype=float) * u
            p[0] = world.robot(rid).start
            paths[rid] = p
        hist = answer.pop("history", None)
        if hist is not None:
            hist = History({k: (to_world(hist[k].tolist(), u) if k in _LENGTH_COLUMNS
                                else hist[k].tolist()) for k in hist.keys()})
        extras = answer.pop("extras")
        extras = {k: _extra_to_world(v, _LENGTH_EXTRAS[k], u) if k in _LENGTH_EXTRAS else v
                  for k, v in extras.items()}
        extras["canonical_unit"] = u
        return self.finish(world, paths, cost=answer.pop("cost", float("nan")) * u,
                           history=hist, extras=extras, **answer)

    # -- which robots drive themselves, which follow -----------------------------------
    def _team(self, problem: Problem) -> _Team:
        form = problem.formation
        use = bool(form is not None and self.stages["formation"] is not None)
        follower_ids = [f.id for f in form.followers] if form is not None else []
        drivers = [r for r in problem.robots if r.id not in follower_ids and r.goal is not None]
        if form is not None and not use:
            drivers = [problem.leader]
        ids = [r.id for r in drivers] + (follower_ids if use else [])
        return _Team(drivers, follower_ids if use else [], ids, use)

    # -- step 3: global paths on the known map -----------------------------------------
    def _global_stage(self, problem: Problem, team: _Team, init: dict[str, np.ndarray] | None,
                      rng: np.random.Generator, cb: _StageCallback,
                      t_start: float) -> _GlobalStage | Result:
        out = _GlobalStage({})
        need = [r for r in team.drivers if not (init and r.id in init)]
        if need:
            t0 = time.perf_counter()
            gres = self.stages["global_solver"].solve(problem.known_view(), rng=rng,
                                                      callback=cb.forward)
            out.result, out.wall_time = gres, time.perf_counter() - t0
            cb.offset += max(gres.n_iter, len(gres.history))
            if cb.stopped:
                return self._early(problem, team.ids, gres, "stopped by callback during the "
                                   "global stage", t_start)
            if gres.status is Status.infeasible:
                return self._early(problem, team.ids, gres, "global planner: no path exists on "
                                   f"the known map ({gres.message})", t_start, Status.infeasible)
            for r in need:
                p = gres.paths.get(r.id)
                if p is None or len(p) < 2 or gres.status is Status.failed:
                    out.messages.append(f"global stage gave no path for {r.id} "
                                        f"({gres.status.value}); heading straight for the goal")
                    p = np.vstack([r.start, r.goal])
                out.paths[r.id] = np.asarray(p, dtype=float)
            if gres.status not in (Status.optimal, Status.solved):
                out.messages.append(f"global path {gres.status.value} on the known map")
        for r in team.drivers:
            if init and r.id in init:
                out.paths[r.id] = np.vstack([r.start, np.asarray(init[r.id], dtype=float)[1:]])
        return out

    # -- step 4: inflection points -> sub-goals, one local controller per driver -------
    def _drivers(self, problem: Problem, team: _Team, gpaths: dict[str, np.ndarray],
                 rng: np.random.Generator) -> list[_Driver]:
        planner = self.stages["local_solver"]
        rngs = rng.spawn(len(team.drivers))
        drivers = []
        for i, r in enumerate(team.drivers):
            goals = subgoals(gpaths[r.id], r.goal, self.angle_tol,
                             self.subgoal_spacing * problem.length_scale)
            ctrl = planner.controller(problem, r.id, rngs[i])
            ctrl.reset(goals[0].copy())
            reach = (self.reach_tol * problem.length_scale
                     or max(2.0 * r.radius, 2.0 * r.max_speed * self.dt))
            g = r.goal - r.start
            drivers.append(_Driver(team.ids.index(r.id), r, goals, ctrl, reach,
                                   problem.goal_tol(r), heading=float(math.atan2(g[1], g[0]))))
        return drivers

    # -- the result ----------------------------------------------------------------------
    def _assemble(self, glob: _GlobalStage, policy: _HybridPolicy, out: SimOutcome,
                  t_start: float) -> dict[str, Any]:
        paths = out.paths()
        claim, msg = self._outcome(glob, policy, out)
        ld = policy.lead
        lp = paths[ld.robot.id]
        dist_goal = np.hypot(*(lp - ld.robot.goal).T)
        hist = History({
            "iteration": list(range(len(out.times))),
            "best_cost": np.minimum.accumulate(dist_goal).tolist(),
            "dist_to_goal": dist_goal.tolist(),
            "n_eval": list(range(len(out.times))),
            "time": out.times.tolist(),
        })
        n_eval = glob.result.n_eval if glob.result is not None else 0
        return dict(
            paths=paths, claim=claim, times=out.times,
            cost=float(np.sum(np.hypot(*np.diff(lp, axis=0).T))), message=msg,
            n_iter=out.steps, n_eval=n_eval + out.steps, history=hist,
            extras=self._extras(glob, policy, out), wall_time=time.perf_counter() - t_start,
        )

    def _outcome(self, glob: _GlobalStage, policy: _HybridPolicy,
                 out: SimOutcome) -> tuple[Status, str]:
        if out.reason == "done" and policy.tracker.all_done:
            claim, msg = Status.solved, "every sub-goal sequence completed"
        else:
            claim = Status.approximate
            msg = {"collision": f"collision: {out.collision}",
                   "budget": f"step budget ({self.max_steps}) exhausted",
                   "gave_up": "; ".join(policy.gave_up) or "local planner gave up",
                   "callback": "stopped by callback"}.get(out.reason, out.reason)
        notes = list(glob.messages)
        if (policy.k_arrived is not None and policy.fctrl is not None and out.reason == "done"
                and not policy.followers_settled(out.positions[-1])):
            notes.append("followers did not settle within settle_steps")
        return claim, "; ".join([msg, *notes])

    def _extras(self, glob: _GlobalStage, policy: _HybridPolicy,
                out: SimOutcome) -> dict[str, Any]:
        ld, gres, fctrl = policy.lead, glob.result, policy.fctrl
        gpath = glob.paths[ld.robot.id]
        return {
            "global_path": gpath,
            "inflection_points": inflection_points(gpath, self.angle_tol),
            "subgoals": ld.goals,
            "global_paths": glob.paths,
            "subgoal_sequences": {d.robot.id: d.goals for d in policy.drivers},
            "global_solver": stage_name(self.global_solver),
            "local_solver": stage_name(self.local_solver),
            "formation_solver": stage_name(self.formation) if fctrl is not None else "",
            "global_status": gres.status.value if gres is not None else "init",
            "global_length": float(np.sum(np.hypot(*np.diff(gpath, axis=0).T))),
            "global_metrics": _small_metrics(gres.metrics) if gres is not None else {},
            "global_wall_time": glob.wall_time,
            "subgoal_events": {d.robot.id: [{"subgoal": j, "t": t, "how": h}
                                            for j, t, h in d.reached_at]
                               for d in policy.drivers},
            "subgoal_times": [t for _, t, _ in ld.reached_at],
            "time_to_goal": ld.t_goal,
            "local_stats": {d.robot.id: dict(d.controller.stats) for d in policy.drivers},
            "leader_field": _field_summary(ld.controller),
            "formation_stats": dict(fctrl.stats) if fctrl is not None else {},
            "sim_reason": out.reason,
            "contacts": list(out.contacts),
            "dt": self.dt,
        }

    def _early(self, problem: Problem, ids: list[str], gres: Result | None, msg: str,
               t_start: float, status: Status = Status.approximate) -> dict[str, Any]:
        """The answer when the run ends before the simulation: robots stay at their starts."""
        paths = {i: problem.robot(i).start[None, :].copy() for i in ids}
        extras: dict[str, Any] = {"global_status": gres.status.value if gres else "none"}
        if gres is not None:
            lp = gres.paths.get(problem.leader.id)
            if lp is not None:
                extras["global_path"] = np.asarray(lp)
                extras["inflection_points"] = inflection_points(lp, self.angle_tol)
        return dict(paths=paths, claim=status, times=np.zeros(1), message=msg,
                    n_eval=gres.n_eval if gres else 0, extras=extras,
                    wall_time=time.perf_counter() - t_start)


#: Progress.info entries of the stages that are lengths (mapped back from the canonical frame).
_LENGTH_INFO = ("feasible_best_length",)
#: History columns that are lengths (mapped back from the canonical frame).
_LENGTH_COLUMNS = ("best_cost", "dist_to_goal")
#: Extras whose values are points or lengths (mapped back from the canonical frame).
#: ``None``: the whole value; a tuple: those keys of a dict value.
_LENGTH_EXTRAS: dict[str, tuple[str, ...] | None] = {
    "global_path": None, "inflection_points": None, "subgoals": None, "global_paths": None,
    "subgoal_sequences": None, "global_length": None, "leader_field": None,
    "global_metrics": ("length", "min_clearance"), "formation_stats": ("max_slack",)}


def _extra_to_world(value: Any, keys: tuple[str, ...] | None, unit: float) -> Any:
    """An extras value of the canonical run in world units (``keys``: :data:`_LENGTH_EXTRAS`)."""
    if keys is None:
        return to_world(value, unit)
    return {k: to_world(v, unit) if k in keys else v for k, v in value.items()}


def _field_summary(ctrl: LocalController) -> dict:
    """The leader's potential-field lengths (map units) when its controller has them."""
    p = getattr(ctrl, "params", None)
    if p is None:
        return {}
    return {"rho_0": float(p.rho_0), "sense_range": float(p.sense_range),
            "length_scale": float(p.unit)}


def _small_metrics(m: dict) -> dict:
    keep = ("feasible", "length", "collisions", "static_collisions", "min_clearance", "reached")
    return {k: m[k] for k in keep if k in m}
