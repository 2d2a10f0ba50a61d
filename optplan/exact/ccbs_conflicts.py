r"""Conflicts of ``ccbs`` and the delta branching rule (Combrink, Roselli, Fabian 2025).

**Timed actions.**  A plan (:class:`~optplan.exact.ccbs_sipp.Plan`) is a sequence of *moves*
(node ``u`` to node ``v`` at full speed, departing at ``t``) and *waits* (at a node, from an
arrival to a departure; the last one, at the goal, for ever).

**Conflicts.**  Two robots conflict when their discs overlap
(:func:`~optplan.geometry.timing.disc_conflict.contact_interval`, contact distance
``(r_i + r_j)(1 - 2 CONTACT_REL_TOL)``); the conflict of a pair is its first one in time.  Its
two actions are never both waits: the first contact of two discs at rest began while one of
them was arriving (the starts are checked apart, and two goals that overlap make the problem
infeasible).

**Branching** (both children with the contact distance ``R = (r_i + r_j)(1 - CONTACT_REL_TOL)``).

* Move ``i`` against move ``j``: whether they overlap depends only on the offset of their
  departures, and the offsets in contact form one open interval (both bodies are convex in
  space-time), so the children "``i`` does not depart along its edge in ``[t_i, e_i)``" and
  "``j`` does not depart in ``[t_j, e_j)``", ``e`` the end of the unsafe interval of each against
  the other fixed (:func:`~optplan.geometry.timing.disc_conflict.unsafe_interval`), exclude
  together only pairs of departures whose offset lies in the contact interval: every
  conflict-free solution survives in one child (the original CCBS rule, sound for two moves).

  *Extended when one arrives where the other starts.*  Every plan that makes a move (speed
  ``w``, from ``a`` to ``b``, over ``[t0, t1]``) is, at any time ``t``, within
  ``rho(t) = w max(0, t0 - t, t - t1)`` of the move's own point ``c(t)`` (``a`` before, ``b``
  after), whatever it does before and after.  Two such plans certainly touch when
  ``|c_i - c_j| + rho_i + rho_j < R``; the left side is the least over ``x`` of
  ``(|x - c_i| + rho_i) + (|x - c_j| + rho_j)``, each term a maximum of convex functions of
  ``(t, x)`` and the departures, so the departures' offsets at which they certainly touch
  still form one interval, which holds the moves' own one.  With ``j``'s move ending at
  ``b_j`` (at ``T_j``) within ``R`` of ``i``'s start ``a_i``: for a departure ``s_i >= T_j``,
  at some time of ``[T_j, s_i]`` the two are at most ``|b_j - a_i| + min(w_i, w_j)
  (s_i - T_j)`` apart, so ``e_i`` is at least ``T_j + (R - |b_j - a_i|) / min(w_i, w_j)``
  (and likewise ``e_j``): the larger end, inside the same interval, keeps the rule sound.
* Move ``i`` against a wait of ``j`` at node ``v`` (until ``t_b``, ``inf`` for the goal):
  the wait has no duration of its own, so the original rule (the wait's node forbidden over the
  time the move passes it, the move over its whole unsafe interval) can cut off conflict-free
  solutions.  The delta rule: with ``(c_s, c_e)`` the times the move (departing at ``t_i``)
  passes within ``R`` of ``v`` and ``delta = min(gamma (c_e - c_s), t_b - c_s)``, the children
  are "``i`` does not depart in ``[t_i, t_i + delta)``" and "``j`` is not at ``v`` in
  ``[c_s + delta, c_e)``".  A departure in ``[t_i, t_i + delta)`` passes ``v`` over an interval
  that holds ``[c_s + delta, c_e)``, so a pair excluded by both collides: sound; both children
  exclude the current conflict (``j`` is at ``v`` in ``[c_s + delta, c_e)`` or leaves it at
  ``c_s + delta``, and the vertex constraint forbids leaving too), and the excluded intervals are
  a fixed fraction of the contact, which is what makes the search terminate.

  *The pass.*  ``(c_s, c_e)`` is not only the move's own contact with ``v``: every plan that
  makes the move is at its end node ``b`` when it ends (``t_i + d``) and, at speed at most
  ``s`` (the move's), no farther than ``|b - v| + s (t - t_i - d)`` from ``v`` afterwards,
  whatever it does next; likewise before it departs from ``a``.  So when ``|b - v| < R``
  the pass lasts at least until ``t_i + d + (R - |b - v|) / s`` (and, when ``|a - v| < R``,
  begins by ``max(0, t_i - (R - |a - v|) / s)``), and a departure at ``t_i + x`` shifts it
  by ``x``: the argument above holds for this longer pass, whose fraction ``gamma`` is the
  larger step.  A move into the node where ``j`` waits has twice the pass of the move alone.
* Move ``i`` against the goal hold of ``j`` (the wait that never ends, from ``j``'s final
  arrival ``a_j``): the delta rule would only delay the move by a fraction of the contact at
  a time, a long chain of children when ``i`` must take another way.  One shot instead:
  "``i`` does not depart along its edge in ``[t_i, inf)``" and "``j``'s final arrival at its
  goal is at ``c_e`` or later" (``c_e`` the end of the move's pass of the goal, departing at
  ``t_i``, as above).  Sound: a conflict-free solution in which ``i`` departs along that edge
  at some ``s >= t_i`` passes the goal over ``(c_s, c_e)`` shifted by ``s - t_i >= 0``; ``j``, which
  holds its goal for ever from ``a_j``, must not be there then, so ``a_j >= c_e + s - t_i >=
  c_e``.  Both children exclude the conflict (``a_j < c_e``: the hold met the pass).  The
  authors' implementation forbids the move for ever too, but gives ``j`` a vertex constraint
  over the pass, which also forbids ``j`` to cross its goal then (not sound).

**Disjoint splitting** (``ccbs``'s option ``disjoint``).  In both rules the child of a mover
``i`` is one edge constraint "``i`` does not depart along ``u -> v`` in ``[t_i, T)``".  Its
complement is the *positive* constraint "``i`` departs along ``u -> v`` at least once in
``[t_i, T)``", which the other child receives beside its own constraint (``i``'s plan, departing
at ``t_i``, already meets it).  Sound with both rules: a conflict-free solution of the parent
either has no such departure (it is in ``i``'s child) or has one at some ``s`` in
``[t_i, T)``; then it also meets the other child's constraint, by the argument that made the
rule sound: two moves, ``s`` in ``[t_i, e_i)``, and ``j`` departing in ``[t_j, e_j)`` would put
the offset of the departures in the contact interval; a move and a wait, ``s`` in
``[t_i, t_i + delta)`` passes ``v`` over all of ``[c_s + delta, c_e)``, so ``j`` is not at ``v``
then.  So every conflict-free solution lies in exactly one child (the children no longer
overlap), the constraints of every node stay necessary for the solutions below it, and its
cost stays a lower bound.  The positive constraint only ever removes plans, so each child still
excludes the current conflict and carries the delta rule's constraint of a fixed fraction of
the contact; what disjoint splitting adds is that a robot, once required to make a move, is
not replanned around it in that subtree.  Unlike Li et al. (ICAPS 2019), the requirement is
not turned into constraints of the other robots (a departure *somewhere* in a window implies
no single time at which the others must keep away), as in the authors' implementation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optplan.exact.ccbs_sipp import Constraints, Plan
from optplan.geometry.timing.disc_conflict import (
    CONTACT_REL_TOL,
    TimedMotion,
    TimedMotions,
    contact_interval,
    contact_intervals,
    unsafe_interval,
)

__all__ = ["Action", "Conflict", "Timeline", "actions_of", "timeline_of", "first_conflict",
           "branch"]

#: Padding of an action's bounding box, relative to the largest coordinate: far above the
#: round-off of the closed form, so the box test never drops a pair it would report.
_BOX_PAD = 1e-6


@dataclass(frozen=True)
class Action:
    """A timed action of a plan: a move ``u -> v`` (``u != v``) or a wait at ``u = v``, over
    ``[t0, t1]`` (``t1 = inf`` for the goal hold)."""

    u: int
    v: int
    t0: float
    t1: float

    @property
    def is_move(self) -> bool:
        """Whether the action is a move."""
        return self.u != self.v


def actions_of(plan: Plan) -> list[Action]:
    """The timed actions of ``plan`` in time order (waits of zero length left out)."""
    out = []
    for k, v in enumerate(plan.nodes):
        if plan.depart[k] > plan.arrive[k]:
            out.append(Action(v, v, plan.arrive[k], plan.depart[k]))
        if k + 1 < len(plan.nodes):
            out.append(Action(v, plan.nodes[k + 1], plan.depart[k], plan.arrive[k + 1]))
    return out


def _motion(nodes, act: Action) -> TimedMotion:
    """The disc centre's motion of ``act`` on a graph with node coordinates ``nodes``."""
    a, b = nodes[act.u], nodes[act.v]
    return TimedMotion((float(a[0]), float(a[1])), (float(b[0]), float(b[1])), act.t0, act.t1)


