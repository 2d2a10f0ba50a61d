"""MAPF importers (optplan.maps.mapf): Continuous-CBS GraphML roadmaps and task files, MovingAI
MAPF grids, the writer back to GraphML, bad files, and ``optplan import-mapf``."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from optplan import cli
from optplan.maps import (
    CCBS_RADIUS,
    read_movingai_mapf,
    read_roadmap_mapf,
    write_roadmap_mapf,
)
from optplan.maps.mapf_build import grid_moves
from optplan.problem import ProblemError, parse_problem

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "problems" / "mapf"
HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n'
        '<graphml xmlns="http://graphml.graphdrawing.org/xmlns">\n'
        '<key id="key0" for="node" attr.name="coords" attr.type="string"/>\n'
        '<key id="key1" for="edge" attr.name="weight" attr.type="double"/>\n'
        '<graph id="G" edgedefault="directed">\n')


def _graph(nodes: list[str], edges: list[tuple[str, str]], weight: str = "1") -> str:
    """A GraphML roadmap in the authors' layout: node ``nk`` at ``nodes[k]`` (``"x,y"``),
    every edge in both directions with ``weight``."""
    body = "".join(f'<node id="n{k}"><data key="key0">{c}</data></node>\n'
                   for k, c in enumerate(nodes))
    body += "".join(f'<edge source="{a}" target="{b}"><data key="key1">{weight}</data></edge>\n'
                    f'<edge source="{b}" target="{a}"><data key="key1">{weight}</data></edge>\n'
                    for a, b in edges)
    return HEAD + body + "</graph>\n</graphml>\n"


def _tasks(pairs: list[tuple[str, str]]) -> str:
    return '<?xml version="1.0" ?>\n<root>\n' + "".join(
        f'   <agent start_id="{s}" goal_id="{g}"/>\n' for s, g in pairs) + "</root>\n"


_SQUARE = ["0,0", "4,0", "4,4", "0,4", "2,2"]
_RING = [("n0", "n1"), ("n1", "n2"), ("n2", "n3"), ("n3", "n0"), ("n4", "n0")]


def _files(tmp_path: Path, graph: str | None = None, tasks: str | None = None
           ) -> tuple[Path, Path]:
    g, t = tmp_path / "graph.xml", tmp_path / "tasks.xml"
    g.write_text(_graph(_SQUARE, _RING) if graph is None else graph, encoding="utf-8")
    t.write_text(_tasks([("0", "2"), ("2", "0")]) if tasks is None else tasks,
                 encoding="utf-8")
    return g, t


# -- reading -------------------------------------------------------------------------------


def test_the_shipped_example() -> None:
    info: dict = {}
    p = read_roadmap_mapf(EXAMPLE / "crossing.xml", EXAMPLE / "crossing_task.xml", info=info)
    assert info == {"nodes": 10, "edges": 10, "one_way": 0, "weights_off": 0, "merged": 0}
    assert p.name == "crossing-task" and p.robot_ids == ["a0", "a1", "a2"]
    assert p.obstacles == () and p.roadmap is not None
    assert [r.start.tolist() for r in p.robots] == [[0.0, 5.0], [10.0, 5.0], [5.0, 0.0]]
    assert all(r.radius == CCBS_RADIUS for r in p.robots)
    assert p.roadmap.neighbours(2).tolist() == [1, 3, 6, 7]
    x0, y0, x1, y1 = p.bounds  # the nodes' box grown by the radius and 1 % of its diagonal
    assert x0 == pytest.approx(-CCBS_RADIUS - 0.01 * math.hypot(10, 10))
    assert x1 == pytest.approx(10 + CCBS_RADIUS + 0.01 * math.hypot(10, 10))


def test_the_docs_show_the_shipped_example() -> None:
    from tests.tools.test_docs import blocks

    page = (ROOT / "docs" / "mapf.md").read_text(encoding="utf-8")
    shown = {b["file"]: b["code"] for b in blocks(page) if b["file"]}
    for name in ("crossing.xml", "crossing_task.xml"):
        assert shown[f"runs/mapf/{name}"] == (EXAMPLE / name).read_text(encoding="utf-8")


def test_authors_layout_weights_ids_and_agents(tmp_path: Path) -> None:
    g, t = _files(tmp_path, tasks=_tasks([("0", "2"), ("n2", "n0"), ("1", "3")]))
    info: dict = {}
    p = read_roadmap_mapf(g, t, agents=2, radius=0.5, max_speed=2.0, info=info)
    assert info["weights_off"] == 10 and info["edges"] == 5 and info["one_way"] == 0
    assert len(p.robots) == 2 and p.name == "graph-tasks-2"
    assert p.robots[1].start.tolist() == [4.0, 4.0] and p.robots[1].max_speed == 2.0
    # weights equal to the Euclidean length are not counted
    g.write_text(_graph(["0,0", "3,4"], [("n0", "n1")], weight="5.0"), encoding="utf-8")
    t.write_text(_tasks([("0", "1")]), encoding="utf-8")
    read_roadmap_mapf(g, t, info=info)
    assert info["weights_off"] == 0


def test_one_way_edges_are_counted(tmp_path: Path) -> None:
    text = HEAD + ('<node id="a"><data key="key0">0,0</data></node>\n'
                   '<node id="b"><data key="key0">1,0</data></node>\n'
                   '<edge source="a" target="b"/>\n</graph>\n</graphml>\n')
    g, t = _files(tmp_path, text, _tasks([("a", "b")]))
    info: dict = {}
    p = read_roadmap_mapf(g, t, radius=0.2, info=info)
    assert info["one_way"] == 1 and p.roadmap.edges.tolist() == [[0, 1]]


def test_duplicate_nodes_error_or_merge(tmp_path: Path) -> None:
    g, t = _files(tmp_path, _graph(["0,0", "4,0", "4,0", "0,4"],
                                   [("n0", "n1"), ("n1", "n2"), ("n2", "n3")]),
                  _tasks([("0", "3")]))
    with pytest.raises(ProblemError, match=r"graph.xml: node 'n2': coordinates \[4.0, 0.0\] "
                                           r"are those of node 'n1': two nodes in one place"):
        read_roadmap_mapf(g, t)
    info: dict = {}
    p = read_roadmap_mapf(g, t, merge_duplicates=True, info=info)
    assert info["merged"] == 1 and p.roadmap.edges.tolist() == [[0, 1], [1, 2]]


def test_write_and_read_back(tmp_path: Path) -> None:
    p = read_roadmap_mapf(EXAMPLE / "crossing.xml", EXAMPLE / "crossing_task.xml")
    g, t = write_roadmap_mapf(p, tmp_path / "out" / "g.xml", tmp_path / "out" / "t.xml")
    info: dict = {}
    q = read_roadmap_mapf(g, t, info=info)
    assert info["weights_off"] == 0 and info["one_way"] == 0
    assert np.array_equal(q.roadmap.nodes, p.roadmap.nodes)
    assert np.array_equal(q.roadmap.edges, p.roadmap.edges)
    assert [r.goal.tolist() for r in q.robots] == [r.goal.tolist() for r in p.robots]
    assert 'source="n3" target="n2"' in g.read_text()  # both directions, as the authors read
    plane = parse_problem({"name": "x", "bounds": [0, 0, 1, 1],
                           "robots": [{"id": "a", "start": [0.5, 0.5], "goal": [0.5, 0.5],
                                       "radius": 0.1}]})
    with pytest.raises(ValueError, match="has no roadmap"):
        write_roadmap_mapf(plane, tmp_path / "g.xml", tmp_path / "t.xml")


# -- bad files: one line naming the file and the element -----------------------------------

_BAD = [
    # (graph text or None, tasks text or None, keywords, expected start of the message)
    (HEAD + "<node id='n0'>", None, {}, "graph.xml: xml: not well-formed XML (no element "
                                        "found: line 6"),
    (_graph(["0,0", "1,1"], [])[:-40], None, {}, "graph.xml: xml: not well-formed XML"),
    ("<!DOCTYPE x [<!ENTITY a 'b'>]><graphml/>", None, {}, "graph.xml: <!DOCTYPE>: a "
                                                           "document type declaration"),
    ("<root/>", None, {}, "graph.xml: <root>: expected a <graphml> document"),
    (HEAD.replace('<graph id="G" edgedefault="directed">\n', "") + "</graphml>", None, {},
     "graph.xml: graph: expected one <graph> element, got 0"),
    (HEAD + "</graph></graphml>", None, {}, "graph.xml: graph: no <node> elements"),
    (_graph(["0,0", "1,1", "2,0", "3,3", "4,4"], []).replace(
        '<data key="key0">1,1</data>', ""), None, {},
     "graph.xml: node 'n1': no <data> with its coordinates \"x,y\""),
    (_graph(["0,0", "1,x", "2,0", "3,3", "4,4"], []), None, {},
     "graph.xml: node 'n1': coordinates '1,x': expected \"x,y\", two finite numbers"),
    (_graph(["0,0", "1", "2,0", "3,3", "4,4"], []), None, {}, "graph.xml: node 'n1': "
                                                              "coordinates '1'"),
    (_graph(["0,0", "nan,1", "2,0", "3,3", "4,4"], []), None, {}, "graph.xml: node 'n1': "
                                                                  "coordinates 'nan,1'"),
    (_graph(["0,0", "1,1", "2,0", "3,3", "4,4"], []).replace('id="n1"', 'id="n0"'), None,
     {}, "graph.xml: node 'n0': id given twice (node 1 of the file)"),
    (_graph(_SQUARE, [("n0", "n7")]), None, {}, "graph.xml: edge 0: target 'n7' is not a "
                                                "node of the graph"),
    (_graph(_SQUARE, [("n0", "n0")]), None, {}, "graph.xml: edge 0: a self-loop at node 'n0'"),
    (_graph(_SQUARE, []).replace("</graph>", '<edge target="n1"/></graph>'), None, {},
     "graph.xml: edge 0: no source attribute"),
    (None, _tasks([("0", "2"), ("n99", "1")]), {},
     "tasks.xml: agent 1: start_id 'n99' is not a node of graph.xml"),
    (None, _tasks([("0", "2"), ("1", "99")]), {},
     "tasks.xml: agent 1: goal_id '99' is not a node of graph.xml"),
    (None, _tasks([("0", "2"), ("1", "3")]), {"agents": 3},
     "tasks.xml: agents: 3 requested, the file has 2"),
    (None, _tasks([("0", "2")]), {"agents": 0}, "tasks.xml: agents: expected an integer >= 1"),
    (None, _tasks([("0", "2")]), {"agents": True}, "tasks.xml: agents: expected an integer"),
    (None, "<root/>", {}, "tasks.xml: agents: the file has no agents"),
    (None, "<root><agent start_id='1'/></root>", {}, "tasks.xml: agent 0: no goal_id"),
    (None, "<root><agent start_i='1' start_j='2'/></root>", {},
     "tasks.xml: agent 0: no start_id attribute (a grid task"),
    (None, "<root><robot start_id='1' goal_id='2'/></root>", {},
     "tasks.xml: element 0: <robot>: expected <agent"),
    (None, "<root><agent start_id='1' goal_id='2'/>", {}, "tasks.xml: xml: not well-formed"),
    (None, _tasks([("0", "2"), ("0", "3")]), {}, "tasks.xml: agent 1: start_id 'n0' is agent "
                                                 "0's start too (two robots on one node "
                                                 "overlap at t = 0)"),
    (None, _tasks([("0", "2"), ("1", "2")]), {}, "tasks.xml: agent 1: goal_id 'n2' is agent "
                                                 "0's goal too"),
    (None, _tasks([("4", "2"), ("0", "1")]), {"radius": 1.5},
     "tasks.xml: agent 1: its start (start_id 'n0') is 2.82843 from agent 0's (start_id 'n4'), "
     "less than twice the radius 1.5"),
    (None, None, {"radius": -1.0}, "tasks.xml: radius: must lie in >= 0, got -1.0"),
    (None, None, {"radius": math.nan}, "tasks.xml: radius: must be finite"),
]


@pytest.mark.parametrize(("graph", "tasks", "kw", "msg"), _BAD)
def test_bad_roadmap_files(tmp_path: Path, graph, tasks, kw, msg) -> None:
    g, t = _files(tmp_path, graph, tasks)
    with pytest.raises(ProblemError) as e:
        read_roadmap_mapf(g, t, **kw)
    text = str(e.value)
    assert "\n" not in text
    assert text.startswith(str(tmp_path) + "/" + msg), text


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ProblemError, match="nope.xml: cannot read file"):
        read_roadmap_mapf(tmp_path / "nope.xml", tmp_path / "t.xml")


# -- MovingAI grids --------------------------------------------------------------------------

_MAP = "type octile\nheight 4\nwidth 5\nmap\n.....\n.@@..\n.....\n..@..\n"


def _scen(lines: list[tuple[int, int, int, int]]) -> str:
    return "version 1\n" + "".join(f"0\tm.map\t5\t4\t{a}\t{b}\t{c}\t{d}\t1.0\n"
                                   for a, b, c, d in lines)


def _grid_files(tmp_path: Path, lines: list[tuple[int, int, int, int]]) -> tuple[Path, Path]:
    m, s = tmp_path / "m.map", tmp_path / "m.map.scen"
    m.write_text(_MAP)
    s.write_text(_scen(lines))
    return m, s


def test_grid_moves() -> None:
    assert [len(grid_moves(k)) for k in (2, 3, 4, 5)] == [2, 4, 8, 16]
    assert set(grid_moves(3)) == {(1, 0), (0, 1), (1, 1), (-1, 1)}
    assert (2, 1) in grid_moves(4) and (2, 2) not in grid_moves(5) and (3, 2) in grid_moves(5)


def test_movingai_instance(tmp_path: Path) -> None:
    m, s = _grid_files(tmp_path, [(0, 0, 4, 3), (4, 0, 0, 3), (0, 2, 4, 2)])
    info: dict = {}
    p = read_movingai_mapf(m, s, agents=2, info=info)
    assert p.name == "m-2" and len(p.robots) == 2 and p.bounds == (0.0, 0.0, 5.0, 4.0)
    assert p.robots[0].start.tolist() == [0.5, 3.5] and p.robots[0].goal.tolist() == [4.5, 0.5]
    assert info["nodes"] == 17 == len(p.roadmap)  # 20 cells, 3 blocked
    # 4-connected: every move between two free cells; the discs pass them all
    assert info["blocked"] == 0 and info["edges"] == info["candidates"]
    assert len(p.obstacles) == 2  # the exact union of the blocked cells, per component
    oset = p.obstacle_set(CCBS_RADIUS)
    e = p.roadmap.edges
    assert oset.segment_free(p.roadmap.nodes[e[:, 0]], p.roadmap.nodes[e[:, 1]]).all()
    p8 = read_movingai_mapf(m, s, connectedness=3, info=info)
    assert info["blocked"] > 0  # diagonals past a blocked corner
    assert len(p8.roadmap.edges) == info["edges"] > len(e)
    # (0, 0) -> (1, 1) passes the corner of the blocked cell (1, 1)? no: (1, 1) is blocked
    assert p8.roadmap.node_at([1.5, 2.5], 1e-9) is None


@pytest.mark.parametrize(("lines", "kw", "msg"), [
    ([(0, 0, 4, 3), (1, 1, 0, 3)], {}, "m.map.scen: line 3: start cell (1, 1) is blocked"),
    ([(0, 0, 4, 3), (0, 0, 0, 3)], {}, "m.map.scen: agent 1: start cell (0, 0) is agent 0's "
                                       "start too"),
    ([(0, 0, 4, 3), (1, 0, 4, 3)], {}, "m.map.scen: agent 1: goal cell (4, 3) is agent 0's "
                                       "goal too"),
    ([(0, 0, 4, 3)], {"agents": 2}, "m.map.scen: agents: 2 requested, the file has 1"),
    ([(0, 0, 4, 3)], {"radius": 0.6}, "m.map.scen: radius: must lie in [0, 0.5], got 0.6"),
    ([(0, 0, 4, 3)], {"connectedness": 6}, "m.map.scen: connectedness: expected one of "
                                           "(2, 3, 4, 5), got 6"),
])
def test_bad_movingai_instances(tmp_path: Path, lines, kw, msg) -> None:
    m, s = _grid_files(tmp_path, lines)
    with pytest.raises(ProblemError) as e:
        read_movingai_mapf(m, s, **kw)
    assert str(e.value).startswith(f"{tmp_path}/{msg}"), str(e.value)


# -- the command -----------------------------------------------------------------------------


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = cli.main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_cli_roadmap(tmp_path: Path, capsys) -> None:
    out_toml = tmp_path / "x.toml"
    rc, out, err = _run(capsys, "import-mapf", str(EXAMPLE / "crossing.xml"),
                        str(EXAMPLE / "crossing_task.xml"), "--agents", "2", "-o", str(out_toml))
    assert rc == 0, err
    assert "crossing.xml: 10 nodes, 10 edges\n" in out and "wrote " in out
    p = parse_problem(tomllib.loads(out_toml.read_text()), str(out_toml))
    assert len(p.robots) == 2 and p.roadmap is not None and len(p.roadmap.edges) == 10
    rc, out, _ = _run(capsys, "import-mapf", str(EXAMPLE / "crossing.xml"),
                      str(EXAMPLE / "crossing_task.xml"), "--radius", "0.25", "--name", "c")
    assert rc == 0 and 'name = "c"' in out and "radius = 0.25" in out and "[roadmap]" in out


def test_cli_movingai(tmp_path: Path, capsys) -> None:
    m, s = _grid_files(tmp_path, [(0, 0, 4, 3), (4, 0, 0, 3)])
    rc, out, err = _run(capsys, "import-mapf", "--map", str(m), "--scen", str(s),
                        "--connectedness", "3", "-o", str(tmp_path / "g.toml"))
    assert rc == 0, err
    assert "m.map: 17 free cells, " in out and "3-connectedness" in out


@pytest.mark.parametrize(("argv", "msg"), [
    ([], "give GRAPH TASKS"),
    (["--map", "x.map"], "give either GRAPH TASKS"),
    (["g.xml", "t.xml", "--connectedness", "3"], "--connectedness is for MovingAI grids"),
    (["--map", "x.map", "--scen", "x.scen", "--merge-duplicates"], "--merge-duplicates is for"),
    (["g.xml", "t.xml"], "g.xml: cannot read file"),
])
def test_cli_errors_are_one_line(capsys, argv, msg) -> None:
    rc, _, err = _run(capsys, "import-mapf", *argv)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("optplan: error: "), err
    assert msg in lines[0], err


def test_ccbs_solves_the_shipped_example_and_the_validator_agrees() -> None:
    """The imported instance end to end: ``ccbs`` keeps to the roadmap (every point of its
    plan on an edge), the validator checks it in the plane, and its sum is the one derived
    by hand: the robot crossing the swap waits for neither."""
    import optplan as op

    p = read_roadmap_mapf(EXAMPLE / "crossing.xml", EXAMPLE / "crossing_task.xml")
    res = op.solve(p, "ccbs")
    assert res.status is op.Status.optimal and res.metrics["collisions"] == 0
    assert "within the roadmap model" in res.message
    g = p.roadmap
    a, b = g.nodes[g.edges[:, 0]], g.nodes[g.edges[:, 1]]
    for rid, path in res.paths.items():
        for q in path:  # on a segment of the roadmap: |q - a| + |q - b| == |a - b|
            gap = np.hypot(*(q - a).T) + np.hypot(*(q - b).T) - np.hypot(*(b - a).T)
            assert gap.min() <= 1e-9 * p.extent, (rid, q)
    assert res.metrics["sum_of_arrivals"] >= res.metrics["team_lower_bound"]
