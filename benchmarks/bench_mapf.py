"""``ccbs`` on generated MAPF instances, against prioritised ``sipp``, ``orca`` and SA-APF.

Instances (``optplan.maps.mapf_gen``): random ``sparse`` and ``dense`` roadmaps
(``roadmap_instance``) and MovingAI-style grids ``empty`` (16 x 16), ``room`` (64 x 64) and
``warehouse`` (``grid_instance``), for each robot count of ``--agents`` and each seed of
``--seeds`` (``numpy.random.default_rng(seed)``).  On each:

* ``ccbs`` (``time_limit`` ``--time-limit``, default 30 s): success (``optimal`` within the
  roadmap model), wall and CPU time (``time.process_time``: the load of a shared machine
  shows as the gap between the two), the sum of arrival times; its plan checked by the validator
  (``metrics["collisions"]``, every robot reached) and by a dense pairwise check of its own;
* each baseline of ``--baselines`` (default prioritised ``sipp``, ``orca``, ``sa-apf-paper``;
  ``rng = seed``, ``time_limit`` ``--baseline-time-limit``): valid runs (success, no
  contact), runs with a contact, the sum of arrival times over ``ccbs``'s where both are valid
  (the baselines move in the plane, not on the roadmap: below 1 is possible and says the
  roadmap model is narrower than the plane), wall time;
* with ``--ccbs-cpp PATH`` (the authors' ``Continuous-CBS`` built from its public source), the
  same instance written as GraphML + task XML (``optplan.maps.write_roadmap_mapf``, a grid
  as its roadmap) and solved by it (``agent_size`` the robots' radius, the same time limit):
  its flowtime beside ``ccbs``'s sum where both solve, agreeing to 1e-6 relative or
  ``ccbs``'s lower.

Prints per (family, robots) the table, then the targets: ``ccbs`` solves >= 90 % of the
10-robot instances of ``sparse`` and of ``dense``; 0 invalid ``ccbs`` plans; every side-by-side
sum agreeing.  The load average is printed before and after.

    python benchmarks/bench_mapf.py --agents 2 5 10 --seeds 0 1 2 --families sparse empty
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import optplan as op
from optplan.geometry.timing import arrival_time
from optplan.maps.mapf import write_roadmap_mapf
from optplan.maps.mapf_gen import grid_instance, roadmap_instance

FAMILIES = ("sparse", "dense", "empty", "room", "warehouse")
GRID_SIZE = {"empty": 16, "room": 64, "warehouse": None}
BASELINES = ("sipp", "orca", "sa-apf-paper")
#: the relative agreement of two sums (the issue's 1e-6)
AGREE = 1e-6


@dataclass
class Run:
    """One solver on one instance."""

    valid: bool
    contact: bool
    total: float | None
    wall: float
    cpu: float
    status: str


@dataclass
class Row:
    """Everything measured on one instance."""

    family: str
    agents: int
    seed: int
    ccbs: Run
    checked: bool
    runs: dict[str, Run] = field(default_factory=dict)
    cpp: float | None = None
    cpp_solved: bool = False


def instance(family: str, agents: int, seed: int) -> op.Problem:
    """The instance of ``family`` with ``agents`` robots drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    if family in ("sparse", "dense"):
        return roadmap_instance(family, agents, rng)
    return grid_instance(family, agents, rng, size=GRID_SIZE[family])


def sum_of_arrivals(p: op.Problem, res: op.Result) -> float | None:
    """The sum of every robot's arrival at its goal (``None`` when one never arrives)."""
    total = 0.0
    for r in p.robots:
        t = arrival_time(p, r.id, res.paths[r.id], res.times) if r.id in res.paths else None
        if t is None:
            return None
        total += t
    return total


def run(p: op.Problem, solver: str, seed: int, limit: float) -> tuple[Run, op.Result]:
    """``solver`` on ``p`` (the validator's word on it)."""
    t0, c0 = time.perf_counter(), time.process_time()
    res = op.solve(p, solver, rng=seed, time_limit=limit)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    contact = bool(res.metrics.get("collisions"))
    valid = bool(res.success and not contact and res.metrics.get("reached"))
    return Run(valid, contact, sum_of_arrivals(p, res) if valid else None, wall, cpu,
               res.status.value), res


def dense_check(p: op.Problem, res: op.Result, samples: int = 4000) -> bool:
    """An independent check of a team plan: every pair of robots at least ``r_i + r_j``
    apart (to 1e-9 of the map) at ``samples`` times spread over the plan."""
    times = np.asarray(res.times, float)
    grid = np.linspace(0.0, float(times[-1]), samples)
    pos = {r.id: np.column_stack([np.interp(grid, times, res.paths[r.id][:, k])
                                  for k in (0, 1)]) for r in p.robots}
    tol = 1e-9 * p.extent
    robots = list(p.robots)
    for i, a in enumerate(robots):
        for b in robots[i + 1:]:
            d = np.hypot(*(pos[a.id] - pos[b.id]).T)
            if d.min() < a.radius + b.radius - tol:
                return False
    return True


