"""Every use of numba's private internals, in one place (the kernel machinery of
:mod:`optplan.geometry.compiled.jit` and :mod:`optplan.geometry.compiled.kernel_cache` needs a few).

numba has no public API for what the kernels need: a cache that looks in two places (numba's
own, then the one a wheel ships), a lock around a compilation shared by processes, a
dispatcher that compiles one declared signature lazily, on its first call.  Each is built on
an internal of numba, listed below with what it relies on; nothing else in optplan names a
private numba attribute.  Tested with the numba versions of the pin in ``pyproject.toml``
(:data:`TESTED`): the internals below are the same, with the same signatures, from numba 0.60
(read in its source) to 0.68 (the tests run on it).

When this module is imported, :func:`problems` checks that every internal class, method and
signature is still there; a numba that changed one makes ``import optplan`` fail with a
:class:`NumbaInternalsError` naming it (a missing internal would otherwise not always fail:
the kernels could silently compile in every process, or on every call).  The private
attributes of numba's objects are checked where they are used, on the objects (a dispatcher's
``_cache`` when a kernel is declared, at import; a cache's ``_impl`` and ``_cache_file`` when
it is made): a missing one is a :class:`NumbaInternalsError` too.  The behaviour (entries
written and loaded again through a locator of ours, the key naming another CPU, the first
call compiling the declared signature, the lock file beside the index) is tested by
``tests/geometry/test_numba_internals.py``.  When numba changes one: adapt this module (only
this one), then widen the pin.

The internals, and what each relies on:

``numba.core.caching._CacheLocator`` (:class:`CacheLocator`)
    The abstract base of numba's cache locators, with the attribute ``_py_file`` numba reads
    (its warning that a function cannot be cached).  A subclass implements
    ``get_cache_path()`` (the entries' directory), ``get_source_stamp()`` (any picklable
    freshness stamp: a stale stamp is a miss), ``get_disambiguator()`` (a string told apart
    functions of one name) and the class method ``from_function(py_func, py_file)`` (an
    instance, or None when the locator does not apply); numba calls the inherited
    ``ensure_cache_path()`` (makes the directory) before it saves an entry.
``CompileResultCacheImpl._locator_classes``, ``FunctionCache._impl_class`` (:class:`LocatedCache`)
    A cache implementation tries the locator classes of ``_locator_classes`` in order (the
    first whose ``from_function`` returns one wins; none: ``RuntimeError``), and a
    ``FunctionCache`` builds its implementation from the class ``_impl_class``.
``Cache._index_key(sig, codegen)`` (:attr:`LocatedCache.cpu`)
    An entry's key: ``(sig, codegen.magic_tuple(), hashes)`` where ``magic_tuple()`` is
    ``(target triple, CPU name, CPU features)``; replacing the CPU names the CPU the entries
    were compiled for (the shipped cache: numba's generic CPU) instead of this process's.
``Cache._impl.locator``, ``Cache._cache_file._index_path`` (:func:`index_lock_path`)
    A cache's locator (its ``ensure_cache_path()``) and the path of the entry's index file
    (``<function>-<line>.pyXY.nbi``): the cross-process compile lock sits beside it.
``RuntimeError`` from ``FunctionCache(py_func)`` (:func:`numba_cache`)
    numba's own cache raises it when none of its locators applies (no writable directory):
    the kernels then compile in memory.
``numba.misc.appdirs.AppDirs`` (:func:`user_cache_dir`)
    numba's vendored ``appdirs``: ``AppDirs(appname="numba", appauthor=False).user_cache_dir``
    is the directory of numba's user-wide cache locator (the warning names it).
``numba.core.config.CPU_NAME``, ``CPU_FEATURES`` (:func:`cpu`)
    The ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` of this process.
``numba.core.registry.CPUDispatcher``, ``Dispatcher._compile_for_args``,
``_compilation_chain_init_hook``, ``_can_compile``, ``_cache``,
``numba.core.compiler_lock.global_compiler_lock`` (:class:`LazyDispatcher`)
    A call from Python that matches no compiled overload, while compilation is enabled, makes
    numba's C dispatcher call ``self._compile_for_args(*args)`` and call what it returns with
    the same arguments; ``_compilation_chain_init_hook()`` prepares the compiler (numba calls
    it first in its own ``_compile_for_args``).  ``_can_compile`` is False once
    ``disable_compile()`` ran; ``compile(sig)`` loads and saves through the cache object
    ``_cache`` (``load_overload``, ``save_overload``, ``enable``, ``disable``, ``flush``,
    ``cache_path``), under the re-entrant ``global_compiler_lock``.
``targetoptions["_nrt"]`` (:data:`NO_REFCOUNT`)
    The target option compiling a function without numba's reference counting.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any, ClassVar

import numba
from numba.core import caching, config, dispatcher, registry
from numba.core.compiler_lock import global_compiler_lock

__all__ = ["TESTED", "NO_REFCOUNT", "NumbaInternalsError", "CacheLocator", "FunctionCache",
           "LocatedCache", "LazyDispatcher", "global_compiler_lock", "numba_cache",
           "index_lock_path", "user_cache_dir", "cpu", "problems"]

#: The numba versions this module is tested with (the pin of ``pyproject.toml``; a test checks
#: that the two agree).
TESTED = ">=0.60,<0.69"
#: Target options compiling a function without numba's reference counting (``@leaf``).
NO_REFCOUNT: dict[str, Any] = {"_nrt": False}


class NumbaInternalsError(ImportError):
    """The installed numba lacks an internal the kernel machinery uses (module docstring)."""


def _fix(what: str) -> str:
    return (f"numba {numba.__version__} changed {what}; update "
            f"optplan/geometry/compiled/numba_internals.py and the numba pin in pyproject.toml "
            f"(tested: numba{TESTED})")


def _params(fn: Any) -> list[str]:
    try:
        return list(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        return []


def _abstract(cls: Any) -> set[str]:
    return set(getattr(cls, "__abstractmethods__", ()))


#: (what, check): each check is True when the internal is there with the shape relied on
_CHECKS: list[tuple[str, Callable[[], bool]]] = [
    ("numba.core.caching._CacheLocator (the base of a cache locator: abstract "
     "get_cache_path, get_source_stamp, get_disambiguator; from_function, ensure_cache_path)",
     lambda: isinstance(getattr(caching, "_CacheLocator", None), type)
     and _abstract(caching._CacheLocator) == {"get_cache_path", "get_source_stamp",
                                              "get_disambiguator"}
     and _params(caching._CacheLocator.from_function) == ["py_func", "py_file"]
     and _params(caching._CacheLocator.ensure_cache_path) == ["self"]),
    ("numba.core.caching.CompileResultCacheImpl._locator_classes (the locators tried)",
     lambda: isinstance(getattr(getattr(caching, "CompileResultCacheImpl", None),
                                "_locator_classes", None), list)),
    ("numba.core.caching.FunctionCache._impl_class (its implementation class)",
     lambda: getattr(getattr(caching, "FunctionCache", None), "_impl_class", None)
     is getattr(caching, "CompileResultCacheImpl", object())),
    ("numba.core.caching.Cache._index_key(sig, codegen) (an entry's key)",
     lambda: _params(getattr(getattr(caching, "Cache", None), "_index_key", None))
     == ["self", "sig", "codegen"]),
    ("numba.core.caching.Cache's load_overload(sig, target_context), save_overload(sig, "
     "data), enable, disable, flush, cache_path (what a dispatcher asks of its cache)",
     lambda: _params(caching.Cache.load_overload) == ["self", "sig", "target_context"]
     and _params(caching.Cache.save_overload) == ["self", "sig", "data"]
     and all(hasattr(caching.Cache, n) for n in ("enable", "disable", "flush", "cache_path"))),
    ("numba.misc.appdirs.AppDirs (numba's user-wide cache directory)",
     lambda: hasattr(_appdirs(), "user_cache_dir")),
    ("numba.core.config.CPU_NAME / CPU_FEATURES (NUMBA_CPU_NAME, NUMBA_CPU_FEATURES)",
     lambda: hasattr(config, "CPU_NAME") and hasattr(config, "CPU_FEATURES")),
    ("numba.core.registry.CPUDispatcher (the dispatcher of @njit)",
     lambda: isinstance(getattr(registry, "CPUDispatcher", None), type)
     and issubclass(registry.CPUDispatcher, dispatcher.Dispatcher)),
    ("Dispatcher._compile_for_args(*args, **kws) (numba's C dispatcher calls it on a call "
     "no overload matches)",
     lambda: _params(getattr(dispatcher.Dispatcher, "_compile_for_args", None))
     == ["self", "args", "kws"]),
    ("Dispatcher._compilation_chain_init_hook() (prepares the compiler)",
     lambda: _params(getattr(dispatcher.Dispatcher, "_compilation_chain_init_hook", None))
     == ["self"]),
    ("Dispatcher.compile(sig) and disable_compile(val)",
     lambda: _params(dispatcher.Dispatcher.compile) == ["self", "sig"]
     and _params(dispatcher.Dispatcher.disable_compile) == ["self", "val"]),
]


def _appdirs() -> Any:
    from numba.misc.appdirs import AppDirs

    return AppDirs(appname="numba", appauthor=False)


def problems() -> list[str]:
    """The internals the installed numba lacks or changed (``[]``: none), as messages
    saying what to update."""
    bad = []
    for what, check in _CHECKS:
        try:
            ok = check()
        except Exception:  # noqa: BLE001 - any failure of a check is a changed internal
            ok = False
        if not ok:
            bad.append(_fix(what))
    return bad


_found = problems()
if _found:
    raise NumbaInternalsError("optplan's compiled kernels need numba internals that the "
                              "installed numba does not have:\n" + "\n".join(_found))

FunctionCache: Any = caching.FunctionCache


class CacheLocator(caching._CacheLocator):
    """The base of a numba cache locator (module docstring): a subclass implements
    ``get_cache_path``, ``get_source_stamp``, ``get_disambiguator`` and ``from_function``,
    and calls this ``__init__``.  numba reads the attribute ``_py_file`` (the function's
    file, named in its warning that a function cannot be cached)."""

    def __init__(self, py_file: str) -> None:
        self._py_file = py_file


class LocatedCache(FunctionCache):
    """numba's function cache with one locator class, :attr:`locator` (a subclass of
    :class:`CacheLocator`), and an index key naming the CPU :attr:`cpu` (name, features)
    instead of this process's.  Subclasses set both."""

    locator: ClassVar[type]
    cpu: ClassVar[tuple[str, str]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._impl_class = type(f"{cls.__name__}Impl", (caching.CompileResultCacheImpl,),
                               {"_locator_classes": [cls.locator]})

    def _index_key(self, sig: Any, codegen: Any) -> Any:
        try:
            sig_, (triple, _name, _features), hashes = super()._index_key(sig, codegen)
        except (TypeError, ValueError) as e:
            raise NumbaInternalsError(_fix("Cache._index_key's key (sig, (triple, cpu name, "
                                           f"cpu features), hashes): {e}")) from e
        return (sig_, (triple, *self.cpu), hashes)


def numba_cache(py_func: Any) -> Any:
    """numba's own function cache of ``py_func`` (``NUMBA_CACHE_DIR``, ``__pycache__``, the
    user-wide directory), or None when numba has no writable place for it."""
    try:
        cache = FunctionCache(py_func)
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return None
    _has(cache, "_impl", "_cache_file")
    return cache


def _has(obj: Any, *names: str) -> None:
    """Raise :class:`NumbaInternalsError` unless ``obj`` has the private attributes
    ``names``."""
    missing = [n for n in names if not hasattr(obj, n)]
    if missing:
        raise NumbaInternalsError(_fix(f"the attributes {missing} of {type(obj).__name__}"))


def index_lock_path(cache: Any) -> str:
    """The path of the compile lock of a :func:`numba_cache` entry (beside its index file,
    ``<entry>.nbi.lock``), its directory made."""
    try:
        cache._impl.locator.ensure_cache_path()
        return str(cache._cache_file._index_path) + ".lock"
    except AttributeError as e:
        raise NumbaInternalsError(_fix(f"a cache's _impl.locator or _cache_file._index_path: "
                                       f"{e}")) from e


def user_cache_dir() -> str:
    """numba's user-wide cache directory (``~/.cache/numba`` on Linux)."""
    return str(_appdirs().user_cache_dir)


def cpu() -> tuple[str | None, str | None]:
    """``(NUMBA_CPU_NAME, NUMBA_CPU_FEATURES)`` of this process (None: the host's)."""
    cfg: Any = config  # numba's settings module (untyped)
    return cfg.CPU_NAME, cfg.CPU_FEATURES


class LazyDispatcher(registry.CPUDispatcher):
    """A ``CPUDispatcher`` whose first call from Python compiles :meth:`first_signature`
    (:meth:`compile` is given it whatever the call's types), then dispatches the call as
    for an eagerly compiled one; with access to numba's private state it needs."""

    def first_signature(self) -> Any:
        """The signature the first call compiles (a subclass says)."""
        raise NotImplementedError

    def _compile_for_args(self, *_args: Any) -> Any:
        """First call from Python: compile the declared signature, then dispatch the call
        as for an eagerly compiled dispatcher (converted to the declared types, or a
        ``TypeError``): numba calls what this returns with the call's arguments."""
        disp: Any = self  # numba's attributes are untyped
        disp._compilation_chain_init_hook()
        self.compile(self.first_signature())
        return self

    @property
    def can_compile(self) -> bool:
        """Compilation is enabled (``disable_compile()`` not called yet)."""
        _has(self, "_can_compile")
        disp: Any = self
        return bool(disp._can_compile)

    @property
    def kernel_cache(self) -> Any:
        """The cache ``compile()`` loads from and saves to (numba's ``_cache``)."""
        return self._cache

    @kernel_cache.setter
    def kernel_cache(self, cache: Any) -> None:
        _has(self, "_cache")  # set by numba's Dispatcher.__init__: still the one it uses
        self._cache = cache
