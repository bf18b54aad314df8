"""Morphology descriptors of robot graphs."""

from __future__ import annotations

import math

import mujoco
import networkx as nx
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES, morphology_descriptors
from ariel.body_phenotypes.robogen_lite.graph_io import robot_graph as _graph
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko_graph
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.spider import spider_graph


def _compiled_extent(graph: nx.DiGraph) -> np.ndarray:
    model = construct_mjspec_from_graph(graph).spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    corners = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)
    points = np.concatenate(
        [
            data.geom_xpos[i] + (corners * model.geom_size[i]) @ data.geom_xmat[i].reshape(3, 3).T
            for i in range(model.ngeom)
        ]
    )
    return points.max(axis=0) - points.min(axis=0)


def test_gecko_descriptors() -> None:
    d = morphology_descriptors(gecko_graph())
    assert list(d) == list(DESCRIPTOR_NAMES)
    assert d["num_modules"] == 15
    assert d["num_hinges"] == 8
    assert d["num_bricks"] == 6
    assert d["num_limbs"] == 4  # four flippers
    assert d["num_core_children"] == 3
    assert d["depth"] == 6  # core > neck > abdomen > spine > butt > bl_leg > bl_flipper
    assert d["branching"] == pytest.approx(14 / 11)
    assert d["joints_ratio"] == pytest.approx(8 / 15)
    assert d["symmetry"] == pytest.approx(0.5)  # legs mirror, nothing at the BACK
    assert d["extent_x"] == pytest.approx(0.8)
    assert d["extent_y"] == pytest.approx(0.6 + 0.05 * math.sqrt(2) - 0.05)
    assert d["extent_z"] == pytest.approx(0.1 + 0.05 + 0.05 * math.sqrt(2))


def test_values_are_plain_python_numbers() -> None:
    for value in morphology_descriptors(gecko_graph()).values():
        assert type(value) in (int, float)


def test_spider_is_fully_symmetric() -> None:
    d = morphology_descriptors(spider_graph())
    assert d["symmetry"] == 1.0
    assert d["num_limbs"] == 4
    assert d["depth"] == 3
    assert d["extent_x"] == pytest.approx(0.8)
    assert d["extent_y"] == pytest.approx(0.8)


def test_core_only() -> None:
    d = morphology_descriptors(_graph({0: ("CORE", "DEG_0")}, []))
    assert d["num_modules"] == 1
    assert d["num_limbs"] == 0
    assert d["depth"] == 0
    assert d["branching"] == 0.0
    assert d["joints_ratio"] == 0.0
    assert d["symmetry"] == 1.0
    assert (d["extent_x"], d["extent_y"], d["extent_z"]) == pytest.approx((0.2, 0.2, 0.2))


def test_partial_symmetry() -> None:
    # LEFT: hinge > brick, RIGHT: hinge only -> 1 of 2 modules match; FRONT/BACK empty -> 1.
    graph = _graph(
        {
            0: ("CORE", "DEG_0"),
            1: ("HINGE", "DEG_0"),
            2: ("BRICK", "DEG_0"),
            3: ("HINGE", "DEG_0"),
        },
        [(0, 1, "LEFT"), (1, 2, "FRONT"), (0, 3, "RIGHT")],
    )
    d = morphology_descriptors(graph)
    assert d["symmetry"] == pytest.approx((0.5 + 1.0) / 2)
    assert d["branching"] == pytest.approx(3 / 2)
    assert d["num_limbs"] == 2


@pytest.mark.parametrize(("right_child_face", "expected"), [("RIGHT", 1.0), ("LEFT", 0.75)])
def test_mirror_swaps_left_and_right(right_child_face: str, expected: float) -> None:
    # The mirror image of "brick with a brick on its LEFT" is "brick with a brick on its RIGHT".
    graph = _graph(
        {i: ("CORE" if i == 0 else "BRICK", "DEG_0") for i in range(5)},
        [(0, 1, "LEFT"), (1, 2, "LEFT"), (0, 3, "RIGHT"), (3, 4, right_child_face)],
    )
    assert morphology_descriptors(graph)["symmetry"] == pytest.approx(expected)


def test_rotation_difference_breaks_symmetry() -> None:
    graph = _graph(
        {0: ("CORE", "DEG_0"), 1: ("HINGE", "DEG_0"), 2: ("HINGE", "DEG_90")},
        [(0, 1, "FRONT"), (0, 2, "BACK")],
    )
    assert morphology_descriptors(graph)["symmetry"] == pytest.approx(0.5)


def _tangled_graph() -> nx.DiGraph:
    return _graph(
        {
            0: ("CORE", "DEG_0"),
            1: ("BRICK", "DEG_45"),
            2: ("HINGE", "DEG_90"),
            3: ("BRICK", "DEG_0"),
            4: ("HINGE", "DEG_45"),
            5: ("BRICK", "DEG_90"),
            6: ("HINGE", "DEG_0"),
            7: ("BRICK", "DEG_0"),
        },
        [
            (0, 1, "BACK"),
            (1, 2, "TOP"),
            (2, 3, "FRONT"),
            (3, 4, "LEFT"),
            (1, 5, "BOTTOM"),
            (5, 6, "RIGHT"),
            (0, 7, "RIGHT"),
        ],
    )


def _random_tree(seed: int, size: int = 12) -> nx.DiGraph:
    """A random valid robot tree (its own generator), to cross-check the geometry."""
    rng = np.random.default_rng(seed)
    allowed = {
        "CORE": ["FRONT", "BACK", "RIGHT", "LEFT"],
        "BRICK": ["FRONT", "RIGHT", "LEFT", "TOP", "BOTTOM"],
        "HINGE": ["FRONT"],
    }
    graph = _graph({0: ("CORE", "DEG_0")}, [])
    free = [(0, face) for face in allowed["CORE"]]
    for node in range(1, size):
        parent, face = free.pop(int(rng.integers(len(free))))
        module_type = str(rng.choice(["BRICK", "HINGE"]))
        graph.add_node(
            node, type=module_type, rotation=str(rng.choice(["DEG_0", "DEG_45", "DEG_90"]))
        )
        graph.add_edge(parent, node, face=face)
        free.extend((node, f) for f in allowed[module_type])
    return graph


@pytest.mark.parametrize(
    "build",
    [gecko_graph, spider_graph, _tangled_graph] + [lambda s=s: _random_tree(s) for s in range(4)],
)
def test_extent_matches_the_compiled_geometry(build) -> None:
    d = morphology_descriptors(build())
    np.testing.assert_allclose(
        [d["extent_x"], d["extent_y"], d["extent_z"]], _compiled_extent(build()), atol=1e-9
    )


def test_invalid_graph_is_rejected() -> None:
    graph = gecko_graph()
    graph.add_edge(4, 2, face="TOP")
    with pytest.raises(ValueError):
        morphology_descriptors(graph)
