"""Morphology descriptors of a robot graph: plain numbers for tables and analysis.

Works on the graph alone (no MuJoCo compile), so it is cheap enough for every evaluation row.
"""

from __future__ import annotations

import functools
import math

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    DESCRIPTOR_NAMES,
    IDX_OF_CORE,
    ModuleFaces,
    ModuleRotationsTheta,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.constructor import RobotTree, validate_robot_graph
from ariel.body_phenotypes.robogen_lite.modules.brick import (
    BRICK_GEOM_POS,
    BRICK_HALF_EXTENTS,
    BRICK_SITES,
)
from ariel.body_phenotypes.robogen_lite.modules.core import (
    CORE_GEOM_POS,
    CORE_HALF_EXTENTS,
    CORE_SITES,
)
from ariel.body_phenotypes.robogen_lite.modules.hinge import (
    HINGE_SITES,
    ROTOR_BODY_POS,
    ROTOR_HALF_EXTENTS,
    STATOR_BODY_POS,
    STATOR_HALF_EXTENTS,
)

__all__ = ["DESCRIPTOR_NAMES", "morphology_descriptors"]


# A mirror image (in a vertical plane) swaps a module's LEFT and RIGHT faces; the others stay.
_MIRROR_FACE = {
    ModuleFaces.LEFT: ModuleFaces.RIGHT,
    ModuleFaces.RIGHT: ModuleFaces.LEFT,
}

# Per module type: boxes (centre in the module's root frame, half-extents) and site frames
# (position, quaternion w-x-y-z) in the root frame, with all joints at zero.
_BOXES: dict[ModuleType, list[tuple[tuple[float, ...], tuple[float, ...]]]] = {
    ModuleType.CORE: [(CORE_GEOM_POS, CORE_HALF_EXTENTS)],
    ModuleType.BRICK: [(BRICK_GEOM_POS, BRICK_HALF_EXTENTS)],
    ModuleType.HINGE: [
        (STATOR_BODY_POS, STATOR_HALF_EXTENTS),
        (ROTOR_BODY_POS, ROTOR_HALF_EXTENTS),
    ],
}
_SITES: dict[ModuleType, dict[ModuleFaces, tuple[tuple[float, ...], tuple[float, ...]]]] = {
    ModuleType.CORE: {face: (pos, quat) for face, (_n, pos, quat) in CORE_SITES.items()},
    ModuleType.BRICK: {face: (pos, quat) for face, (_n, pos, quat) in BRICK_SITES.items()},
    # The hinge's site sits on the rotor body.
    ModuleType.HINGE: {
        face: (tuple(np.add(ROTOR_BODY_POS, pos)), quat)
        for face, (_n, pos, quat) in HINGE_SITES.items()
    },
}
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


def _quat_to_matrix(quat: tuple[float, ...] | list[float]) -> np.ndarray:
    w, x, y, z = np.asarray(quat, float) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@functools.cache
def _growth_rotation(degrees: float) -> np.ndarray:
    half = math.radians(degrees) / 2.0
    return _quat_to_matrix((math.cos(half), 0.0, math.sin(half), 0.0))


# The per-type constants of `_extent`, as arrays made once (the same numbers it computed per
# module before, so the extents stay bit-identical): site (position, rotation) per face, and
# the box corners in the module's root frame.
_SITE_FRAMES: dict[ModuleType, dict[ModuleFaces, tuple[np.ndarray, np.ndarray]]] = {
    kind: {face: (np.asarray(pos), _quat_to_matrix(quat)) for face, (pos, quat) in sites.items()}
    for kind, sites in _SITES.items()
}
_BOX_CORNERS: dict[ModuleType, list[np.ndarray]] = {
    kind: [np.asarray(centre) + _CORNERS * np.asarray(half) for centre, half in boxes]
    for kind, boxes in _BOXES.items()
}


def _extent(tree: RobotTree) -> tuple[float, float, float]:
    """Axis-aligned size of the body at rest (joints at zero), in the core's frame."""
    frames: dict[int, tuple[np.ndarray, np.ndarray]] = {IDX_OF_CORE: (np.eye(3), np.zeros(3))}
    points = []
    for node in tree.order:
        if node != IDX_OF_CORE:
            parent, face = tree.parent[node]
            rot_p, pos_p = frames[parent]
            site_pos, site_rot = _SITE_FRAMES[tree.types[parent]][face]
            theta = ModuleRotationsTheta[tree.rotations[node].name].value
            rot = rot_p @ site_rot @ _growth_rotation(theta)
            frames[node] = (rot, pos_p + rot_p @ site_pos)
        rot, pos = frames[node]
        for local in _BOX_CORNERS[tree.types[node]]:
            points.append(pos + local @ rot.T)
    cloud = np.concatenate(points)
    size = cloud.max(axis=0) - cloud.min(axis=0)
    return float(size[0]), float(size[1]), float(size[2])


