"""The CasADi model of the waypoint NLP: objective, flat constraint rows, one build per structure.

The NLP is built once per structure ``(N, the kept pairs' segments, vertex rows per pair,
IPOPT options)`` with ``casadi.nlpsol`` on SX symbols (``expand = True``; :func:`build_model`,
cached); the constraint vector is flat, indexed by the kept (segment, piece) pairs
(:func:`pair_rows`).  The piece vertices are *parameters* and the clearances *bounds*, so seeds
and warm starts with the same pairs re-use one compiled solver.  The maths is in the
:mod:`optplan.exact.nlp` module docstring.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["objective_function", "pair_rows", "build_model", "BuiltNLP", "IterCallback"]


def _length_terms(P: Any, eps: Any, w: Any, n_seg: int):
    """Smoothed length and spacing regulariser of a casadi ``(n_seg + 1, 2)`` point matrix."""
    import casadi as ca

    D = P[1:, :] - P[:-1, :]
    length = ca.sum1(ca.sqrt(ca.sum2(D * D) + eps**2))
    if n_seg > 1:
        DD = D[1:, :] - D[:-1, :]
        reg = w * n_seg * ca.sum1(ca.sum2(DD * DD))
    else:
        reg = 0
    return length, reg


@functools.lru_cache(maxsize=16)
def objective_function(n_points: int):
    """CasADi function ``(P (n_points, 2), eps, w) -> (smoothed length, regulariser)``.

    The expression the NLP minimises (in normalised units); exported for the twin test.
    """
    import casadi as ca

    P = ca.SX.sym("P", n_points, 2)
    eps = ca.SX.sym("eps")
    w = ca.SX.sym("w")
    L, R = _length_terms(P, eps, w, n_points - 1)
    return ca.Function("waypoint_length", [P, eps, w], [L, R], ["P", "eps", "w"], ["L", "R"])


class IterCallback:
    """Factory of a casadi iteration callback forwarding to a Python target (set per solve)."""

    @staticmethod
    def make(nx: int, ng: int, np_: int) -> Any:
        import casadi as ca

        class CB(ca.Callback):
            def __init__(self) -> None:
                ca.Callback.__init__(self)
                self.target: Callable[[float], bool] | None = None
                self.construct("optplan_nlp_iter", {})

            def get_n_in(self):
                return ca.nlpsol_n_out()

            def get_n_out(self):
                return 1

            def get_name_in(self, i):
                return ca.nlpsol_out(i)

            def get_name_out(self, i):
                return "ret"

            def get_sparsity_in(self, i):
                name = ca.nlpsol_out(i)
                if name == "f":
                    return ca.Sparsity.scalar()
                if name in ("x", "lam_x"):
                    return ca.Sparsity.dense(nx)
                if name in ("g", "lam_g"):
                    return ca.Sparsity.dense(ng)
                if name == "lam_p":
                    return ca.Sparsity.dense(np_)
                return ca.Sparsity(0, 0)

            def eval(self, arg):
                stop = False
                if self.target is not None:
                    stop = bool(self.target(float(arg[ca.nlpsol_out().index("f")])))
                return [1 if stop else 0]

        return CB()


@dataclass
class BuiltNLP:
    """A compiled NLP and its sizes (variables ``nx``, constraint rows ``ng``)."""

    solver: Any
    n_seg: int
    n_pairs: int
    n_rows: int
    nx: int
    ng: int
    callback: Any = None


def pair_rows(rows: np.ndarray) -> list[int]:
    """Order of the constraint rows: pair by pair, its ``rows[k]`` vertex rows, then its two
    endpoint rows and its norm row (the built expression lists all vertex rows, then all
    first-endpoint, second-endpoint and norm rows)."""
    K = len(rows)
    nvt = int(rows.sum())
    off = np.r_[0, np.cumsum(rows)[:-1]]
    out: list[int] = []
    for k in range(K):
        out += range(int(off[k]), int(off[k] + rows[k]))
        out += [nvt + k, nvt + K + k, nvt + 2 * K + k]
    return out


@functools.lru_cache(maxsize=32)
def build_model(n_seg: int, seg: tuple, rows: tuple, ipopt_opts: tuple,
           with_callback: bool) -> BuiltNLP:
    """Build the waypoint NLP for a structure: ``n_seg`` segments and the kept pairs, pair
    ``k`` on segment ``seg[k]`` (non-decreasing) with ``rows[k]`` vertex rows.

    Variables ``x = [interior waypoints (N-1)x2 row-major, a (2 per pair), c (1 per pair)]``;
    parameters ``[start, goal, eps, w, vertex rows (sum(rows) x 2)]``; constraint rows per
    pair: ``rows[k]`` vertex rows ``a.v - c`` (upper bound 0; the rows beyond the piece's
    vertex count repeat its last vertex and get an infinite bound), two endpoint rows
    ``a.p - c`` (lower bound = clearance), one ``|a|^2`` row (upper bound 1).  No slot of a
    segment is padded to the busiest segment's count (issue 18: such empty slots stayed in
    IPOPT's KKT system as free rows and made every iteration slower).  The
    expression is built with vectorised SX indexing (one operation per row type).
    """
    import casadi as ca

    N, K = n_seg, len(seg)
    nW = max(N - 1, 0)
    W = ca.SX.sym("W", nW * 2)
    A = ca.SX.sym("A", K * 2)
    C = ca.SX.sym("C", K)
    start = ca.SX.sym("start", 2)
    goal = ca.SX.sym("goal", 2)
    eps = ca.SX.sym("eps")
    w = ca.SX.sym("w")
    nvt = int(sum(rows))
    Vp = ca.SX.sym("V", nvt * 2)
    P = ca.vertcat(start.T, ca.reshape(W, 2, nW).T, goal.T)
    L, R = _length_terms(P, eps, w, N)
    if K:
        ax, ay = A[0::2], A[1::2]
        own = np.repeat(np.arange(K), rows).tolist()
        s0 = [int(i) for i in seg]
        s1 = [i + 1 for i in s0]
        def per_row(e):  # e[own] as a column: with K = 1, e is 1 x 1 and e[list] is a row
            return ca.reshape(e[own], len(own), 1)

        gv = per_row(ax) * Vp[0::2] + per_row(ay) * Vp[1::2] - per_row(C)
        Px, Py = P[:, 0], P[:, 1]
        e0 = ax * Px[s0] + ay * Py[s0] - C
        e1 = ax * Px[s1] + ay * Py[s1] - C
        gexpr = ca.vertcat(gv, e0, e1, ax * ax + ay * ay)[pair_rows(np.asarray(rows))]
    else:
        gexpr = ca.SX(0, 1)
    x = ca.vertcat(W, A, C)
    p = ca.vertcat(start, goal, eps, w, Vp)
    nlp = {"x": x, "p": p, "f": L + R, "g": gexpr}
    ip = dict(ipopt_opts)
    opts: dict[str, Any] = {"expand": True, "print_time": False, "error_on_fail": False,
                            "ipopt": ip}
    cb = None
    if with_callback:
        cb = IterCallback.make(x.numel(), gexpr.numel(), p.numel())
        opts["iteration_callback"] = cb
    solver = ca.nlpsol("waypoint_nlp", "ipopt", nlp, opts)
    return BuiltNLP(solver, N, K, nvt, int(x.numel()), int(gexpr.numel()), cb)

