"""Multi-agent path-finding (MAPF) instances -> Problems whose robots keep to a roadmap.

Two formats (``docs/mapf.md``):

* **roadmaps** as the continuous-time MAPF benchmarks ship them (Continuous-CBS): a GraphML
  graph (``<node id="n0"><data key="key0">x,y</data></node>``, ``<edge source="n0"
  target="n1">`` with an optional weight) and a task file (``<root><agent start_id="136"
  goal_id="50"/>...</root>``): :func:`read_roadmap_mapf`; :func:`write_roadmap_mapf` writes
  a problem back in that format;
* **MovingAI MAPF grids**: a ``.map`` and a ``.scen`` whose first ``k`` lines are the agents:
  :func:`read_movingai_mapf`, the roadmap of the free cells' centres
  (:func:`~optplan.maps.mapf_build.grid_roadmap`).

Every error is a :class:`~optplan.ProblemError` naming the file and the element
(``tasks.xml: agent 3: start_id 'n99' is not a node of graph.xml``).  The XML files are read
with :mod:`xml.etree.ElementTree` (expat); a document type declaration (``<!DOCTYPE``,
entities) is refused, as no GraphML file needs one.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from optplan.maps.checks import err
from optplan.maps.importer import scene_name
from optplan.maps.mapf_build import (
    CCBS_RADIUS,
    _radius,
    check_agent_ends,
    grid_mapf_problem,
    roadmap_problem,
)
from optplan.maps.movingai import read_movingai
from optplan.maps.scen import _check_entry, _check_one_map, read_scen_entries
from optplan.problem import Problem, ProblemError, RoadmapGraph

__all__ = ["MAX_XML_BYTES", "read_graphml", "read_tasks", "read_roadmap_mapf",
           "read_movingai_mapf", "write_roadmap_mapf"]

#: The largest GraphML or task file read (bytes): the authors' largest roadmap (11,342 nodes,
#: 527,066 directed edges) is about 45 MB.
MAX_XML_BYTES = 256 * 2**20

#: relative difference above which an edge's weight is not its Euclidean length
_WEIGHT_REL = 1e-6


def _local(tag: Any) -> str:
    """An element's tag without its namespace (``{http://graphml...}node`` -> ``node``)."""
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _load_xml(path: Path) -> ET.Element:
    """The root element of an XML file (size limit, no DTD, well-formed)."""
    try:
        size = path.stat().st_size
        if size > MAX_XML_BYTES:
            raise err(path, "<file>", f"{size / 2**20:.1f} MB is more than the "
                                      f"{MAX_XML_BYTES // 2**20} MB read (MAX_XML_BYTES)")
        data = path.read_bytes()
    except OSError as e:
        raise ProblemError(f"{path}: cannot read file ({e.strerror or e})") from None
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise err(path, "<!DOCTYPE>", "a document type declaration (DTD, entities) is not "
                                      "read: GraphML and task files need none")
    try:
        return ET.fromstring(data)
    except ET.ParseError as e:
        raise err(path, "xml", f"not well-formed XML ({e})") from None


def _children(parent: ET.Element, name: str) -> list[ET.Element]:
    """The child elements of ``parent`` named ``name`` (any namespace)."""
    return [c for c in parent if _local(c.tag) == name]


def _key_ids(root: ET.Element, attr_name: str, kind: str) -> set[str]:
    """The ids of the GraphML ``<key>`` declarations of ``attr.name`` for ``kind``."""
    return {k.get("id", "") for k in _children(root, "key")
            if k.get("attr.name") == attr_name and k.get("for") in (kind, "all")}


def _data(el: ET.Element, keys: set[str], fallback: bool) -> str | None:
    """The text of ``el``'s ``<data>`` of one of ``keys`` (its first ``<data>`` when
    ``fallback`` and no key is declared, as the authors' reader does); None without one."""
    data = _children(el, "data")
    found = [d for d in data if d.get("key") in keys] if keys else (data[:1] if fallback
                                                                    else [])
    return (found[0].text or "") if found else None


def _coords(where: Path, key: str, text: str | None) -> tuple[float, float]:
    """``"x,y"`` as two finite numbers."""
    if text is None:
        raise err(where, key, "no <data> with its coordinates \"x,y\"")
    parts = text.strip().split(",")
    try:
        xy = [float(t) for t in parts]
    except ValueError:
        xy = []
    if len(xy) != 2 or not all(math.isfinite(v) for v in xy):
        raise err(where, key, f"coordinates {text.strip()[:60]!r}: expected \"x,y\", two "
                              "finite numbers")
    return xy[0], xy[1]