def _subtree_size(tree: RobotTree, node: int) -> int:
    return 1 + sum(_subtree_size(tree, child) for _face, child in tree.children[node])


def _overlap(tree: RobotTree, a: int, b: int) -> int:
    """Modules of subtree ``a`` matched by the mirror image of subtree ``b``, top-down."""
    if tree.types[a] is not tree.types[b] or tree.rotations[a] is not tree.rotations[b]:
        return 0
    b_children = dict(tree.children[b])
    total = 1
    for face, child in tree.children[a]:
        mirrored = b_children.get(_MIRROR_FACE.get(face, face))
        if mirrored is not None:
            total += _overlap(tree, child, mirrored)
    return total


def _pair_symmetry(tree: RobotTree, face_a: ModuleFaces, face_b: ModuleFaces) -> float:
    on_core = dict(tree.children[IDX_OF_CORE])
    a, b = on_core.get(face_a), on_core.get(face_b)
    if a is None and b is None:
        return 1.0
    if a is None or b is None:
        return 0.0
    return _overlap(tree, a, b) / max(_subtree_size(tree, a), _subtree_size(tree, b))


def morphology_descriptors(graph: nx.DiGraph | RobotTree) -> dict[str, float | int]:
    """Describe the body of a robot graph with plain numbers.

    The descriptors, in ``DESCRIPTOR_NAMES`` order:

    - ``num_modules``: modules, core included.
    - ``num_hinges``, ``num_bricks``: modules of each type.
    - ``num_limbs``: leaf modules (no children), the core excluded; 0 for a lone core.
    - ``num_core_children``: how many of the core's faces carry a module.
    - ``depth``: edges on the longest path from the core to a leaf (0 for a lone core).
    - ``branching``: mean number of children over modules that have any (0.0 for a lone core).
    - ``joints_ratio``: ``num_hinges / num_modules``.
    - ``symmetry`` in [0, 1]: mean of two mirror scores, LEFT vs RIGHT and FRONT vs BACK
      subtrees of the core. A pair's score is the number of modules matched top-down between
      one subtree and the mirror image of the other (same type and rotation; the mirror swaps
      LEFT/RIGHT faces; a mismatch stops the match below it), divided by the larger subtree's
      size; two empty faces score 1, one empty face 0. Rotations are compared as given,
      since a graph cannot express the mirrored (negative) angle.
    - ``extent_x``, ``extent_y``, ``extent_z``: size in metres of the axis-aligned box around
      all module geoms at rest (joints at zero), in the core's frame (+y: the core's FRONT,
      +z: up).

    Args:
        graph: The robot graph (validated like ``construct_mjspec_from_graph``), or a
            `RobotTree` from `validate_robot_graph` (used as it is).

    Returns:
        The descriptors above as plain Python ints and floats, keys in ``DESCRIPTOR_NAMES``
        order.

    Raises:
        TypeError: If ``graph`` is neither a ``RobotTree`` nor a ``networkx.DiGraph``.
        ValueError: If the graph is not a valid robot tree (see `validate_robot_graph`).
    """
    tree = graph if isinstance(graph, RobotTree) else validate_robot_graph(graph)
    types = list(tree.types.values())
    num_modules = len(types)
    num_hinges = sum(t is ModuleType.HINGE for t in types)
    num_bricks = sum(t is ModuleType.BRICK for t in types)
    parents = [node for node, kids in tree.children.items() if kids]
    num_limbs = sum(1 for node, kids in tree.children.items() if not kids and node != IDX_OF_CORE)
    depth_of = {IDX_OF_CORE: 0}
    for node in tree.order[1:]:
        depth_of[node] = depth_of[tree.parent[node][0]] + 1
    branching = sum(len(tree.children[node]) for node in parents) / len(parents) if parents else 0.0
    symmetry = (
        _pair_symmetry(tree, ModuleFaces.LEFT, ModuleFaces.RIGHT)
        + _pair_symmetry(tree, ModuleFaces.FRONT, ModuleFaces.BACK)
    ) / 2.0
    extent_x, extent_y, extent_z = _extent(tree)
    return {
        "num_modules": int(num_modules),
        "num_hinges": int(num_hinges),
        "num_bricks": int(num_bricks),
        "num_limbs": int(num_limbs),
        "num_core_children": len(tree.children[IDX_OF_CORE]),
        "depth": int(max(depth_of.values())),
        "branching": float(branching),
        "joints_ratio": float(num_hinges / num_modules),
        "symmetry": float(symmetry),
        "extent_x": extent_x,
        "extent_y": extent_y,
        "extent_z": extent_z,
    }
