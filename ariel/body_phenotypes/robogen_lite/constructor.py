"""Build a robot body (a ``CoreModule`` and its MjSpec) from a robot graph.

A robot graph is a ``networkx.DiGraph`` that is a tree rooted at node 0 (the core). Node ids
are ints (they become module indices). Node attributes: ``type`` (``ModuleType`` member or its
name, e.g. "HINGE") and ``rotation`` (``ModuleRotationsIdx``/``ModuleRotationsTheta`` member
or its name, e.g. "DEG_45"). Edge attribute: ``face`` (``ModuleFaces`` member or its name),
the parent's face the child is attached to.

The graph is validated first; every problem is a one-line ``ValueError`` (a non-DiGraph is a
``TypeError``). The body is then attached top-down, breadth-first from the core, visiting the
children of a module in ascending face value (FRONT, BACK, RIGHT, LEFT, TOP, BOTTOM) and then
ascending node id. So actuators come out in that breadth-first order of their hinges, and
element names never compound: every name is ``f"{parent}-{child}-{face_value}-"`` + the
module's own name (e.g. "0-12-3-hinge" for node 12 on the core's LEFT face), or the core's.
"""

from __future__ import annotations

import numbers
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, TypeVar

import networkx as nx

from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    ALLOWED_ROTATIONS,
    IDX_OF_CORE,
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleRotationsTheta,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.graph_io import load_graph_from_json, save_graph_as_json
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule
from ariel.body_phenotypes.robogen_lite.modules.module import Module

__all__ = [
    "RobotTree",
    "attachment_prefix",
    "construct_mjspec_from_graph",
    "load_graph_from_json",
    "parse_face",
    "parse_module_type",
    "parse_rotation",
    "save_graph_as_json",
    "validate_robot_graph",
]

_E = TypeVar("_E", bound=Enum)

# The members each parser names in its error (built once: the parsers run per node and edge).
_REAL_TYPES = tuple(t for t in ModuleType if t is not ModuleType.NONE)
_ROTATIONS = tuple(ModuleRotationsIdx)
_FACES = tuple(ModuleFaces)


def _parse_enum(value: object, enum: type[_E], what: str, allowed: Sequence[_E], where: str) -> _E:
    if isinstance(value, enum):
        return value
    if isinstance(value, str):
        member = enum.__members__.get(value.strip().upper())
        if member is not None:
            return member
    names = ", ".join(member.name for member in allowed)
    # Worded as upstream's constructor ("Unknown module type ..."), which scripts match on.
    raise ValueError(f"Unknown {what} {value!r} ({where}); allowed: {names}")


def parse_module_type(value: object, where: str = "value") -> ModuleType:
    """A ``ModuleType`` from a member or its name ("HINGE", case-insensitive).

    Args:
        value: A ``ModuleType`` member (returned as is) or its name; surrounding whitespace
            and case are ignored.
        where: Where the value came from (e.g. "node 3"), quoted in the error message.

    Returns:
        The ``ModuleType`` member.

    Raises:
        ValueError: If ``value`` is neither a ``ModuleType`` nor the name of one.
    """
    return _parse_enum(value, ModuleType, "module type", _REAL_TYPES, where)


def parse_rotation(value: object, where: str = "value") -> ModuleRotationsIdx:
    """A ``ModuleRotationsIdx`` from a rotation member (Idx or Theta) or its name ("DEG_45").

    Args:
        value: A ``ModuleRotationsIdx`` member (returned as is), a ``ModuleRotationsTheta``
            member (mapped by name) or a member's name (case-insensitive).
        where: Where the value came from (e.g. "node 3"), quoted in the error message.

    Returns:
        The ``ModuleRotationsIdx`` member.

    Raises:
        ValueError: If ``value`` is not a rotation member nor the name of one.
    """
    if isinstance(value, ModuleRotationsTheta):
        return ModuleRotationsIdx[value.name]
    return _parse_enum(value, ModuleRotationsIdx, "rotation", _ROTATIONS, where)


def parse_face(value: object, where: str = "value") -> ModuleFaces:
    """A ``ModuleFaces`` from a member or its name ("LEFT", case-insensitive).

    Args:
        value: A ``ModuleFaces`` member (returned as is) or its name; surrounding whitespace
            and case are ignored.
        where: Where the value came from (e.g. "edge 0 -> 1"), quoted in the error message.

    Returns:
        The ``ModuleFaces`` member.

    Raises:
        ValueError: If ``value`` is neither a ``ModuleFaces`` nor the name of one.
    """
    return _parse_enum(value, ModuleFaces, "face", _FACES, where)


def attachment_prefix(parent: int, child: int, face: ModuleFaces) -> str:
    """Name prefix of a child module's elements: ``"{parent}-{child}-{face.value}-"``.

    Args:
        parent: Node id (module index) of the parent module.
        child: Node id (module index) of the attached child module.
        face: The parent's face the child is attached to.

    Returns:
        The prefix, e.g. ``"0-12-3-"`` for node 12 on the core's LEFT face.
    """
    return f"{parent}-{child}-{face.value}-"


