"""The package's dependency rules (docs/architecture.md), checked on every import statement.

Imports inside functions count too (a lazy import is still a dependency).
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "optplan"

#: the model, the geometry and the core: never import a method or a tool
CORE = ("optplan.problem", "optplan.canonical", "optplan.geometry", "optplan.metrics",
        "optplan.result", "optplan.options", "optplan.catalog", "optplan.solver",
        "optplan.interfaces", "optplan.sim", "optplan.violations", "optplan.backend")
#: the method families (one package each)
METHODS = ("optplan.exact", "optplan.swarm", "optplan.potential", "optplan.formation",
           "optplan.hybrid")
TOOLS = ("optplan.cli", "optplan.bench", "optplan.benchdb", "optplan.report", "optplan.plot",
         "optplan.doc_tables",
         "optplan.maps", "optplan.generators", "optplan.experiments")


def module_name(p: Path, root: Path = ROOT) -> str:
    """The dotted name of the module file ``p`` of the package directory ``root``."""
    return ".".join(p.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__")


def modules(root: Path = ROOT) -> dict[str, set[str]]:
    """module name -> the optplan modules it imports (``root`` is the package directory)."""
    out = {}
    for p in sorted(root.rglob("*.py")):
        name = module_name(p, root)
        deps: set[str] = set()
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                deps.add(node.module)
                deps.update(f"{node.module}.{a.name}" for a in node.names)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        out[name] = {d for d in deps if d == "optplan" or d.startswith("optplan.")}
    return out


def under(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


#: every module's name (the parametrisations: no parsing while pytest collects, in every
#: xdist worker)
NAMES = sorted(module_name(p) for p in ROOT.rglob("*.py"))


@functools.cache
def imports() -> dict[str, set[str]]:
    """:func:`modules` of the package, parsed once, when a test first asks."""
    return modules()


def test_every_module_has_a_layer() -> None:
    layered = CORE + METHODS + TOOLS + ("optplan", "optplan.__main__")
    assert all(under(m, layered) for m in NAMES), sorted(
        m for m in NAMES if not under(m, layered))


@pytest.mark.parametrize("mod", sorted(m for m in NAMES if under(m, CORE)))
def test_core_never_imports_a_method_or_a_tool(mod: str) -> None:
    bad = sorted(d for d in imports()[mod] if under(d, METHODS + TOOLS))
    assert not bad, f"{mod} imports {bad}"


@pytest.mark.parametrize("mod", sorted(m for m in NAMES if under(m, METHODS)))
def test_methods_never_import_a_tool(mod: str) -> None:
    bad = sorted(d for d in imports()[mod] if under(d, TOOLS))
    assert not bad, f"{mod} imports {bad}"


def test_the_checker_sees_lazy_imports(tmp_path: Path) -> None:
    pkg = tmp_path / "optplan" / "swarm"
    pkg.mkdir(parents=True)
    (pkg / "bad.py").write_text("def f():\n    from optplan.plot import plot_result\n"
                                "    import optplan.bench\n")
    deps = modules(tmp_path / "optplan")["optplan.swarm.bad"]
    assert {"optplan.plot", "optplan.bench"} <= deps
    assert [d for d in deps if under(d, TOOLS)]


def test_every_module_is_on_the_architecture_page() -> None:
    page = (ROOT.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    missing = []
    for m in NAMES:
        rel = m.removeprefix("optplan").lstrip(".").replace(".", "/")
        if not rel or rel == "__main__" or (ROOT / rel).is_dir():
            continue  # the package and its sub-packages (listed as folders)
        entry = rel + ".py" if rel.startswith("experiments/") else rel.rsplit("/")[-1] + ".py"
        if entry not in page:
            missing.append(entry)
    assert not missing, f"modules missing from docs/architecture.md: {missing}"


#: the size budget of a module (lines) and of a function (cyclomatic complexity, radon)
MAX_LINES = 600
MAX_COMPLEXITY = 15


def test_every_module_is_small() -> None:
    big = {str(p.relative_to(ROOT.parent)): n for p in sorted(ROOT.rglob("*.py"))
           if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


def test_no_function_is_too_complex() -> None:
    """Cyclomatic complexity as radon counts it (boolean operators included)."""
    from radon.complexity import cc_visit

    bad = []
    for p in sorted(ROOT.rglob("*.py")):
        for block in cc_visit(p.read_text(encoding="utf-8")):
            for b in [block, *getattr(block, "methods", [])]:
                if b.complexity > MAX_COMPLEXITY:
                    bad.append(f"{p.relative_to(ROOT.parent)}:{b.lineno} {b.name} "
                               f"{b.complexity}")
    assert not bad, f"functions above complexity {MAX_COMPLEXITY}: {bad}"


def test_the_catalogue_does_not_import_the_solver() -> None:
    """The catalogue reads files; the solver uses it (the docs' preset tables, which need
    both, live in optplan.doc_tables)."""
    assert not any(under(d, ("optplan.solver",)) for d in imports()["optplan.catalog"])


#: names vulture reports that are used from outside its view, each with the reason
VULTURE_USED = {
    "signum": "a signal handler's signature (bench.run)",
    "exc": "a context manager's __exit__ signature (benchdb)",
    "_negative_number_matcher": "argparse reads it (cli.parser)",
    "_compile_for_args": "numba's dispatcher calls it on a first call "
                         "(geometry.compiled.numba_internals)",
    **dict.fromkeys(("get_cache_path", "get_source_stamp", "get_disambiguator",
                     "from_function"),
                    "a numba cache locator's methods, called by numba "
                    "(geometry.compiled.kernel_cache)"),
    "_py_file": "a numba cache locator's attribute, read by numba's warnings "
                "(geometry.compiled.numba_internals)",
    **dict.fromkeys(("get_n_in", "get_n_out", "get_name_in", "get_name_out",
                     "get_sparsity_in", "eval"),
                    "casadi.Callback methods, called by CasADi (exact.nlp_model)"),
    "n_rows": "size of a built NLP, checked by tests/exact/test_nlp_flat.py",
    "obstacle": "owner of each NLP piece, checked by tests/exact/test_nlp.py",
    "retries": "Clarabel adapter's retry count, checked by tests/formation",
    **dict.fromkeys(("static_bound", "goal_bound"),
                    "fields of the public TimeBound record (geometry.timing.time_bounds)"),
    "squares": "public method of maps.Grid (the exact union of cells as a shapely geometry)",
    **dict.fromkeys(("maxdict", "maxlevel", "maxlist", "maxtuple", "maxlong", "maxother",
                     "maxstring"), "reprlib.Repr settings (problem.model)"),
    "writeable": "numpy's array flag (swarm.core)",
}


def test_no_dead_code() -> None:
    """vulture (the dev extra) finds nothing unused at 60 % confidence or more, but the names
    above."""
    import vulture

    v = vulture.Vulture(ignore_names=sorted(VULTURE_USED))
    v.scavenge([str(ROOT)])
    dead = [f"{Path(i.filename).relative_to(ROOT.parent)}:{i.first_lineno} {i.typ} {i.name}"
            for i in v.get_unused_code(min_confidence=60)]
    assert not dead, f"unused code (remove it, or add the name to VULTURE_USED): {dead}"


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """module -> the optplan modules it imports, every import statement counted (inside
    functions and under ``TYPE_CHECKING`` too): ``from a import b`` is an import of ``a.b``
    when that is a module, else of ``a``; relative imports are resolved."""
    files = {".".join(p.relative_to(root.parent).with_suffix("").parts).removesuffix(
        ".__init__"): p for p in sorted(root.rglob("*.py"))}
    graph: dict[str, set[str]] = {}
    for name, p in files.items():
        pkg = name if p.name == "__init__.py" else name.rpartition(".")[0]
        deps: set[str] = set()
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                deps.update(f"{base}.{a.name}" if f"{base}.{a.name}" in files else base
                            for a in node.names)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        graph[name] = {d for d in deps if d in files and d != name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles: strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while not comp or comp[-1] != v:
                comp.append(stack.pop())
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


#: import cycles that must stay, each with its reason (none today: a new one fails the test)
CYCLES_ALLOWED: dict[tuple[str, ...], str] = {}


def test_no_import_cycle() -> None:
    """No two modules import each other, directly or around a loop (lazy imports and
    annotations under TYPE_CHECKING count: a type the other way is still a dependency)."""
    found = {tuple(c) for c in cycles(import_graph())}
    new = sorted(found - set(CYCLES_ALLOWED))
    assert not new, f"import cycles: {new}"
    assert not set(CYCLES_ALLOWED) - found, "CYCLES_ALLOWED lists a cycle that is gone"


def test_the_cycle_check_sees_a_lazy_cycle(tmp_path: Path) -> None:
    pkg = tmp_path / "optplan" / "fam"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from optplan.fam import b\n")
    (pkg / "b.py").write_text("def f():\n    from . import c\n")
    (pkg / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                              "    from optplan.fam.a import X\n")
    (pkg / "d.py").write_text("import optplan.fam.a\n")
    graph = import_graph(tmp_path / "optplan")
    assert graph["optplan.fam.b"] == {"optplan.fam.c"}
    assert cycles(graph) == [["optplan.fam.a", "optplan.fam.b", "optplan.fam.c"]]


def is_private(name: str) -> bool:
    """``_x`` is private to its package; dunder names (``__version__``) are not."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def attribute_module(node: ast.Attribute, alias: dict[str, str]) -> str | None:
    """The dotted name ``m.a.b`` of ``node``'s value ``m.a.b`` (``node = m.a.b._x``) when its
    root ``m`` is bound to an optplan module (``alias``), else None."""
    chain, v = [], node.value
    while isinstance(v, ast.Attribute):
        chain.append(v.attr)
        v = v.value
    if not isinstance(v, ast.Name) or v.id not in alias:
        return None
    return ".".join([alias[v.id], *reversed(chain)])


