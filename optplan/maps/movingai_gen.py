"""Seeded MovingAI-format benchmark maps: random, room, maze and street-like grids, written as
a ``.map`` and a ``.scen`` whose optimal lengths come from A* on the 8-connected grid without
corner cutting (the MovingAI convention).

:func:`benchmark_terrain` draws a map (terrain characters: ``.`` free, ``@`` blocked, ``T``
trees, also blocked); :func:`octile_length` is the grid's shortest path (a compiled A* with
the octile heuristic); :func:`scen_queries` draws start/goal pairs between mutually reachable
free cells; :func:`generate_benchmark` does all of it and writes ``<name>.map`` and
``<name>.map.scen`` (``optplan gen-map``).  Every random choice comes from the ``rng``
(a ``numpy.random.Generator``): the same seed gives the same files.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from optplan.geometry.compiled import B2, compiled, i8, inlined

__all__ = ["KINDS", "GeneratedMap", "benchmark_terrain", "octile_length", "scen_queries",
           "generate_benchmark", "default_name"]

#: The map families.
KINDS = ("random", "room", "maze", "street")
#: Sizes accepted (cells per side); the tests and the docs use 32 to 1024.
MIN_SIZE, MAX_SIZE = 8, 2048
#: The densest random map: near 41 % blocked cells the free cells stop percolating
#: (4-connected site percolation on the square grid: free share 0.593).
MAX_DENSITY = 0.4
_SQRT2 = math.sqrt(2.0)


# --------------------------------------------------------------------------------------
# the maps
# --------------------------------------------------------------------------------------


def _random(size: int, rng: np.random.Generator, density: float) -> np.ndarray:
    """Exactly ``round(density x size^2)`` blocked cells, uniformly placed (as MovingAI's
    ``random-W-H-D`` maps)."""
    t = np.full(size * size, ".", dtype="<U1")
    t[rng.permutation(size * size)[:round(density * size * size)]] = "@"
    return t.reshape(size, size)


def _room(size: int, rng: np.random.Generator) -> np.ndarray:
    """Square rooms of side ``pitch - 1`` behind one-cell walls (``pitch = size // 8``,
    between 4 and 16); the doors of a random spanning tree of the rooms, plus each other
    wall's door with probability 1/2, are opened: every free cell is reachable."""
    pitch = min(16, max(4, size // 8))
    t = np.full((size, size), ".", dtype="<U1")
    t[pitch - 1::pitch, :] = "@"
    t[:, pitch - 1::pitch] = "@"
    n = -(-size // pitch)  # rooms per side (the last may be cut by the edge)
    walls = [((i, j), (i + di, j + dj)) for i in range(n) for j in range(n)
             for di, dj in ((0, 1), (1, 0)) if i + di < n and j + dj < n]
    order = rng.permutation(len(walls))
    extra = rng.random(len(walls)) < 0.5
    parent = list(range(n * n))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    door = max(1, (pitch - 1) // 3)
    for k in order:
        (i, j), (i2, j2) = walls[k]
        a, b = find(i * n + j), find(i2 * n + j2)
        if a == b and not extra[k]:
            continue
        parent[a] = b
        lo = int(rng.integers(0, pitch - door))  # the door's place along the wall
        if i2 > i:   # a horizontal wall below room (i, j)
            t[i * pitch + pitch - 1, j * pitch + lo:j * pitch + lo + door] = "."
        else:        # a vertical wall right of it
            t[i * pitch + lo:i * pitch + lo + door, j * pitch + pitch - 1] = "."
    return t


def _maze(size: int, rng: np.random.Generator) -> np.ndarray:
    """A perfect maze (randomised depth-first search) of corridors ``c = max(1, size // 128)``
    cells wide between one-cell walls; cells the last corridor does not reach stay blocked."""
    c = max(1, size // 128)
    p = c + 1
    n = max(1, (size + 1) // p)
    t = np.full((size, size), "@", dtype="<U1")
    keys = rng.random((n, n, 4))
    moves = ((0, 1), (1, 0), (0, -1), (-1, 0))
    seen = np.zeros((n, n), dtype=bool)
    start = (int(rng.integers(0, n)), int(rng.integers(0, n)))
    seen[start] = True
    t[start[0] * p:start[0] * p + c, start[1] * p:start[1] * p + c] = "."
    stack = [(start, list(np.argsort(keys[start])))]
    while stack:
        (i, j), todo = stack[-1]
        if not todo:
            stack.pop()
            continue
        di, dj = moves[todo.pop()]
        a, b = i + di, j + dj
        if not (0 <= a < n and 0 <= b < n) or seen[a, b]:
            continue
        seen[a, b] = True
        r0, c0 = min(i, a) * p, min(j, b) * p
        t[r0:r0 + c + abs(di) * p, c0:c0 + c + abs(dj) * p] = "."  # the cell and the gap
        stack.append(((a, b), list(np.argsort(keys[a, b]))))
    return t


def _split(rect: tuple[int, int, int, int], rng: np.random.Generator, lo: int, hi: int,
           unit: int, blocks: list) -> None:
    """Binary space partition of ``rect = (r0, c0, r1, c1)`` into blocks of side ``lo..hi``
    separated by streets ``unit..3 unit`` wide."""
    r0, c0, r1, c1 = rect
    h, w = r1 - r0, c1 - c0
    street = unit * int(rng.integers(1, 4))
    big = max(h, w)
    if big < 2 * lo + street or (big <= hi and rng.random() < 0.3):
        blocks.append(rect)
        return
    if h >= w:
        cut = r0 + int(rng.integers(lo, h - lo - street + 1))
        _split((r0, c0, cut, c1), rng, lo, hi, unit, blocks)
        _split((cut + street, c0, r1, c1), rng, lo, hi, unit, blocks)
    else:
        cut = c0 + int(rng.integers(lo, w - lo - street + 1))
        _split((r0, c0, r1, cut), rng, lo, hi, unit, blocks)
        _split((r0, cut + street, r1, c1), rng, lo, hi, unit, blocks)


def _building(t: np.ndarray, rect: tuple[int, int, int, int], rng: np.random.Generator) -> None:
    """Fill one city block: a park with trees, a slanted building, a row of buildings with
    one-cell alleys, or one building (each behind a yard of 0 to ``1 + h // 12`` cells, ``h``
    the block's height)."""
    s = int(rng.integers(0, 2 + (rect[2] - rect[0]) // 12))
    r0, c0, r1, c1 = rect[0] + s, rect[1] + s, rect[2] - s, rect[3] - s
    if r1 - r0 < 2 or c1 - c0 < 2:
        return
    kind = rng.random()
    if kind < 0.15:    # a park: scattered trees
        park = t[r0:r1, c0:c1]
        park[rng.random(park.shape) < 0.08] = "T"
    elif kind < 0.35:  # a slanted building: a rotated rectangle, rasterised by cell centres
        yy, xx = np.mgrid[r0:r1, c0:c1] + 0.5
        cy, cx, a = (r0 + r1) / 2, (c0 + c1) / 2, rng.uniform(-0.6, 0.6)
        u = (xx - cx) * math.cos(a) + (yy - cy) * math.sin(a)
        v = -(xx - cx) * math.sin(a) + (yy - cy) * math.cos(a)
        half = 0.35 * min(r1 - r0, c1 - c0)
        t[r0:r1, c0:c1][(np.abs(u) <= half) & (np.abs(v) <= half * rng.uniform(0.5, 1.0))] = "@"
    elif kind < 0.65 and c1 - c0 >= 7:  # a row of buildings, one-cell alleys between them
        cuts = np.sort(rng.choice(np.arange(c0 + 2, c1 - 2), size=min(3, (c1 - c0) // 5),
                                  replace=False))
        t[r0:r1, c0:c1] = "@"
        t[r0:r1, cuts] = "."
    else:
        t[r0:r1, c0:c1] = "@"


def _street(size: int, rng: np.random.Generator) -> np.ndarray:
    """City blocks (a binary space partition, blocks of ``size // 16`` to ``size // 6``
    cells, streets ``size // 128`` to three times that wide, at least 1 to 3 cells) filled by
    :func:`_building`."""
    t = np.full((size, size), ".", dtype="<U1")
    blocks: list[tuple[int, int, int, int]] = []
    _split((0, 0, size, size), rng, max(4, size // 16), max(8, size // 6),
           max(1, size // 128), blocks)
    for rect in blocks:
        _building(t, rect, rng)
    return t


def benchmark_terrain(kind: str, size: int, rng: np.random.Generator, *,
                      density: float = 0.2) -> np.ndarray:
    """A ``size x size`` MovingAI map of the family ``kind``, as terrain characters.

    Parameters
    ----------
    kind : ``"random"``, ``"room"``, ``"maze"`` or ``"street"``
        ``random``: exactly ``round(density x size^2)`` blocked cells; ``room``: square rooms
        behind one-cell walls (``size // 8`` apart, 4 to 16), connected by doors; ``maze``: a
        perfect maze of corridors ``max(1, size // 128)`` cells wide; ``street``: city blocks
        between streets (whole, subdivided and slanted buildings, parks with trees).
    size : int
        Cells per side, ``MIN_SIZE`` to ``MAX_SIZE`` (8 to 2048).
    rng : numpy.random.Generator
        Every random choice.
    density : float
        The blocked share of a ``random`` map, 0 to ``MAX_DENSITY`` (0.4).

    Returns
    -------
    numpy.ndarray
        ``(size, size)`` of ``"."`` (free), ``"@"`` and ``"T"`` (blocked), row 0 at the top.
    """
    if kind not in KINDS:
        raise ValueError(f"unknown map kind {kind!r} (expected one of {', '.join(KINDS)})")
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or \
            not MIN_SIZE <= size <= MAX_SIZE:
        raise ValueError(f"size: expected an integer in {MIN_SIZE}..{MAX_SIZE}, got {size!r}")
    if not (isinstance(density, (int, float)) and 0.0 <= density <= MAX_DENSITY):
        raise ValueError(f"density: expected a number in 0..{MAX_DENSITY} (the free cells stop "
                         f"percolating near 0.41), got {density!r}")
    size = int(size)
    if kind == "random":
        return _random(size, rng, float(density))
    return {"room": _room, "maze": _maze, "street": _street}[kind](size, rng)


# --------------------------------------------------------------------------------------
# shortest paths on the grid
# --------------------------------------------------------------------------------------


@inlined
def _octile(x: int, y: int, gx: int, gy: int) -> float:
    dx, dy = abs(x - gx), abs(y - gy)
    return max(dx, dy) + (_SQRT2 - 1.0) * min(dx, dy)


@inlined
def _step_ok(blocked: np.ndarray, ux: int, uy: int, dx: int, dy: int) -> bool:
    """Whether the move from ``(ux, uy)`` by ``(dx, dy)`` stays on free cells, a diagonal
    move only when both cells beside it are free (no corner cutting)."""
    h, w = blocked.shape
    vx, vy = ux + dx, uy + dy
    if vx < 0 or vy < 0 or vx >= w or vy >= h or blocked[vy, vx]:
        return False
    return dx == 0 or dy == 0 or not (blocked[uy, vx] or blocked[vy, ux])


@compiled(B2, i8, i8, i8, i8)
def _astar(blocked: np.ndarray, sx: int, sy: int, gx: int, gy: int) -> float:
    """A* from cell ``(sx, sy)`` to ``(gx, gy)`` (column, row from the top), octile
    heuristic; ``inf`` when the goal is not reachable."""
    h, w = blocked.shape
    if blocked[sy, sx] or blocked[gy, gx]:
        return np.inf
    dist = np.full(h * w, np.inf)
    done = np.zeros(h * w, dtype=np.bool_)
    dist[sy * w + sx] = 0.0
    heap = [(_octile(sx, sy, gx, gy), 0.0, float(sy * w + sx))]
    while len(heap):
        _, d, fu = heapq.heappop(heap)
        u = int(fu)
        if done[u]:
            continue
        uy, ux = u // w, u % w
        if ux == gx and uy == gy:
            return d
        done[u] = True
        for k in range(9):
            dx, dy = k % 3 - 1, k // 3 - 1
            if k == 4 or not _step_ok(blocked, ux, uy, dx, dy):
                continue
            nd = d + (_SQRT2 if dx != 0 and dy != 0 else 1.0)
            v = (uy + dy) * w + ux + dx
            if nd < dist[v]:
                dist[v] = nd
                heapq.heappush(heap, (nd + _octile(ux + dx, uy + dy, gx, gy), nd, float(v)))
    return np.inf


def octile_length(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """The shortest 8-connected grid path from ``start`` to ``goal`` (cells ``(x, y)``:
    column, row from the top) with unit straight and ``sqrt(2)`` diagonal moves, a diagonal
    only between two free side cells (MovingAI's octile length); ``inf`` if unreachable."""
    b = np.ascontiguousarray(blocked, dtype=np.bool_)
    return float(_astar(b, int(start[0]), int(start[1]), int(goal[0]), int(goal[1])))


# --------------------------------------------------------------------------------------
# queries and files
# --------------------------------------------------------------------------------------


def scen_queries(blocked: np.ndarray, n: int, rng: np.random.Generator
                 ) -> list[tuple[int, tuple[int, int], tuple[int, int], float]]:
    """``n`` queries ``(bucket, start, goal, length)`` between distinct, mutually reachable
    free cells, sorted by bucket (``floor(length / 4)``, as MovingAI's).

    The start is uniform among the free cells of the components (4-connected: without
    corner cutting a diagonal step also joins two 4-connected cells) of two cells or more,
    the goal uniform among the other cells of the start's component.
    """
    labels, _ = ndimage.label(~np.asarray(blocked, dtype=bool))
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    cand = np.flatnonzero(sizes[labels.ravel()] >= 2)
    if n > 0 and not len(cand):
        raise ValueError("the map has no two mutually reachable free cells")
    w = blocked.shape[1]
    out = []
    for _ in range(n):
        s = int(cand[rng.integers(len(cand))])
        comp = np.flatnonzero(labels.ravel() == labels.ravel()[s])
        j = int(rng.integers(len(comp) - 1))           # any cell of it but the start
        g = int(comp[j + (j >= np.searchsorted(comp, s))])
        start, goal = (s % w, s // w), (g % w, g // w)
        length = octile_length(blocked, start, goal)
        out.append((int(length // 4), start, goal, length))
    out.sort(key=lambda q: q[0])
    return out


@dataclass(frozen=True)
class GeneratedMap:
    """What :func:`generate_benchmark` wrote."""

    map_path: Path
    scen_path: Path
    width: int
    height: int
    blocked: float
    queries: int
    buckets: tuple[int, int]


def default_name(kind: str, size: int, density: float = 0.2) -> str:
    """``<kind>-<size>-<size>`` (``random-<size>-<size>-<percent>`` for random maps), as
    MovingAI names its maps."""
    if kind == "random":
        return f"{kind}-{size}-{size}-{round(100 * density)}"
    return f"{kind}-{size}-{size}"


def generate_benchmark(kind: str, size: int, out: str | Path, *, rng: np.random.Generator,
                       queries: int = 100, density: float = 0.2, name: str | None = None
                       ) -> GeneratedMap:
    """Draw a map (:func:`benchmark_terrain`) and ``queries`` start/goal pairs
    (:func:`scen_queries`), write ``<out>/<name>.map`` (``type octile``) and
    ``<out>/<name>.map.scen`` (``version 1``; tab-separated ``bucket map width height start_x
    start_y goal_x goal_y optimal_length``, the length with 8 decimals).

    Parameters
    ----------
    kind, size, density
        As :func:`benchmark_terrain`.
    out : path
        The directory (made if missing).
    rng : numpy.random.Generator
        Every random choice (the map, then the queries).
    queries : int
        Lines of the ``.scen`` (>= 0).
    name : str, optional
        The files' stem; default :func:`default_name`.

    Returns
    -------
    GeneratedMap
        The paths, the size, the blocked share, the query count and the bucket range.
    """
    if isinstance(queries, bool) or not isinstance(queries, (int, np.integer)) or queries < 0:
        raise ValueError(f"queries: expected an integer >= 0, got {queries!r}")
    terrain = benchmark_terrain(kind, size, rng, density=density)
    blocked = terrain != "."
    found = scen_queries(blocked, int(queries), rng)
    name = name or default_name(kind, int(size), density)
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    h, w = terrain.shape
    mp, sp = d / f"{name}.map", d / f"{name}.map.scen"
    mp.write_text(f"type octile\nheight {h}\nwidth {w}\nmap\n"
                  + "".join("".join(row) + "\n" for row in terrain), encoding="ascii")
    sp.write_text("version 1\n" + "".join(
        f"{b}\t{mp.name}\t{w}\t{h}\t{s[0]}\t{s[1]}\t{g[0]}\t{g[1]}\t{length:.8f}\n"
        for b, s, g, length in found), encoding="ascii")
    buckets = (found[0][0], found[-1][0]) if found else (0, -1)
    return GeneratedMap(mp, sp, w, h, float(blocked.mean()), len(found), buckets)
