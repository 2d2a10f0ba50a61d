"""What the figure scripts of ``docs/figures`` share: the command line and the saving.

A script run as ``python docs/figures/<name>.py`` finds this module beside it (its folder is
the first entry of ``sys.path``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

__all__ = ["parser", "save"]


def parser(prog: str, doc: str, default_out: Path, dpi: float | None = None
           ) -> argparse.ArgumentParser:
    """The parser of a figure script: ``--out`` (the output folder, never the docs unless
    asked) and, when ``dpi`` is given, ``--dpi`` with that default; the script adds its own
    options."""
    ap = argparse.ArgumentParser(prog=prog, description=doc,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=default_out,
                    help=f"output folder (default {default_out})")
    if dpi is not None:
        ap.add_argument("--dpi", type=float, default=dpi,
                        help=f"PNG resolution (default {dpi:g})")
    return ap


def save(fig: Any, out: Path, dpi: float) -> Path:
    """Write ``fig`` to ``out`` (its folder made), close it if pyplot holds it, and say so."""
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close(fig)
    print(f"wrote {out}")
    return out