@dataclass(frozen=True)
class Timeline:
    """A plan's timed actions (:func:`actions_of`) as arrays: their motions, which are moves,
    and each one's bounding box (padded by ``1e-6`` of the largest coordinate)."""

    actions: tuple[Action, ...]
    motions: TimedMotions
    is_move: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray


def timeline_of(nodes: np.ndarray, plan: Plan) -> Timeline:
    """The :class:`Timeline` of ``plan`` on a graph with node coordinates ``nodes``."""
    acts = tuple(actions_of(plan))
    u = np.array([x.u for x in acts], int)
    v = np.array([x.v for x in acts], int)
    a, b = nodes[u], nodes[v]
    motions = TimedMotions.build(a, b, np.array([x.t0 for x in acts], float),
                                 np.array([x.t1 for x in acts], float))
    pad = _BOX_PAD * float(np.abs(nodes[np.r_[u, v]]).max(initial=0.0))
    return Timeline(acts, motions, u != v, np.minimum(a, b) - pad, np.maximum(a, b) + pad)


@dataclass(frozen=True)
class Conflict:
    """The first conflict of robots ``i`` and ``j``: their actions and the first contact."""

    i: int
    j: int
    act_i: Action
    act_j: Action
    time: float


def first_conflict(i: int, j: int, line_i: Timeline, line_j: Timeline, contact: float
                   ) -> Conflict | None:
    """The first conflict of two robots' actions (module docstring), ``None`` without one.

    ``contact`` is the sum of their radii; the detection distance is
    ``contact (1 - 2 CONTACT_REL_TOL)``.  Every pair of actions whose windows overlap and
    whose padded bounding boxes come within that distance is tested at once
    (:func:`~optplan.geometry.timing.disc_conflict.contact_intervals`).  Of the pairs whose
    contact begins first, the one earliest in time order (the order of a sweep along both
    plans: by the sum of the two action indices) with a move is the conflict (the last of
    them when all are two waits).
    """
    radius = contact * (1.0 - 2.0 * CONTACT_REL_TOL)
    mi, mj = line_i.motions, line_j.motions
    lo = np.maximum(mi.t0[:, None], mj.t0[None, :])
    hi = np.minimum(mi.t1[:, None], mj.t1[None, :])
    gap = np.maximum(line_i.box_lo[:, None] - line_j.box_hi[None],
                     line_j.box_lo[None] - line_i.box_hi[:, None]).max(axis=2)
    k, m = np.nonzero((hi > lo) & (gap < radius))
    if not len(k):
        return None
    start, _ = contact_intervals(mi.take(k), mj.take(m), radius)
    hit = ~np.isnan(start)
    if not hit.any():
        return None
    t = start[hit].min()
    ties = np.flatnonzero(start == t)
    ties = ties[np.argsort(k[ties] + m[ties], kind="stable")]
    moves = line_i.is_move[k[ties]] | line_j.is_move[m[ties]]
    pick = ties[int(np.argmax(moves))] if moves.any() else ties[-1]
    return Conflict(i, j, line_i.actions[k[pick]], line_j.actions[m[pick]], float(t))


