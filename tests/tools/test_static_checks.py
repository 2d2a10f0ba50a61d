"""The type check and the strict docs build, as tests: they run on one pytest-xdist worker
while the other runs tests (``make test`` used to run them one after the other, each on one
core, with the second core idle: about 30 s of a first run's wall time).

Both run the tool in a child process on the checkout, exactly as a developer would type it;
a failure shows the tool's own output.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _run(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", *args], cwd=ROOT, capture_output=True,
                          text=True, env=env)


def test_mypy_finds_no_issue_in_the_package() -> None:
    out = _run("mypy", "optplan")
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.startswith("Success: no issues found"), out.stdout


def test_the_docs_site_builds_strict(tmp_path: Path) -> None:
    """``mkdocs build --strict`` (a broken link, a page missing from the navigation, a bad
    anchor: a warning, so an error), into a temporary directory."""
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    out = _run("mkdocs", "build", "--strict", "--quiet", "-d", str(tmp_path / "site"), env=env)
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / "site" / "index.html").is_file()


def test_the_files_run_first_exist() -> None:
    """``tests/conftest.py``'s list of the longest files names files that exist (a renamed
    file would silently lose its place at the front)."""
    from tests.conftest import FIRST

    assert all((ROOT / f).is_file() for f in FIRST), [f for f in FIRST if not (ROOT / f).is_file()]
