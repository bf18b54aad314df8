"""CPPN-NEAT genomes, IdManager and the best-first decoder (upstream's cppn_neat API)."""

from __future__ import annotations

import json
import random
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.config import ALLOWED_FACES, ModuleFaces, ModuleType
from ariel.body_phenotypes.robogen_lite.constructor import (
    construct_mjspec_from_graph,
    validate_robot_graph,
)
from ariel.body_phenotypes.robogen_lite.cppn_neat.activations import ACTIVATION_FUNCTIONS
from ariel.body_phenotypes.robogen_lite.cppn_neat.connection import Connection
from ariel.body_phenotypes.robogen_lite.cppn_neat.genome import Genome
from ariel.body_phenotypes.robogen_lite.cppn_neat.id_manager import IdManager
from ariel.body_phenotypes.robogen_lite.decoders.cppn_best_first import (
    MorphologyDecoderBestFirst,
)

N_IN, N_OUT = 6, 8


def _genome(seed: int, mutations: int = 4) -> Genome:
    ids = IdManager(node_start=N_IN + N_OUT - 1, innov_start=N_IN * N_OUT - 1)
    genome = Genome.random(N_IN, N_OUT, N_IN + N_OUT, 0, rng=seed)
    gen = np.random.default_rng(seed)
    for _ in range(mutations):
        genome.mutate(0.6, 0.6, ids.get_next_innov_id, ids.get_next_node_id, rng=gen)
    return genome


def test_random_genome_is_fully_connected_and_seeded() -> None:
    genome = Genome.random(N_IN, N_OUT, N_IN + N_OUT, 0, rng=1)
    assert len(genome.nodes) == N_IN + N_OUT and len(genome.connections) == N_IN * N_OUT
    assert sorted(genome.connections) == list(range(N_IN * N_OUT))
    assert all(-1 <= c.weight <= 1 for c in genome.connections.values())
    assert genome.to_dict() == Genome.random(N_IN, N_OUT, 0, 0, rng=1).to_dict()
    assert genome.to_dict() != Genome.random(N_IN, N_OUT, 0, 0, rng=2).to_dict()
    random.seed(3)
    first = Genome.random(N_IN, N_OUT).to_dict()
    random.seed(3)
    assert Genome.random(N_IN, N_OUT).to_dict() == first


def test_activate_matches_a_hand_computed_network() -> None:
    genome = Genome.random(2, 1, rng=0)
    w = {(c.in_id, c.out_id): c.weight for c in genome.connections.values()}
    bias = genome.nodes[2].bias
    expected = 1.0 / (1.0 + np.exp(-(0.5 * w[0, 2] - 1.0 * w[1, 2] + bias)))
    assert genome.activate([0.5, -1.0]) == pytest.approx([expected])
    with pytest.raises(ValueError, match="Expected 2 inputs"):
        genome.activate([1.0])


def test_structural_mutation_adds_genes_and_ids_advance() -> None:
    ids = IdManager(node_start=N_IN + N_OUT - 1, innov_start=N_IN * N_OUT - 1)
    genome = Genome.random(N_IN, N_OUT, rng=0)
    genome.mutate(1.0, 0.0, ids.get_next_innov_id, ids.get_next_node_id, rng=0)
    assert len(genome.nodes) == N_IN + N_OUT + 1 and len(genome.connections) == N_IN * N_OUT + 2
    assert sum(not c.enabled for c in genome.connections.values()) == 1
    assert ids.node_id == N_IN + N_OUT and ids.innov_id == N_IN * N_OUT + 1
    assert len(genome.activate([0.1] * N_IN)) == N_OUT


def test_a_cyclic_genome_still_activates() -> None:
    genome = Genome.random(2, 1, rng=0)
    genome.add_connection(Connection(2, 2, 0.5, True, 99))  # a self-loop on the output
    with pytest.raises(ValueError, match="cycle"):
        genome.get_node_ordering()
    out = genome.activate([1.0, 1.0])
    assert len(out) == 1 and np.isfinite(out[0])


def test_crossover_keeps_matching_genes_and_the_fitter_parents_extra_genes() -> None:
    a, b = _genome(1), _genome(1, mutations=0)
    a.fitness, b.fitness = 2.0, 1.0
    child = a.crossover(b, rng=0)
    assert set(child.connections) == set(a.connections)
    assert set(b.connections) <= set(child.connections)
    b.fitness = 3.0
    assert set(a.crossover(b, rng=0).connections) == set(b.connections)
    # Minimising: the lower fitness is the fitter parent.
    assert set(a.crossover(b, is_maximisation=False, rng=0).connections) == set(a.connections)


def test_dict_round_trip_and_errors() -> None:
    genome = _genome(5)
    plain = json.loads(json.dumps(genome.to_dict()))
    again = Genome.from_dict(plain, fitness=1.5)
    assert again.to_dict() == genome.to_dict() and again.fitness == 1.5
    x = np.random.default_rng(0).random((4, N_IN))
    assert np.array_equal(genome.compile()(x), again.compile()(x))
    with pytest.raises(ValueError, match="not a CPPN genome"):
        Genome.from_dict({"nodes": {}})
    assert set(ACTIVATION_FUNCTIONS) == {"sigmoid", "tanh", "sin", "gaussian", "relu"}


def test_id_manager_persists(tmp_path: Path) -> None:
    path = tmp_path / "ids.json"
    ids = IdManager(path)
    ids.set_initial_ids(N_IN, N_OUT)
    assert ids.get_next_node_id() == N_IN + N_OUT and ids.get_next_innov_id() == N_IN * N_OUT
    ids.save()
    loaded = IdManager(path)
    assert (loaded.node_id, loaded.innov_id) == (ids.node_id, ids.innov_id)


@pytest.mark.parametrize("seed", range(6))
def test_best_first_decoder_builds_valid_bodies(seed: int) -> None:
    genome = _genome(seed)
    graph = MorphologyDecoderBestFirst(genome, max_modules=12).decode()
    assert isinstance(graph, nx.DiGraph) and 1 <= len(graph) <= 12
    tree = validate_robot_graph(graph)
    for parent, kids in tree.children.items():
        assert all(face in ALLOWED_FACES[tree.types[parent]] for face, _ in kids)
    assert all(t is not ModuleType.CORE for n, t in tree.types.items() if n != 0)
    construct_mjspec_from_graph(graph).spec.compile()
    # Deterministic: the same genome decodes to the same graph.
    again = MorphologyDecoderBestFirst(genome, max_modules=12).decode()
    assert nx.utils.graphs_equal(graph, again)


def test_best_first_decoder_fills_to_max_modules_and_checks_the_cppn() -> None:
    graph = MorphologyDecoderBestFirst(_genome(0), max_modules=20).decode()
    assert len(graph) == 20  # best-first never stops early while a face is free
    assert graph.nodes[0]["type"] == "CORE"
    assert {graph.edges[e]["face"] for e in graph.edges} <= {f.name for f in ModuleFaces}
    with pytest.raises(ValueError, match="6 inputs"):
        MorphologyDecoderBestFirst(Genome.random(3, 8, rng=0)).decode()
