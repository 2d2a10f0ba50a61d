"""The exact graph at benchmark scale: import, graph build and a batch of queries on one map.

For each map kind and size (``--kinds``, ``--sizes``) a MovingAI map and its ``.scen``
(``--queries`` lines, seed ``--seed``) are generated with
``optplan.maps.movingai_gen.generate_benchmark`` in a temporary directory, then:

* **import**: ``optplan.maps.read_scen`` (the ``.map`` read, its obstacle cells turned into
  conservative polygons, one validated problem per line sharing one obstacle set: the exact
  collision engine of a point robot, made once by the import to check the lines' ends and
  cached on the problems, as every solver and the validator use it);
* **build**: the :class:`~optplan.geometry.tangent.tangent_graph.TangentGraph` of that obstacle set
  (the circles; with ``--build`` the whole graph, else the successors of a circle are made
  when a query first expands it and kept for the later queries);
* **queries**: every ``.scen`` line answered on that one graph, each with a budget of
  ``--budget`` CPU seconds (a query stopped by it counts as unfinished; its time is the
  budget, so the median and the worst are lower bounds when some are unfinished); query times
  are CPU milliseconds (``time.process_time``: the machine is shared, wall times would
  measure the other jobs);
* **memory**: the peak resident set size of the process (``resource.getrusage``), and the
  bytes the graph stores;
* **op.solve** (unless ``--no-solve``): every line through ``op.solve(p, "visgraph")``
  (its default ``graph = "auto"``; ``time_limit`` the budget), as a user who reads the
  ``.scen`` and solves line by line, on a cold process cache: the first solve makes the
  map's shared graph (``optplan.problem.shared``; built and compiled from ``SIGHTLINES_MIN``
  circles on), its wall s (CPU s) is the ``op.solve first s`` column; the later ones' CPU
  ms (median / worst) the ``op.solve ms`` column (the query, the polyline's validation and
  the result); how many lengths equal the explicit graph API's to the bit; the peak RSS
  after them (both graphs are alive then).

Beside it, ``extremitypathfinder`` (a point-robot visibility-graph library, optional: the
``bench`` extra) on the same polygons: the free space of the imported obstacles inside the
bounds (shapely), one environment per connected part of it, ``prepare`` (its graph) timed as
its build, and the same queries; every length must agree with optplan's to 1e-9 relative
(disagreements are counted and listed, a shorter extremitypathfinder length with the length of
its path inside the obstacles, measured with shapely).  Maps with more than
``--epf-max-vertices`` polygon vertices are skipped for it (its build grows with the square of
the vertices).

Import and build times are wall seconds (CPU seconds, ``time.process_time``, in brackets),
query times CPU milliseconds, on a machine shared with other jobs; ``reference ms`` is the
machine's speed just before each map (:func:`reference_ms`: a fixed workload in two threads),
so that a run in a slow spell of the machine shows as one.  ``--sightlines on|off``
sets :class:`TangentGraph`'s option (default: from ``SIGHTLINES_MIN`` circles on);
``--build`` makes the whole graph first (:meth:`TangentGraph.build`: its time is the build;
the queries are then the compiled search of ``optplan/geometry/tangent/chain_search.py``, whose
expanded nodes are departure points, not arrivals).
``python benchmarks/bench_maps_scale.py --sizes 1024 --queries 1000 --build
--epf-max-vertices 0`` is the issue's scale (1024 x 1024 street and room maps, the graph built
once, extremitypathfinder skipped: its build grows with the square of the vertices); see
``docs/solvers/visgraph.md``.
"""

from __future__ import annotations

import argparse
import math
import resource
import statistics
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import box
from shapely.geometry.polygon import orient

from optplan.geometry.tangent.tangent_graph import MAX_GRAPH_BYTES, TangentGraph, tangent_graph
from optplan.maps import read_scen
from optplan.maps.movingai_gen import generate_benchmark

#: Relative agreement required between optplan's and extremitypathfinder's lengths.
REL = 1e-9


