"""Experiment commands (`optplan bench --tag NAME`, `optplan validate`).

Each module here exposes ``main(argv: list[str] | None = None) -> int`` that parses its own
arguments, runs, and prints a table; the CLI dispatches ``optplan bench --tag pso-comparison``
to ``optplan.experiments.pso_comparison:main``.  The fidelity checks share the helpers below:
one preset with one option at a few values (:func:`option_sweep`, :func:`option_groups`) and a
``main`` that prints titled sections (:func:`sections_main`).
"""

import argparse
import functools
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import optplan as op

Row = dict[str, Any]


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


def sections_main(module: str, doc: str, seed_counts: Sequence[tuple[str, int, str]],
                  sections: Sequence[tuple[str, str, Callable[[argparse.Namespace], str]]],
                  argv: list[str] | None) -> int:
    """The ``main`` of an experiment module that prints titled tables.

    Parameters
    ----------
    module
        The module's dotted name (the usage line is ``python -m <module>``).
    doc
        The module's docstring; its first paragraph is the description.
    seed_counts
        ``(flag, default, what)``: an integer option ``flag`` (e.g. ``--seeds``), the number of
        seeds of ``what`` (e.g. ``"the k_B table"``).
    sections
        ``(key, title, table)``, printed by :func:`print_sections`: ``title`` is formatted with
        the parsed options (``{seeds}``), ``table`` makes the table from them; ``--skip``
        takes the keys.
    argv
        The arguments (default: the command line's).

    Returns
    -------
    int
        0.
    """
    ap = argparse.ArgumentParser(prog=f"python -m {module}", description=doc.split("\n\n")[0])
    for flag, default, what in seed_counts:
        ap.add_argument(flag, type=int, default=default, help=f"seeds of {what} ({default})")
    ap.add_argument("--skip", default="",
                    help="comma-separated: " + ", ".join(key for key, _, _ in sections))
    a = ap.parse_args(argv)
    print_sections([(key, title.format(**vars(a)), functools.partial(table, a))
                    for key, title, table in sections], a.skip)
    return 0


def option_sweep(preset: str, option: str, values: Sequence[Any], seeds: Sequence[int],
                 scenes: Sequence[str], cells: Callable[[op.Problem, op.Result], Row]
                 ) -> list[Row]:
    """``preset`` with ``option`` at each of ``values``, per scene and seed.

    Parameters
    ----------
    preset
        The solver preset.
    option
        The option set to each value.
    values
        Its values.
    seeds
        The seeds of every (scene, value).
    scenes
        Catalogue scenes.
    cells
        The row's further entries, from the problem and the result.

    Returns
    -------
    list of dict
        One row per (scene, value, seed), in that order: ``scene``, ``option``'s value,
        ``seed``, ``success``, ``status`` (the value), then ``cells``'s.
    """
    rows = []
    for scene in scenes:
        prob = op.load_problem(scene)
        for v in values:
            for s in seeds:
                res = op.solve(prob, preset, rng=int(s), **{option: v})
                rows.append({"scene": scene, option: v, "seed": int(s), "success": res.success,
                             "status": res.status.value, **cells(prob, res)})
    return rows


def option_groups(rows: list[Row], option: str, values: Sequence[Any]
                  ) -> Iterator[tuple[str, Any, list[Row]]]:
    """The rows of :func:`option_sweep` grouped: ``(scene, value, its rows)`` per scene (in
    first-seen order), then per value of ``option`` (in the order of ``values``)."""
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for v in values:
            yield scene, v, [r for r in rows if r["scene"] == scene and r[option] == v]
