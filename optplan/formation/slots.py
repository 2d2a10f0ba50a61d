r"""The L-phi convention: the formation frame's geometry (paper §II.G).

Geometry (the L-phi convention, fixed in :class:`optplan.problem.Follower`)
--------------------------------------------------------------------------
The leader is at :math:`p_L` with heading :math:`\theta_L`.  A follower's slot is

.. math::  s = p_L + L\,R(\theta_L)\,[-\cos\varphi,\ \sin\varphi]^T,

i.e. :math:`\varphi` is measured from the leader's *backward* heading, positive to the leader's
left; :math:`\varphi = 0` is directly behind.  The actual polar coordinates of a follower at
:math:`p_F` are :math:`r = \|p_F - p_L\|` and
:math:`\varphi = \mathrm{wrap}(\theta_L + \pi - \operatorname{atan2}(p_F - p_L))`.
With the paper-formation start (leader (60, 60) heading :math:`\pi/4`, :math:`L = 60`),
:math:`\varphi = +\pi/4` puts f1 at (0, 60) and :math:`\varphi = -\pi/4` puts f2 at (60, 0),
as in the paper's Figs. 13 and 31.
"""

from __future__ import annotations

import numpy as np

__all__ = ["wrap", "relative_polar", "slot_positions"]


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles to ``[-pi, pi)``."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def relative_polar(p_lead: np.ndarray, theta: float, p_f: np.ndarray) -> tuple[np.ndarray,
                                                                               np.ndarray]:
    """Actual ``(r, phi)`` of followers ``p_f`` (``(F, 2)``) in the L-phi convention."""
    rel = np.atleast_2d(p_f) - np.asarray(p_lead)[None, :]
    r = np.hypot(rel[:, 0], rel[:, 1])
    phi = wrap(theta + np.pi - np.arctan2(rel[:, 1], rel[:, 0]))
    return r, np.asarray(phi)


def slot_positions(p_lead: np.ndarray, theta: float, L: np.ndarray,
                   phi: np.ndarray) -> np.ndarray:
    """Slots ``p_L + L R(theta) [-cos phi, sin phi]``, shape ``(F, 2)``."""
    ang = theta + np.pi - np.asarray(phi, dtype=float)
    L = np.asarray(L, dtype=float)
    return np.asarray(p_lead)[None, :] + np.stack([L * np.cos(ang), L * np.sin(ang)], axis=-1)

