"""Where the compiled kernels' machine code is cached: numba's per-user cache, and a cache
shipped inside a wheel so that a fresh installation's first solve compiles nothing.

Every ``@compiled`` kernel (:mod:`optplan.geometry.compiled.jit`) looks up its machine code in two
places, in this order (:class:`KernelCache`):

1. **numba's own cache** (``NUMBA_CACHE_DIR`` when set; else ``__pycache__`` beside the
   module when writable; else the user-wide ``~/.cache/numba``): what this machine compiled
   for its own CPU.  A kernel compiled in this process is saved here, never elsewhere.  When
   none of these is writable, numba has no cache: the kernel is compiled in memory, again in
   every process, with one :class:`NoKernelCacheWarning` per process (numba alone would
   refuse to compile it: ``import optplan`` failed).
2. **the shipped cache** ``optplan/_kernels/`` (read only): machine code compiled when the
   wheel was built (:func:`build`, run by the wheel's build hook ``hatch_build.py``) for the
   *generic* CPU of the build's platform (numba's ``NUMBA_CPU_NAME=generic``: the baseline
   instruction set, x86-64 with SSE2 on a PC, so it runs on any CPU of that platform).

numba has no public API for either: the numba internals this needs are in
:mod:`optplan.geometry.compiled.numba_internals`, and nowhere else.

numba keys an entry on the function's signature, its bytecode, the platform triple, the CPU
name and features and numba's version; the shipped entries are stamped with a hash of the
sources of every kernel module (a kernel's machine code includes the kernels it calls, from
other modules too; numba's own cache stamps only the kernel's own file) and looked up with
the CPU name and features replaced by the generic ones they were built with.  Any difference
(another Python, another numba, another platform, an edited kernel module) is a miss: the
kernel is compiled as before, for this CPU, and saved in numba's cache.

A source checkout (``pip install -e``, ``make test``) has no shipped cache: ``optplan/_kernels``
only exists in a built wheel.  ``make``'s install step instead compiles every kernel for this
machine into numba's own cache (:func:`compile_all`), so that its first solves load them too.
Build a shipped cache into a directory with
``python -c "from optplan.geometry.compiled.kernel_cache import build_in_child as b; b('DIR')"`` (a
child process with the generic CPU: :func:`build` refuses to run with the host's CPU, whose
code could not be shipped).  The results are
the same either way: no kernel uses fast-math, so the generic and the host code compute the
same floating-point operations in the same order (``benchmarks/ipso_digest.py`` prints the
same digests).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from functools import cache
from importlib import import_module
from pathlib import Path
from typing import Any

from optplan.geometry.compiled.numba_internals import (
    CacheLocator,
    LocatedCache,
    cpu,
    index_lock_path,
    numba_cache,
    user_cache_dir,
)

__all__ = ["KERNEL_MODULES", "REGISTRY", "SHIPPED_DIR", "GENERIC_CPU", "KernelCache",
           "NoKernelCacheWarning", "ShippedCache", "build", "build_in_child", "compile_all"]

#: The package's root directory (``optplan/``).
PACKAGE_DIR = Path(__file__).resolve().parents[2]
#: The shipped cache's directory inside the package (present in a built wheel only).
SHIPPED_DIR = PACKAGE_DIR / "_kernels"
#: The CPU name and features the shipped cache is compiled for (numba's generic target).
GENERIC_CPU = ("generic", "")
#: Every module that defines ``@compiled`` kernels (a test checks the list is complete).
KERNEL_MODULES = (
    "optplan.geometry.compiled.jit",
    "optplan.geometry.collision.kernel",
    "optplan.geometry.collision.nearest_kernel",
    "optplan.geometry.collision.pairs_kernel",
    "optplan.geometry.collision.arc_kernel",
    "optplan.geometry.tangent.triangular_expansion",
    "optplan.geometry.tangent.chain_search",
    "optplan.swarm.operators",
    "optplan.swarm.ga",
    "optplan.swarm.ipso",
    "optplan.swarm.refine",
    "optplan.swarm.signatures",
    "optplan.swarm.roadmap",
    "optplan.swarm.roadmap_graph",
    "optplan.maps.movingai_gen",
)


@cache
def _sources_hash() -> str:
    """SHA-256 of the sources of every kernel module (the shipped entries' freshness stamp:
    a kernel's machine code includes the kernels it calls, from other modules too, so an edit
    to any of them makes every shipped entry stale)."""
    h = hashlib.sha256()
    for name in KERNEL_MODULES:
        h.update(PACKAGE_DIR.joinpath(*name.split(".")[1:]).with_suffix(".py").read_bytes())
    return h.hexdigest()


class _ShippedLocator(CacheLocator):
    """numba cache locator of the shipped cache: ``root/<the module's package path>``,
    stamped with the contents of every kernel module (:func:`_sources_hash`; not their
    modification times, which an installation does not keep)."""

    root: Path = SHIPPED_DIR

    def __init__(self, py_func: Any, py_file: str) -> None:
        super().__init__(py_file)
        self._lineno = py_func.__code__.co_firstlineno
        rel = Path(py_file).resolve().parent.relative_to(PACKAGE_DIR)
        self._cache_path = str(self.root / rel)

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_source_stamp(self) -> str:
        return _sources_hash()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> _ShippedLocator | None:
        try:
            return cls(py_func, py_file)
        except ValueError:  # not a module of the package
            return None


class ShippedCache(LocatedCache):
    """numba's function cache on the shipped directory, keyed with the generic CPU (the CPU
    the entries were compiled for) instead of this process's CPU."""

    locator = _ShippedLocator
    cpu = GENERIC_CPU

    @contextmanager
    def compiling(self) -> Iterator[None]:
        """No lock (:meth:`KernelCache.compiling`): the shipped cache is built by one
        process."""
        yield


