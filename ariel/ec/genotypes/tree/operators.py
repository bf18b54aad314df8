"""Genetic operators on `TreeGenome` (upstream's names and signatures; GP-style, Koza 1992).

Mutations edit the genome IN PLACE and return None, as upstream's; `crossover_subtree` returns
two new children and leaves its parents alone. Every operator takes a keyword ``rng``: a
``numpy.random.Generator`` or an int seed. Without one it draws a seed from Python's global
``random`` module, which upstream's operators use, so ``random.seed(...)`` in an upstream-style
script still makes a run repeatable. Every result is a valid tree (`validate_genome_dict`
passes): upstream's crossover and subtree mutation could disconnect a subtree; these graft it
where the old one was (docs/decisions.md).
"""

from __future__ import annotations

import random
import warnings
from typing import Any

import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    ALLOWED_ROTATIONS,
    IDX_OF_CORE,
    ModuleType,
)
from ariel.ec.genotypes.tree.tree_genome import TreeGenome

__all__ = [
    "add_node",
    "crossover_one_point",
    "crossover_subtree",
    "free_faces",
    "get_top_ancestor",
    "get_tree_depth",
    "mutate_add_node",
    "mutate_hoist",
    "mutate_replace_node",
    "mutate_rotation",
    "mutate_shrink",
    "mutate_subtree_replacement",
    "random_tree",
    "remove_subtree",
    "subtree_swap",
    "validate_tree_depth",
]

RngLike = np.random.Generator | int | None

#: Module types a genome may add (never a second core, never an empty slot).
_BODY_TYPES = ("BRICK", "HINGE")


def _rng(rng: RngLike) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        # Upstream draws from Python's `random`; seeding it keeps upstream scripts repeatable.
        return np.random.default_rng(random.getrandbits(64))
    return np.random.default_rng(rng)


def _pick(rng: np.random.Generator, items: list[Any]) -> Any:
    return items[int(rng.integers(len(items)))]


def _children(genome: TreeGenome, node: int) -> list[dict[str, Any]]:
    return [e for e in genome.edges if e["parent"] == node]


def _parent_edge(genome: TreeGenome, node: int) -> dict[str, Any] | None:
    return next((e for e in genome.edges if e["child"] == node), None)


def _subtree(genome: TreeGenome, root: int) -> list[int]:
    """``root`` and its descendants, breadth-first."""
    found, i = [root], 0
    while i < len(found):
        found.extend(e["child"] for e in _children(genome, found[i]))
        i += 1
    return found


def _random_module(rng: np.random.Generator) -> dict[str, str]:
    kind = _pick(rng, list(_BODY_TYPES))
    rotations = [r.name for r in ALLOWED_ROTATIONS[ModuleType[kind]]]
    return {"type": kind, "rotation": _pick(rng, rotations)}


def _next_id(genome: TreeGenome) -> int:
    return max(genome.nodes, default=IDX_OF_CORE) + 1


def free_faces(genome: TreeGenome, nodes: list[int] | None = None) -> list[tuple[int, str]]:
    """``(node, face)`` pairs where a child could attach, in node-id then face order.

    Args:
        genome: the genome to inspect.
        nodes: the node ids to look at, in this order; ``None`` means every node, by id.

    Returns:
        ``(node id, face name)`` for each face the node's type allows that has no child yet.
    """
    result = []
    for node in sorted(genome.nodes) if nodes is None else nodes:
        used = {e["face"] for e in _children(genome, node)}
        kind = ModuleType[genome.nodes[node]["type"]]
        result.extend((node, f.name) for f in ALLOWED_FACES[kind] if f.name not in used)
    return result


def add_node(
    genome: TreeGenome, parent: int, face: str, node_id: int, mtype: str, rotation: str
) -> None:
    """Add module ``node_id`` on ``parent``'s ``face`` (the caller checks the face is free).

    Nothing is validated: an existing node ``node_id`` is overwritten.

    Args:
        genome: the genome to edit in place.
        parent: the id of the module to attach to.
        face: the `ModuleFaces` name of ``parent``'s face, e.g. ``"FRONT"``.
        node_id: the new module's id (`TreeGenome`'s ids are ints; the core is 0).
        mtype: the new module's `ModuleType` name, e.g. ``"HINGE"``.
        rotation: the new module's `ModuleRotationsIdx` name, e.g. ``"DEG_90"``.
    """
    genome.nodes[node_id] = {"type": mtype, "rotation": rotation}
    genome.edges.append({"parent": parent, "child": node_id, "face": face})


