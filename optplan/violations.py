"""Where the validator's complaints are, on the map (what :mod:`optplan.plot` draws in red).

The validator (:func:`optplan.metrics.evaluate`) counts collisions; this module locates them:
the spans of each path segment that are in contact with a static obstacle (the exact engine,
bisected), each robot's first static contact point, the contacts in time with moving
obstacles and other robots, and the excursions outside the bounds.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from optplan.problem import Problem

__all__ = ["violations", "contact_spans"]


def contact_spans(oset: Any, a: np.ndarray, b: np.ndarray, short: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Per colliding segment ``a[k] -> b[k]``: the parameters of its first and last contact.

    Whether the prefix ``a -> a + u (b - a)`` collides grows with ``u`` and whether the suffix
    ``a + u (b - a) -> b`` does shrinks with it; two rounds of 64 exact tests of each locate
    the first and the last contact to 1/4096 of the segment (the span drawn red is never
    shorter than the contact).  Segments shorter than ``short`` are kept whole.
    """
    k = len(a)
    u0, u1 = np.zeros(k), np.ones(k)
    todo = np.flatnonzero(np.hypot(*(b - a).T) >= short)
    if not todo.size:
        return u0, u1
    A, D = a[todo], (b - a)[todo]
    grid = np.linspace(0.0, 1.0, 65)
    rows = np.repeat(np.arange(len(todo)), len(grid))

    def bad(lo: np.ndarray, hi: np.ndarray, prefix: bool) -> tuple[np.ndarray, np.ndarray]:
        u = lo[:, None] + (hi - lo)[:, None] * grid[None, :]
        pts = A[rows] + u.reshape(-1, 1) * D[rows]
        ends = A[rows] if prefix else A[rows] + D[rows]
        return u, ~oset.segment_free(ends, pts).reshape(u.shape)

    lo, hi = np.zeros(len(todo)), np.ones(len(todo))
    for _ in range(2):  # the first contact: the first u whose prefix collides
        u, hit = bad(lo, hi, True)
        j = np.where(hit.any(axis=1), hit.argmax(axis=1), len(grid) - 1)
        lo, hi = u[np.arange(len(u)), np.maximum(j - 1, 0)], u[np.arange(len(u)), j]
    u0[todo] = lo
    lo, hi = np.zeros(len(todo)), np.ones(len(todo))
    for _ in range(2):  # the last contact: the last u whose suffix collides
        u, hit = bad(lo, hi, False)
        j = np.where(hit.any(axis=1), len(grid) - 1 - hit[:, ::-1].argmax(axis=1), 0)
        lo = u[np.arange(len(u)), j]
        hi = u[np.arange(len(u)), np.minimum(j + 1, len(grid) - 1)]
    u1[todo] = hi
    return u0, u1


