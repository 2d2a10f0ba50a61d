"""A third-party backend installed as a plugin distribution works in the Python API, the CLI and
bench worker processes (entry-point groups ``optplan.backends`` and ``optplan.presets``)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

PLANNER = '''
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.result import Status
from optplan.solver import Backend, check_int


@dataclass(frozen=True, kw_only=True)
class Toy(Backend):
    """Straight line with ``n`` points (a plugin example)."""

    name: ClassVar[str] = "toy"
    n: int = 2

    def __post_init__(self):
        check_int(self, "n", 2, 1000)

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        paths = {r.id: np.linspace(r.start, r.goal, self.n) for r in problem.planned_robots}
        return self.finish(problem, paths, claim=Status.solved, message="toy straight line")
'''


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory) -> Path:
    """A tiny installed distribution: a package plus its ``.dist-info`` with entry points."""
    root = tmp_path_factory.mktemp("plugin")
    pkg = root / "toyplug"
    (pkg / "presets").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "planner.py").write_text(PLANNER)
    (pkg / "presets" / "__init__.py").write_text("")
    (pkg / "presets" / "toy-five.toml").write_text(
        'backend = "toy"\nsummary = "straight line, five points (plugin preset)"\n'
        "[options]\nn = 5\n")
    info = root / "toyplug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toyplug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent("""\
        [optplan.backends]
        toy = toyplug.planner:Toy

        [optplan.presets]
        toyplug = toyplug.presets
        """))
    return root


def _run(plugin_path: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(plugin_path), *[p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                             if p]])}
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                          timeout=300, cwd=str(plugin_path))


def test_plugin_backend_and_preset_in_the_api(plugin_path: Path) -> None:
    code = textwrap.dedent("""
        import optplan as op
        assert "toy" in op.list_backends(), op.list_backends()
        assert "toy-five" in op.list_solvers()
        r = op.solve("open-field", "toy")
        print(r.status, len(r.path))
        r = op.solve("open-field", "toy-five")
        print(r.status, len(r.path), r.solver)
        try:
            op.solve("open-field", "toy", n=1)
        except ValueError as e:
            print("error:", e)
    """)
    out = _run(plugin_path, "-c", code)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "solved 2"
    assert lines[1] == "solved 5 toy-five"
    assert "option 'n' of backend 'toy'" in lines[2]


def test_plugin_in_the_cli_and_in_bench_workers(plugin_path: Path) -> None:
    out = _run(plugin_path, "-m", "optplan", "solve", "open-field", "toy-five")
    assert out.returncode == 0, out.stderr
    assert "solved" in out.stdout
    out = _run(plugin_path, "-m", "optplan", "list", "solvers")
    assert out.returncode == 0 and "toy-five" in out.stdout
    out = _run(plugin_path, "-m", "optplan", "bench", "--problems", "open-field", "--solvers",
               "toy,toy-five", "--seeds", "2", "--workers", "2")
    assert out.returncode == 0, out.stderr
    assert "error" not in out.stdout.lower(), out.stdout
    assert out.stdout.count("toy") >= 2