def remove_subtree(genome: TreeGenome, node_id: int) -> None:
    """Remove ``node_id``, its descendants and every edge touching them (no-op if absent).

    Args:
        genome: the genome to edit in place.
        node_id: the root of the subtree to remove.
    """
    if node_id not in genome.nodes:
        return
    gone = set(_subtree(genome, node_id))
    for node in gone:
        genome.nodes.pop(node, None)
    genome.edges = [e for e in genome.edges if e["child"] not in gone and e["parent"] not in gone]


def get_top_ancestor(genome: TreeGenome, node_id: int) -> int:
    """The ancestor of ``node_id`` that hangs directly on the core (``node_id`` if it does).

    Args:
        genome: the genome to inspect.
        node_id: the module whose ancestor is wanted.

    Returns:
        The id of that ancestor; ``node_id`` itself if it has no parent edge (the core).
    """
    current = node_id
    while (edge := _parent_edge(genome, current)) is not None and edge["parent"] != IDX_OF_CORE:
        current = edge["parent"]
    return current


def _grow(genome: TreeGenome, parent: int, face: str, size: int, rng: np.random.Generator) -> None:
    """Attach a random subtree of ``size`` modules at ``parent``'s free ``face``."""
    first = _next_id(genome)
    add_node(genome, parent, face, first, **_module_args(_random_module(rng)))
    grown = [first]
    for _ in range(size - 1):
        spots = free_faces(genome, grown)
        if not spots:
            break
        where, where_face = _pick(rng, spots)
        node = _next_id(genome)
        add_node(genome, where, where_face, node, **_module_args(_random_module(rng)))
        grown.append(node)


def _module_args(module: dict[str, str]) -> dict[str, str]:
    return {"mtype": module["type"], "rotation": module["rotation"]}


def random_tree(max_modules: int, *, rng: RngLike = None) -> TreeGenome:
    """A random valid tree of ``max_modules`` modules, the core included.

    From the core alone, each step adds a random module (BRICK or HINGE, a rotation its type
    allows) on a random free face. (Upstream's loop adds ``max_modules`` modules besides the
    core, one more than its docstring promises; docs/decisions.md.)

    Args:
        max_modules: the number of modules, core included (>= 1); fewer only if no free face
            is left.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).

    Returns:
        A new `TreeGenome`.

    Raises:
        ValueError: ``max_modules`` < 1 (or a bool).

    Example:
        ```python
        from ariel.ec.genotypes.tree.operators import mutate_add_node, random_tree

        genome = random_tree(8, rng=42)
        mutate_add_node(genome, rng=1)  # operators edit the genome in place
        print(len(genome))  # 9
        ```
    """
    if isinstance(max_modules, bool) or int(max_modules) < 1:
        raise ValueError(f"max_modules must be an int >= 1 (the core counts), not {max_modules!r}")
    gen = _rng(rng)
    genome = TreeGenome()
    while len(genome.nodes) < int(max_modules):
        spots = free_faces(genome)
        if not spots:
            break
        parent, face = _pick(gen, spots)
        add_node(genome, parent, face, _next_id(genome), **_module_args(_random_module(gen)))
    return genome


def get_tree_depth(genome: TreeGenome) -> int:
    """Edges on the longest path from the core to a leaf (0 for a lone core or no nodes).

    Args:
        genome: the genome to measure.

    Returns:
        The depth, counted in edges.
    """
    if IDX_OF_CORE not in genome.nodes:
        return 0
    depth = {IDX_OF_CORE: 0}
    for node in _subtree(genome, IDX_OF_CORE)[1:]:
        edge = _parent_edge(genome, node)
        depth[node] = depth[edge["parent"]] + 1 if edge else 0
    return max(depth.values())


def validate_tree_depth(genome: TreeGenome, max_depth: int) -> bool:
    """Whether the tree's depth is at most ``max_depth``.

    Args:
        genome: the genome to check.
        max_depth: the largest allowed depth, in edges from the core (see `get_tree_depth`).

    Returns:
        ``True`` if ``get_tree_depth(genome) <= max_depth``.
    """
    return get_tree_depth(genome) <= max_depth


