"""Map drawing: obstacles as true polygons and circles, inflated obstacles, violations."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Circle, PathPatch
from matplotlib.path import Path as MplPath

from optplan.plot.style import COLLISION_COLOUR
from optplan.problem import Problem


def _polygons(geom: Any) -> list:
    """Polygons of a shapely Polygon / MultiPolygon / collection (empty -> [])."""
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    if hasattr(geom, "geoms"):
        out = []
        for g in geom.geoms:
            out += _polygons(g)
        return out
    return []


def _poly_path(poly: Any) -> MplPath:
    """A matplotlib path of a shapely polygon including its holes."""
    verts, codes = [], []
    for ring in (poly.exterior, *poly.interiors):
        c = np.asarray(ring.coords)[:, :2]
        verts.append(c)
        codes += [MplPath.MOVETO] + [MplPath.LINETO] * (len(c) - 2) + [MplPath.CLOSEPOLY]
    return MplPath(np.concatenate(verts), codes)


def _draw_poly(ax: Axes, geom: Any, **kw: Any) -> list[PathPatch]:
    patches = []
    for poly in _polygons(geom):
        patch = PathPatch(_poly_path(poly), **kw)
        ax.add_patch(patch)
        patches.append(patch)
    return patches


def _draw_obstacle(ax: Axes, o: Any, **kw: Any) -> list:
    """Draw a static obstacle: a true circle for circles, its polygon (holes included) else."""
    if o.is_circle:
        patch = Circle((float(o.center[0]), float(o.center[1])), float(o.radius), **kw)
        ax.add_patch(patch)
        return [patch]
    return _draw_poly(ax, o.geometry, **kw)


def _draw_inflated(ax: Axes, obstacles: Sequence, r: float, **kw: Any) -> None:
    """Dashed outlines of the obstacles grown by ``r``, from the exact model.

    Circles: true circles of radius ``R + r``.  Polygons: shapely ``buffer(r)`` of the exact
    polygon, FOR DRAWING ONLY (a polygonised rounding of the corners; no collision decision
    anywhere uses it, those go to :meth:`optplan.problem.Problem.obstacle_set`).  Overlapping
    polygon outlines are merged.
    """
    import shapely

    label = kw.pop("label", None)
    polys = [o.geometry.buffer(r, quad_segs=16) for o in obstacles if not o.is_circle]
    for g in ([shapely.union_all(polys)] if polys else []):
        for poly in _polygons(g):
            for ring in (poly.exterior, *poly.interiors):
                c = np.asarray(ring.coords)
                ax.plot(c[:, 0], c[:, 1], label=label, gid="outline", **kw)
                label = None
    for o in obstacles:
        if o.is_circle:
            ax.add_patch(Circle((float(o.center[0]), float(o.center[1])),
                                float(o.radius) + r, fill=False, ec=kw.get("color"),
                                ls=kw.get("ls"), lw=kw.get("lw"), zorder=kw.get("zorder"),
                                label=label))
            label = None


def _draw_violations(ax: Axes, v: Mapping[str, list]) -> None:
    """Red marks for :func:`optplan.violations.violations`; legend entries "collision" and
    "outside the map"."""
    label: str | None = "collision"
    for seg in v["segments"]:
        # a wide red band under the path: the robot's colour stays visible along its middle
        ax.plot(seg[:, 0], seg[:, 1], "-", color=COLLISION_COLOUR, lw=6.0, alpha=0.75,
                solid_capstyle="round", zorder=6.9, gid="collision", label=label)
        label = None
    pts = [np.asarray(c["position"], dtype=float) for c in v["contacts"]] + list(v["entries"])
    if pts:
        q = np.asarray(pts).reshape(-1, 2)
        ax.plot(q[:, 0], q[:, 1], "X", color=COLLISION_COLOUR, mec="black", mew=0.6, ms=9,
                ls="none", zorder=10, gid="collision-point", label=label)
    if v["contacts"]:
        c = min(v["contacts"], key=lambda c: c["time"])
        ax.annotate(f"{c.get('other', 'contact')}, t={c['time']:.3g}", tuple(c["position"]),
                    textcoords="offset points", xytext=(6, 6), fontsize=7,
                    color=COLLISION_COLOUR, zorder=10)
    for c in v["moving"]:  # the moving obstacle where it was at the contact
        _draw_poly(ax, c, fc="none", ec=COLLISION_COLOUR, lw=1.0, ls="--", zorder=8.5)
    label = "outside the map"
    for run in v["outside"]:
        ax.plot(run[:, 0], run[:, 1], "--", color=COLLISION_COLOUR, lw=1.6, zorder=8.5,
                gid="outside", label=label)
        label = None
    if v["outside_points"]:
        q = np.concatenate(v["outside_points"])
        ax.plot(q[:, 0], q[:, 1], "o", color=COLLISION_COLOUR, ms=3.5, ls="none", zorder=8.5,
                gid="outside")


def _include_points(ax: Axes, prob: Problem, paths: Mapping[str, np.ndarray]) -> None:
    """Widen the limits so that points outside the bounds are in view."""
    parts = [np.asarray(p, dtype=float).reshape(-1, 2) for p in paths.values()]
    pts = np.concatenate(parts) if parts else np.zeros((0, 2))
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        return
    x0, y0, x1, y1 = prob.bounds
    lo = np.minimum(pts.min(axis=0), (x0, y0))
    hi = np.maximum(pts.max(axis=0), (x1, y1))
    if np.all(lo >= (x0, y0)) and np.all(hi <= (x1, y1)):
        return
    pad = 0.02 * float(max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