def _graph_nodes(path: Path, graph: ET.Element, keys: set[str]
                 ) -> tuple[list[str], np.ndarray]:
    """The nodes' ids (in file order) and coordinates."""
    ids: list[str] = []
    pts = []
    seen: set[str] = set()
    for k, node in enumerate(_children(graph, "node")):
        nid = node.get("id")
        if not nid:
            raise err(path, f"node {k}", "no id attribute")
        if nid in seen:
            raise err(path, f"node {nid!r}", f"id given twice (node {k} of the file)")
        seen.add(nid)
        pts.append(_coords(path, f"node {nid!r}", _data(node, keys, fallback=True)))
        ids.append(nid)
    if not ids:
        raise err(path, "graph", "no <node> elements")
    return ids, np.array(pts, dtype=float)


def _graph_edges(path: Path, graph: ET.Element, index: dict[str, int], pts: np.ndarray,
                 weight_keys: set[str]) -> tuple[np.ndarray, int]:
    """The edges as index pairs (file order) and how many weights are not the Euclidean
    length of their edge (weights are ignored: the robots drive the straight segment)."""
    pairs = []
    off = 0
    for k, edge in enumerate(_children(graph, "edge")):
        name = f"edge {edge.get('id') or k}"
        ends = []
        for attr in ("source", "target"):
            v = edge.get(attr)
            if v is None:
                raise err(path, name, f"no {attr} attribute")
            if v not in index:
                raise err(path, name, f"{attr} {v!r} is not a node of the graph")
            ends.append(index[v])
        if ends[0] == ends[1]:
            raise err(path, name, f"a self-loop at node {edge.get('source')!r}")
        w = _data(edge, weight_keys, fallback=False)
        if w is not None:
            length = float(np.hypot(*(pts[ends[0]] - pts[ends[1]])))
            try:
                off += not abs(float(w) - length) <= _WEIGHT_REL * length
            except ValueError:
                off += 1
        pairs.append(ends)
    return np.array(pairs, dtype=np.int64).reshape(-1, 2), off


def _merge(path: Path, ids: list[str], pts: np.ndarray, merge: bool) -> np.ndarray:
    """Per node, the node it stands as: itself, or (``merge``) the first node at the same
    coordinates; two nodes at one point are an error without ``merge``."""
    _, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    rep = first[inverse.reshape(-1)]
    twins = np.flatnonzero(rep != np.arange(len(ids)))
    if twins.size and not merge:
        k = int(twins[0])
        raise err(path, f"node {ids[k]!r}", f"coordinates {pts[k].tolist()} are those of node "
                                            f"{ids[int(rep[k])]!r}: two nodes in one place "
                                            "(merge_duplicates=True, --merge-duplicates, reads "
                                            "them as one node)")
    return rep