def _pair_spans(prob: Problem, oset: Any, sp: np.ndarray, seg: np.ndarray, obs: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The contact span of every colliding (segment, solid) pair, against that solid alone."""
    from optplan.geometry import obstacle_set

    u0, u1 = np.zeros(len(seg)), np.ones(len(seg))
    n_obs = len(prob.obstacles)
    for j in np.unique(obs):
        sel = np.flatnonzero(obs == j)
        solid = oset.members.get(int(j), (int(j),))  # a solid, maybe with the bounds wall
        one = obstacle_set([prob.obstacles[m] for m in solid if m < n_obs], oset.radius,
                           prob.frame, walls=max(solid) >= n_obs)
        u0[sel], u1[sel] = contact_spans(one, sp[seg[sel]], sp[seg[sel] + 1],
                                         2e-3 * prob.extent)
    return u0, u1


def _merged_spans(seg: np.ndarray, u0: np.ndarray, u1: np.ndarray) -> list[list]:
    """``[segment, u0, u1]`` in path order, overlapping spans on one segment merged."""
    spans: list[list] = []
    for i in np.lexsort((u0, seg)):
        if spans and spans[-1][0] == seg[i] and u0[i] <= spans[-1][2]:
            spans[-1][2] = max(spans[-1][2], u1[i])
        else:
            spans.append([int(seg[i]), float(u0[i]), float(u1[i])])
    return spans


def _polylines(sp: np.ndarray, spans: list[list]) -> list[np.ndarray]:
    """The spans as polylines, joined where one ends at a vertex and the next starts there."""
    out: list[np.ndarray] = []
    line: list[np.ndarray] = []
    for i, (k, a0, a1) in enumerate(spans):
        a, d = sp[k], sp[k + 1] - sp[k]
        joined = i > 0 and spans[i - 1][0] == k - 1 and spans[i - 1][2] == 1.0 and a0 == 0.0
        if line and not joined:
            out.append(np.asarray(line))
            line = []
        line += [a + a1 * d] if line else [a + a0 * d, a + a1 * d]
    out.append(np.asarray(line))
    return out


def _static(prob: Problem, rid: str, p: np.ndarray, out: dict[str, list]) -> None:
    """The static contacts of robot ``rid``'s path ``p`` and its excursions out of bounds."""
    oset = prob.obstacle_set(prob.robot(rid).radius)
    sp = p if len(p) > 1 else np.vstack([p, p])
    cr = oset.crossings(sp[None], details=True, penetration=False)
    seg, obs = cr.pairs[1], cr.pairs[2]
    if seg.size:
        spans = _merged_spans(seg, *_pair_spans(prob, oset, sp, seg, obs))
        out["segments"].extend(_polylines(sp, spans))
        k, a0 = spans[0][0], spans[0][1]
        out["entries"].append(sp[k] + a0 * (sp[k + 1] - sp[k]))
    off = np.flatnonzero(~prob.frame.in_bounds(p))
    if off.size:
        out["outside_points"].append(p[off])
        for run in np.split(off, np.flatnonzero(np.diff(off) > 1) + 1):
            out["outside"].append(p[max(run[0] - 1, 0): run[-1] + 2])


def _contacts(prob: Problem, own: dict, paths: Mapping, metrics: Mapping,
              times: np.ndarray | None) -> list[dict]:
    """The contacts in time: ``metrics["contacts"]``, else the first contact and, when the
    metrics count more than one, all of them recomputed."""
    contacts = metrics.get("contacts")
    if contacts is None:
        first = metrics.get("first_contact")
        contacts = [first] if first else []
        n = int(metrics.get("dynamic_contacts", 0) or 0) + int(
            metrics.get("separation_violations", 0) or 0)
        if first and n > 1 and set(own) == set(paths):
            from optplan.metrics import time_checks, time_stamps

            tc = time_checks(prob, own, time_stamps(prob, own, times))
            contacts = sorted(tc["contacts"], key=lambda c: c["time"]) or contacts
    return [c for c in contacts if c and c.get("position") is not None]


def violations(prob: Problem, paths: Mapping[str, np.ndarray], metrics: Mapping,
               times: np.ndarray | None) -> dict[str, list]:
    """Where the validator's complaints are, on the map.

    ``segments``: the path segments colliding with a static obstacle (or the bounds wall),
    recomputed with the exact engine (``problem.obstacle_set(radius).crossings(...,
    details=True).pairs``), each trimmed to its spans of contact with each solid it meets
    (:func:`contact_spans`), joined into one polyline where consecutive spans meet;
    ``entries``: each colliding robot's first static contact point; ``contacts``: the contacts
    in time (moving obstacles, other robots) with ``time`` and ``position``, from
    ``metrics["contacts"]``, else ``metrics["first_contact"]`` (and, when the metrics count
    more than one, all of them recomputed by :func:`optplan.metrics.time_checks`);
    ``moving``: the shapes of the moving obstacles met, where they were at the contact (first
    10 contacts); ``outside``: runs of path points outside the bounds, with the neighbouring
    points inside (the excursion), and ``outside_points``.
    """
    out: dict[str, list] = {"segments": [], "entries": [], "contacts": [], "moving": [],
                            "outside": [], "outside_points": []}
    own = {k: np.asarray(v, dtype=float).reshape(-1, 2) for k, v in paths.items()
           if k in prob.robot_ids and len(np.asarray(v))}
    for rid, p in own.items():
        _static(prob, rid, p, out)
    out["contacts"] = _contacts(prob, own, paths, metrics, times)
    movers = {d.name: d for d in prob.dynamic_obstacles}
    out["moving"] = [movers[c["other"]].geometry_at(float(c["time"]))
                     for c in out["contacts"][:10]
                     if c.get("kind") == "moving obstacle" and c.get("other") in movers]
    return out
