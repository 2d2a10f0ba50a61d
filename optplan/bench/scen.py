"""MovingAI ``.scen`` files expanded into scenario TOMLs for a sweep, the bucket selection,
and the ``.scen`` columns of a run's row (file, bucket, line, octile optimum)."""

from __future__ import annotations

import math
import re
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

from optplan.bench.rows import _NO_SCEN_ROW, _num

#: the ``.scen`` columns of a problem that is not a ``.scen`` line
NO_SCEN: dict[str, Any] = {k: v for k, v in _NO_SCEN_ROW.items() if k != "octile_ratio"}

_DESC_RE = re.compile(r"^MovingAI (.+) line (\d+): bucket (-?\d+),")

#: largest bucket number ``parse_buckets`` accepts (MovingAI's are lengths / 4)
MAX_BUCKET = 1_000_000


def parse_buckets(spec: str, option: str = "buckets") -> list[int]:
    """The buckets of a selection such as ``"0-5,9"`` (ranges inclusive), sorted.

    Parameters
    ----------
    spec : str
        Comma-separated bucket numbers and ranges ``A-B`` (``A <= B``), each in
        ``[0, MAX_BUCKET]``.
    option : str
        The option's name, for the error message.

    Raises
    ------
    ValueError
        An empty selection, a part that is not a number or a range, a number outside
        ``[0, MAX_BUCKET]``, or a range whose end is below its start; the message names
        ``option`` and the part.
    """
    out: set[int] = set()
    parts = [t.strip() for t in str(spec).split(",")]
    if not any(parts):
        raise ValueError(f"{option} {spec!r}: expected bucket numbers and ranges such as "
                         f"0-5,9")
    for part in parts:
        m = re.fullmatch(r"(\d+)(?:\s*-\s*(\d+))?", part)
        if m is None:
            raise ValueError(f"{option} {spec!r}: {part!r} is not a bucket number or a range "
                             f"A-B of them (allowed: integers 0..{MAX_BUCKET}, e.g. 0-5,9)")
        lo = int(m.group(1))
        hi = int(m.group(2)) if m.group(2) is not None else lo
        if hi > MAX_BUCKET:
            raise ValueError(f"{option} {spec!r}: bucket {hi} is outside 0..{MAX_BUCKET}")
        if hi < lo:
            raise ValueError(f"{option} {spec!r}: the range {part!r} ends below its start")
        out.update(range(lo, hi + 1))
    return sorted(out)


def _select_lines(path: str, buckets: Collection[int] | None, radius: float) -> list[Any]:
    """The problems of the lines of ``path`` in ``buckets`` (all of them for None)."""
    from optplan.maps import read_scen, read_scen_entries
    from optplan.problem import ProblemError

    batch = read_scen(path, radius=radius, buckets=buckets)
    if not batch and buckets is not None:
        have = sorted({e.bucket for e in read_scen_entries(path)})
        raise ProblemError(f"{path}: no line is in the buckets asked for ({_ranges(buckets)}); "
                           f"the file's buckets: {_ranges(have)}")
    return batch


def _ranges(bs: Collection[int]) -> str:
    """``[0, 1, 2, 5]`` as ``"0-2,5"``."""
    out: list[str] = []
    for b in sorted(bs):
        if out and out[-1].split("-")[-1] == str(b - 1):
            out[-1] = f"{out[-1].split('-')[0]}-{b}"
        else:
            out.append(str(b))
    return ",".join(out)


def expand_scen(problems: Sequence[str], directory: str | Path, *, radius: float = 0.0,
                buckets: Collection[int] | None = None) -> list[str]:
    """Replace every MovingAI ``.scen`` file among ``problems`` by one scenario per line.

    Each ``.scen`` is read with :func:`optplan.maps.read_scen` (its ``.map`` next to it; one
    robot of ``radius``, a point by default, from the start cell's centre to the goal cell's)
    and written with :func:`optplan.maps.write_batch` as ``<directory>/<scen stem>/<scen
    stem>-<line>.toml``; the paths of those files take the ``.scen``'s place, in line order
    (names and paths travel to worker processes; rewriting the same files on a rerun keeps a
    results database's cells, so ``db=`` resumes).  Other entries are kept as they are.
    ``buckets`` keeps the lines of those buckets only (every line by default).

    Raises
    ------
    optplan.ProblemError
        A ``.scen`` (or its map) that cannot be read, a line whose start or goal is
        blocked, or a ``.scen`` with no line in ``buckets`` (the message lists its buckets).
    """
    from optplan.maps import write_batch

    out: list[str] = []
    for entry in problems:
        s = str(entry)
        if not s.lower().endswith(".scen"):
            out.append(s)
            continue
        batch = _select_lines(s, buckets, radius)
        stem = Path(s).name[: -len(".scen")]
        stem = stem[: -len(".map")] if stem.lower().endswith(".map") else stem
        out.extend(str(q) for q in write_batch(batch, Path(directory) / (stem or "scen")))
    return out


def scen_columns(problem: Any) -> dict[str, Any]:
    """The ``.scen`` columns of a problem made by :func:`optplan.maps.read_scen` (also when
    read back from its scenario file): ``scen`` (the ``.scen`` file name), ``bucket``,
    ``scen_line`` and ``octile_optimum`` (the file's optimal length, map units); the values of
    :data:`NO_SCEN` for any other problem."""
    from optplan.maps import scen_octile_length

    m = _DESC_RE.match(problem.description or "")
    octile = scen_octile_length(problem) if m else None
    if m is None or octile is None:
        return dict(NO_SCEN)
    return {"scen": m.group(1), "bucket": int(m.group(3)), "scen_line": int(m.group(2)),
            "octile_optimum": float(octile)}


def with_scen(row: dict[str, Any], cols: dict[str, Any]) -> dict[str, Any]:
    """``row`` with the ``.scen`` columns ``cols`` (:func:`scen_columns`) and ``octile_ratio``
    (``length / octile_optimum``, nan without both)."""
    row.update(cols)
    length, octile = _num(row.get("length")), _num(row.get("octile_optimum"))
    ok = math.isfinite(length) and math.isfinite(octile) and octile > 0
    row["octile_ratio"] = length / octile if ok else math.nan
    return row
