"""Crowded circles: ``visgraph``'s ``graph`` option on a polygon of many vertices.

The scene: a 100 x 100 field, a robot of radius 2 from (10, 20) to (90, 40), a polygon of
``n`` vertices round a circle of radius 6 at (50, 30) across its straight path, a box and a
circle obstacle.  The polygon's vertex circles crowd together: from each of them the sight
lines cross the thin triangles between the polygon and the far corners of the field, so the
build's sight lines run thousands of views per circle (``benchmarks/bench_maps_scale.py``'s
maps: 34-150).  Per ``n`` (``--vertices``) and per ``graph`` option, one ``op.solve(p,
"visgraph", graph=...)`` on a cold process cache (``optplan.problem.shared.clear``): CPU s
(``time.process_time``; the machine is shared), what ``auto`` chose (``built``, or ``lazy``
when the build ran past its sight-line budget ``VIEWS_PER_CIRCLE n + VIEWS_BASE``), the
built graph's views per circle and the wall seconds of its phases (sight lines, tangents,
and the chains with their exact arc tests), and whether the three options gave the same
exact length and polyline (float64 bytes).  Two queries: *round* the polygon (the one above)
and *far* from it (from (10, 80) to (90, 90)): the lazy search pays for the circles it
expands, the build for all of them.

    python benchmarks/bench_crowded.py --vertices 1000 5000 20000
"""

from __future__ import annotations

import argparse
import math
import os
import time

import optplan as op
from optplan.geometry.tangent import tangent_graph as tg
from optplan.problem import parse_problem, shared


def crowded(n: int, far: bool = False) -> op.Problem:
    """The scene of the module docstring with a polygon of ``n`` vertices (``far``: the
    robot goes from (10, 80) to (90, 90), far from the polygon)."""
    ring = [[50 + 6 * math.cos(2 * math.pi * k / n), 30 + 6 * math.sin(2 * math.pi * k / n)]
            for k in range(n)]
    return parse_problem({
        "name": f"crowded-{n}", "bounds": [0, 0, 100, 100],
        "robots": [{"id": "r", "start": [10, 80] if far else [10, 20],
                    "goal": [90, 90] if far else [90, 40], "radius": 2.0}],
        "obstacles": [{"type": "polygon", "name": "ring", "vertices": ring},
                      {"type": "polygon", "name": "box",
                       "vertices": [[70, 20], [75, 20], [75, 45], [70, 45]]},
                      {"type": "circle", "name": "c", "center": [25, 50], "radius": 4.0}],
    })


def run(n: int, graph: str, far: bool = False) -> dict:
    """One cold ``op.solve`` with ``graph``: CPU s, status, length, polyline bytes and the
    map's graph afterwards."""
    shared.clear()
    p = crowded(n, far)
    t0 = time.process_time()
    res = op.solve(p, "visgraph", graph=graph)
    cpu = time.process_time() - t0
    g = tg.tangent_graph(p.obstacle_set(2.0, known_only=True))
    return {"cpu": cpu, "status": res.status.value, "graph": g,
            "answer": (res.metrics["lengths_exact"].get("r"), res.paths["r"].tobytes())}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vertices", type=int, nargs="+", default=[1000, 5000, 20000])
    args = ap.parse_args(argv)
    run(1000, "built")  # imports and compiled kernels (the sight lines: 1005 circles) out
    load0 = os.getloadavg()[0]
    print(f"visgraph on crowded circles: one cold op.solve per option, CPU s; sight-line "
          f"budget {tg.VIEWS_PER_CIRCLE} views per circle + {tg.VIEWS_BASE:,}; "
          f"load average {load0:.1f}\n")
    print("| polygon vertices | circles | views per circle (built) | auto chose "
          "| auto CPU s: round / far | lazy CPU s: round / far | built CPU s: round / far "
          "| built phases wall s: sight lines / tangents / chains | status | same answers |")
    print("|---:|---:|---:|:---|---:|---:|---:|:---|:---|:---|")
    for n in args.vertices:
        r = {g: run(n, g) for g in ("auto", "lazy", "built")}
        f = {g: run(n, g, True) for g in ("auto", "lazy", "built")}
        gb = r["built"]["graph"]
        ph = gb.stats["build_wall_s"]
        chose = "lazy" if r["auto"]["graph"].crowded else "built"
        same = (len({x["answer"] for x in r.values()}) == 1
                and len({x["answer"] for x in f.values()}) == 1)
        print(f"| {n} | {gb.circles.n} | {gb.sightlines.views / gb.circles.n:.0f} | {chose} "
              f"| {r['auto']['cpu']:.2f} / {f['auto']['cpu']:.2f} "
              f"| {r['lazy']['cpu']:.2f} / {f['lazy']['cpu']:.2f} "
              f"| {r['built']['cpu']:.2f} / {f['built']['cpu']:.2f} "
              f"| {ph['sightlines']:.2f} / {ph['tangents']:.2f} / {ph['chains']:.2f} "
              f"| {'/'.join(sorted({x['status'] for x in [*r.values(), *f.values()]}))} "
              f"| {same} |")
    print(f"\nload average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
