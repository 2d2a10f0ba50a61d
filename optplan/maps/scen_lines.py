"""One line of a MovingAI ``.scen`` as a problem name: ``<file>.scen#line=N[,radius=R]``.

A sweep over a ``.scen`` (``optplan bench --problems X.scen``) names each of its lines this way
instead of writing one scenario file per line (each would hold the whole map).  Whoever loads
such a name (:func:`read_scen_line`, :func:`optplan.bench.scen.load_bench_problem`), in the
process that solves it (an ``optplan bench`` worker, a Dask worker), reads the ``.scen`` and
its map once per process with :func:`~optplan.maps.read_scen` and keeps the whole batch
(:data:`MAX_FILES` files, least recently used dropped): every line of a file shares one
obstacle set and, through it, one tangent graph (:mod:`optplan.problem.shared`).

The name holds the ``.scen`` path as given, the line number in the file (the one
:func:`~optplan.maps.read_scen_entries` reports, and the problem's name ``<stem>-<line>``), and
the robot radius when it is not 0.  The file is read again when its size or modification time
changes.
"""

from __future__ import annotations

import math
import re
import threading
from collections import OrderedDict
from pathlib import Path

from optplan.maps.scen import read_scen, scen_line_of
from optplan.problem import Problem, ProblemError

__all__ = ["MAX_FILES", "read_scen_line", "scen_batch", "scen_line_name"]

#: ``.scen`` files whose batches a process keeps.
MAX_FILES = 4

_NAME = re.compile(r"^(?P<path>.+\.scen)#line=(?P<line>\d+)(?:,radius=(?P<radius>[^,#]+))?$",
                   re.IGNORECASE)
_lock = threading.Lock()
_batches: OrderedDict[tuple, dict[int, Problem]] = OrderedDict()


def scen_line_name(path: str | Path, line: int, radius: float = 0.0) -> str:
    """The problem name of line ``line`` of the ``.scen`` file ``path`` for a robot of
    ``radius`` (``repr`` of the float: read back bit for bit)."""
    tail = "" if radius == 0 else f",radius={float(radius)!r}"
    return f"{path}#line={int(line)}{tail}"


def scen_batch(path: str | Path, radius: float = 0.0) -> dict[int, Problem]:
    """Every line of the ``.scen`` file ``path`` as a problem (robot radius ``radius``), by
    line number: :func:`~optplan.maps.read_scen`, once per process while the file keeps its
    size and modification time (the batch is shared: do not modify its problems).

    Raises
    ------
    optplan.ProblemError
        The file or its map cannot be read, or a line is bad (:func:`~optplan.maps.read_scen`).
    """
    path = Path(path)
    try:
        st = path.stat()
    except OSError as e:
        raise ProblemError(f"{path}: cannot read the .scen file ({e.strerror or e})") from None
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size, float(radius))
    with _lock:  # one read per file: the threads of a process wait for it
        batch = _batches.get(key)
        if batch is None:
            batch = {_line(q): q for q in read_scen(path, radius=radius)}
            _batches[key] = batch
            while len(_batches) > MAX_FILES:
                _batches.popitem(last=False)
        _batches.move_to_end(key)
    return batch


def _line(problem: Problem) -> int:
    where = scen_line_of(problem)
    assert where is not None  # read_scen names every line in the description
    return where[1]


def read_scen_line(name: str) -> Problem:
    """The problem named ``<file>.scen#line=N[,radius=R]`` (:func:`scen_line_name`).

    Raises
    ------
    optplan.ProblemError
        A name of another form, a radius that is not a finite number ``>= 0``, a ``.scen``
        file (or its map) that cannot be read, or a line number that is not a line of the
        file (the message gives the file's first and last line).
    """
    m = _NAME.match(name)
    if m is None:
        raise ProblemError(f"{name!r}: expected <file>.scen#line=N or "
                           f"<file>.scen#line=N,radius=R")
    path, line = Path(m.group("path")), int(m.group("line"))
    radius = 0.0
    if m.group("radius") is not None:
        try:
            radius = float(m.group("radius"))
        except ValueError:
            radius = math.nan
        if not (math.isfinite(radius) and radius >= 0):
            raise ProblemError(f"{name}: radius {m.group('radius')!r} is not a finite number "
                               f">= 0")
    batch = scen_batch(path, radius)
    if line not in batch:
        lines = sorted(batch)
        span = f"lines {lines[0]} to {lines[-1]}" if lines else "no line"
        raise ProblemError(f"{name}: {path} has no problem at line {line} ({span})")
    return batch[line]