def _rss_mib() -> float:
    """Peak resident set size of this process so far (MiB; Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


class _Clock:
    """Wall and CPU seconds of a block."""

    def __enter__(self) -> _Clock:
        self.w, self.c = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc) -> None:
        self.wall = time.perf_counter() - self.w
        self.cpu = time.process_time() - self.c


def _vertices(problem) -> int:
    return sum(len(shapely.get_coordinates(o.geometry)) - 1 - len(o.geometry.interiors)
               for o in problem.obstacles)


def run_optplan(scen: Path, budget: float, sightlines: bool | None = None,
                full: bool = False, repeat: int = 1) -> dict:
    """Import, build and the queries of one ``.scen`` on one :class:`TangentGraph`
    (``sightlines``: its option; ``full``: :meth:`TangentGraph.build` before the queries;
    ``repeat``: the import and the build made that many times, each from scratch, the
    queries on the last)."""
    ti, tb = [], []
    for _ in range(repeat):
        probs = graph = p0 = oset = None  # the previous repeat's freed first
        with _Clock() as ci:
            probs = read_scen(scen)
        ti.append(ci)
        p0 = probs[0]
        with _Clock() as cb:
            oset = p0.obstacle_set(p0.robots[0].radius)  # made by the import (cached)
            graph = TangentGraph(oset, sightlines=sightlines,
                                 max_bytes=2**30 if full else MAX_GRAPH_BYTES)
            if full:
                graph.build()
        tb.append(cb)
    times, cpus, lengths, unfinished, expanded = [], [], [], 0, []
    for p in probs:
        r = p.robots[0]
        c0 = time.process_time()
        with _Clock() as tq:
            res = graph.shortest_path(r.start, r.goal,
                                      stop=lambda c0=c0: time.process_time() - c0 > budget)
        stopped = bool(res.info.get("stopped"))
        unfinished += stopped
        times.append(budget if stopped else tq.cpu)
        cpus.append(tq.cpu)
        lengths.append(math.nan if stopped else res.length)
        expanded.append(res.info["n_expanded"])
    return {"problems": probs, "vertices": _vertices(p0), "circles": graph.circles.n,
            "expanded": expanded, "stats": dict(graph.stats),
            "import": ti, "build": tb, "times": times,
            "cpus": cpus, "lengths": lengths, "unfinished": unfinished,
            "graph_mib": graph.nbytes / 2**20, "rss": _rss_mib()}


def run_solve(probs: list, budget: float, lengths: list[float]) -> dict:
    """``op.solve(p, "visgraph")`` on each problem of the import, in line order, on a cold
    process cache (:func:`optplan.problem.shared.clear`): the first solve makes the map's
    graph (built and compiled from ``SIGHTLINES_MIN`` circles), the later ones only query it.
    Per solve: CPU and wall seconds, its ``lengths_exact`` compared with the explicit
    graph API's ``lengths`` bit for bit; the peak resident set size after them."""
    import optplan as op
    from optplan.problem import shared

    shared.clear()
    clocks, same, certified = [], 0, 0
    for p, want in zip(probs, lengths):
        with _Clock() as c:
            res = op.solve(p, "visgraph", time_limit=budget)
        clocks.append(c)
        got = res.metrics["lengths_exact"].get(p.robots[0].id, math.inf)
        same += got == want or (math.isnan(want) and res.status != "optimal")
        certified += res.status == "optimal"
    r = probs[0].robots[0]
    graph = tangent_graph(probs[0].obstacle_set(r.radius, known_only=True))
    return {"first": clocks[0], "times": [c.cpu for c in clocks[1:]] or [clocks[0].cpu],
            "same": same, "optimal": certified, "rss": _rss_mib(),
            "graph_mib": graph.nbytes / 2**20, "built": graph.chains is not None}


def reference_ms() -> float:
    """The machine's speed at the moment: wall milliseconds of a fixed workload, two threads
    each sorting ``2**21`` seeded random floats (numpy releases the GIL while it sorts), the
    median of three.  On a shared machine a slow run of the benchmark comes with a slow
    reference (the build, in two threads, is the figure it resembles most)."""
    x = np.random.default_rng(0).random(2**21)
    times = []
    with ThreadPoolExecutor(2) as pool:
        for _ in range(3):
            t = time.perf_counter()
            list(pool.map(np.sort, [x, x[::-1]]))
            times.append(1e3 * (time.perf_counter() - t))
    return statistics.median(times)


def _free_parts(problem) -> list:
    """The free space inside the bounds (shapely), one polygon per connected part."""
    blocked = shapely.union_all([o.geometry for o in problem.obstacles])
    free = box(*problem.bounds).difference(blocked)
    return [orient(q, 1.0) for q in getattr(free, "geoms", [free]) if q.area > 0]


