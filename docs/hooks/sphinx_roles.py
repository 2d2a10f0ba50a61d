"""MkDocs hook: render Sphinx cross-reference roles left in numpy-style docstrings.

mkdocstrings shows ``:func:`solve``` as the literal text ":func:" before the code span.  This
hook turns each role (``:func:``, ``:class:``, ``:meth:``, ``:mod:``, ``:attr:``, ``:data:``,
``:obj:``, ``:exc:``, with an optional ``py:`` domain and a leading ``~``) into an optional
cross-reference for mkdocs-autorefs: a link when the object is documented on the site (the
API reference renders ``optplan.solver``, ``optplan.result``, ``optplan.catalog``,
``optplan.metrics.evaluate`` and ``optplan.interfaces``), the plain code span otherwise.
"""

from __future__ import annotations

import html
import re

_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|obj|exc):<code>~?([^<]*)</code>")


def _ref(m: re.Match) -> str:
    name = html.unescape(m[1]).strip().rstrip("()")
    # a bare name (``Result``) is tried as the package-level alias (``optplan.Result``)
    ident = html.escape(name if "." in name else f"optplan.{name}", quote=True)
    short = html.escape(name.rsplit(".", 1)[-1] if m[0].find("~") >= 0 else name)
    return f'<autoref identifier="{ident}" optional><code>{short}</code></autoref>'


def on_page_content(html_text: str, **kwargs) -> str:
    return _ROLE.sub(_ref, html_text)
