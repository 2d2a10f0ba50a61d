"""The figures of docs/plotting.md (headless; run from anywhere).

    python docs/figures/plotting.py                 # into runs/plotting-figures/
    python docs/figures/plotting.py --out docs/img  # refresh the docs' figures

Writes ``plotting-map.png``, ``plotting-formation.png``, ``plotting-formation.gif``,
``plotting-collisions.png`` and ``plotting-convergence.png`` into ``--out`` (default
``runs/plotting-figures``; the docs' copies in ``docs/img/`` change only when ``--out`` names
that folder) with :mod:`optplan.plot`, the same functions behind ``optplan show --out``,
``optplan plot`` and ``optplan animate``, and prints the numbers the page quotes (the
collision counts, the animation's cost).  ``--no-gif`` skips the animation.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import optplan as op

__all__ = ["main"]

#: the default output folder (never the docs unless asked)
DEFAULT_OUT = Path("runs") / "plotting-figures"


def first_available(*names: str) -> str:
    """The first solver name that resolves (presets may still be missing in a build)."""
    for n in names:
        try:
            op.get_solver(n)
            return n
        except (ValueError, ImportError):
            continue
    raise SystemExit(f"none of the solvers {names} is available")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python docs/figures/plotting.py",
                                 description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT,
                    help=f"output folder (default {DEFAULT_OUT})")
    ap.add_argument("--no-gif", action="store_true", help="skip the animation")
    a = ap.parse_args(argv)
    from optplan import plot

    out: Path = a.out
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    # 1. a map: known and temporary obstacles, inflated outlines, moving obstacles' tracks
    plot.plot_problem(op.load_problem("paper-hybrid"), out=out / "plotting-map.png", dpi=100)

    # 2. a formation run with snapshots, and its animation (timed: the page quotes it)
    lf = first_available("leader-follower-paper", "leader-follower")
    res = op.solve("paper-formation", lf, rng=0)
    print(res.summary())
    plot.plot_result(res, out=out / "plotting-formation.png", snapshot_every=40)
    if not a.no_gif:
        c0, w0 = time.process_time(), time.perf_counter()
        plot.animate(res, out / "plotting-formation.gif", fps=10, max_frames=60)
        print(f"animate: 60 frames of {res.problem} in {time.process_time() - c0:.1f} s CPU "
              f"({time.perf_counter() - w0:.1f} s wall)")

    # 3. what the validator rejects, in red: the visibility graph plans on the known map, so
    #    its path runs through the temporary obstacles it cannot see
    res = op.solve("paper-hybrid", "visgraph")
    m = res.metrics
    print(f"visgraph on paper-hybrid: {res.status.value}, static collisions "
          f"{m['static_collisions']} with {m['crossed']}, in bounds {m['in_bounds']}")
    plot.plot_result(res, out=out / "plotting-collisions.png")

    # 4. convergence of two swarm solvers over 5 common seeds (median and IQR band): plain PSO,
    #    feasible in fewer than half of the runs (no median in the right panel), and the IPSO
    #    variant
    groups = {}
    for name in ("pso", "ipso"):
        groups[name] = [op.solve("paper-env1", name, rng=k) for k in range(5)]
        print(name, [round(r.metrics["length"], 1) for r in groups[name]],
              "collision-free:", sum(r.metrics["collisions"] == 0 for r in groups[name]))
    plot.plot_convergence(groups, out=out / "plotting-convergence.png")

    print(f"wrote {len(list(out.glob('plotting-*')))} files to {out} in "
          f"{time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
