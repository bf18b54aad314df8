"""construct_mjspec_from_graph: validation errors, attribute forms, naming, order, JSON I/O."""

from __future__ import annotations

import json
import re
from collections.abc import Callable

import mujoco
import networkx as nx
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.config import (
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleRotationsTheta,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.constructor import (
    construct_mjspec_from_graph,
    load_graph_from_json,
    save_graph_as_json,
    validate_robot_graph,
)
from ariel.body_phenotypes.robogen_lite.graph_io import (
    load_graph_from_json as load_from_graph_io,
    robot_graph as _graph,
)
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko_graph


def _small() -> nx.DiGraph:
    return _graph(
        {0: ("CORE", "DEG_0"), 1: ("HINGE", "DEG_90"), 2: ("BRICK", "DEG_45")},
        [(0, 1, "LEFT"), (1, 2, "FRONT")],
    )


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) for i in range(count)]


# ---------------------------------------------------------------- building


def test_returns_core_module_with_spec() -> None:
    graph = _small()
    before = nx.node_link_data(graph, edges="edges")
    core = construct_mjspec_from_graph(graph)
    assert isinstance(core, CoreModule)
    model = core.spec.compile()
    assert model.nbody == 1 + 1 + 3 + 1
    assert model.nu == 1
    assert float(model.body_mass.sum()) == pytest.approx(1.0 + 0.06 + 0.055)
    assert nx.node_link_data(graph, edges="edges") == before  # input not mutated


def test_core_only_graph() -> None:
    graph = _graph({0: ("CORE", "DEG_0")}, [])
    model = construct_mjspec_from_graph(graph).spec.compile()
    assert model.nbody == 2
    assert model.nu == 0


def test_prefixes_are_parent_child_face() -> None:
    model = construct_mjspec_from_graph(_small()).spec.compile()
    bodies = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
    assert bodies == ["world", "core", "0-1-3-hinge", "0-1-3-stator", "0-1-3-rotor", "1-2-0-brick"]
    assert _names(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu) == ["0-1-3-servo"]


def _deep_graph() -> nx.DiGraph:
    # A chain deep enough that bottom-up attachment would compound names, plus side branches.
    nodes = {0: ("CORE", "DEG_0")}
    edges = []
    for node in range(1, 9):
        nodes[node] = ("HINGE" if node % 2 else "BRICK", "DEG_0")
        edges.append((node - 1, node, "FRONT"))
    nodes[12] = ("HINGE", "DEG_90")
    edges.append((2, 12, "LEFT"))
    nodes[11] = ("BRICK", "DEG_0")
    edges.append((12, 11, "FRONT"))
    nodes[10] = ("HINGE", "DEG_45")
    edges.append((0, 10, "BACK"))
    return _graph(nodes, edges)


def test_element_names_never_compound() -> None:
    graph = _deep_graph()
    model = construct_mjspec_from_graph(graph).spec.compile()
    pattern = re.compile(r"^(\d+)-(\d+)-(\d)-(hinge|stator|rotor|brick|servo)$")
    for name in _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)[2:] + _names(
        model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu
    ):
        match = pattern.match(name)
        assert match, name
        parent, child, face = (int(g) for g in match.groups()[:3])
        assert graph.has_edge(parent, child)
        assert ModuleFaces[graph.edges[parent, child]["face"]].value == face
    assert model.nbody == 2 + 6 * 3 + 5  # world, core, 6 hinges, 5 bricks


def test_breadth_first_attachment_order_sets_actuator_order() -> None:
    # Children of a module in ascending face value (FRONT 0, BACK 1, RIGHT 2, LEFT 3), then id.
    graph = _graph(
        {
            0: ("CORE", "DEG_0"),
            5: ("HINGE", "DEG_0"),
            3: ("HINGE", "DEG_0"),
            9: ("HINGE", "DEG_0"),
            1: ("HINGE", "DEG_0"),
            2: ("HINGE", "DEG_0"),
        },
        [(0, 5, "LEFT"), (0, 3, "RIGHT"), (5, 1, "FRONT"), (0, 9, "FRONT"), (9, 2, "FRONT")],
    )
    assert validate_robot_graph(graph).order == [0, 9, 3, 5, 2, 1]
    model = construct_mjspec_from_graph(graph).spec.compile()
    assert _names(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu) == [
        "0-9-0-servo",
        "0-3-2-servo",
        "0-5-3-servo",
        "9-2-0-servo",
        "5-1-0-servo",
    ]