def private_crossings(root: Path = ROOT) -> list[str]:
    """Every use of another package's private name: ``from X import _n`` and ``X._n`` (``X``
    imported as a module, ``import X`` / ``import X as m`` / ``from P import X``), where ``X``
    is owned by another package than the importing module's.  A package is the innermost
    package directory: ``optplan.geometry.collision`` and ``optplan.geometry.tangent`` are two,
    and a module of ``optplan/`` itself (``optplan.benchdb``) is of the package ``optplan``."""
    files = {module_name(p, root): p for p in sorted(root.rglob("*.py"))}

    def package(mod: str) -> str:
        return mod if files[mod].name == "__init__.py" else mod.rpartition(".")[0]

    bad = []
    for name, p in files.items():
        here = package(name)
        tree = ast.parse(p.read_text(encoding="utf-8"))
        alias: dict[str, str] = {}  # local name -> the module it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = here.split(".")[: len(here.split(".")) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                alias.update({a.asname or a.name: f"{base}.{a.name}" for a in node.names
                              if f"{base}.{a.name}" in files})
                bad += [f"{name}:{node.lineno} from {base} import {a.name}" for a in node.names
                        if base in files and is_private(a.name) and package(base) != here]
            elif isinstance(node, ast.Import):
                for a in node.names:  # import a.b (binds a) / import a.b as m (binds a.b)
                    bound = a.asname or a.name.split(".")[0]
                    alias[bound] = a.name if a.asname else bound
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and is_private(node.attr):
                mod = attribute_module(node, alias)
                if mod in files and package(mod) != here:
                    bad.append(f"{name}:{node.lineno} {mod}.{node.attr}")
    return bad


