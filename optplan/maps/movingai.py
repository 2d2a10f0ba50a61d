"""MovingAI ``.map`` files -> :class:`~optplan.maps.Grid`."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from optplan.maps import checks
from optplan.maps.checks import MAX_CELLS, check_cells, err, number
from optplan.maps.grid import FREE, OCCUPIED, Grid
from optplan.problem import ProblemError

#: MovingAI terrain: passable characters (``.`` ground, ``G`` ground, ``S`` swamp); ``@`` and
#: ``O`` (out of bounds), ``T`` (trees) and ``W`` (water) are obstacles.
MOVINGAI_PASSABLE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")
_PASSABLE_CODES = np.frombuffer(b".GS", dtype=np.uint8)
_BLOCKED_CODES = np.frombuffer(b"@OTW", dtype=np.uint8)


def read_movingai(path: str | Path, *, resolution: float = 1.0,
                  origin: Sequence[float] = (0.0, 0.0), max_cells: int = MAX_CELLS) -> Grid:
    """Read a MovingAI ``.map`` (``type``, ``height``, ``width``, ``map``, then the rows).

    ``.``, ``G`` and ``S`` are free; ``@``, ``O``, ``T`` and ``W`` are obstacles.  MovingAI
    cell ``(x, y)`` (column ``x``, row ``y`` from the top) is grid cell ``(row y, col x)``; with
    the default ``resolution = 1`` and ``origin = (0, 0)`` its centre is
    ``(x + 0.5, height - y - 0.5)``.

    A leading UTF-8 byte order mark, trailing white space of a row and text after the grid
    (a citation, a licence) are ignored, but a grid row after the ``height`` rows is an error
    (the header's height is wrong), and so is a map of more than ``max_cells`` cells, before
    the grid is allocated.

    Raises
    ------
    ProblemError
        Naming the file and the line (or the header key) of what is wrong.
    """
    p = Path(path)
    res = number(resolution, p, "resolution", positive=True)
    org = checks.origin(list(origin), p)  # checks.: the parameter hides it
    lines = _read_lines(p)
    h, w, k = _header(p, lines, max_cells)
    rows = [ln.rstrip() for ln in lines[k + 1:k + 1 + h]]
    if len(rows) < h:
        raise err(p, "height", f"header says {h} rows, the file has {len(rows)}")
    for r, row in enumerate(rows):
        if not row.isascii():
            c = next(i for i, ch in enumerate(row) if not ch.isascii())
            raise err(p, f"line {k + 2 + r}", f"non-ASCII byte at column {c + 1} (expected "
                                              "one of . G S @ O T W)")
        if len(row) != w:
            raise err(p, f"line {k + 2 + r}", f"expected {w} cells, got {len(row)}")
    _check_after_grid(p, lines, k + 1 + h, w, h)
    codes = np.frombuffer("".join(rows).encode("latin-1"), dtype=np.uint8).reshape(h, w)
    free = np.isin(codes, _PASSABLE_CODES)
    bad = ~(free | np.isin(codes, _BLOCKED_CODES))
    if bad.any():
        r, c = (int(i) for i in np.argwhere(bad)[0])
        raise err(p, f"line {k + 2 + r}", f"unknown terrain {rows[r][c]!r} at column {c + 1} "
                                          "(expected one of . G S @ O T W)")
    cells = np.where(free, FREE, OCCUPIED).astype(np.uint8)
    return Grid(cells, res, org, str(p))


def _read_lines(p: Path) -> list[str]:
    """The file's lines (bytes as Latin-1: the header and the grid are checked character by
    character, text after the grid may be anything); a leading UTF-8 byte order mark (an
    editor's) is dropped."""
    try:
        data = p.read_bytes()
        return data.removeprefix(b"\xef\xbb\xbf").decode("latin-1").splitlines()
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None


def _header(p: Path, lines: list[str], max_cells: int) -> tuple[int, int, int]:
    """Height, width and the index of the ``map`` line; the header's lines (``type``,
    ``height``, ``width``) checked, and the size against ``max_cells``."""
    head: dict[str, tuple[str, int]] = {}
    k = 0
    while k < len(lines) and lines[k].strip() != "map":
        parts = lines[k].split()
        k += 1
        if not parts:
            continue
        if len(parts) != 2 or parts[0] not in ("type", "height", "width"):
            raise err(p, f"line {k}", f"expected 'type T', 'height H', 'width W' or 'map', "
                                      f"got {lines[k - 1][:60]!r}")
        head[parts[0]] = (parts[1], k)
    size = []
    for key in ("height", "width"):
        if key not in head:
            raise err(p, key, "missing header line")
        text, line = head[key]
        if not text.isdigit() or int(text) < 1:
            raise err(p, f"line {line}", f"{key}: expected a positive integer, got {text!r}")
        size.append(int(text))
    check_cells(p, f"line {head['width'][1]}", size[0], size[1], max_cells)
    if k >= len(lines):
        raise err(p, "map", "missing 'map' line before the grid")
    return size[0], size[1], k


def _check_after_grid(p: Path, lines: list[str], start: int, w: int, h: int) -> None:
    """The first non-blank line after the grid is not one more grid row."""
    for k in range(start, len(lines)):
        s = lines[k].rstrip()
        if not s:
            continue
        if len(s) == w and set(s) <= MOVINGAI_PASSABLE | MOVINGAI_BLOCKED:
            raise err(p, f"line {k + 1}", f"a grid row after the {h} rows the header's "
                                          f"height gives (is the height wrong?)")
        return
