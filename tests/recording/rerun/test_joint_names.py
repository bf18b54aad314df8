"""Joint names for people (`ariel.recording.rerun._joint_names.joint_labels`): the branch of the
core and the hinge's number in it, from the names the robogen-lite constructor gives."""

from __future__ import annotations

import json
import re

import networkx as nx
import numpy as np
import pytest
from _helpers import two_branches

from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.body_phenotypes.robogen_lite.graph_io import graph_to_plain
from ariel.ec.genotypes.tree.encoder import TreeEncoder
from ariel.recording.rerun._joint_names import joint_labels

LABEL = re.compile(r"(front|back|right|left) branch, hinge (\d+)")


def _joint_names(graph: nx.DiGraph, prefix: str = "robot1_") -> list[str]:
    """The joints of the body built from ``graph``, named and ordered as in a run's
    ``joint_names`` (its actuators)."""
    model = construct_mjspec_from_graph(graph).spec.compile()
    return [prefix + model.actuator(a).name for a in range(model.nu)]


def test_a_hinge_is_named_by_its_branch_and_its_number_there() -> None:
    graph = two_branches()
    names = _joint_names(graph)
    assert names == [  # the constructor's names: parent-child-face-servo, breadth-first
        "robot1_0-1-2-servo",
        "robot1_3-5-2-servo",
        "robot1_3-4-3-servo",
        "robot1_1-2-0-servo",
    ]
    by_name = dict(zip(names, joint_labels(names, graph)))
    assert by_name == {
        "robot1_0-1-2-servo": "right branch, hinge 1",
        "robot1_1-2-0-servo": "right branch, hinge 2",
        "robot1_3-5-2-servo": "front branch, hinge 1",
        "robot1_3-4-3-servo": "front branch, hinge 2",
    }
    # the graph as the bodies table stores it (node-link JSON), its dict, and without prefix
    stored = json.dumps(nx.node_link_data(graph_to_plain(graph), edges="edges"))
    assert joint_labels(names, stored) == joint_labels(names, json.loads(stored))
    assert joint_labels(names, stored) == list(by_name.values())
    bare = [n.removeprefix("robot1_") for n in names]
    assert joint_labels(bare, stored) == list(by_name.values())


def test_without_the_graph_a_hinge_is_named_by_its_module() -> None:
    names = _joint_names(two_branches())
    assert joint_labels(names) == [
        "hinge module 1",
        "hinge module 5",
        "hinge module 4",
        "hinge module 2",
    ]
    assert joint_labels(names, "not json") == joint_labels(names)  # an unreadable graph
    assert joint_labels([], two_branches()) == []


def test_hand_named_joints_lose_prefix_and_suffix_and_stay_unique() -> None:
    gecko = ["robot1_neckservo", "robot1_fl_legservo", "robot1_fl_flipperservo"]
    assert joint_labels(gecko) == ["neck", "fl leg", "fl flipper"]
    # two names that would read the same keep their names without the prefix
    assert joint_labels(["robot1_a_servo", "robot1_a-servo", "robot1_b"]) == [
        "a_servo",
        "a-servo",
        "b",
    ]


@pytest.mark.parametrize("seed", range(4))
def test_labels_of_random_bodies_are_unique_and_count_from_the_core(seed: int) -> None:
    encoder = TreeEncoder(max_modules=25, min_modules=10)
    rng = np.random.default_rng(seed)
    for _ in range(10):
        graph = encoder.decode(encoder.random_genotype(rng))
        names = _joint_names(graph)
        labels = joint_labels(names, graph)
        assert len(set(labels)) == len(labels) == len(names)
        depth = nx.shortest_path_length(graph, 0)
        branches: dict[str, list[tuple[int, int]]] = {}  # branch -> (number, depth) per hinge
        for name, label in zip(names, labels):
            found = LABEL.fullmatch(label)
            assert found, label
            hinge = int(name.split("-")[1])
            first = nx.shortest_path(graph, 0, hinge)[1]  # the module on the core's face
            assert found.group(1) == str(graph.edges[0, first]["face"]).lower()
            branches.setdefault(found.group(1), []).append((int(found.group(2)), depth[hinge]))
        for hinges in branches.values():  # in the order of the actuators: 1, 2, ...
            assert [number for number, _ in hinges] == list(range(1, len(hinges) + 1))
            depths = [d for _, d in hinges]
            assert depths == sorted(depths)  # hinge 1 nearest the core
