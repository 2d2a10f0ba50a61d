"""MkDocs hook: replace ``<!-- paper-table: PRESET -->`` with the preset-vs-paper table and
``<!-- options-table: PRESET [PRESET ...] -->`` with the presets' options table.

The table is generated from ``solvers/PRESET.toml`` (its ``[options]``, ``[paper]`` and
``[paper_notes]`` tables) by :func:`optplan.doc_tables.paper_table`, so it is always the values the
solver really uses; the options table by :func:`optplan.doc_tables.options_table` from the
declared options and the backends' docstrings.
"""

from __future__ import annotations

import re

from optplan.doc_tables import options_table, paper_table

_MARK = re.compile(r"<!--\s*paper-table:\s*([\w.-]+)\s*-->")
_OPTIONS = re.compile(r"<!--\s*options-table:\s*([\w.\s-]+?)\s*-->")


def on_page_markdown(markdown: str, **kwargs) -> str:
    markdown = _OPTIONS.sub(lambda m: options_table(m[1].split()), markdown)
    return _MARK.sub(lambda m: paper_table(m[1]), markdown)
