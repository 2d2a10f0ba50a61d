"""The end-game of ``ipso`` (beyond the paper; options ``tighten_rounds``, ``endgame``,
``endgame_margin``): the candidate paths of a run tightened, the shortest kept.

Candidates (:func:`endgame_candidates`): the best collision-free particle, every island's best
and, with ``endgame = "classes"``, the roadmap corridors, reduced to the shortest candidate of
each homotopy class (:func:`one_per_class`); only paths collision-free with the margin of
``space.clear`` (else with the fitness kernel) qualify.  Tightening (:func:`tighten_best`): a
quick coarse :func:`optplan.swarm.refine.tighten` of every candidate ranks them
(:data:`QUICK_ROUNDS` rounds, :data:`QUICK_FRACTIONS`), those within ``endgame_margin`` of the
best (at most :data:`ENDGAME_KEEP`) are tightened in full, and the shortest result the fitness
finds collision-free is the answer.  The driver is :meth:`optplan.swarm.ipso.IPSO._finish`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from optplan.geometry import path_lengths
from optplan.swarm.core import SwarmSpace, decode
from optplan.swarm.refine import tighten
from optplan.swarm.signatures import signature_hashes

__all__ = [
    "QUICK_ROUNDS",
    "QUICK_FRACTIONS",
    "ENDGAME_KEEP",
    "pad_paths",
    "free_paths",
    "candidate_paths",
    "one_per_class",
    "endgame_candidates",
    "quick_rank",
    "tighten_best",
]

#: The end-game's quick ranking pass: rounds and cut fractions (1/2 to 1/16) of
#: :func:`~optplan.swarm.refine.tighten`; at most ENDGAME_KEEP candidates (those within
#: ``endgame_margin`` of the best) are then tightened in full.
QUICK_ROUNDS = 2
QUICK_FRACTIONS = 0.5 ** np.arange(1, 5)
ENDGAME_KEEP = 4


def pad_paths(paths: list[np.ndarray]) -> np.ndarray:
    """Polylines of different lengths as one array ``(P, M, 2)``, each padded with copies of
    its end point (repeated end points add zero-length segments: no crossing, no ray
    crossing)."""
    M = max(len(p) for p in paths)
    out = np.empty((len(paths), M, 2))
    for i, p in enumerate(paths):
        out[i, :len(p)] = p
        out[i, len(p):] = p[-1]
    return out


def free_paths(paths: np.ndarray, test) -> np.ndarray:
    """Collision-free flags of the polylines ``(P, M, 2)`` for the obstacle set ``test``
    (None: every path is free)."""
    if test is None:
        return np.ones(len(paths), bool)
    return test.crossings(paths, penetration=False).count == 0


def candidate_paths(space: SwarmSpace, feas_x: np.ndarray | None, island_x: Iterable,
                    seeds: Iterable) -> list[np.ndarray]:
    """The end-game's candidate polylines: the best collision-free particle ``feas_x`` (if
    any), the island bests ``island_x`` (particles) and the paths ``seeds``, in this order."""
    X = [feas_x] if feas_x is not None else []
    X += list(island_x)
    paths = list(decode(np.array(X), space)) if X else []
    paths += [np.asarray(p, float) for p in seeds]
    return paths


def one_per_class(cand: list[tuple[float, int]], sig: np.ndarray) -> list[tuple[float, int]]:
    """The first (shortest) of the sorted candidates ``(length, index)`` of each signature
    ``sig[index]``."""
    seen: set[int] = set()
    keep = []
    for L, i in cand:
        if sig[i] not in seen:
            seen.add(sig[i])
            keep.append((L, i))
    return keep


def endgame_candidates(space: SwarmSpace, feas_x: np.ndarray | None, island_x: Iterable,
                       seeds: Iterable, by_class: bool) -> tuple[list[np.ndarray], int]:
    """Collision-free candidate paths of the end-game (:func:`candidate_paths`), shortest
    first; ``by_class``: the shortest of each homotopy class only.  Returns them and the
    number of paths evaluated."""
    paths = candidate_paths(space, feas_x, island_x, seeds)
    if not paths:
        return [], 0
    padded = pad_paths(paths)
    # collision-free with the margin of space.clear: a path that is free only within the
    # geometric tolerance (a swarm best pressed onto an obstacle) can collide once cut
    feas = free_paths(padded, space.clear if space.clear is not None else space.obstacles)
    if not feas.any():
        feas = free_paths(padded, space.obstacles)
    lens = [float(path_lengths(p)) for p in paths]
    cand = sorted((lens[i], i) for i in range(len(paths)) if feas[i])
    if by_class:
        cand = one_per_class(cand, signature_hashes(padded, space))
    return [paths[i] for _, i in cand], len(paths)


def quick_rank(cand: list[np.ndarray], space: SwarmSpace, rounds: int,
               margin: float) -> tuple[list[np.ndarray], int]:
    """The quick coarse tightening of every candidate (at most :data:`QUICK_ROUNDS` of
    ``rounds``, :data:`QUICK_FRACTIONS`); returns the results within ``margin`` of the
    shortest (at most :data:`ENDGAME_KEEP`, shortest first) and the segments tested."""
    out, n = tighten(cand, space, rounds=min(rounds, QUICK_ROUNDS), fractions=QUICK_FRACTIONS)
    lens = np.array([path_lengths(p) for p in out])
    keep = [out[i] for i in np.argsort(lens, kind="stable")
            if lens[i] <= lens.min() * (1.0 + margin)][:ENDGAME_KEEP]
    return keep, n


def tighten_best(cand: list[np.ndarray], space: SwarmSpace, rounds: int, margin: float
                 ) -> tuple[np.ndarray | None, float, int, int]:
    """Tighten the candidates (:func:`quick_rank` first when there are several, then
    ``rounds`` rounds of :func:`optplan.swarm.refine.tighten`) and pick the shortest result
    the fitness finds collision-free.

    Returns ``(path, its length, candidates tightened in full, segments tested)``; the path
    is None (length ``inf``) when no result is collision-free.
    """
    n_eval = 0
    if len(cand) > 1:  # rank the candidates after a quick coarse tightening
        cand, n = quick_rank(cand, space, rounds, margin)
        n_eval += n
    out, n = tighten(cand, space, rounds=rounds)
    n_eval += n
    lens = np.array([path_lengths(p) for p in out])
    # a safety net: only paths the fitness finds collision-free
    ok = free_paths(pad_paths(out), space.obstacles)
    if not ok.any():
        return None, math.inf, len(cand), n_eval
    lens = np.where(ok, lens, np.inf)
    j = int(np.argmin(lens))
    return out[j], float(lens[j]), len(cand), n_eval
