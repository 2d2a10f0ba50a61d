"""MkDocs hook: replace ``<!-- paper-table: PRESET -->`` with the preset-vs-paper table.

The table is generated from ``solvers/PRESET.toml`` (its ``[options]``, ``[paper]`` and
``[paper_notes]`` tables) by :func:`optplan.catalog.paper_table`, so it is always the values the
solver really uses.
"""

from __future__ import annotations

import re

from optplan.catalog import paper_table

_MARK = re.compile(r"<!--\s*paper-table:\s*([\w.-]+)\s*-->")


def on_page_markdown(markdown: str, **kwargs) -> str:
    return _MARK.sub(lambda m: paper_table(m[1]), markdown)
