"""Save and load robot graphs as networkx node-link JSON.

Attribute values are written as names ("HINGE", "DEG_45", "LEFT"), so files are plain JSON
and load back into graphs that ``construct_mjspec_from_graph`` accepts directly.
"""

from __future__ import annotations

import hashlib
import json
import numbers
from collections.abc import Iterable, Mapping
from enum import Enum
from functools import lru_cache
from pathlib import Path
from typing import Any

import networkx as nx

__all__ = [
    "graph_key",
    "graph_to_plain",
    "load_graph_from_json",
    "robot_graph",
    "save_graph_as_json",
]


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

    Values may be enum members or their names; they are stored as given (not validated) and
    nodes are added in the given order.

    Args:
        nodes: ``{node id: (type, rotation)}``: each module's ``ModuleType`` and
            ``ModuleRotationsIdx`` (members or names, e.g. ``("HINGE", "DEG_90")``).
        edges: ``(parent id, child id, face)`` triples: the parent's ``ModuleFaces`` face
            (member or name) the child is attached to.

    Returns:
        A directed graph with node attributes ``type`` and ``rotation`` and edge attribute
        ``face``.

    Example:
        ```python
        from ariel.body_phenotypes.robogen_lite.graph_io import graph_key, robot_graph

        a = robot_graph({0: ("CORE", "DEG_0"), 1: ("HINGE", "DEG_90")}, [(0, 1, "LEFT")])
        b = robot_graph({0: ("CORE", "DEG_0"), 7: ("HINGE", "DEG_90")}, [(0, 7, "LEFT")])
        print(graph_key(a) == graph_key(b))  # True: same body, other node numbers
        ```
    """
    graph = nx.DiGraph()
    for node, (module_type, rotation) in nodes.items():
        graph.add_node(node, type=module_type, rotation=rotation)
    for parent, child, face in edges:
        graph.add_edge(parent, child, face=face)
    return graph


def graph_to_plain(graph: nx.DiGraph) -> nx.DiGraph:
    """A copy of ``graph`` with enum attribute values as names and numpy numbers as Python ones.

    Node ids and the graph's own attributes are converted the same way; other values are
    kept as they are.

    Args:
        graph: The graph to convert (left unchanged).

    Returns:
        A new graph of the same class, ready for JSON.
    """
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

    Attribute values are written as in `graph_to_plain` (enum members as names).

    Args:
        graph: The robot graph to save.
        save_file: The JSON file to write (overwritten if it exists); when None nothing is
            written (as upstream).
    """
    if save_file is None:
        return
    data = nx.node_link_data(graph_to_plain(graph), edges="edges")
    Path(save_file).write_text(json.dumps(data, indent=4), encoding="utf-8")


def load_graph_from_json(load_file: str | Path) -> nx.DiGraph:
    """Read a graph written by `save_graph_as_json` (directed, not a multigraph).

    Files from older networkx versions that keep edges under "links" load too.

    Args:
        load_file: The node-link JSON file to read.

    Returns:
        The graph, with the attribute values as saved (names, e.g. "HINGE").

    Raises:
        ValueError: If the file is not JSON, or not a node-link graph (no "nodes" key).
    """
    data = json.loads(Path(load_file).read_text(encoding="utf-8"))
    if not isinstance(data, dict) or "nodes" not in data:
        raise ValueError(f"{load_file} is not a node-link graph JSON (no 'nodes' key)")
    edges_key = "links" if "edges" not in data and "links" in data else "edges"
    data = {**data, "directed": True, "multigraph": False}
    data.setdefault(edges_key, [])
    return nx.node_link_graph(data, directed=True, multigraph=False, edges=edges_key)


def graph_key(graph: nx.DiGraph | str) -> str:
    """A key of the robot graph's structure: equal for two graphs exactly when they are the
    same body (module types and rotations, attachment faces), whatever their node numbers.

    A robot graph is a tree grown from the core, so the key hashes its canonical form: each
    node's attributes, then its children's (face, subtree) pairs in sorted order (AHU 1974).
    A graph that is no forest (not a robot graph) gets networkx's Weisfeiler-Lehman hash.

    Args:
        graph: A robot graph, or its node-link JSON text (the bodies table's ``graph``
            column).

    Returns:
        16 hex digits for a robot graph; ``"wl-"`` and the Weisfeiler-Lehman hash for a graph
        that is no forest.
    """
    if isinstance(graph, str):
        return _key_of_json(graph)
    return _key(graph_to_plain(graph))


@lru_cache(maxsize=4096)
def _key_of_json(text: str) -> str:
    data = json.loads(text)
    edges_key = "links" if "edges" not in data and "links" in data else "edges"
    data = {**data, "directed": True, "multigraph": False}
    data.setdefault(edges_key, [])
    return _key(nx.node_link_graph(data, directed=True, multigraph=False, edges=edges_key))


def _label(attrs: Mapping[str, Any]) -> str:
    return json.dumps(attrs, sort_keys=True, default=str)


def _key(graph: nx.DiGraph) -> str:
    if not nx.is_forest(graph):
        labelled = nx.DiGraph()
        labelled.add_nodes_from((n, {"label": _label(a)}) for n, a in graph.nodes(data=True))
        labelled.add_edges_from((u, v, {"label": _label(a)}) for u, v, a in graph.edges(data=True))
        return "wl-" + nx.weisfeiler_lehman_graph_hash(
            labelled, node_attr="label", edge_attr="label", iterations=max(1, len(graph))
        )
    canonical: dict[Any, str] = {}
    for node in reversed(list(nx.topological_sort(graph))):  # children before their parents
        children = sorted(
            f"{_label(graph.edges[node, child])}>{canonical[child]}"
            for child in graph.successors(node)
        )
        canonical[node] = f"{_label(graph.nodes[node])}({','.join(children)})"
    roots = sorted(canonical[n] for n in graph.nodes if graph.in_degree(n) == 0)
    return hashlib.sha256("|".join(roots).encode()).hexdigest()[:16]
