"""Experiment commands (`optplan bench --tag NAME`, `optplan validate`).

Each module here exposes ``main(argv: list[str] | None = None) -> int`` that parses its own
arguments, runs, and prints a table; the CLI dispatches ``optplan bench --tag pso-comparison``
to ``optplan.experiments.pso_comparison:main``.
"""

from collections.abc import Callable, Sequence


def print_sections(sections: Sequence[tuple[str, str, Callable[[], str]]], skip: str) -> None:
    """Print each ``(key, title, table)`` section whose key is not in the comma-separated
    ``skip``: its title, a blank line and its table (made only then), a blank line between
    sections."""
    skipped = set(filter(None, skip.split(",")))
    for n, (key, title, table) in enumerate(sections):
        if key not in skipped:
            print(f"{title}\n")
            print(table())
            if n < len(sections) - 1:
                print()
