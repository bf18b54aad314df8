"""Tree genome (upstream's ``ariel.ec.genotypes.tree``): conversion, operators, validation."""

from __future__ import annotations

import json
import random
import warnings
from pathlib import Path

import mujoco
import networkx as nx
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.ec.genotypes.tree import TreeGenome, operators as ops
from ariel.ec.genotypes.tree.io import genome_to_networkx_dict, load_genome, save_genome
from ariel.ec.genotypes.tree.validation import is_single_connected_tree, validate_genome_dict

MUTATIONS = [
    ops.mutate_replace_node,
    ops.mutate_subtree_replacement,
    ops.mutate_shrink,
    ops.mutate_hoist,
    ops.mutate_add_node,
    ops.mutate_rotation,
]


def test_random_tree_has_the_requested_size_and_builds() -> None:
    genome = ops.random_tree(20, rng=3)
    assert len(genome.nodes) == 20 and len(genome.edges) == 19
    validate_genome_dict(genome.to_dict())
    graph = genome.to_networkx()
    assert isinstance(graph, nx.DiGraph) and nx.is_arborescence(graph)
    model = construct_mjspec_from_graph(graph).spec.compile()
    hinges = sum(a["type"] == "HINGE" for a in genome.nodes.values())
    assert isinstance(model, mujoco.MjModel) and model.nu == hinges


def test_random_tree_is_deterministic_for_a_seed_and_for_pythons_random() -> None:
    assert ops.random_tree(12, rng=7) == ops.random_tree(12, rng=7)
    assert ops.random_tree(12, rng=7) != ops.random_tree(12, rng=8)
    random.seed(5)
    first = ops.random_tree(12)
    random.seed(5)
    assert ops.random_tree(12) == first  # upstream scripts seed `random`


def test_dict_and_json_round_trips(tmp_path: Path) -> None:
    genome = ops.random_tree(9, rng=1)
    plain = json.loads(json.dumps(genome.to_dict()))
    assert TreeGenome.from_dict(plain) == genome
    assert TreeGenome.from_json(genome.to_json()) == genome
    save_genome(genome, tmp_path / "g.json")
    assert load_genome(tmp_path / "g.json") == genome
    assert genome_to_networkx_dict(genome) == genome.to_dict()
    assert TreeGenome.from_networkx(genome.to_networkx()) == genome


@pytest.mark.parametrize("mutation", MUTATIONS, ids=lambda f: f.__name__)
def test_mutations_keep_a_valid_tree_and_repeat_with_a_seed(mutation) -> None:
    for seed in range(15):
        genome = ops.random_tree(10, rng=seed)
        again = genome.copy()
        mutation(genome, rng=seed)
        mutation(again, rng=seed)
        assert genome == again
        validate_genome_dict(genome.to_dict())
        construct_mjspec_from_graph(genome.to_networkx())


def test_mutations_change_the_genome_and_return_none() -> None:
    changed = 0
    for seed in range(10):
        genome = ops.random_tree(8, rng=seed)
        before = genome.copy()
        assert ops.mutate_replace_node(genome, rng=seed) is None
        changed += genome != before
    assert changed == 10  # a point mutation always changes a module's type


def test_crossover_swaps_subtrees_and_leaves_parents_alone() -> None:
    a, b = ops.random_tree(10, rng=1), ops.random_tree(10, rng=2)
    a0, b0 = a.copy(), b.copy()
    c1, c2 = ops.crossover_subtree(a, b, rng=4)
    assert a == a0 and b == b0
    for child in (c1, c2):
        validate_genome_dict(child.to_dict())
    # Modules are conserved: what one child lost, the other gained.
    assert len(c1.nodes) + len(c2.nodes) == len(a.nodes) + len(b.nodes)
    assert (c1, c2) != (a, b)  # upstream's version returned parent copies every time
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ops.crossover_one_point(a, b, rng=4)
    assert any(issubclass(w.category, DeprecationWarning) for w in caught)


def test_tree_depth() -> None:
    genome = TreeGenome()
    assert ops.get_tree_depth(genome) == 0
    ops.add_node(genome, 0, "FRONT", 1, "HINGE", "DEG_0")
    ops.add_node(genome, 1, "FRONT", 2, "BRICK", "DEG_90")
    assert ops.get_tree_depth(genome) == 2
    assert ops.validate_tree_depth(genome, 2) and not ops.validate_tree_depth(genome, 1)
    assert ops.get_top_ancestor(genome, 2) == 1
    ops.remove_subtree(genome, 1)
    assert list(genome.nodes) == [0] and genome.edges == []


def _genome(types: dict[int, str], edges: list[tuple[int, int, str]]) -> dict:
    nodes = {str(n): {"type": t, "rotation": "DEG_0"} for n, t in types.items()}
    return {"nodes": nodes, "edges": [{"parent": p, "child": c, "face": f} for p, c, f in edges]}


@pytest.mark.parametrize(
    ("genome", "message"),
    [
        (_genome({}, []), "core node"),
        (_genome({0: "CORE", 1: "X"}, []), "invalid type"),
        (_genome({0: "CORE", 1: "HINGE"}, [(0, 1, "TOP")]), "not allowed"),
        (_genome({0: "CORE", 1: "HINGE"}, []), "single connected tree"),
        (_genome({0: "CORE", 1: "CORE"}, [(0, 1, "LEFT")]), "alone is the CORE"),
        (
            _genome({0: "CORE", 1: "BRICK", 2: "BRICK"}, [(0, 1, "LEFT"), (0, 2, "LEFT")]),
            "already has child",
        ),
    ],
)
def test_validate_genome_dict_names_the_problem(genome: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        validate_genome_dict(genome)


def test_is_single_connected_tree() -> None:
    assert is_single_connected_tree(ops.random_tree(6, rng=0).to_dict())
    cut = ops.random_tree(6, rng=0).to_dict()
    cut["edges"] = cut["edges"][1:]
    assert not is_single_connected_tree(cut)


def test_prune_invalid_edges_drops_bad_faces() -> None:
    genome = TreeGenome()
    ops.add_node(genome, 0, "FRONT", 1, "HINGE", "DEG_0")
    ops.add_node(genome, 1, "LEFT", 2, "BRICK", "DEG_0")  # a hinge has no LEFT face
    ops._prune_invalid_edges(genome)
    assert sorted(genome.nodes) == [0, 1]
    validate_genome_dict(genome.to_dict())
    assert np.isclose(ops.get_tree_depth(genome), 1)


def test_encoders_keep_bodies_within_max_modules() -> None:
    from ariel.body_phenotypes.robogen_lite.cppn_encoder import CPPNEncoder
    from ariel.ec.genotypes.tree.encoder import TreeEncoder

    rng = np.random.default_rng(0)
    for encoder in (TreeEncoder(max_modules=6), CPPNEncoder(max_modules=6)):
        genotype = encoder.random_genotype(rng)
        for _ in range(20):
            genotype = encoder.crossover(genotype, encoder.mutate(genotype, rng), rng)
            assert 1 <= len(encoder.decode(genotype)) <= 6
    with pytest.raises(ValueError, match="min_modules"):
        TreeEncoder(max_modules=3, min_modules=4)
