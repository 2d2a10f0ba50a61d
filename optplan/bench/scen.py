"""MovingAI ``.scen`` files expanded into their lines' names for a sweep, the bucket
selection, and the ``.scen`` columns of a run's row (file, bucket, line, octile optimum)."""

from __future__ import annotations

import math
import re
from collections.abc import Collection, Sequence
from typing import Any

from optplan.bench.rows import _NO_SCEN_ROW, _num

#: the ``.scen`` columns of a problem that is not a ``.scen`` line
NO_SCEN: dict[str, Any] = {k: v for k, v in _NO_SCEN_ROW.items() if k != "octile_ratio"}


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


def _select_lines(path: str, buckets: Collection[int] | None, radius: float) -> list[int]:
    """The line numbers of ``path`` in ``buckets`` (all of them for None), in file order."""
    from optplan.maps import scen_batch
    from optplan.problem import ProblemError

    batch = scen_batch(path, radius)
    lines = [k for k, q in batch.items()
             if buckets is None or scen_columns(q)["bucket"] in buckets]
    if not lines and buckets is not None:
        have = sorted({scen_columns(q)["bucket"] for q in batch.values()})
        raise ProblemError(f"{path}: no line is in the buckets asked for ({_ranges(buckets)}); "
                           f"the file's buckets: {_ranges(have)}")
    return lines


def _ranges(bs: Collection[int]) -> str:
    """``[0, 1, 2, 5]`` as ``"0-2,5"``."""
    out: list[str] = []
    for b in sorted(bs):
        if out and out[-1].split("-")[-1] == str(b - 1):
            out[-1] = f"{out[-1].split('-')[0]}-{b}"
        else:
            out.append(str(b))
    return ",".join(out)


def load_bench_problem(problem: Any) -> Any:
    """A problem of a sweep: the line of a ``.scen`` named ``<file>.scen#line=N[,radius=R]``
    (:func:`optplan.maps.read_scen_line`: the file read once per process), else whatever
    :func:`optplan.catalog.load_problem` takes (a catalogue name, a ``.toml`` path, a
    ``Problem``)."""
    from optplan.catalog import load_problem

    if isinstance(problem, str) and ".scen#" in problem.lower():
        from optplan.maps import read_scen_line

        return read_scen_line(problem)
    return load_problem(problem)


def expand_scen(problems: Sequence[str], *, radius: float = 0.0,
                buckets: Collection[int] | None = None) -> list[str]:
    """Replace every MovingAI ``.scen`` file among ``problems`` by the names of its lines.

    Each ``.scen`` is read with :func:`optplan.maps.read_scen` (its ``.map`` next to it; one
    robot of ``radius``, a point by default, from the start cell's centre to the goal cell's;
    every line checked here, before any run); its lines' names
    ``<file>.scen#line=N[,radius=R]`` (:func:`optplan.maps.scen_line_name`) take its place, in
    line order.  Names travel to worker processes, each of which reads the file once
    (:func:`optplan.maps.read_scen_line`; nothing is written), and the same command names
    the same lines again, so a results database's cells resume (``db=``).  Other entries are
    kept as they are.  ``buckets`` keeps the lines of those buckets only (every line by
    default).

    Raises
    ------
    optplan.ProblemError
        A ``.scen`` (or its map) that cannot be read, a line whose start or goal is
        blocked, or a ``.scen`` with no line in ``buckets`` (the message lists its buckets).
    """
    from optplan.maps import scen_line_name

    out: list[str] = []
    for entry in problems:
        s = str(entry)
        if not s.lower().endswith(".scen"):
            out.append(s)
            continue
        out.extend(scen_line_name(s, k, radius) for k in _select_lines(s, buckets, radius))
    return out


def scen_columns(problem: Any) -> dict[str, Any]:
    """The ``.scen`` columns of a problem made by :func:`optplan.maps.read_scen` (also when
    read back from its scenario file): ``scen`` (the ``.scen`` file name), ``bucket``,
    ``scen_line`` and ``octile_optimum`` (the file's optimal length, map units); the values of
    :data:`NO_SCEN` for any other problem."""
    from optplan.maps import scen_line_of, scen_octile_length

    where = scen_line_of(problem)
    octile = scen_octile_length(problem) if where else None
    if where is None or octile is None:
        return dict(NO_SCEN)
    scen, line, bucket = where
    return {"scen": scen, "bucket": bucket, "scen_line": line, "octile_optimum": float(octile)}


def with_scen(row: dict[str, Any], cols: dict[str, Any]) -> dict[str, Any]:
    """``row`` with the ``.scen`` columns ``cols`` (:func:`scen_columns`) and ``octile_ratio``
    (``length / octile_optimum``, nan without both)."""
    row.update(cols)
    length, octile = _num(row.get("length")), _num(row.get("octile_optimum"))
    ok = math.isfinite(length) and math.isfinite(octile) and octile > 0
    row["octile_ratio"] = length / octile if ok else math.nan
    return row
