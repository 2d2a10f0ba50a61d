"""Fuzz optplan's input validation (issue 14): the full run, ``python benchmarks/fuzz_inputs.py``.

A thin entry point: the harness is the package :mod:`benchmarks.fuzz` (one module per input
surface, its docstring describes the families and the outcome categories);
``--workers N``, ``--seed S``, ``--quick``, ``--family F``, ``--json FILE``.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository
    from benchmarks.fuzz import main

    sys.exit(main())
