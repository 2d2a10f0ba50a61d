"""The one numba configuration of the package: :func:`compiled`, and the argument types of
the compiled kernels.

Every compiled function of optplan (the geometry kernels, the swarm's steps, roadmap and
refinement loops) is declared with ``@compiled(arg types...)``: one explicit signature, so
numba compiles it exactly once, when its module is imported (eagerly), and caches the machine
code on disk.  A call with other argument types is converted to the declared ones where that
is safe (an ``int`` for a ``float64``, a contiguous array for an ``A``-layout one) and is an
error otherwise; it never compiles a second specialisation (an ``int`` option value, a
literal constant in a call, a strided view instead of a contiguous array each used to).

Where the cache lives (numba's rules, see docs/benchmarks.md "First run and the numba
cache"): ``NUMBA_CACHE_DIR`` when set; else ``__pycache__`` next to the module when that
directory is writable; else numba's user-wide cache directory (``~/.cache/numba`` on Linux,
``$XDG_CACHE_HOME/numba`` when set).  A read-only installation therefore compiles once per
user, not once per process.

A small helper with one call site is ``@inlined`` instead: numba inlines it into its caller's
IR, so it costs no compilation of its own (a compiled function costs about 0.1 s of CPU to
compile however small it is).  A helper with several callers, or a large one, is
``@compiled``: inlining it would compile its body once per call site.

Type names: ``f8`` float64, ``i8`` int64, ``b1`` boolean; ``F1``, ``F2``, ``F3`` C-contiguous
float64 arrays of 1, 2, 3 dimensions, ``I1``, ``I2`` int64 ones, ``B1``, ``B2`` boolean ones;
``FA1``, ``FA2`` float64 arrays of any layout (strided views: the swarm's particles are a view
into its polylines).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba
from numba import types

__all__ = ["compiled", "inlined", "f8", "i8", "b1", "F1", "F2", "F3", "I1", "I2", "B1", "B2", "FA1",
           "FA2", "IA1", "IA2"]

f8 = types.float64
i8 = types.int64
b1 = types.boolean
F1 = types.Array(f8, 1, "C")
F2 = types.Array(f8, 2, "C")
F3 = types.Array(f8, 3, "C")
I1 = types.Array(i8, 1, "C")
I2 = types.Array(i8, 2, "C")
B1 = types.Array(b1, 1, "C")
B2 = types.Array(b1, 2, "C")
FA1 = types.Array(f8, 1, "A")
FA2 = types.Array(f8, 2, "A")
IA1 = types.Array(i8, 1, "A")
IA2 = types.Array(i8, 2, "A")


def compiled(*argtypes: Any) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: ``numba.njit`` with the one signature ``argtypes`` (return type inferred),
    compiled when the module is imported, cached on disk, without the GIL, no fastmath.

    Parameters
    ----------
    *argtypes : numba types
        The argument types, in order (the aliases of this module).

    Returns
    -------
    callable
        The decorator; the decorated function is a numba dispatcher that accepts only
        ``argtypes`` (or arguments safely converted to them).
    """
    return numba.njit([tuple(argtypes)], cache=True, nogil=True, fastmath=False)


def inlined(fn: Callable[..., Any]) -> Any:
    """Decorator for a small helper with one call site: ``numba.njit(inline="always")``,
    typed and inlined in its caller's IR, never compiled on its own (see the module
    docstring).

    Parameters
    ----------
    fn : callable
        The helper.

    Returns
    -------
    numba dispatcher
        Callable from compiled code (and, compiled then, from Python: the tests do).
    """
    return numba.njit(inline="always", nogil=True, fastmath=False)(fn)
