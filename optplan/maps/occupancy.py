"""Occupancy images and ROS ``map_server`` YAML files -> :class:`~optplan.maps.Grid`; any map
by its suffix (:func:`read_grid`)."""

from __future__ import annotations

import difflib
import re
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from optplan.maps import checks
from optplan.maps.checks import MAX_CELLS, check_cells, err, number
from optplan.maps.grid import FREE, OCCUPIED, UNKNOWN, Grid
from optplan.maps.movingai import read_movingai
from optplan.problem import ProblemError

#: ROS ``map_server`` defaults for the optional YAML keys.
ROS_DEFAULTS = {"negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary"}
_ROS_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
_MODES = ("trinary", "scale", "raw")
_IMAGE_SUFFIXES = (".png", ".pgm", ".ppm", ".pbm", ".pnm", ".bmp", ".tif", ".tiff", ".gif",
                   ".jpg", ".jpeg")


def _open_image(path: Path, where: Any, key: str, max_cells: int) -> tuple[Any, str]:
    """The decoded image (grey, RGB(A) or 16-bit) and its mode; its size, read from the header,
    checked against ``max_cells`` before anything is decoded."""
    from PIL import Image

    with warnings.catch_warnings():  # the pixel limit below is lower than Pillow's warning's
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        with Image.open(path) as src:
            w, h = src.size
            check_cells(where, key, h, w, max_cells, f"image {str(path)!r}: ")
            src.load()
            im: Image.Image = src
            mode = im.mode
            if mode == "P":
                im = im.convert("RGBA" if "transparency" in im.info else "RGB")
            elif mode in ("1", "CMYK", "YCbCr", "LAB", "HSV"):
                im = im.convert("L" if mode == "1" else "RGB")
            return np.asarray(im), im.mode


def _read_pixels(path: Path, where: Any, key: str, max_cells: int = MAX_CELLS
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """Colour channels ``(H, W, n)`` on the 0..255 scale and the alpha channel (or None)."""
    from PIL import Image, UnidentifiedImageError

    try:
        arr, mode = _open_image(path, where, key, max_cells)
    except ProblemError:
        raise
    except FileNotFoundError:
        raise err(where, key, f"no such image file {str(path)!r}") from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError,
            Image.DecompressionBombError) as e:  # Pillow's complaints about a malformed file
        raise err(where, key, f"cannot read image {str(path)!r} ({e})") from None
    arr = np.asarray(arr, dtype=float)
    if mode.startswith("I;16") or (mode == "I" and arr.max(initial=0) > 255):
        arr = arr * (255.0 / 65535.0)
    elif mode == "F" and arr.max(initial=0) <= 1.0:
        arr = arr * 255.0
    if arr.ndim == 2:
        return arr[:, :, None], None
    if mode in ("LA", "RGBA", "La", "RGBa", "PA"):
        return arr[:, :, :-1], arr[:, :, -1]
    return arr, None


def classify(colour: np.ndarray, alpha: np.ndarray | None, *, negate: bool = False,
             occupied_thresh: float = 0.65, free_thresh: float = 0.196,
             mode: str = "trinary") -> np.ndarray:
    """ROS ``map_server`` classification of pixels into ``FREE``/``OCCUPIED``/``UNKNOWN``.

    ``colour`` is ``(H, W, n)`` on 0..255, ``alpha`` ``(H, W)`` or None.  As ``map_server``:
    the channels are averaged (in ``trinary`` mode the alpha channel is averaged in too),
    ``negate`` replaces the average ``a`` by ``255 - a``, and the occupancy probability is
    ``p = (255 - a) / 255``: occupied when ``p > occupied_thresh``, free when
    ``p < free_thresh``, unknown otherwise.  ``scale`` mode: the same thresholds (the
    intermediate values ``map_server`` scales to 1..99 are uncertain: unknown here).
    ``raw`` mode: the average *is* the occupancy value ``v`` (0..100 percent, larger values
    unknown, as ``-1``/255 in ROS); ``v / 100`` is compared with the thresholds.
    """
    colour = np.asarray(colour, dtype=float)
    if colour.ndim == 2:
        colour = colour[:, :, None]
    if mode == "trinary" and alpha is not None:
        avg = (colour.sum(axis=2) + alpha) / (colour.shape[2] + 1)
    else:
        avg = colour.mean(axis=2)
    if negate:
        avg = 255.0 - avg
    out = np.full(avg.shape, UNKNOWN, dtype=np.uint8)
    if mode == "raw":
        v = np.trunc(avg)  # map_server stores the double into an int8
        known = v <= 100
        p = v / 100.0
        out[known & (p > occupied_thresh)] = OCCUPIED
        out[known & (p < free_thresh)] = FREE
        return out
    p = (255.0 - avg) / 255.0
    out[p > occupied_thresh] = OCCUPIED
    out[p < free_thresh] = FREE
    return out


