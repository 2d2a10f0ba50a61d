"""Every Python block of README.md and docs/ runs, and the outputs the docs quote are checked.

Rules (documented in docs/index.md, "Docs that stay true"):

* every fenced ``python`` block of a page runs, in page order, in one namespace per page, in a
  fresh temporary directory (so nothing is left in the repository); a block may read what an
  earlier block of its page wrote (the page says so), never a file of another page;
* whatever a page's blocks write, inputs of ``<!-- file: -->`` blocks included, goes under
  ``runs/`` (ignored by git; ``make demo`` writes there too), so the examples, run from a
  checkout as shown, leave ``git status`` clean;
* a block preceded by the line ``<!-- file: NAME -->`` (any language) is written to ``NAME`` in
  that directory before the page runs (e.g. the scenario a later block loads);
* a ``console`` block preceded by ``<!-- run -->`` runs through the CLI: each line
  ``$ optplan ARGS`` (or ``.venv/bin/optplan ARGS``) is passed to :func:`optplan.cli.main`
  (in the page's temporary directory, in page order) and must exit with status 0 and print
  the lines that follow it, compared like a doctest (``...`` for what varies); a command whose
  shown output starts with ``optplan: error:`` must exit with status 2 and print that on stderr;
* a python block with an ``if __name__ == "__main__":`` guard runs with ``__name__`` set to
  ``"__main__"`` (as the script it shows would);
* every code fence is closed, and no ```` ```lang ```` line sits inside an open block (a missing
  closing fence renders the rest of the page as code; neither mkdocs nor the blocks notice);
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
FENCE = re.compile(r"^(?P<indent>[ ]*)```+(?P<lang>[\w-]*)[^\n]*$")
MARK = re.compile(r"^\s*<!--\s*(?P<what>no-run|run|file:\s*(?P<name>[\w./-]+))\s*-->\s*$")


def _closes(line: str, ticks: str) -> bool:
    """Whether ``line`` closes a fence opened with ``ticks`` (CommonMark: backticks at least as
    many as the opening ones and nothing else; ```` ```text ```` opens, it never closes)."""
    s = line.strip()
    return s.startswith(ticks) and set(s) == {"`"}


def fences(lines: list[str]) -> list[tuple[int, int, re.Match[str], list[int]]]:
    """``(opening line, closing line or len(lines), opening match, inner openers)`` of every
    fenced block; an inner opener is a line that opens a fence (```` ```lang ````, as many
    backticks) inside the block: to a renderer it is code, not the start of a new block."""
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        ticks = "`" * (len(lines[i].strip()) - len(lines[i].strip().lstrip("`")))
        j, inner = i + 1, []
        while j < len(lines) and not _closes(lines[j], ticks):
            im = FENCE.match(lines[j])
            if im and im["lang"] and lines[j].strip().startswith(ticks):
                inner.append(j)
            j += 1
        out.append((i, j, m, inner))
        i = j + 1
    return out


def fence_problems(text: str) -> list[str]:
    """Fences a Markdown renderer would not read as the author meant: a fence never closed, and
    an opening fence (```` ```lang ````) inside an open block, which is code to the renderer
    (the block above it lacks its closing fence)."""
    lines = text.splitlines()
    out = []
    for i, j, _, inner in fences(lines):
        out += [f"line {k + 1}: '{lines[k].strip()}' inside the block opened at line {i + 1} "
                f"(is that block's closing fence missing?)" for k in inner]
        if j == len(lines):
            out.append(f"line {i + 1}: fence never closed")
    return out


def blocks(text: str) -> list[dict]:
    """Fenced blocks with their language, code, marker and the line before them."""
    lines = text.splitlines()
    out = []
    for i, j, m, _ in fences(lines):
        indent = m["indent"]
        body = [x[len(indent):] if x.startswith(indent) else x for x in lines[i + 1:j]]
        prev = [x for x in lines[:i] if x.strip()]
        before = prev[-1] if prev else ""
        mk = MARK.match(before)
        out.append({"lang": m["lang"], "code": "\n".join(body) + "\n", "line": i + 1,
                    "mark": mk["what"] if mk else "", "file": mk["name"] if mk else None,
                    "before": before})
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
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main(argv[1:])
        # a command the page shows failing must fail with the usage status and say so on stderr
        fails = want.startswith("optplan: error:")
        got = err.getvalue() if fails else out.getvalue()
        assert rc == (2 if fails else 0), (
            f"{page.name}:{block['line']}: `{cmd}` exited with {rc}\n{err.getvalue()}")
        assert not want or checker.check_output(want, got, flags), (
            f"{page.relative_to(ROOT)}:{block['line']}: `{cmd}` prints\n{got}\n"
            f"but the page says\n{want}")


def run_python(block: dict, page: Path, ns: dict) -> str:
    """Run a python block in the page's namespace and return what it printed.  A block with an
    ``if __name__ == "__main__":`` guard (a script that starts worker processes) runs as a
    script would: with ``__name__`` set to ``"__main__"`` for that block."""
    buf = io.StringIO()
    name = ns.get("__name__")
    if re.search(r"^if __name__ == .__main__.:", block["code"], re.M):
        ns["__name__"] = "__main__"
    try:
        with contextlib.redirect_stdout(buf):
            exec(compile(block["code"], f"{page.name}:{block['line']}", "exec"), ns)  # noqa: S102
    finally:
        ns["__name__"] = name
    return buf.getvalue()


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_fence_is_closed(page: Path) -> None:
    problems = fence_problems(page.read_text(encoding="utf-8"))
    assert not problems, f"{page.relative_to(ROOT)}: " + "; ".join(problems)


def test_the_fence_check_catches_a_missing_closing_fence() -> None:
    # docs/solvers/apf.md had this: a table in a text block with no closing fence, so the
    # next three sections rendered as code (the next opening fence closed nothing)
    text = "intro\n\n```text\n| a |\n\nprose\n\n```text\nmore\n```\n\nend\n"
    problems = fence_problems(text)
    assert problems == ["line 8: '```text' inside the block opened at line 3 (is that "
                        "block's closing fence missing?)"]
    assert fence_problems("```python\nx = 1\n") == ["line 1: fence never closed"]
    assert fence_problems("````markdown\n```python\nx\n```\n````\n") == []  # nested
    assert fence_problems("```python\nx = 1\n```\n\n```text\n1\n```\n") == []


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
            got = run_python(b, page, ns)
            nxt = bl[k + 1] if k + 1 < len(bl) else None
            if nxt and nxt["lang"] == "text" and nxt["before"].lower().startswith("prints"):
                assert checker.check_output(nxt["code"], got, flags), (
                    f"{page.relative_to(ROOT)}:{b['line']}: the block prints\n{got}\n"
                    f"but the page says (line {nxt['line']})\n{nxt['code']}")
    finally:
        sys.modules.pop(mod.__name__, None)
        os.chdir(cwd)
        plt.close("all")
    leftovers = [p for p in ROOT.iterdir() if p.name not in _TRACKED and not p.name.startswith(".")]
    assert not leftovers, f"the page wrote files into the repository root: {leftovers}"
    outside = sorted(str(f.relative_to(tmp_path)) for f in tmp_path.rglob("*")
                     if f.is_file() and f.relative_to(tmp_path).parts[0] != "runs")
    assert not outside, (
        f"{page.relative_to(ROOT)}: its examples write outside runs/ (run from a checkout, they "
        f"would leave these files in it): {outside}")


_TRACKED = {p.name for p in ROOT.iterdir()} | {"site", "runs", "build", "dist"}


def _load_hook(name: str) -> types.ModuleType:
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / "hooks" / f"{name}.py")
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("page", [p for p in PAGES
                                  if any(b["file"] for b in blocks(p.read_text("utf-8")))],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_hidden_file_blocks_show_their_name(page: Path) -> None:
    """A block written to a file by ``<!-- file: NAME -->`` (a comment, which does not render)
    shows NAME in the rendered page: the site's hook gives its fence a title."""
    import markdown

    hook = _load_hook("file_titles")
    text = page.read_text(encoding="utf-8")
    names = [b["file"] for b in blocks(text) if b["file"]]
    html = markdown.markdown(hook.on_page_markdown(text),
                             extensions=["pymdownx.superfences", "pymdownx.highlight"])
    for name in names:
        assert f'<span class="filename">{name}</span>' in html, (
            f"{page.relative_to(ROOT)}: the block written to {name} does not show its name")
