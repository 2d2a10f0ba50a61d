"""Suite-wide collection order.

``make test`` runs ``pytest -n 2 --dist loadfile --no-loadscope-reorder``: pytest-xdist hands
whole files to its two workers in collection order (without the option, in decreasing order of
their test counts), so a long file handed out last leaves one worker running it while the
other idles.  The longest files (a warm run's ``--durations``; the type check is the
longest single test of a first run) are collected first; the order within a file and of the
other files is unchanged.
"""

from __future__ import annotations

import pytest

#: files run first, longest first
FIRST = ("tests/tools/test_static_checks.py", "tests/tools/test_fuzz.py",
         "tests/geometry/test_solids.py", "tests/tools/test_docs.py",
         "tests/tools/test_benchdb.py", "tests/core/test_scale_invariance.py")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {f: k for k, f in enumerate(FIRST)}
    items.sort(key=lambda it: rank.get(it.nodeid.split("::")[0], len(FIRST)))  # stable
