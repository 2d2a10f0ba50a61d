"""The one exact geometry core of optplan.

* :mod:`~optplan.geometry.frame`: local frame and tolerance model (``eps = 1e-9 L``).
* :mod:`~optplan.geometry.obstacles`: the exact collision/clearance engine
  (:class:`ObstacleSet`: true polygons and circles, disc robots of radius ``r >= 0``).
* :mod:`~optplan.geometry.tangent_graph`: the arc-exact shortest path of a disc robot
  (the certified optimum).
* :mod:`~optplan.geometry.pieces`: the one convex decomposition.
* :mod:`~optplan.geometry.polyline`: polyline utilities.
"""

from optplan.geometry.frame import REL_TOL, Frame
from optplan.geometry.obstacles import (
    PIECE_EDGES,
    DiscCrossings,
    ObstacleSet,
    clip_obstacles,
    obstacle_set,
)
from optplan.geometry.pieces import convex_decompose, convex_pieces
from optplan.geometry.polyline import cumulative_length, path_lengths

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