def test_rotation_is_applied() -> None:
    model = construct_mjspec_from_graph(_small()).spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    # The hinge on the core's LEFT grows along -x; DEG_90 turns its joint axis horizontal.
    axis = data.xaxis[model.joint("0-1-3-servo").id]
    np.testing.assert_allclose(np.abs(axis), [0, 1, 0], atol=1e-12)


def _model_arrays(graph: nx.DiGraph) -> tuple:
    model = construct_mjspec_from_graph(graph).spec.compile()
    return (
        model.nbody,
        model.nu,
        model.body_mass.copy(),
        model.body_pos.copy(),
        model.body_quat.copy(),
        _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody),
    )


def _assert_same_model(a: tuple, b: tuple) -> None:
    assert a[0] == b[0]
    assert a[1] == b[1]
    np.testing.assert_array_equal(a[2], b[2])
    np.testing.assert_array_equal(a[3], b[3])
    np.testing.assert_array_equal(a[4], b[4])
    assert a[5] == b[5]


def test_enum_members_and_names_are_accepted() -> None:
    by_name = _small()
    by_enum = _graph(
        {
            0: (ModuleType.CORE, ModuleRotationsIdx.DEG_0),
            1: (ModuleType.HINGE, ModuleRotationsIdx.DEG_90),
            2: (ModuleType.BRICK, ModuleRotationsTheta.DEG_45),
        },
        [(0, 1, ModuleFaces.LEFT), (1, 2, ModuleFaces.FRONT)],
    )
    lower_case = _graph(
        {0: ("core", "deg_0"), 1: ("hinge", "DEG_90"), 2: ("Brick", ModuleRotationsTheta.DEG_45)},
        [(0, 1, "left"), (1, 2, "FRONT")],
    )
    reference = _model_arrays(by_name)
    _assert_same_model(reference, _model_arrays(by_enum))
    _assert_same_model(reference, _model_arrays(lower_case))


def test_numpy_integer_node_ids_are_accepted() -> None:
    graph = nx.relabel_nodes(_small(), {n: np.int64(n) for n in (0, 1, 2)})
    _assert_same_model(_model_arrays(_small()), _model_arrays(graph))


# ---------------------------------------------------------------- validation


def _with(change: Callable[[nx.DiGraph], None]) -> nx.DiGraph:
    graph = _small()
    change(graph)
    return graph


def _remove_attr(graph: nx.DiGraph, node: int, key: str) -> None:
    del graph.nodes[node][key]


INVALID: dict[str, tuple[Callable[[], object], str]] = {
    "cycle": (lambda: _with(lambda g: g.add_edge(2, 1, face="FRONT")), "has a cycle"),
    "self loop": (lambda: _with(lambda g: g.add_edge(2, 2, face="FRONT")), "has a cycle"),
    "two parents": (
        lambda: _graph(
            {
                0: ("CORE", "DEG_0"),
                1: ("BRICK", "DEG_0"),
                2: ("BRICK", "DEG_0"),
                3: ("BRICK", "DEG_0"),
            },
            [(0, 1, "LEFT"), (0, 2, "RIGHT"), (1, 3, "FRONT"), (2, 3, "FRONT")],
        ),
        r"node 3 has 2 parents \(1, 2\)",
    ),
    "no node 0": (
        lambda: nx.relabel_nodes(_small(), {0: 7, 1: 8, 2: 9}),
        "has no node 0",
    ),
    "core not root": (
        lambda: _graph(
            {0: ("CORE", "DEG_0"), 1: ("BRICK", "DEG_0")},
            [(1, 0, "FRONT")],
        ),
        "not rooted at node 0: the core has parent 1",
    ),
    "disconnected": (
        lambda: _with(lambda g: g.add_node(5, type="BRICK", rotation="DEG_0")),
        r"not a tree rooted at node 0: nodes \[5\] are not connected",
    ),
    "non-int node id": (
        lambda: _with(lambda g: g.add_edge(2, "x", face="FRONT")),
        "node ids must be ints",
    ),
    "missing type": (lambda: _with(lambda g: _remove_attr(g, 1, "type")), "node 1 has no 'type'"),
    "missing rotation": (
        lambda: _with(lambda g: _remove_attr(g, 2, "rotation")),
        "node 2 has no 'rotation'",
    ),
    "missing face": (
        lambda: _with(lambda g: g.edges[1, 2].pop("face")),
        r"edge 1 -> 2 has no 'face'",
    ),
    "unknown type": (
        lambda: _with(lambda g: g.nodes[1].update(type="WHEEL")),
        r"Unknown module type 'WHEEL' \(node 1\); allowed: CORE, BRICK, HINGE",
    ),
    "unknown rotation": (
        lambda: _with(lambda g: g.nodes[1].update(rotation="DEG_30")),
        r"Unknown rotation 'DEG_30' \(node 1\); allowed: DEG_0, DEG_45, DEG_90",
    ),
    "unknown face": (
        lambda: _with(lambda g: g.edges[1, 2].update(face="UP")),
        r"Unknown face 'UP' \(edge 1 -> 2\)",
    ),
    "NONE module": (
        lambda: _with(lambda g: g.nodes[2].update(type="NONE")),
        "node 2 has type NONE",
    ),
    "node 0 not core": (
        lambda: _with(lambda g: g.nodes[0].update(type="BRICK")),
        "node 0 must be the CORE, but its type is BRICK",
    ),
    "second core": (
        lambda: _with(lambda g: g.nodes[2].update(type="CORE")),
        "node 2 has type CORE; only node 0",
    ),
    "face not allowed": (
        lambda: _with(lambda g: g.edges[1, 2].update(face="LEFT")),
        r"face LEFT is not allowed on a HINGE \(edge 1 -> 2\); allowed: FRONT",
    ),
    "core TOP not allowed": (
        lambda: _with(lambda g: g.edges[0, 1].update(face="TOP")),
        "face TOP is not allowed on a CORE",
    ),
    "rotation not allowed": (
        lambda: _with(lambda g: g.nodes[0].update(rotation="DEG_90")),
        r"rotation DEG_90 is not allowed on a CORE \(node 0\); allowed: DEG_0",
    ),
    "two children on one face": (
        lambda: _with(
            lambda g: (g.add_node(3, type="BRICK", rotation="DEG_0"), g.add_edge(0, 3, face="LEFT"))
        ),
        r"node 0 has two children on face LEFT \(nodes 1 and 3\)",
    ),
}


