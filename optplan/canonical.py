"""The canonical frame: a scene divided by its length scale, coordinates quantised.

A chaotic planner (the hybrid's simulated-annealing walk among potential fields) amplifies a
last-bit difference of its input until a discrete decision flips.  A scene drawn in centimetres is
not an exact binary multiple of the same scene drawn in metres (0.01 has no finite binary
expansion), so such a planner run on the two drawings parts after a few hundred steps, although
every option it has is a multiple of :attr:`~optplan.problem.Problem.length_scale`.

The *canonical image* of a problem removes that difference before the planner starts:

1. every length is divided by the problem's ``length_scale`` ``u`` (about the coordinate origin;
   times are unchanged), so the image of the centimetre drawing and that of the metre drawing
   differ by a few units in the last place, and the image's ``length_scale`` is exactly 1;
2. every coordinate and length of the image is rounded to ``d = DIGITS - floor(log10 L)``
   decimal places (``L`` the image's bounds diagonal; ``d = 7`` when ``length_scale`` is derived,
   ``L`` about 707).  Two values a few units in the last place apart round to the same decimal
   unless they straddle a rounding boundary: never for coordinates written with at most ``d``
   decimals in the image's units (they sit on the grid, and a ``d``-decimal literal maps to
   itself exactly, so a paper scene's image *is* the scene), and with a chance of about ``2e-6``
   per coordinate otherwise.

The planner runs on the image and its answer is mapped back (``x u``; the start of each path is set
to the robot's exact start).  The shared validator then grades the mapped paths on the problem as
given.  Rounding moves a vertex or a radius by at most ``0.5 x 10**-d <= 5e-10 L``, at most half the
geometric tolerance ``eps = 1e-9 L`` (:mod:`optplan.geometry.collision.frame`) and about a tenth of
it at the usual ``L = 707``, so the image is the same scene to within the validator's resolution.

What is and is not invariant: a drawing scaled by any factor gives bit-identical planner decisions
(up to the straddle chance above); a translated drawing does not (the frame is about the origin, and
translation changes the last bits of every coordinate).  The ``hybrid`` backend plans in this frame;
the other backends plan on the scene as given (their scale invariance within 1 % is tested
directly, ``tests/core/test_scale_invariance.py``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from optplan.problem import Problem, round_decimals, transform_problem

__all__ = ["DIGITS", "canonical_problem", "to_canonical", "to_world", "format_point"]

#: Decimal digits kept below the leading digit of the image's bounds diagonal.
DIGITS = 9


def canonical_problem(problem: Problem) -> Problem:
    """The canonical image of ``problem`` (cached on it; module docstring).

    Its ``length_scale`` is exactly 1 and its :attr:`~optplan.problem.Problem.world_unit` is the
    world length of one of its units (``problem.length_scale``).
    """

    def build() -> Problem:
        u = problem.length_scale
        x0, y0, x1, y1 = problem.bounds
        diag = math.hypot(x1 - x0, y1 - y0) / u
        d = DIGITS - math.floor(math.log10(diag))
        image = transform_problem(problem, 1.0 / u, decimals=d)
        image = dataclasses.replace(image, scale=1.0, world_unit=u, _cache={})
        image.memo(("decimals",), lambda: d)
        return image

    return problem.memo(("canonical",), build)


def to_canonical(image: Problem, points: Any) -> np.ndarray:
    """World ``points`` (e.g. an ``init`` path) in the coordinates of the canonical ``image``:
    divided by its unit and rounded like the image itself."""
    d = image.memo(("decimals",), lambda: None)
    x = np.asarray(points, dtype=float) / image.world_unit
    return x if d is None else round_decimals(x, d)


def to_world(x: Any, unit: float) -> Any:
    """Coordinates or lengths of the canonical image in world units (``x * unit``), through
    dicts and lists; ``None`` stays ``None``."""
    if x is None:
        return None
    if isinstance(x, dict):
        return {k: to_world(v, unit) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return type(x)(to_world(v, unit) for v in x)
    if isinstance(x, np.ndarray):
        return x * unit
    return float(x) * unit


def format_point(problem: Problem, x: Any) -> str:
    """``"(x, y)"`` of a point of ``problem`` in world coordinates (for messages)."""
    w = np.asarray(x, dtype=float) * problem.world_unit
    return f"({w[0]:.2f}, {w[1]:.2f})"
