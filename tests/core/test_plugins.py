"""A third-party backend installed as a plugin distribution works in the Python API, the CLI and
bench worker processes (entry-point groups ``optplan.backends`` and ``optplan.presets``)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests import helpers

ROOT = Path(__file__).resolve().parents[2]


def page_file(name: str) -> str:
    """The block of docs/adding-a-solver.md marked ``<!-- file: NAME -->`` (the walk-through)."""
    text = (ROOT / "docs" / "adding-a-solver.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- file: " + re.escape(name) + r" -->\n```\w*\n(.*?)```", text, re.S)
    assert m, f"docs/adding-a-solver.md has no block for {name}"
    return m.group(1)


def make_dist(root: Path, name: str, files: dict[str, str], entry_points: str) -> None:
    """Install (by path) a distribution ``name``: its ``files`` and a ``.dist-info`` with
    ``entry_points``."""
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    info = root / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent(entry_points))


def toyplug(root: Path) -> None:
    """The plugin of docs/adding-a-solver.md, laid out as the page shows: ``toyplug`` and its
    ``presets`` folder are namespace packages (no ``__init__.py``)."""
    make_dist(root, "toyplug", {
        "toyplug/planner.py": page_file("runs/toyplug/toyplug/planner.py"),
        "toyplug/presets/line-five.toml": page_file("runs/toyplug/toyplug/presets/line-five.toml"),
    }, """\
        [optplan.backends]
        line = toyplug.planner:Line

        [optplan.presets]
        toyplug = toyplug.presets
        """)


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory) -> Path:
    """The toy plugin alone (:func:`toyplug`)."""
    root = tmp_path_factory.mktemp("plugin")
    toyplug(root)
    assert not list(root.rglob("__init__.py"))
    return root


def _run(plugin_path: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(plugin_path), *[p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                             if p]])}
    return helpers.run([sys.executable, *args], capture_output=True, text=True, env=env,
                       cwd=str(plugin_path))


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


@pytest.fixture(scope="module")
def broken_path(tmp_path_factory) -> Path:
    """Beside the working toy plugin: a distribution whose package raises when imported (its
    backend and its presets are lost), one whose backend module raises when imported, and one
    with malformed entry points."""
    root = tmp_path_factory.mktemp("broken")
    toyplug(root)
    make_dist(root, "boomplug", {
        "boomplug/__init__.py": "raise RuntimeError('boom in the package')\n",
        "boomplug/planner.py": "",
        "boomplug/presets/boom-fast.toml": 'backend = "boom"\n',
    }, """\
        [optplan.backends]
        boom = boomplug.planner:Boom

        [optplan.presets]
        boomplug = boomplug.presets
        """)
    make_dist(root, "modplug", {
        "modplug/__init__.py": "",
        "modplug/planner.py": "raise RuntimeError('boom in the planner')\n",
    }, """\
        [optplan.backends]
        kaboom = modplug.planner:Kaboom
        """)
    make_dist(root, "badplug", {"badplug/__init__.py": ""}, """\
        [optplan.backends]
        nocolon = badplug.planner
        twocolons = badplug.planner:A:B

        [optplan.presets]
        badplug = badplug/presets
        """)
    return root


def test_a_broken_plugin_is_reported_once_and_breaks_nothing(broken_path: Path) -> None:
    code = textwrap.dedent("""
        import warnings
        import optplan as op
        from optplan.catalog import PluginWarning
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            print(op.solve("open-field", "visgraph").status.value)
            print(op.solve("open-field", "line-five").status.value)
            print("line-five" in op.list_solvers(), "line" in op.list_backends())
            op.list_solvers()
            for name in ("kaboom", "boom", "boom-fast", "nocolon", "twocolons"):
                try:
                    op.solve("open-field", name)
                except (ImportError, ValueError) as e:
                    print("error:", e)
        for w in caught:
            assert w.category is PluginWarning, w
            print("warning:", w.message)
    """)
    out = _run(broken_path, "-c", code)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[:3] == ["optimal", "solved", "True True"]
    errors = [ln for ln in lines if ln.startswith("error:")]
    assert errors[0] == ("error: plugin distribution 'modplug' (entry point kaboom = "
                         "modplug.planner:Kaboom in optplan.backends): importing it raised "
                         "RuntimeError: boom in the planner")
    assert errors[1] == ("error: plugin distribution 'boomplug' (entry point boom = "
                         "boomplug.planner:Boom in optplan.backends): importing it raised "
                         "RuntimeError: boom in the package")
    assert errors[2].startswith("error: unknown solver 'boom-fast'")  # its presets are lost
    assert errors[3] == ("error: plugin distribution 'badplug' (entry point nocolon = "
                         "badplug.planner in optplan.backends) ignored: expected "
                         "'package.module:Class', got 'badplug.planner'")
    assert "'badplug.planner:A:B'" in errors[4] and "too many values" not in errors[4]
    warned = [ln for ln in lines if ln.startswith("warning:")]
    # each problem once; the working plugin is not mentioned
    assert len(warned) == len(set(warned)) == 6, warned
    assert sum("'boomplug'" in w for w in warned) == 2
    assert any("'boomplug'" in w and "presets skipped: RuntimeError: boom in the package" in w
               for w in warned)
    assert sum("'modplug'" in w for w in warned) == 1
    assert sum("'badplug'" in w for w in warned) == 3
    assert any("'badplug'" in w and "presets skipped: ValueError: expected 'package.folder'" in w
               for w in warned)
    assert not any("toyplug" in w for w in warned)


def test_a_broken_plugin_leaves_the_cli_working(broken_path: Path) -> None:
    out = _run(broken_path, "-m", "optplan", "list", "solvers")
    assert out.returncode == 0, out.stderr
    assert "line-five" in out.stdout and "visgraph" in out.stdout
    warned = [ln for ln in out.stderr.splitlines() if "PluginWarning" in ln]
    assert any("'boomplug'" in w and "boom in the package" in w for w in warned), out.stderr
    assert len(warned) == len(set(warned))
    out = _run(broken_path, "-m", "optplan", "solve", "open-field", "line-five")
    assert out.returncode == 0, out.stderr
    out = _run(broken_path, "-m", "optplan", "solve", "open-field", "kaboom")
    assert out.returncode == 2
    assert out.stderr.startswith("optplan: error: plugin distribution 'modplug'"), out.stderr
    assert "RuntimeError: boom in the planner" in out.stderr


def test_register_rejects_a_malformed_entry_point() -> None:
    import optplan as op

    with pytest.raises(ValueError, match=r"expected 'package.module:Class', got 'a:b:c'"):
        op.register("abc", "a:b:c")


@pytest.fixture(scope="module")
def failing_path(tmp_path_factory) -> Path:
    """Beside the working toy plugin: plugins whose package calls ``sys.exit()`` or whose module
    raises a ``BaseException`` subclass when imported, a missing dependency, module or class,
    entry points naming what is not a ``Backend`` subclass, a preset naming an unknown backend."""
    root = tmp_path_factory.mktemp("failing")
    toyplug(root)
    make_dist(root, "exitplug", {
        "exitplug/__init__.py": "import sys\nsys.exit(3)\n",
        "exitplug/planner.py": "",
        "exitplug/presets/exit-fast.toml": 'backend = "exit"\n',
    }, """\
        [optplan.backends]
        exit = exitplug.planner:Exit

        [optplan.presets]
        exitplug = exitplug.presets
        """)
    make_dist(root, "baseplug", {
        "baseplug/__init__.py": "",
        "baseplug/planner.py": "class Stop(BaseException):\n    pass\n\n\n"
                               "raise Stop('stop in the planner')\n",
    }, "[optplan.backends]\nhalt = baseplug.planner:Halt\n")
    make_dist(root, "depplug", {
        "depplug/__init__.py": "",
        "depplug/planner.py": "import no_such_dependency_xyz\n",
    }, "[optplan.backends]\nneedy = depplug.planner:Needy\n")
    make_dist(root, "ghostplug", {
        "ghostplug/__init__.py": "",
        "ghostplug/planner.py": "import os\n\nX = 1\n\n\nclass Plain:\n    pass\n",
    }, """\
        [optplan.backends]
        ghost = ghostplug.nothere:Ghost
        noclass = ghostplug.planner:Missing
        amodule = ghostplug.planner:os
        aclass = ghostplug.planner:Plain
        anint = ghostplug.planner:X
        """)
    make_dist(root, "presetplug", {"presetplug/presets/nope-fast.toml": 'backend = "nope"\n'},
              "[optplan.presets]\npresetplug = presetplug.presets\n")
    return root


FAILING = {  # name -> (error type, the distribution, what the message says after the entry point)
    "exit": ("ImportError", "exitplug", "importing it raised SystemExit: 3"),
    "halt": ("ImportError", "baseplug", "importing it raised Stop: stop in the planner"),
    "needy": ("ImportError", "depplug", "importing it raised ModuleNotFoundError: No module "
              "named 'no_such_dependency_xyz'"),
    "ghost": ("ImportError", "ghostplug", "importing it raised ModuleNotFoundError: No module "
              "named 'ghostplug.nothere'"),
    "noclass": ("ImportError", "ghostplug", "module 'ghostplug.planner' has no 'Missing'"),
    "amodule": ("ImportError", "ghostplug", "'os' is the module 'os', not a subclass of "
                "optplan.Backend"),
    "aclass": ("ImportError", "ghostplug", "'Plain' is the class 'Plain', not a subclass of "
               "optplan.Backend"),
    "anint": ("ImportError", "ghostplug", "'X' is an object of type 'int', not a subclass of "
              "optplan.Backend"),
    "nope-fast": ("ValueError", "presetplug", "nope-fast.toml: backend: unknown backend 'nope'"),
}


def test_a_plugin_that_exits_or_misses_a_part_is_reported_once_and_breaks_nothing(
        failing_path: Path) -> None:
    code = textwrap.dedent("""
        import json, sys, warnings
        import optplan as op
        from optplan.catalog import PluginWarning
        out = {"errors": {}}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out["visgraph"] = op.solve("open-field", "visgraph").status.value
            out["line-five"] = op.solve("open-field", "line-five").status.value
            out["solvers"] = op.list_solvers(backends=True)
            op.list_solvers(backends=True)
            for name in sys.argv[1:] + sys.argv[1:]:
                try:
                    op.solve("open-field", name)
                except (ImportError, ValueError) as e:
                    out["errors"].setdefault(name, []).append([type(e).__name__, str(e)])
            out["after"] = op.list_solvers(backends=True)
        out["warnings"] = [[w.category.__name__, str(w.message)] for w in caught]
        print(json.dumps(out))
    """)
    out = _run(failing_path, "-c", code, *FAILING, "exit-fast")
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout.splitlines()[-1])
    assert got["visgraph"] == "optimal" and got["line-five"] == "solved"
    assert "line" in got["solvers"] and "line-five" in got["solvers"]
    # found without importing the modules: a package that exits, a missing module or preset
    # backend is not listed; a module that fails when imported is listed until it is used
    assert not set(got["solvers"]) & {"exit", "ghost", "nope-fast", "exit-fast"}
    assert "line" in got["after"] and not set(got["after"]) & {*FAILING, "exit-fast"}
    assert {c for c, _ in got["warnings"]} == {"PluginWarning"}
    warned = [m for _, m in got["warnings"]]
    assert len(warned) == len(set(warned)), warned  # each problem once
    assert not any("toyplug" in w for w in warned)
    for name, (kind, dist, says) in FAILING.items():
        first, again = got["errors"][name]
        assert first == again, (name, first, again)  # the same error every time
        assert first[0] == kind, (name, first)
        assert first[1].startswith(f"plugin distribution {dist!r} (entry point "), first
        assert says in first[1], (name, first)
        assert first[1] in warned, (name, first, warned)  # the warning has the same text
    # the package that exits also loses its presets, reported once
    assert got["errors"]["exit-fast"][0][1].startswith("unknown solver 'exit-fast'")
    assert sum("'exitplug'" in w and "presets skipped: SystemExit: 3" in w for w in warned) == 1
    assert len(warned) == len(FAILING) + 1


def test_a_plugin_that_exits_leaves_the_cli_working(failing_path: Path) -> None:
    out = _run(failing_path, "-m", "optplan", "list", "solvers")
    assert out.returncode == 0, out.stderr
    assert "line-five" in out.stdout and "visgraph" in out.stdout
    assert "optplan: warning: PluginWarning: plugin distribution 'exitplug'" in out.stderr
    assert "presets skipped: SystemExit: 3" in out.stderr
    out = _run(failing_path, "-m", "optplan", "solve", "open-field", "exit")
    assert out.returncode == 2, out.stderr
    assert out.stderr.startswith("optplan: error: plugin distribution 'exitplug' (entry point "
                                 "exit = exitplug.planner:Exit in optplan.backends): importing "
                                 "it raised SystemExit: 3"), out.stderr
    out = _run(failing_path, "-m", "optplan", "solve", "open-field", "nope-fast")
    assert out.returncode == 2, out.stderr
    assert out.stderr.startswith("optplan: error: plugin distribution 'presetplug'"), out.stderr
    assert "nope-fast.toml: backend: unknown backend 'nope'" in out.stderr


def test_a_keyboard_interrupt_in_a_plugin_is_never_swallowed(tmp_path: Path) -> None:
    make_dist(tmp_path, "intplug", {
        "intplug/__init__.py": "raise KeyboardInterrupt\n",
        "intplug/presets/int-fast.toml": 'backend = "visgraph"\n',
    }, "[optplan.presets]\nintplug = intplug.presets\n")
    code = textwrap.dedent("""
        import optplan as op
        for _ in range(2):
            try:
                op.list_solvers()
            except KeyboardInterrupt:
                print("interrupted")
    """)
    out = _run(tmp_path, "-c", code)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["interrupted", "interrupted"]
    assert "PluginWarning" not in out.stderr
    out = _run(tmp_path, "-m", "optplan", "list", "solvers")
    assert out.returncode == 130, out.stderr
    assert "optplan: interrupted" in out.stderr


def test_interrupted_sees_a_keyboard_interrupt_in_a_group() -> None:
    from optplan.catalog import interrupted

    assert interrupted(KeyboardInterrupt())
    assert interrupted(BaseExceptionGroup("g", [ValueError(), KeyboardInterrupt()]))
    assert not interrupted(SystemExit(3))
    assert not interrupted(BaseExceptionGroup("g", [SystemExit(3)]))
    assert not interrupted(RuntimeError("boom"))
