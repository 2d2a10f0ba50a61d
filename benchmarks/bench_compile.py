"""First-run cost of the numba kernels: compile CPU seconds per kernel module with an empty
cache, and the first- and second-solve CPU times of ``visgraph``, ``ipso``, ``sa-apf-paper``
and ``hybrid-paper``.

Each case runs in a fresh Python process whose ``NUMBA_CACHE_DIR`` is a new empty temporary
directory, so every kernel it needs is compiled there (nothing is read from the package's
``__pycache__`` or from the user cache; only from the package's shipped kernels,
``optplan/_kernels``, which an installed wheel has, ``--wheel``, and a checkout has not unless
someone built them into it).  The child measures CPU seconds
(``time.process_time``: every thread of the process; the machine is shared, so wall times
would measure the other users), in this order:

* ``import``: ``import optplan`` (no kernel compiles here: each compiles, with its one
  signature, on its first call, :mod:`optplan.geometry.compiled.jit`);
* ``first solve``: the first ``op.solve(problem, solver, rng=0)`` (the kernels it calls
  compile here);
* ``second solve``: the same call again in the same process (no compilation);
* ``warm import`` and ``warm first solve``: a second fresh process on the now filled cache (what
  every later process pays: loading the cached machine code).

Compile time per kernel module comes from numba's ``numba:compile`` events (CPU seconds
between the start and the end of a dispatcher's compilation, minus the compilations nested in
it), summed over the dispatchers of a module, over one process that imports optplan and runs
the four solves (one empty cache).  The targets of issue 28 are printed beside the times:
first ``ipso`` solve (import included) <= 10 s CPU, first ``visgraph`` solve <= 5 s CPU.

``--wheel`` measures an installed wheel instead of the checkout: the wheel is built from the
checkout with ``pip wheel`` (its build hook compiles every kernel for the generic CPU into
``optplan/_kernels``, :mod:`optplan.geometry.compiled.kernel_cache`), installed without dependencies
into a temporary directory, and the children import optplan from there (still with an empty
``NUMBA_CACHE_DIR``: what a fresh installation on a new machine pays).

``--installed`` measures the checkout as the two-command start leaves it: before the cold
process, a fresh process on the same empty cache runs ``make``'s install step,
:func:`optplan.geometry.compiled.kernel_cache.compile_all` (every kernel compiled for this CPU
into numba's cache; its CPU seconds are printed), so the cold columns are the first solves
after ``make demo`` or ``make test`` installed optplan.

``--together N`` also starts N processes at once per case on one empty cache and prints the
import + first solve CPU of each: a kernel holds a lock on its cache entry while it compiles,
so the others wait and load it
(:meth:`optplan.geometry.compiled.kernel_cache.KernelCache.compiling`); their sum is about one
compilation, not N.

``--numba-opt N`` runs the children with ``NUMBA_OPT=N`` (numba's LLVM optimisation level,
process-wide; default 3) to see how much of the compile time is LLVM's optimisation.

Run: ``.venv/bin/python benchmarks/bench_compile.py [--cases visgraph ipso ...] [--wheel]
[--together 2] [--numba-opt 0] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

#: name -> (problem, solver): the cases of issue 28
CASES = {
    "visgraph": ("paper-env1", "visgraph"),
    "ipso": ("paper-env1", "ipso"),
    "sa-apf-paper": ("paper-warehouse", "sa-apf-paper"),
    "hybrid-paper": ("paper-warehouse", "hybrid-paper"),
}
#: CPU-second targets of issue 28 (import + first solve in a fresh process, empty cache)
TARGETS = {"visgraph": 5.0, "ipso": 10.0}


def _child(cases: list[str]) -> dict:
    """Run in the fresh process: import, then each case twice; CPU seconds and the compile
    CPU per dispatcher."""
    from numba.core import event

    stack: list[list[float]] = []
    per_fn: dict[str, float] = {}

    class _Listener(event.Listener):
        def on_start(self, ev):
            stack.append([time.process_time(), 0.0])

        def on_end(self, ev):
            t0, nested = stack.pop()
            took = time.process_time() - t0
            if stack:
                stack[-1][1] += took
            disp = ev.data["dispatcher"]
            name = f"{disp.py_func.__module__}:{disp.py_func.__qualname__}"
            per_fn[name] = per_fn.get(name, 0.0) + took - nested

    event.register("numba:compile", _Listener())
    out: dict = {"per_fn": per_fn, "cases": {}}
    t = time.process_time()
    import optplan as op

    out["import"] = time.process_time() - t
    out["file"] = op.__file__
    for case in cases:
        problem, solver = CASES[case]
        times = []
        for _ in range(2):
            t = time.process_time()
            op.solve(problem, solver, rng=0)
            times.append(time.process_time() - t)
        out["cases"][case] = times
    return out


def run_child(cases: list[str], cache: str, opt: int | None = None,
              site: str | None = None) -> dict:
    """A fresh interpreter with ``NUMBA_CACHE_DIR=cache`` (and ``NUMBA_OPT=opt``) running
    :func:`_child`; with ``site``, optplan is imported from that directory (an installed
    wheel, :func:`install_wheel`), not from the checkout."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    if opt is not None:
        env["NUMBA_OPT"] = str(opt)
    if site is not None:
        env["PYTHONPATH"] = site
    code = (f"import json, sys; sys.path.insert(0, {os.path.dirname(__file__)!r}); "
            f"import bench_compile as b; print(json.dumps(b._child({cases!r})))")
    # cwd: the checkout's parent for a wheel (so that `import optplan` cannot find the checkout)
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=True, cwd=site or os.getcwd())
    out = json.loads(p.stdout.strip().splitlines()[-1])
    if site is not None and not out["file"].startswith(site):
        raise RuntimeError(f"the child imported optplan from {out['file']}, not from {site}")
    return out


