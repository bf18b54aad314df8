"""`graph_key`: one key per body structure, whatever the node numbers (distinct morphologies)."""

from __future__ import annotations

import json

import networkx as nx

from ariel.body_phenotypes.robogen_lite.graph_io import graph_key, robot_graph

NODES = {0: ("CORE", "DEG_0"), 1: ("BRICK", "DEG_0"), 2: ("HINGE", "DEG_45"), 3: ("HINGE", "DEG_0")}
EDGES = [(0, 1, "FRONT"), (1, 2, "LEFT"), (0, 3, "BACK")]


def test_the_same_body_numbered_otherwise_has_the_same_key() -> None:
    graph = robot_graph(NODES, EDGES)
    order = {0: 7, 1: 3, 2: 9, 3: 1}  # other node numbers, edges added in another order
    renumbered = robot_graph(
        {order[n]: NODES[n] for n in (3, 2, 0, 1)},
        [(order[a], order[b], face) for a, b, face in reversed(EDGES)],
    )
    text = json.dumps(nx.node_link_data(renumbered, edges="edges"), sort_keys=True)
    assert graph_key(graph) == graph_key(renumbered) == graph_key(text)


def test_another_face_rotation_or_module_is_another_key() -> None:
    keys = {
        graph_key(robot_graph(NODES, EDGES)),
        graph_key(robot_graph(NODES, [(0, 1, "FRONT"), (1, 2, "RIGHT"), (0, 3, "BACK")])),
        graph_key(robot_graph({**NODES, 2: ("HINGE", "DEG_0")}, EDGES)),
        graph_key(robot_graph({**NODES, 1: ("HINGE", "DEG_0")}, EDGES)),
        graph_key(robot_graph(NODES, [(0, 1, "FRONT"), (0, 2, "LEFT"), (0, 3, "BACK")])),
    }
    assert len(keys) == 5