def test_no_module_uses_another_packages_private_names() -> None:
    """A package's private names (``_x``) are its own: another package imports only its
    public surface (the subpackages of optplan.geometry are packages of their own)."""
    bad = private_crossings()
    assert not bad, f"private names used across packages: {bad}"


def test_the_private_check_sees_every_form(tmp_path: Path) -> None:
    for pkg in ("optplan/fam/a", "optplan/fam/b"):
        (tmp_path / pkg).mkdir(parents=True)
        (tmp_path / pkg / "__init__.py").write_text("")
    (tmp_path / "optplan" / "__init__.py").write_text("")
    (tmp_path / "optplan" / "fam" / "__init__.py").write_text("")
    (tmp_path / "optplan/fam/a/m.py").write_text("_x = 1\n__version__ = '1'\n")
    (tmp_path / "optplan/fam/a/n.py").write_text(  # the same package: allowed
        "from optplan.fam.a.m import _x\nfrom . import m\nm._x\n")
    (tmp_path / "optplan/fam/b/k.py").write_text(
        "from optplan.fam.a.m import _x, __version__\n"
        "import optplan.fam.a.m\nimport optplan.fam.a.m as mm\nfrom optplan.fam.a import m\n"
        "def f():\n    from ..a.m import _x\n    return optplan.fam.a.m._x + mm._x + m._x\n")
    bad = private_crossings(tmp_path / "optplan")
    assert not [b for b in bad if "fam.a.n" in b or "__version__" in b], bad
    assert len([b for b in bad if b.startswith("optplan.fam.b.k")]) == 5, bad


#: the identical-code budget: no run of this many code lines stands twice in the package
#: (the shape budget, pairs of the ``duplicates`` tool, is checked by hand: docs/architecture.md)
MIN_REPEAT = 6


def repeated_runs(root: Path = ROOT, n: int = MIN_REPEAT) -> list[str]:
    """Every run of ``n`` identical code lines that stands in two places (in one file or two).
    White space is folded; blank lines, comments, lone punctuation and import statements are
    passed over (as the ``duplicates`` tool does)."""
    seen: dict[tuple[str, ...], str] = {}
    bad = []
    for p in sorted(root.rglob("*.py")):
        text = p.read_text(encoding="utf-8")
        skip = {i for node in ast.walk(ast.parse(text))
                if isinstance(node, ast.Import | ast.ImportFrom)
                for i in range(node.lineno, (node.end_lineno or node.lineno) + 1)}
        lines = [(i, s) for i, line in enumerate(text.splitlines(), 1)
                 if i not in skip and (s := " ".join(line.split()))
                 and not s.startswith("#") and any(c.isalnum() for c in s)]
        last = -n  # a run overlapping the last one reported in this file is the same run
        for k in range(len(lines) - n + 1):
            run = tuple(s for _, s in lines[k:k + n])
            where = f"{p.relative_to(root.parent)}:{lines[k][0]}"
            if run not in seen:
                seen[run] = where
            elif k >= last + n:
                bad.append(f"{where} ~ {seen[run]}")
                last = k
    return bad


