"""Occupancy grids and benchmark maps as optplan problems (``docs/maps.md``).

Readers
-------
* **ROS** ``map_server`` **YAML** (:func:`read_ros_yaml`): ``image`` (relative to the YAML
  file), ``resolution`` (m / cell), ``origin`` ``[x, y, yaw]`` (the pose of the lower-left
  corner of the image), ``negate``, ``occupied_thresh``, ``free_thresh`` and ``mode``
  (``trinary``, ``scale``, ``raw``), classified as ROS ``map_server`` does.
* **bare images** (PNG, PGM, ...; :func:`read_image`) with a given ``resolution`` and
  ``origin`` and the same classification options.
* **ROS messages** as plain dicts (:mod:`optplan.maps.ros_msgs`, no ROS needed): an
  in-memory ``nav_msgs/OccupancyGrid`` (:func:`read_occupancy_grid`; ``data`` int8 -1/0..100
  row-major from the origin cell, classified as ``map_server``'s ``raw`` mode), and out, a
  result's timed path as ``nav_msgs/Path`` (:func:`path_msg`, ``optplan export-path``) and a
  grid as ``nav_msgs/OccupancyGrid`` (:func:`occupancy_grid_msg`).
* **MovingAI** ``.map`` grids (:func:`read_movingai`) and their ``.scen`` start/goal pairs
  (:func:`read_scen`: one :class:`~optplan.Problem` per line, a batch for ``bench``; one
  line by name, ``<file>.scen#line=N``: :func:`read_scen_line`).
* **multi-agent path finding** (``docs/mapf.md``): Continuous-CBS's GraphML roadmaps and task
  files (:func:`read_roadmap_mapf`, :func:`write_roadmap_mapf`) and MovingAI MAPF grids
  (:func:`read_movingai_mapf`: the first ``k`` lines of a ``.scen`` as agents), as problems
  whose robots keep to a roadmap (``Problem.roadmap``).

Every reader returns a :class:`Grid` (cells ``FREE``, ``OCCUPIED`` or ``UNKNOWN``; row 0 is
the *top* of the map).  :func:`grid_polygons` turns its obstacle cells (occupied, and unknown
unless ``unknown="free"``) into polygons with holes, **conservatively**: every obstacle cell
square lies inside the polygons.  The construction, in cell units:

1. the exact union ``U`` of the obstacle cell squares, one 8-connected component at a time
   (``skimage.measure.label``; each component is the union of the maximal rectangles of its
   row runs, integer coordinates, so the union is exact);
2. ``U`` grown by ``grow`` cells (Minkowski sum with a disc, ``shapely.buffer``);
3. simplified (Douglas-Peucker, topology preserved) with the tolerance ``simplify`` cells;
4. verified: the simplified polygon must cover ``U`` (``shapely.covers``, exact for the
   integer squares); if not, step 3 is repeated with 0.9, 0.75, 0.5 and 0.25 times the
   tolerance, and finally without simplification.  The result ``S`` satisfies
   ``U <= S <= U + disc(grow + simplify)`` (Minkowski sums).

:func:`import_map` adds robots (:class:`Robots`) and returns a validated
:class:`~optplan.Problem` (its errors are :class:`~optplan.ProblemError` naming the file and
key); its options are grouped in :class:`ReadOptions` (how the map is read, unknown cells,
cropping), :class:`PolygonOptions` (``grow``, ``simplify``, ``join``; :func:`read_scen`
takes them too) and :class:`SceneOptions` (the scenario's name and keys); :func:`write_toml`
writes any problem as a scenario file.  World coordinates: cell ``(row, col)`` of an image
with ``H`` rows covers
``origin + R(yaw) @ resolution * ([col, col + 1] x [H - 1 - row, H - row])``.
"""

from __future__ import annotations

from optplan.maps.grid import FREE, MAX_CELLS, OCCUPIED, UNKNOWN, Grid
from optplan.maps.importer import CROP_MARGIN as CROP_MARGIN
from optplan.maps.importer import ROUND_REL as ROUND_REL
from optplan.maps.importer import import_map, scene_name
from optplan.maps.mapf import (
    read_graphml,
    read_movingai_mapf,
    read_roadmap_mapf,
    read_tasks,
    write_roadmap_mapf,
)
from optplan.maps.mapf_build import CCBS_RADIUS as CCBS_RADIUS
from optplan.maps.mapf_build import grid_mapf_problem, roadmap_problem
from optplan.maps.movingai import MOVINGAI_BLOCKED as MOVINGAI_BLOCKED
from optplan.maps.movingai import MOVINGAI_PASSABLE as MOVINGAI_PASSABLE
from optplan.maps.movingai import read_movingai
from optplan.maps.occupancy import ROS_DEFAULTS as ROS_DEFAULTS
from optplan.maps.occupancy import classify as classify
from optplan.maps.occupancy import read_grid, read_image, read_ros_yaml
from optplan.maps.options import PolygonOptions, ReadOptions, Robots, SceneOptions
from optplan.maps.polygons import exact_union, grid_polygons
from optplan.maps.ros_msgs import (
    TimedPath,
    occupancy_grid_msg,
    path_msg,
    read_occupancy_grid,
    read_path_msg,
    timed_path_msg,
)
from optplan.maps.scen import SCEN_POLYGONS as SCEN_POLYGONS
from optplan.maps.scen import (
    ScenEntry,
    read_scen,
    read_scen_entries,
    scen_line_of,
    scen_octile_length,
)
from optplan.maps.scen_lines import read_scen_line, scen_batch, scen_line_name
from optplan.maps.toml_writer import to_toml, write_batch, write_toml

__all__ = [
    "FREE",
    "OCCUPIED",
    "UNKNOWN",
    "MAX_CELLS",
    "Grid",
    "ScenEntry",
    "read_grid",
    "read_ros_yaml",
    "read_image",
    "read_movingai",
    "read_scen_entries",
    "read_scen",
    "read_scen_line",
    "scen_batch",
    "scen_line_name",
    "scen_octile_length",
    "scen_line_of",
    "exact_union",
    "grid_polygons",
    "import_map",
    "Robots",
    "ReadOptions",
    "PolygonOptions",
    "SceneOptions",
    "scene_name",
    "to_toml",
    "write_toml",
    "write_batch",
    "TimedPath",
    "path_msg",
    "timed_path_msg",
    "read_path_msg",
    "read_occupancy_grid",
    "occupancy_grid_msg",
    "read_graphml",
    "read_tasks",
    "read_roadmap_mapf",
    "read_movingai_mapf",
    "write_roadmap_mapf",
    "roadmap_problem",
    "grid_mapf_problem",
]
