"""Save and load robot graphs as networkx node-link JSON.

Attribute values are written as names ("HINGE", "DEG_45", "LEFT"), so files are plain JSON
and load back into graphs that ``construct_mjspec_from_graph`` accepts directly.
"""

from __future__ import annotations

import json
import numbers
from collections.abc import Iterable, Mapping
from enum import Enum
from pathlib import Path
from typing import Any

import networkx as nx

__all__ = ["graph_to_plain", "load_graph_from_json", "robot_graph", "save_graph_as_json"]


def _plain(value: Any) -> Any:
    if isinstance(value, Enum):
        return value.name
    if isinstance(value, bool):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value)
    return value


def robot_graph(
    nodes: Mapping[int, tuple[Any, Any]], edges: Iterable[tuple[int, int, Any]]
) -> nx.DiGraph:
    """A robot graph from ``{node: (type, rotation)}`` and ``(parent, child, face)`` triples.

    Values may be enum members or their names; nodes are added in the given order.
    """
    graph = nx.DiGraph()
    for node, (module_type, rotation) in nodes.items():
        graph.add_node(node, type=module_type, rotation=rotation)
    for parent, child, face in edges:
        graph.add_edge(parent, child, face=face)
    return graph


def graph_to_plain(graph: nx.DiGraph) -> nx.DiGraph:
    """A copy of ``graph`` with enum attribute values as names and numpy numbers as Python ones."""
    plain = type(graph)()
    plain.graph.update({key: _plain(value) for key, value in graph.graph.items()})
    for node, attrs in graph.nodes(data=True):
        plain.add_node(_plain(node), **{key: _plain(value) for key, value in attrs.items()})
    for parent, child, attrs in graph.edges(data=True):
        plain.add_edge(
            _plain(parent), _plain(child), **{key: _plain(value) for key, value in attrs.items()}
        )
    return plain


def save_graph_as_json(graph: nx.DiGraph, save_file: str | Path | None = None) -> None:
    """Write ``graph`` as node-link JSON (edges under the key "edges", indent 4).

    Does nothing when ``save_file`` is None (as upstream).
    """
    if save_file is None:
        return
    data = nx.node_link_data(graph_to_plain(graph), edges="edges")
    Path(save_file).write_text(json.dumps(data, indent=4), encoding="utf-8")


def load_graph_from_json(load_file: str | Path) -> nx.DiGraph:
    """Read a graph written by :func:`save_graph_as_json` (directed, not a multigraph).

    Files from older networkx versions that keep edges under "links" load too.
    """
    data = json.loads(Path(load_file).read_text(encoding="utf-8"))
    if not isinstance(data, dict) or "nodes" not in data:
        raise ValueError(f"{load_file} is not a node-link graph JSON (no 'nodes' key)")
    edges_key = "links" if "edges" not in data and "links" in data else "edges"
    data = {**data, "directed": True, "multigraph": False}
    data.setdefault(edges_key, [])
    return nx.node_link_graph(data, directed=True, multigraph=False, edges=edges_key)
