"""The exact collision and clearance engine: the local frame and its tolerance
(:mod:`.frame`), the obstacle set of true polygons and circles (:mod:`.obstacles`, with the
solids it merges, :mod:`.solids`, its convex pieces, :mod:`.pieces`, its item grid,
:mod:`.grid`, and its compiled loops, :mod:`.kernel`, :mod:`.nearest_kernel`,
:mod:`.pairs_kernel`), homotopy classes by winding numbers (:mod:`.homotopy`) and the
polyline utilities every method shares (:mod:`.polyline`, with the farthest vertex in clear
sight that every waypoint follower steers for).
"""

from optplan.geometry.collision.frame import MAX_REL_COORD, REL_TOL, Frame
from optplan.geometry.collision.homotopy import obstacle_points, same_homotopy
from optplan.geometry.collision.obstacles import (
    PIECE_EDGES,
    DiscCrossings,
    ObstacleSet,
    clip_obstacles,
    obstacle_set,
)
from optplan.geometry.collision.pieces import convex_decompose, convex_pieces
from optplan.geometry.collision.polyline import (
    cumulative_length,
    farthest_clear,
    path_lengths,
    points_along,
    resample_path,
    resample_uniform,
)
from optplan.geometry.collision.solids import corner_partners, solid_edges, solid_rings

__all__ = [
    "MAX_REL_COORD",
    "REL_TOL",
    "Frame",
    "PIECE_EDGES",
    "DiscCrossings",
    "ObstacleSet",
    "clip_obstacles",
    "obstacle_set",
    "solid_edges",
    "solid_rings",
    "convex_decompose",
    "convex_pieces",
    "corner_partners",
    "obstacle_points",
    "same_homotopy",
    "cumulative_length",
    "farthest_clear",
    "path_lengths",
    "points_along",
    "resample_path",
    "resample_uniform",
]
