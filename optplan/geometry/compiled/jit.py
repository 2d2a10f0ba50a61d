"""The one numba configuration of the package: :func:`compiled`, and the argument types of
the compiled kernels.

Every compiled function of optplan (the geometry kernels, the swarm's steps, roadmap and
refinement loops) is declared with ``@compiled(arg types...)``: one explicit signature, so
numba compiles it exactly once, and caches the machine code on disk.  It is compiled lazily:
on its first call (from Python, or when a compiled caller is compiled), not when its module is
imported, so a process compiles (or loads from the cache) only the kernels it runs: a
``visgraph`` solve never compiles the swarm's steps, an ``ipso`` solve never compiles the
clearance kernel.  Whatever the argument types of that first call, the declared signature is
what is compiled (:class:`OneSignature`); a call with other argument types is converted to the
declared ones where that is safe (an ``int`` for a ``float64``, a contiguous array for an
``A``-layout one) and is an error otherwise; it never compiles a second specialisation (an
``int`` option value, a literal constant in a call, a strided view instead of a contiguous
array each used to).

Where the cache lives (numba's rules, see docs/benchmarks.md "First run and the numba
cache"): ``NUMBA_CACHE_DIR`` when set; else ``__pycache__`` next to the module when that
directory is writable; else numba's user-wide cache directory (``~/.cache/numba`` on Linux,
``$XDG_CACHE_HOME/numba`` when set).  A read-only installation therefore compiles once per
user, not once per process; with none of them writable, the kernels compile in memory in
every process, with one warning (``kernel_cache.NoKernelCacheWarning``).  An installed wheel
also ships the kernels compiled for its platform's generic CPU, looked up when numba's cache
has nothing (:mod:`optplan.geometry.compiled.kernel_cache`): its first solve compiles nothing.

A helper with one call site (in compiled code) is ``@inlined`` instead: numba inlines it into
its caller's IR, so it costs no compilation of its own (a compiled function costs 0.1-0.3 s of
CPU to compile, its own machine code and Python wrapper, however small it is, and its code is
compiled again into each caller's module).  A helper with several callers is ``@compiled``:
inlining it would compile its body once per call site.  Loops that run once per solve or per
refinement round are vectorised numpy instead (docs/benchmarks.md "First run").

A function that allocates no array (it reads and writes the arrays it is given) is
``@leaf`` instead of ``@compiled``: compiled the same way but without numba's reference
counting (``_nrt=False``).  With reference counting, every call of a compiled function from
compiled code increments and decrements the count of each array argument around the call
(two atomic operations per array; a multi-block ``@inlined`` helper pays the same on its
array arguments), and these were the largest single cost of the sight-line expansion and
the exact segment tests of the 1024 x 1024 graph build (``perf``: ``NRT_incref`` /
``NRT_decref``).  A hot loop is therefore a ``@leaf`` given its scratch arrays by a thin
``@compiled`` (or Python) wrapper that allocates them, and the helpers it calls are
``@leaf`` or single-block ``@inlined`` (whose counts numba removes).  Compiling a ``@leaf``
that allocates is an error (numba refuses), so the rule cannot be broken silently.

Shared compiled utilities: :func:`argsort_stable` and the binary min-heap :func:`heap_push` /
:func:`heap_pop` (the swarm roadmap's searches, the compiled A* of the built tangent graph).

Type names: ``f8`` float64, ``i8`` int64, ``b1`` boolean; ``F1``, ``F2``, ``F3`` C-contiguous
float64 arrays of 1, 2, 3 dimensions, ``I1``, ``I2`` int64 ones, ``B1``, ``B2`` boolean ones;
``FA1``, ``FA2`` float64 arrays of any layout (strided views: the swarm's particles are a view
into its polylines).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import types

from optplan.geometry.compiled.kernel_cache import REGISTRY, KernelCache
from optplan.geometry.compiled.numba_internals import (
    NO_REFCOUNT,
    LazyDispatcher,
    global_compiler_lock,
)

__all__ = ["compiled", "leaf", "inlined", "OneSignature", "argsort_stable",
           "heap_push", "heap_pop", "f8", "i8", "b1", "F1", "F2", "F3", "I1", "I2", "B1", "B2",
           "FA1", "FA2", "IA1", "IA2"]

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


class OneSignature(LazyDispatcher):
    """A numba dispatcher that compiles one declared signature, lazily.

    Until its first call it can compile; the first compilation request, whatever argument
    types it names (a Python call's, or a compiled caller's when that caller is typed),
    compiles (or loads from the disk cache) the declared signature instead, and compilation
    is then disabled.  While it compiles, it holds its cache entry's lock across processes
    (:meth:`optplan.geometry.compiled.kernel_cache.KernelCache.compiling`: processes started
    together compile each kernel once).  Later calls are converted to that signature or rejected,
    exactly as for ``numba.njit([signature])``, which compiles the same signature at import.
    (The first call reaches :meth:`compile` through numba internals:
    :class:`optplan.geometry.compiled.numba_internals.LazyDispatcher`.)
    """

    _declared: tuple[Any, ...] | None = None

    def compile(self, sig: Any) -> Any:
        """Compile the declared signature (whatever ``sig`` is) and disable compilation.

        Parameters
        ----------
        sig : numba signature or tuple of types
            The types of the call that asked; ignored once a signature is declared.

        Returns
        -------
        object
            The entry point of the declared signature's machine code.
        """
        if self._declared is None:
            return super().compile(sig)
        disp: Any = self  # numba's attributes are untyped
        with global_compiler_lock:
            if not self.can_compile:  # compiled meanwhile: the declared overload exists
                return disp.overloads[self._declared].entry_point
            with self.kernel_cache.compiling():  # another process compiling it: wait, load
                entry = super().compile(self._declared)
            self.disable_compile()
            return entry

    def first_signature(self) -> Any:
        """The declared signature (what the first call compiles)."""
        return self._declared


def compiled(*argtypes: Any, refcount: bool = True) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: a numba function with the one signature ``argtypes`` (return type
    inferred), compiled on its first call (:class:`OneSignature`), cached on disk, without
    the GIL, no fastmath.

    Parameters
    ----------
    *argtypes : numba types
        The argument types, in order (the aliases of this module).
    refcount : bool
        False for :func:`leaf`: compiled without numba's reference counting.

    Returns
    -------
    callable
        The decorator; the decorated function is a numba dispatcher that accepts only
        ``argtypes`` (or arguments safely converted to them).
    """
    sig = tuple(argtypes)
    extra = {} if refcount else NO_REFCOUNT

    def wrap(fn: Callable[..., Any]) -> Any:
        disp = OneSignature(py_func=fn, locals={}, targetoptions={
            "nopython": True, "nogil": True, "fastmath": False, "boundscheck": None, **extra})
        # numba's cache, then the shipped one (kernel_cache)
        disp.kernel_cache = KernelCache(fn)
        disp._declared = sig
        REGISTRY.append(disp)
        return disp

    return wrap


