"""Input checks shared by the map readers: the errors they raise (:func:`err`), numbers,
origins, the size and place of a map, and the limits they enforce (:data:`MAX_CELLS`,
:data:`MAP_MIN_LENGTH`, :data:`MAP_MAX_LENGTH`).

Every check raises a :class:`~optplan.ProblemError` ``"<where>: <key>: <message>"`` naming the
source (a file, ``<grid>``), the key and the value with what is allowed.  The package's
modules use them; :mod:`optplan.maps.grid` re-exports the limits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from optplan.geometry.collision import MAX_REL_COORD
from optplan.problem import ProblemError

#: The largest map the readers accept, in cells (pixels of an image): 8192 x 8192.  A size
#: above it is an error before anything of that size is allocated or decoded (the readers'
#: ``max_cells=`` raises it); decoding works in float64 channels, about 1.6 GB for an RGB
#: image of this size.
MAX_CELLS = 8192 * 8192


#: The supported size of a map: its diagonal ``hypot(width, height) x resolution`` lies in
#: ``[MAP_MIN_LENGTH, MAP_MAX_LENGTH]`` = ``[1e-30, 1e30]`` map units, and the centre of the
#: map lies within ``MAX_REL_COORD`` (1e6) diagonals of the coordinate origin (the rule of
#: the geometry core, :mod:`optplan.geometry.collision.frame`: the double format resolves the
#: tolerance ``1e-9 x`` the diagonal there).  Why these bounds: the geometry core accepts diagonals
#: in ``[1e-100, 1e100]``, but the exact obstacle engine squares and multiplies lengths, and an
#: imported map runs clean (no overflow, underflow or nan) only for diagonals between about
#: ``1e-60`` and ``1e70``; 30 decades inside that on each side still cover every unit a map
#: is drawn in.  Outside these bounds the world coordinates of the cells underflow, overflow
#: or cannot be rounded (``resolution: 1e-300`` was a raw ``GEOSException``);
#: ``docs/maps.md``, "Accepted ranges".
MAP_MIN_LENGTH, MAP_MAX_LENGTH = 1e-30, 1e30


def err(where: Any, key: str, msg: str) -> ProblemError:
    """The error of a bad input: ``ProblemError("<where>: <key>: <msg>")``.

    Parameters
    ----------
    where : path or str
        The source: a file, ``"<grid>"``, a message's name.
    key : str
        The key, field or line that is wrong (``"resolution"``, ``"line 7"``).
    msg : str
        What is wrong and what is allowed.

    Returns
    -------
    ProblemError
        To raise.
    """
    return ProblemError(f"{where}: {key}: {msg}")


def is_real(v: Any) -> bool:
    """Whether ``v`` is a real number.

    Parameters
    ----------
    v : object
        Any value.

    Returns
    -------
    bool
        True for an ``int``, ``float`` or a numpy integer or floating scalar; False for
        anything else, a bool or ``numpy.bool_`` included.
    """
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(
        v, (bool, np.bool_))


def check_extent(where: Any, width: int, height: int, res: float,
                 origin: tuple[float, float, float], key: str = "resolution",
                 origin_key: str = "origin") -> None:
    """Check that a map's size and place are within the geometry core's limits.

    Checked before any geometry is made: a ``width x height`` grid of cells of side ``res``
    at ``origin`` has a diagonal in ``[MAP_MIN_LENGTH, MAP_MAX_LENGTH]`` and its centre
    within ``MAX_REL_COORD`` diagonals of the coordinate origin.

    Parameters
    ----------
    where : path or str
        The source named in the error.
    width, height : int
        The map's size in cells.
    res : float
        The side of a cell (map units).
    origin : (x, y, yaw)
        The world pose of the map's lower-left corner.
    key, origin_key : str
        The keys an error names for the size and for the place.

    Raises
    ------
    ProblemError
        Giving the resolutions (the places) this map allows.
    """
    cells = math.hypot(width, height)
    diag = cells * res
    if not MAP_MIN_LENGTH <= diag <= MAP_MAX_LENGTH:
        raise err(where, key, f"{res!r} makes the {width} x {height} cell map {diag:.3g} map "
                              f"units across (its diagonal), outside the supported range "
                              f"[{MAP_MIN_LENGTH:g}, {MAP_MAX_LENGTH:g}]; for this map the "
                              f"resolution must lie in [{MAP_MIN_LENGTH / cells:.3g}, "
                              f"{MAP_MAX_LENGTH / cells:.3g}]")
    ox, oy, yaw = origin
    c, s = math.cos(yaw), math.sin(yaw)
    cx = ox + 0.5 * res * (c * width - s * height)
    cy = oy + 0.5 * res * (s * width + c * height)
    far = max(abs(cx), abs(cy))
    if not far <= MAX_REL_COORD * diag:
        raise err(where, origin_key, f"{[ox, oy, yaw]} puts the centre of the map "
                                     f"{far:.3g} from the coordinate origin, more than "
                                     f"{MAX_REL_COORD:g} x its diagonal {diag:.3g} (allowed: "
                                     f"at most {MAX_REL_COORD * diag:.3g}): double precision "
                                     f"cannot resolve the map's cells there; shift the "
                                     f"origin")


def check_cells(where: Any, key: str, height: int, width: int, max_cells: int,
                what: str = "") -> None:
    """Check that a map of ``height x width`` cells has at most ``max_cells`` cells.

    Called before anything of that size is allocated or decoded.

    Parameters
    ----------
    where : path or str
        The source named in the error.
    key : str
        The key an error names (``"image"``, ``"line 3"``).
    height, width : int
        The map's size in cells.
    max_cells : int
        The limit, a positive integer (:data:`MAX_CELLS` by default in the readers).
    what : str
        The start of the message (``"image 'x.png': "``).

    Raises
    ------
    ProblemError
        When ``max_cells`` is not a positive integer or the map is larger.
    """
    if not (is_real(max_cells) and isinstance(max_cells, (int, np.integer))) \
            or max_cells < 1:
        raise err(where, "max_cells", f"expected a positive integer (cells), got "
                                      f"{max_cells!r}")
    if height * width > max_cells:
        raise err(where, key, f"{what}{width} x {height} = {width * height:,} cells, more "
                              f"than the limit of {max_cells:,} (max_cells; {MAX_CELLS:,} = "
                              "8192 x 8192 by default): too large to read safely")


def check_unknown(unknown: str, where: Any) -> None:
    """Check what unknown cells are: ``"occupied"`` or ``"free"``.

    Parameters
    ----------
    unknown : str
        The value given.
    where : path or str
        The source named in the error.

    Raises
    ------
    ProblemError
        For any other value.
    """
    if unknown not in ("occupied", "free"):
        raise err(where, "unknown", f"expected 'occupied' or 'free', got {unknown!r}")


def number(v: Any, where: Any, key: str, *, positive: bool = False) -> float:
    """A real number as a finite float.

    Parameters
    ----------
    v : object
        An ``int``, ``float`` or numpy real scalar (not a bool).
    where : path or str
        The source named in the error.
    key : str
        The key named in the error.
    positive : bool
        Whether the number must be > 0.

    Returns
    -------
    float

    Raises
    ------
    ProblemError
        For anything else, infinity and nan included.
    """
    if not is_real(v):
        raise err(where, key, f"expected a number, got {v!r} ({type(v).__name__})")
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise err(where, key, f"must be finite, got {v!r}")
    if positive and x <= 0:
        raise err(where, key, f"must be > 0, got {v!r}")
    return x


def origin(v: Any, where: Any, key: str = "origin") -> tuple[float, float, float]:
    """A map's origin as ``(x, y, yaw)``.

    Parameters
    ----------
    v : sequence, array or str
        ``[x, y]`` or ``[x, y, yaw]`` (yaw 0 when left out), finite numbers; a string of
        numbers separated by commas or white space; a numpy array.
    where : path or str
        The source named in the error.
    key : str
        The key named in the error (an entry's error names ``key[i]``).

    Returns
    -------
    tuple of float

    Raises
    ------
    ProblemError
        For anything else.
    """
    if isinstance(v, str):
        try:
            v = [float(t) for t in v.replace(",", " ").split()]
        except ValueError:
            raise err(where, key, f"expected [x, y] or [x, y, yaw], got {v!r}") from None
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if not isinstance(v, (list, tuple)) or len(v) not in (2, 3):
        raise err(where, key, f"expected [x, y] or [x, y, yaw], got {v!r}")
    xs = [number(t, where, f"{key}[{k}]") for k, t in enumerate(v)]
    return (xs[0], xs[1], xs[2] if len(xs) == 3 else 0.0)
