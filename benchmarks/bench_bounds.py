"""The bounds are a wall (issue 30): no NULL optimum on maps whose free space reaches the edge.

Prints one markdown table per source, one line per group of queries, with the number of
queries, how many ``op.solve(problem, "visgraph")`` returned ``optimal``, ``infeasible`` or
another status, how many have ``reference_optimum(problem)["optimum"] is None`` although a
path exists (target 0), how many optima leave the independent band ``straight line <= optimum
<= upper bound`` (target 0), in how many the wall *binds* (the optimum of the same query on
the map grown by its size on every side is shorter; a consistency check too: it is never
longer), and the median / worst ``op.solve`` time of a query (the first query of a map
includes building its obstacle set).  Sources:

1. **catalogue**: every scene of ``op.list_problems()``.  A path exists when ``visgraph``
   on the known map (``problem.known_view()``) returns a path the validator accepts; the band
   has no upper bound here (``lower only``).  Scenes with temporary or moving obstacles are
   ``approximate`` by design (the known-map plan runs through them); their validator verdicts
   are listed under the table.
2. **occupancy maps** (``optplan.catalog.map_files()``, ROS ``map_server`` YAML + PNG,
   imported with ``optplan.maps.import_map``, robot radius 0.3 m): the full maps (walled at
   the image edge) and random square crops whose free space reaches the crop's edge.  Starts
   and goals are centres of *safe* cells (Euclidean distance to every obstacle cell at least
   ``r + grow + simplify + sqrt 2`` cells, so that every 8-neighbour move between safe cells
   is free of the imported polygons inflated by ``r``; centre at least ``r`` from the edge),
   half of the queries from the band of safe cells nearest the image edge.  A path exists
   (and its length is the band's upper bound) when the pair is connected in the safe-cell
   graph; the grid path is also checked with shapely against the problem's polygons.
3. **MovingAI-type maps without a border**: random ``.map`` files (densities 10, 20, 30 %,
   sizes ``--size``, seeded) and ``.scen`` files whose ``optimal_length`` is this script's own
   8-connected grid Dijkstra (``scipy.sparse.csgraph``; diagonal moves cost sqrt 2 and need
   both adjacent cardinal cells free, MovingAI's rule), start/goal cells connected on the grid,
   half of them on the border rows/columns; read back with ``optplan.maps.read_scen`` (point
   robots).  The band's upper bound is the ``.scen`` octile length
   (``optplan.maps.scen_octile_length``).  Files go to a temporary directory.

Run: ``python benchmarks/bench_bounds.py [--seeds 3] [--size 32,64] [--queries 20]``
(default: about 1.5 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra

import optplan as op
from optplan.catalog import map_files
from optplan.maps import (
    Grid,
    Robots,
    SceneOptions,
    import_map,
    read_ros_yaml,
    read_scen,
    scen_octile_length,
)
from optplan.solver import reference_optimum

SQRT2 = math.sqrt(2.0)
#: Relative tolerance of the band check (the geometric tolerance is 1e-9 x the map diagonal).
BAND_REL = 1e-9
#: Robot radius on the occupancy maps (m), as in the catalogue's office/warehouse scenes.
MAP_RADIUS = 0.3
#: ``import_map``'s default growth + simplification (cells): the polygons lie in
#: ``U + disc(GROW_SIMPLIFY)`` (``optplan.maps.grid_polygons``).
GROW_SIMPLIFY = 0.5 + 0.5
DENSITIES = (0.10, 0.20, 0.30)
CROP = 200  # cells (10 m at 5 cm)


# --------------------------------------------------------------------------------------
# grids: 8-connected Dijkstra with MovingAI's corner rule
# --------------------------------------------------------------------------------------


def octile_graph(free: np.ndarray) -> coo_matrix:
    """The 8-connected graph of the free cells (node ``row * W + col``): cardinal moves cost
    1, diagonal moves sqrt 2 and only when both adjacent cardinal cells are free."""
    free = np.asarray(free, dtype=bool)
    h, w = free.shape
    idx = np.arange(h * w).reshape(h, w)
    rows, cols, costs = [], [], []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            r0, r1 = max(0, -dr), h - max(0, dr)
            c0, c1 = max(0, -dc), w - max(0, dc)
            ok = free[r0:r1, c0:c1] & free[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
            if dr and dc:  # no corner cutting
                ok &= free[r0 + dr:r1 + dr, c0:c1] & free[r0:r1, c0 + dc:c1 + dc]
            a = idx[r0:r1, c0:c1][ok]
            rows.append(a)
            cols.append(a + dr * w + dc)
            costs.append(np.full(a.size, SQRT2 if dr and dc else 1.0))
    return coo_matrix((np.concatenate(costs), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(h * w, h * w)).tocsr()


def octile_lengths(free: np.ndarray, sources: list[tuple[int, int]],
                   predecessors: bool = False):
    """Grid shortest-path lengths (cells) from each source ``(row, col)`` to every cell
    (``inf`` when unreachable), optionally with the predecessor matrix."""
    w = free.shape[1]
    out = dijkstra(octile_graph(free), directed=True, indices=[r * w + c for r, c in sources],
                   return_predecessors=predecessors)
    return out


def grid_route(pred: np.ndarray, w: int, goal: tuple[int, int]) -> list[tuple[int, int]]:
    """Cells ``(row, col)`` of the Dijkstra route ending at ``goal`` (one predecessor row)."""
    k, route = goal[0] * w + goal[1], []
    while k >= 0:
        route.append(divmod(int(k), w))
        k = pred[k]
    return route[::-1]


def border_mask(shape: tuple[int, int]) -> np.ndarray:
    m = np.zeros(shape, dtype=bool)
    m[0, :] = m[-1, :] = m[:, 0] = m[:, -1] = True
    return m


# --------------------------------------------------------------------------------------
# MovingAI-type maps and scenarios
# --------------------------------------------------------------------------------------


def random_movingai(rng: np.random.Generator, height: int, width: int,
                    density: float) -> np.ndarray:
    """A random blocked mask (``True`` = ``@``), no border of obstacles."""
    return rng.random((height, width)) < density


def write_map(path: Path, blocked: np.ndarray) -> Path:
    h, w = blocked.shape
    rows = ["".join("@" if b else "." for b in row) for row in blocked]
    grid = "\n".join(rows)
    path.write_text(f"type octile\nheight {h}\nwidth {w}\nmap\n{grid}\n", encoding="ascii")
    return path


def pick_scen(rng: np.random.Generator, blocked: np.ndarray, n: int
              ) -> list[tuple[tuple[int, int], tuple[int, int], float]]:
    """``n`` grid-connected ``(start, goal, octile length)`` pairs, cells as ``(x, y)``
    (column, row from the top); every second start on the border rows/columns, every fourth
    goal too."""
    free = ~blocked
    h, w = free.shape
    _, label = connected_components(octile_graph(free), directed=False)
    label = label.reshape(h, w)
    sizes = np.bincount(label[free].ravel(), minlength=label.max() + 1)
    usable = free & (sizes[label] >= 2)
    border = usable & border_mask(free.shape)
    out: list[tuple[tuple[int, int], tuple[int, int], float]] = []
    tries = 0
    while len(out) < n and tries < 50 * n:
        tries += 1
        k = len(out)
        pool = border if (k % 2 == 0 and border.any()) else usable
        rs, cs = np.nonzero(pool)
        i = rng.integers(len(rs))
        s = (int(rs[i]), int(cs[i]))
        same = usable & (label == label[s])
        gpool = same & border if (k % 4 == 0 and (same & border).sum() > 1) else same
        rs, cs = np.nonzero(gpool)
        j = rng.integers(len(rs))
        g = (int(rs[j]), int(cs[j]))
        if g == s:
            continue
        dist = octile_lengths(free, [s])[0]
        length = float(dist[g[0] * w + g[1]])
        if not math.isfinite(length):  # cannot happen: same component
            raise AssertionError(f"cells {s} and {g} share a component but are not connected")
        out.append(((s[1], s[0]), (g[1], g[0]), length))
    return out


def write_scen(path: Path, map_name: str, shape: tuple[int, int],
               pairs: list[tuple[tuple[int, int], tuple[int, int], float]]) -> Path:
    h, w = shape
    lines = ["version 1"]
    for (sx, sy), (gx, gy), length in pairs:
        lines.append("\t".join(str(v) for v in (int(length // 4), map_name, w, h, sx, sy, gx,
                                                 gy, repr(length))))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def movingai_problems(rng: np.random.Generator, directory: Path, size: int, density: float,
                      seed: int, n: int) -> list[op.Problem]:
    """Write one random map and its ``.scen`` in ``directory`` and read them back."""
    blocked = random_movingai(rng, size, size, density)
    stem = f"rand-{size}-{round(density * 100)}-{seed}"
    write_map(directory / f"{stem}.map", blocked)
    pairs = pick_scen(rng, blocked, n)
    scen = write_scen(directory / f"{stem}.map.scen", f"{stem}.map", blocked.shape, pairs)
    return read_scen(scen)


# --------------------------------------------------------------------------------------
# occupancy maps
# --------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class MapQuery:
    """One occupancy-map query: the problem and the independent upper bound (a verified
    safe-grid path length, map units; ``nan`` when the grid path failed the shapely check)."""

    problem: op.Problem
    upper: float


def safe_cells(grid: Grid, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Free cells whose centre is far enough from the obstacle cells and the edge that every
    8-neighbour move between two of them is free of the imported polygons inflated by
    ``radius`` (the polygons lie within ``grow + simplify`` cells of the obstacle squares),
    and every cell's distance to the edge (cells)."""
    mask = grid.obstacle_mask()
    r = radius / grid.resolution
    edt = ndimage.distance_transform_edt(~mask)  # centre to nearest obstacle cell centre
    h, w = mask.shape
    rr, cc = np.mgrid[0:h, 0:w]
    edge = np.minimum(np.minimum(rr + 0.5, h - rr - 0.5), np.minimum(cc + 0.5, w - cc - 0.5))
    # point to square >= centre distance - sqrt(2)/2; a move's points are within sqrt(2)/2 of
    # an end; the edge constraint is convex, so the ends suffice
    return (~mask) & (edt >= r + GROW_SIMPLIFY + SQRT2 + 1e-6) & (edge >= r + 1e-6), edge


