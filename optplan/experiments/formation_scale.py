"""Scale invariance of the formation presets (issue 15): the same scene drawn 100 x smaller or
larger.

Every scene is scaled about the origin by ``--scales`` with
:func:`optplan.problem.transform_problem` (positions, sizes, radii, speeds, formation distances,
tolerances, sensing range and ``length_scale``) and solved by each formation preset (seed 0,
preset settings).  Printed (markdown): per scene and preset, the status at every scale, the
total path length and the formation RMSE at scale 1 (map units of the scene as written) and the
largest relative deviation of the rescaled length and RMSE over the other scales.

    python -m optplan.experiments.formation_scale [--scenes a,b] [--solvers a,b]
        [--scales 0.01,100] [--path-solver visgraph]
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import optplan as op
from optplan.problem import transform_problem

__all__ = ["main", "run"]

SCENES = ("paper-formation", "formation-open-field", "warehouse-team")
SOLVERS = ("leader-follower-paper", "formation-qp")


def run(scene: str, solver: str, scale: float, path_solver: str | None = None
        ) -> tuple[str, float, float]:
    """``(status, total path length / scale, formation RMSE / scale)``."""
    prob = transform_problem(op.load_problem(scene), scale)
    extra: dict[str, Any] = {} if path_solver is None else {"path_solver": path_solver}
    r = op.solve(prob, solver, rng=0, **extra)
    total = sum(float(v) for v in r.metrics["lengths"].values())
    return r.status.value, total / scale, float(r.metrics["formation_rmse"]) / scale


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--solvers", default=",".join(SOLVERS))
    ap.add_argument("--scales", default="0.01,100")
    ap.add_argument("--path-solver", default=None,
                    help="planner of the leader's reference (default: the preset's, ipso)")
    a = ap.parse_args(list(argv) if argv is not None else None)
    scales = [float(x) for x in a.scales.split(",")]
    print("| scene | preset | length_scale | status x1 / " + " / ".join(f"x{k:g}" for k in scales)
          + " | total length x1 | formation RMSE x1 | max rel. deviation length | "
          "max rel. deviation RMSE |")
    print("|---|---|---:|---|---:|---:|---:|---:|")
    for scene in a.scenes.split(","):
        ell = op.load_problem(scene).length_scale
        for solver in a.solvers.split(","):
            st1, len1, rmse1 = run(scene, solver, 1.0, a.path_solver)
            sts, dl, dr = [st1], 0.0, 0.0
            for k in scales:
                st, length, rmse = run(scene, solver, k, a.path_solver)
                sts.append(st)
                dl = max(dl, abs(length - len1) / len1)
                dr = max(dr, abs(rmse - rmse1) / rmse1 if rmse1 else abs(rmse - rmse1))
            print(f"| {scene} | {solver} | {ell:g} | {' / '.join(sts)} | {len1:.3f} | "
                  f"{rmse1:.4f} | {dl:.1e} | {dr:.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
