"""The **plugin** family: broken plugin distributions beside a working one, each run in a
fresh Python process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

from benchmarks.fuzz.core import ROOT, Case, Outcome

_PLUGIN_BACKEND = '''
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.result import Status
from optplan.solver import Backend


@dataclass(frozen=True, kw_only=True)
class Line(Backend):
    """A straight line from start to goal."""

    name: ClassVar[str] = "NAME"

    def solve(self, problem, /, *, rng=None, init=None, callback=None):
        paths = {r.id: np.array([r.start, r.goal]) for r in problem.robots}
        return self.finish(problem, paths, claim=Status.solved, n_iter=1, n_eval=1)
'''

_PLUGIN_RUN = '''
import contextlib, io, json, sys, warnings
import optplan as op
from optplan import cli

out = {"use": []}
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    try:
        out["visgraph"] = op.solve("open-field", "visgraph").status.value
        out["n_solvers"] = len(op.list_solvers())
    except BaseException as e:
        out["broke"] = f"{type(e).__name__}: {e}"
    for name in sys.argv[1:]:
        try:
            out["use"].append(["ok", op.solve("open-field", name).status.value])
        except (ImportError, ValueError) as e:
            out["use"].append(["error", f"{type(e).__name__}: {e}"])
        except BaseException as e:
            out["use"].append(["crash", f"{type(e).__name__}: {e}"])
out["warnings"] = [f"{w.category.__name__}: {w.message}" for w in caught]
err = io.StringIO()
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
    out["cli"] = cli.main(["list", "solvers"])
out["cli_err"] = err.getvalue()
print("FUZZ-RESULT " + json.dumps(out))
'''


def _plugin(dist: str, files: dict[str, str], backends: str = "",
            presets: str = "") -> dict[str, Any]:
    eps = (f"[optplan.backends]\n{backends}\n" if backends else "") + \
          (f"[optplan.presets]\n{presets}\n" if presets else "")
    return {"dist": dist, "files": files, "entry_points": eps}


def plugin_cases() -> list[Case]:
    """Plugin distributions that raise, are malformed or name what does not exist, beside the
    toolkit's own solvers (which must keep working)."""
    good = _PLUGIN_BACKEND.replace("NAME", "fzline")
    variants: list[tuple[str, dict[str, Any], list[str], bool]] = [
        ("working plugin", _plugin("fzgood", {"fzgood/__init__.py": "", "fzgood/b.py": good,
                                              "fzgood/presets/fzline-fast.toml":
                                              'backend = "fzline"\n'},
                                   "fzline = fzgood.b:Line", "fzgood = fzgood.presets"),
         ["fzline", "fzline-fast"], False),
        ("namespace presets", _plugin("fzns", {"fzns/b.py": good.replace("fzline", "fzns"),
                                               "fzns/presets/fzns-five.toml":
                                               'backend = "fzns"\n'},
                                      "fzns = fzns.b:Line", "fzns = fzns.presets"),
         ["fzns-five"], False)]
    for what, init in (("package raises", "raise RuntimeError('boom')"),
                       ("package SyntaxError", "def (:"),
                       ("package missing dependency", "import no_such_dependency_fz"),
                       ("package exits", "raise SystemExit(3)"),
                       ("package calls sys.exit()", "import sys\nsys.exit()"),
                       ("package raises a BaseException", "class Stop(BaseException):\n"
                                                          "    pass\nraise Stop('stop')")):
        variants.append((what, _plugin("fzbad", {"fzbad/__init__.py": init, "fzbad/b.py": good,
                                                 "fzbad/presets/fzbad-x.toml":
                                                 'backend = "fzline"\n'},
                                       "fzline = fzbad.b:Line", "fzbad = fzbad.presets"),
                         ["fzline"], True))
    for what, ep in (("no colon", "fzline = fzbad.b"), ("two colons", "fzline = fzbad.b:A:B"),
                     ("empty class", "fzline = fzbad.b:"), ("missing class",
                                                             "fzline = fzbad.b:Missing"),
                     ("missing module", "fzline = fzbad.nothere:Line"),
                     ("not a backend", "fzline = fzbad.b:np"), ("spaces", "fzline = fz bad:L")):
        variants.append((f"entry point {what}", _plugin(
            "fzbad", {"fzbad/__init__.py": "", "fzbad/b.py": good}, ep), ["fzline"], True))
    for what, files, ep in (
            ("presets missing", {}, "fzbad = fzbad.nothere"),
            ("presets a path", {}, "fzbad = fzbad/presets"),
            ("preset TOML broken", {"fzbad/presets/fzbad-x.toml": "backend = [\n"},
             "fzbad = fzbad.presets"),
            ("preset unknown backend", {"fzbad/presets/fzbad-x.toml": 'backend = "nope"\n'},
             "fzbad = fzbad.presets"),
            ("preset bad option", {"fzbad/presets/fzbad-x.toml":
                                   'backend = "visgraph"\n[options]\nnope = 1\n'},
             "fzbad = fzbad.presets")):
        variants.append((what, _plugin("fzbad", {"fzbad/__init__.py": "", **files}, presets=ep),
                         ["fzbad-x"], True))
    return [Case("plugin", f"plugin/{k + 1:04d}/{what}", what, {"plugin": p, "use": use},
                 (p["dist"], "fzbad-x", "fzline"), must)
            for k, (what, p, use, must) in enumerate(variants)]


