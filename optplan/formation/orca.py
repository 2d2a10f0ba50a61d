r"""Backend ``orca``: optimal reciprocal collision avoidance (RVO2, through ``pyrvo``).

ORCA (van den Berg, Guy, Lin and Manocha, *Reciprocal n-body collision avoidance*, ISRR 2011):
every agent, every step, chooses the velocity closest to its *preferred* velocity among those
that keep it collision-free for the next ``time_horizon`` seconds against every neighbour, each
neighbour taking half of the avoidance, and for ``time_horizon_obst`` seconds against the
obstacles: a small linear program in the plane per agent (docs/solvers/orca.md).  The scene is
put into RVO2 by :mod:`optplan.formation.orca_world` (robots as agents, static obstacles as
polygons, a circle as the polygon circumscribed about it, the bounds as a wall, moving
obstacles as agents with prescribed velocities).

The run steps in time on :func:`optplan.sim.simulate` (its ``dt``, ``max_steps``, the stop at the
goal, a contact stops the run, the timed trajectories in ``Result.times``): each step gives RVO2
the robots' positions and velocities and the movers' positions and velocities at that time, sets
each robot's preferred velocity, lets RVO2 solve every agent's LP (``do_step``) and moves the
robots by the velocities it chose.  Preferred velocities:

* every planned robot (``team = false``) toward its goal at ``speed_factor * max_speed``
  (slowing so as to stop on it), or along the certified shortest path of the known map
  (``subgoals = "visgraph"``): toward the farthest of its next waypoints RVO2 sees with the
  robot's radius, a waypoint within ``subgoal_reach`` counting as passed;
* ``team = true`` (a ``[formation]``): the leader so, the followers toward their L-phi slots
  (:func:`optplan.formation.slots.slot_positions`) about where the leader's preferred velocity
  takes it this step, with the heading of that velocity.

The result is graded by the shared validator, exactly and in continuous time: whatever the
polygons, the single precision of RVO2 or a non-reciprocating mover let through is a collision
in the metrics.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from optplan.formation.orca_lp import full_share, orca_velocity
from optplan.formation.orca_world import (
    AgentParams,
    LocalFrame,
    Movers,
    build_world,
    require_pyrvo,
)
from optplan.formation.slots import slot_positions
from optplan.geometry.collision import farthest_clear, path_lengths
from optplan.geometry.tangent import problem_shortest_path
from optplan.problem import Problem, Robot
from optplan.result import History, Progress, Result, Status
from optplan.sim import SimOutcome, SimState, simulate
from optplan.solver import Backend, make_rng, option
from optplan.units import Each, Record, Unit

__all__ = ["ORCA", "EXTRAS_UNITS"]

#: The units of the result's extras (:mod:`optplan.units`).
EXTRAS_UNITS = Record({
    "sim_steps": Unit.DIMENSIONLESS, "sim_reason": Unit.TEXT, "collision": Unit.TEXT,
    "time_to_goal": Unit.TIME, "length_scale": Unit.LENGTH, "agents": Unit.DIMENSIONLESS,
    "mover_agents": Unit.DIMENSIONLESS, "obstacle_vertices": Unit.DIMENSIONLESS,
    "subgoals": Each(Unit.POINT)})

#: Waypoints ahead of the current one that the sub-goal tracker tests for visibility.
LOOKAHEAD = 40

#: The leader's track is searched every this many steps for a point a follower sees ...
TRAIL_STRIDE = 5
#: ... at most this many points back.
TRAIL_POINTS = 60

#: A robot whose velocity differed from its preferred one by more than this fraction of its
#: max_speed on the last step was held back by ORCA (and gets the ``perturb`` jitter).
HELD_FRACTION = 0.01

#: A robot whose net displacement over ``stall_time`` is below this fraction of
#: ``max_speed * stall_time`` has stalled.
STALL_FRACTION = 0.05


class _Waypoints:
    """One robot's sub-goals (local coordinates) and its progress along them."""

    def __init__(self, points: np.ndarray):
        self.points = np.asarray(points, dtype=float)
        self.i = 0

    def target(self, sim: Any, p: np.ndarray, reach: float, r_vis: float) -> tuple[np.ndarray,
                                                                                   bool]:
        """The current sub-goal of a robot at ``p`` and whether it is the last one.

        Waypoints within ``reach`` are passed; then the farthest of the next
        :data:`LOOKAHEAD` waypoints that RVO2 sees from ``p`` with clearance ``r_vis``
        (``query_visibility``) becomes the current one.
        """
        w, last = self.points, len(self.points) - 1
        while self.i < last and np.hypot(*(w[self.i] - p)) <= reach:
            self.i += 1
        j = farthest_clear(p, w, lambda a, Q: [_rvo_sees(sim, a, Q[0], r_vis)],
                           range(self.i + 1, min(last, self.i + LOOKAHEAD) + 1), chunk=1)
        if j is not None:
            self.i = j
        return w[self.i], self.i == last