def _thresholds(where: Any, occupied_thresh: Any, free_thresh: Any, mode: Any,
                negate: Any) -> tuple[float, float, str, bool]:
    occ = number(occupied_thresh, where, "occupied_thresh")
    free = number(free_thresh, where, "free_thresh")
    for k, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= v <= 1.0:
            raise err(where, k, f"must be in [0, 1], got {v!r}")
    if free > occ:
        raise err(where, "free_thresh", f"must be <= occupied_thresh ({occ!r}), got {free!r}")
    if not isinstance(mode, str) or mode not in _MODES:
        close = difflib.get_close_matches(str(mode), _MODES, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise err(where, "mode", f"unknown mode {mode!r}{hint} (allowed: {', '.join(_MODES)})")
    if isinstance(negate, (bool, np.bool_)):  # numpy scalars as Python's
        neg = bool(negate)
    elif isinstance(negate, (int, np.integer)) and negate in (0, 1):
        neg = bool(negate)
    else:
        raise err(where, "negate", f"expected 0 or 1, got {negate!r}")
    return occ, free, mode, neg


def read_image(path: str | Path, *, resolution: float, origin: Sequence[float] = (0.0, 0.0),
               negate: bool = False, occupied_thresh: float = 0.65, free_thresh: float = 0.196,
               mode: str = "trinary", max_cells: int = MAX_CELLS) -> Grid:
    """Read a bare image (PNG, PGM, ...) as a :class:`Grid` (ROS ``map_server`` classification,
    :func:`classify`).  ``resolution``: cell side in map units; ``origin``: ``(x, y[, yaw])`` of
    the lower-left corner; an image of more than ``max_cells`` pixels is an error before it is
    decoded."""
    p = Path(path)
    res = number(resolution, p, "resolution", positive=True)
    org = checks.origin(list(origin), p)  # checks.: the parameter hides it
    occ, free, mode, neg = _thresholds(p, occupied_thresh, free_thresh, mode, negate)
    if not p.is_file():
        raise err(p, "image", "no such file")
    colour, alpha = _read_pixels(p, p, "image", max_cells)
    cells = classify(colour, alpha, negate=neg, occupied_thresh=occ, free_thresh=free, mode=mode)
    return Grid(cells, res, org, str(p))


#: a float in exponent notation without a dot (``5e-2``): a float in YAML 1.2 and to ROS,
#: a string to PyYAML's YAML 1.1 resolver
_EXP_FLOAT = re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$")


def _yaml_load(text: str) -> Any:
    """``yaml.safe_load`` reading ``5e-2`` as the number ROS reads (YAML 1.2), not a string."""
    import yaml

    class Loader(yaml.SafeLoader):
        pass

    Loader.add_implicit_resolver("tag:yaml.org,2002:float", _EXP_FLOAT, list("-+.0123456789"))
    return yaml.load(text, Loader=Loader)  # noqa: S506 - a SafeLoader


def _read_text(p: Path) -> str:
    """The text of a map_server YAML file; an error naming it when unreadable or not UTF-8."""
    try:
        return p.read_text(encoding="utf-8")
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise ProblemError(f"{p}: not UTF-8 text ({e.reason} at byte {e.start}): expected a "
                           f"map_server YAML file") from None


def read_ros_yaml(path: str | Path, *, max_cells: int = MAX_CELLS) -> Grid:
    """Read a ROS ``map_server`` map (YAML + image) as a :class:`Grid`.

    Required keys: ``image``, ``resolution``, ``origin``; optional ``negate`` (0),
    ``occupied_thresh`` (0.65), ``free_thresh`` (0.196), ``mode`` (``trinary``).  Unknown keys
    are rejected with a suggestion.  An image of more than ``max_cells`` pixels is an error
    before it is decoded.
    """
    import yaml

    p = Path(path)
    text = _read_text(p)
    try:
        data = _yaml_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ProblemError(f"{p}: invalid YAML{at}: {getattr(e, 'problem', e)}") from None
    if not isinstance(data, dict):
        raise err(p, "<root>", "expected a mapping of map_server keys")
    for k in data:
        if k not in _ROS_KEYS:
            close = difflib.get_close_matches(str(k), _ROS_KEYS, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise err(p, str(k), f"unknown key{hint} (allowed: {', '.join(_ROS_KEYS)})")
    for k in ("image", "resolution", "origin"):
        if k not in data:
            raise err(p, k, "missing required key")
    res = number(data["resolution"], p, "resolution", positive=True)
    org = checks.origin(data["origin"], p)
    opts = {k: data.get(k, v) for k, v in ROS_DEFAULTS.items()}
    occ, free, mode, neg = _thresholds(p, opts["occupied_thresh"], opts["free_thresh"],
                                       opts["mode"], opts["negate"])
    img = data["image"]
    if not isinstance(img, str) or not img:
        raise err(p, "image", f"expected a file name, got {img!r}")
    ip = Path(img)
    if not ip.is_absolute():
        ip = p.parent / ip
    if not ip.is_file():
        raise err(p, "image", f"no such file {str(ip)!r}")
    colour, alpha = _read_pixels(ip, p, "image", max_cells)
    cells = classify(colour, alpha, negate=neg, occupied_thresh=occ, free_thresh=free, mode=mode)
    return Grid(cells, res, org, str(p))


def read_grid(path: str | Path, *, resolution: float | None = None,
              origin: Sequence[float] | None = None, max_cells: int = MAX_CELLS,
              **classify_opts: Any) -> Grid:
    """Read any supported map by its suffix: ``.yaml``/``.yml`` (ROS), ``.map`` (MovingAI) or
    an image (``resolution`` required; ``origin`` default ``(0, 0)``); at most ``max_cells``
    cells (:data:`~optplan.maps.checks.MAX_CELLS` by default), checked before decoding."""
    p = Path(path)
    suf = p.suffix.lower()
    if not p.exists():
        raise ProblemError(f"{p}: no such map file")
    if suf in (".yaml", ".yml"):
        for k, v in (("resolution", resolution), ("origin", origin), *classify_opts.items()):
            if v is not None:
                raise err(p, k, "given by the YAML file; do not pass it for a ROS map")
        return read_ros_yaml(p, max_cells=max_cells)
    if suf == ".map":
        if classify_opts:
            raise err(p, next(iter(classify_opts)), "not an option of MovingAI maps")
        return read_movingai(p, resolution=1.0 if resolution is None else resolution,
                             origin=(0.0, 0.0) if origin is None else origin,
                             max_cells=max_cells)
    if suf in _IMAGE_SUFFIXES:
        if resolution is None:
            raise err(p, "resolution", "required for a bare image (map units per cell, e.g. "
                                       "--resolution 0.05)")
        opts = {k: v for k, v in classify_opts.items() if v is not None}
        return read_image(p, resolution=resolution,
                          origin=(0.0, 0.0) if origin is None else origin,
                          max_cells=max_cells, **opts)
    raise ProblemError(f"{p}: unknown map format {suf or '(no suffix)'!r} (expected .yaml/.yml, "
                       f".map or an image: {', '.join(_IMAGE_SUFFIXES)})")
