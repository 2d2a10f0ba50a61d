"""The arc-exact shortest path of a disc robot (the certified optimum): the tangent
visibility graph of the grown obstacles' circles (:mod:`.tangent_graph`; its circles and arc
test, :mod:`.circles`, its common tangents, :mod:`.tangent_edges`, its candidate sight lines,
:mod:`.sightlines` over :mod:`.triangular_expansion`), the A* of one query
(:mod:`.tangent_search`), the built graph as explicit chains and their compiled A*
(:mod:`.tangent_chains`, :mod:`.chain_search`), and the drawing of its arcs
(:mod:`.arc_lines`).  The function ``tangent_graph`` is imported from its module (the name is
the module's).
"""

from optplan.geometry.tangent.arc_lines import arc_polyline
from optplan.geometry.tangent.circles import circles_of
from optplan.geometry.tangent.tangent_graph import TangentGraph, problem_shortest_path
from optplan.geometry.tangent.tangent_search import TangentSearch

__all__ = ["TangentGraph", "TangentSearch", "arc_polyline", "circles_of",
           "problem_shortest_path"]