def install_step(cache: str, site: str | None = None) -> dict:
    """``make``'s install step in a fresh interpreter on ``cache``: every kernel compiled
    (:func:`~optplan.geometry.compiled.kernel_cache.compile_all`); its CPU seconds."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    code = ("import json, time; t = time.process_time(); "
            "from optplan.geometry.compiled.kernel_cache import compile_all; n = compile_all(); "
            "print(json.dumps({'kernels': n, 'cpu': time.process_time() - t}))")
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=True, cwd=site or os.getcwd())
    return json.loads(p.stdout.strip().splitlines()[-1])


def install_wheel(tmp: str) -> str:
    """Build optplan's wheel from this checkout (``pip wheel``, in pip's isolated build
    environment: the build hook compiles the shipped kernels) and install it without its
    dependencies into ``tmp/site`` (the dependencies come from this environment); returns
    that directory."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    dist, site = os.path.join(tmp, "dist"), os.path.join(tmp, "site")
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", dist, root],
                   check=True)
    (whl,) = [f for f in os.listdir(dist) if f.endswith(".whl")]
    print(f"built {whl} in {time.perf_counter() - t:.0f} s (wall, the kernels' compilation "
          "included)")
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", site,
                    os.path.join(dist, whl)], check=True)
    return site


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    ap.add_argument("--numba-opt", type=int, default=None, choices=range(4),
                    help="NUMBA_OPT of the children (default: numba's, 3)")
    ap.add_argument("--modules", action=argparse.BooleanOptionalAction, default=True,
                    help="also the per-module table (one more process, all cases)")
    ap.add_argument("--json", default=None, help="also write the measurements here")
    ap.add_argument("--together", type=int, default=0, metavar="N",
                    help="also start N processes at once per case on one empty cache (they "
                         "compile each kernel once: the others wait and load it)")
    ap.add_argument("--installed", action="store_true",
                    help="run make's install step (every kernel compiled for this CPU) on "
                         "each empty cache before the cold process")
    ap.add_argument("--wheel", action="store_true",
                    help="build and install the wheel (its shipped kernels) into a temporary "
                         "directory and measure that installation instead of the checkout")
    args = ap.parse_args(argv)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory(prefix="optplan-wheel-") as tmp:
        site = install_wheel(tmp) if args.wheel else None
        return _measure(args, site)


