"""An upstream-style script: decode a body, save its graph as JSON, load it, rebuild it."""

from __future__ import annotations

from pathlib import Path

import mujoco
import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import (
    HighProbabilityDecoder,
    load_graph_from_json,
    save_graph_as_json,
)
from ariel.ec.genotypes.tree.operators import random_tree
from ariel.simulation.environments import SimpleFlatWorld


def compiled(graph: nx.DiGraph) -> mujoco.MjModel:
    world = SimpleFlatWorld()
    world.spawn(construct_mjspec_from_graph(graph).spec, position=(0, 0, 0))
    return world.spec.compile()


def test_graph_json_round_trip_rebuilds_the_same_robot(tmp_path: Path) -> None:
    rng = np.random.default_rng(42)
    n = 20
    decoded = HighProbabilityDecoder(n).probability_matrices_to_graph(
        rng.random((n, 4)), rng.random((n, n, 6)), rng.random((n, 3))
    )
    for name, graph in (("hpd", decoded), ("tree", random_tree(15, rng=1).to_networkx())):
        path = tmp_path / f"{name}.json"
        save_graph_as_json(graph, path)
        loaded = load_graph_from_json(path)
        assert nx.utils.graphs_equal(loaded, graph)
        a, b = compiled(graph), compiled(loaded)
        assert (a.nbody, a.ngeom, a.nu) == (b.nbody, b.ngeom, b.nu)
        assert np.array_equal(a.body_mass, b.body_mass)
