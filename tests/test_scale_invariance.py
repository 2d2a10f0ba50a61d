"""Scale invariance of every preset (metamorphic): the same scene drawn 100 x smaller or larger.

:func:`optplan.problem.transform_problem` scales every length of a scene (positions, sizes, radii,
speeds, formation distances, tolerances, sensing range and ``length_scale``); every preset must
then give the same status and lengths that scale within 1 % (stochastic presets: the same seed).
The fast test runs one representative scene per preset; the ``slow`` test runs every catalogue
scene with every preset.
"""

from __future__ import annotations

from functools import cache

import pytest

import optplan as op
from optplan.problem import transform_problem

SCALES = (0.01, 100.0)
REL_TOL = 0.01

#: preset -> one scene it is meant for (the fast test)
REPRESENTATIVE = {
    "apf-paper": "trap-saddle",
    "sa-apf-paper": "trap-u",
    "hybrid-paper": "paper-hybrid",
    "hybrid-qp": "paper-hybrid",
    "leader-follower-paper": "paper-formation",
    "formation-qp": "paper-formation",
    "ipso-paper": "paper-env1",
    "ipso": "paper-env2",
    "mpso-paper": "paper-env1",
    "pso-paper": "paper-env2",
    "nlp-ipopt": "paper-env1",
    "visgraph": "warehouse-grid",
}


@cache
def outcome(scene: str, solver: str, scale: float) -> tuple[str, float]:
    """``(status, total path length / scale)``, or ``("error: ...", nan)`` for a refused input."""
    prob = transform_problem(op.load_problem(scene), scale)
    try:
        r = op.solve(prob, solver, rng=0, reference=False)
    except ValueError as e:  # e.g. a formation backend on a scene without [formation]
        return f"error: {str(e).split(':')[-1].strip()}", float("nan")
    total = sum(float(len_) for len_ in r.metrics["lengths"].values())
    return r.status.value, total / scale


def check(scene: str, solver: str) -> None:
    st1, len1 = outcome(scene, solver, 1.0)
    for k in SCALES:
        st, length = outcome(scene, solver, k)
        assert st == st1, f"{solver} on {scene} x {k:g}: status {st!r}, at scale 1 {st1!r}"
        if not st.startswith("error"):
            assert length == pytest.approx(len1, rel=REL_TOL), (
                f"{solver} on {scene} x {k:g}: length {length:.6g} (rescaled), at scale 1 "
                f"{len1:.6g}")


def test_every_preset_has_a_representative_scene() -> None:
    from optplan.catalog import preset_files

    assert set(preset_files()) == set(REPRESENTATIVE)


@pytest.mark.parametrize("solver", sorted(REPRESENTATIVE))
def test_scale_invariance_representative(solver: str) -> None:
    check(REPRESENTATIVE[solver], solver)


#: Known failures of the length check (the status is the same at every scale): the hybrid's
#: simulated-annealing walk is chaotic on these scenes, so a last-bit difference of a position
#: (x 0.01 is not exact in binary) or of the global path grows until a later decision flips (a
#: detection, a skipped sub-goal) and the walks part (``python -m
#: optplan.experiments.apf_fidelity`` prints where).  The global stage itself (``ipso``, whose
#: own lengths agree within 1 % and pass above) already returns paths that differ in the 6th
#: digit on warehouse-grid, and on office-floor one robot's path at x 1 takes a neighbouring
#: corridor 0.9 % longer: a near-tie in a discrete choice that rounding breaks differently.
#: Making them agree needs the planners to run in a canonical, quantised frame (not done; see
#: docs/solvers/apf.md).
CHAOTIC = {(s, p) for s in ("paper-env1", "warehouse-grid", "office-floor")
           for p in ("hybrid-paper", "hybrid-qp")}


@pytest.mark.slow
@pytest.mark.parametrize("scene", op.list_problems())
@pytest.mark.parametrize("solver", op.list_solvers())
def test_scale_invariance_every_scene(scene: str, solver: str) -> None:
    if (scene, solver) in CHAOTIC:
        statuses = {outcome(scene, solver, k)[0] for k in (1.0, *SCALES)}
        assert len(statuses) == 1, f"{solver} on {scene}: statuses {statuses}"
        pytest.xfail("chaotic SA walk: the status agrees at every scale, the lengths part")
    check(scene, solver)
