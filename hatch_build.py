"""Wheel build hook: ship the compiled numba kernels inside the wheel.

A wheel (not an editable install, not an sdist) gets ``optplan/_kernels/``: every kernel of
the package compiled for the generic CPU of the build's platform
(:mod:`optplan.geometry.compiled.kernel_cache`), so that the first solve after ``pip install`` loads
machine code instead of compiling it (they compile once, here, when the wheel is built).
The wheel is then tagged for this Python and platform (``cp311-cp311-linux_x86_64``).
``OPTPLAN_SHIP_KERNELS=0`` builds a pure-Python wheel without them (the kernels then compile
on first use, as from a checkout);
``OPTPLAN_SHIP_KERNELS=module,module`` ships the kernels of those modules only (the tests use
it to keep the wheel's build short).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from typing import Any

from hatchling.builders.hooks.plugin.interface import BuildHookInterface

CHILD = ("import sys; "
         "from optplan.geometry.compiled.kernel_cache import KERNEL_MODULES, build_in_child; "
         "build_in_child(sys.argv[1], sys.argv[2:] or KERNEL_MODULES)")


class CustomBuildHook(BuildHookInterface):
    """Compile the kernels into a temporary directory and force-include it as
    ``optplan/_kernels``."""

    PLUGIN_NAME = "custom"
    _tmp: str | None = None

    def initialize(self, version: str, build_data: dict[str, Any]) -> None:
        if self.target_name != "wheel" or version == "editable":
            return
        ship = os.environ.get("OPTPLAN_SHIP_KERNELS", "1").strip()
        if ship == "0":
            return
        modules = [] if ship == "1" else [m.strip() for m in ship.split(",") if m.strip()]
        self._tmp = tempfile.mkdtemp(prefix="optplan-kernels-")
        # the package from this source tree (the current directory of `python -c`)
        subprocess.run([sys.executable, "-c", CHILD, self._tmp, *modules], cwd=self.root,
                       check=True)
        build_data["force_include"][self._tmp] = "optplan/_kernels"
        build_data["pure_python"] = False
        build_data["infer_tag"] = True

    def finalize(self, version: str, build_data: dict[str, Any], artifact_path: str) -> None:
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
