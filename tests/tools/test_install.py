"""Both install modes load the whole catalogue.

* non-editable: build the wheel, unpack it with ``pip install --no-deps --target`` and import
  it from a directory outside the repository; the wheel must ship ``problems/`` and
  ``solvers/`` (hatch ``force-include`` into ``optplan/_data``);
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
for name in probs:
    op.load_problem(name)
solvers = op.list_solvers()
for name in solvers:
    op.get_solver(name)
print(json.dumps({"file": op.__file__, "problems": probs, "solvers": solvers, "heavy": heavy,
                  "catalog": str(catalog_dir("problems")), "version": op.__version__}))
"""


def _pip(*args: str, cwd: Path | None = None) -> None:
    subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", *args],
                   check=True, cwd=cwd, capture_output=True, text=True)


def test_wheel_install_loads_every_catalogue_name(tmp_path: Path) -> None:
    wheels, target, elsewhere = tmp_path / "wheels", tmp_path / "site", tmp_path / "cwd"
    elsewhere.mkdir()
    # the dev venv has hatchling: build without isolation (no download); a fresh venv may not
    isolation = [] if importlib.util.find_spec("hatchling") is None else ["--no-build-isolation"]
    _pip("wheel", "--no-deps", *isolation, "-w", str(wheels), str(REPO))
    (wheel,) = wheels.glob("optplan-*.whl")
    _pip("install", "--no-deps", "--no-compile", "--target", str(target), str(wheel))
    env = {k: v for k, v in os.environ.items() if k not in ("OPTPLAN_CATALOG", "PYTHONPATH")}
    env["PYTHONPATH"] = str(target)
    out = subprocess.run([sys.executable, "-c", CHECK], cwd=elsewhere, env=env, check=True,
                         capture_output=True, text=True)
    info = json.loads(out.stdout.strip().splitlines()[-1])
    assert Path(info["file"]).resolve().is_relative_to(target.resolve()), info["file"]
    assert Path(info["catalog"]).resolve() == (target / "optplan" / "_data" / "problems").resolve()
    assert info["problems"] == sorted(p.stem for p in (REPO / "problems").glob("*.toml"))
    assert info["solvers"] == op.list_solvers()
    assert info["version"] == op.__version__
    assert info["heavy"] == [], f"`import optplan` imports heavy modules: {info['heavy']}"


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
