r"""Triangular expansion: the vertices a point may see, over a constrained triangulation.

The compiled kernel of :mod:`optplan.geometry.tangent.sightlines` (its module docstring has the
mathematics and the tolerances).  The free space is a constrained triangulation whose
constrained edges are the solids' boundary edges; a *view* is a triangle entered through one
of its edges with an interval ``[L, R]`` of directions (radians, unwrapped in the frame of the
source's window) of the rays from the source ``s`` that cross that edge.  With ``A`` and ``B``
the entry edge's ends (``A`` first counter-clockwise as seen from ``s``) and ``c`` the third
vertex at direction ``theta_c``:

* ``c`` is seen when ``L - SLACK <= theta_c <= R + SLACK``;
* the rays continue through the edge ``(A, c)`` with ``[L, min(R, theta_c + w)]`` and through
  ``(c, B)`` with ``[max(L, theta_c - w), R]``, an edge that is constrained stopping them;
  ``w = SLACK`` plus, where ``c`` is a convex corner and the sibling edge is constrained,
  ``asin(kappa eps / |c - s|)``: a ray that grazes a convex corner within the tolerance goes
  on (it may be free for the exact predicate);
* a ray through a *pinch* vertex (where solids touch at a point) goes on into the free
  triangles at that vertex whose corner contains its direction (a point robot may pass).

Every direction is measured as ``mid + wrap(atan2(p - s) - lo - mid)`` from the interval's
middle ``mid``: the point lies beyond the entry edge, so within half a turn of any direction
of the interval, and the result is in the interval's unwrapped frame.

Grouped arguments (no compiled function takes more than 10 parameters; typed once below):

* ``mesh``, :data:`MESH`: ``(VX, TR, CONV, PINCH, vstart, vtri, cstart, citems)``, the
  triangulation and its centres (:func:`expand_views`' parameters);
* ``src``, :data:`SOURCES`: ``(S, SV, ST, LO, WID, G)``, the sources (idem);
* ``marks``: ``(cstamp, pst, work)``, the stamps of the centres reported and of the pinch
  vertices passed, per source group, and ``work = [views run, budget]`` (the budget ``< 0``:
  none);
* ``eye``: ``(sx, sy, lo, tiny)``, one source, the start of its window and the widening
  tolerance ``KAPPA eps``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from optplan.geometry.compiled import B1, F1, F2, I1, I2, compiled, f8, i8, inlined, leaf

__all__ = ["expand_views", "locate", "pack_triangles", "KAPPA", "SLACK"]

#: ``mesh``: ``VX, TR, CONV, PINCH, vstart, vtri, cstart, citems`` (module docstring)
MESH = types.Tuple((F2, I2, B1, B1, I1, I1, I1, I1))
#: ``src``: ``S, SV, ST, LO, WID, G`` (module docstring)
SOURCES = types.Tuple((F2, I1, I1, F1, F1, I1))
_MARKS = types.UniTuple(I1, 3)  # cstamp, pst, work
_EYE = types.UniTuple(f8, 4)  # sx, sy, lo, tiny

TWO_PI = 2.0 * math.pi
#: Widening at a grazed convex corner, in units of ``eps`` at the corner's distance.
KAPPA = 4.0
#: Angular slack (rad) of every interval end and of the seen test.
SLACK = 1e-9


def pack_triangles(T: np.ndarray, NB: np.ndarray, NK: np.ndarray, CON: np.ndarray,
                   FREE: np.ndarray) -> np.ndarray:
    """The ``(nt, 8)`` int64 rows of :func:`expand_views` (its ``TR``): corners, neighbours,
    flags (constrained edges, free space, the edges' indices in their neighbours)."""
    flags = (CON.astype(np.int64) << np.arange(3)).sum(axis=1) + (FREE.astype(np.int64) << 3)
    flags += (NK.astype(np.int64) << (4 + 2 * np.arange(3))).sum(axis=1)
    return np.ascontiguousarray(np.column_stack([T, NB, flags, np.zeros(len(T), np.int64)]),
                                dtype=np.int64)


@inlined
def _con(TR, t, e):
    """The edge opposite corner ``e`` of triangle ``t`` is constrained."""
    return (TR[t, 6] >> e) & 1 != 0


@inlined
def _free(TR, t):
    """Triangle ``t`` is free space."""
    return (TR[t, 6] >> 3) & 1 != 0


@inlined
def _nk(TR, t, e):
    """The index, in the neighbour across it, of the edge opposite corner ``e`` of ``t``."""
    return (TR[t, 6] >> (4 + 2 * e)) & 3


@inlined
def _rel(px, py, sx, sy, lo, mid):
    """Direction of ``p`` from ``s`` in the unwrapped frame of an interval around ``mid``."""
    d = math.atan2(py - sy, px - sx) - lo - mid
    d -= TWO_PI * math.floor((d + math.pi) / TWO_PI)
    return mid + d


@leaf(F2, i8, f8, f8, f8, B1)
def _widen(VX, v, sx, sy, tiny, CONV):  # pragma: no cover - compiled
    """Widening of an interval end at vertex ``v`` whose sibling edge is constrained."""
    if not CONV[v]:
        return SLACK
    d = math.hypot(VX[v, 0] - sx, VX[v, 1] - sy)
    if d <= tiny:
        return math.pi
    return SLACK + math.asin(tiny / d)


@leaf(MESH, i8, f8, _EYE, F2, i8)
def _jump(mesh, v, th, eye, stk, n_st):  # pragma: no cover - compiled
    """The rays through the pinch vertex ``v`` (direction ``th``) go on into the free
    triangles at ``v`` whose corner holds their direction: a view of each entered at ``v``
    (``k = 3 + corner``) is pushed (the caller made room: :data:`ROOM`); returns the stack's
    size."""
    VX, TR, CONV, _, vstart, vtri, _, _ = mesh
    sx, sy, _, tiny = eye
    w = _widen(VX, v, sx, sy, tiny, CONV)
    dx = VX[v, 0] - sx
    dy = VX[v, 1] - sy
    dn = math.hypot(dx, dy)
    for rr in range(vstart[v], vstart[v + 1]):
        t = vtri[rr] // 3
        kk = vtri[rr] % 3
        if not _free(TR, t):
            continue
        p = TR[t, (kk + 1) % 3]
        r = TR[t, (kk + 2) % 3]
        px = VX[p, 0] - VX[v, 0]
        py = VX[p, 1] - VX[v, 1]
        rx = VX[r, 0] - VX[v, 0]
        ry = VX[r, 1] - VX[v, 1]
        if (px * dy - py * dx < -w * math.hypot(px, py) * dn
                or dx * ry - dy * rx < -w * math.hypot(rx, ry) * dn):
            continue  # the corner does not hold the direction
        n_st = _put(stk, n_st, t, 3 + kk, th - w, th + w)
    return n_st


@leaf(MESH, _MARKS, i8, i8, f8, _EYE, I1, i8, F2, i8)
def _visit(mesh, marks, q, v, th, eye, out, n_out, stk, n_st):  # pragma: no cover - compiled
    """Vertex ``v`` (direction ``th``) is seen by the sources tagged ``q``: its centres not
    seen yet are appended to ``out``, and at a pinch (the first time) the rays through it go
    on (:func:`_jump`); returns the sizes of ``out`` and of the stack (the caller made
    room)."""
    PINCH = mesh[3]
    cstart = mesh[6]
    citems = mesh[7]
    cstamp, pst = marks[0], marks[1]
    for t in range(cstart[v], cstart[v + 1]):
        c = citems[t]
        if cstamp[c] != q:
            cstamp[c] = q
            out[n_out] = c
            n_out += 1
    if PINCH[v] and pst[v] != q:
        pst[v] = q
        n_st = _jump(mesh, v, th, eye, stk, n_st)
    return n_out, n_st


@inlined
def _put(stk, n, t, k, L, R):
    """Write the view ``(t, k, L, R)`` at row ``n`` (room made by the caller)."""
    stk[n, 0] = t
    stk[n, 1] = k
    stk[n, 2] = L
    stk[n, 3] = R
    return n + 1


@inlined
def _split(mesh, t, k, c, tc, L, R, eye, stk, n_st):
    """Push the views beyond the two other edges of triangle ``t`` entered opposite ``k``:
    ``(A, c)`` with ``[L, min(R, tc + w)]``, ``(c, B)`` with ``[max(L, tc - w), R]``
    (module docstring; the caller made room); returns the stack's size."""
    VX, TR, CONV, _, _, _, _, _ = mesh
    sx, sy, _, tiny = eye
    e1 = (k + 1) % 3  # the edge (A, c), opposite B
    e2 = (k + 2) % 3  # the edge (c, B), opposite A
    if not _con(TR, t, e1) and TR[t, 3 + e1] >= 0:
        R1 = min(R, tc + (_widen(VX, c, sx, sy, tiny, CONV) if _con(TR, t, e2) else SLACK))
        if L < R1:
            n_st = _put(stk, n_st, TR[t, 3 + e1], _nk(TR, t, e1), L, R1)
    if not _con(TR, t, e2) and TR[t, 3 + e2] >= 0:
        L2 = max(L, tc - (_widen(VX, c, sx, sy, tiny, CONV) if _con(TR, t, e1) else SLACK))
        if L2 < R:
            n_st = _put(stk, n_st, TR[t, 3 + e2], _nk(TR, t, e2), L2, R)
    return n_st


@leaf(MESH, _MARKS, i8, _EYE, F2, i8, I1, i8, i8)
def _expand(mesh, marks, q, eye, stk, n_st, out, n_out, room):  # pragma: no cover - compiled
    """Run the views on the stack for the sources tagged ``q`` (module docstring); returns
    the size of ``out``, or -1 when the stack has no ``room`` left for a view's pushes."""
    VX = mesh[0]
    TR = mesh[1]
    sx, sy, lo, _ = eye
    work = marks[2]
    while n_st > 0:
        if n_st + room > stk.shape[0]:
            return -1
        n_st -= 1
        work[0] += 1
        t = int(stk[n_st, 0])
        k = int(stk[n_st, 1])
        L = stk[n_st, 2]
        R = stk[n_st, 3]
        mid = 0.5 * (L + R)
        if k >= 3:  # entered at a pinch vertex: its two other vertices, the edge beyond
            for j in range(1, 3):
                v = TR[t, (k - 3 + j) % 3]
                th = _rel(VX[v, 0], VX[v, 1], sx, sy, lo, mid)
                if L - SLACK <= th <= R + SLACK:
                    n_out, n_st = _visit(mesh, marks, q, v, th, eye, out, n_out, stk, n_st)
            if not _con(TR, t, k - 3) and TR[t, k] >= 0:
                n_st = _put(stk, n_st, TR[t, k], _nk(TR, t, k - 3), L, R)
            continue
        c = TR[t, k]
        tc = _rel(VX[c, 0], VX[c, 1], sx, sy, lo, mid)
        if L - SLACK <= tc <= R + SLACK:
            n_out, n_st = _visit(mesh, marks, q, c, tc, eye, out, n_out, stk, n_st)
        n_st = _split(mesh, t, k, c, tc, L, R, eye, stk, n_st)
    return n_out


@compiled(F2, I2, f8, f8, i8, i8)
def locate(VX, TR, x, y, t0, maxit):  # pragma: no cover - compiled
    """The triangle holding ``(x, y)`` (its boundary included), by a remembering walk from
    triangle ``t0`` (never straight back; the edge tried first turns with the step, so the
    walk ends on any triangulation); -1 when the point is outside the triangulation or the
    walk exceeds ``maxit`` steps."""
    t = t0
    prev = -1
    for it in range(maxit):
        moved = False
        for j in range(3):
            k = (it + j) % 3
            p = TR[t, (k + 1) % 3]
            r = TR[t, (k + 2) % 3]
            o = ((VX[r, 0] - VX[p, 0]) * (y - VX[p, 1])
                 - (VX[r, 1] - VX[p, 1]) * (x - VX[p, 0]))
            if o < 0.0 and TR[t, 3 + k] != prev:
                prev = t
                t = TR[t, 3 + k]
                moved = True
                break
        if not moved:
            return t
        if t < 0:
            return -1
    return -1


@inlined
def _passable(VX, TR, t, kk, a, b, sx, sy, tiny, vertex):
    """A first view may leave its triangle across the edge ``(a, b)`` opposite ``kk``: it
    is not constrained, or the source is no vertex and lies within ``tiny`` of it (or in a
    triangle inside a solid)."""
    if not _con(TR, t, kk):
        return True
    if vertex:
        return False
    ex = VX[b, 0] - VX[a, 0]
    ey = VX[b, 1] - VX[a, 1]
    return (abs(ex * (sy - VX[a, 1]) - ey * (sx - VX[a, 0])) / math.hypot(ex, ey) <= tiny
            or not _free(TR, t))


@inlined
def _root(mesh, marks, q, eye, wd, edge, stk, n_st, out, n_out):
    """The first view beyond the edge opposite corner ``kk`` of triangle ``t``, ``edge = (t,
    kk, vertex)`` (the source at that corner when ``vertex``, else inside ``t``), cut to the
    window ``[0, wd]`` (every turn of it); its ends are seen; returns the sizes of ``out``
    and of the stack (the caller made room)."""
    VX, TR, CONV, _, _, _, _, _ = mesh
    sx, sy, lo, tiny = eye
    t, kk, vertex = edge
    a = TR[t, (kk + 1) % 3]
    b = TR[t, (kk + 2) % 3]
    ta = math.atan2(VX[a, 1] - sy, VX[a, 0] - sx) - lo
    ta -= TWO_PI * math.floor(ta / TWO_PI)
    tb = _rel(VX[b, 0], VX[b, 1], sx, sy, lo, ta + 0.5 * math.pi)
    if tb < ta:  # the source on the edge: half a turn
        tb = ta + math.pi
    wa = _widen(VX, a, sx, sy, tiny, CONV) if _con(TR, t, (kk + 2) % 3) else SLACK
    wb = _widen(VX, b, sx, sy, tiny, CONV) if _con(TR, t, (kk + 1) % 3) else SLACK
    go = _passable(VX, TR, t, kk, a, b, sx, sy, tiny, vertex) and TR[t, 3 + kk] >= 0
    for sh in range(-1, 2) if wd < TWO_PI else range(0, 1):
        L = ta - wa + sh * TWO_PI
        R = tb + wb + sh * TWO_PI
        if wd < TWO_PI:
            L = max(L, -SLACK)
            R = min(R, wd + SLACK)
        for v, th in ((a, ta + sh * TWO_PI), (b, tb + sh * TWO_PI)):
            if L - SLACK <= th <= R + SLACK:
                n_out, n_st = _visit(mesh, marks, q, v, th, eye, out, n_out, stk, n_st)
        if go and L < R:
            n_st = _put(stk, n_st, TR[t, 3 + kk], _nk(TR, t, kk), L, R)
    return n_out, n_st


@compiled(I1, i8)
def _grown_i(a, need):  # pragma: no cover - compiled
    """``a`` copied into an array of at least ``need`` (and twice its) items."""
    b = np.empty(max(need, 2 * a.shape[0]), np.int64)
    for k in range(a.shape[0]):
        b[k] = a[k]
    return b


@compiled(F2, i8)
def _grown_f(a, need):  # pragma: no cover - compiled
    """``a`` copied into an array of at least ``need`` (and twice its) rows."""
    b = np.empty((max(need, 2 * a.shape[0]), a.shape[1]))
    for k in range(a.shape[0]):
        for j in range(a.shape[1]):
            b[k, j] = a[k, j]
    return b


@inlined
def _one_source(src, mesh, marks, q, tag, tiny, stk, out, n_out, room):
    """Append the candidates of source ``q`` (stamped ``tag``) to ``out`` (room made for
    every centre); returns the new size of ``out``, -1 when the stack lacks room."""
    S, SV, ST, LO, WID, _ = src
    TR = mesh[1]
    vstart = mesh[4]
    vtri = mesh[5]
    citems = mesh[7]
    n_c = citems.shape[0]
    if SV[q] < 0 and ST[q] < 0:  # not located: every centre
        for c in range(n_c):
            out[n_out + c] = c
        return n_out + n_c
    eye = (S[q, 0], S[q, 1], LO[q], tiny)
    n_st = 0
    roots = range(vstart[SV[q]], vstart[SV[q] + 1]) if SV[q] >= 0 else range(3)
    for rr in roots:
        t = vtri[rr] // 3 if SV[q] >= 0 else ST[q]
        if SV[q] < 0 or _free(TR, t):
            if n_st + 3 * room > stk.shape[0]:
                return -1
            edge = (t, vtri[rr] % 3 if SV[q] >= 0 else rr, SV[q] >= 0)
            n_out, n_st = _root(mesh, marks, tag, eye, WID[q], edge, stk, n_st, out, n_out)
    return _expand(mesh, marks, tag, eye, stk, n_st, out, n_out, room)


@leaf(SOURCES, MESH, f8, I1, _MARKS, F2, I1, I1, i8, i8)
def _sources(src, mesh, eps, counts, marks, stk, out, state, room,
             gspan):  # pragma: no cover - compiled
    """The loop of :func:`expand_views` from source ``state[0]`` (``state``: next source,
    size of ``out``, stamp offset); returns 0 when every source is done, 1 when ``out``
    needs room (stopped between two sources), 2 when the stack does (``state`` set back to
    the start of the group, whose stamps are renewed with the offset ``gspan``), 3 when
    the views run exceed the budget (``marks[2]``)."""
    S = src[0]
    G = src[5]
    n_c = mesh[7].shape[0]
    tiny = KAPPA * eps
    q = state[0]
    n_out = state[1]
    g0 = q  # the start of q's group and the size of out there
    while g0 > 0 and G[g0 - 1] == G[q]:
        g0 -= 1
    out0 = n_out
    for p in range(g0, q):
        out0 -= counts[p]
    while q < S.shape[0]:
        if q > g0 and G[q] != G[q - 1]:
            g0 = q
            out0 = n_out
        if out.shape[0] - n_out < n_c:
            state[0] = q
            state[1] = n_out
            return 1
        m = _one_source(src, mesh, marks, q, G[q] + state[2], tiny, stk, out, n_out, room)
        if m < 0:
            state[0] = g0
            state[1] = out0
            state[2] += gspan
            return 2
        counts[q] = m - n_out
        n_out = m
        q += 1
        if 0 <= marks[2][1] < marks[2][0]:
            state[0] = q
            state[1] = n_out
            return 3
    state[0] = q
    state[1] = n_out
    return 0


@compiled(SOURCES, MESH, f8, i8)
def expand_views(src, mesh, eps, budget):  # pragma: no cover - compiled
    """Candidate visible centres per source by triangular expansion (module docstring).

    Parameters
    ----------
    src : tuple ``(S, SV, ST, LO, WID, G)``, the sources:
    S : (k, 2) sources; SV : (k,) the vertex each source is (-1: none); ST : (k,) the
        triangle holding it when it is no vertex (-1: not found: every centre is then a
        candidate); LO, WID : (k,) window start and width (rad, ``>= 2 pi``: all directions);
    G : (k,) the sources' groups (ints >= 0): consecutive sources of one group (the windows
        of one point) report a centre once between them;
    mesh : tuple ``(VX, TR, CONV, PINCH, vstart, vtri, cstart, citems)``, the triangulation:
    VX : (nv, 2) vertices; TR : (nt, 8) one row per triangle (one cache line): its corners
        (counter-clockwise), the neighbours across the edges opposite them (-1: none), and
        flags: bit ``e`` the edge opposite corner ``e`` is constrained, bit 3 the triangle is
        free space, bits ``4 + 2 e`` and ``5 + 2 e`` that edge's index in the neighbour
        (:func:`pack_triangles`);
    CONV, PINCH : (nv,) the vertex is a convex corner of a solid / where solids touch;
    vstart, vtri : CSR of the triangles at each vertex (``vtri = 3 t + corner``);
    cstart, citems : CSR of the centres at each vertex; eps : tolerance;
    budget : the views (triangles entered) the expansion may run, over all sources (< 0:
    no bound).

    Returns
    -------
    counts : (k,) int64
        Candidates per source.
    flat : int64 array
        The candidates of source 0, then of source 1, ...
    views : int
        The views run (the work: it grows with the visible regions, not with the
        candidates).  Past ``budget`` the expansion stops after the source that crossed it:
        ``views > budget`` and the counts and candidates are those of the sources done.

    The loop is :func:`_sources` (a ``@leaf``: no reference counting); this wrapper makes
    its arrays and grows them when it asks.
    """
    S, _, _, _, _, G = src
    VX, _, _, _, vstart, _, _, citems = mesh
    k = S.shape[0]
    n_c = citems.shape[0]
    deg = 1  # the most triangles at a vertex: a view pushes at most 2 deg + 2 views
    for v in range(VX.shape[0]):
        deg = max(deg, vstart[v + 1] - vstart[v])
    room = 2 * deg + 2
    gspan = 1
    for q in range(k):
        gspan = max(gspan, G[q] + 1)
    counts = np.zeros(k, np.int64)
    cstamp = np.full(n_c, -1, np.int64)
    pst = np.full(VX.shape[0], -1, np.int64)
    work = np.array([0, budget], np.int64)
    stk = np.empty((max(1024, 8 * room), 4))
    out = np.empty(16 * k + n_c, np.int64)
    state = np.zeros(3, np.int64)
    while True:
        why = _sources(src, mesh, eps, counts, (cstamp, pst, work), stk, out, state, room,
                       gspan)
        if why == 0 or why == 3:
            return counts, out[:state[1]].copy(), work[0]
        if why == 1:
            out = _grown_i(out, out.shape[0] + n_c)
        else:
            stk = _grown_f(stk, 2 * stk.shape[0])