@dataclass(frozen=True)
class RobotTree:
    """A validated robot graph with parsed attributes.

    Made by `validate_robot_graph`; `construct_mjspec_from_graph` accepts it in place of the
    graph.

    Attributes:
        types: Module type of every node id.
        rotations: Rotation of every node id.
        parent: ``(parent id, parent's face)`` of every node id except the core's.
        children: ``(face, child id)`` pairs of every node id (empty for leaves), in ascending
            face value, then node id.
        order: Every node id in the breadth-first attachment order from the core (the core
            first).
    """

    types: dict[int, ModuleType]
    rotations: dict[int, ModuleRotationsIdx]
    parent: dict[int, tuple[int, ModuleFaces]]
    children: dict[int, list[tuple[ModuleFaces, int]]]
    order: list[int]


def _is_tree_from_core(graph: nx.DiGraph) -> bool:
    """Whether ``graph`` is a tree rooted at the core: a quick test, no error messages.

    The core has no parent, every other node at most one, and all are reachable from the core.
    Then there is no cycle either: a cycle's nodes have their one parent on the cycle, so no
    path from the core (not on it, as it has no parent) could enter it.
    """
    pred = graph.pred
    if pred[IDX_OF_CORE] or any(len(parents) > 1 for parents in pred.values()):
        return False
    succ = graph.succ
    seen = {IDX_OF_CORE}
    stack = [IDX_OF_CORE]
    while stack:
        for child in succ[stack.pop()]:
            if child not in seen:
                seen.add(child)
                stack.append(child)
    return len(seen) == len(pred)


def _check_structure(graph: Any) -> None:
    if not isinstance(graph, nx.DiGraph) or graph.is_multigraph():
        raise TypeError(
            f"robot graph must be a networkx DiGraph (a tree rooted at node 0), "
            f"got {type(graph).__name__}"
        )
    for node in graph.nodes:
        if isinstance(node, bool) or not isinstance(node, numbers.Integral):
            raise ValueError(f"robot graph node ids must be ints (module indices), got {node!r}")
    if IDX_OF_CORE not in graph:
        raise ValueError(
            f"robot graph has no node {IDX_OF_CORE}: it must be a tree rooted at node "
            f"{IDX_OF_CORE} (the core)"
        )
    if _is_tree_from_core(graph):
        return  # the checks below would all pass; they run to name what is wrong
    try:
        cycle = nx.find_cycle(graph)
    except nx.NetworkXNoCycle:
        cycle = None
    if cycle:
        path = " -> ".join(str(edge[0]) for edge in cycle) + f" -> {cycle[-1][1]}"
        raise ValueError(f"robot graph has a cycle ({path}); it must be a tree rooted at node 0")
    for node in graph.nodes:
        parents = sorted(graph.predecessors(node))
        if len(parents) > 1:
            raise ValueError(
                f"node {node} has {len(parents)} parents {tuple(parents)}; "
                "every module attaches to exactly one parent"
            )
    core_parents = list(graph.predecessors(IDX_OF_CORE))
    if core_parents:
        raise ValueError(
            f"robot graph is not rooted at node {IDX_OF_CORE}: "
            f"the core has parent {core_parents[0]}"
        )
    unreachable = sorted(set(graph.nodes) - nx.descendants(graph, IDX_OF_CORE) - {IDX_OF_CORE})
    if unreachable:
        raise ValueError(
            f"robot graph is not a tree rooted at node {IDX_OF_CORE}: nodes {unreachable} are not "
            f"connected to it"
        )


def validate_robot_graph(graph: nx.DiGraph) -> RobotTree:
    """Check that ``graph`` is a buildable robot tree and parse its attributes.

    Args:
        graph: The robot graph, in the format described in the module docstring.

    Returns:
        The parsed tree, with the breadth-first attachment order.

    Raises:
        TypeError: If ``graph`` is not a ``networkx.DiGraph`` (or is a multigraph).
        ValueError: A one-line message for: a node id that is not an int, no node 0, a
            cycle, a node with two parents, a core that is not the root, nodes not connected
            to the core, a missing attribute, an unknown type/rotation/face, a NONE module, a
            CORE anywhere but node 0 (or node 0 not a CORE), a face not allowed on the
            parent's type, a rotation not allowed on the module's type, and two children on
            one face of a parent.
    """
    _check_structure(graph)
    types, rotations = _parse_nodes(graph)
    parent, children = _parse_edges(graph, types)
    order = _attachment_order(children)  # sorts each node's children, too
    return RobotTree(
        types=types, rotations=rotations, parent=parent, children=children, order=order
    )


