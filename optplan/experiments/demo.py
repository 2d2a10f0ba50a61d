"""``make demo``: the toolkit's main job in one go.

Solves ``paper-warehouse`` (paper §VI.C, Figs 33-34) with the ``hybrid-paper`` solver (IPSO
global path on the known map -> inflection points -> SA-APF leader -> leader-follower
formation), prints a summary table, and writes the result JSON, a PNG and a GIF under
``runs/``.  The table gives both times of the run: the leader's arrival at its goal, and the
end of the simulation (the GIF's last frame), which comes later when the followers are still
settling into their formation slots::

    python -m optplan.experiments.demo [--problem paper-warehouse] [--solver hybrid-paper]
                                       [--seed 0] [--out runs]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import optplan as op
from optplan.exact.visgraph import shortest_length

__all__ = ["main", "summary_table"]


def summary_table(prob: op.Problem, res: op.Result) -> str:
    """Markdown summary of a (formation) result."""
    m = res.metrics
    opt = shortest_length(prob, prob.leader, known_only=True)
    glen = res.extras.get("global_length", math.nan)
    # the leader's arrival is not the end of the run: the simulation (and the GIF, which shows
    # all of it) goes on until the followers have settled in their slots (``settle_steps``)
    t_goal = float(res.extras.get("time_to_goal", math.nan))
    t_end = float(res.times[-1]) if res.times is not None and len(res.times) else math.nan
    after = (" (followers settling into formation after the leader's arrival)"
             if prob.formation is not None and t_end > t_goal else "")
    rows = [
        ("problem / solver", f"{prob.name} / {res.solver} (seed {res.seed})"),
        ("status", f"{res.status.value}: {res.message}"),
        ("every robot reached", str(bool(m["reached"]))),
    ]
    for rid, length in m["lengths"].items():
        rows.append((f"length {rid}", f"{length:.2f}"))
    rows += [
        ("leader global path length", f"{glen:.2f} ({res.extras.get('global_solver', '?')}, "
                                      f"{res.extras.get('global_status', '?')} on the known map)"),
        ("certified optimum (visgraph, known map)", f"{opt:.2f}" if opt else "n/a"),
        ("global path / optimum", f"{glen / opt:.4f}" if opt else "n/a"),
        ("inflection points (sub-goals)", str(len(res.extras.get("inflection_points", [])))),
        ("formation RMSE", f"{m.get('formation_rmse', math.nan):.3f}"),
        ("min separation (safety distance)",
         f"{m.get('min_separation', math.nan):.3f} ({m.get('safety_distance', math.nan):g})"),
        ("collisions (static / dynamic / separation)",
         f"{m['collisions']} ({m['static_collisions']} / {m['dynamic_contacts']} / "
         f"{m.get('separation_violations', 0)})"),
        ("min clearance static / moving", f"{m['min_clearance']:.3f} / "
                                          f"{m['min_clearance_dynamic']:.3f}"),
        ("leader's time to goal (simulated)", f"{t_goal:.1f} s"),
        ("end of simulation (the GIF's last frame)", f"{t_end:.1f} s{after}"),
        ("wall time", f"{res.wall_time:.1f} s"),
    ]
    w = max(len(k) for k, _ in rows)
    lines = [f"| {'quantity':<{w}} | value |", f"|{'-' * (w + 2)}|-------|"]
    lines += [f"| {k:<{w}} | {v} |" for k, v in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="optplan demo", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problem", default="paper-warehouse")
    ap.add_argument("--solver", default="hybrid-paper")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("runs"))
    ap.add_argument("--global-solver", default=None,
                    help="override the hybrid's global stage (default: the preset's)")
    ap.add_argument("--no-gif", action="store_true", help="skip the animation")
    a = ap.parse_args(argv)

    t0 = time.perf_counter()
    prob = op.load_problem(a.problem)
    print(prob.summary())
    print(f"\nsolving with {a.solver} (seed {a.seed}) ...", flush=True)
    over = {"global_solver": a.global_solver} if a.global_solver else {}
    res = op.solve(prob, a.solver, rng=a.seed, **over)
    print()
    print(summary_table(prob, res))

    from optplan.plot import animate, plot_result

    a.out.mkdir(parents=True, exist_ok=True)
    stem = a.out / f"demo-{a.problem}-{a.solver}"
    res.save(stem.with_suffix(".json"))
    plot_result(res, problem=prob, out=stem.with_suffix(".png"), snapshot_every=100)
    written = [stem.with_suffix(".json"), stem.with_suffix(".png")]
    if not a.no_gif:
        animate(res, stem.with_suffix(".gif"), problem=prob, fps=10, max_frames=120)
        written.append(stem.with_suffix(".gif"))
    print("\nwrote " + ", ".join(str(p) for p in written))
    print(f"total {time.perf_counter() - t0:.1f} s")
    return 0 if res.success else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
