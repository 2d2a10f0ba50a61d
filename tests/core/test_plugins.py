"""A third-party backend installed as a plugin distribution works in the Python API, the CLI and
bench worker processes (entry-point groups ``optplan.backends`` and ``optplan.presets``)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def page_file(name: str) -> str:
    """The block of docs/adding-a-solver.md marked ``<!-- file: NAME -->`` (the walk-through)."""
    text = (ROOT / "docs" / "adding-a-solver.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- file: " + re.escape(name) + r" -->\n```\w*\n(.*?)```", text, re.S)
    assert m, f"docs/adding-a-solver.md has no block for {name}"
    return m.group(1)


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory) -> Path:
    """A tiny installed distribution: a package plus its ``.dist-info`` with entry points."""
    root = tmp_path_factory.mktemp("plugin")
    pkg = root / "toyplug"
    (pkg / "presets").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "planner.py").write_text(page_file("toyplug/planner.py"))
    (pkg / "presets" / "__init__.py").write_text("")
    (pkg / "presets" / "line-five.toml").write_text(page_file("toyplug/presets/line-five.toml"))
    info = root / "toyplug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toyplug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent("""\
        [optplan.backends]
        line = toyplug.planner:Line

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
        assert "line" in op.list_backends(), op.list_backends()
        assert "line-five" in op.list_solvers()
        r = op.solve("open-field", "line")
        print(r.status, len(r.path))
        r = op.solve("open-field", "line-five")
        print(r.status, len(r.path), r.solver)
        try:
            op.solve("open-field", "line", n=1)
        except ValueError as e:
            print("error:", e)
    """)
    out = _run(plugin_path, "-c", code)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "solved 2"
    assert lines[1] == "solved 5 line-five"
    assert "option 'n' of backend 'line'" in lines[2]


def test_plugin_in_the_cli_and_in_bench_workers(plugin_path: Path) -> None:
    out = _run(plugin_path, "-m", "optplan", "solve", "open-field", "line-five")
    assert out.returncode == 0, out.stderr
    assert "solved" in out.stdout
    out = _run(plugin_path, "-m", "optplan", "list", "solvers")
    assert out.returncode == 0 and "line-five" in out.stdout
    out = _run(plugin_path, "-m", "optplan", "show-solver", "line-five")
    assert out.returncode == 0, out.stderr
    assert "an integer in [2, 1000]" in out.stdout and "Number of path points" in out.stdout
    out = _run(plugin_path, "-m", "optplan", "bench", "--problems", "open-field", "--solvers",
               "line,line-five", "--seeds", "2", "--workers", "2")
    assert out.returncode == 0, out.stderr
    assert "error" not in out.stdout.lower(), out.stdout
    assert out.stdout.count("line") >= 2