def run_epf(probs: list) -> dict | None:
    """extremitypathfinder on the free space of ``probs[0]``'s obstacles, the same queries."""
    try:
        from extremitypathfinder import PolygonEnvironment
    except ImportError:
        return None
    parts = _free_parts(probs[0])
    envs: dict[int, object] = {}
    with _Clock() as tb:
        for k, q in enumerate(parts):
            env = PolygonEnvironment()
            holes = [np.asarray(h.coords)[:-1] for h in q.interiors]  # clockwise (orient)
            env.store(np.asarray(q.exterior.coords)[:-1], holes)  # store also prepares
            envs[k] = env
    times, lengths, paths = [], [], []
    for p in probs:
        r = p.robots[0]
        s = shapely.points(r.start)
        k = next((k for k, q in enumerate(parts) if q.covers(s)), None)
        path, length = None, None
        with _Clock() as tq:
            if k is not None:
                path, length = envs[k].find_shortest_path(tuple(r.start), tuple(r.goal))
        times.append(tq.wall)
        lengths.append(math.inf if length is None else float(length))
        paths.append(path)
    return {"build": (tb.wall, tb.cpu), "times": times, "lengths": lengths, "paths": paths,
            "rss": _rss_mib()}


def _through_obstacles(path, blocked) -> float:
    """Length of ``path`` inside the interior of ``blocked`` (shapely; 0 along a boundary)."""
    if not path or len(path) < 2:
        return 0.0
    line = shapely.LineString(path)
    return float(line.intersection(blocked).length
                 - line.intersection(blocked.boundary).length)


def _fmt(pair: tuple[float, float]) -> str:
    return f"{pair[0]:.2f} ({pair[1]:.2f})"


def _fmt_runs(clocks: list[_Clock]) -> str:
    """One run: wall (CPU); several: the median wall time (the fastest)."""
    if len(clocks) == 1:
        return _fmt((clocks[0].wall, clocks[0].cpu))
    walls = [c.wall for c in clocks]
    return f"{statistics.median(walls):.2f} ({min(walls):.2f})"


def _solve_cells(solved: dict | None, n: int) -> str:
    """The op.solve columns: first solve wall s (CPU s), the later ones' CPU ms median /
    worst, the lines whose length is the graph API's to the bit, the peak RSS."""
    if solved is None:
        return "skipped | skipped | skipped | skipped"
    return (f"{_fmt((solved['first'].wall, solved['first'].cpu))} | {_ms(solved['times'])} | "
            f"{solved['same']} of {n} | {solved['rss']:.0f}")


def _ms(xs: list[float]) -> str:
    return f"{1e3 * statistics.median(xs):.1f} / {1e3 * max(xs):.0f}"