def cpp_flowtime(p: op.Problem, binary: str, limit: float) -> tuple[bool, float | None]:
    """The authors' CCBS on ``p`` written as a roadmap: (solved, flowtime)."""
    with tempfile.TemporaryDirectory() as d:
        g, t = write_roadmap_mapf(p, Path(d) / "map.xml", Path(d) / "task.xml")
        cfg = Path(d) / "config.xml"
        cfg.write_text(
            "<?xml version=\"1.0\" ?>\n<root><algorithm><use_cardinal>true</use_cardinal>"
            "<use_disjoint_splitting>true</use_disjoint_splitting><hlh_type>2</hlh_type>"
            f"<agent_size>{p.robots[0].radius!r}</agent_size><timelimit>{limit:g}</timelimit>"
            "<precision>0.0000001</precision></algorithm></root>\n")
        out = subprocess.run([binary, str(g), str(t), str(cfg)], capture_output=True,
                             text=True, timeout=limit + 60).stdout
        solved = "Soulution found: true" in out or "Solution found: true" in out
        log = Path(d) / "task_log.xml"  # full precision (stdout prints 6 digits)
        summary = ET.parse(log).getroot().find(".//summary") if log.exists() else None
        flow = None if summary is None else float(summary.get("flowtime", "nan"))
    return solved, flow if solved else None


def measure(family: str, agents: int, seed: int, a: argparse.Namespace) -> Row:
    """Every solve of one instance (module docstring)."""
    p = instance(family, agents, seed)
    cc, res = run(p, "ccbs", seed, a.time_limit)
    cc.valid = cc.valid and res.status is op.Status.optimal
    row = Row(family, agents, seed, cc, dense_check(p, res) if cc.valid else True)
    for b in a.baselines:
        row.runs[b] = run(p, b, seed, a.baseline_time_limit)[0]
    if a.ccbs_cpp:
        row.cpp_solved, row.cpp = cpp_flowtime(p, a.ccbs_cpp, a.time_limit)
    return row


def _mw(xs: list[float], digits: int = 3) -> str:
    """``median / worst (largest)`` or ``-``."""
    return f"{statistics.median(xs):.{digits}f} / {max(xs):.{digits}f}" if xs else "-"


def table(rows: list[Row], baselines: list[str], cpp: bool) -> str:
    """One line per (family, robots)."""
    head = ["family", "robots", "ccbs solved (30 s)", "ccbs wall med / worst (s)",
            "ccbs CPU med / worst (s)",
            "ccbs sum med", "invalid ccbs plans"]
    for b in baselines:
        head += [f"{b} valid", f"{b} with contact", f"{b} sum / ccbs med / worst",
                 f"{b} wall med (s)"]
    if cpp:
        head += ["C++ CCBS solved", "sums agree (1e-6) or ours lower"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in dict.fromkeys((r.family, r.agents) for r in rows):
        rs = [r for r in rows if (r.family, r.agents) == key]
        ok = [r for r in rs if r.ccbs.valid]
        cells = [key[0], str(key[1]), f"{len(ok)} / {len(rs)}",
                 _mw([r.ccbs.wall for r in rs], 2), _mw([r.ccbs.cpu for r in rs], 2),
                 f"{statistics.median(r.ccbs.total for r in ok):.2f}" if ok else "-",
                 str(sum(not r.checked or (r.ccbs.status == "optimal" and not r.ccbs.valid)
                         for r in rs))]
        for b in baselines:
            runs = [r.runs[b] for r in rs]
            ratio = [r.runs[b].total / r.ccbs.total for r in ok if r.runs[b].total is not None]
            cells += [f"{sum(x.valid for x in runs)} / {len(rs)}",
                      str(sum(x.contact for x in runs)), _mw(ratio),
                      f"{statistics.median(x.wall for x in runs):.2f}"]
        if cpp:
            both = [r for r in ok if r.cpp_solved]
            agree = sum(r.cpp is not None and (abs(r.ccbs.total - r.cpp) <= AGREE * r.cpp
                                                or r.ccbs.total < r.cpp) for r in both)
            cells += [f"{sum(r.cpp_solved for r in rs)} / {len(rs)}",
                      f"{agree} / {len(both)}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def targets(rows: list[Row]) -> str:
    """The issue's targets, met or not."""
    out = []
    for fam in ("sparse", "dense"):
        rs = [r for r in rows if r.family == fam and r.agents == 10]
        if rs:
            share = sum(r.ccbs.valid for r in rs) / len(rs)
            out.append(f"* ccbs solves {100 * share:.0f} % of the 10-robot {fam} instances "
                       f"within the limit (target >= 90 %: {'met' if share >= 0.9 else 'NOT met'})")
    bad = sum(not r.checked for r in rows)
    out.append(f"* invalid ccbs plans (validator or the dense pairwise check): {bad} (target 0)")
    return "\n".join(out)


def _load() -> str:
    """The load average (1, 5, 15 min) and the cores."""
    return ", ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} cores"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    ap.add_argument("--agents", nargs="+", type=int, default=[2, 5, 10, 20, 40])
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(10)))
    ap.add_argument("--time-limit", type=float, default=30.0)
    ap.add_argument("--baseline-time-limit", type=float, default=60.0)
    ap.add_argument("--baselines", nargs="*", default=list(BASELINES))
    ap.add_argument("--ccbs-cpp", default=None,
                    help="the authors' CCBS binary (github.com/PathPlanning/Continuous-CBS)")
    a = ap.parse_args(argv)
    load0 = _load()
    rows = [measure(f, k, s, a) for f in a.families for k in a.agents for s in a.seeds]
    print(f"\n## ccbs on generated MAPF instances\n\nseeds {a.seeds}, ccbs time_limit "
          f"{a.time_limit:g} s, baselines {a.baseline_time_limit:g} s; load average before "
          f"{load0}, after {_load()}\n")
    print(table(rows, a.baselines, bool(a.ccbs_cpp)))
    print()
    print(targets(rows))


if __name__ == "__main__":
    main()
