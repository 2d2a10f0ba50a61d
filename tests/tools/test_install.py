"""Both install modes load the whole catalogue.

* non-editable: build the wheel, unpack it with ``pip install --no-deps --target`` and import
  it from a directory outside the repository; the wheel must ship ``problems/`` and
  ``solvers/`` (hatch ``force-include`` into ``optplan/_data``) and its compiled kernels
  (``optplan/_kernels``, the build hook ``hatch_build.py``; here those of
  ``optplan.geometry.compiled.jit`` only, to keep the build short), loaded without compiling in a
  fresh process with an empty numba cache (and, with one warning, where no numba cache
  directory is writable), and missed (compiled) once a kernel module is edited;
* editable (the test run itself): ``optplan`` is imported from this checkout.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import optplan as op

REPO = Path(__file__).resolve().parents[2]

CHECK = r"""
import json, sys
import optplan as op
heavy = sorted(m for m in ("casadi", "cvxpy", "matplotlib", "clarabel") if m in sys.modules)
from optplan.catalog import catalog_dir
probs = op.list_problems()
solvers = op.list_solvers()
if sys.argv[1:] != ["kernel-only"]:
    for name in probs:
        op.load_problem(name)
    for name in solvers:
        op.get_solver(name)
import numpy as np
from optplan.geometry.compiled import jit
order = jit.argsort_stable(np.array([3.0, 1.0, 2.0, 1.0, np.nan, 0.5])).tolist()
st = jit.argsort_stable.stats
print(json.dumps({"file": op.__file__, "problems": probs, "solvers": solvers, "heavy": heavy,
                  "catalog": str(catalog_dir("problems")), "version": op.__version__,
                  "order": order, "hit_miss": [sum(st.cache_hits.values()),
                                               sum(st.cache_misses.values())]}))
"""


def _pip(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None) -> None:
    subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", *args],
                   check=True, cwd=cwd, capture_output=True, text=True, env=env)


def test_wheel_install_loads_every_catalogue_name(tmp_path: Path) -> None:
    wheels, target, elsewhere = tmp_path / "wheels", tmp_path / "site", tmp_path / "cwd"
    elsewhere.mkdir()
    # the dev venv has hatchling: build without isolation (no download); a fresh venv may not
    isolation = [] if importlib.util.find_spec("hatchling") is None else ["--no-build-isolation"]
    _pip("wheel", "--no-deps", *isolation, "-w", str(wheels), str(REPO),
         env=dict(os.environ, OPTPLAN_SHIP_KERNELS="optplan.geometry.compiled.jit"))
    (wheel,) = wheels.glob("optplan-*.whl")
    assert not wheel.name.endswith("-py3-none-any.whl"), wheel.name  # it holds machine code
    _pip("install", "--no-deps", "--no-compile", "--target", str(target), str(wheel))
    shipped = sorted(p.name.split("-")[0] for p in (target / "optplan" / "_kernels").rglob("*.nbi"))
    assert shipped == ["jit.argsort_stable", "jit.heap_pop", "jit.heap_push"]

    def check(cache: str | None, *args: str, home: Path | None = None) -> dict:
        env = {k: v for k, v in os.environ.items()
               if k not in ("OPTPLAN_CATALOG", "PYTHONPATH", "XDG_CACHE_HOME", "PYTHONWARNINGS")
               and not k.startswith("NUMBA_")}
        env.update(PYTHONPATH=str(target), PYTHONDONTWRITEBYTECODE="1")
        env.update({"NUMBA_CACHE_DIR": str(tmp_path / cache)} if cache else {})
        env.update({"HOME": str(home)} if home else {})
        out = subprocess.run([sys.executable, "-c", CHECK, *args], cwd=elsewhere, env=env,
                             check=True, capture_output=True, text=True)
        return {**json.loads(out.stdout.strip().splitlines()[-1]), "stderr": out.stderr}

    info = check("empty")
    # the shipped kernel is loaded, not compiled (numba's own cache is empty), same answer
    assert info["hit_miss"] == [1, 0] and info["order"] == [5, 1, 3, 2, 0, 4], info
    assert not any((tmp_path / "empty").rglob("jit.argsort_stable-*.nbi"))
    assert Path(info["file"]).resolve().is_relative_to(target.resolve()), info["file"]
    assert Path(info["catalog"]).resolve() == (target / "optplan" / "_data" / "problems").resolve()
    assert info["problems"] == sorted(p.stem for p in (REPO / "problems").glob("*.toml"))
    assert info["solvers"] == op.list_solvers()
    assert info["version"] == op.__version__
    assert info["heavy"] == [], f"`import optplan` imports heavy modules: {info['heavy']}"
    # no writable numba cache anywhere (NUMBA_CACHE_DIR unset, an installation that cannot
    # hold a __pycache__, a home whose ~/.cache cannot be made): import and the shipped kernel
    # still work, with one warning (numba used to fail at import: "no locator available")
    for d in [target / "optplan", *(target / "optplan").rglob("*")]:
        if d.is_dir() and d.name != "__pycache__":
            (d / "__pycache__").write_text("not a directory\n")
    home = tmp_path / "home"
    home.mkdir()
    (home / ".cache").write_text("not a directory\n")
    ro = check(None, "kernel-only", home=home)
    assert ro["hit_miss"] == [1, 0] and ro["order"] == [5, 1, 3, 2, 0, 4], ro
    assert ro["stderr"].count("NoKernelCacheWarning") == 1, ro["stderr"]
    assert "NUMBA_CACHE_DIR" in ro["stderr"] and "the wheel ships" in ro["stderr"], ro["stderr"]
    # a kernel module edited after the build (not even the called kernel's own module: a
    # kernel's machine code includes the kernels it calls) misses every shipped entry
    with (target / "optplan" / "geometry" / "collision" / "kernel.py").open("a") as f:
        f.write("\n# edited after the wheel was built\n")
    stale = check("empty2", "kernel-only")
    assert stale["hit_miss"] == [0, 1] and stale["order"] == [5, 1, 3, 2, 0, 4], stale
    assert any((tmp_path / "empty2").rglob("jit.argsort_stable-*.nbi"))


def test_editable_install_uses_this_checkout() -> None:
    assert Path(op.__file__).resolve().parent == REPO / "optplan"
    from optplan.catalog import catalog_dir

    assert catalog_dir("problems") == REPO / "problems"
    assert catalog_dir("solvers") == REPO / "solvers"
    names = op.list_problems()
    assert names == sorted(p.stem for p in (REPO / "problems").glob("*.toml"))
    for name in names:
        assert op.load_problem(name).name == name
    presets = sorted(p.stem for p in (REPO / "solvers").glob("*.toml"))
    assert set(op.list_solvers()) <= set(presets)
    for name in op.list_solvers():
        assert op.get_solver(name).preset == name


def test_console_script_is_declared() -> None:
    import tomllib

    meta = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert meta["project"]["scripts"]["optplan"] == "optplan.cli:main"
    assert importlib.util.find_spec("optplan.cli") is not None
