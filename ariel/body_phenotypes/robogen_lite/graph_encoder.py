"""The ``graph`` body encoder: a robot graph given directly, as networkx node-link data.

The genotype is the graph itself (``networkx.node_link_data(graph, edges="edges")``, as
`graph_io` writes it), so it cannot vary: ``evolvable`` is False and `mutate`/`crossover`
refuse. Registered as ``"graph"`` in ``ariel._builtin_names``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NoReturn

import networkx as nx

from ariel.body_phenotypes.robogen_lite.graph_io import graph_to_plain
from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS
from ariel.errors import cannot_vary

if TYPE_CHECKING:
    import numpy as np

__all__ = ["GraphEncoder"]


class GraphEncoder:
    """A robot graph given directly, as networkx node-link data (``edges="edges"``).

    ``random_genotype`` gives the gecko's graph (the rng is not used): the default body, as
    the ``prebuilt`` encoder's.
    """

    name = "graph"
    evolvable = False

    def __init__(self) -> None:
        pass

    def random_genotype(self, rng: np.random.Generator) -> dict[str, Any]:
        return nx.node_link_data(graph_to_plain(PREBUILT_GRAPHS["gecko"]()), edges="edges")

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> NoReturn:
        cannot_vary(self.name)

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> NoReturn:
        cannot_vary(self.name)

    def decode(self, genotype: Any) -> nx.DiGraph:
        if isinstance(genotype, nx.DiGraph):
            return genotype
        if not isinstance(genotype, dict) or "nodes" not in genotype:
            raise ValueError("a 'graph' body must be networkx node-link data (a dict with 'nodes')")
        return nx.node_link_graph(genotype, directed=True, multigraph=False, edges="edges")