def _install_plugin(root: Path, p: dict[str, Any]) -> None:
    for rel, text in p["files"].items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    info = root / f"{p['dist']}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {p['dist']}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(p["entry_points"])


def _unclear(dist: str, errors: list[str], warned: list[str]) -> str | None:
    """Why the errors about the plugin distribution ``dist`` are unclear (None when they are
    clear): one names neither the distribution nor the preset, or one naming the distribution
    was not also reported as a ``PluginWarning`` with the same text (``"ImportError: text"``,
    ``"PluginWarning: text"``)."""
    if any(f"'{dist}'" not in m and "fzbad-x" not in m for m in errors):
        return f"does not name the distribution: {errors}"
    texts = {w.removeprefix("PluginWarning: ") for w in warned}
    unwarned = [m for m in errors if f"distribution '{dist}'" in m
                and m.split(": ", 1)[-1] not in texts]
    return f"not reported as a PluginWarning: {unwarned}" if unwarned else None


def _plugin_verdict(case: Case, out: dict[str, Any]) -> Outcome:
    dist = case.data["plugin"]["dist"]
    if "broke" in out or out.get("visgraph") != "optimal" or out.get("cli") != 0:
        return Outcome(case, "crash", f"the toolkit broke: {out}")
    crashes = [m for k, m in out["use"] if k == "crash"]
    if crashes:
        return Outcome(case, "crash", crashes[0])
    errors = [m for k, m in out["use"] if k == "error"]
    said = errors + out["warnings"]
    unclear = _unclear(dist, errors, out["warnings"])
    if unclear:
        return Outcome(case, "unclear message", unclear)
    if not case.must_reject:
        if errors or out["warnings"]:
            return Outcome(case, "unclear message", f"a working plugin complained: {said}")
        return Outcome(case, "accepted and solved", f"used {case.data['use']}")
    if len(errors) < len(out["use"]):
        return Outcome(case, "silently accepted", f"a broken plugin was used: {out['use']}")
    if not any(dist in w for w in out["warnings"] + errors):
        return Outcome(case, "silently accepted", f"nothing names {dist!r}: {said}")
    return Outcome(case, "clear error", errors[0][:300])


def run_plugin(case: Case, tmp: Path) -> Outcome:
    root = tmp / "site"
    root.mkdir()
    _install_plugin(root, case.data["plugin"])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), str(ROOT)])}
    # no timeout: the parent counts this child's CPU time with its worker's (a hang kills both)
    proc = subprocess.run([sys.executable, "-c", _PLUGIN_RUN, *case.data["use"]], env=env,
                          capture_output=True, text=True, cwd=tmp)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("FUZZ-RESULT ")), None)
    if line is None:
        return Outcome(case, "crash", f"exit {proc.returncode}: {proc.stderr[-400:]!r}")
    return _plugin_verdict(case, json.loads(line.removeprefix("FUZZ-RESULT ")))