def _parse_nodes(
    graph: nx.DiGraph,
) -> tuple[dict[int, ModuleType], dict[int, ModuleRotationsIdx]]:
    """Each node's module type and rotation, checked (`validate_robot_graph`'s node errors)."""
    types: dict[int, ModuleType] = {}
    rotations: dict[int, ModuleRotationsIdx] = {}
    for node, attrs in graph.nodes(data=True):
        where = f"node {node}"
        for key in ("type", "rotation"):
            if key not in attrs:
                raise ValueError(f"{where} has no {key!r} attribute")
        module_type = parse_module_type(attrs["type"], where)
        if module_type is ModuleType.NONE:
            raise ValueError(
                f"{where} has type NONE (an empty slot); robot graphs hold only real modules"
            )
        if node == IDX_OF_CORE and module_type is not ModuleType.CORE:
            raise ValueError(
                f"node {IDX_OF_CORE} must be the CORE, but its type is {module_type.name}"
            )
        if node != IDX_OF_CORE and module_type is ModuleType.CORE:
            raise ValueError(f"{where} has type CORE; only node {IDX_OF_CORE} may be the core")
        rotation = parse_rotation(attrs["rotation"], where)
        if rotation not in ALLOWED_ROTATIONS[module_type]:
            allowed = ", ".join(r.name for r in ALLOWED_ROTATIONS[module_type])
            raise ValueError(
                f"rotation {rotation.name} is not allowed on a {module_type.name} ({where}); "
                f"allowed: {allowed}"
            )
        types[int(node)] = module_type
        rotations[int(node)] = rotation
    return types, rotations


def _parse_edges(
    graph: nx.DiGraph, types: dict[int, ModuleType]
) -> tuple[dict[int, tuple[int, ModuleFaces]], dict[int, list[tuple[ModuleFaces, int]]]]:
    """Each node's parent and each node's children, by face (`validate_robot_graph`'s edge
    errors); ``types``: the nodes' module types (`_parse_nodes`)."""
    parent: dict[int, tuple[int, ModuleFaces]] = {}
    children: dict[int, list[tuple[ModuleFaces, int]]] = {node: [] for node in types}
    for u, v, attrs in graph.edges(data=True):
        where = f"edge {u} -> {v}"
        if "face" not in attrs:
            raise ValueError(f"{where} has no 'face' attribute")
        face = parse_face(attrs["face"], where)
        parent_type = types[int(u)]
        if face not in ALLOWED_FACES[parent_type]:
            allowed = ", ".join(f.name for f in ALLOWED_FACES[parent_type])
            raise ValueError(
                f"face {face.name} is not allowed on a {parent_type.name} ({where}); "
                f"allowed: {allowed}"
            )
        for other_face, other in children[int(u)]:
            if other_face is face:
                raise ValueError(
                    f"node {u} has two children on face {face.name} (nodes {other} and {v})"
                )
        children[int(u)].append((face, int(v)))
        parent[int(v)] = (int(u), face)
    return parent, children


def _attachment_order(children: dict[int, list[tuple[ModuleFaces, int]]]) -> list[int]:
    """The breadth-first attachment order from the core; sorts each node's ``children`` (in
    place) by face, then node."""
    for kids in children.values():
        kids.sort(key=lambda item: (item[0].value, item[1]))
    order: list[int] = []
    queue = deque([IDX_OF_CORE])
    while queue:
        node = queue.popleft()
        order.append(node)
        queue.extend(child for _face, child in children[node])
    return order


def construct_mjspec_from_graph(graph: nx.DiGraph | RobotTree) -> CoreModule:
    """Build the body described by ``graph``; return its ``CoreModule`` (``.spec`` is the MjSpec).

    See the module docstring for the graph format, the validation and the attachment order.

    Args:
        graph: The robot graph, or a `RobotTree` from `validate_robot_graph` (validated
            once, used twice).

    Returns:
        The core module, with every other module attached; its ``.spec`` is the body's
        ``mujoco.MjSpec``.

    Raises:
        TypeError: If ``graph`` is neither a ``RobotTree`` nor a ``networkx.DiGraph``.
        ValueError: If the graph is not a valid robot tree (see `validate_robot_graph`).

    Example:
        ```python
        import networkx as nx

        from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph

        graph = nx.DiGraph()
        graph.add_node(0, type="CORE", rotation="DEG_0")
        graph.add_node(1, type="HINGE", rotation="DEG_90")
        graph.add_node(2, type="BRICK", rotation="DEG_0")
        graph.add_edge(0, 1, face="FRONT")
        graph.add_edge(1, 2, face="FRONT")
        core = construct_mjspec_from_graph(graph)
        model = core.spec.compile()
        print(model.nu)  # 1 actuator: the hinge
        ```
    """
    tree = graph if isinstance(graph, RobotTree) else validate_robot_graph(graph)
    core = CoreModule(index=IDX_OF_CORE)
    modules: dict[int, Module] = {IDX_OF_CORE: core}
    for node in tree.order[1:]:
        parent, face = tree.parent[node]
        module: Module
        if tree.types[node] is ModuleType.HINGE:
            module = HingeModule(index=node)
        else:
            module = BrickModule(index=node)
        module.rotate(ModuleRotationsTheta[tree.rotations[node].name].value)
        # The parent is already in the core's tree (breadth-first), so names never compound.
        modules[parent].sites[face].attach_body(
            body=module.body, prefix=attachment_prefix(parent, node, face)
        )
        modules[node] = module
    return core
