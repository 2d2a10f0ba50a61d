r"""The query-independent edges of the tangent graph: common tangents that pass both cones.

Travelling around circle ``i`` with sense ``s_i`` (+1 counter-clockwise) and leaving towards
circle ``j`` reached with sense ``s_j``, the unique common tangent has left normal
``n = exp(i beta)``, ``beta = arg(c_j - c_i) + arccos(delta / d)``, with
``delta = s_j rho_j - s_i rho_i`` and ``d = |c_j - c_i| > |delta|``; its tangent points are
``c - s rho n`` and its length ``sqrt(d^2 - delta^2)``.  A tangent point on a vertex circle
must lie in the vertex's normal cone (the directions between the outward normals of its two
edges), else the path would cut into an offset edge: :func:`tangent_edges` keeps the tangents
whose departure and arrival points both pass (the bitangent filter of the reduced visibility
graph).  :class:`Edges` holds those of one circle and sense, with the status of their
segments.  The search that uses them is :mod:`optplan.geometry.tangent.tangent_search`.
"""

from __future__ import annotations

import numpy as np

from optplan.geometry.tangent.circles import ANGLE_TOL, TWO_PI, Circles

__all__ = ["Edges", "arc_sweep", "both_senses", "cone_off", "tangent_exists", "tangent_normal",
           "tangent_edges"]


def cone_off(C: Circles, k, th):
    """Offset of angle(s) ``th`` from the cone start of circle(s) ``k``, nan outside the
    cone (``ANGLE_TOL`` of slack at both ends; the offset is clamped to the cone's width)."""
    off = np.mod(th - C.lo[k], TWO_PI)
    off = np.where(off > TWO_PI - ANGLE_TOL, 0.0, off)  # just below lo: on the boundary
    return np.where(off <= C.reach[k], np.minimum(off, C.cap[k]), np.nan)


def arc_sweep(C: Circles, k, s, th_a, th_d, od=None):
    """Angle swept along circle(s) ``k`` in sense(s) ``s`` from the arrival angle(s) ``th_a``
    to the departure angle(s) ``th_d`` (``od``: their cone offsets when known): on a circle
    obstacle ``(th_d - th_a) s mod 2 pi`` (``0`` within ``ANGLE_TOL`` below a full turn), on
    a vertex circle the difference of the cone offsets times ``s`` (``0`` within
    ``ANGLE_TOL`` behind the arrival; negative or nan: not along the cone).  The one
    definition of a path's arc, used by the searches and by the path's length
    (:func:`~optplan.geometry.tangent.arc_lines.exact_path`)."""
    full = C.full[k]
    one = np.ndim(full) == 0  # one circle (a search's expansion): only its case
    if not one or full:
        turn = np.mod((th_d - th_a) * s, TWO_PI)
        turn = np.where(turn > TWO_PI - ANGLE_TOL, 0.0, turn)
        if one:
            return turn
    if od is None:
        od = cone_off(C, k, th_d)
    with np.errstate(invalid="ignore"):
        sweep = (od - cone_off(C, k, th_a)) * s
        sweep = np.where((sweep < 0) & (sweep > -ANGLE_TOL), 0.0, sweep)
    return sweep if one else np.where(full, turn, sweep)


