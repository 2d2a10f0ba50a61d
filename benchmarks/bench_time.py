"""Arrival times among moving obstacles: the references in time, the heuristics, and OMPL.

Scenes:

* every catalogue scene with moving obstacles (:func:`catalogue_scenes`), the leader planned;
* random 500 x 500 scenes of ``bench_sipp.random_scene`` (``optplan.generators``'s random
  static obstacles, one robot of radius 1 and speed 10 from (10, 10) to (490, 490)) with their
  movers going back and forth across the start-goal diagonal (``crossing=True``, so that they
  cross the robot's way): 10 obstacles and 5 movers, 50 and 10, 100 and 20, ``--random-seeds``
  seeds of each.

Three tables, each with the machine's 1-minute load average before and after its runs:

1. **References**: the wall time of :func:`optplan.geometry.timing.schedule.fastest_schedule` on the
   leader's ``visgraph`` path (``see_temporary = true``: the shortest path of the whole static
   map) and of ``optplan.solve(problem, "sipp")`` (bound, search and validator, as in
   ``bench_sipp.py``), each on a freshly built problem (no cached roadmap or bound); ``sipp``'s
   statuses and its arrival over the certified lower bound; whether the shortest path driven at
   full speed from t = 0 hits a mover (the movers matter) and its fastest schedule over the
   ``sipp`` arrival.  Targets of issue 25: ``sipp`` <= 100 ms on
   ``paper-warehouse``, <= 1 s with 100 obstacles and 20 movers.
2. **Heuristics**: ``apf-paper``, ``sa-apf-paper``, ``hybrid-paper``, ``hybrid-qp`` and
   ``ipso`` (a geometric path timed at ``max_speed`` from t = 0), ``--seeds`` seeds on each
   catalogue scene and one on each random scene: the share of plans that reach the goal and
   are collision-free (the validator's ``feasible``, in continuous time), and over those the
   leader's arrival (:func:`optplan.geometry.timing.time_bounds.arrival_time`, the metric
   ``arrival_time`` of ``reference=True``) over the ``sipp`` reference and over the lower
   bound, median and worst.  The grades are those of ``op.solve(..., reference=True)`` without
   its ``schedule_arrival``: the fastest schedule of a heuristic's own trajectory is the slow
   part of that grading (a 3,000-point trajectory takes about a minute), and
   ``time_paper_scenes.py`` reports it on the paper's scenes.
3. **OMPL**: OMPL's Python bindings (the ``ompl`` wheel, ``pip install 'optplan[bench]'``)
   do not expose ``geometric.STRRTstar``, so the space-time planner here is ``RRTstar`` in a
   ``SpaceTimeStateSpace`` (:func:`ompl_plan`), one anytime run per scene read at each budget
   of ``--budgets`` (1 s and 10 s); its plan is checked by ``optplan.metrics.evaluate``
   (exact, continuous time).  The count of scenes on which ``sipp`` arrives later than a
   collision-free OMPL plan of the largest budget is printed with their names (target: none).

Run: ``python benchmarks/bench_time.py [--quick] [--seeds 3] [--random-seeds 5] [--no-ompl]``
(full run about 8 minutes on a shared 2-core machine; ``--quick``: two catalogue scenes, two
random scenes, one seed, budgets 1 s and 2 s).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import os
import platform
import statistics
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import optplan as op
from optplan.exact.sipp import earliest_arrival
from optplan.geometry.timing.schedule import fastest_schedule
from optplan.geometry.timing.time_bounds import arrival_lower_bound, arrival_time
from optplan.metrics import evaluate
from optplan.problem import Problem

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_sipp import TARGET_RANDOM, TARGET_WAREHOUSE, random_scene  # noqa: E402

PRESETS = ("apf-paper", "sa-apf-paper", "hybrid-paper", "hybrid-qp", "ipso")
RANDOM_SIZES = ((10, 5), (50, 10), (100, 20))
QUICK_CATALOGUE = ("paper-apf-env1", "paper-warehouse")
#: random scene size on which the 1 s target holds
TARGET_SIZE = (100, 20)
#: OMPL: the moving obstacles are kept this fraction of the robot radius away at the sampled
#: states, which are at most this far apart in the robot's motion relative to a mover
MARGIN = 0.1


@dataclass(frozen=True)
class Scene:
    """A scene of the benchmark.

    Attributes
    ----------
    name : str
        The catalogue name, or ``random-N-M-sSEED``.
    group : str
        Rows of the tables: the catalogue name, or ``random N obstacles, M movers``.
    build : callable
        Returns a freshly built :class:`~optplan.problem.Problem` (no cached values).
    """

    name: str
    group: str
    build: Callable[[], Problem]


def catalogue_scenes(names: tuple[str, ...] | None = None) -> list[Scene]:
    """The catalogue scenes with moving obstacles (all of them, or those of ``names``)."""
    out = []
    for name in op.list_problems():
        if names is not None and name not in names:
            continue
        if op.load_problem(name).dynamic_obstacles:
            out.append(Scene(name, name, lambda n=name: op.load_problem(n)))
    return out


def random_scenes(sizes: tuple[tuple[int, int], ...], seeds: int) -> list[Scene]:
    """``seeds`` random scenes of each ``(obstacles, movers)`` size, movers across the way."""
    return [Scene(f"random-{n}-{m}-s{s}", f"random {n} obstacles, {m} movers",
                  lambda n=n, m=m, s=s: random_scene(n, m, s, crossing=True))
            for n, m in sizes for s in range(seeds)]


def _ratio(a: float | None, b: float | None) -> float | None:
    ok = a is not None and b is not None and 0 < b < math.inf
    return float(a) / float(b) if ok else None  # type: ignore[arg-type]


def _med_worst(xs: list[float], fmt: str = ".3f") -> str:
    """``median / worst`` (worst: the largest) of ``xs``, or ``-``."""
    return f"{statistics.median(xs):{fmt}} / {max(xs):{fmt}}" if xs else "-"


# ---- 1. references ----------------------------------------------------------------------

def reference_row(scene: Scene) -> dict[str, Any]:
    """Wall times and arrivals of the references on one freshly built scene.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    dict
        ``sipp_ms`` (``Result.wall_time`` of ``optplan.solve(problem, "sipp")``), ``status``,
        ``arrival`` (the leader's), ``bound``, ``schedule_ms`` (``fastest_schedule`` of the
        leader's ``visgraph`` path), ``schedule`` (its arrival), ``collides`` (the path at full
        speed from t = 0 hits a mover).
    """
    prob = scene.build()
    rid = prob.leader.id
    res = op.solve(prob, "sipp")
    lead = res.extras["sipp"][rid]
    vis = op.solve(scene.build(), "visgraph", see_temporary=True)
    path = vis.paths[rid]
    fresh = scene.build()
    t0 = time.perf_counter()
    sch = fastest_schedule(fresh, path, rid)
    sch_s = time.perf_counter() - t0
    ev = evaluate(fresh, {rid: path})
    return {"scene": scene.name, "group": scene.group, "sipp_ms": 1000 * res.wall_time,
            "status": str(res.status), "arrival": lead["arrival"],
            "bound": arrival_lower_bound(fresh, rid).value, "schedule_ms": 1000 * sch_s,
            "schedule": sch.arrival, "collides": ev["dynamic_contacts"] > 0}


def _target(group: str) -> tuple[str, float | None]:
    if group == "paper-warehouse":
        return f"<= {1000 * TARGET_WAREHOUSE:.0f} ms", TARGET_WAREHOUSE
    if group == "random {} obstacles, {} movers".format(*TARGET_SIZE):
        return f"<= {1000 * TARGET_RANDOM:.0f} ms", TARGET_RANDOM
    return "-", None


def reference_table(rows: list[dict[str, Any]]) -> str:
    """Table 1, one row per scene group."""
    out = ["| scene | runs | fastest_schedule ms (median / worst) | sipp ms (median / worst) | "
           "sipp status | sipp / lower bound (median / worst) | shortest path at full speed "
           "hits a mover | its fastest schedule / sipp (median / worst) | sipp target |",
           "|---|---:|---:|---:|---|---:|---:|---:|---|"]
    for g in dict.fromkeys(r["group"] for r in rows):
        rs = [r for r in rows if r["group"] == g]
        label, tgt = _target(g)
        worst = max(r["sipp_ms"] for r in rs) / 1000
        met = "" if tgt is None else (": met" if worst <= tgt else ": NOT met")
        st = ", ".join(f"{k} {v}" for k, v in sorted(Counter(r["status"] for r in rs).items()))
        gap = [x for r in rs if (x := _ratio(r["arrival"], r["bound"])) is not None]
        late = [x for r in rs if (x := _ratio(r["schedule"], r["arrival"])) is not None]
        out.append(f"| {g} | {len(rs)} | {_med_worst([r['schedule_ms'] for r in rs], fmt='.1f')}"
                   f" | {_med_worst([r['sipp_ms'] for r in rs], fmt='.1f')} | {st} | "
                   f"{_med_worst(gap, fmt='.4f')} | {sum(r['collides'] for r in rs)}/{len(rs)} "
                   f"| {_med_worst(late, fmt='.4f')} | {label}{met} |")
    return "\n".join(out)


# ---- 2. heuristics ----------------------------------------------------------------------

def heuristic_rows(scene: Scene, seeds: int) -> list[dict[str, Any]]:
    """Every preset of :data:`PRESETS` on one scene, ``seeds`` seeds, graded in time.

    The reference (``earliest_arrival``, the ``sipp`` preset's) and the lower bound are those
    of ``reference=True``; the arrival is the leader's as executed.
    """
    prob = scene.build()
    rid = prob.leader.id
    ref = earliest_arrival(prob, rid).arrival
    bound = arrival_lower_bound(prob, rid).value
    rows = []
    for preset in PRESETS:
        for seed in range(seeds):
            res = op.solve(prob, preset, rng=seed)
            path = res.paths.get(rid)
            arr = None if path is None else arrival_time(prob, rid, path, res.times)
            rows.append({"scene": scene.name, "group": scene.group, "preset": preset,
                         "seed": seed, "wall": res.wall_time, "arrival": arr,
                         "valid": arr is not None and bool(res.metrics["feasible"]),
                         "arrived": arr is not None, "to_ref": _ratio(arr, ref),
                         "to_bound": _ratio(arr, bound)})
    return rows


def heuristic_table(rows: list[dict[str, Any]]) -> str:
    """Table 2, one row per (scene group, preset); ratios over the valid plans only."""
    out = ["| scene | preset | plans | reached the goal | collision-free and reached | "
           "arrival / sipp (median / worst) | arrival / lower bound (median / worst) | "
           "median wall s |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for g in dict.fromkeys(r["group"] for r in rows):
        for p in PRESETS:
            rs = [r for r in rows if r["group"] == g and r["preset"] == p]
            ok = [r for r in rs if r["valid"]]
            out.append(f"| {g} | {p} | {len(rs)} | {sum(r['arrived'] for r in rs)} | "
                       f"{len(ok)} ({100 * len(ok) / len(rs):.0f} %) | "
                       f"{_med_worst([r['to_ref'] for r in ok if r['to_ref'] is not None])} | "
                       f"{_med_worst([r['to_bound'] for r in ok if r['to_bound'] is not None])}"
                       f" | {statistics.median(r['wall'] for r in rs):.2f} |")
    return "\n".join(out)


# ---- 3. OMPL ----------------------------------------------------------------------------

def mover_speed(dyn) -> float:
    """The largest speed of a moving obstacle's reference point (a ``loop`` jump aside)."""
    if dyn.velocity is not None:
        return float(np.hypot(*dyn.velocity))
    w, t = np.asarray(dyn.waypoints, float), np.asarray(dyn.times, float)
    if len(w) < 2:
        return 0.0
    return float(np.max(np.hypot(*np.diff(w, axis=0).T) / np.maximum(np.diff(t), 1e-12)))


class SpaceTimeChecker:
    """Validity of space-time states and motions of one robot, for OMPL.

    A state ``(x, y, t)`` is valid when the robot's disc is clear of the static obstacles (all
    of them, temporary ones included: ``problem.obstacle_set(radius, known_only=False)``,
    exact) and more than ``margin`` clear of every moving obstacle placed at ``t``
    (``DynamicObstacle.distance``).  A motion is valid when it goes forward in time, no faster
    than ``max_speed``, its segment is clear of the static obstacles (exact) and the robot,
    sampled along it at times where its position relative to any mover moves at most
    ``margin`` between samples, stays ``margin`` clear of the movers (coarse samples first,
    :meth:`_movers_clear`).  The sampled check leaves the robot at least ``margin / 2`` clear
    between samples unless a mover jumps (a ``loop``); the exact validator checks the plan
    afterwards.
    """

    def __init__(self, problem: Problem, rid: str, margin: float = MARGIN):
        robot = problem.robot(rid)
        self.radius, self.speed = float(robot.radius), float(robot.max_speed)
        self.static = problem.obstacle_set(self.radius, known_only=False)
        self.movers = list(problem.dynamic_obstacles)
        self.margin = margin * self.radius
        self.mover_speed = max([mover_speed(d) for d in self.movers] + [0.0])

    def _clear(self, pts: np.ndarray, t: np.ndarray, slack: float | np.ndarray = 0.0
               ) -> np.ndarray:
        """Per point, clear of every mover by more than ``margin + slack``."""
        ok = np.ones(len(pts), bool)
        for d in self.movers:
            ok &= d.distance(pts, t) > self.radius + self.margin + slack
        return ok

    def state_valid(self, state) -> bool:
        """OMPL state validity: clear of the static obstacles and of the movers at ``t``."""
        p = np.array([[state[0][0], state[0][1]]])
        if self.static.point_distances(p)[0] <= self.radius:
            return False
        return bool(self._clear(p, np.array([state[1].position]))[0])

    def motion_valid(self, s1, s2) -> bool:
        """OMPL motion validity (class docstring)."""
        t1, t2 = s1[1].position, s2[1].position
        p1 = np.array([s1[0][0], s1[0][1]])
        p2 = np.array([s2[0][0], s2[0][1]])
        dt = t2 - t1
        length = float(np.hypot(*(p2 - p1)))
        if not (dt > 0 and length <= self.speed * dt * (1 + 1e-9)):
            return False
        if not self.static.segment_free(p1[None], p2[None])[0]:
            return False
        return not self.movers or self._movers_clear(p1, p2, t1, dt, length)

    def _movers_clear(self, p1: np.ndarray, p2: np.ndarray, t1: float, dt: float,
                      length: float) -> bool:
        """The movers along a motion: sampled at spacings 64, 8 and 1 x ``margin`` (of the
        motion relative to any mover), each level refining only the stretches between two
        samples that the coarser one could not prove clear (a sample clear by more than half
        the spacing clears the half-stretch on each side: distance is 1-Lipschitz)."""
        reach = length + self.mover_speed * dt  # relative displacement over the whole motion
        lo, hi = np.zeros(1), np.ones(1)
        spacing = 64 * self.margin
        while len(lo):
            fine = spacing <= self.margin * (1 + 1e-9)
            n = np.maximum(2, np.ceil((hi - lo) * reach / spacing).astype(int) + 1)
            u = np.concatenate([np.linspace(a, b, k) for a, b, k in zip(lo, hi, n)])
            slack = 0.0 if fine else np.repeat((hi - lo) * reach / (n - 1) / 2, n)
            ok = self._clear(p1 + u[:, None] * (p2 - p1), t1 + u * dt, slack)
            if fine:
                return bool(ok.all())
            last = np.cumsum(n) - 1  # a stretch's last sample: no pair with the next stretch
            pair = np.ones(len(u) - 1, bool)
            pair[last[:-1]] = False
            bad = np.flatnonzero(pair & ~(ok[:-1] & ok[1:]))
            lo, hi = u[bad], u[bad + 1]
            spacing = max(spacing / 8, self.margin)
        return True


def _ompl_setup(problem: Problem, rid: str, horizon: float, seed: int):
    """OMPL objects for :func:`ompl_plan`: space, space information, problem definition and
    the Python objects OMPL holds (kept alive by the caller)."""
    from ompl import base as ob

    robot = problem.robot(rid)
    chk = SpaceTimeChecker(problem, rid)
    r2 = ob.RealVectorStateSpace(2)
    b = ob.RealVectorBounds(2)
    x0, y0, x1, y1 = problem.bounds
    b.setLow(0, x0 + robot.radius)
    b.setLow(1, y0 + robot.radius)
    b.setHigh(0, x1 - robot.radius)
    b.setHigh(1, y1 - robot.radius)
    r2.setBounds(b)
    # time weight 1: between two states the robot can join at max_speed the distance is their
    # time difference (infinite otherwise), so the path-length objective is the arrival time
    space = ob.SpaceTimeStateSpace(r2, robot.max_speed, 1.0)
    space.setTimeBounds(0.0, horizon)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(chk.state_valid)

    class Motion(ob.MotionValidator):
        def checkMotion(self, s1, s2):
            return chk.motion_valid(s1, s2)

    motion = Motion(si)
    si.setMotionValidator(motion)
    si.setup()
    gx, gy = float(robot.goal[0]), float(robot.goal[1])
    t_min = math.dist(robot.start, robot.goal) / robot.max_speed
    rng = np.random.default_rng([seed, 25])

    class Goal(ob.GoalSampleableRegion):
        """The goal position at any time of ``[straight-line time, horizon]``."""

        def distanceGoal(self, s):
            return math.hypot(s[0][0] - gx, s[0][1] - gy) / robot.max_speed

        def sampleGoal(self, s):
            s[0][0], s[0][1] = gx, gy
            s[1].position = float(rng.uniform(t_min, horizon))

        def maxSampleCount(self):
            return 1 << 30

    goal = Goal(si)
    goal.setThreshold(1e-9)
    pdef = ob.ProblemDefinition(si)
    start = space.allocState()
    start[0][0], start[0][1] = float(robot.start[0]), float(robot.start[1])
    start[1].position = 0.0
    pdef.addStartState(start)
    pdef.setGoal(goal)
    pdef.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
    return si, pdef, (chk, motion, goal, start, space)


def ompl_plan(problem: Problem, rid: str, budgets: tuple[float, ...], seed: int = 0,
              horizon_factor: float = 2.0) -> dict[float, dict[str, Any]]:
    """Earliest arrival by OMPL's ``RRTstar`` in a ``SpaceTimeStateSpace``, checked exactly.

    Parameters
    ----------
    problem : Problem
    rid : str
        The robot planned (alone among the static and moving obstacles).
    budgets : tuple of float
        Increasing planning times (s): one anytime run, its best plan read at each.
    seed : int
        Seed of the goal-time samples (OMPL's own sampler is seeded once per process,
        ``ompl.util.RNG.setSeed``; a run bounded by wall time is not reproducible exactly).
    horizon_factor : float
        Time bound of the space: this many times the straight-line time at ``max_speed``.

    Returns
    -------
    dict
        Per budget: ``arrival`` (``None`` without an exact solution), ``valid``
        (``optplan.metrics.evaluate``'s ``feasible`` of the timed plan), ``collisions``,
        ``iterations`` (so far), ``horizon``.

    Notes
    -----
    Planner: ``RRTstar``, range = the straight-line time (in the space's distance, time),
    default goal bias 0.05; the goal is the goal position at any time of ``[straight-line
    time, horizon]`` (``GoalSampleableRegion``).  The motion validator rejects backward time
    and speeds above ``max_speed`` (as OMPL's ``SpaceTimePlanning`` demo does) and checks the
    motion (:class:`SpaceTimeChecker`).  ``solve`` is called once per budget on the same
    planner, which goes on growing its tree.
    """
    from ompl import geometric as og

    robot = problem.robot(rid)
    t_min = math.dist(robot.start, robot.goal) / robot.max_speed
    horizon = horizon_factor * t_min
    si, pdef, keep = _ompl_setup(problem, rid, horizon, seed)
    planner = og.RRTstar(si)
    planner.setRange(t_min)
    planner.setProblemDefinition(pdef)
    planner.setup()
    out: dict[float, dict[str, Any]] = {}
    spent = 0.0
    for budget in budgets:
        planner.solve(float(budget) - spent)
        spent = float(budget)
        row: dict[str, Any] = {"arrival": None, "valid": False, "collisions": None,
                               "iterations": planner.numIterations(), "horizon": horizon}
        if pdef.hasExactSolution():
            states = pdef.getSolutionPath().getStates()
            pts = np.array([[s[0][0], s[0][1]] for s in states])
            ts = np.array([s[1].position for s in states])
            ev = evaluate(problem, {rid: pts}, ts)
            row.update(arrival=float(ts[-1]), valid=bool(ev["feasible"]),
                       collisions=int(ev["collisions"]))
        out[budget] = row
    planner.clear()
    del keep
    return out


def ompl_rows(scene: Scene, budgets: tuple[float, ...], ref_rows: dict[str, dict]
              ) -> dict[str, Any]:
    """OMPL on one scene, read at every budget, beside the ``sipp`` arrival and the bound."""
    prob = scene.build()
    ref = ref_rows[scene.name]
    return {"scene": scene.name, "group": scene.group, "sipp": ref["arrival"],
            "bound": ref["bound"], "runs": ompl_plan(prob, prob.leader.id, budgets)}


def _fmt(x: float | None, f: str = ".2f") -> str:
    return "-" if x is None else f"{x:{f}}"


def ompl_table(rows: list[dict[str, Any]], budgets: tuple[float, ...]) -> str:
    """Table 3, one row per scene, and the count of scenes where ``sipp`` arrives later."""
    head = "| scene | sipp arrival s | lower bound s |"
    sep = "|---|---:|---:|"
    for b in budgets:
        head += f" RRT* {b:g} s: arrival s (/ sipp) | collision-free |"
        sep += "---:|---|"
    out = [head + " sipp later than RRT* |", sep + "---|"]
    later = []
    top = max(budgets)
    for r in rows:
        line = f"| {r['scene']} | {_fmt(r['sipp'])} | {_fmt(r['bound'])} |"
        for b in budgets:
            x = r["runs"][b]
            rat = _ratio(x["arrival"], r["sipp"])
            arr = "none" if x["arrival"] is None else f"{x['arrival']:.2f} ({rat:.3f})"
            ok = "-" if x["arrival"] is None else ("yes" if x["valid"] else
                                                     f"no ({x['collisions']} collisions)")
            line += f" {arr} | {ok} |"
        best = r["runs"][top]
        is_later = (best["valid"] and best["arrival"] is not None and r["sipp"] is not None
                    and r["sipp"] > best["arrival"] * (1 + 1e-9))
        if is_later:
            later.append(r["scene"])
        out.append(line + (" yes |" if is_later else " no |"))
    out.append("")
    for b in budgets:
        xs = [r["runs"][b] for r in rows]
        ok = [x for x in xs if x["valid"]]
        rat = [q for r in rows if r["runs"][b]["valid"]
               and (q := _ratio(r["runs"][b]["arrival"], r["sipp"])) is not None]
        out.append(f"RRT* {b:g} s: exact solution on {sum(x['arrival'] is not None for x in xs)}"
                   f"/{len(xs)} scenes, collision-free on {len(ok)}/{len(xs)}; arrival / sipp "
                   f"over the collision-free ones (median / worst) {_med_worst(rat)}; median "
                   f"iterations {statistics.median(x['iterations'] for x in xs):.0f}")
    out.append(f"target: sipp never arrives later than OMPL's space-time planner at {top:g} s. "
               f"Scenes where sipp arrives later than a collision-free RRT* {top:g} s plan: "
               f"{len(later)}/{len(rows)}" + (f" ({', '.join(later)})" if later else ""))
    return "\n".join(out)


def _ompl_available() -> tuple[str | None, str]:
    """``(None, what is used)`` when ``ompl`` imports (its log quietened, its sampler seeded),
    else ``(why not, "")``."""
    try:
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError as e:
        return f"OMPL not installed ({e}): pip install 'optplan[bench]'", ""
    ou.setLogLevel(ou.LOG_ERROR)
    ou.RNG.setSeed(25)
    has = hasattr(og, "STRRTstar")
    return None, (f"OMPL {importlib.metadata.version('ompl')}: "
                  f"geometric.STRRTstar {'exposed' if has else 'not exposed'} by the Python "
                  "bindings; planner used: RRTstar in a SpaceTimeStateSpace (R^2 x time, time "
                  "weight 1: path cost = arrival), time bound 2 x the straight-line time, range "
                  "= the straight-line time, goal = the goal position at any time; movers "
                  f"sampled at most {MARGIN:g} x radius apart (relative motion) and kept "
                  f"{MARGIN:g} x radius clear; plans checked by optplan.metrics.evaluate\n")


# ---- main -------------------------------------------------------------------------------

def _section(title: str, fn: Callable[[], str]) -> None:
    print(f"## {title}\n")
    l0, t0 = os.getloadavg()[0], time.perf_counter()
    table = fn()
    print(f"load average {l0:.2f} before, {os.getloadavg()[0]:.2f} after "
          f"({time.perf_counter() - t0:.0f} s)\n")
    print(table + "\n", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a small run (a minute or two)")
    ap.add_argument("--seeds", type=int, default=3, help="heuristic seeds per catalogue scene")
    ap.add_argument("--random-seeds", type=int, default=5, help="random scenes per size")
    ap.add_argument("--repeats", type=int, default=3,
                    help="timed runs of the references per catalogue scene")
    ap.add_argument("--budgets", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--no-ompl", action="store_true")
    args = ap.parse_args(argv)
    budgets = tuple(sorted(args.budgets))
    if args.quick:
        cat = catalogue_scenes(QUICK_CATALOGUE)
        rnd = random_scenes(((10, 5), TARGET_SIZE), 1)
        args.seeds, args.repeats = 1, 1
        budgets = (1.0, 2.0) if args.budgets == [1.0, 10.0] else budgets
    else:
        cat = catalogue_scenes()
        rnd = random_scenes(RANDOM_SIZES, args.random_seeds)
    scenes = cat + rnd
    print("bench_time: arrival times among moving obstacles (references, heuristics, OMPL)")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
          f"(shared), Python {platform.python_version()}, numpy {np.__version__}; "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"scenes: {len(cat)} catalogue ({', '.join(s.name for s in cat)}), {len(rnd)} random "
          f"(bench_sipp.random_scene, movers across the start-goal diagonal)\n")
    op.solve("paper-apf-env1", "sipp")  # warm-up: numba kernels, imports
    ref_rows: list[dict[str, Any]] = []

    def refs() -> str:
        for s in scenes:
            reps = args.repeats if s in cat else 1
            ref_rows.extend(reference_row(s) for _ in range(reps))
        return reference_table(ref_rows)

    _section("References: fastest_schedule (visgraph path) and sipp", refs)
    h_rows: list[dict[str, Any]] = []

    def heur() -> str:
        for s in scenes:
            h_rows.extend(heuristic_rows(s, args.seeds if s in cat else 1))
        return heuristic_table(h_rows) + (
            "\n\nRatios over the collision-free plans that reach the goal.  A ratio below 1: "
            "the plan stops within the goal tolerance, a little before the goal itself, to "
            "which sipp and the bound drive.")

    _section(f"Heuristics: arrival against sipp and the lower bound ({args.seeds} seeds per "
             "catalogue scene, one per random scene)", heur)
    why, what = ("--no-ompl", "") if args.no_ompl else _ompl_available()
    if why is not None:
        print(f"OMPL table skipped: {why}")
        return 0
    first = {r["scene"]: r for r in ref_rows}
    o_rows: list[dict[str, Any]] = []

    def ompl() -> str:
        print(what)
        o_rows.extend(ompl_rows(s, budgets, first) for s in scenes)
        return ompl_table(o_rows, budgets)

    _section("OMPL's space-time planner beside sipp", ompl)
    return 0


if __name__ == "__main__":
    sys.exit(main())