def _move_move(nodes, c: Conflict, radius: float) -> tuple[tuple, tuple]:
    """The two children of a conflict of two moves (the unsafe intervals, each extended while
    the other robot, arrived near this move's start node, cannot yet be far enough from it:
    module docstring)."""
    out = []
    for me, other in ((c.act_i, c.act_j), (c.act_j, c.act_i)):
        hit = unsafe_interval(_motion(nodes, me), _motion(nodes, other), radius)
        end = hit[1] if hit is not None else me.t0
        gap = float(np.hypot(*(nodes[other.v] - nodes[me.u])))
        if gap < radius:
            end = max(end, other.t1 + (radius - gap) / min(_speed(nodes, me),
                                                            _speed(nodes, other)))
        out.append(("edge", me.u, me.v, me.t0, max(end, math.nextafter(me.t0, math.inf))))
    return out[0], out[1]


def _speed(nodes, move: Action) -> float:
    """The speed of a move."""
    return float(np.hypot(*(nodes[move.v] - nodes[move.u]))) / (move.t1 - move.t0)


def _pass(nodes, move: Action, point: np.ndarray, radius: float
          ) -> tuple[float, float] | None:
    """When every plan that makes ``move`` (departing at ``move.t0``) is within ``radius`` of
    ``point``: the move's own contact interval, extended past its end (and before its start)
    while the robot, at speed at most the move's, cannot yet be ``radius`` away from ``point``
    after arriving at (before departing from) an end point within ``radius`` of it.  ``None``
    when the move never comes within ``radius``."""
    a, b = nodes[move.u], nodes[move.v]
    still = TimedMotion((float(point[0]), float(point[1])), (float(point[0]), float(point[1])),
                        -math.inf, math.inf)
    hit = contact_interval(_motion(nodes, move), still, radius)
    if hit is None:
        return None
    cs, ce = hit
    speed = _speed(nodes, move)
    d_a, d_b = float(np.hypot(*(a - point))), float(np.hypot(*(b - point)))
    if d_b < radius:
        ce = max(ce, move.t1 + (radius - d_b) / speed)
    if d_a < radius:
        cs = min(cs, max(0.0, move.t0 - (radius - d_a) / speed))
    return cs, ce


