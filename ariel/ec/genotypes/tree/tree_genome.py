"""`TreeGenome`: a robot body as a tree of modules, stored as plain dicts (upstream's API).

``genome.nodes`` maps a node id to ``{"type": "HINGE", "rotation": "DEG_45"}`` (enum NAMES);
``genome.edges`` lists ``{"parent": 0, "child": 3, "face": "LEFT"}``. Node 0 is the core.
``to_networkx()`` gives the robot graph ``construct_mjspec_from_graph`` builds; ``to_dict()``
is plain JSON data (what the ``tree`` body encoder stores as its genotype).
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import networkx as nx

from ariel.body_phenotypes.robogen_lite.config import IDX_OF_CORE
from ariel.body_phenotypes.robogen_lite.graph_io import graph_to_plain

__all__ = ["TreeGenome"]


def _node_id(value: Any) -> int:
    """JSON object keys are strings: accept "3" as node 3."""
    if isinstance(value, bool):
        raise ValueError(f"node ids are ints, got {value!r}")
    try:
        return int(value)
    except (TypeError, ValueError):
        raise ValueError(f"node ids are ints, got {value!r}") from None


def _edge_set(edges: list[dict[str, Any]]) -> set[tuple]:
    return {tuple(sorted(e.items())) for e in edges}


class TreeGenome:
    """Nodes ``{id: {"type", "rotation"}}`` and edges ``[{"parent", "child", "face"}]``.

    ``TreeGenome()`` holds just the core. The operators in
    `ariel.ec.genotypes.tree.operators` edit ``nodes`` and ``edges`` in place.

    Args:
        nodes: node id -> ``{"type": <ModuleType name>, "rotation": <ModuleRotationsIdx
            name>}``, kept as given (not copied); ``None`` gives just the core,
            ``{0: {"type": "CORE", "rotation": "DEG_0"}}``.
        edges: ``{"parent": id, "child": id, "face": <ModuleFaces name>}`` dicts, kept as
            given; ``None`` gives no edges.
    """

    def __init__(
        self,
        nodes: dict[int, dict[str, Any]] | None = None,
        edges: list[dict[str, Any]] | None = None,
    ) -> None:
        if nodes is None:
            nodes = {IDX_OF_CORE: {"type": "CORE", "rotation": "DEG_0"}}
        self.nodes: dict[int, dict[str, Any]] = nodes
        self.edges: list[dict[str, Any]] = [] if edges is None else edges

    # ---- graph conversion ------------------------------------------------------------------

    def to_networkx(self) -> nx.DiGraph:
        """The robot graph: node attributes ``type``/``rotation``, edge attribute ``face``.

        Nodes in ascending id order, edges in genome order (ready for
        ``construct_mjspec_from_graph``).
        """
        graph = nx.DiGraph()
        for node in sorted(self.nodes):
            attrs = self.nodes[node]
            graph.add_node(node, type=attrs["type"], rotation=attrs["rotation"])
        for edge in self.edges:
            graph.add_edge(edge["parent"], edge["child"], face=edge["face"])
        return graph

    @classmethod
    def from_networkx(cls, graph: nx.DiGraph) -> TreeGenome:
        """A genome from a robot graph (attribute values may be enum members or names)."""
        plain = graph_to_plain(graph)
        nodes = {
            _node_id(n): {"type": a["type"], "rotation": a.get("rotation", "DEG_0")}
            for n, a in plain.nodes(data=True)
        }
        edges = [
            {"parent": _node_id(u), "child": _node_id(v), "face": a["face"]}
            for u, v, a in plain.edges(data=True)
        ]
        return cls(nodes, edges)

    # ---- plain data / JSON -----------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """``{"nodes": {"0": {...}, ...}, "edges": [...]}``: JSON keys are strings."""
        return {
            "nodes": {str(n): dict(self.nodes[n]) for n in sorted(self.nodes)},
            "edges": [dict(e) for e in self.edges],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TreeGenome:
        """Inverse of `to_dict` (node ids may be strings or ints)."""
        if not isinstance(data, dict) or "nodes" not in data:
            raise ValueError("a tree genome dict needs 'nodes' (and 'edges'), as to_dict() writes")
        nodes = {_node_id(k): dict(v) for k, v in data["nodes"].items()}
        edges = [
            {**e, "parent": _node_id(e["parent"]), "child": _node_id(e["child"])}
            for e in data.get("edges", [])
        ]
        return cls(nodes, edges)

    def to_json(self, *, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_json(cls, text: str) -> TreeGenome:
        return cls.from_dict(json.loads(text))

    def save_json(self, path: str | Path) -> None:
        Path(path).write_text(self.to_json(), encoding="utf-8")

    @classmethod
    def load_json(cls, path: str | Path) -> TreeGenome:
        return cls.from_json(Path(path).read_text(encoding="utf-8"))

    # ---- conveniences ----------------------------------------------------------------------

    @classmethod
    def default_init(cls) -> TreeGenome:
        """A genome holding only the core."""
        return cls()

    def copy(self) -> TreeGenome:
        return TreeGenome(copy.deepcopy(self.nodes), copy.deepcopy(self.edges))

    __copy__ = copy

    def __deepcopy__(self, memo: dict[int, Any]) -> TreeGenome:
        return self.copy()

    def __len__(self) -> int:
        return len(self.nodes)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TreeGenome):
            return NotImplemented
        # The same modules on the same faces: the order edges were added in does not matter.
        return self.nodes == other.nodes and _edge_set(self.edges) == _edge_set(other.edges)

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __repr__(self) -> str:
        return f"TreeGenome({len(self.nodes)} nodes, {len(self.edges)} edges)"
