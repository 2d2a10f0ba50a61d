"""The one exact geometry core of optplan, one package per subject, each with its public
surface (its ``__all__``; another package imports nothing else):

* :mod:`~optplan.geometry.collision`: the exact collision/clearance engine
  (:class:`ObstacleSet`: true polygons and circles, disc robots of radius ``r >= 0``), the
  local frame and tolerance model (``eps = 1e-9 L``), the one convex decomposition, homotopy
  classes and the polyline utilities.
* :mod:`~optplan.geometry.tangent`: the arc-exact shortest path of a disc robot (the
  certified optimum) on the tangent visibility graph.
* :mod:`~optplan.geometry.timing`: the references in time (moving obstacles' motion, contact
  times, forbidden regions of the (arc length, time) plane, the fastest schedule, arrival
  bounds).
* :mod:`~optplan.geometry.compiled`: the compiled-kernel machinery (``@compiled``, the numba
  cache and the wheel's shipped kernels).

The names below (the collision engine's most used) are re-exported here.
"""

from optplan.geometry.collision import (
    PIECE_EDGES,
    REL_TOL,
    DiscCrossings,
    Frame,
    ObstacleSet,
    clip_obstacles,
    convex_decompose,
    convex_pieces,
    cumulative_length,
    obstacle_set,
    path_lengths,
)

__all__ = [
    "REL_TOL",
    "Frame",
    "PIECE_EDGES",
    "DiscCrossings",
    "ObstacleSet",
    "clip_obstacles",
    "convex_decompose",
    "convex_pieces",
    "obstacle_set",
    "path_lengths",
    "cumulative_length",
]