def _agreement(ours: list[float], epf: dict, problem) -> tuple[int, int, list[str]]:
    """Compared queries, disagreements (> REL relative) and a note per disagreement: a
    shorter extremitypathfinder path is measured against the obstacles (shapely)."""
    blocked = shapely.union_all([o.geometry for o in problem.obstacles])
    n, bad, notes = 0, 0, []
    for k, (a, b) in enumerate(zip(ours, epf["lengths"])):
        if math.isnan(a):
            continue
        n += 1
        if a == b or (math.isfinite(a) and abs(a - b) <= REL * max(abs(a), 1.0)):
            continue
        bad += 1
        why = (f"its path runs {_through_obstacles(epf['paths'][k], blocked):.3f} inside "
               "obstacles" if b < a else "longer")
        notes.append(f"line {k + 1}: optplan {a:.9f}, extremitypathfinder {b:.9f} ({why})")
    return n, bad, notes


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="street,room")
    ap.add_argument("--sizes", default="64,128")
    ap.add_argument("--queries", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--budget", type=float, default=10.0, help="CPU seconds per query")
    ap.add_argument("--epf-max-vertices", type=int, default=3000)
    ap.add_argument("--show", type=int, default=3, help="disagreements listed per map")
    ap.add_argument("--repeat", type=int, default=1,
                    help="imports and builds per map, each from scratch (the table shows the "
                         "median wall time and, in brackets, the fastest)")
    ap.add_argument("--sightlines", choices=("auto", "on", "off"), default="auto",
                    help="TangentGraph(sightlines=): auto (from SIGHTLINES_MIN circles), "
                         "on or off")
    ap.add_argument("--build", action="store_true",
                    help="make the whole graph (TangentGraph.build) before the queries, "
                         "which then run the compiled search; its time is the build time")
    ap.add_argument("--no-solve", action="store_true",
                    help="skip the op.solve columns (every line through op.solve on a cold "
                         "process cache)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1, got {args.repeat}")
    sight = {"auto": None, "on": True, "off": False}[args.sightlines]
    print("exact tangent graph at scale: point robot, one TangentGraph per map "
          f"(sightlines {args.sightlines}{', whole graph built first' if args.build else ''}), "
          f"{args.queries} .scen queries per map, seed {args.seed}, query budget "
          f"{args.budget:g} CPU s; wall s (CPU s); query CPU ms: median / worst; shared 2-core "
          "machine; reference: a fixed two-thread workload (ms) just before each map"
          + (f"; import and build: median wall s of {args.repeat} runs from scratch (fastest)"
             if args.repeat > 1 else ""))
    print()
    print("| map | vertices | circles | import s | build s | query ms | unfinished | graph MiB "
          "| peak RSS MiB | op.solve first s | op.solve ms | op.solve = graph "
          "| op.solve peak RSS MiB | extremitypathfinder build s | its query ms "
          "| lengths agree | reference ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---|---:|")
    notes: list[str] = []
    work: list[str] = []  # the search's and the graph's counts per map
    for kind in args.kinds.split(","):
        for size in (int(s) for s in args.sizes.split(",")):
            with tempfile.TemporaryDirectory() as d:
                gen = generate_benchmark(kind, size, d, rng=np.random.default_rng(args.seed),
                                         queries=args.queries)
                ref = reference_ms()
                ours = run_optplan(gen.scen_path, args.budget, sight, args.build, args.repeat)
                solved = (None if args.no_solve else
                          run_solve(ours["problems"], args.budget, ours["lengths"]))
                epf = (run_epf(ours["problems"])
                       if ours["vertices"] <= args.epf_max_vertices else None)
            if epf is None:
                e_build = e_q = agree = "skipped"
            else:
                n, bad, bad_notes = _agreement(ours["lengths"], epf, ours["problems"][0])
                e_build, e_q = _fmt(epf["build"]), _ms(epf["times"])
                agree = f"{n - bad} of {n}"
                notes += [f"{kind}-{size} {x}" for x in bad_notes[:args.show]]
            print(f"| {kind}-{size} | {ours['vertices']} | {ours['circles']} | "
                  f"{_fmt_runs(ours['import'])} | {_fmt_runs(ours['build'])} | "
                  f"{_ms(ours['times'])} | "
                  f"{ours['unfinished']} | {ours['graph_mib']:.0f} | {ours['rss']:.0f} | "
                  f"{_solve_cells(solved, len(ours['problems']))} | "
                  f"{e_build} | {e_q} | {agree} | {ref:.0f} |", flush=True)
            if solved is not None:
                work.append(f"{kind}-{size}: op.solve: {solved['optimal']} optimal of "
                            f"{len(ours['problems'])}, the map's shared graph "
                            f"({'built' if solved['built'] else 'lazy'}) "
                            f"{solved['graph_mib']:.0f} MiB")
            st, ex = ours["stats"], ours["expanded"]
            work.append(f"{kind}-{size}: expanded {'nodes' if args.build else 'arrivals'} "
                        "per query median "
                        f"{statistics.median(ex):.0f}, worst {max(ex)} (unfinished queries: "
                        f"up to the budget); stored edges {st['edges']}, exact segment tests "
                        f"{st['segment_tests']}")
            if args.repeat > 1:
                work.append(f"{kind}-{size}: wall s of each repeat: import " + ", ".join(
                    f"{c.wall:.2f}" for c in ours["import"]) + "; build " + ", ".join(
                    f"{c.wall:.2f}" for c in ours["build"]))
            if "build_wall_s" in st:
                work.append(f"{kind}-{size}: build wall s: " + ", ".join(
                    f"{k} {v:.2f}" for k, v in st["build_wall_s"].items())
                    + f"; circle pairs that see each other {st['build_pairs']}")
    for line in work:
        print(line)
    for line in notes:
        print("disagreement:", line)


if __name__ == "__main__":
    main()