def verified_length(problem: op.Problem, points: np.ndarray, radius: float) -> float:
    """Length of a polyline if shapely confirms it stays ``radius`` from every obstacle
    polygon and inside the bounds shrunk by ``radius`` (else ``nan``)."""
    line = shapely.LineString(points)
    tol = 1e-9 * problem.extent
    union = shapely.union_all([o.geometry for o in problem.obstacles])
    x0, y0, x1, y1 = problem.bounds
    inner = shapely.box(x0 + radius - tol, y0 + radius - tol, x1 - radius + tol,
                        y1 - radius + tol)
    ok = shapely.distance(union, line) >= radius - tol and inner.covers(line)
    return float(line.length) if ok else float("nan")


def crop(grid: Grid, rng: np.random.Generator, size: int = CROP) -> Grid:
    """A random ``size x size`` window of ``grid`` whose free space reaches every side."""
    h, w = grid.cells.shape
    mask = grid.obstacle_mask()
    best = None
    for _ in range(200):
        r0, c0 = int(rng.integers(0, h - size + 1)), int(rng.integers(0, w - size + 1))
        win = mask[r0:r0 + size, c0:c0 + size]
        sides = [win[0], win[-1], win[:, 0], win[:, -1]]
        score = min(float(np.mean(~s)) for s in sides)
        if best is None or score > best[0]:
            best = (score, r0, c0)
        if score >= 0.2:
            break
    _, r0, c0 = best
    ox, oy, _ = grid.origin
    res = grid.resolution
    origin = (ox + c0 * res, oy + (h - r0 - size) * res, 0.0)
    return Grid(grid.cells[r0:r0 + size, c0:c0 + size].copy(), res, origin,
                f"{grid.source}[{r0}:{r0 + size}, {c0}:{c0 + size}]")


