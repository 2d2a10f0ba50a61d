"""The numba internals of the kernel machinery (optplan.geometry.compiled.numba_internals) are still
there and still behave as relied on; the installed numba is inside the tested pin.

A numba that changed one of them must fail here, with a message naming what changed ("numba
X changed ...; update optplan/geometry/compiled/numba_internals.py and the numba pin"), not make the
kernels silently compile again in every process or on every call.
"""

from __future__ import annotations

import inspect
import os
import subprocess
import sys
import tomllib
from contextlib import contextmanager
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core import caching, dispatcher
from packaging.specifiers import SpecifierSet
from packaging.version import Version

from optplan.geometry.compiled import numba_internals as ni
from optplan.geometry.compiled.jit import compiled, f8, i8

ROOT = Path(__file__).resolve().parents[2]


def _changed(what: str) -> str:
    return (f"numba {numba.__version__} changed {what}; update "
            f"optplan/geometry/compiled/numba_internals.py and the numba pin in pyproject.toml")


def test_every_internal_is_there() -> None:
    """The checks ``import optplan`` runs (a failure there raises NumbaInternalsError)."""
    found = ni.problems()
    assert not found, "\n".join(found)


def test_the_pin_is_the_tested_range() -> None:
    """pyproject.toml pins numba to numba_internals.TESTED (the package and the wheel's build
    hook), and the installed numba is inside it."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    hook = meta["tool"]["hatch"]["build"]["targets"]["wheel"]["hooks"]["custom"]
    for where, deps in (("[project] dependencies", meta["project"]["dependencies"]),
                        ("the wheel hook's dependencies", hook["dependencies"])):
        pins = [d for d in deps if d.startswith("numba")]
        assert pins == [f"numba{ni.TESTED}"], f"{where}: {pins} (numba_internals.TESTED: "\
                                              f"{ni.TESTED})"
    spec = SpecifierSet(ni.TESTED)
    assert any(s.operator == "<" for s in spec), "the pin needs an upper bound"
    assert Version(numba.__version__) in spec, (
        f"numba {numba.__version__} is outside the tested range numba{ni.TESTED}: run these "
        "tests with it, update optplan/geometry/compiled/numba_internals.py if they fail, then "
        "widen "
        "the pin (pyproject.toml, numba_internals.TESTED)")


@pytest.mark.parametrize("what, owner, needle", [
    ("Cache._impl (set in Cache.__init__)", caching.Cache.__init__, "self._impl = "),
    ("Cache._cache_file (set in Cache.__init__)", caching.Cache.__init__,
     "self._cache_file = "),
    ("IndexDataCacheFile._index_path", caching.IndexDataCacheFile.__init__,
     "self._index_path = "),
    ("CacheImpl: the locator classes of _locator_classes", caching.CacheImpl.__init__,
     "self._locator_classes"),
    ("CacheImpl: RuntimeError when no locator applies", caching.CacheImpl.__init__,
     "raise RuntimeError"),
    ("the locator's _py_file (read by CompileResultCacheImpl)", caching.CompileResultCacheImpl,
     "self._locator._py_file"),
    ("Dispatcher._cache (set in Dispatcher.__init__)", dispatcher.Dispatcher.__init__,
     "self._cache = "),
    ("Dispatcher.compile: loads through self._cache", dispatcher.Dispatcher.compile,
     "self._cache.load_overload("),
    ("Dispatcher.compile: saves through self._cache", dispatcher.Dispatcher.compile,
     "self._cache.save_overload("),
    ("Dispatcher.compile: refuses once _can_compile is False", dispatcher.Dispatcher.compile,
     "self._can_compile"),
    ("disable_compile sets _can_compile", dispatcher.Dispatcher.disable_compile,
     "self._can_compile = "),
    ("_compile_for_args calls _compilation_chain_init_hook",
     dispatcher.Dispatcher._compile_for_args, "self._compilation_chain_init_hook()"),
    ("Cache._index_key returns (sig, codegen.magic_tuple(), hashes)",
     caching.Cache._index_key, "return (sig, codegen.magic_tuple(), "),
])
def test_private_attributes_are_set_and_read_where_relied_on(what, owner, needle) -> None:
    """The private attributes numba_internals reads or writes on numba's objects, in numba's
    source (the import-time checks see classes and signatures, not instance attributes)."""
    try:
        src = inspect.getsource(owner)
    except (OSError, TypeError):
        pytest.skip("numba installed without its sources")
    assert needle in src, _changed(what)


def _twice(x, n):
    return 2.0 * x + n


class _TmpLocator(ni.CacheLocator):
    """Entries in ``root`` (set by the test)."""

    root = ""

    def __init__(self, py_func, py_file):
        super().__init__(py_file)
        self._line = py_func.__code__.co_firstlineno

    def get_cache_path(self):
        return self.root

    def get_source_stamp(self):
        return "stamp"

    def get_disambiguator(self):
        return str(self._line)

    @classmethod
    def from_function(cls, py_func, py_file):
        return cls(py_func, py_file)


class _TmpCache(ni.LocatedCache):
    locator = _TmpLocator
    cpu = ("generic", "")

    @contextmanager
    def compiling(self):
        yield


def test_a_located_cache_saves_and_loads_through_its_locator(tmp_path) -> None:
    """What the shipped cache needs: entries saved where our locator says, keyed with the CPU
    we name, and loaded again by a fresh dispatcher (a hit: nothing compiled)."""
    _TmpLocator.root = str(tmp_path)
    first = compiled(f8, i8)(_twice)
    first.kernel_cache = _TmpCache(_twice)
    assert first(1.5, 2) == 5.0
    assert (sum(first.stats.cache_misses.values()), sum(first.stats.cache_hits.values())) \
        == (1, 0), _changed("how a dispatcher saves through its cache")
    names = sorted(p.suffix for p in tmp_path.iterdir())
    assert names == [".nbc", ".nbi"], _changed(f"where a located cache writes ({names})")
    codegen = first.targetctx.codegen()
    magic = codegen.magic_tuple()
    assert isinstance(magic, tuple) and len(magic) == 3, _changed(f"magic_tuple ({magic})")
    key = first.kernel_cache._index_key(first.signatures[0], codegen)
    assert key[1] == (magic[0], "generic", ""), _changed(f"Cache._index_key ({key[:2]})")
    again = compiled(f8, i8)(_twice)
    again.kernel_cache = _TmpCache(_twice)
    assert again(1.5, 2) == 5.0
    assert (sum(again.stats.cache_misses.values()), sum(again.stats.cache_hits.values())) \
        == (0, 1), _changed("how a dispatcher loads through its cache (compiled again)")


def test_the_first_call_compiles_the_declared_signature_only() -> None:
    """LazyDispatcher._compile_for_args: numba's C dispatcher calls it on the first call (an
    int for the float64 argument), it compiles the declared signature, and the call is then
    converted to it; other types are refused, nothing else is compiled."""
    k = compiled(f8, i8)(_twice)
    assert k.can_compile
    assert k(1, 2) == 4.0
    assert k.signatures == [(numba.float64, numba.int64)], _changed(
        f"the first call's compilation (_compile_for_args): {k.signatures}")
    assert not k.can_compile, _changed("disable_compile / _can_compile")
    assert k(np.float64(0.5), np.int64(1)) == 2.0
    with pytest.raises(TypeError):
        k("a", 1)
    assert len(k.signatures) == 1


def test_numba_cache_and_its_lock_path() -> None:
    """numba's own cache of a function in a file (here: the tests' ``__pycache__`` or
    NUMBA_CACHE_DIR), the lock beside its index; none for a function without a file."""
    c = ni.numba_cache(_twice)
    assert c is not None
    lock = ni.index_lock_path(c)
    assert lock.endswith(".nbi.lock") and os.path.dirname(lock) == c.cache_path
    assert os.path.isdir(c.cache_path)
    ns: dict = {}
    exec(compile("def g(x):\n    return x\n", "<no file>", "exec"), ns)
    assert ni.numba_cache(ns["g"]) is None, _changed("FunctionCache without a locator")


def test_user_cache_dir_is_the_one_numba_uses() -> None:
    user = getattr(caching, "UserWideCacheLocator", None) or caching._UserWideCacheLocator
    loc = user(_twice, inspect.getfile(_twice))
    assert loc.get_cache_path().startswith(ni.user_cache_dir()), _changed("AppDirs")


def test_a_lost_private_attribute_is_an_error_not_a_slowdown() -> None:
    k = compiled(f8, i8)(_twice)
    del k.__dict__["_cache"]  # as if numba had renamed it
    with pytest.raises(ni.NumbaInternalsError, match="changed .*_cache.*update"):
        k.kernel_cache = None
    with pytest.raises(ni.NumbaInternalsError, match="_index_path"):
        ni.index_lock_path(object())


@pytest.mark.parametrize("remove, named", [
    ("del caching._CacheLocator", "_CacheLocator"),
    ("del dispatcher._DispatcherBase._compile_for_args", "_compile_for_args"),
    ("caching.Cache._index_key = lambda self, sig: None", "_index_key"),
])
def test_a_missing_internal_fails_the_import_loudly(remove, named) -> None:
    """A numba without one of the internals: importing the kernels raises
    NumbaInternalsError naming it and what to update."""
    code = ("from numba.core import caching, dispatcher\n"
            f"{remove}\n"
            "import optplan.geometry.compiled.jit\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       cwd=ROOT, check=False)
    assert p.returncode != 0
    assert "NumbaInternalsError" in p.stderr, p.stderr[-2000:]
    assert named in p.stderr and "update optplan/geometry/compiled/numba_internals.py and the " \
        "numba pin" in p.stderr, p.stderr[-2000:]
