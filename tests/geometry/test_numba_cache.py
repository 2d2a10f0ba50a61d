"""A read-only installation still caches its compiled kernels (optplan.geometry.compiled.jit).

A copy of the package whose directories cannot hold a ``__pycache__`` (a file of that name
stands in each; this holds even for root, whom permission bits do not stop) runs a small
``visgraph`` solve in two fresh processes with ``NUMBA_CACHE_DIR`` unset and ``XDG_CACHE_HOME``
pointing at an empty directory: the first compiles the geometry kernels it uses (kernels
compile on their first call) and writes numba's user-wide cache there, the second loads the
kernels from it and compiles nothing.  With no writable cache at all (a home whose
``~/.cache`` cannot be made either) the kernels compile in memory, with one warning.

The kernels a wheel ships (optplan.geometry.compiled.kernel_cache): their build runs only for the
generic CPU and covers every module that declares a kernel; tests/tools/test_install.py builds
a wheel with shipped kernels and loads them.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
import time
from pathlib import Path

PKG = Path(__file__).resolve().parents[2] / "optplan"

CHILD = """
import json
import optplan as op
from optplan.geometry.collision import kernel
from optplan.problem import parse_problem
prob = parse_problem({
    "name": "box", "bounds": [0.0, 0.0, 100.0, 100.0],
    "robots": [{"id": "r", "start": [10.0, 10.0], "goal": [90.0, 90.0], "radius": 1.0}],
    "obstacles": [{"type": "polygon", "vertices": [[30, 30], [70, 30], [70, 70], [30, 70]]}]})
assert op.solve(prob, "visgraph").success
stats = {n: getattr(kernel, n).stats for n in kernel.__all__}
out = {n: [sum(s.cache_hits.values()), sum(s.cache_misses.values())] for n, s in stats.items()}
print(json.dumps({"file": op.__file__, "stats": out}))
"""


def _read_only_copy(dst: Path) -> Path:
    """The package's sources under ``dst`` (with the solver presets where a wheel puts them)
    and no writable ``__pycache__`` anywhere."""
    pkg = dst / "optplan"
    shutil.copytree(PKG, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "_kernels"))
    shutil.copytree(PKG.parent / "solvers", pkg / "_data" / "solvers", dirs_exist_ok=True)
    for d in [pkg, *(p for p in pkg.rglob("*") if p.is_dir())]:
        (d / "__pycache__").write_text("not a directory\n")
    for p in [pkg, *pkg.rglob("*")]:
        p.chmod(p.stat().st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    return pkg


def _run(root: Path, cache_home: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYTHONPATH=str(root), XDG_CACHE_HOME=str(cache_home),
               PYTHONDONTWRITEBYTECODE="1")
    p = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True,
                       cwd=root, check=True)
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert Path(out["file"]).is_relative_to(root), out["file"]  # the copy, not the checkout
    return out["stats"]


def test_read_only_package_caches_in_the_user_cache_dir(tmp_path: Path) -> None:
    pkg = _read_only_copy(tmp_path / "site")
    try:
        first = _run(tmp_path / "site", tmp_path / "cache")
        written = sorted(p.name for p in (tmp_path / "cache" / "numba").rglob("kernel.*.nbi"))
        second = _run(tmp_path / "site", tmp_path / "cache")
    finally:
        for p in [pkg, *pkg.rglob("*")]:
            p.chmod(p.stat().st_mode | stat.S_IWUSR)
    used = {n for n, (hit, miss) in first.items() if hit or miss}
    assert "crossings" in used, first  # the solve ran the collision kernel
    assert all(miss == 1 and hit == 0 for n, (hit, miss) in first.items() if n in used), first
    assert any(n.startswith("kernel.crossings-") for n in written), written
    # the second process compiles nothing: the kernels the solve calls are loaded from the
    # user-wide cache (with the machine code of the kernels they call: those are not loaded)
    assert all(miss == 0 for hit, miss in second.values()), second
    assert second["crossings"] == [1, 0], second
    assert not any((d / "__pycache__").is_dir() for d in [pkg, *pkg.rglob("*")]
                   if d.is_dir())


NO_CACHE_CHILD = """
import json, warnings
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    import optplan as op
    from optplan.geometry.collision import kernel
    from optplan.problem import parse_problem
    prob = parse_problem({
        "name": "box", "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [10.0, 10.0], "goal": [90.0, 90.0], "radius": 1.0}],
        "obstacles": [{"type": "polygon", "vertices": [[30, 30], [70, 30], [70, 70], [30, 70]]}]})
    ok = op.solve(prob, "visgraph").success
s = kernel.crossings.stats
print(json.dumps({"file": op.__file__, "ok": ok, "crossings": [sum(s.cache_hits.values()),
                  sum(s.cache_misses.values())],
                  "warnings": [[w.category.__name__, str(w.message)] for w in caught]}))