def _prune_invalid_edges(genome: TreeGenome) -> None:
    """Drop edges to missing nodes, on faces the parent's type lacks, or on a taken face (with
    the subtree below them), then any node no longer reached from the core."""
    seen: set[tuple[int, str]] = set()
    valid, dropped = [], []
    for edge in genome.edges:
        parent, child = edge["parent"], edge["child"]
        if parent not in genome.nodes or child not in genome.nodes:
            continue
        allowed = [f.name for f in ALLOWED_FACES[ModuleType[genome.nodes[parent]["type"]]]]
        if edge["face"] not in allowed or (parent, edge["face"]) in seen:
            dropped.append(child)
            continue
        seen.add((parent, edge["face"]))
        valid.append(edge)
    genome.edges = valid
    for child in dropped:
        remove_subtree(genome, child)
    reached = set(_subtree(genome, IDX_OF_CORE)) if IDX_OF_CORE in genome.nodes else set()
    for node in [n for n in genome.nodes if n not in reached]:
        genome.nodes.pop(node)
    genome.edges = [e for e in genome.edges if e["parent"] in reached and e["child"] in reached]


def _detach(genome: TreeGenome, root: int) -> tuple[dict[int, dict], list[dict]]:
    """Remove the subtree at ``root``; return its nodes and internal edges (copies)."""
    keep = _subtree(genome, root)
    inside = set(keep)
    nodes = {n: dict(genome.nodes[n]) for n in keep}
    edges = [dict(e) for e in genome.edges if e["parent"] in inside and e["child"] in inside]
    remove_subtree(genome, root)
    return nodes, edges


def _graft(genome: TreeGenome, parent: int, face: str, root: int, part: tuple) -> None:
    """Insert a detached subtree (renumbered past the genome's ids) at ``parent``'s ``face``."""
    nodes, edges = part
    start = _next_id(genome)
    mapping = {old: start + i for i, old in enumerate(sorted(nodes))}
    for old, attrs in nodes.items():
        genome.nodes[mapping[old]] = attrs
    genome.edges.append({"parent": parent, "child": mapping[root], "face": face})
    genome.edges.extend(
        {**e, "parent": mapping[e["parent"]], "child": mapping[e["child"]]} for e in edges
    )


def subtree_swap(a: TreeGenome, b: TreeGenome, a_node: int, b_node: int) -> None:
    """Swap the subtrees at ``a_node`` (in ``a``) and ``b_node`` (in ``b``), in place.

    Each subtree takes the other's place (same parent, same face), renumbered to free ids.

    Args:
        a: the first genome, edited in place.
        b: the second genome, edited in place.
        a_node: the root of the subtree taken from ``a`` (not the core).
        b_node: the root of the subtree taken from ``b`` (not the core).

    Raises:
        ValueError: either node has no parent (the core, or a node not in its genome).
    """
    a_edge, b_edge = _parent_edge(a, a_node), _parent_edge(b, b_node)
    if a_edge is None or b_edge is None:
        raise ValueError("subtree_swap needs two non-core nodes (the core cannot be swapped)")
    a_part, b_part = _detach(a, a_node), _detach(b, b_node)
    _graft(a, a_edge["parent"], a_edge["face"], b_node, b_part)
    _graft(b, b_edge["parent"], b_edge["face"], a_node, a_part)


def _non_core(genome: TreeGenome) -> list[int]:
    return sorted(n for n in genome.nodes if n != IDX_OF_CORE)


def crossover_subtree(
    a: TreeGenome, b: TreeGenome, *, rng: RngLike = None
) -> tuple[TreeGenome, TreeGenome]:
    """GP subtree crossover: swap a random non-core subtree of each parent; two children.

    The parents are left unchanged; a parent with only its core gives plain copies.

    Args:
        a: the first parent.
        b: the second parent.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).

    Returns:
        ``(child1, child2)``: new genomes, ``a`` and ``b`` with their chosen subtrees swapped.
    """
    gen = _rng(rng)
    child1, child2 = a.copy(), b.copy()
    n1, n2 = _non_core(child1), _non_core(child2)
    if not n1 or not n2:
        return child1, child2
    subtree_swap(child1, child2, _pick(gen, n1), _pick(gen, n2))
    return child1, child2


def crossover_one_point(
    a: TreeGenome, b: TreeGenome, *, rng: RngLike = None
) -> tuple[TreeGenome, TreeGenome]:
    """Deprecated upstream: `crossover_subtree` under its old name (warns DeprecationWarning).

    Args:
        a: the first parent.
        b: the second parent.
        rng: as in `crossover_subtree`.

    Returns:
        The two children `crossover_subtree` returns.
    """
    warnings.warn(
        "crossover_one_point() is deprecated; use crossover_subtree()",
        DeprecationWarning,
        stacklevel=2,
    )
    return crossover_subtree(a, b, rng=rng)


