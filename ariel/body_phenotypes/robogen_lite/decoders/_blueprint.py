"""Shared base of the decoders (`Blueprint`) and the robot-graph file helpers, where upstream
keeps them: `save_graph_as_json` / `load_graph_from_json` (from `graph_io`) and `draw_graph`.

`draw_graph` imports matplotlib only when called, so importing a decoder stays light.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import networkx as nx

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces, ModuleRotationsIdx, ModuleType
from ariel.body_phenotypes.robogen_lite.graph_io import load_graph_from_json, save_graph_as_json

__all__ = ["Blueprint", "draw_graph", "load_graph_from_json", "save_graph_as_json"]


class Blueprint:
    """Base of decoders that grow a graph of ``num_modules`` modules at most.

    A decoder fills ``nodes`` (module indices), ``edges`` (``(parent, child, face)``),
    ``type_dict`` and ``rot_dict`` (index -> ``ModuleType`` / ``ModuleRotationsIdx``);
    `generate_networkx_graph` then adds them to ``graph``.

    Args:
        num_modules: Most modules the decoder may place (an int >= 1); kept as
            ``num_modules``.

    Raises:
        ValueError: If ``num_modules`` is a bool or less than 1.
    """

    def __init__(self, num_modules: int) -> None:
        if isinstance(num_modules, bool) or int(num_modules) < 1:
            raise ValueError(f"num_modules must be an int >= 1, not {num_modules!r}")
        self.num_modules = int(num_modules)
        self._graph: dict[int, Any] = {}
        self.graph = nx.DiGraph()
        self.type_dict: dict[int, ModuleType] = {}
        self.rot_dict: dict[int, ModuleRotationsIdx] = {}
        self.nodes: set[int] = set()
        self.edges: list[tuple[int, int, ModuleFaces]] = []

    def generate_networkx_graph(self) -> None:
        """Add ``nodes`` (ascending, with ``type`` and ``rotation`` names) and ``edges`` (with
        the ``face`` name; a face may be a ``ModuleFaces`` or its value) to ``graph``.

        Raises:
            ValueError: If nothing was decoded yet (no ``nodes``): an empty graph would
                otherwise come back as if it were a body.
        """
        if not self.nodes:
            steps = getattr(self, "_ENTRY", "the decoder's steps")
            msg = f"no modules decoded yet (nodes is empty): call {steps} first"
            raise ValueError(msg)
        types, rotations = self.type_dict, self.rot_dict
        self.graph.add_nodes_from(
            (node, {"type": types[node].name, "rotation": rotations[node].name})
            for node in sorted(self.nodes)
        )
        self.graph.add_edges_from(
            (
                parent,
                child,
                {"face": (face if isinstance(face, ModuleFaces) else ModuleFaces(face)).name},
            )
            for parent, child, face in self.edges
        )


def draw_graph(
    graph: nx.DiGraph,
    title: str = "NetworkX Directed Graph",
    save_file: str | Path | None = None,
    *,
    seed: int = 42,
    dpi: int = 300,
) -> None:
    """Draw a robot graph with matplotlib.

    Nodes are placed by a spectral layout refined by a seeded spring layout, labelled with
    their id and type; edges are labelled by face.

    Args:
        graph: The robot graph to draw (at least one node).
        title: Title of the plot.
        save_file: Image file to save the drawing to (format from its suffix); when None the
            figure is shown with ``plt.show()`` instead.
        seed: Seed of the spring layout (the same seed gives the same picture).
        dpi: Resolution of the saved image, in dots per inch.

    Raises:
        ValueError: If ``graph`` has no nodes.
    """
    import matplotlib.pyplot as plt  # lazy: heavy optional library

    if graph.number_of_nodes() == 0:
        raise ValueError("cannot draw an empty graph")
    layout = nx.spectral_layout(graph) if graph.number_of_nodes() > 2 else None
    pos = nx.spring_layout(graph, pos=layout, k=1.0, iterations=50, seed=seed)
    labels = {n: f"{n}\n{a.get('type', '')}" for n, a in graph.nodes(data=True)}
    edge_labels = {(u, v): str(a.get("face", "")) for u, v, a in graph.edges(data=True)}
    fig, ax = plt.subplots(figsize=(8, 8))
    try:
        nx.draw(graph, pos, ax=ax, labels=labels, node_color="#fdca40", node_size=700, font_size=7)
        nx.draw_networkx_edge_labels(graph, pos, edge_labels=edge_labels, ax=ax, font_size=6)
        ax.set_title(title)
        if save_file is None:
            plt.show()
        else:
            fig.savefig(save_file, dpi=dpi, bbox_inches="tight")
    finally:
        plt.close(fig)
