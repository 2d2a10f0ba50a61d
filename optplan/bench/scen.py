"""MovingAI ``.scen`` files expanded into scenario TOMLs for a sweep."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path


def expand_scen(problems: Sequence[str], directory: str | Path, *, radius: float = 0.0
                ) -> list[str]:
    """Replace every MovingAI ``.scen`` file among ``problems`` by one scenario per line.

    Each ``.scen`` is read with :func:`optplan.maps.read_scen` (its ``.map`` next to it; one
    robot of ``radius``, a point by default, from the start cell's centre to the goal cell's)
    and written with :func:`optplan.maps.write_batch` as ``<directory>/<scen stem>/<scen
    stem>-<line>.toml``; the paths of those files take the ``.scen``'s place, in line order
    (names and paths travel to worker processes; rewriting the same files on a rerun keeps a
    results database's cells, so ``db=`` resumes).  Other entries are kept as they are.

    Raises
    ------
    optplan.ProblemError
        A ``.scen`` (or its map) that cannot be read, or a line whose start or goal is
        blocked.
    """
    from optplan.maps import read_scen, write_batch

    out: list[str] = []
    for entry in problems:
        s = str(entry)
        if not s.lower().endswith(".scen"):
            out.append(s)
            continue
        batch = read_scen(s, radius=radius)
        stem = Path(s).name[: -len(".scen")]
        stem = stem[: -len(".map")] if stem.lower().endswith(".map") else stem
        out.extend(str(q) for q in write_batch(batch, Path(directory) / (stem or "scen")))
    return out