def _move_wait(nodes, move: Action, wait: Action, radius: float, gamma: float
               ) -> tuple[tuple, tuple]:
    """The children of a move against a wait: the delta rule (module docstring)."""
    hit = _pass(nodes, move, nodes[wait.u], radius)
    if hit is None:  # round-off at the detection margin: the smallest step forward
        t = math.nextafter(move.t0, math.inf)
        return (("edge", move.u, move.v, move.t0, t),
                ("vertex", wait.u, wait.u, max(wait.t0, move.t0), t))
    cs, ce = hit
    if math.isinf(wait.t1):  # the goal hold: the one-shot rule (module docstring)
        return (("edge", move.u, move.v, move.t0, math.inf),
                ("hold", wait.u, wait.u, ce, math.inf))
    delta = min(gamma * (ce - cs), wait.t1 - cs)
    return (("edge", move.u, move.v, move.t0, move.t0 + delta),
            ("vertex", wait.u, wait.u, cs + delta, ce))


def branch(nodes, c: Conflict, contact: float, gamma: float) -> tuple[tuple, tuple]:
    """The constraints of the two children of conflict ``c``: one for robot ``c.i``, one for
    ``c.j``, each ``(kind, u, v, t1, t2)`` with ``kind`` ``"edge"`` (no departure along
    ``u -> v`` in ``[t1, t2)``), ``"vertex"`` (not at ``u`` in ``[t1, t2)``) or ``"hold"``
    (the final arrival at the goal ``u`` at ``t1`` or later).

    Parameters
    ----------
    nodes : ndarray ``(n, 2)``
        Node coordinates.
    c : Conflict
    contact : float
        The sum of the two radii (the branching distance is ``contact (1 - CONTACT_REL_TOL)``).
    gamma : float
        The fraction of the contact interval the delta rule excludes, in ``(0, 1)``.

    Raises
    ------
    RuntimeError
        For a conflict of two waits (the module docstring: it is never the first one).
    """
    radius = contact * (1.0 - CONTACT_REL_TOL)
    if c.act_i.is_move and c.act_j.is_move:
        return _move_move(nodes, c, radius)
    if c.act_i.is_move:
        return _move_wait(nodes, c.act_i, c.act_j, radius, gamma)
    if c.act_j.is_move:
        cj, ci = _move_wait(nodes, c.act_j, c.act_i, radius, gamma)
        return ci, cj
    raise RuntimeError(f"ccbs: robots {c.i} and {c.j} first conflict while both wait "
                       f"(at nodes {c.act_i.u} and {c.act_j.u}, t = {c.time:.9g})")


def constrain(cons: Constraints, child: tuple) -> Constraints:
    """A copy of ``cons`` with the child's constraint added (``kind`` ``"vertex"``, ``"edge"``,
    ``"positive"``: a departure along ``u -> v`` required in ``[t1, t2)``, or ``"hold"``: the
    final arrival at the goal at ``t1`` or later)."""
    out = Constraints(dict(cons.vertex), dict(cons.edge), cons.positive, cons.hold_from,
                      cons.key | {child})
    kind, u, v, lo, hi = child
    if kind == "vertex":
        out.add_vertex(u, lo, hi)
    elif kind == "hold":
        out.add_hold(lo)
    elif kind == "positive":
        out.add_positive(u, v, lo, hi)
    else:
        out.add_edge(u, v, lo, hi)
    return out