@pytest.mark.parametrize("kind", sorted(INVALID))
def test_invalid_graph_gives_one_line_value_error(kind: str) -> None:
    build, message = INVALID[kind]
    with pytest.raises(ValueError, match=message) as info:
        construct_mjspec_from_graph(build())
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("graph", [nx.Graph(), nx.MultiDiGraph(), {0: {}}, None])
def test_not_a_digraph_is_a_type_error(graph: object) -> None:
    with pytest.raises(TypeError, match="must be a networkx DiGraph"):
        construct_mjspec_from_graph(graph)  # type: ignore[arg-type]


# ---------------------------------------------------------------- JSON


def test_json_round_trip_preserves_attributes_and_model(tmp_path) -> None:
    graph = gecko_graph()
    # Mix in enum members: they are saved as names.
    graph.nodes[5]["type"] = ModuleType.HINGE
    graph.nodes[5]["rotation"] = ModuleRotationsIdx.DEG_90
    graph.edges[0, 5]["face"] = ModuleFaces.LEFT
    path = tmp_path / "gecko.json"
    save_graph_as_json(graph, path)
    raw = json.loads(path.read_text())
    assert "edges" in raw
    assert raw["directed"] is True

    loaded = load_graph_from_json(path)
    assert isinstance(loaded, nx.DiGraph)
    assert not loaded.is_multigraph()
    assert sorted(loaded.nodes) == sorted(graph.nodes)
    assert set(loaded.edges) == set(graph.edges)
    for node, attrs in graph.nodes(data=True):
        assert loaded.nodes[node] == {
            key: getattr(value, "name", value) for key, value in attrs.items()
        }
    for u, v, attrs in graph.edges(data=True):
        assert loaded.edges[u, v]["face"] == getattr(attrs["face"], "name", attrs["face"])
    _assert_same_model(_model_arrays(graph), _model_arrays(loaded))


def test_save_none_is_a_no_op_and_links_key_loads(tmp_path) -> None:
    save_graph_as_json(_small(), None)
    assert list(tmp_path.iterdir()) == []
    data = nx.node_link_data(_small(), edges="links")
    path = tmp_path / "old.json"
    path.write_text(json.dumps(data))
    loaded = load_from_graph_io(path)
    assert set(loaded.edges) == {(0, 1), (1, 2)}
    _assert_same_model(_model_arrays(_small()), _model_arrays(loaded))


def test_numpy_node_ids_are_saved_as_plain_ints(tmp_path) -> None:
    graph = nx.relabel_nodes(_small(), {n: np.int64(n) for n in (0, 1, 2)})
    path = tmp_path / "g.json"
    save_graph_as_json(graph, path)
    assert sorted(load_graph_from_json(path).nodes) == [0, 1, 2]
