"""The option objects of :func:`~optplan.maps.import_map` and :func:`~optplan.maps.read_scen`.

Frozen dataclasses grouping related keywords, each with the defaults of the command line
(``optplan import-map``)::

    import_map(path, Robots(start=(1.0, 2.0), goal=(5.0, 6.0), radius=0.3),
               read=ReadOptions(resolution=0.05), polygons=PolygonOptions(grow=1.0),
               scene=SceneOptions(name="lab"))

They hold the values as given: :func:`~optplan.maps.import_map` checks them, in the order
it uses them, with errors naming the map file, the option, the value and what is allowed
(``map.yaml: grow: must be >= 0 (cells), got -1``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from optplan.maps.checks import MAX_CELLS, err

T = TypeVar("T")


@dataclass(frozen=True, kw_only=True)
class Robots:
    """The robots put on the map: one per start/goal pair, all alike.

    Parameters
    ----------
    start, goal : point or list of points
        ``(x, y)`` or a list of them, world coordinates in map units; as many goals as
        starts.
    radius : float
        Every robot's radius (map units), >= 0.
    ids : str or list of str, optional
        The robots' ids; default ``"r1"`` (``"r1", "r2", ...`` for several robots).
    max_speed : float
        Every robot's speed limit (map units / s).
    """

    start: Any
    goal: Any
    radius: float
    ids: str | Sequence[str] | None = None
    max_speed: float = 1.0


@dataclass(frozen=True, kw_only=True)
class ReadOptions:
    """How a map file is read into a grid, and which of its cells count.

    Parameters
    ----------
    resolution, origin, negate, occupied_thresh, free_thresh, mode : optional
        For bare images (:func:`~optplan.maps.read_image`: ``resolution`` required, map units
        per cell; ``origin`` ``(x, y[, yaw])``, default ``(0, 0)``); for MovingAI maps
        ``resolution`` (default 1) and ``origin`` only; a ROS map takes them from its YAML
        file (giving one is an error).  None: not given.
    unknown : ``"occupied"`` (default) or ``"free"``
        What unknown cells are.
    crop : ``"auto"`` (default), True or False
        Crop the map (its cells and the scenario's bounds) to the bounding box of its known
        (free or occupied) cells (``numpy.bool_`` is accepted; a number, 0 or 1 included, is
        an error: ``crop`` is a switch, not a margin).  ``"auto"`` crops when the unknown
        cells outside that box are more than ``CROP_MARGIN`` (25 %) of the image and unknown
        cells are obstacles (``unknown="occupied"``: the margin is then an obstacle the bounds
        replace; with ``unknown="free"`` it is free space, and only ``crop=True`` drops it).
    max_cells : int
        The largest map read, in cells (:data:`~optplan.maps.checks.MAX_CELLS`, 8192 x 8192),
        checked before the image is decoded or the grid allocated (for an in-memory grid,
        before any geometry is made).

    With an in-memory grid (``import_map(grid=...)``) only ``unknown``, ``crop`` and
    ``max_cells`` apply.
    """

    resolution: float | None = None
    origin: Sequence[float] | None = None
    negate: bool | None = None
    occupied_thresh: float | None = None
    free_thresh: float | None = None
    mode: str | None = None
    unknown: str = "occupied"
    crop: Any = "auto"
    max_cells: int = MAX_CELLS


@dataclass(frozen=True, kw_only=True)
class PolygonOptions:
    """How the obstacle cells become polygons (:func:`~optplan.maps.grid_polygons`).

    Parameters
    ----------
    grow, simplify : float
        Growth and Douglas-Peucker tolerance in **cells**, each in ``[0, 4]``; ``simplify > 0``
        needs ``grow > 0``.  :func:`~optplan.maps.read_scen`'s default is
        :data:`~optplan.maps.scen.SCEN_POLYGONS` (0.25 and 0.2).
    join : ``"round"`` (default) or ``"mitre"``
        Growth join style.
    """

    grow: float = 0.5
    simplify: float = 0.5
    join: str = "round"


@dataclass(frozen=True, kw_only=True)
class SceneOptions:
    """The scenario keys of an imported map.

    Parameters
    ----------
    name : str, optional
        The scenario's name; default :func:`~optplan.maps.scene_name` of the map's path (the
        file's stem, or its directory's name for a ``map.yaml``).
    description, source : str, optional
        Default: what was imported, and how.
    tags : iterable of str
        Default ``("map",)``.
    goal_tolerance, sensing_range : float, optional
        The scenario's ``goal_tolerance`` and ``[sensing] range``.
    dynamic_obstacles : sequence of dict
        Tables as in the TOML format.
    """

    name: str | None = None
    description: str | None = None
    source: str | None = None
    tags: Iterable[str] = ("map",)
    goal_tolerance: float | None = None
    sensing_range: float | None = None
    dynamic_obstacles: Sequence[dict] = ()


def checked(where: Any, key: str, value: Any, cls: type[T], default: T | None = None) -> T:
    """An option object checked for its class.

    Parameters
    ----------
    where : path or str
        The source named in the error (the map).
    key : str
        The parameter named in the error (``"polygons"``).
    value : object
        What was passed.
    cls : type
        The class expected (:class:`PolygonOptions`, ...).
    default : optional
        What None stands for; without it None is an error too.

    Returns
    -------
    object
        ``value``, or ``default`` for None.

    Raises
    ------
    ProblemError
        When ``value`` is not a ``cls``.
    """
    if value is None and default is not None:
        return default
    if not isinstance(value, cls):
        raise err(where, key, f"expected an optplan.maps.{cls.__name__}, got "
                              f"{type(value).__name__}")
    return value
