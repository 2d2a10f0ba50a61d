"""What every command shares: the error type, ``--set`` parsing, list and number formatting."""

from __future__ import annotations

import math
import tomllib
from typing import Any

PROG = "optplan"


class CLIError(Exception):
    """A user error detected by the CLI itself (exit status 2)."""




def parse_set(items: list[str] | None) -> dict[str, Any]:
    """Parse ``key=value`` items; values are TOML literals, else bare strings.

    >>> parse_set(["w=[0.9, 0.2]", "n=30", "name=ipso-paper", "flag=true"])
    {'w': [0.9, 0.2], 'n': 30, 'name': 'ipso-paper', 'flag': True}
    """
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise CLIError(f"--set expects key=value, got {item!r}")
        value = value.strip()
        try:
            out[key] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            out[key] = value
    return out


def _split_list(s: str | None) -> list[str]:
    return [x.strip() for x in (s or "").split(",") if x.strip()]


def _fmt(x: Any, digits: int = 4) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return str(v)
    return f"{v:.{digits}f}"