def map_queries(path: Path, grid: Grid, rng: np.random.Generator, n: int,
                name: str) -> list[MapQuery]:
    """``n`` safe-grid-connected queries on ``grid``; every second start, every fourth goal
    too, from the band of safe cells nearest the image edge."""
    safe, edge = safe_cells(grid, MAP_RADIUS)
    h, w = safe.shape
    _, label = connected_components(octile_graph(safe), directed=False)
    label = label.reshape(h, w)
    sizes = np.bincount(label[safe].ravel(), minlength=label.max() + 1)
    usable = safe & (sizes[label] >= 50)
    band = usable & (edge <= edge[usable].min() + 4)
    out: list[MapQuery] = []
    tries = 0
    while len(out) < n and tries < 50 * n:
        tries += 1
        k = len(out)
        pool = band if (k % 2 == 0 and band.any()) else usable
        rs, cs = np.nonzero(pool)
        i = rng.integers(len(rs))
        s = (int(rs[i]), int(cs[i]))
        same = usable & (label == label[s])
        gpool = same & band if (k % 4 == 0 and (same & band).sum() > 1) else same
        rs, cs = np.nonzero(gpool)
        j = rng.integers(len(rs))
        g = (int(rs[j]), int(cs[j]))
        if g == s:
            continue
        _, pred = octile_lengths(safe, [s], predecessors=True)
        route = grid_route(pred[0], w, g)
        pts = np.array([grid.cell_centre(r, c) for r, c in route])
        prob = import_map(path, Robots(radius=MAP_RADIUS, start=pts[0], goal=pts[-1]),
                          scene=SceneOptions(name=f"{name}-{k}"), grid=grid)
        out.append(MapQuery(prob, verified_length(prob, pts, MAP_RADIUS)))
    return out


