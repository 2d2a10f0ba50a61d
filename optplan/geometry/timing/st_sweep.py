r"""The earliest arrival along a path: a sweep of the (arc length, delay) plane.

Along a fixed path, a schedule is a non-decreasing time ``t(s)`` with ``dt/ds >= 1/v``.  In the
coordinates ``(s, tau)`` with the *delay* ``tau = t - s / v``, full speed is horizontal and a
wait is vertical, so a schedule is exactly a non-decreasing ``tau(s)`` from ``(0, 0)`` that
avoids the forbidden regions (:mod:`optplan.geometry.timing.st_regions`; a shear keeps them convex),
and the earliest arrival is the lowest such path's ``tau`` at ``s = S``, plus ``S / v``.

**Structure.**  At a given ``s`` each region's section is an open interval ``(lo(s), hi(s))``
with ``lo`` convex and ``hi`` concave.  Overlapping sections merge into *blocks* (closed: two
sections that touch leave no room), and the free *gaps* lie between blocks.  The gap
structure changes only where a region's extent in ``s`` begins or ends, at the path's corners,
and where two regions begin or cease to overlap: ``f(s) = max(lo_i - hi_j, lo_j - hi_i)`` is
convex, so its zeros are found by a golden-section minimum and bisection (to round-off).
Between two such *events* the gaps keep their floor block and ceiling block.

**Sweep.**  In a gap entered at ``s_a`` at delay ``e_a``, the lowest path is
``tau(s) = max(e_a, max_i max_{[s_a, s]} hi_i)`` over the floor block's regions ``i`` (a
running maximum: wait exactly as long as the floor demands).  ``hi_i`` is concave, so this
running maximum is ``hi_i`` up to its peak and flat after it, and the gap survives the
interval iff every ceiling region's ``lo`` stays above it: minima of ``lo`` over sub-intervals,
all closed-form extremes of a linear function over a convex region
(:func:`~optplan.geometry.timing.st_regions.region_extremes`).  At an event, the robot may wait: the
free vertical segments (*components*) at that ``s`` connect the gaps ending there to the gaps
starting there.  The arrival is the lowest reachable delay at ``s = S``.

**Schedule.**  The lowest path is realised by a staircase (full speed, then a wait) that stays
on or above the floor and strictly below the ceiling; its corners touch the floor at most, so
the schedule is collision-free with touching allowed, and its arrival is the optimum.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optplan.geometry.timing.st_regions import Regions, region_extremes, sections

__all__ = ["Sweep", "sweep"]

#: golden-section and bisection steps (each shrinks the bracket by 0.618 or 0.5: far below
#: any resolution of the arc length)
_GOLDEN_STEPS = 90
_BISECT_STEPS = 64
_PHI = (np.sqrt(5.0) - 1.0) / 2.0


@dataclass
class _Gap:
    """A gap of one interval: its entry, floor and ceiling regions, back pointer."""

    floor: np.ndarray
    ceil: np.ndarray
    entry: float | None = None
    source: int = -1
    exit: float | None = None


@dataclass
class _Comp:
    """A free vertical segment at an event: ``[lo, hi]``, its lowest reachable delay."""

    lo: float
    hi: float
    reach: float | None = None
    source: int = -1


@dataclass
class Sweep:
    """The result of :func:`sweep` in ``(s, tau)`` coordinates.

    Attributes
    ----------
    arrival_tau : float or None
        The lowest reachable delay at ``s = S`` (``None``: the end is unreachable).
    corners : ndarray ``(m, 2)``
        The staircase ``(s, tau)`` of an optimal schedule (``s`` and ``tau`` non-decreasing).
    start_blocked : bool
        The start ``(0, 0)`` lies inside a forbidden region.
    events : int
        Number of events of the sweep.
    """

    arrival_tau: float | None
    corners: np.ndarray
    start_blocked: bool = False
    events: int = 0
    info: dict = field(default_factory=dict)


class _Plane:
    """The regions in ``(s, tau)`` coordinates: sections, extents, domains."""

    def __init__(self, reg: Regions, speed: float, stol: float):
        self.reg, self.v, self.stol = reg, float(speed), float(stol)
        self.off = reg.ta - reg.s0 / self.v  # tau = off + t' - sigma / v
        self.g = np.array([-1.0 / self.v, 1.0])
        full0, full1 = np.zeros(len(reg)), reg.ell
        hi_s, _, t_end = region_extremes(reg, np.array([1.0, 0.0]), full0, full1)
        lo_s, _, t_beg = region_extremes(reg, np.array([-1.0, 0.0]), full0, full1)
        self.dom = np.stack([reg.s0 - lo_s, reg.s0 + hi_s], axis=1)  # -inf/inf where empty
        # the delay at the two extreme points of each region in s (its closure's section there
        # when the region only touches the line s = const)
        self.tips = np.stack([self.off + t_beg - self.dom[:, 0] / self.v + reg.s0 / self.v,
                              self.off + t_end - self.dom[:, 1] / self.v + reg.s0 / self.v],
                             axis=1)
        self.tmax = self.off + region_extremes(reg, self.g, full0, full1)[0]
        self.tmin = self.off - region_extremes(reg, -self.g, full0, full1)[0]

    def section(self, idx: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Delay sections ``(lo, hi)`` of regions ``idx`` at arc lengths ``s`` (NaN: none)."""
        reg = self.reg.take(idx)
        sig = np.clip(s - reg.s0, 0.0, reg.ell)
        lo, hi = sections(reg, sig)
        base = self.off[idx] - sig / self.v
        return base + lo, base + hi

    def closure(self, idx: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`section`, with the closure's single point where a region only touches the
        line ``s = const`` (at the ends of its extent, within :attr:`stol`)."""
        lo, hi = self.section(idx, s)
        for end in (0, 1):
            tip = np.isnan(lo) & (np.abs(s - self.dom[idx, end]) <= self.stol)
            lo = np.where(tip, self.tips[idx, end], lo)
            hi = np.where(tip, self.tips[idx, end], hi)
        return lo, hi

    def peak(self, idx: np.ndarray, a: np.ndarray, b: np.ndarray, top: bool
             ) -> tuple[np.ndarray, np.ndarray]:
        """Max (``top``) or min of the delay over regions ``idx`` within ``s in [a, b]``, and
        the arc length where it is attained (``-inf`` / ``inf`` where they do not meet)."""
        reg = self.reg.take(idx)
        lo = np.clip(a - reg.s0, 0.0, reg.ell)
        hi = np.clip(b - reg.s0, 0.0, reg.ell)
        val, sig, _ = region_extremes(reg, self.g if top else -self.g, lo, np.maximum(hi, lo))
        val = self.off[idx] + (val if top else -val)
        return val, reg.s0 + sig


def _overlap(plane: _Plane, i: np.ndarray, j: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``max(lo_i - hi_j, lo_j - hi_i)`` at ``s`` (``inf`` where a section is empty)."""
    li, hi_i = plane.section(i, s)
    lj, hj = plane.section(j, s)
    f = np.maximum(li - hj, lj - hi_i)
    return np.where(np.isnan(f), np.inf, f)


def _overlapping(dom: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The index pairs ``(a, b)``, ``a != b`` once each, of the intervals ``dom`` ``(n, 2)``
    that overlap: sorted by start, each interval meets the ones that start before it ends
    (memory grows with the overlapping pairs, not with ``n^2``)."""
    order = np.argsort(dom[:, 0], kind="stable")
    starts = dom[order, 0]
    ends = np.searchsorted(starts, dom[order, 1], side="left")  # first start at/after the end
    counts = np.maximum(ends - np.arange(len(order)) - 1, 0)
    a = np.repeat(np.arange(len(order)), counts)
    first = np.repeat(np.arange(len(order)) + 1 - np.concatenate([[0], np.cumsum(counts)[:-1]]),
                      counts)
    b = first + np.arange(len(a))
    return order[a], order[b]


def _pair_events(plane: _Plane, keep: np.ndarray) -> np.ndarray:
    """Arc lengths where two regions begin or cease to overlap (convex ``f``: golden-section
    minimum, then bisection on each side)."""
    if len(keep) < 2:
        return np.zeros(0)
    dom, tmin, tmax = plane.dom[keep], plane.tmin[keep], plane.tmax[keep]
    a, b = _overlapping(dom)
    lo = np.maximum(dom[a, 0], dom[b, 0])
    hi = np.minimum(dom[a, 1], dom[b, 1])
    ok = (lo < hi) & (np.maximum(tmin[a], tmin[b]) < np.minimum(tmax[a], tmax[b]))
    i, j, lo, hi = keep[a[ok]], keep[b[ok]], lo[ok], hi[ok]
    if len(i) == 0:
        return np.zeros(0)
    x0, x1 = lo.copy(), hi.copy()
    for _ in range(_GOLDEN_STEPS):
        m1, m2 = x1 - _PHI * (x1 - x0), x0 + _PHI * (x1 - x0)
        left = _overlap(plane, i, j, m1) <= _overlap(plane, i, j, m2)
        x0, x1 = np.where(left, x0, m1), np.where(left, m2, x1)
    m = 0.5 * (x0 + x1)
    neg = _overlap(plane, i, j, m) < 0
    out = []
    for end in (lo, hi):
        p, q = m[neg].copy(), end[neg].copy()  # f(p) < 0; the root lies between p and q
        for _ in range(_BISECT_STEPS):
            c = 0.5 * (p + q)
            inside = _overlap(plane, i[neg], j[neg], c) < 0
            p, q = np.where(inside, c, p), np.where(inside, q, c)
        out.append(q)
    return np.concatenate(out) if out else np.zeros(0)


def _blocks(lo: np.ndarray, hi: np.ndarray, idx: np.ndarray) -> list[tuple[float, float,
                                                                          np.ndarray]]:
    """Closed merge of the sections ``(lo, hi)`` of regions ``idx``: ``(lo, hi, members)``."""
    ok = ~np.isnan(lo)
    lo, hi, idx = lo[ok], hi[ok], idx[ok]
    order = np.argsort(lo, kind="stable")
    out: list[tuple[float, float, list]] = []
    for k in order:
        if out and lo[k] <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi[k]), out[-1][2] + [idx[k]])
        else:
            out.append((lo[k], hi[k], [idx[k]]))
    return [(a, b, np.asarray(m, int)) for a, b, m in out]


def _components(plane: _Plane, s: float) -> list[_Comp]:
    """The free vertical segments at ``s``.

    A region blocks the line ``s = const`` where its open section is not empty: inside its
    extent in ``s``, and at an end of its extent that is an end of its path segment (the
    robot at a corner of the path).  At an end set by the obstacle's shape the region only
    touches the line (an interior point would reach further), and touching is allowed.
    """
    st, dom = plane.stol, plane.dom
    seg_lo = np.abs(dom[:, 0] - plane.reg.s0) <= st
    seg_hi = np.abs(dom[:, 1] - (plane.reg.s0 + plane.reg.ell)) <= st
    idx = np.flatnonzero(((dom[:, 0] < s - st) | (seg_lo & (dom[:, 0] <= s + st)))
                         & ((dom[:, 1] > s + st) | (seg_hi & (dom[:, 1] >= s - st))))
    lo, hi = plane.section(idx, np.full(len(idx), s))
    edges = [-np.inf]
    for a, b, _ in _blocks(lo, hi, idx):
        edges += [a, b]
    edges.append(np.inf)
    return [_Comp(edges[k], edges[k + 1]) for k in range(0, len(edges), 2)]


def _gaps(plane: _Plane, a: float, b: float) -> list[_Gap]:
    """The gaps of the interval ``(a, b)`` (structure at its midpoint)."""
    mid = 0.5 * (a + b)
    idx = np.flatnonzero((plane.dom[:, 0] < mid) & (plane.dom[:, 1] > mid))
    lo, hi = plane.section(idx, np.full(len(idx), mid))
    members = [m for _, _, m in _blocks(lo, hi, idx)]
    none = np.zeros(0, int)
    bounds = [none, *members, none]
    return [_Gap(bounds[k], bounds[k + 1]) for k in range(len(bounds) - 1)]


def _limits(plane: _Plane, gap: _Gap, s: float) -> tuple[float, float]:
    """The gap's floor and ceiling at ``s`` (``-inf`` / ``inf`` where unbounded), on the
    closure of its regions."""
    fl = plane.closure(gap.floor, np.full(len(gap.floor), s))[1]
    ce = plane.closure(gap.ceil, np.full(len(gap.ceil), s))[0]
    f = float(np.nanmax(fl)) if np.isfinite(fl).any() else -np.inf
    c = float(np.nanmin(ce)) if np.isfinite(ce).any() else np.inf
    return f, c


def _enter(plane: _Plane, gap: _Gap, comps: list[_Comp], s: float, tol: float) -> None:
    """The gap's lowest entry delay at ``s`` from the components there."""
    f, c = _limits(plane, gap, s)
    for k, comp in enumerate(comps):
        if comp.reach is None:
            continue
        level = max(comp.reach, f)
        if level <= comp.hi + tol and level < c and (gap.entry is None or level < gap.entry):
            gap.entry, gap.source = level, k


def _run(plane: _Plane, gap: _Gap, a: float, b: float) -> None:
    """Carry the gap's entry across ``[a, b]``: its exit delay, or ``None`` if squeezed."""
    e = gap.entry
    if e is None:
        return
    n_f, n_c = len(gap.floor), len(gap.ceil)
    top, arg = (plane.peak(gap.floor, np.full(n_f, a), np.full(n_f, b), True)
                if n_f else (np.zeros(0), np.zeros(0)))
    if n_c:
        low, _ = plane.peak(gap.ceil, np.full(n_c, a), np.full(n_c, b), False)
        if np.any(low <= e):
            return
        lift = top > e
        if lift.any():
            ii = np.repeat(np.flatnonzero(lift), n_c)
            kk = np.tile(np.arange(n_c), int(lift.sum()))
            low2, _ = plane.peak(gap.ceil[kk], arg[ii], np.full(len(ii), b), False)
            if np.any(low2 <= top[ii]):
                return
    gap.exit = max([e, *top.tolist()])


def _leave(gaps: list[_Gap], comps: list[_Comp], tol: float) -> None:
    """Hand the surviving gaps' exit delays to the components at the interval's end."""
    for g, gap in enumerate(gaps):
        if gap.exit is None:
            continue
        for comp in comps:
            if comp.lo - tol <= gap.exit <= comp.hi + tol:
                level = max(gap.exit, comp.lo)
                if comp.reach is None or level < comp.reach:
                    comp.reach, comp.source = level, g
                break


def _events(plane: _Plane, keep: np.ndarray, knots: np.ndarray, S: float) -> np.ndarray:
    ev = np.concatenate([[0.0, S], knots, plane.dom[keep].ravel(), _pair_events(plane, keep)])
    ev = np.unique(np.clip(ev[np.isfinite(ev)], 0.0, S))
    if len(ev) > 1:  # merge events closer than round-off of the arc length
        ev = ev[np.concatenate([[True], np.diff(ev) > 1e-12 * S])]
        ev[-1] = S
    return ev


def sweep(reg: Regions, speed: float, knots: np.ndarray, S: float, tol: float) -> Sweep:
    """The lowest schedule along a path of length ``S > 0`` (module docstring).

    Parameters
    ----------
    reg : Regions
        The path's forbidden regions (:func:`~optplan.geometry.timing.st_regions.path_regions`).
    speed : float
        The robot's speed limit.
    knots : ndarray
        Arc lengths of the path's corners.
    S : float
        The path's length.
    tol : float
        Delay tolerance of the hand-over between gaps and components (round-off).
    """
    plane = _Plane(reg, speed, 1e-9 * S)
    keep = np.flatnonzero(np.isfinite(plane.dom[:, 0]) & (plane.tmax > -tol))
    ev = _events(plane, keep, knots, S)
    comps = _components(plane, 0.0)
    start = [c for c in comps if c.lo - tol <= 0.0 <= c.hi + tol]
    if not start:
        return Sweep(None, np.zeros((0, 2)), start_blocked=True, events=len(ev))
    start[0].reach = 0.0
    history: list[tuple[list[_Gap], float, float, list[_Comp]]] = []
    for a, b in zip(ev[:-1], ev[1:]):
        gaps = _gaps(plane, a, b)
        for gap in gaps:
            _enter(plane, gap, comps, a, tol)
            _run(plane, gap, a, b)
        comps = _components(plane, b)
        _leave(gaps, comps, tol)
        history.append((gaps, a, b, comps))
    best = [k for k, c in enumerate(comps) if c.reach is not None]
    if not best:
        return Sweep(None, np.zeros((0, 2)), events=len(ev))
    last = min(best, key=lambda k: float(comps[k].reach or 0.0))
    arrival = float(comps[last].reach or 0.0)
    return Sweep(arrival, _staircase(plane, history, last, S, arrival), events=len(ev))


def _staircase(plane: _Plane, history: list, comp: int, S: float, arrival: float
               ) -> np.ndarray:
    """The corners ``(s, tau)`` of an optimal schedule, traced back through the sweep from
    component ``comp`` at the end of the path."""
    pts: list[tuple[float, float]] = [(S, arrival)]
    for gaps, a, b, comps_b in reversed(history):
        gap = gaps[comps_b[comp].source]
        pts += reversed(_steps(plane, gap, a, b))
        comp = gap.source
    pts.append((0.0, 0.0))
    out = np.array(pts[::-1], float)
    out[:, 1] = np.maximum.accumulate(out[:, 1])
    return out


def _steps(plane: _Plane, gap: _Gap, a: float, b: float) -> list[tuple[float, float]]:
    """A staircase from ``(a, entry)`` to ``(b, exit)`` on or above the gap's running floor and
    strictly below its ceiling (refined by halving where a level would touch the ceiling)."""
    e, x = float(gap.entry or 0.0), float(gap.exit or 0.0)
    if x <= e or len(gap.floor) == 0:
        return [(a, e), (b, e)]
    n_f = len(gap.floor)
    top, arg = plane.peak(gap.floor, np.full(n_f, a), np.full(n_f, b), True)
    m = float(np.max(arg[top > e]))
    cuts = [a, m, b] if a < m < b else [a, b]
    for _ in range(40):
        levels = [_level(plane, gap, a, q, e) for q in cuts[1:]]
        bad = [k for k in range(len(levels)) if not _below(plane, gap, cuts[k], cuts[k + 1],
                                                             levels[k])]
        if not bad:
            break
        for k in reversed(bad):
            cuts.insert(k + 1, 0.5 * (cuts[k] + cuts[k + 1]))
    pts: list[tuple[float, float]] = [(a, e)]
    for p, q, lv in zip(cuts[:-1], cuts[1:], levels):
        pts += [(p, lv), (q, lv)]
    return pts


def _level(plane: _Plane, gap: _Gap, a: float, q: float, e: float) -> float:
    """The running floor at ``q``: ``max(e, max_i max_{[a, q]} hi_i)``."""
    n = len(gap.floor)
    top, _ = plane.peak(gap.floor, np.full(n, a), np.full(n, q), True)
    return max([e, *top.tolist()])


def _below(plane: _Plane, gap: _Gap, p: float, q: float, level: float) -> bool:
    """Whether ``level`` stays strictly below the gap's ceiling on ``[p, q]``."""
    n = len(gap.ceil)
    if n == 0:
        return True
    low, _ = plane.peak(gap.ceil, np.full(n, p), np.full(n, q), False)
    return bool(np.all(low > level))
