"""The quick figure scripts of ``docs/figures`` run and write their PNGs (into a temporary
folder): a script that falls behind the API it draws fails here, not when the docs are
refreshed.  The slow ones (time limits of seconds, many solves) are left to their pages."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

FIGURES = Path(__file__).resolve().parents[2] / "docs" / "figures"


@pytest.mark.parametrize("script, pngs", [
    ("visgraph.py", ["visgraph-paper-env.png", "visgraph-chains.png"]),
    ("geometry.py", ["geometry-solids.png"]),
    ("ccbs_swap.py", ["ccbs-swap.png"]),
])
def test_figure_script_writes_its_pngs(script: str, pngs: list[str], tmp_path: Path) -> None:
    out = subprocess.run([sys.executable, str(FIGURES / script), "--out", str(tmp_path)],
                         capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stderr
    for name in pngs:
        png = tmp_path / name
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"wrote {png}" in out.stdout