def read_graphml(path: str | Path, *, merge_duplicates: bool = False,
                 info: dict | None = None) -> tuple[RoadmapGraph, list[str], np.ndarray]:
    """Read a roadmap in the GraphML of the continuous-time MAPF benchmarks.

    Parameters
    ----------
    path : path
        ``<graphml>`` with one ``<graph>``: ``<node id=...>`` elements whose ``<data>`` (of
        the key declared with ``attr.name="coords"``, else the node's first ``<data>``) is
        ``"x,y"``, and ``<edge source=... target=...>`` elements.  Edges are undirected (both
        directions of a file's edge are one edge; a one-way edge becomes two-way, counted in
        ``info``); their weights (``attr.name="weight"``) are read, compared with the
        Euclidean length and ignored: a robot drives the straight segment at its speed, as
        the authors' planner does (their files write weight 1).
    merge_duplicates : bool
        Read nodes at the same coordinates as one node (their edges joined); without it
        they are an error.
    info : dict, optional
        Receives ``nodes``, ``edges`` (undirected, after merging), ``one_way`` (file edges
        without their reverse in a directed graph), ``weights_off`` (weights that are not the
        Euclidean length) and ``merged`` (nodes merged into another).

    Returns
    -------
    (RoadmapGraph, list of str, numpy.ndarray)
        The graph, the file's node ids in file order, and per file node its node in the
        graph.

    Raises
    ------
    ProblemError
        Naming the file and the element.
    """
    p = Path(path)
    root = _load_xml(p)
    if _local(root.tag) != "graphml":
        raise err(p, f"<{_local(root.tag)}>", "expected a <graphml> document")
    graphs = _children(root, "graph")
    if len(graphs) != 1:
        raise err(p, "graph", f"expected one <graph> element, got {len(graphs)}")
    ids, pts = _graph_nodes(p, graphs[0], _key_ids(root, "coords", "node"))
    index = {nid: k for k, nid in enumerate(ids)}
    edges, off = _graph_edges(p, graphs[0], index, pts, _key_ids(root, "weight", "edge"))
    rep = _merge(p, ids, pts, merge_duplicates)
    keep = np.flatnonzero(rep == np.arange(len(ids)))
    new = np.full(len(ids), -1, dtype=np.int64)
    new[keep] = np.arange(len(keep))
    node_of = new[rep]
    e = node_of[edges]
    e = e[e[:, 0] != e[:, 1]]
    graph = RoadmapGraph(pts[keep], e)
    if info is not None:
        directed = graphs[0].get("edgedefault", "directed") == "directed"
        fwd = {tuple(x) for x in edges.tolist()}
        one_way = sum((b, a) not in fwd for a, b in fwd) if directed else 0
        info.update(nodes=len(graph), edges=len(graph.edges), one_way=one_way,
                    weights_off=off, merged=len(ids) - len(keep))
    return graph, ids, node_of


def _node_ref(v: str, index: dict[str, int], n: int) -> int | None:
    """A task's node reference: a node id, else (the authors' files) the 0-based position of
    the node in the graph file; None when it is neither."""
    if v in index:
        return index[v]
    if v.strip().isdigit() and int(v) < n:
        return int(v)
    return None


def read_tasks(path: str | Path, graph_path: str | Path, ids: list[str],
               agents: int | None = None) -> list[tuple[int, int]]:
    """The agents of a task file: per agent, its start and goal as file node positions.

    Parameters
    ----------
    path : path
        ``<root>`` whose children are ``<agent start_id=... goal_id=.../>`` elements; a
        reference is a node id of the graph or, as the authors' files write it, the node's
        0-based position in the graph file (their ids are ``n0``, ``n1``, ... in order).
    graph_path : path
        The graph file (named in messages).
    ids : list of str
        The graph's node ids in file order (:func:`read_graphml`).
    agents : int, optional
        The first ``agents`` agents (default: all).

    Returns
    -------
    list of (int, int)

    Raises
    ------
    ProblemError
        Naming the file and the agent (``tasks.xml: agent 3: start_id 'n99' is not a node of
        graph.xml``).
    """
    p = Path(path)
    root = _load_xml(p)
    elements = [c for c in root if isinstance(c.tag, str)]
    k_max = _agent_count(p, agents, len(elements))
    index = {nid: k for k, nid in enumerate(ids)}
    out = []
    for k, a in enumerate(elements[:k_max]):
        if _local(a.tag) != "agent":
            raise err(p, f"element {k}", f"<{_local(a.tag)}>: expected <agent start_id=... "
                                         "goal_id=.../>")
        ends = []
        for attr in ("start_id", "goal_id"):
            v = a.get(attr)
            if v is None:
                grid = " (a grid task: start_i/start_j; read it with its grid)" \
                    if a.get("start_i") is not None else ""
                raise err(p, f"agent {k}", f"no {attr} attribute{grid}")
            ref = _node_ref(v, index, len(ids))
            if ref is None:
                raise err(p, f"agent {k}", f"{attr} {v!r} is not a node of "
                                           f"{Path(graph_path).name}")
            ends.append(ref)
        out.append((ends[0], ends[1]))
    return out


def _agent_count(where: Path, agents: Any, available: int) -> int:
    """``agents`` checked: an integer in ``[1, available]``, None for all."""
    if available == 0:
        raise err(where, "agents", "the file has no agents")
    if agents is None:
        return available
    if isinstance(agents, bool) or not isinstance(agents, (int, np.integer)) or agents < 1:
        raise err(where, "agents", f"expected an integer >= 1, got {agents!r}")
    if agents > available:
        raise err(where, "agents", f"{agents} requested, the file has {available}")
    return int(agents)


