"""What the hybrid planner's steps share: the options they read and step 3's outcome.

The steps (:mod:`~optplan.hybrid.stages`, :mod:`~optplan.hybrid.policy`,
:mod:`~optplan.hybrid.answer`) take the backend as :class:`RunOptions`, the part of
:class:`~optplan.hybrid.planner.Hybrid` they read (its option fields, documented there), so
they do not import the planner that imports them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from optplan.result import Result

__all__ = ["RunOptions", "GlobalStage"]


class RunOptions(Protocol):
    """The options of :class:`~optplan.hybrid.planner.Hybrid` that its steps read."""

    @property
    def stages(self) -> dict[str, Any]: ...
    @property
    def global_solver(self) -> Any: ...
    @property
    def local_solver(self) -> Any: ...
    @property
    def formation(self) -> Any: ...
    @property
    def angle_tol(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def max_steps(self) -> int: ...
    @property
    def v_factor(self) -> float: ...
    @property
    def heading_rate(self) -> float: ...
    @property
    def settle_tol(self) -> float: ...
    @property
    def settle_steps(self) -> int: ...
    @property
    def stop_on_collision(self) -> bool: ...


@dataclass
class GlobalStage:
    """Step 3's outcome: a path per driving robot."""

    paths: dict[str, np.ndarray]
    result: Result | None = None
    wall_time: float = 0.0
    messages: list[str] = field(default_factory=list)
