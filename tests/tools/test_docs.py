"""Every Python block of README.md and docs/ runs, and the outputs the docs quote are checked.

Rules (documented in docs/index.md, "Docs that stay true"):

* every fenced ``python`` block of a page runs, in page order, in one namespace per page, in a
  fresh temporary directory (so nothing is left in the repository);
* a block preceded by the line ``<!-- file: NAME -->`` (any language) is written to ``NAME`` in
  that directory before the page runs (e.g. the scenario a later block loads);
* a ``console`` block preceded by ``<!-- run -->`` runs through the CLI: each line
  ``$ optplan ARGS`` (or ``.venv/bin/optplan ARGS``) is passed to :func:`optplan.cli.main`
  (in the page's temporary directory, in page order) and must exit with status 0 and print
  the lines that follow it, compared like a doctest (``...`` for what varies);
* a block preceded by ``<!-- no-run -->`` is not run (use it only for fragments that cannot run
  on their own, and say so in the text);
* a python block followed by a ``text`` block introduced by a line starting with "prints" must
  print that text, compared like a doctest with ``ELLIPSIS`` and ``NORMALIZE_WHITESPACE``: write
  ``...`` for what varies (wall times), never a stale number.
"""

from __future__ import annotations

import contextlib
import doctest
import io
import os
import re
import shlex
import sys
import types
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
FENCE = re.compile(r"^(?P<indent>[ ]*)```(?P<lang>[\w-]*)[^\n]*$")
MARK = re.compile(r"^\s*<!--\s*(?P<what>no-run|run|file:\s*(?P<name>[\w./-]+))\s*-->\s*$")


def blocks(text: str) -> list[dict]:
    """Fenced blocks with their language, code, marker and the line before them."""
    lines = text.splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m or not m["lang"] and not lines[i].strip().startswith("```"):
            i += 1
            continue
        indent, lang = m["indent"], m["lang"]
        j = i + 1
        body = []
        while j < len(lines) and not lines[j].strip().startswith("```"):
            body.append(lines[j][len(indent):] if lines[j].startswith(indent) else lines[j])
            j += 1
        prev = [x for x in lines[:i] if x.strip()]
        before = prev[-1] if prev else ""
        mk = MARK.match(before)
        out.append({"lang": lang, "code": "\n".join(body) + "\n", "line": i + 1,
                    "mark": mk["what"] if mk else "", "file": mk["name"] if mk else None,
                    "before": before})
        i = j + 1
    return out


def runnable(page: Path) -> bool:
    return any(b["lang"] in ("python", "py") and b["mark"] != "no-run"
               or b["lang"] == "console" and b["mark"] == "run"
               for b in blocks(page.read_text(encoding="utf-8")))


def console_commands(code: str) -> list[tuple[str, str]]:
    """``(command line, expected output)`` pairs of a console block (``$ `` prompts)."""
    out: list[tuple[str, list[str]]] = []
    for line in code.splitlines():
        cmd = line[2:].strip() if line.startswith("$ ") else line.strip()
        if line.startswith("$ ") or cmd.split(" ")[0].endswith("bin/optplan"):
            out.append((cmd, []))
        elif out:
            out[-1][1].append(line)
    return [(cmd, "\n".join(lines).strip() + "\n" if lines else "") for cmd, lines in out]


def run_console(block: dict, page: Path, checker, flags) -> None:
    from optplan.cli import main

    for cmd, want in console_commands(block["code"]):
        argv = shlex.split(cmd)
        assert Path(argv[0]).name == "optplan", (
            f"{page.name}:{block['line']}: not an optplan command: {cmd}")
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            rc = main(argv[1:])
        got = buf.getvalue()
        assert rc == 0, f"{page.name}:{block['line']}: `{cmd}` exited with {rc}"
        assert not want or checker.check_output(want, got, flags), (
            f"{page.relative_to(ROOT)}:{block['line']}: `{cmd}` prints\n{got}\n"
            f"but the page says\n{want}")


@pytest.mark.parametrize("page", [p for p in PAGES if runnable(p)],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_doc_blocks_run_and_print_what_the_page_says(page: Path, tmp_path: Path) -> None:
    bl = blocks(page.read_text(encoding="utf-8"))
    for b in bl:
        if b["file"]:
            (tmp_path / b["file"]).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / b["file"]).write_text(b["code"], encoding="utf-8")
    # a real module, so that dataclasses (which look their module up) work in the blocks
    mod = types.ModuleType("optplan_docs_page")
    sys.modules[mod.__name__] = mod
    ns = mod.__dict__
    checker = doctest.OutputChecker()
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        for k, b in enumerate(bl):
            if b["lang"] == "console" and b["mark"] == "run":
                run_console(b, page, checker, flags)
                continue
            if b["lang"] not in ("python", "py") or b["mark"] == "no-run" or b["file"]:
                continue
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(compile(b["code"], f"{page.name}:{b['line']}", "exec"), ns)  # noqa: S102
            nxt = bl[k + 1] if k + 1 < len(bl) else None
            if nxt and nxt["lang"] == "text" and nxt["before"].lower().startswith("prints"):
                got = buf.getvalue()
                assert checker.check_output(nxt["code"], got, flags), (
                    f"{page.relative_to(ROOT)}:{b['line']}: the block prints\n{got}\n"
                    f"but the page says (line {nxt['line']})\n{nxt['code']}")
    finally:
        sys.modules.pop(mod.__name__, None)
        os.chdir(cwd)
        plt.close("all")
    leftovers = [p for p in ROOT.iterdir() if p.name not in _TRACKED and not p.name.startswith(".")]
    assert not leftovers, f"the page wrote files into the repository root: {leftovers}"


_TRACKED = {p.name for p in ROOT.iterdir()} | {"site", "runs", "build", "dist"}