def _measure(args: argparse.Namespace, site: str | None) -> int:
    """The tables of :func:`main` for the checkout (``site`` None) or an installed wheel."""
    rows, record, steps = [], {}, []
    for case in args.cases:
        with tempfile.TemporaryDirectory(prefix="optplan-numba-") as cache:
            if args.installed:
                steps.append(install_step(cache, site))
            cold = run_child([case], cache, args.numba_opt, site)
            warm = run_child([case], cache, args.numba_opt, site)
        first = cold["import"] + cold["cases"][case][0]
        target = TARGETS.get(case)
        record[case] = {"cold": cold, "warm": warm}
        rows.append(f"| {case} | {cold['import']:.2f} | {cold['cases'][case][0]:.2f} | "
                    f"{first:.2f} | {f'<= {target:.0f}' if target else '-'} | "
                    f"{cold['cases'][case][1]:.2f} | {warm['import']:.2f} | "
                    f"{warm['cases'][case][0]:.2f} |")
    where = (f"optplan installed from its wheel ({site}; its shipped kernels)" if site
             else "optplan from this checkout")
    if steps:
        cpu = [x["cpu"] for x in steps]
        where += (f", after make's install step on each empty cache ({steps[0]['kernels']} "
                  f"kernels compiled: {min(cpu):.1f} to {max(cpu):.1f} CPU s)")
    cache = ("the NUMBA_CACHE_DIR the install step filled" if steps
             else "empty NUMBA_CACHE_DIR")
    print(f"\nCPU seconds per case, {where}, fresh process, {cache} (cold), then "
          "a second process on that cache (warm):\n")
    print("| case | import | first solve | import + first | target | second solve | "
          "warm import | warm first solve |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    if args.together > 1:
        _together_table(args, site, record)
    if args.modules:
        _module_table(record, args.numba_opt, site)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(record, f, indent=1)
    return 0


def _together_table(args: argparse.Namespace, site: str | None, record: dict) -> None:
    """Print, per case, the import + first solve CPU of ``args.together`` processes started
    at once on one empty cache (beside one process alone, the cold column above)."""
    from concurrent.futures import ThreadPoolExecutor

    n = args.together
    print(f"\n{n} processes started at once per case, one empty NUMBA_CACHE_DIR: import + "
          "first solve CPU seconds of each, and their sum (one process alone: the table "
          "above):\n")
    print("| case | each | sum |")
    print("|---|---|---|")
    for case in args.cases:
        with tempfile.TemporaryDirectory(prefix="optplan-numba-") as cache, \
                ThreadPoolExecutor(n) as pool:
            futs = [pool.submit(run_child, [case], cache, args.numba_opt, site)
                    for _ in range(n)]
            outs = [f.result() for f in futs]
        each = [o["import"] + o["cases"][case][0] for o in outs]
        record.setdefault("together", {})[case] = outs
        print(f"| {case} | {', '.join(f'{x:.2f}' for x in sorted(each))} | {sum(each):.2f} |")


def _module_table(record: dict, opt: int | None, site: str | None) -> None:
    """Print the compile CPU per kernel module (one process, the four cases, empty cache)."""
    with tempfile.TemporaryDirectory(prefix="optplan-numba-") as cache:
        allc = run_child(list(CASES), cache, opt, site)
    record["all"] = allc
    mods: dict[str, float] = {}
    for name, sec in allc["per_fn"].items():
        mod = name.split(":")[0]
        mods[mod] = mods.get(mod, 0.0) + sec
    print("\nCompile CPU seconds per kernel module (numba:compile events, nested compilations "
          "apart; one process running the four cases on an empty cache):\n")
    print("| module | compile CPU s | dispatchers |")
    print("|---|---|---|")
    for mod, sec in sorted(mods.items(), key=lambda kv: -kv[1]):
        n = sum(1 for k in allc["per_fn"] if k.split(":")[0] == mod)
        print(f"| {mod} | {sec:.2f} | {n} |")
    print(f"| total | {sum(mods.values()):.2f} | {len(allc['per_fn'])} |")


if __name__ == "__main__":
    raise SystemExit(main())