def both_senses(idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every circle of ``idx`` twice, with sense ``+1`` then ``-1``: ``(circles, senses)``."""
    sj = np.empty(2 * len(idx), np.int64)
    sj[0::2], sj[1::2] = 1, -1
    return np.repeat(idx, 2), sj


def tangent_exists(dd, delta, eps: float):
    """The common tangent exists: centre distance ``dd`` beyond ``|delta|`` (with
    ``1e-3 eps`` of slack)."""
    return dd > np.abs(delta) + eps * 1e-3


def tangent_normal(D, dd, delta):
    """Left normal ``n = exp(i beta)`` of the common tangent, ``beta = arg(D) +
    arccos(delta / d)`` (``D = c_j - c_i``, ``dd = |D|``; module docstring)."""
    cos = np.minimum(np.maximum(delta / dd, -1.0), 1.0)  # np.clip, without its overhead
    return np.exp(1j * (np.arctan2(D.imag, D.real) + np.arccos(cos)))


class Edges:
    """The query-independent successors of circle ``i`` in sense ``si``: the tangents to
    other circles (both senses) that pass both cones, with their segment status (``ok``: 0
    unknown, 1 free, -1 blocked; filled in by the searches); ``pi`` is None for a point."""

    __slots__ = ("i", "j", "sj", "seg", "pi", "pj", "th_d", "th_a", "od", "ok")

    def __init__(self, i, j, sj, seg, pi, pj, th_d, th_a, od):
        self.i, self.j, self.sj, self.seg, self.pi, self.pj = i, j, sj, seg, pi, pj
        self.th_d, self.th_a, self.od, self.ok = th_d, th_a, od, np.zeros(len(j), np.int8)

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the successors where ``mask`` is True."""
        for k in ("j", "sj", "seg", "pi", "pj", "th_d", "th_a", "od", "ok"):
            v = getattr(self, k)
            if v is not None:
                setattr(self, k, v[mask])

    @property
    def nbytes(self) -> int:
        return sum(getattr(getattr(self, k), "nbytes", 0) for k in self.__slots__)


def tangent_edges(C: Circles, I, SI, J, SJ, eps: float) -> dict[str, np.ndarray]:
    """The tangents from circles ``I`` (senses ``SI``) to circles ``J`` (senses ``SJ``) that
    exist (``|c_j - c_i| > |delta|``, ``i != j``) and pass both cones (the departure cone
    tested first, on more candidates).  ``I`` and ``SI`` may be one circle and sense (scalars,
    as if repeated).

    Returns
    -------
    dict
        Arrays over the kept tangents: ``i, si`` (one source: the scalars given), ``j, sj``,
        ``seg`` (length), ``pi``, ``pj`` (departure and arrival points, local complex),
        ``th_d``, ``th_a`` (their angles on their circles) and ``od`` (the departure's cone
        offset).
    """
    I, SI, J, SJ = (np.asarray(x) for x in (I, SI, J, SJ))
    one = I.ndim == 0  # one source: its values broadcast, nothing to gather
    ci, ri, cj, rj = C.center[I], C.rho[I], C.center[J], C.rho[J]
    D = cj - ci
    dd = np.abs(D)
    delta = SJ * rj - SI * ri
    k = ((J != I) & tangent_exists(dd, delta, eps)).nonzero()[0]
    nl = tangent_normal(D[k], dd[k], delta[k])
    Ik, SIk = (I, SI) if one else (I[k], SI[k])
    z = -SIk * nl
    od = cone_off(C, Ik, np.arctan2(z.imag, z.real))
    m = np.isfinite(od).nonzero()[0]  # the departure in its cone
    k, nl, od, z = k[m], nl[m], od[m], z[m]
    jk, sjk = J[k], SJ[k]
    w = -sjk * nl
    th_a = np.arctan2(w.imag, w.real)
    m = np.isfinite(cone_off(C, jk, th_a)).nonzero()[0]  # the arrival in its cone
    k, nl, jk, sjk, z = k[m], nl[m], jk[m], sjk[m], z[m]
    seg = np.sqrt(np.maximum(dd[k] ** 2 - delta[k] ** 2, 0.0))
    return {"i": I if one else I[k], "si": SI if one else SI[k], "j": jk, "sj": sjk,
            "seg": seg, "pi": ci - SI * ri * nl if one else ci[k] - SI[k] * ri[k] * nl,
            "pj": cj[k] - sjk * rj[k] * nl, "th_d": np.arctan2(z.imag, z.real),
            "th_a": th_a[m], "od": od[m]}


def _edges(t: dict[str, np.ndarray], sl: slice, i: int, point: bool) -> Edges:
    return Edges(i, t["j"][sl].astype(np.int32), t["sj"][sl].astype(np.int8), t["seg"][sl],
                 None if point else t["pi"][sl], t["pj"][sl], t["th_d"][sl], t["th_a"][sl],
                 t["od"][sl])


def edges_of_one(C: Circles, i: int, si: int, vis: np.ndarray, eps: float) -> Edges:
    """The :class:`Edges` of circle ``i`` in sense ``si`` towards the circles ``vis``."""
    t = tangent_edges(C, i, si, *both_senses(vis), eps)
    return _edges(t, slice(None), i, bool(C.rho[i] == 0))