def mutate_replace_node(genome: TreeGenome, *, rng: RngLike = None) -> None:
    """Point mutation: a random non-core module becomes the other type, with a random allowed
    rotation; children on faces the new type lacks are removed with their subtrees.

    A genome with only its core is left unchanged.

    Args:
        genome: the genome to edit in place.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).
    """
    gen = _rng(rng)
    candidates = _non_core(genome)
    if not candidates:
        return
    node = _pick(gen, candidates)
    new_type = _pick(gen, [t for t in _BODY_TYPES if t != genome.nodes[node]["type"]])
    rotations = [r.name for r in ALLOWED_ROTATIONS[ModuleType[new_type]]]
    genome.nodes[node] = {"type": new_type, "rotation": _pick(gen, rotations)}
    _prune_invalid_edges(genome)


def _cut_random_subtree(
    genome: TreeGenome, gen: np.random.Generator
) -> tuple[int, dict[str, Any] | None] | None:
    """Remove a random non-core subtree; its root and the edge it hung from (None: nothing
    but the core to cut)."""
    candidates = _non_core(genome)
    if not candidates:
        return None
    node = _pick(gen, candidates)
    edge = _parent_edge(genome, node)
    remove_subtree(genome, node)
    return node, edge


def mutate_subtree_replacement(
    genome: TreeGenome, max_modules: int = 10, *, rng: RngLike = None
) -> None:
    """Subtree mutation: a random non-core subtree is replaced by a new random subtree of
    1 to ``min(3, max_modules)`` modules, grown from the same face.

    A genome with only its core is left unchanged.

    Args:
        genome: the genome to edit in place.
        max_modules: caps the new subtree's size (not the body's); values below 1 count as 1.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).
    """
    gen = _rng(rng)
    cut = _cut_random_subtree(genome, gen)
    if cut is None:
        return
    _, edge = cut
    size = int(gen.integers(1, max(1, min(3, int(max_modules))) + 1))
    if edge is not None:
        _grow(genome, edge["parent"], edge["face"], size, gen)


def mutate_shrink(genome: TreeGenome, *, rng: RngLike = None) -> None:
    """Shrink mutation: a random non-core subtree is replaced by one new random leaf module.

    A genome with only its core is left unchanged.

    Args:
        genome: the genome to edit in place.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).
    """
    gen = _rng(rng)
    cut = _cut_random_subtree(genome, gen)
    if cut is None:
        return
    node, edge = cut
    if edge is not None:
        add_node(genome, edge["parent"], edge["face"], node, **_module_args(_random_module(gen)))


def mutate_hoist(genome: TreeGenome, *, rng: RngLike = None) -> None:
    """Hoist mutation: a random non-core module with children is replaced by one of its
    children (the module's other subtrees are dropped).

    A genome without such a module is left unchanged.

    Args:
        genome: the genome to edit in place.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).
    """
    gen = _rng(rng)
    candidates = sorted({e["parent"] for e in genome.edges} - {IDX_OF_CORE})
    if not candidates:
        return
    node = _pick(gen, candidates)
    edge = _parent_edge(genome, node)
    if edge is None:
        return
    kept = _pick(gen, sorted(e["child"] for e in _children(genome, node)))
    for other in [e["child"] for e in _children(genome, node) if e["child"] != kept]:
        remove_subtree(genome, other)
    genome.nodes.pop(node)
    genome.edges = [e for e in genome.edges if node not in (e["parent"], e["child"])]
    genome.edges.append({"parent": edge["parent"], "child": kept, "face": edge["face"]})


def mutate_add_node(genome: TreeGenome, *, rng: RngLike = None) -> None:
    """Grow mutation (ours): one random module on a random free face.

    A genome without a free face is left unchanged.

    Args:
        genome: the genome to edit in place.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).
    """
    gen = _rng(rng)
    spots = free_faces(genome)
    if spots:
        parent, face = _pick(gen, spots)
        add_node(genome, parent, face, _next_id(genome), **_module_args(_random_module(gen)))


def mutate_rotation(genome: TreeGenome, *, rng: RngLike = None) -> None:
    """Rotation mutation (upstream's examples inline it): a random non-core module takes
    another rotation its type allows.

    A genome with only its core is left unchanged.

    Args:
        genome: the genome to edit in place.
        rng: a ``numpy.random.Generator`` (used as is), an int seed, or ``None`` (a seed drawn
            from Python's ``random`` module).
    """
    gen = _rng(rng)
    candidates = _non_core(genome)
    if not candidates:
        return
    node = _pick(gen, candidates)
    attrs = genome.nodes[node]
    others = [
        r.name for r in ALLOWED_ROTATIONS[ModuleType[attrs["type"]]] if r.name != attrs["rotation"]
    ]
    if others:
        attrs["rotation"] = _pick(gen, others)
