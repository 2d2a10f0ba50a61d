r"""Basic artificial potential field local planner (paper §II.E, eqs 3-13): the ``apf`` backend.

The field (eqs 3-6, :mod:`optplan.potential.field`), the controller's step (eqs 12-13) and its
local-minimum detection (:mod:`optplan.potential.controller`) and the time-stepping driver
(:mod:`optplan.potential.backend`) are shared with SA-APF (:mod:`optplan.potential.sa_apf`).
This module holds what is the basic planner's own:

Units of :math:`\eta` (a choice, documented in ``docs/solvers/apf.md``).  In eq 34
:math:`\eta` multiplies :math:`\rho_g^n`, so :math:`\eta_{(34)}` and :math:`\eta_{(5)}` cannot
both be 3.7 in the same length unit.  On the paper's map scale (hundreds of units,
:math:`\rho_0 = 20`) the literal eq 6 with :math:`\eta = 3.7, k = 15` balances attraction only
at a clearance of ~0.1 map units: the basic robot drives into obstacles.  The basic planner
therefore uses :math:`\eta_{eff} = \eta \cdot (D/\lambda)^{m}` with :math:`D` the start-goal
distance and ``eta_match_n`` :math:`= m` (3, the improved method's exponent, in the ``apf-paper``
preset):
both planners then have the same repulsion at the start, and they differ only near the goal,
which is exactly the paper's comparison.  ``eta_match_n = 0`` gives the literal eq 6.

The basic planner only counts detections; it gives up when it is still within
``2 l + radius`` of a detected minimum ``patience`` steps later (status ``approximate``).

"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from optplan.interfaces import LocalPlanner
from optplan.options import option
from optplan.potential.backend import PotentialFieldBackend
from optplan.potential.controller import APFController
from optplan.potential.field import FieldParams
from optplan.problem import Problem, Robot

__all__ = ["APF"]


@dataclass(frozen=True, kw_only=True)
class APF(PotentialFieldBackend, LocalPlanner):
    """Basic artificial potential field local planner (paper §II.E, eqs 3-13).

    Parameters
    ----------
    eta_match_n : float
        Unit matching of ``eta`` with the improved method (module docstring): the basic
        repulsion uses ``eta * (D / length_scale) ** eta_match_n`` with ``D`` the start-goal
        distance.  ``0`` is the literal eq 6 (on map-scale scenes its repulsion is
        negligible).  Default 3.
    patience : int
        Steps the basic planner waits, still trapped, after a detection before giving up.
    k, eta, rho_0, l, dt, max_steps, rho_min, sense_range, window, stall_ratio, n_probe, \
detect_eq38, evade_factor, sense_robots
        Shared options, see :class:`PotentialFieldBackend`.
    """

    name: ClassVar[str] = "apf"
    eta_match_n: float = option(3.0, lo=0.0, hi=6.0)
    patience: int = option(30, lo=1, hi=10_000_000)

    # -- helpers ------------------------------------------------------------------------
    def field_params(self, problem: Problem, robot: Robot) -> FieldParams:
        """The potential's parameters for ``robot`` (basic method: n = 0, matched eta)."""
        eta = self.eta
        if self.eta_match_n and robot.goal is not None:
            D = max(float(np.hypot(*(robot.goal - robot.start))) / problem.length_scale, 1e-9)
            eta = self.eta * D ** self.eta_match_n
        return self._params(problem, robot, eta, 0.0)

    def controller(self, problem: Problem, robot_id: str, rng: np.random.Generator
                   ) -> APFController:
        """A :class:`~optplan.interfaces.LocalController` for ``robot_id``
        (:class:`~optplan.interfaces.LocalPlanner`)."""
        robot = problem.robot(robot_id)
        return APFController(self, problem, robot, rng, self.field_params(problem, robot),
                             self.patience)