# --------------------------------------------------------------------------------------
# running and tabulating
# --------------------------------------------------------------------------------------


@dataclasses.dataclass
class Row:
    source: str
    queries: int = 0
    optimal: int = 0
    infeasible: int = 0
    other: dict = dataclasses.field(default_factory=dict)
    null_with_path: int = 0
    band_checked: int = 0
    band_violations: int = 0
    wall_matters: int = 0
    times: list = dataclasses.field(default_factory=list)
    failures: list = dataclasses.field(default_factory=list)


def run_query(row: Row, problem: op.Problem, path_exists: bool | None, upper: float | None
              ) -> op.Result:
    """Solve one query with visgraph and book it in ``row``.  ``path_exists=None``: decided
    by the validated known-map visgraph path; ``upper=None``: no upper bound."""
    t0 = time.perf_counter()
    res = op.solve(problem, "visgraph")
    row.times.append(time.perf_counter() - t0)
    ref = reference_optimum(problem)
    opt = ref["optimum"]
    row.queries += 1
    st = res.status.value
    if st == "optimal":
        row.optimal += 1
    elif st == "infeasible":
        row.infeasible += 1
    else:
        row.other[st] = row.other.get(st, 0) + 1
    lead = problem.leader
    if path_exists is None:
        known = op.solve(problem.known_view(), "visgraph")
        path_exists = known.status.value == "optimal" and known.metrics["collisions"] == 0
    what = f"{problem.name}: {lead.start.tolist()} -> {lead.goal.tolist()} (r {lead.radius:g})"
    if opt is None and path_exists:
        row.null_with_path += 1
        row.failures.append(f"{what}: optimum None ({ref['reference_error']}), visgraph {st}: "
                            f"{res.message}")
    elif path_exists and st not in ("optimal", "infeasible") and not problem.dynamic_obstacles \
            and not any(not o.known for o in problem.obstacles):
        row.failures.append(f"{what}: visgraph {st}: {res.message}")
    if opt is not None:
        # the same query on the map grown by its size on every side (no wall near the path):
        # a lower bound; strictly shorter when the wall of the bounds changes the optimum
        x0, y0, x1, y1 = problem.bounds
        w, h = x1 - x0, y1 - y0
        grown = dataclasses.replace(problem, bounds=(x0 - w, y0 - h, x1 + w, y1 + h),
                                    _cache={})
        free = reference_optimum(grown)["optimum"]
        if free is not None and free < opt * (1 - BAND_REL):
            row.wall_matters += 1
        if free is None or free > opt * (1 + BAND_REL):
            row.failures.append(f"{what}: optimum {opt!r} below {free!r}, the optimum on the "
                                "map grown by its size")
    if upper is not None and not math.isfinite(upper):
        row.failures.append(f"{what}: the safe-grid path failed the shapely check")
    if opt is not None:
        straight = float(np.hypot(*(lead.goal - lead.start)))
        hi = math.inf if upper is None or not math.isfinite(upper) else upper
        if upper is not None:
            row.band_checked += 1
        if not (straight * (1 - BAND_REL) <= opt <= hi * (1 + BAND_REL)):
            row.band_violations += 1
            row.failures.append(f"{what}: optimum {opt!r} outside [{straight!r}, {hi!r}]")
    return res


