"""What README.md says about the repository cannot go stale.

* its preset table lists exactly the solver presets of ``solvers/*.toml`` (what ``optplan list
  solvers`` prints), each in the row of its backend;
* its Layout lists exactly the top-level directories of the repository and the packages of
  ``optplan/``, and every file it names exists;
* its "What ``make demo`` prints" block, and the quick start's, are what ``python -m
  optplan.experiments.demo`` prints, numbers masked (row names, words and line structure must
  match; ``...`` as in every doc block, ``tests/tools/test_docs.py``).  The PNG and the GIF
  are not drawn (they print nothing).

The README's code blocks themselves run in ``tests/tools/test_docs.py``, like every page's.
"""

from __future__ import annotations

import contextlib
import doctest
import io
import re
import shutil
import subprocess
import tomllib
from pathlib import Path

import pytest

import optplan as op
from tests.tools.test_docs import ROOT, blocks

README = (ROOT / "README.md").read_text(encoding="utf-8")


def section(title: str) -> str:
    """The text of the README's ``## title`` section (up to the next ``## ``)."""
    m = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", README, re.M | re.S)
    assert m, f"README.md has no section '## {title}'"
    return m[1]


def names(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def test_the_preset_table_is_the_registry() -> None:
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in section("Solvers").splitlines() if line.startswith("| `")]
    listed = {p: names(r[0]) for r in rows for p in names(r[1])}
    assert sum(len(names(r[1])) for r in rows) == len(listed), "a preset listed twice"
    files = {f.stem: tomllib.loads(f.read_text(encoding="utf-8"))["backend"]
             for f in (ROOT / "solvers").glob("*.toml")}
    assert sorted(listed) == sorted(files), (
        f"README.md's preset table: missing {sorted(set(files) - set(listed))}, "
        f"not presets {sorted(set(listed) - set(files))}")
    wrong = {p: (b, listed[p]) for p, b in files.items() if b not in listed[p]}
    assert not wrong, f"presets in the row of another backend (backend, row): {wrong}"
    assert set(op.list_solvers()) <= set(listed)  # what `optplan list solvers` prints


def _layout() -> list[str]:
    (code,) = [b["code"] for b in blocks(section("Layout")) if b["lang"] == "text"]
    return code.splitlines()


def _tracked_top_level() -> set[str]:
    """Top-level entries of the repository: git's tracked files when this is a checkout."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    return {f.split("/")[0] + ("/" if "/" in f else "") for f in out}


def test_the_layout_is_the_repository() -> None:
    lines = _layout()
    top = [ln.split()[0] for ln in lines if ln[:1].strip()]
    dirs = {t for t in top if t.endswith("/")}
    tracked = _tracked_top_level()
    real_dirs = {t for t in tracked if t.endswith("/")}
    assert dirs == real_dirs, (f"README.md's Layout: directories missing "
                               f"{sorted(real_dirs - dirs)}, not in the repository "
                               f"{sorted(dirs - tracked)}")
    assert all((ROOT / t).is_file() for t in top if not t.endswith("/")), top
    # the packages of optplan/, indented under it, are the package's subpackages
    pkgs = {ln.split()[0].rstrip("/") for ln in lines if re.match(r"^  \S+/", ln)}
    real = {p.parent.name for p in (ROOT / "optplan").glob("*/__init__.py")}
    assert pkgs == real, (f"README.md's Layout: packages missing {sorted(real - pkgs)}, "
                          f"not in optplan/ {sorted(pkgs - real)}")
    # modules named in it exist
    for mod in re.findall(r"\((\w+\.py)\)", "\n".join(lines)):
        assert (ROOT / "optplan" / mod).is_file(), mod


def _mask(text: str) -> str:
    return re.sub(r"\d+(?:\.\d+)?", "N", text)


#: the pages that quote the demo's output: README.md and the quick start
DEMO_PAGES = ("README.md", "docs/quickstart.md")


def test_the_demo_output_is_what_the_demo_prints(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    import optplan.plot
    from optplan.experiments import demo

    quoted = {name: [b["code"] for b in blocks((ROOT / name).read_text(encoding="utf-8"))
                     if b["lang"] == "text" and "solving with hybrid-paper" in b["code"]]
              for name in DEMO_PAGES}
    assert all(len(q) == 1 for q in quoted.values()), {k: len(q) for k, q in quoted.items()}
    assert [b["code"] for b in blocks(section("What `make demo` prints"))
            if b["lang"] == "text"] == quoted["README.md"]
    # the figures print nothing; skipping them keeps this test to the solve
    monkeypatch.setattr(optplan.plot, "plot_result", lambda *a, **k: None)
    monkeypatch.setattr(optplan.plot, "animate", lambda *a, **k: None)
    monkeypatch.chdir(tmp_path)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = demo.main([])  # what `make demo` runs
    got = buf.getvalue()
    assert rc == 0, got
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    for name, (want,) in quoted.items():
        assert doctest.OutputChecker().check_output(_mask(want), _mask(got), flags), (
            f"{name}: the output of `make demo` it quotes is not what the demo prints:\n{got}")
