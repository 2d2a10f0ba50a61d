"""The figures' colours, file formats and legend places."""

from __future__ import annotations

#: colours: one per robot (leader first; no red, which marks collisions), obstacles, temporary
#: obstacles, dynamic obstacles, the global path, collisions and excursions
ROBOT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2",
                 "#17becf", "#bcbd22")
KNOWN_FILL = "#9e9e9e"
TEMP_FILL = "#ffb74d"
DYN_COLOUR = "#6a1b9a"
GLOBAL_COLOUR = "#000000"
COLLISION_COLOUR = "#ff0000"
#: file formats of the static figures, by suffix
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: legend placements of :func:`plot_problem` / :func:`plot_result`
LEGEND_PLACES = ("auto", "outside", "corner")
#: history columns holding the best feasible length so far (first one present is drawn)
LENGTH_COLUMNS = ("best_length", "feasible_best_length")
