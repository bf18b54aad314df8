"""Checks of a tree genome's dict form (``TreeGenome.to_dict()``), as upstream's validation.

`validate_genome_dict` raises a one-line ``ValueError`` naming the first problem; a genome
that passes builds with ``construct_mjspec_from_graph``. Stricter than upstream (see
docs/decisions.md): a node with two parents, a CORE other than node 0, a NONE module, a
rotation its type does not allow and edges to missing children are refused too.
"""

from __future__ import annotations

from typing import Any

from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    ALLOWED_ROTATIONS,
    IDX_OF_CORE,
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleType,
)

__all__ = ["is_single_connected_tree", "validate_genome_dict"]


def _int_id(value: Any) -> int:
    return int(value) if isinstance(value, str) else value


def _nodes(genome: dict[str, Any]) -> dict[int, dict[str, Any]]:
    return {_int_id(k): v for k, v in (genome.get("nodes") or {}).items()}


def is_single_connected_tree(genome: dict[str, Any]) -> bool:
    """Whether every node is reached from the core, exactly once, through the edges.

    Args:
        genome: a genome dict (``TreeGenome.to_dict()`` form; node ids may be strings or ints).

    Returns:
        ``True`` for a single tree rooted at node 0 (or an empty genome, as upstream);
            ``False`` if the core is missing or has a parent, an edge names a missing node, a node
            has two parents, or a node is unreachable or reached twice.
    """
    nodes = _nodes(genome)
    if not nodes:
        return True  # upstream: an empty genome is trivially connected
    if IDX_OF_CORE not in nodes:
        return False
    children: dict[int, list[int]] = {n: [] for n in nodes}
    parents: dict[int, int] = {}
    for edge in genome.get("edges") or []:
        parent, child = _int_id(edge["parent"]), _int_id(edge["child"])
        if parent not in nodes or child not in nodes or child in parents:
            return False
        parents[child] = parent
        children[parent].append(child)
    if IDX_OF_CORE in parents:
        return False
    seen = {IDX_OF_CORE}
    stack = [IDX_OF_CORE]
    while stack:
        for child in children[stack.pop()]:
            if child in seen:
                return False
            seen.add(child)
            stack.append(child)
    return len(seen) == len(nodes)


def validate_genome_dict(genome: dict[str, Any]) -> None:
    """Raise ``ValueError`` unless ``genome`` (a ``to_dict()`` form) is a buildable robot tree.

    Args:
        genome: a genome dict (``TreeGenome.to_dict()`` form; node ids may be strings or ints).

    Raises:
        ValueError: a one-line message naming the first problem: not a dict, no core at node
            0, an unknown or second CORE type, a rotation or face the module type does not
            allow, an edge to a missing node, two children on one face, or not a single
            connected tree.
    """
    if not isinstance(genome, dict):
        raise ValueError(f"a tree genome dict is needed, got {type(genome).__name__}")
    nodes = _nodes(genome)
    if IDX_OF_CORE not in nodes:
        raise ValueError(f"Genome must contain core node with index {IDX_OF_CORE}")
    types = [t.name for t in ModuleType if t is not ModuleType.NONE]
    for nid, attrs in nodes.items():
        kind, rotation = attrs.get("type"), attrs.get("rotation")
        if kind not in types:
            raise ValueError(f"Node {nid} has invalid type {kind!r}; allowed: {', '.join(types)}")
        if (kind == "CORE") != (nid == IDX_OF_CORE):
            raise ValueError(f"Node {nid} has type {kind}; node {IDX_OF_CORE} alone is the CORE")
        allowed = [r.name for r in ALLOWED_ROTATIONS[ModuleType[kind]]]
        if rotation not in allowed:
            if rotation not in ModuleRotationsIdx.__members__:
                raise ValueError(f"Node {nid} has invalid rotation {rotation!r}")
            raise ValueError(
                f"Node {nid} ({kind}) has rotation {rotation}; allowed: {', '.join(allowed)}"
            )
    occupied: set[tuple[int, str]] = set()
    for edge in genome.get("edges") or []:
        parent, child, face = _int_id(edge["parent"]), _int_id(edge["child"]), edge["face"]
        if face not in ModuleFaces.__members__:
            raise ValueError(f"Edge parent={parent} child={child} has invalid face {face!r}")
        for end, what in ((parent, "parent"), (child, "child")):
            if end not in nodes:
                raise ValueError(f"Edge has missing {what} node {end}")
        ptype = nodes[parent]["type"]
        allowed_faces = [f.name for f in ALLOWED_FACES[ModuleType[ptype]]]
        if face not in allowed_faces:
            raise ValueError(
                f"Face {face!r} not allowed for parent type {ptype!r}; "
                f"allowed: {', '.join(allowed_faces)}"
            )
        if (parent, face) in occupied:
            raise ValueError(f"Parent {parent} already has child at face {face!r}")
        occupied.add((parent, face))
    if not is_single_connected_tree(genome):
        raise ValueError("Genome does not form a single connected tree with core as root")
