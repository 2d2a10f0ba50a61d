"""MovingAI ``.map`` files -> :class:`~optplan.maps.Grid`."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from optplan.maps.grid import FREE, OCCUPIED, Grid, _err, _number, _origin
from optplan.problem import ProblemError

#: MovingAI terrain: passable characters (``.`` ground, ``G`` ground, ``S`` swamp); ``@`` and
#: ``O`` (out of bounds), ``T`` (trees) and ``W`` (water) are obstacles.
MOVINGAI_PASSABLE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")


def read_movingai(path: str | Path, *, resolution: float = 1.0,
                  origin: Sequence[float] = (0.0, 0.0)) -> Grid:
    """Read a MovingAI ``.map`` (``type``, ``height``, ``width``, ``map``, then the rows).

    ``.``, ``G`` and ``S`` are free; ``@``, ``O``, ``T`` and ``W`` are obstacles.  MovingAI
    cell ``(x, y)`` (column ``x``, row ``y`` from the top) is grid cell ``(row y, col x)``; with
    the default ``resolution = 1`` and ``origin = (0, 0)`` its centre is
    ``(x + 0.5, height - y - 0.5)``.
    """
    p = Path(path)
    res = _number(resolution, p, "resolution", positive=True)
    org = _origin(list(origin), p)
    lines = _read_lines(p)
    head, k = _header(p, lines)
    h, w = int(head["height"]), int(head["width"])
    rows = [ln.rstrip("\r\n") for ln in lines[k + 1:k + 1 + h]]
    if len(rows) < h:
        raise _err(p, "height", f"header says {h} rows, the file has {len(rows)}")
    cells = np.empty((h, w), dtype=np.uint8)
    for r, row in enumerate(rows):
        cells[r] = _terrain_row(p, row, w, k + 2 + r)
    return Grid(cells, res, org, str(p))


def _read_lines(p: Path) -> list[str]:
    """The file's lines (ASCII only)."""
    try:
        return p.read_text(encoding="ascii", errors="strict").splitlines()
    except OSError as e:
        raise ProblemError(f"{p}: cannot read file ({e.strerror})") from None
    except UnicodeDecodeError:
        raise ProblemError(f"{p}: not a MovingAI map (non-ASCII content)") from None


def _header(p: Path, lines: list[str]) -> tuple[dict[str, str], int]:
    """The header lines before ``map`` (``type``, ``height``, ``width``) and the index of the
    ``map`` line; height and width checked."""
    head: dict[str, str] = {}
    k = 0
    while k < len(lines) and lines[k].strip() != "map":
        parts = lines[k].split()
        k += 1
        if not parts:
            continue
        if len(parts) != 2 or parts[0] not in ("type", "height", "width"):
            raise _err(p, f"line {k}", f"expected 'type T', 'height H', 'width W' or 'map', "
                                       f"got {lines[k - 1]!r}")
        head[parts[0]] = parts[1]
    for key in ("height", "width"):
        if key not in head:
            raise _err(p, key, "missing header line")
        if not head[key].isdigit() or int(head[key]) < 1:
            raise _err(p, key, f"expected a positive integer, got {head[key]!r}")
    if k >= len(lines):
        raise _err(p, "map", "missing 'map' line before the grid")
    return head, k


def _terrain_row(p: Path, row: str, w: int, line: int) -> list[int]:
    """One grid row's cells (FREE or OCCUPIED) from its ``w`` terrain characters."""
    if len(row) != w:
        raise _err(p, f"line {line}", f"expected {w} cells, got {len(row)}")
    bad = set(row) - MOVINGAI_PASSABLE - MOVINGAI_BLOCKED
    if bad:
        c = min(row.index(b) for b in bad)
        raise _err(p, f"line {line}", f"unknown terrain {row[c]!r} at column {c + 1} "
                                      "(expected one of . G S @ O T W)")
    return [FREE if ch in MOVINGAI_PASSABLE else OCCUPIED for ch in row]