def test_no_code_stands_twice() -> None:
    """Code written twice is factored into one helper, a table or a constant."""
    bad = repeated_runs()
    assert not bad, f"runs of {MIN_REPEAT} identical lines written twice: {bad}"


def test_the_repeat_check_sees_a_repeat(tmp_path: Path) -> None:
    body = "".join(f"    x{i} = f(x, {i})\n" for i in range(MIN_REPEAT))
    (tmp_path / "optplan").mkdir()
    (tmp_path / "optplan/a.py").write_text(f"import os\n\ndef f(x):\n{body}    return x\n")
    (tmp_path / "optplan/b.py").write_text(f"def g(x):  # other\n\n{body.replace('    ', '  ')}")
    (tmp_path / "optplan/c.py").write_text("def h(x):\n" + body.replace("x5", "y5"))
    assert repeated_runs(tmp_path / "optplan") == ["optplan/b.py:3 ~ optplan/a.py:4"]


#: the cast budget: ``typing.cast`` only where a library's types force it (each one commented);
#: none is needed today (issue 43: 19 before, each replaced by a narrowing check or a type)
MAX_CASTS = 0


def _casts(tree: ast.AST) -> list[int]:
    """Lines of ``cast(...)`` (imported from typing) and ``typing.cast(...)`` calls."""
    named = any(isinstance(n, ast.ImportFrom) and n.module == "typing"
                and any(a.name == "cast" for a in n.names) for n in ast.walk(tree))
    return [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call) and (
        (named and isinstance(n.func, ast.Name) and n.func.id == "cast")
        or (isinstance(n.func, ast.Attribute) and n.func.attr == "cast"
            and isinstance(n.func.value, ast.Name) and n.func.value.id == "typing"))]


def test_casts_stay_within_budget() -> None:
    """Types instead of casts: a narrow argument, a Protocol or a record, not ``cast(``."""
    found = [f"{p.relative_to(ROOT.parent)}:{k}" for p in sorted(ROOT.rglob("*.py"))
             for k in _casts(ast.parse(p.read_text(encoding="utf-8")))]
    assert len(found) <= MAX_CASTS, f"{len(found)} casts (budget {MAX_CASTS}): {found}"


def test_the_cast_check_sees_both_spellings() -> None:
    src = "import typing\nfrom typing import cast\nx = cast(int, 1)\ny = typing.cast(int, 2)\n"
    assert _casts(ast.parse(src)) == [3, 4]
    assert _casts(ast.parse("def cast(v):\n    return v\nz = cast(1)\n")) == []


#: the most parameters a function may take (``self`` / ``cls`` not counted); compiled
#: kernels take their arrays grouped in tuples (documented once in their module docstring).
#: No exception: the last seven (import_map 28, solve_waypoint_nlp 14, simulate 12,
#: recovery 12, run_grid 12, Backend.finish 12, read_scen 11) took option records in issue 43
MAX_PARAMETERS = 10


def test_no_function_takes_more_than_ten_parameters() -> None:
    """Every function and method of the package (nested ones too) takes at most
    :data:`MAX_PARAMETERS` parameters, ``*args`` and ``**kwargs`` each counting one."""
    over = []
    for p in sorted(ROOT.rglob("*.py")):
        rel = p.relative_to(ROOT.parent).as_posix()
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            a = node.args
            names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
            n = len(names) + (a.vararg is not None) + (a.kwarg is not None)
            n -= bool(names) and names[0] in ("self", "cls")
            if n > MAX_PARAMETERS:
                over.append(f"{rel}:{node.lineno}:{node.name} ({n})")
    assert not over, "over the parameter budget: " + ", ".join(over)


NUMPYDOC_SECTION = re.compile(r"^\s*(Parameters|Returns|Yields|Raises)\n\s*-{3,}$", re.M)


def test_private_helpers_have_no_numpydoc_sections() -> None:
    """A private helper's docstring says what it does in a line or a paragraph; the
    Parameters / Returns sections belong to the public API (issue 43)."""
    found = []
    for p in sorted(ROOT.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
                    and is_private(node.name)
                    and NUMPYDOC_SECTION.search(ast.get_docstring(node) or "")):
                found.append(f"{p.relative_to(ROOT.parent)}:{node.lineno}:{node.name}")
    assert not found, f"numpydoc sections on private helpers: {found}"
