"""Headless figures: maps, paths, formation snapshots, convergence curves and GIF animations.

Everything here draws on a :class:`matplotlib.figure.Figure` attached to the Agg canvas
directly, never through ``pyplot``: no display is needed, no global backend is switched and
no window is ever opened.  Every function returns the figure; those with an ``out`` argument
also write it (PNG, SVG or PDF chosen by the suffix, at ``dpi``; GIF with Pillow for
:func:`animate`; no ffmpeg needed).

>>> import optplan as op
>>> from optplan.plot import plot_result
>>> res = op.solve("open-field", "visgraph")
>>> fig = plot_result(res, out="/tmp/open-field.png")

Conventions: known static obstacles are filled grey, temporary ones (``known = false``,
unseen by global planners) orange and hatched; circles are drawn as true circles
(``matplotlib.patches.Circle``, the exact centre and radius); the inflated outlines (first
robot's radius) are dashed; dynamic obstacles show their start shape and their track dotted;
starts are circles, goals stars.  What the validator rejects is drawn in red on top: the
path segments that collide with a static obstacle (recomputed with the exact engine), each
robot's first static contact point, the contacts in time with moving obstacles or other robots
(from ``result.metrics``) and the path points outside the bounds.  Red is reserved for this; no
robot is drawn red.  Legends never sit on the data: outside the axes (the figures made here
use matplotlib's constrained layout to make room), or in the corner of the axes with the least
drawn data.  ``matplotlib`` is imported when this module is imported, so ``import optplan``
stays light as long as this module is not imported.
"""

from __future__ import annotations

from optplan.plot.animation import animate
from optplan.plot.convergence import plot_convergence
from optplan.plot.figure import new_figure
from optplan.plot.result import plot_result
from optplan.plot.scene import plot_problem
from optplan.plot.style import COLLISION_COLOUR as COLLISION_COLOUR
from optplan.plot.style import DYN_COLOUR as DYN_COLOUR
from optplan.plot.style import FORMATS as FORMATS
from optplan.plot.style import GLOBAL_COLOUR as GLOBAL_COLOUR
from optplan.plot.style import KNOWN_FILL as KNOWN_FILL
from optplan.plot.style import LEGEND_PLACES as LEGEND_PLACES
from optplan.plot.style import LENGTH_COLUMNS as LENGTH_COLUMNS
from optplan.plot.style import ROBOT_COLOURS as ROBOT_COLOURS
from optplan.plot.style import TEMP_FILL as TEMP_FILL

__all__ = ["plot_problem", "plot_result", "plot_convergence", "animate", "new_figure"]