def print_table(title: str, rows: list[Row], band: str) -> None:
    print(f"## {title}")
    print()
    print(f"| source | queries | optimal | infeasible | other | optimum None with a path | "
          f"{band} violations | wall binds | median s | worst s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        other = ", ".join(f"{k} {v}" for k, v in sorted(r.other.items())) or "0"
        checked = f"{r.band_violations} / {r.band_checked}" if r.band_checked else \
            f"{r.band_violations} (lower only)"
        print(f"| {r.source} | {r.queries} | {r.optimal} | {r.infeasible} | {other} | "
              f"{r.null_with_path} | {checked} | {r.wall_matters} | "
              f"{statistics.median(r.times):.3f} | "
              f"{max(r.times):.3f} |")
    print()
    for r in rows:
        for f in r.failures:
            print(f"* FAIL {r.source}: {f}")
    if any(r.failures for r in rows):
        print()


def catalogue_table() -> None:
    row = Row("catalogue")
    notes = []
    for name in op.list_problems():
        p = op.load_problem(name)
        res = run_query(row, p, None, None)
        if res.status.value not in ("optimal", "infeasible"):
            crossed = ", ".join(repr(c) for c in res.metrics.get("crossed", []))
            notes.append(f"* {name}: {res.status.value}, known-map plan; validator: "
                         f"{res.metrics['static_collisions']} static collision(s) "
                         f"({crossed or 'none'}), {res.metrics['dynamic_contacts']} moving "
                         f"contact(s)")
    print_table(f"Catalogue ({row.queries} scenes)", [row], "straight-line")
    if notes:
        print("Statuses other than optimal / infeasible (temporary or moving obstacles, not "
              "seen by the known-map plan):")
        print()
        print("\n".join(notes))
        print()


def maps_table(seeds: int, queries: int) -> None:
    rows = []
    for name, path in sorted(map_files().items()):
        grid = read_ros_yaml(path)
        full, crops = Row(f"{name} (full, {grid.width}x{grid.height})"), \
            Row(f"{name} (crops {CROP}x{CROP}, free space at the edge)")
        for seed in range(seeds):
            rng = np.random.default_rng([30, seed])
            for q in map_queries(path, grid, rng, queries, f"{name}-{seed}"):
                run_query(full, q.problem, True, q.upper)
            sub = crop(grid, rng)
            for q in map_queries(path, sub, rng, queries, f"{name}-crop-{seed}"):
                run_query(crops, q.problem, True, q.upper)
        rows += [full, crops]
    print_table(f"Occupancy maps (radius {MAP_RADIUS:g} m, {seeds} seed(s), {queries} queries "
                "per map or crop)", rows, "band (straight <= optimum <= safe-grid path)")


def movingai_table(seeds: int, sizes: list[int], queries: int) -> None:
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-bounds-") as tmp:
        for size in sizes:
            for density in DENSITIES:
                row = Row(f"{size}x{size}, {round(density * 100)} %")
                for seed in range(seeds):
                    rng = np.random.default_rng([30, size, round(density * 100), seed])
                    for p in movingai_problems(rng, Path(tmp), size, density, seed, queries):
                        run_query(row, p, True, scen_octile_length(p))
                rows.append(row)
    print_table(f"MovingAI-type maps without a border (point robots, {seeds} map(s) per line, "
                f"{queries} queries per map, half from border cells)", rows,
                "band (straight <= optimum <= .scen octile)")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3,
                    help="random maps per size/density and random query sets per map")
    ap.add_argument("--size", default="32,64",
                    help="MovingAI map sizes, comma-separated (square maps)")
    ap.add_argument("--queries", type=int, default=20, help="queries per map or crop")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.size.split(",") if s.strip()]
    op.solve("paper-env1", "visgraph")  # warm-up: imports and compiled kernels
    t0 = time.perf_counter()
    catalogue_table()
    maps_table(args.seeds, args.queries)
    movingai_table(args.seeds, sizes, args.queries)
    print(f"total {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
