"""Paper fidelity and scale checks of the local planners (docs/solvers/apf.md).

``python -m optplan.experiments.apf_fidelity [--seeds 5] [--skip kb,scale,metre]``

Prints four markdown tables:

1. **Boltzmann constant** (option ``k_B`` of ``sa-apf``): ``sa-apf-paper`` with the default
   dimensionless ``k_B = 1`` and with the paper's 1.380649e-23 on ``paper-apf-env1``,
   ``paper-apf-env2`` and ``trap-u`` (``--seeds`` seeds): successes, detections split into
   eq 38 itself and the added stall / oscillation tests, escapes and median SA proposals.
2. **SA defaults**: ``sa-apf-paper`` on ``trap-u`` for a few ``(tau_0, sa_step)`` pairs
   (``--sweep-seeds`` seeds): successes, runs with an escape, median SA proposals.
3. **Scale invariance**: every time-stepping preset on its representative scene drawn
   x 0.01, x 1 and x 100 (:func:`optplan.problem.transform_problem`, seed 0): status and total
   path length divided by the scale.
4. **Metre-scale scenes**: the time-stepping presets on ``warehouse-grid`` and
   ``office-floor`` and ``warehouse-team`` (seed 0): ``length_scale``, status and message.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

import optplan as op
from optplan.experiments import option_groups, option_sweep, sections_main
from optplan.geometry.collision import path_lengths
from optplan.potential.sa_apf import K_B, K_B_PAPER
from optplan.problem import transform_problem

__all__ = ["sweep_rows", "format_sweep", "KB_SCENES", "PRESETS", "REPRESENTATIVE",
           "METRE_SCENES", "kb_rows", "format_kb", "scale_rows", "format_scale", "metre_rows",
           "format_metre", "main"]

KB_SCENES = ("paper-apf-env1", "paper-apf-env2", "trap-u")
PRESETS = ("apf-paper", "sa-apf-paper", "hybrid-paper", "hybrid-qp")
#: the scene of each time-stepping preset in tests/core/test_scale_invariance.py
REPRESENTATIVE = {"apf-paper": "trap-saddle", "sa-apf-paper": "trap-u",
                  "hybrid-paper": "paper-hybrid", "hybrid-qp": "paper-hybrid"}
#: (preset, scene) pairs whose simulated-annealing walks are chaotic: before the hybrid planned
#: in the canonical frame (optplan.canonical) their lengths parted between the scales; the docs
#: show them beside the representative scenes
CHAOTIC = (("hybrid-paper", "paper-env1"), ("hybrid-paper", "warehouse-grid"),
           ("hybrid-paper", "office-floor"))
SCALES = (0.01, 1.0, 100.0)
METRE_SCENES = ("warehouse-grid", "office-floor", "warehouse-team")


def _stats(res: op.Result) -> dict[str, Any]:
    """Detections / escapes / SA proposals of a local-planner or hybrid result (extras)."""
    ex = res.extras
    if "detections" in ex:
        det, esc, sa = ex["detections"], ex["local_minima_escaped"], ex["sa_steps"]
    else:  # hybrid: per driver
        st = list(ex.get("local_stats", {}).values())
        det = {k: sum(s["detections"][k] for s in st) for k in ("eq38", "stall", "oscillation")}
        esc, sa = sum(s["escapes"] for s in st), sum(s["sa_steps"] for s in st)
    return {"eq38": int(det["eq38"]), "stall_osc": int(det["stall"] + det["oscillation"]),
            "escapes": int(esc), "sa_steps": int(sa)}


def kb_rows(seeds: Sequence[int], scenes: Sequence[str] = KB_SCENES) -> list[dict[str, Any]]:
    return option_sweep("sa-apf-paper", "k_B", (K_B, K_B_PAPER), seeds, scenes,
                        lambda prob, res: {"message": res.message, **_stats(res)})


def format_kb(rows: list[dict[str, Any]]) -> str:
    out = ["| scene | k_B | success | detections: eq 38 / stall or oscillation | escapes | "
           "median SA proposals |", "|---|---|---|---|---|---|"]
    for scene, kb, rs in option_groups(rows, "k_B", (K_B, K_B_PAPER)):
        out.append(f"| {scene} | {kb:g} | {sum(r['success'] for r in rs)}/{len(rs)} "
                   f"| {sum(r['eq38'] for r in rs)} / {sum(r['stall_osc'] for r in rs)} "
                   f"| {sum(r['escapes'] for r in rs)} "
                   f"| {float(np.median([r['sa_steps'] for r in rs])):.0f} |")
    return "\n".join(out)


def sweep_rows(seeds: Sequence[int], scene: str = "trap-u",
               grid: Sequence[tuple[float, float]] = ((1.0, 4.0), (3.0, 4.0), (5.0, 4.0),
                                                      (5.0, 10.0), (10.0, 10.0))
               ) -> list[dict[str, Any]]:
    """``sa-apf-paper`` on ``scene`` for each ``(tau_0, sa_step)`` of ``grid``."""
    prob = op.load_problem(scene)
    rows = []
    for tau_0, step in grid:
        for s in seeds:
            res = op.solve(prob, "sa-apf-paper", rng=int(s), tau_0=tau_0, sa_step=step)
            rows.append({"tau_0": tau_0, "sa_step": step, "seed": int(s),
                         "success": res.success, **_stats(res)})
    return rows


def format_sweep(rows: list[dict[str, Any]], scene: str = "trap-u") -> str:
    out = [f"| tau_0 | sa_step | solved on {scene} | runs with an escape | median SA proposals |",
           "|---|---|---|---|---|"]
    for tau_0, step in dict.fromkeys((r["tau_0"], r["sa_step"]) for r in rows):
        rs = [r for r in rows if r["tau_0"] == tau_0 and r["sa_step"] == step]
        out.append(f"| {tau_0:g} | {step:g} | {sum(r['success'] for r in rs)}/{len(rs)} "
                   f"| {sum(r['escapes'] > 0 for r in rs)}/{len(rs)} "
                   f"| {float(np.median([r['sa_steps'] for r in rs])):.0f} |")
    return "\n".join(out)


def scale_rows(pairs: Sequence[tuple[str, str]] | None = None) -> list[dict[str, Any]]:
    """Status and rescaled length of each ``(preset, scene)`` at every scale (default: the
    representative scenes, then :data:`CHAOTIC`)."""
    if pairs is None:
        pairs = [(p, REPRESENTATIVE[p]) for p in PRESETS] + list(CHAOTIC)
    rows = []
    for p, scene in pairs:
        for k in SCALES:
            prob = transform_problem(op.load_problem(scene), k)
            res = op.solve(prob, p, rng=0)
            rows.append({"preset": p, "scene": scene, "scale": k, "status": res.status.value,
                         "length": sum(float(v) for v in res.metrics["lengths"].values()) / k,
                         "length_scale": prob.length_scale, "extent": prob.extent / k,
                         "paths": {i: q / k for i, q in res.paths.items()},
                         "times": res.times,
                         "global": {i: q / k for i, q in
                                    res.extras.get("global_paths", {}).items()}})
    return rows


def _agree_until(a: dict[str, Any], b: dict[str, Any]) -> float:
    """Time until which the rescaled trajectories of two rows stay within 1e-6 x the map
    extent of each other (``inf``: all the way)."""
    tol = 1e-6 * a["extent"]
    t_div = np.inf
    for rid, pa in a["paths"].items():
        pb = b["paths"][rid]
        n = min(len(pa), len(pb))
        bad = np.nonzero(np.hypot(*(pa[:n] - pb[:n]).T) > tol)[0]
        if len(bad):
            t_div = min(t_div, float(a["times"][bad[0]]))
        elif len(pa) != len(pb):
            t_div = min(t_div, float(a["times"][n - 1]))
    return t_div


def _scale_groups(rows: list[dict[str, Any]]) -> list[tuple[str, str, list[dict[str, Any]]]]:
    """The rows of :func:`scale_rows` grouped by ``(preset, scene)``, in first-seen order. Returns
    ``(preset, scene, rows of that pair)``."""
    pairs = dict.fromkeys((r["preset"], r["scene"]) for r in rows)
    return [(p, scene, [r for r in rows if r["preset"] == p and r["scene"] == scene])
            for p, scene in pairs]


def _scale_line(p: str, scene: str, rs: list[dict[str, Any]]) -> str:
    """One table line: status and length / scale at each scale, their largest relative difference
    and how long the trajectories agree with the x 1 one (:func:`_agreement`); ``rs`` are their
    rows, one per scale, one of them at scale 1.  Returns the markdown table line."""
    base = next(r["length"] for r in rs if r["scale"] == 1.0)
    dev = max(abs(r["length"] - base) / base for r in rs) if base > 0 else math.nan
    cells = " | ".join(f"{r['status']}, {r['length']:.3f}" for r in rs)
    return f"| {p} | {scene} | {cells} | {dev:.1e} | {_agreement(rs)} |"


def _agreement(rs: list[dict[str, Any]]) -> str:
    """How long the trajectories at every scale agree with the x 1 one ; ``rs`` are the rows of one
    ``(preset, scene)``, one per scale, one of them at scale 1.  Returns ``"the end"`` when they
    agree all the way, else the time (s) of the first divergence, one decimal."""
    one = next(r for r in rs if r["scale"] == 1.0)
    until = min(_agree_until(one, r) for r in rs if r is not one)
    return "the end" if until == np.inf else f"{until:.1f}"


def _same_global(gs: list[np.ndarray], extent: float) -> bool:
    """True when the global paths of one robot at every scale have the same vertex count and agree
    within 1e-9 x the map extent (``gs``: the robot's rescaled global path at each scale;
    ``extent``: the rescaled map extent). Returns whether the paths agree."""
    return all(len(g) == len(gs[0]) and np.allclose(g, gs[0], rtol=0, atol=1e-9 * extent)
               for g in gs)


def _global_notes(p: str, scene: str, rs: list[dict[str, Any]]) -> list[str]:
    """Notes on the robots whose global paths differ between the scales (``rs``: their rows; only
    the rows with global paths count, and nothing is noted unless there is one such row per scale).
    Returns one markdown list item per robot whose global paths differ."""
    rs = [r for r in rs if r["global"]]
    if len(rs) != len(SCALES):
        return []
    notes = []
    for rid in rs[0]["global"]:
        gs = [r["global"][rid] for r in rs]
        if _same_global(gs, rs[0]["extent"]):
            continue
        desc = " / ".join(f"{path_lengths(g):.6f} "
                          f"({len(g)} vertices)" for g in gs)
        notes.append(f"- {p} on {scene}, {rid}: global path length / scale at x "
                     + " / ".join(f"{k:g}" for k in SCALES) + f": {desc}")
    return notes


def format_scale(rows: list[dict[str, Any]]) -> str:
    """Markdown table of :func:`scale_rows`, with notes on global paths that differ. Returns the
    table, one line per ``(preset, scene)``, then the notes if any."""
    out = ["| preset | scene | " + " | ".join(f"x {k:g}: status, length / scale" for k in SCALES)
           + " | max relative length difference | trajectories agree until (s) |",
           "|---|---|" + "---|" * (len(SCALES) + 2)]
    groups = _scale_groups(rows)
    out += [_scale_line(p, scene, rs) for p, scene, rs in groups]
    notes = [n for p, scene, rs in groups for n in _global_notes(p, scene, rs)]
    if notes:
        out += ["", "Global paths that differ between the scales:", *notes]
    return "\n".join(out)


def metre_rows(presets: Sequence[str] = PRESETS, scenes: Sequence[str] = METRE_SCENES,
               seed: int = 0) -> list[dict[str, Any]]:
    rows = []
    for scene in scenes:
        prob = op.load_problem(scene)
        for p in presets:
            res = op.solve(prob, p, rng=seed)
            rows.append({"scene": scene, "preset": p, "length_scale": prob.length_scale,
                         "status": res.status.value, "message": res.message,
                         "collisions": int(res.metrics["collisions"]), **_stats(res),
                         "sensing_gap": sensing_gap(prob, res)})
    return rows


def sensing_gap(problem: op.Problem, res: op.Result) -> dict[str, Any]:
    """The largest difference, over the path samples of ``res``, between the distance to a
    static obstacle that the planners sense (:meth:`optplan.sim.ObstacleField.nearest`) and
    the exact distance (shapely); ``{}`` when there is none above 1e-6."""
    import shapely

    from optplan.sim import ObstacleField

    fld = ObstacleField(problem)
    best: dict[str, Any] = {}
    for rid, path in res.paths.items():
        _, dist = fld.nearest(path, 0.0)
        for j, o in enumerate(problem.obstacles):
            if o.geometry is None:
                continue
            exact = shapely.distance(o.geometry, shapely.points(path))
            gap = dist[:, j] - exact
            i = int(np.argmax(np.abs(gap)))
            if abs(gap[i]) > max(1e-6, best.get("gap", 0.0)):
                best = {"gap": float(abs(gap[i])), "robot": rid, "obstacle": o.name,
                        "at": path[i].tolist(), "sensed": float(dist[i, j]),
                        "exact": float(exact[i])}
    return best


def format_metre(rows: list[dict[str, Any]]) -> str:
    out = ["| scene (length_scale) | preset | status | collisions | detections: eq 38 / "
           "stall or oscillation | escapes | message |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        msg = r["message"].replace("|", "/")
        out.append(f"| {r['scene']} ({r['length_scale']:.4f}) | {r['preset']} | {r['status']} "
                   f"| {r['collisions']} | {r['eq38']} / {r['stall_osc']} | {r['escapes']} "
                   f"| {msg} |")
    gaps = [r for r in rows if r.get("sensing_gap")]
    if gaps:
        out += ["", "Sensed vs exact distance to a static obstacle, largest gap along the paths:"]
        for r in gaps:
            g = r["sensing_gap"]
            out.append(f"- {r['scene']} / {r['preset']}: {g['robot']} at ({g['at'][0]:.2f}, "
                       f"{g['at'][1]:.2f}): {g['obstacle']} sensed at {g['sensed']:.3f}, exact "
                       f"{g['exact']:.3f}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    return sections_main("optplan.experiments.apf_fidelity", __doc__, [
        ("--seeds", 5, "the k_B table"),
        ("--sweep-seeds", 8, "the tau_0 / sa_step sweep on trap-u"),
    ], [
        ("kb", "Boltzmann constant of eq 15, sa-apf-paper ({seeds} seeds)",
         lambda a: format_kb(kb_rows(range(a.seeds)))),
        ("sweep", "tau_0 / sa_step sweep, sa-apf-paper on trap-u ({sweep_seeds} seeds)",
         lambda a: format_sweep(sweep_rows(range(a.sweep_seeds)))),
        ("scale", "Scale invariance (seed 0; the scene drawn x 0.01, x 1, x 100)",
         lambda a: format_scale(scale_rows())),
        ("metre", "Metre-scale scenes (seed 0)", lambda a: format_metre(metre_rows())),
    ], argv)


if __name__ == "__main__":
    raise SystemExit(main())
