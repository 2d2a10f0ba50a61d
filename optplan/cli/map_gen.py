"""``optplan gen-map``: a seeded MovingAI benchmark map and its ``.scen``."""

from __future__ import annotations

import argparse
import time
from typing import TextIO


def cmd_gen_map(args: argparse.Namespace, out: TextIO) -> int:
    """Write ``<out>/<name>.map`` and ``<out>/<name>.map.scen`` (name: MovingAI's
    ``<kind>-<size>-<size>[-<density %>]`` and ``-seed<S>``) and say what was written."""
    import numpy as np

    from optplan.maps.movingai_gen import default_name, generate_benchmark

    name = args.name or f"{default_name(args.kind, args.size, args.density)}-seed{args.seed}"
    t0 = time.perf_counter()
    gen = generate_benchmark(args.kind, args.size, args.out, rng=np.random.default_rng(args.seed),
                             queries=args.queries, density=args.density, name=name)
    dt = time.perf_counter() - t0
    lo, hi = gen.buckets
    print(f"wrote {gen.map_path} ({gen.width} x {gen.height} cells, {gen.blocked:.1%} blocked) "
          f"and {gen.scen_path} ({gen.queries} queries, buckets {lo}..{hi}) in {dt:.1f} s",
          file=out)
    return 0
