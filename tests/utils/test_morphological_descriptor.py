"""MorphologicalMeasures (upstream's ``ariel.utils.morphological_descriptor``)."""

from __future__ import annotations

import pytest

from ariel.body_phenotypes.robogen_lite.descriptors import morphology_descriptors
from ariel.body_phenotypes.robogen_lite.graph_io import robot_graph
from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS
from ariel.ec.genotypes.tree.operators import random_tree
from ariel.utils.morphological_descriptor import MorphologicalMeasures


@pytest.mark.parametrize("seed", range(8))
def test_counts_agree_with_morphology_descriptors(seed: int) -> None:
    graph = random_tree(3 + 2 * seed, rng=seed).to_networkx()
    measures, ours = MorphologicalMeasures(graph), morphology_descriptors(graph)
    assert measures.num_modules == ours["num_modules"] == graph.number_of_nodes()
    assert measures.num_bricks == ours["num_bricks"]
    assert measures.num_active_hinges == measures.num_joints == ours["num_hinges"]
    assert measures.num_single_neighbour_modules == ours["num_limbs"]
    for value in (
        measures.branching,
        measures.limbs,
        measures.length_of_limbs,
        measures.coverage,
        measures.joints,
        measures.symmetry,
        measures.module_diversity,
    ):
        assert 0.0 <= value <= 1.0


def test_gecko_is_left_right_symmetric() -> None:
    measures = MorphologicalMeasures(PREBUILT_GRAPHS["gecko"]())
    assert measures.xz_symmetry == 1.0 and measures.symmetry == measures.S == 1.0
    assert measures.num_modules == 15 and measures.num_active_hinges == 8
    assert measures.joints == pytest.approx(8 / 14)
    assert not measures.is_2d  # the back legs are rotated 45 degrees
    with pytest.raises(ValueError, match="planar"):
        _ = measures.proportion_2d
    assert measures.P == 0.0


def test_a_straight_chain() -> None:
    graph = robot_graph(
        {0: ("CORE", "DEG_0"), 1: ("HINGE", "DEG_0"), 2: ("BRICK", "DEG_0")},
        [(0, 1, "FRONT"), (1, 2, "FRONT")],
    )
    measures = MorphologicalMeasures(graph)
    assert (measures.bounding_box_depth, measures.bounding_box_width) == (3, 1)
    assert measures.coverage == 1.0 and measures.proportion == pytest.approx(1 / 3)
    assert measures.length_of_limbs == 1.0  # the hinge has exactly two neighbours
    assert measures.module_diversity == 1.0  # hinge -> brick
    assert not measures.core_is_filled


def test_empty_graph_is_refused() -> None:
    import networkx as nx

    with pytest.raises(ValueError, match="empty"):
        MorphologicalMeasures(nx.DiGraph())
