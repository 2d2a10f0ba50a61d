"""A backend's own time limit: :class:`Deadline`, the run's callback behind a clock.

Every backend that can run for minutes has a ``time_limit`` option; ``optplan.solve``'s own
``time_limit`` replaces it.  The clock is :data:`optplan.solver.clock` (a module global, read
at every poll, so tests replace it and stay independent of the machine's load).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

from optplan.result import Progress, Result, notify

__all__ = ["Deadline", "now"]


def now() -> float:
    """The deadline clock's reading, :data:`optplan.solver.clock` (looked up at each call:
    tests replace it)."""
    from optplan import solver

    return solver.clock()


class Deadline:
    """A backend's ``callback`` behind its own ``time_limit`` (seconds from construction, on
    :data:`optplan.solver.clock`, read at each poll: tests replace it).

    Called with every :class:`~optplan.result.Progress` of the run: after the limit it raises
    ``StopIteration`` (``timed_out``), otherwise it forwards the report to ``callback``, whose
    stop request also raises ``StopIteration``; ``stopped`` then stays true.
    """

    def __init__(self, callback: Callable[[Progress], Any] | None, time_limit: float | None):
        self.callback, self.time_limit = callback, time_limit
        self.end = (now() + time_limit
                    if time_limit is not None and not math.isinf(time_limit) else None)
        self.stopped = self.timed_out = False

    def __call__(self, p: Progress) -> None:
        if self.expired():
            raise StopIteration
        self.report(p)

    def expired(self) -> bool:
        """Whether the limit is reached (one clock reading; ``stopped`` and ``timed_out``
        set when it is)."""
        if self.end is not None and now() >= self.end:
            self.stopped = self.timed_out = True
        return self.timed_out

    def report(self, p: Progress) -> None:
        """Forward ``p`` to the callback; its stop request raises ``StopIteration``."""
        if notify(self.callback, p):
            self.stopped = True
            raise StopIteration

    @property
    def forward(self) -> Callable[[Progress], Any] | None:
        """What to pass to a stage: this object, or None without a callback or limit."""
        return self if self.callback is not None or self.end is not None else None

    def stop_text(self) -> str:
        """What stopped the run."""
        return (f"stopped by the time limit ({self.time_limit:g} s)" if self.timed_out
                else "stopped by the callback")

    def mark(self, res: Result) -> Result:
        """``res`` with ``stop_reason = "time_limit"`` and the message saying so, after the
        limit stopped the run."""
        if not self.timed_out:
            return res
        return dataclasses.replace(res, stop_reason="time_limit", message=(
            f"time limit ({self.time_limit:g} s) reached; {res.message}"))
