"""Digest of the ``ipso`` answers on the maps of the tails benchmark: identical outputs check.

For every map of :mod:`bench_ipso_tails` (the paper maps and the corridor maps of
``--corridor-seeds``) and every seed ``0 .. --seeds-1``, ``ipso`` (or the ``--solver`` preset,
e.g. ``ipso-paper``; with ``--option k=v`` overrides) runs once; per map the SHA-256 of all
returned paths (their float64 bytes, in seed order) is printed, with an overall digest.  Two
versions of the code whose pure-speed changes are behaviour-identical print the same digests
for the same seeds; ``--nlp`` also digests the NLP polish (``nlp-ipopt`` warm-started from the
``ipso`` path).

Run: ``.venv/bin/python benchmarks/ipso_digest.py [--seeds 30] [--corridor-seeds 0 1 2]
[--nlp] [--solver ipso-paper] [--option endgame=classes ...]``.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

import optplan as op

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_ipso_tails import maps  # noqa: E402


def _value(s: str):
    for conv in (int, float):
        try:
            return conv(s)
        except ValueError:
            pass
    return s


def digest(paths: dict) -> bytes:
    """Bytes of the paths of one result (robot ids sorted)."""
    return b"".join(k.encode() + np.ascontiguousarray(paths[k], float).tobytes()
                    for k in sorted(paths))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--corridor-seeds", type=int, nargs="*", default=[0, 1, 2])
    ap.add_argument("--nlp", action="store_true", help="also digest the NLP polish")
    ap.add_argument("--maps", nargs="*", default=None, help="only these map names")
    ap.add_argument("--solver", default="ipso", help="the preset to digest (e.g. ipso-paper)")
    ap.add_argument("--option", nargs="*", default=[], help="ipso overrides key=value")
    args = ap.parse_args(argv)
    over = {k: _value(v) for k, v in (o.split("=", 1) for o in args.option)}
    total = hashlib.sha256()
    for name, prob in maps(args.corridor_seeds):
        if args.maps and name not in args.maps:
            continue
        h, hn = hashlib.sha256(), hashlib.sha256()
        for s in range(args.seeds):
            r = op.solve(prob, args.solver, rng=s, **over)
            h.update(digest(r.paths))
            if args.nlp:
                q = op.solve(prob, "nlp-ipopt", init=r.paths)
                hn.update(digest(q.paths))
        line = f"{name}: {args.solver} {h.hexdigest()[:16]}"
        if args.nlp:
            line += f"  nlp {hn.hexdigest()[:16]}"
        print(line, flush=True)
        total.update(line.encode())
    print(f"all: {total.hexdigest()[:16]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
