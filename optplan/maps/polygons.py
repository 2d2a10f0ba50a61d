"""Polygon extraction: the exact union of a grid's occupied cells, grown and simplified
conservatively."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon


def _rectangles(mask: np.ndarray, row0: int, col0: int, height: int) -> np.ndarray:
    """Maximal vertical stacks of identical row runs of ``mask`` as boxes in cell units
    (``x = col``, ``y = height - row``; an array of shapely boxes, made in one call);
    ``mask`` is a window at ``(row0, col0)``."""
    h, w = mask.shape
    pad = np.zeros((h, w + 2), dtype=np.int8)
    pad[:, 1:-1] = mask
    d = np.diff(pad, axis=1)
    rs, cs = np.nonzero(d == 1)
    _, ce = np.nonzero(d == -1)
    runs_by_row: dict[int, list[tuple[int, int]]] = {}
    for r, a, b in zip(rs.tolist(), cs.tolist(), ce.tolist()):
        runs_by_row.setdefault(r, []).append((a, b))
    out: list[tuple[int, int, int, int]] = []  # a, b, top, bottom
    active: dict[tuple[int, int], int] = {}
    for r in range(h + 1):
        nxt: dict[tuple[int, int], int] = {}
        for run in runs_by_row.get(r, ()):
            nxt[run] = active.pop(run, r)
        for (a, b), top in active.items():
            out.append((a, b, top, r))
        active = nxt
    q = np.array(out, dtype=float).reshape(-1, 4)
    return shapely.box(col0 + q[:, 0], height - (row0 + q[:, 3]), col0 + q[:, 1],
                       height - (row0 + q[:, 2]))


def exact_union(mask: np.ndarray) -> Any:
    """Exact union of the cell squares of a boolean ``(H, W)`` mask, in cell units
    (``x = col``, ``y = H - row``): a (Multi)Polygon with integer vertices, empty if none."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return Polygon()
    return shapely.union_all(_rectangles(m, 0, 0, m.shape[0]))


def _polys(g: Any) -> list[Polygon]:
    if g.is_empty:
        return []
    if isinstance(g, Polygon):
        return [g]
    return [q for q in getattr(g, "geoms", []) if isinstance(q, Polygon) and not q.is_empty]


#: Fractions of the simplification tolerance tried in turn until the simplified polygon covers
#: its cells (the last, no simplification, always does).
_FALLBACK = (1.0, 0.9, 0.75, 0.5, 0.25, 0.0)


@dataclass
class _Stats:
    components: int = 0
    fallbacks: int = 0
    tolerance_min: float = math.inf


def _grown(u: Any, grow: float, join: str) -> Any:
    """The components ``u`` (one or an array) grown by ``grow`` cells."""
    if grow > 0:
        return shapely.buffer(u, grow, quad_segs=4, join_style=join, mitre_limit=2.0)
    return u


def _conservative_all(us: np.ndarray, grow: float, simplify: float, join: str,
                      stats: _Stats) -> list[Polygon]:
    """:func:`_conservative` of every component ``us``: the first tolerance tried for all
    of them in vectorised calls, the smaller ones only where it does not cover."""
    out: list[Polygon] = []
    if simplify <= 0 or len(us) == 0:
        for u in us:
            out += _conservative(u, grow, simplify, join, stats)
        return out
    g = _grown(us, grow, join)
    s = shapely.simplify(g, simplify * _FALLBACK[0], preserve_topology=True)
    bad = ~shapely.is_valid(s)
    s[bad] = shapely.make_valid(s[bad])
    cov = shapely.covers(s, us)
    for k in range(len(us)):
        if cov[k]:
            stats.tolerance_min = min(stats.tolerance_min, simplify * _FALLBACK[0])
            out += [shapely.geometry.polygon.orient(q, 1.0) for q in _polys(s[k])]
        else:
            out += _conservative(us[k], grow, simplify, join, stats, g[k], first=1)
    return out


def _conservative(u: Any, grow: float, simplify: float, join: str, stats: _Stats,
                  g: Any = None, first: int = 0) -> list[Polygon]:
    """``S`` with ``U <= S <= U + disc(grow + simplify)`` for one component ``u`` (cells;
    ``g``: ``u`` grown, when made already; ``first``: the first tolerance to try)."""
    if g is None:
        g = _grown(u, grow, join)
    for k, f in enumerate(_FALLBACK):
        if k < first:
            continue
        tol = simplify * f
        s = shapely.simplify(g, tol, preserve_topology=True) if tol > 0 else g
        if not s.is_valid:
            s = shapely.make_valid(s)
        if tol <= 0 or shapely.covers(s, u):
            stats.fallbacks += k
            break
    stats.tolerance_min = min(stats.tolerance_min, tol)
    return [shapely.geometry.polygon.orient(q, 1.0) for q in _polys(s)]


def grid_polygons(mask: np.ndarray, *, grow: float = 0.5, simplify: float = 0.5,
                  join: str = "round", stats: dict | None = None) -> list[Polygon]:
    """Conservative polygons (cell units, ``x = col``, ``y = H - row``) of a boolean mask.

    Each 8-connected component of ``mask`` (``skimage.measure.label``) becomes the exact union
    ``U`` of its cell squares, grown by ``grow`` cells (``join``: ``"round"``, the Euclidean
    Minkowski sum, or ``"mitre"``, the square grown by ``grow`` in every axis), simplified with
    the tolerance ``simplify`` cells and checked to cover ``U`` (with a smaller tolerance
    until it does).  Every result covers its component; with ``join = "round"`` it lies inside
    ``U + disc(grow + simplify)`` (``"mitre"``: ``U + disc(sqrt(2) grow + simplify)``).

    ``stats``, if given, receives ``components``, ``fallbacks`` (tolerance reductions) and
    ``tolerance_min`` (the smallest tolerance used).
    """
    from skimage import measure

    m = np.asarray(mask, dtype=bool)
    if grow < 0 or simplify < 0 or not (math.isfinite(grow) and math.isfinite(simplify)):
        raise ValueError(f"grow and simplify must be finite and >= 0, got {grow}, {simplify}")
    if simplify > 0 and grow == 0:
        raise ValueError("simplify > 0 needs grow > 0: without growth the simplified polygon "
                         "cannot cover every cell")
    if join not in ("round", "mitre"):
        raise ValueError(f"join must be 'round' or 'mitre', got {join!r}")
    st = _Stats()
    out: list[Polygon] = []
    if m.any():
        labels = measure.label(m, connectivity=2)
        us = []
        for region in measure.regionprops(labels):
            r0, c0, _, _ = region.bbox
            us.append(shapely.union_all(_rectangles(region.image, r0, c0, m.shape[0])))
        st.components = len(us)
        out = _conservative_all(np.array(us, dtype=object), grow, simplify, join, st)
    if stats is not None:
        stats.update(components=st.components, fallbacks=st.fallbacks,
                     tolerance_min=st.tolerance_min if st.components else simplify)
    return out
