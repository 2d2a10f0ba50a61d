"""Moved to :mod:`optplan.experiments.maps_scenes` (``python -m optplan.experiments.maps_scenes``).

Kept as a thin alias so that code loading this file by path keeps working; it writes nothing
unless run, and then runs the module's ``main`` (default output ``runs/maps``).
"""

from __future__ import annotations

from optplan.experiments.maps_scenes import *  # noqa: F403
from optplan.experiments.maps_scenes import build_scenes, main  # noqa: F401

if __name__ == "__main__":
    main()