class KernelCache:
    """A kernel's cache: numba's own cache first (loads and saves), then the shipped one
    (loads only, when the package has one).  Implements what a numba dispatcher asks of its
    ``_cache``."""

    def __init__(self, py_func: Any) -> None:
        self._own: Any = numba_cache(py_func)  # None: numba has no writable cache directory
        if self._own is None:
            _warn_no_cache(py_func)
        self._shipped: ShippedCache | None = None
        if SHIPPED_DIR.is_dir():
            try:
                self._shipped = ShippedCache(py_func)
            except RuntimeError:  # a kernel outside the package: no shipped entry
                pass

    @property
    def cache_path(self) -> str:
        """numba's own cache directory of this kernel (``""`` when there is none: the kernel
        compiles in memory)."""
        return self._own.cache_path if self._own is not None else ""

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        """The cached compile result of ``sig``: numba's cache, else the shipped one, else
        None."""
        found = None if self._own is None else self._own.load_overload(sig, target_context)
        if found is None and self._shipped is not None:
            found = self._shipped.load_overload(sig, target_context)
        return found

    def save_overload(self, sig: Any, data: Any) -> None:
        """Save a compile result of this process in numba's cache (nowhere when there is
        none)."""
        if self._own is not None:
            self._own.save_overload(sig, data)

    @contextmanager
    def compiling(self) -> Iterator[None]:
        """Hold, across processes, an exclusive lock on this kernel's entry in numba's cache
        while it compiles (POSIX ``flock`` on ``<entry>.nbi.lock``; no lock where there is no
        ``flock`` or the lock file cannot be made).  Processes started together (pytest-xdist
        workers, a sweep's workers) then compile each kernel once: the others wait, and the
        compilation they then ask for finds the kernel in the cache and loads it."""
        if self._own is None:  # compiled in memory: nothing to share
            yield
            return
        try:
            import fcntl

            f = open(index_lock_path(self._own), "a")  # noqa: SIM115
        except (ImportError, OSError):
            yield
            return
        with f:
            fcntl.flock(f, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(f, fcntl.LOCK_UN)

    def enable(self) -> None:
        if self._own is not None:
            self._own.enable()

    def disable(self) -> None:
        if self._own is not None:
            self._own.disable()

    def flush(self) -> None:
        if self._own is not None:
            self._own.flush()


class NoKernelCacheWarning(RuntimeWarning):
    """numba has no writable cache directory: kernels compile in memory, in every process."""


_warned: list[bool] = []  # the fallback's warning, once per process


def _warn_no_cache(py_func: Any) -> None:
    """Warn, once per process, that numba found no writable cache directory for the kernels
    (``NUMBA_CACHE_DIR`` unset, the package's ``__pycache__`` and numba's user-wide cache
    directory not writable): they are compiled in memory instead (and the shipped ones, in a
    wheel, still loaded)."""
    if _warned:
        return
    _warned.append(True)
    import warnings

    user = user_cache_dir()
    here = Path(py_func.__code__.co_filename).resolve().parent / "__pycache__"
    shipped = " (the kernels the wheel ships are still loaded)" if SHIPPED_DIR.is_dir() else ""
    warnings.warn(
        f"optplan: numba found no writable cache directory for its compiled kernels: "
        f"NUMBA_CACHE_DIR is unset, and neither the package's __pycache__ ({here}, beside each "
        f"module) nor numba's user cache directory ({user}) could be written; kernels are "
        f"compiled in memory, again in every process{shipped}.  Set NUMBA_CACHE_DIR to a "
        f"writable directory to cache them", NoKernelCacheWarning, stacklevel=4)


#: Every ``@compiled`` (and ``@leaf``) kernel, in definition order
#: (``optplan.geometry.compiled.jit`` registers them; :func:`build` compiles those of the package).
REGISTRY: list[Any] = []


def _dispatchers(modules: Sequence[str]) -> list[Any]:
    """The ``@compiled`` kernels defined in ``modules`` (imported here)."""
    for name in modules:
        import_module(name)
    return [d for d in REGISTRY if d.py_func.__module__ in modules]


def compile_all(modules: Sequence[str] = KERNEL_MODULES) -> int:
    """Compile the kernels of ``modules`` (default: all) for this machine's CPU into numba's
    own cache, as their first calls would (those already cached load instead).

    The two-command start's install step runs it (``make``: "compiling the numba kernels"), so
    that a checkout's first solves, like an installed wheel's, compile nothing.  Returns the
    number of kernels.
    """
    disps = _dispatchers(modules)
    for d in disps:
        d.compile(d._declared)
    return len(disps)


def build(dest: str | os.PathLike[str], modules: Sequence[str] = KERNEL_MODULES) -> int:
    """Compile the kernels of ``modules`` (default: all) for the generic CPU into ``dest``
    (the shipped cache's layout; the kernels they call are compiled there too).

    Runs in a process started with ``NUMBA_CPU_NAME=generic`` (:func:`build_in_child` starts
    one); refuses otherwise.  Returns the number of kernels compiled.
    """
    if cpu() != GENERIC_CPU:
        raise RuntimeError("the shipped kernel cache must be compiled for the generic CPU: "
                           "use build_in_child(dir) (it sets NUMBA_CPU_NAME=generic); this "
                           f"process has NUMBA_CPU_NAME={cpu()[0]!r}")
    _ShippedLocator.root = Path(dest).resolve()
    disps = _dispatchers(modules)
    for d in REGISTRY:  # before anything compiles: a kernel's callees save there too
        d.kernel_cache = ShippedCache(d.py_func)
    for d in disps:
        d.compile(d._declared)
    return len(disps)


def build_in_child(dest: str | os.PathLike[str], modules: Sequence[str] = KERNEL_MODULES) -> None:
    """:func:`build` in a child of this interpreter started with ``NUMBA_CPU_NAME=generic``
    (the wheel's build hook calls this).

    Raises
    ------
    RuntimeError
        When the child fails (its output is in the message).
    """
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CPU_FEATURES", "NUMBA_OPT")}
    env["NUMBA_CPU_NAME"] = GENERIC_CPU[0]
    code = ("import sys; from optplan.geometry.compiled.kernel_cache import build; "
            "build(sys.argv[1], sys.argv[2:])")
    p = subprocess.run([sys.executable, "-c", code, os.fspath(dest), *modules], env=env,
                       capture_output=True, text=True, check=False)
    if p.returncode != 0:
        raise RuntimeError(f"building the shipped kernel cache into {os.fspath(dest)!r} failed "
                           f"(exit {p.returncode}):\n{p.stdout}{p.stderr}")
