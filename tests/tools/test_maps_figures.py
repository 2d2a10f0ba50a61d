"""The maps page's figure script: its ROS map is deterministic and is cropped on import."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from optplan.maps import ReadOptions, Robots, import_map

#: the figure scripts' folder: docs/figures/maps.py (outside the package) is loaded from its file
_FIGURES = Path(__file__).resolve().parents[2] / "docs" / "figures"
_SPEC = importlib.util.spec_from_file_location("docs_figures_maps", _FIGURES / "maps.py")
assert _SPEC is not None and _SPEC.loader is not None
maps_figures = importlib.util.module_from_spec(_SPEC)
# the script imports figure_io from beside it (its folder is sys.path[0] when it is run)
sys.path.insert(0, str(_FIGURES))
try:
    _SPEC.loader.exec_module(maps_figures)
finally:
    sys.path.remove(str(_FIGURES))


def test_the_office_map_is_the_same_bytes_and_is_cropped_to_the_office(tmp_path: Path) -> None:
    a = maps_figures.write_office_map(tmp_path / "a")
    b = maps_figures.write_office_map(tmp_path / "b")
    for name in ("office.yaml", "office.pgm"):
        assert (a.parent / name).read_bytes() == (b.parent / name).read_bytes()
    info: dict = {}
    robots = Robots(start=maps_figures.START, goal=maps_figures.GOAL, radius=maps_figures.RADIUS)
    prob = import_map(a, robots, info=info)
    assert prob.name == "office"
    assert info["crop"]["cropped"] and info["crop"]["margin"] > 0.25
    # the office's outer wall, 6.2 x 9.2 m, is the new extent; the image was 20 x 16 m
    assert prob.bounds == pytest.approx((-4.5, -3.2, 4.7, 3.0), abs=0.051)
    whole = import_map(a, robots, read=ReadOptions(crop=False))
    assert whole.bounds == pytest.approx((-10.0, -8.0, 10.0, 8.0))


@pytest.mark.slow
def test_the_figure_script_writes_the_png_and_the_outcomes(tmp_path: Path, capsys) -> None:
    assert maps_figures.main(["--out", str(tmp_path), "--seeds", "1"]) == 0
    assert (tmp_path / "maps-ros-cropped.png").stat().st_size > 10_000
    assert not (tmp_path / "office.yaml").exists()  # the map went to a temporary directory
    out = capsys.readouterr().out
    assert out.startswith("visgraph   optimal")
    assert "| visgraph | 1/1 | 1.0000 | 1.0000 | optimal 1 |" in out