def _pair_name(first: str, second: Path) -> str:
    """``<first>-<second's stem>``, the stem without ``first`` when it starts with it
    (``crossing`` and ``crossing_task.xml`` -> ``crossing-task``); characters other than
    letters, digits, ``_ . -`` become ``-``."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "-", second.stem).strip("-.")
    rest = stem.removeprefix(first).strip("-_.") if stem.startswith(first) else stem
    return f"{first}-{rest}" if rest else first


def read_roadmap_mapf(graph_path: str | Path, task_path: str | Path, *,
                      agents: int | None = None, radius: float = CCBS_RADIUS,
                      max_speed: float = 1.0, merge_duplicates: bool = False,
                      info: dict | None = None) -> Problem:
    """A continuous-time MAPF instance on a roadmap (Continuous-CBS's GraphML and task XML).

    Parameters
    ----------
    graph_path : path
        The roadmap (:func:`read_graphml`).
    task_path : path
        The agents (:func:`read_tasks`).
    agents : int, optional
        The first ``agents`` agents of the task file (default: all).
    radius : float
        Every robot's radius (the graph's units, >= 0); default :data:`CCBS_RADIUS`, the
        authors' ``sqrt(2) / 4``.
    max_speed : float
        Every robot's speed (units / s): an edge takes its length / ``max_speed``.
    merge_duplicates : bool
        Read nodes at one point as one node (:func:`read_graphml`).
    info : dict, optional
        Receives :func:`read_graphml`'s counts.

    Returns
    -------
    Problem
        Robots ``a0``, ``a1``, ... (agent ``k`` of the file), the roadmap, no static obstacles
        (the roadmap avoids them); bounds: the nodes' bounding box grown by the radius and 1 %
        of its diagonal.

    Raises
    ------
    ProblemError
        Naming the file and the element; also for two agents on one start (or goal) node, or
        whose discs overlap there.
    """
    gp, tp = Path(graph_path), Path(task_path)
    r = _radius(tp, radius)
    graph, ids, node_of = read_graphml(gp, merge_duplicates=merge_duplicates, info=info)
    tasks = read_tasks(tp, gp, ids, agents)
    ends = [(int(node_of[s]), int(node_of[g])) for s, g in tasks]
    check_agent_ends(tp, graph.nodes, ends, r,
                     [(f"start_id {ids[s]!r}", f"goal_id {ids[g]!r}") for s, g in tasks])
    name = _pair_name(scene_name(gp), tp) + (f"-{len(ends)}" if agents else "")
    scene = {"name": name, "tags": ["mapf", "roadmap"],
             "description": f"MAPF: {len(ends)} agents of {tp.name} on the roadmap {gp.name} "
                            f"({len(graph)} nodes, {len(graph.edges)} edges)",
             "source": f"optplan.maps.read_roadmap_mapf({gp.name!r}, {tp.name!r}): the "
                       "Continuous-CBS GraphML roadmap and task format"}
    return roadmap_problem(graph, ends, radius=r, max_speed=max_speed, scene=scene,
                            where=str(tp))


def read_movingai_mapf(map_path: str | Path, scen_path: str | Path, *,
                       agents: int | None = None, radius: float | None = None,
                       connectedness: int = 2, max_speed: float = 1.0,
                       info: dict | None = None) -> Problem:
    """A MAPF instance on a MovingAI grid: a ``.map`` and the first lines of a ``.scen``.

    Parameters
    ----------
    map_path : path
        The MovingAI map (:func:`~optplan.maps.read_movingai`; cells of side 1, cell
        ``(x, y)``'s centre at ``(x + 0.5, height - y - 0.5)``).
    scen_path : path
        The ``.scen`` (:func:`~optplan.maps.read_scen_entries`): line ``k`` (in file order) is
        agent ``k``, from the centre of its start cell to the centre of its goal cell.
    agents : int, optional
        The first ``agents`` lines (default: all).
    radius : float, optional
        Every robot's radius in cells, in ``[0, 0.5]``; default :data:`CCBS_RADIUS`.
    connectedness : int
        The grid's moves, Continuous-CBS's values: 2 (4-connected, its default), 3
        (8-connected), 4 (16 moves), 5 (32 moves); a move is an edge only where the robot's
        disc drives it clear of the blocked cells
        (:func:`~optplan.maps.mapf_build.grid_roadmap`).
    max_speed : float
        Every robot's speed (cells / s).
    info : dict, optional
        Receives the roadmap's counts (``nodes``, ``edges``, ``candidates``, ``blocked``).

    Returns
    -------
    Problem
        Robots ``a0``, ``a1``, ...; the blocked cells as static obstacles (their exact union,
        so the validator checks the plane); the roadmap of the free cells' centres.

    Raises
    ------
    ProblemError
        Naming the file and the line or agent.
    """
    mp, sp = Path(map_path), Path(scen_path)
    every = read_scen_entries(sp)
    _check_one_map(sp, every)
    entries = every[:_agent_count(sp, agents, len(every))]
    grid = read_movingai(mp)
    mask = grid.obstacle_mask()
    for e in entries:
        _check_entry(sp, e, grid, mask, mp)
    name = _pair_name(scene_name(mp), Path(sp.name.removesuffix(".scen")))
    scene = {"name": name + (f"-{len(entries)}" if agents else ""), "tags": ["mapf", "movingai"],
             "description": f"MAPF: the first {len(entries)} lines of {sp.name} as agents on "
                            f"{mp.name} ({connectedness}-connectedness, "
                            f"{2 ** connectedness} moves)",
             "source": f"optplan.maps.read_movingai_mapf({mp.name!r}, {sp.name!r})"}
    return grid_mapf_problem(grid, [(e.start, e.goal) for e in entries],
                             radius=CCBS_RADIUS if radius is None else radius,
                             connectedness=connectedness, max_speed=max_speed, scene=scene,
                             where=str(sp), info=info)


def write_roadmap_mapf(problem: Problem, graph_path: str | Path,
                       task_path: str | Path) -> tuple[Path, Path]:
    """Write a roadmap problem as Continuous-CBS reads it: GraphML and task XML.

    Node ``k`` is ``<node id="nk">`` with ``<data key="key0">x,y</data>`` (``repr`` of the
    doubles), every edge is written in both directions (the authors' reader follows an edge
    from its source only) with its Euclidean length as the weight, and agent ``k`` is robot
    ``k`` with ``start_id``/``goal_id`` the 0-based node positions.  The robots' radius is not
    part of these files: give it to the authors' planner as ``<agent_size>`` in its
    ``config.xml``.

    Parameters
    ----------
    problem : Problem
        A problem with a roadmap (every start and goal a node).
    graph_path, task_path : path
        The files to write (their directories made).

    Returns
    -------
    (Path, Path)

    Raises
    ------
    ValueError
        When ``problem`` has no roadmap or a robot has no goal.
    """
    graph = problem.roadmap
    if graph is None:
        raise ValueError(f"problem {problem.name!r} has no roadmap")
    eps = problem.frame.eps
    ends = []
    for r in problem.robots:
        s = graph.node_at(r.start, eps)
        g = None if r.goal is None else graph.node_at(r.goal, eps)
        if s is None or g is None:
            raise ValueError(f"robot {r.id!r}: its start and goal must be nodes of the roadmap")
        ends.append((s, g))
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<graphml xmlns="http://graphml.graphdrawing.org/xmlns">',
             '  <key id="key0" for="node" attr.name="coords" attr.type="string" />',
             '  <key id="key1" for="edge" attr.name="weight" attr.type="double" />',
             '  <graph id="G" edgedefault="directed">']
    lines += [f'    <node id="n{k}">\n      <data key="key0">{x!r},{y!r}</data>\n    </node>'
              for k, (x, y) in enumerate(graph.nodes.tolist())]
    e = 0
    for (i, j), length in zip(graph.edges.tolist(), graph.lengths.tolist()):
        for a, b in ((i, j), (j, i)):
            lines.append(f'    <edge id="e{e}" source="n{a}" target="n{b}">\n'
                         f'      <data key="key1">{length!r}</data>\n    </edge>')
            e += 1
    lines += ["  </graph>", "</graphml>"]
    gp, tp = Path(graph_path), Path(task_path)
    for path in (gp, tp):
        path.parent.mkdir(parents=True, exist_ok=True)
    gp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    tp.write_text('<?xml version="1.0" ?>\n<root>\n' + "".join(
        f'   <agent start_id="{s}" goal_id="{g}"/>\n' for s, g in ends) + "</root>\n",
        encoding="utf-8")
    return gp, tp
