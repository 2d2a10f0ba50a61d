"""MkDocs hook: a block marked ``<!-- file: NAME -->`` shows ``NAME`` as its title.

The doc test (``tests/tools/test_docs.py``) writes such a block to the file ``NAME`` before the
page runs, and a later block reads it; the comment itself does not render, so the reader needs
the name on the page.  The hook adds ``title="NAME"`` to the block's opening fence
(``pymdownx.highlight`` renders it above the code, as the theme shows file names).
"""

from __future__ import annotations

import re

_FILE_BLOCK = re.compile(
    r"^(?P<mark>[ ]*<!--\s*file:\s*(?P<name>[\w./-]+)\s*-->[ ]*\n(?:[ ]*\n)*)"
    r"(?P<fence>[ ]*`{3,}[\w-]*)(?P<rest>[^\n]*)$", re.M)


def with_file_titles(markdown: str) -> str:
    """``markdown`` with ``title="NAME"`` on the opening fence of every ``file:`` block (a
    fence that already has a title keeps it).

    >>> with_file_titles('<!-- file: a/b.toml -->\\n```toml\\nx = 1\\n```\\n')
    '<!-- file: a/b.toml -->\\n```toml title="a/b.toml"\\nx = 1\\n```\\n'
    """
    def title(m: re.Match[str]) -> str:
        if "title=" in m["rest"]:
            return m[0]
        return f'{m["mark"]}{m["fence"]} title="{m["name"]}"{m["rest"]}'

    return _FILE_BLOCK.sub(title, markdown)


def on_page_markdown(markdown: str, **kwargs: object) -> str:
    return with_file_titles(markdown)
