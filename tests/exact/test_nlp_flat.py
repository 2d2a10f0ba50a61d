"""The waypoint NLP's flat constraint vector: one block of rows per kept
(segment, piece) pair, no empty slots padded to the busiest segment's count."""

from __future__ import annotations

import numpy as np

import optplan as op
from optplan.exact.nlp import WaypointNLP
from optplan.exact.nlp_model import build_model, pair_rows


def _scene() -> op.Problem:
    return op.parse_problem({
        "name": "nlp-flat-test",
        "bounds": [0.0, 0.0, 100.0, 100.0],
        "robots": [{"id": "r", "start": [5.0, 50.0], "goal": [95.0, 50.0], "radius": 2.0,
                    "max_speed": 1.0}],
        "obstacles": [
            {"type": "rectangle", "name": "box", "min": [40.0, 30.0], "max": [60.0, 70.0]},
            {"type": "circle", "name": "disc", "center": [80.0, 60.0], "radius": 5.0},
        ],
    })


def test_pair_rows_order_is_pair_by_pair() -> None:
    # built order: 4 + 8 vertex rows, then first endpoints, second endpoints, norms
    perm = pair_rows(np.array([4, 8]))
    assert perm == [0, 1, 2, 3, 12, 14, 16, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17]
    assert sorted(perm) == list(range(18))


def test_structure_has_no_padding() -> None:
    """Three pairs on segments 0, 0, 2 of a 3-segment path: 2 x 2 waypoint coordinates, 3 x 3
    hyperplane variables and 3 x (4 + 3) rows, nothing for the empty segment 1."""
    opts = tuple(sorted(WaypointNLP().ipopt_options().items()))
    built = build_model(3, (0, 0, 2), (4, 4, 4), opts, False)
    assert built.nx == 4 + 9
    assert built.ng == 3 * (4 + 3)
    assert built.n_pairs == 3 and built.n_rows == 12


def test_same_pairs_reuse_the_build_and_the_result() -> None:
    prob = _scene()
    init = np.array([[5.0, 50.0], [50.0, 75.0], [95.0, 50.0]])
    a = op.solve(prob, "nlp-ipopt", init=init)
    hits = build_model.cache_info().hits
    b = op.solve(prob, "nlp-ipopt", init=init)
    assert build_model.cache_info().hits > hits
    assert a.status is b.status and a.success
    np.testing.assert_array_equal(a.paths["r"], b.paths["r"])
    rnd = a.extras["ipopt"]["r"]["rounds"][0]
    assert rnd["vertex_rows"] % 4 == 0 and rnd["vertex_rows"] >= 4 * rnd["n_pairs"]
    assert "slots" not in rnd


def test_a_single_kept_pair_builds() -> None:
    """One (segment, piece) pair: CasADi indexes a 1 x 1 expression with a list as a row, which
    made the vertex rows 1 x n against n x 1 (trap-gnron failed with a dimension mismatch)."""
    built = build_model(3, (1,), (4,), (("print_level", 0),), False)
    assert built.ng == 4 + 3  # 4 vertex rows, 2 endpoint rows, 1 norm row
    res = op.solve("trap-gnron", "nlp-ipopt", rng=0, reference=True)
    assert res.status is op.Status.optimal, res.message
    assert res.metrics["ratio_to_optimum"] <= 1.0 + 1e-3