def leaf(*argtypes: Any) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: :func:`compiled` without reference counting, for a function that
    allocates no array (module docstring); numba refuses to compile one that does.

    Parameters
    ----------
    *argtypes : numba types
        The argument types, in order.

    Returns
    -------
    callable
        The decorator (as :func:`compiled`'s).
    """
    return compiled(*argtypes, refcount=False)


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


@compiled(types.Array(f8, 1, "A"))
def argsort_stable(keys):  # pragma: no cover - compiled
    """``np.argsort(keys, kind="stable")`` for compiled code: ascending, ties in index order,
    NaN last (numpy's and numba's order); a bottom-up merge sort.

    A stable sort's order is unique, so this returns exactly what numba's
    ``np.argsort(kind="mergesort")`` returns; compiling that one costs about 1.3 s of CPU (its
    merge routines, per key type), this one about a tenth of it.

    Parameters
    ----------
    keys : ndarray of float64, shape (n,)
        The keys (any layout).

    Returns
    -------
    ndarray of int64, shape (n,)
        The permutation that sorts ``keys``.
    """
    n = keys.shape[0]
    a = np.arange(n)
    b = np.empty(n, np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i, j = lo, mid
            for k in range(lo, hi):
                if i < mid and j < hi:
                    x, y = keys[a[i]], keys[a[j]]
                    # take from the right only when it is strictly smaller (stable);
                    # NaN is larger than everything but NaN
                    take_right = y < x or (math.isnan(x) and not math.isnan(y))
                else:
                    take_right = i >= mid
                if take_right:
                    b[k] = a[j]
                    j += 1
                else:
                    b[k] = a[i]
                    i += 1
        a, b = b, a
        width *= 2
    return a


@compiled(F1, I1, i8, f8, i8)  # one signature: no literal-argument specialisations
def heap_push(hk, hv, size, key, val):
    """Push ``(key, val)`` onto the binary min-heap ``hk, hv`` of ``size`` items (compiled
    code: the roadmap's searches, the built tangent graph's A*); returns the new size."""
    i = size
    hk[i] = key
    hv[i] = val
    while i > 0:
        up = (i - 1) >> 1
        if hk[up] <= hk[i]:
            break
        hk[up], hk[i] = hk[i], hk[up]
        hv[up], hv[i] = hv[i], hv[up]
        i = up
    return size + 1


@compiled(F1, I1, i8)
def heap_pop(hk, hv, size):
    """Pop the smallest ``(key, val)``; returns it and the new size."""
    key, val = hk[0], hv[0]
    size -= 1
    hk[0], hv[0] = hk[size], hv[size]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and hk[c + 1] < hk[c]:
            c += 1
        if hk[i] <= hk[c]:
            break
        hk[c], hk[i] = hk[i], hk[c]
        hv[c], hv[i] = hv[i], hv[c]
        i = c
    return key, val, size
