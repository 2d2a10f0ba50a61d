"""``optplan export-path``: a saved result's timed path as a ``nav_msgs/Path`` (YAML or JSON)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TextIO

from optplan.cli.common import CLIError
from optplan.cli.figures import _load_result


def _format(args: argparse.Namespace) -> str:
    """``yaml`` or ``json``: ``--format``, else the suffix of ``--out``, else YAML."""
    if args.format:
        return str(args.format)
    if args.out and Path(args.out).suffix.lower() == ".json":
        return "json"
    return "yaml"


def cmd_export_path(args: argparse.Namespace, out: TextIO) -> int:
    """One robot's path of a result JSON as a ``nav_msgs/Path`` message
    (:func:`optplan.maps.path_msg`), on stdout or into ``--out``."""
    import yaml

    from optplan.maps import path_msg

    if not math.isfinite(args.start_time) or args.start_time < 0:
        raise CLIError(f"--start-time must be a finite number of seconds >= 0, got "
                       f"{args.start_time:g}")
    res, _ = _load_result(args.result, None)
    try:
        msg = path_msg(res, args.robot, frame_id=args.frame_id, start_time=args.start_time)
    except ValueError as e:
        raise CLIError(f"{args.result}: {str(e).replace('robot:', '--robot:', 1)}") from None
    text = (json.dumps(msg, indent=1) + "\n" if _format(args) == "json"
            else yaml.safe_dump(msg, sort_keys=False, default_flow_style=None))
    if not args.out:
        out.write(text)
        return 0
    Path(args.out).write_text(text, encoding="utf-8")
    rid = args.robot or res.metrics.get("leader") or next(iter(res.paths))
    print(f"wrote {args.out}: nav_msgs/Path of robot {rid}"
          f", {len(msg['poses'])} poses over {_span(msg)} s in frame {args.frame_id!r}",
          file=out)
    return 0


def _span(msg: dict) -> str:
    first, last = (msg["poses"][k]["header"]["stamp"] for k in (0, -1))
    return f"{(last['sec'] - first['sec']) + 1e-9 * (last['nanosec'] - first['nanosec']):.3f}"
