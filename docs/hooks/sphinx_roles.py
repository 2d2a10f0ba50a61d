"""MkDocs hook: render Sphinx cross-reference roles left in numpy-style docstrings.

mkdocstrings shows ``:func:`solve``` as the literal text ":func:" before the code span.  This
hook drops the role prefix (``:func:``, ``:class:``, ``:meth:``, ``:mod:``, ``:attr:``,
``:data:``, ``:obj:``, ``:exc:``, with an optional ``py:`` domain) and a leading ``~`` so that
only the code span remains.
"""

from __future__ import annotations

import re

_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|obj|exc):(<code>)~?")


def on_page_content(html: str, **kwargs) -> str:
    return _ROLE.sub(r"\1", html)
