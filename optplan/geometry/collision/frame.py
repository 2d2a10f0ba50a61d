"""The local frame and the tolerance model of the geometry core.

Every geometric computation of optplan runs in a *local frame*: coordinates relative to the
centre of the map's bounds, subtracted once when a map is built.  Round-off then scales with the
size of the map, not with where it sits (a 300 m map at UTM northing 5e6 behaves like the same map
at the origin).

One length scale ``L`` (the diagonal of the bounds) defines every tolerance:

``eps = REL_TOL * L``
    the geometric tolerance.  A disc robot of radius ``r`` is clear of an obstacle when the
    exact distance is ``>= r - eps`` (touching is allowed).

Nothing is scaled by the largest coordinate anywhere: an obstacle far outside the bounds is
dropped (or clipped, when it reaches into the working region) and cannot loosen anything
inside.  Input the double format cannot resolve at this tolerance is rejected (see
:meth:`Frame.check_extent`).  ``docs/geometry.md`` is the user-facing page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["REL_TOL", "MAX_REL_COORD", "MIN_LENGTH", "MAX_LENGTH", "Frame"]

#: Geometric tolerance relative to the map length scale ``L`` (bounds diagonal).
REL_TOL = 1e-9

#: Largest supported |coordinate - frame origin| / L.  Double precision resolves
#: ``1.1e-16 * 1e6 = 1.1e-10 < REL_TOL``: one decade of headroom below the tolerance.
MAX_REL_COORD = 1e6

#: Supported range of the map length scale ``L`` (squares of lengths must neither overflow
#: nor underflow).
MIN_LENGTH = 1e-100
MAX_LENGTH = 1e100


@dataclass(frozen=True)
class Frame:
    """Local frame of a map: origin (centre of the bounds) and length scale.

    Attributes
    ----------
    bounds : tuple of float
        ``(xmin, ymin, xmax, ymax)`` in world coordinates.
    origin : numpy.ndarray
        Centre of the bounds, world coordinates, shape ``(2,)``.
    length : float
        ``L``, the diagonal of the bounds.
    """

    bounds: tuple[float, float, float, float]
    origin: np.ndarray
    length: float

    @classmethod
    def from_bounds(cls, bounds) -> Frame:
        """Frame of ``bounds``; raises ``ValueError`` for sizes double precision cannot hold."""
        x0, y0, x1, y1 = (float(v) for v in bounds)
        if not all(math.isfinite(v) for v in (x0, y0, x1, y1)) or x0 >= x1 or y0 >= y1:
            raise ValueError(f"bounds must be finite with xmin < xmax and ymin < ymax, got "
                             f"{[x0, y0, x1, y1]}")
        w, h = x1 - x0, y1 - y0
        if not math.isfinite(w) or not math.isfinite(h):
            raise ValueError(f"bounds {[x0, y0, x1, y1]}: width or height overflows")
        length = math.hypot(w, h)
        if not (MIN_LENGTH <= length <= MAX_LENGTH):
            raise ValueError(f"bounds {[x0, y0, x1, y1]}: map size {length:.3g} is outside the "
                             f"supported range [{MIN_LENGTH:g}, {MAX_LENGTH:g}]")
        origin = np.array([x0 + 0.5 * w, y0 + 0.5 * h])
        if float(np.max(np.abs(origin))) > MAX_REL_COORD * length:
            raise ValueError(
                f"bounds {[x0, y0, x1, y1]}: the map (size {length:.3g}) sits at "
                f"{float(np.max(np.abs(origin))):.3g} from the coordinate origin, more than "
                f"{MAX_REL_COORD:g} x its size; double precision cannot resolve the tolerance "
                f"{REL_TOL:g} x size there (shift the coordinates)")
        return cls((x0, y0, x1, y1), origin, float(length))

    @property
    def eps(self) -> float:
        """Geometric tolerance ``REL_TOL * L`` (map units)."""
        return REL_TOL * self.length

    @property
    def local_bounds(self) -> tuple[float, float, float, float]:
        """The bounds in the local frame, exactly symmetric around 0: ``(-w/2, -h/2, w/2,
        h/2)`` (the same numbers wherever the map sits; at the origin they equal
        ``bounds - origin``)."""
        x0, y0, x1, y1 = self.bounds
        hw, hh = 0.5 * (x1 - x0), 0.5 * (y1 - y0)
        return (-hw, -hh, hw, hh)

    def local(self, points) -> np.ndarray:
        """World -> local coordinates (float array, same shape)."""
        return np.asarray(points, dtype=float) - self.origin

    def world(self, points) -> np.ndarray:
        """Local -> world coordinates (float array, same shape)."""
        return np.asarray(points, dtype=float) + self.origin

    def check_extent(self, local_extent: float, what: str) -> None:
        """Raise ``ValueError`` when a local |coordinate| or size is beyond what doubles resolve.

        ``local_extent`` is the largest |local coordinate| (or size) of an object that reaches
        into the working region; ``what`` names it for the message.
        """
        if not local_extent <= MAX_REL_COORD * self.length:
            raise ValueError(
                f"{what} reaches {local_extent:.3g} from the centre of a map of size "
                f"{self.length:.3g} (more than {MAX_REL_COORD:g} x its size): double precision "
                f"cannot resolve the tolerance {REL_TOL:g} x size there")

    def in_bounds(self, points, slack: float | None = None) -> np.ndarray:
        """Per point: inside the bounds up to ``slack`` (default ``eps``)."""
        p = self.local(points).reshape(-1, 2)
        x0, y0, x1, y1 = self.local_bounds
        s = self.eps if slack is None else slack
        return ((p[:, 0] >= x0 - s) & (p[:, 0] <= x1 + s) & (p[:, 1] >= y0 - s)
                & (p[:, 1] <= y1 + s))
