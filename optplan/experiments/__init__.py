"""Experiment commands (`optplan bench --tag NAME`, `optplan validate`).

Each module here exposes ``main(argv: list[str] | None = None) -> int`` that parses its own
arguments, runs, and prints a table; the CLI dispatches ``optplan bench --tag pso-comparison``
to ``optplan.experiments.pso_comparison:main``.
"""
