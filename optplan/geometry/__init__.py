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

The collision engine's public surface (its ``__all__``) is re-exported here.
"""

from optplan.geometry.collision import *  # noqa: F403
from optplan.geometry.collision import __all__ as __all__