def _rvo_sees(sim: Any, p: np.ndarray, q: np.ndarray, radius: float) -> bool:
    """Whether RVO2 sees ``q`` from ``p`` with clearance ``radius`` (``query_visibility``)."""
    return bool(sim.query_visibility((float(p[0]), float(p[1])), (float(q[0]), float(q[1])),
                                     float(radius)))


def _toward(p: np.ndarray, target: np.ndarray, speed: float, dt: float, stop: bool) -> np.ndarray:
    """Velocity from ``p`` toward ``target`` at ``speed``; with ``stop``, slowed so as to land
    on it at the end of the step."""
    d = target - p
    n = float(np.hypot(*d))
    if n == 0.0:
        return np.zeros(2)
    return d / n * (min(speed, n / dt) if stop else speed)


class _OrcaRun:
    """One ORCA simulation: the policy, ``done`` test, progress cost and history of
    :func:`optplan.sim.simulate` for :class:`ORCA` (module docstring)."""

    def __init__(self, o: ORCA, problem: Problem, robots: list[Robot],
                 subgoals: dict[str, np.ndarray], rng: np.random.Generator):
        self.o, self.problem, self.robots, self.rng = o, problem, robots, rng
        self.ids = [r.id for r in robots]
        self.frame = LocalFrame.of(problem)
        u = self.frame.unit
        self.params = AgentParams(o.neighbor_dist, o.max_neighbors, o.time_horizon,
                                  o.time_horizon_obst, o.margin)
        self.movers = Movers(problem)
        self.sim, self.n_vertices = build_world(problem, robots, self.frame, self.params, o.dt,
                                                o.circle_sides, self.movers)
        self.vmax = np.array([r.max_speed for r in robots]) / u
        self.radius = np.array([r.radius for r in robots]) / u
        form = problem.formation if o.team else None
        self.slots = ((np.array([f.L for f in form.followers]) / u,
                       np.array([f.phi for f in form.followers])) if form else None)
        self.goals, self.way = self._targets(subgoals, team=form is not None)
        self.tol = np.array([problem.goal_tol(r) for r in robots]) / u
        self.heading = self._first_heading()
        self.window = max(1, round(o.stall_time / o.dt)) if o.stall_time > 0 else 0
        self.track: list[np.ndarray] = []
        self.last_pref = np.zeros((len(robots), 2))
        self.trail: list[np.ndarray] = []
        self.stalled = False
        self.hist = History()

    def _targets(self, subgoals: dict[str, np.ndarray], team: bool
                 ) -> tuple[dict[int, np.ndarray], dict[int, _Waypoints]]:
        """The goals of the goal-seeking robots (the leader alone in a team) and the sub-goal
        trackers of those with sub-goals, by robot index (local coordinates)."""
        goals: dict[int, np.ndarray] = {}
        for i, r in enumerate(self.robots):
            if r.goal is not None and not (team and i > 0):
                goals[i] = self.frame.local(r.goal)
        way = {i: _Waypoints(self.frame.local(subgoals[r.id]))
               for i, r in enumerate(self.robots) if r.id in subgoals}
        return goals, way

    def _first_heading(self) -> float:
        """The formation frame's heading before the leader moves: toward its first sub-goal,
        else its goal (0 without either)."""
        first = self.way[0].points[0] if 0 in self.way else self.goals.get(0)
        if first is None:
            return 0.0
        d0 = first - self.frame.local(self.robots[0].start)
        return float(np.arctan2(d0[1], d0[0]))

    # -- preferred velocities --------------------------------------------------------------
    def _goal_velocity(self, i: int, p: np.ndarray) -> np.ndarray:
        """Robot ``i``'s preferred velocity toward its goal or current sub-goal (local); zero
        within its goal tolerance (a robot at its goal holds still unless pushed)."""
        if np.hypot(*(p - self.goals[i])) <= self.tol[i]:
            return np.zeros(2)
        speed = self.o.speed_factor * self.vmax[i]
        if i in self.way:
            target, last = self.way[i].target(self.sim, p, self.o.subgoal_reach, self.radius[i])
        else:
            target, last = self.goals[i], True
        return _toward(p, target, speed, self.o.dt, last)

    def preferred(self, P: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Every robot's preferred velocity (local units), given their local positions and
        which robots ORCA held back on the last step (those get the ``perturb`` jitter)."""
        V = np.zeros_like(P)
        for i in self.goals:
            V[i] = self._goal_velocity(i, P[i])
            if self.o.perturb > 0 and held[i] and np.any(V[i]):
                V[i] += self._jitter(i)
        if self.slots is not None:
            vl = V[0]
            if np.hypot(*vl) > 1e-6 * self.vmax[0]:
                self.heading = float(np.arctan2(vl[1], vl[0]))
            s = slot_positions(P[0] + self.o.dt * vl, self.heading, *self.slots)
            self.trail.append(P[0].copy())
            for k in range(1, len(P)):
                target = s[k - 1]
                if self.o.trail and not self._sees(P[k], target, k):
                    target = self._trail_point(P[k], k, target)
                V[k] = _toward(P[k], target, self.vmax[k], self.o.dt, True)
        return V

    def _jitter(self, i: int) -> np.ndarray:
        """A velocity uniform in the disc of radius ``perturb * max_speed`` (from ``rng``)."""
        a, r = self.rng.uniform(0.0, 2.0 * np.pi), np.sqrt(self.rng.uniform())
        return self.o.perturb * self.vmax[i] * r * np.array([np.cos(a), np.sin(a)])

    def _sees(self, p: np.ndarray, q: np.ndarray, i: int) -> bool:
        """Whether RVO2 sees ``q`` from ``p`` with robot ``i``'s radius (local points)."""
        return _rvo_sees(self.sim, p, q, self.radius[i])

    def _trail_point(self, p: np.ndarray, i: int, slot: np.ndarray) -> np.ndarray:
        """A follower's target when its slot is hidden: the latest point of the leader's
        track (every :data:`TRAIL_STRIDE`-th step, up to :data:`TRAIL_POINTS` of them) that it
        sees; the slot when it sees none."""
        n = len(self.trail)
        lo = max(0, n - TRAIL_STRIDE * TRAIL_POINTS)
        back = np.asarray(self.trail[lo:])
        j = farthest_clear(p, back, lambda a, Q: [self._sees(a, Q[0], i)],
                           range(n - 1 - lo, -1, -TRAIL_STRIDE)[::-1], chunk=1)
        return slot if j is None else back[j]

    # -- the simulator's callbacks ------------------------------------------------------------
    def policy(self, state: SimState) -> np.ndarray | None:
        """Set RVO2's agents to the state, solve every agent's ORCA program, return the
        velocities (world units); ``None`` when the robots have stalled."""
        if self._stalled(state.positions):
            self.stalled = True
            return None
        fr, u, sim = self.frame, self.frame.unit, self.sim
        P = fr.local(state.positions)
        V = np.asarray(state.velocities, dtype=float) / u
        held = np.hypot(*(V - self.last_pref).T) > HELD_FRACTION * self.vmax
        pref = self.preferred(P, held)
        self.last_pref = pref
        for i in range(len(P)):
            sim.set_agent_position(i, (float(P[i, 0]), float(P[i, 1])))
            sim.set_agent_velocity(i, (float(V[i, 0]), float(V[i, 1])))
            sim.set_agent_pref_velocity(i, (float(pref[i, 0]), float(pref[i, 1])))
        mp, mv = self.movers.at(state.t, state.dt)
        mp, mv = fr.local(mp), mv / u
        for k in range(len(self.movers)):
            j = len(P) + k
            sim.set_agent_position(j, (float(mp[k, 0]), float(mp[k, 1])))
            sim.set_agent_velocity(j, (float(mv[k, 0]), float(mv[k, 1])))
            sim.set_agent_pref_velocity(j, (float(mv[k, 0]), float(mv[k, 1])))
        sim.do_step()
        out = np.array([self._velocity(i, V[i], pref[i]) for i in range(len(P))]) * u
        self.hist.append(iteration=state.k, best_cost=self.cost(state), n_eval=state.k + 1,
                         time=state.t, preferred_speed=float(np.max(np.hypot(*pref.T))) * u,
                         speed=float(np.max(np.hypot(*out.T))))
        return out

    def _velocity(self, i: int, v: np.ndarray, pref: np.ndarray) -> np.ndarray:
        """Robot ``i``'s new velocity (local units): RVO2's, or with a mover among its
        neighbours and ``mover_share`` above one half, ORCA's program solved again with the
        movers' lines moved to that share (:mod:`optplan.formation.orca_lp`)."""
        sim = self.sim
        got = np.asarray(sim.get_agent_velocity(i).to_tuple(), float)
        n_agents = sim.get_agent_num_agent_neighbors(i)
        movers = [k for k in range(n_agents) if sim.get_agent_agent_neighbor(i, k)
                  >= len(self.robots)]
        if self.o.mover_share == 0.5 or not movers:
            return got
        lines = [sim.get_agent_orca_line(i, k) for k in range(sim.get_agent_num_orca_lines(i))]
        dirs = np.array([d for d, _ in lines], float)
        pts = np.array([q for _, q in lines], float)
        n_obst = len(lines) - n_agents
        for k in movers:
            pts[n_obst + k] = full_share(pts[n_obst + k], v, self.o.mover_share)
        return orca_velocity(pts, dirs, n_obst, float(self.vmax[i]), pref)

    def _stalled(self, positions: np.ndarray) -> bool:
        """Whether no robot moved more than :data:`STALL_FRACTION` of ``max_speed *
        stall_time`` over the last ``stall_time`` seconds (a deadlock of ORCA)."""
        self.track.append(np.array(positions, dtype=float))
        if not self.window or len(self.track) <= self.window:
            return False
        moved = np.hypot(*(self.track[-1] - self.track[-1 - self.window]).T) / self.frame.unit
        return bool(np.all(moved < STALL_FRACTION * self.vmax * self.o.stall_time))

    def _errors(self, state: SimState) -> np.ndarray:
        """Per robot: distance to its goal, or for a follower to its slot (local units)."""
        P = self.frame.local(state.positions)
        err = np.zeros(len(P))
        for i, g in self.goals.items():
            err[i] = np.hypot(*(P[i] - g))
        if self.slots is not None:
            s = slot_positions(P[0], self.heading, *self.slots)
            err[1:] = np.hypot(*(P[1:] - s).T)
        return err

    def done(self, state: SimState) -> bool:
        """Every robot with a goal at it; in a team, the followers also within ``settle_tol``
        of their slot distance L of their slots (or still, held where ORCA keeps them)."""
        err = self._errors(state)
        ends = list(self.goals)
        if not np.all(err[ends] <= self.tol[ends]):
            return False
        if self.slots is None:
            return True
        still = np.hypot(*np.asarray(state.velocities[1:], float).T) / self.frame.unit
        return bool(np.all(err[1:] <= self.o.settle_tol * self.slots[0])
                    or (state.k > 0 and np.all(still < 1e-3 * self.vmax[1:])))

    def cost(self, state: SimState) -> float:
        """The largest distance of a robot to its goal or slot (world units)."""
        return float(np.max(self._errors(state))) * self.frame.unit


@dataclass(frozen=True, kw_only=True)
class ORCA(Backend):
    """Optimal reciprocal collision avoidance through RVO2 (module docstring).

    Lengths marked "(x length_scale)" are multiples of the problem's length unit
    :attr:`optplan.problem.Problem.length_scale`; times are in seconds (a scene drawn at another
    scale has its speeds scaled too, so its times are the same).

    Parameters
    ----------
    team : bool
        ``false``: every planned robot (the leader alone in a formation scene) is an agent
        driven to its goal.  ``true``: the problem's ``[formation]`` is required; the leader is
        driven to its goal and every follower to its L-phi slot.
    subgoals : str
        ``"none"``: preferred velocity straight toward the goal.  ``"visgraph"``: along the
        certified shortest path on the known map (:mod:`optplan.geometry.tangent.tangent_graph`,
        what the ``visgraph`` preset plans), from one visible waypoint to the next; plain ORCA stops
        behind concave obstacles.  In a team only the leader follows it.
    subgoal_reach : float
        A waypoint within this distance counts as passed (x length_scale).
    speed_factor : float
        Preferred speed of a goal-seeking robot as a fraction of its ``max_speed`` (followers
        always may use their full speed to keep up).
    perturb : float
        A goal-seeking robot that ORCA held back on the last step (its velocity differed from
        the preferred one by more than 1 % of its ``max_speed``) gets a random velocity uniform
        in the disc of radius ``perturb * max_speed`` (from ``rng``) added to its preferred
        velocity: it breaks the deadlocks of exactly symmetric agents (RVO2's own examples
        perturb every agent); a robot in free space is never perturbed (0: never).
    dt : float
        Time step (s) of the simulation and of RVO2.
    max_steps : int
        Step budget of the simulation.
    neighbor_dist : float
        RVO2's neighbour distance: other agents farther than this are ignored
        (x length_scale).
    max_neighbors : int
        RVO2's largest number of agent neighbours taken into account.
    time_horizon : float
        ORCA's time horizon against other agents (s): velocities are kept collision-free with
        them for this long; at least ``dt``.
    time_horizon_obst : float
        ORCA's time horizon against static obstacles (s); at least ``dt``.
    circle_sides : int
        Sides of the polygon circumscribed about a circle obstacle (in [3, 256]: RVO2 builds
        its obstacle tree in one uninterruptible call whose time grows faster than the square
        of the number of sides; 1024 took 14 s on ``paper-warehouse``).
    margin : float
        Added to every robot's radius in RVO2 (x length_scale): RVO2 computes in single
        precision, and the validator grades contacts to 1e-9 of the map.
    trail : bool
        In a team: a follower that does not see its slot (RVO2's visibility test with its
        radius) heads for the latest point of the leader's track it sees instead (the leader's
        track is clear of the static obstacles).  ``false``: always toward the slot.
    settle_tol : float
        In a team, the run ends when the leader is at its goal and every follower within
        ``settle_tol * L`` of its slot (a fraction of each slot distance L).
    stall_time : float
        The run ends as stalled when no robot moved more than 5 % of ``max_speed *
        stall_time`` over the last ``stall_time`` seconds (s; 0 never stops).
    mover_share : float
        The share of the avoidance of a moving obstacle a robot takes (in [0.5, 1]): 1, the
        whole (a mover keeps its prescribed velocity and reciprocates nothing: each step a
        robot with a mover among its neighbours solves ORCA's program again on RVO2's lines
        with the movers' moved, :mod:`optplan.formation.orca_lp`); 0.5 is RVO2's reciprocal
        rule, as if the mover took the other half.
    """

    name: ClassVar[str] = "orca"
    #: The units of the result's extras (:mod:`optplan.units`).
    extras_units: ClassVar[Record] = EXTRAS_UNITS

    team: bool = option(False)
    subgoals: str = option("none", choices=("none", "visgraph"))
    subgoal_reach: float = option(5.0, lo=0.0, scale=True)
    speed_factor: float = option(1.0, lo=0.0, hi=1.0, lo_open=True)
    perturb: float = option(0.1, lo=0.0, hi=1.0)
    dt: float = option(0.2, lo=0.0, hi=60.0, lo_open=True)
    max_steps: int = option(3000, lo=1, hi=10_000_000)
    neighbor_dist: float = option(40.0, lo=0.0, lo_open=True, scale=True)
    max_neighbors: int = option(10, lo=1, hi=10_000)
    time_horizon: float = option(2.0, lo=0.0, lo_open=True, hi=1e6)
    time_horizon_obst: float = option(1.0, lo=0.0, lo_open=True, hi=1e6)
    circle_sides: int = option(16, lo=3, hi=256)
    margin: float = option(0.01, lo=0.0, hi=100.0, scale=True)
    trail: bool = option(False)
    settle_tol: float = option(0.02, lo=0.0, hi=0.25, lo_open=True)
    stall_time: float = option(10.0, lo=0.0, hi=1e6)
    mover_share: float = option(1.0, lo=0.5, hi=1.0)

    def check(self) -> None:
        """The time horizons cover at least one step (ORCA's guarantee holds for the next
        ``time_horizon`` seconds only)."""
        for k in ("time_horizon", "time_horizon_obst"):
            if getattr(self, k) < self.dt:
                raise ValueError(f"option {k!r} of backend 'orca' must be at least dt "
                                 f"({self.dt:g} s), got {getattr(self, k):g}: ORCA keeps a "
                                 "velocity collision-free for that long, a step must fit in it")

    def _robots(self, problem: Problem) -> list[Robot]:
        """The agents' robots: the planned robots, or with ``team`` leader then followers."""
        if not self.team:
            return list(problem.planned_robots)
        form = problem.formation
        if form is None:
            raise ValueError(f"problem {problem.name!r} has no [formation]: backend 'orca' with "
                             "team = true drives followers to their slots (use team = false)")
        return [problem.leader] + [problem.robot(f.id) for f in form.followers]

    def _subgoals(self, problem: Problem, robots: list[Robot]) -> tuple[dict[str, np.ndarray],
                                                                      str]:
        """The sub-goals of the goal-seeking robots (world) and a note for the message."""
        if self.subgoals == "none":
            return {}, ""
        out, notes = {}, []
        for r in (robots[:1] if self.team else robots):
            if r.goal is None:
                continue
            tp = problem_shortest_path(problem, r, known_only=True)
            if tp.polyline is None or len(tp.polyline) < 2:
                notes.append(f"{r.id}: no path on the known map, straight to the goal")
                out[r.id] = np.asarray(r.goal, float)[None, :]
            else:
                out[r.id] = np.asarray(tp.polyline, float)[1:]
        return out, "; ".join(["sub-goals by visgraph"] + notes)

    def solve(self, problem: Problem, /, *, rng: np.random.Generator | None = None,
              init: dict[str, np.ndarray] | None = None,
              callback: Callable[[Progress], Any] | None = None) -> Result:
        """Simulate the robots with ORCA (module docstring); ``rng`` draws the ``perturb``
        jitter (nothing else is random); ``init`` is unused (ORCA plans no path to start
        from)."""
        t0 = time.perf_counter()
        require_pyrvo()
        robots = self._robots(problem)
        subgoals, note = self._subgoals(problem, robots)
        run = _OrcaRun(self, problem, robots, subgoals, make_rng(rng)[0])
        out = simulate(problem, run.policy, ids=run.ids, dt=self.dt, max_steps=self.max_steps,
                       done=run.done, callback=callback, progress_cost=run.cost)
        claim, msg = self._outcome(out, run)
        paths = out.paths()
        lead = run.ids[0]
        extras = {
            "sim_steps": int(out.steps), "sim_reason": out.reason, "collision": out.collision,
            "time_to_goal": _time_to_goal(out, problem, robots[0]),
            "length_scale": problem.length_scale, "agents": len(robots),
            "mover_agents": len(run.movers), "obstacle_vertices": run.n_vertices}
        if subgoals:
            extras["subgoals"] = {k: v.tolist() for k, v in subgoals.items()}
        return self.finish(problem, paths, claim=claim, times=out.times,
                           cost=float(path_lengths(paths[lead])),
                           message="; ".join(m for m in (msg, note) if m),
                           n_iter=int(out.steps), n_eval=int(out.steps), history=run.hist,
                           extras=extras, wall_time=time.perf_counter() - t0)

    def _outcome(self, out: SimOutcome, run: _OrcaRun) -> tuple[Status, str]:
        """The claimed status and the message of a finished run."""
        if out.reason == "done":
            return Status.solved, ("leader at its goal, followers at their slots"
                                   if run.slots is not None else "goal reached")
        if out.reason == "collision":
            return Status.failed, f"collision: {out.collision}"
        if out.reason == "callback":
            return Status.approximate, "stopped by the callback"
        if run.stalled:
            return Status.approximate, (f"stalled: no robot moved 5 % of its max_speed x "
                                        f"{self.stall_time:g} s in the last {self.stall_time:g}"
                                        " s (an ORCA deadlock)")
        return Status.approximate, f"step budget ({self.max_steps}) exhausted"


def _time_to_goal(out: SimOutcome, problem: Problem, robot: Robot) -> float:
    """Simulated time at which ``robot`` (the leader) first came within its goal tolerance;
    ``nan`` when it never did."""
    if robot.goal is None:
        return float("nan")
    d = np.hypot(*(out.positions[:, 0, :] - robot.goal).T)
    hit = np.flatnonzero(d <= problem.goal_tol(robot))
    return float(out.times[hit[0]]) if len(hit) else float("nan")