"""


def test_no_writable_cache_compiles_in_memory_with_one_warning(tmp_path: Path) -> None:
    """A read-only package, a home whose cache directory cannot be made and no
    ``NUMBA_CACHE_DIR``: numba has no cache locator (it used to make ``import optplan`` fail:
    "cannot cache function ...: no locator available"); the kernels compile in memory, with
    one warning naming the directories tried and ``NUMBA_CACHE_DIR``, and nothing is
    written."""
    site, home = tmp_path / "site", tmp_path / "home"
    pkg = _read_only_copy(site)
    home.mkdir()
    (home / ".cache").write_text("a file: ~/.cache/numba cannot be made (even by root)\n")
    home.chmod(0o555)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("NUMBA_") and k not in ("XDG_CACHE_HOME", "PYTHONWARNINGS")}
    env.update(PYTHONPATH=str(site), HOME=str(home), PYTHONDONTWRITEBYTECODE="1")
    try:
        p = subprocess.run([sys.executable, "-c", NO_CACHE_CHILD], env=env, capture_output=True,
                           text=True, cwd=site)
    finally:
        home.chmod(0o755)
        for q in [pkg, *pkg.rglob("*")]:
            q.chmod(q.stat().st_mode | stat.S_IWUSR)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert Path(out["file"]).is_relative_to(site), out["file"]
    assert out["ok"] and out["crossings"] == [0, 1], out  # compiled (in memory)
    assert len(out["warnings"]) == 1, out["warnings"]
    (cat, msg), = out["warnings"]
    assert cat == "NoKernelCacheWarning", out["warnings"]
    for name in ("NUMBA_CACHE_DIR", str(home / ".cache" / "numba"),
                 str(pkg / "geometry"), "__pycache__"):  # beside the first kernel compiled
        assert name in msg, msg
    assert sorted(q.name for q in home.iterdir()) == [".cache"]
    assert not any((d / "__pycache__").is_dir() for d in [pkg, *pkg.rglob("*")] if d.is_dir())


def test_shipped_cache_build_refuses_the_host_cpu(tmp_path: Path) -> None:
    """Machine code for this CPU could not be shipped: build() runs only with the generic
    CPU (build_in_child starts such a process)."""
    import pytest

    from optplan.geometry.compiled import kernel_cache

    with pytest.raises(RuntimeError, match="generic CPU"):
        kernel_cache.build(tmp_path / "k")
    assert not (tmp_path / "k").exists()


def test_kernel_modules_lists_every_compiled_kernel() -> None:
    """The shipped cache compiles the kernels of KERNEL_MODULES: every module of the package
    that declares a kernel is listed (source scan, and numba's registry after importing)."""
    import re

    from optplan.geometry.compiled import kernel_cache

    declared = {
        ".".join(("optplan", *p.relative_to(PKG).with_suffix("").parts))
        for p in PKG.rglob("*.py")
        if re.search(r"^@(compiled|leaf)\(", p.read_text(), re.MULTILINE)}
    assert declared and declared <= set(kernel_cache.KERNEL_MODULES)
    for name in kernel_cache.KERNEL_MODULES:
        __import__(name)
    ours = {d.py_func.__module__ for d in kernel_cache.REGISTRY
            if d.py_func.__module__.startswith("optplan.")}  # not the tests' own kernels
    assert ours == set(kernel_cache.KERNEL_MODULES)


LOCK_CHILD = """
import json, sys, time
from pathlib import Path
import numpy as np
from optplan.geometry.compiled import jit
Path(sys.argv[2]).touch()  # ready: imported, nothing compiled yet
while not Path(sys.argv[1]).exists():
    time.sleep(0.005)
jit.argsort_stable(np.array([2.0, 1.0, 3.0]))
s = jit.argsort_stable.stats
print(json.dumps([sum(s.cache_hits.values()), sum(s.cache_misses.values())]))
"""


def test_processes_started_together_compile_a_kernel_once(tmp_path: Path) -> None:
    """Two processes on one empty cache call the same kernel at the same moment: one compiles
    it while holding the entry's lock, the other waits and loads it (without the lock both
    compiled it, as pytest-xdist workers and a sweep's workers did)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "cache")
    go = tmp_path / "go"
    procs = [subprocess.Popen([sys.executable, "-c", LOCK_CHILD, str(go), str(tmp_path / f"r{i}")],
                              cwd=PKG.parent, env=env, stdout=subprocess.PIPE, text=True)
             for i in range(2)]
    while not all((tmp_path / f"r{i}").exists() for i in range(2)):
        assert all(p.poll() is None for p in procs), [p.communicate() for p in procs]
        time.sleep(0.01)
    go.touch()
    got = [json.loads(p.communicate()[0].strip().splitlines()[-1]) for p in procs]
    assert all(p.returncode == 0 for p in procs)
    assert sorted(got) == [[0, 1], [1, 0]], got  # one compiled, the other loaded


def test_the_install_step_compiles_so_that_the_first_solve_loads(tmp_path: Path) -> None:
    """``make``'s install step (``compile_all``) in one process on an empty cache: a later
    process's first solve loads every kernel of the module from it and compiles none."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(PKG.parent))
    step = ("from optplan.geometry.compiled.kernel_cache import compile_all; "
            "print(compile_all(['optplan.geometry.collision.kernel']))")
    p = subprocess.run([sys.executable, "-c", step], env=env, capture_output=True, text=True,
                       cwd=PKG.parent, check=True)
    assert int(p.stdout.split()[-1]) >= 1
    p = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True,
                       cwd=PKG.parent, check=True)
    stats = json.loads(p.stdout.strip().splitlines()[-1])["stats"]
    used = {n: s for n, s in stats.items() if s[0] or s[1]}
    assert used and all(misses == 0 for _, misses in used.values()), stats
