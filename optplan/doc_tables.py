"""Tables of the docs generated from the presets, so they cannot go stale (the mkdocs hook
``docs/hooks/paper_tables.py`` fills them in): a ``-paper`` preset's options against the
paper's values (:func:`paper_table`) and the options of presets with their meanings and
allowed values (:func:`options_table`).
"""

from __future__ import annotations

from optplan.catalog import read_preset
from optplan.options import describe_options
from optplan.solver import all_preset_files, get_solver

__all__ = ["paper_table", "options_table"]


def paper_table(preset: str) -> str:
    """Markdown table of a ``-paper`` preset's effective options against the paper's values.

    One row per option named in the preset's ``[paper]`` table: the value the solver uses
    (the preset's, else the backend default), the paper's, whether they agree and the note
    from ``[paper_notes]``.  Generated from the preset files, so the docs cannot go stale.
    """
    files = all_preset_files()
    if preset not in files:
        raise ValueError(f"paper_table: unknown preset {preset!r}")
    data = read_preset(files[preset])
    solver = get_solver(preset)
    if not data["paper"]:
        raise ValueError(f"{files[preset]}: no [paper] table")
    rows = ["| option | `" + preset + "` | paper | same | note |", "|---|---|---|---|---|"]
    for k, pv in data["paper"].items():
        if not hasattr(solver, k):
            raise ValueError(f"{files[preset]}: paper.{k}: not an option of backend "
                             f"{data['backend']!r}")
        v = getattr(solver, k)
        if isinstance(pv, str) and not isinstance(v, str):
            same = "n/a"  # the paper gives no number
        else:
            same = "yes" if v == pv or (
                isinstance(v, (int, float)) and not isinstance(v, bool)
                and abs(float(v) - float(pv)) <= 1e-12 * max(1.0, abs(float(pv)))) else "**no**"
        note = data["paper_notes"].get(k, "").replace("|", "\\|")
        rows.append(f"| `{k}` | `{v!r}` | {pv if isinstance(pv, str) else f'`{pv!r}`'} | "
                    f"{same} | {note} |")
    return "\n".join(rows)


def options_table(presets: list[str]) -> str:
    """Markdown table of the options of one or more presets: the union of their options, each
    with its meaning (from the backend's docstring), allowed values and every preset's value
    (``-`` when the preset's backend has no such option).  Generated, so it cannot go stale.
    """
    solvers = [get_solver(p) for p in presets]
    rows: dict[str, dict] = {}
    for solver in solvers:
        for r in describe_options(type(solver)):
            rows.setdefault(r["name"], r)

    def cell(text: str) -> str:
        return " ".join(str(text).split()).replace("|", "\\|").replace("``", "`")

    head = "| option | meaning | allowed | " + " | ".join(f"`{p}`" for p in presets) + " |"
    out = [head, "|---|---|---|" + "---|" * len(presets)]
    for name, r in rows.items():
        vals = [f"`{getattr(s, name)!r}`" if hasattr(s, name) else "-" for s in solvers]
        out.append(f"| `{name}` | {cell(r['meaning'])} | {cell(r['allowed'])} | "
                   + " | ".join(vals) + " |")
    return "\n".join(out)
