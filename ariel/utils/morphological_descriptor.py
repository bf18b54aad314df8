"""`MorphologicalMeasures`: morphological measures of a robot graph (upstream's class).

After Miras, Haasdijk, Glette and Eiben (2018), *Search Space Analysis of Evolvable Robot
Morphologies* (EvoApplications, LNCS 10784), as revolve2 and upstream ARIEL implement them:
branching, limbs, length of limbs, coverage, joints, proportion and symmetry, on a module
lattice (each face one step in a fixed frame: FRONT/BACK along x, RIGHT/LEFT along y, TOP/BOTTOM
along z, as upstream's grid).

The graph is validated and its counts taken by the workbench's own
`validate_robot_graph` / `morphology_descriptors`, so the numbers both report agree
(``num_modules``, ``num_bricks``, ``num_active_hinges`` = ``num_hinges``,
``num_single_neighbour_modules`` = ``num_limbs``). Fixed from upstream (docs/decisions.md): the
core counts as filled with its four usable faces taken (upstream also expected TOP and BOTTOM,
which no decoder uses, so its core was never filled); symmetry compares each module with its
mirror cell through the core (upstream's loops could index past the grid's edge and wrap
around); ``S`` is the symmetry (one upstream version returned the size).
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    IDX_OF_CORE,
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.constructor import validate_robot_graph
from ariel.body_phenotypes.robogen_lite.descriptors import morphology_descriptors

__all__ = ["MorphologicalMeasures"]

_FACE_STEP = {
    ModuleFaces.FRONT: (1, 0, 0),
    ModuleFaces.BACK: (-1, 0, 0),
    ModuleFaces.RIGHT: (0, 1, 0),
    ModuleFaces.LEFT: (0, -1, 0),
    ModuleFaces.TOP: (0, 0, 1),
    ModuleFaces.BOTTOM: (0, 0, -1),
}
# Rotations that keep a body in the plane (upstream also lists 180 and 270, which no module has).
_PLANAR_ROTATIONS = {ModuleRotationsIdx.DEG_0, ModuleRotationsIdx.DEG_90}


class MorphologicalMeasures:
    """Measures of the body described by ``robot_graph`` (a tree rooted at the core, node 0).

    The graph is validated, and its lattice and counts are worked out, when the object is
    made; the measures are read as properties (``B``, ``L``, ``E``, ``C``, ``J``, ``S``, ``P``
    and the counts they are built from).

    Args:
        robot_graph: The robot graph (the format ``construct_mjspec_from_graph`` takes); kept
            as ``graph``.

    Raises:
        ValueError: If ``robot_graph`` is not a ``networkx.DiGraph``, has no nodes, or is not
            a valid robot tree (see `validate_robot_graph`).
        TypeError: If ``robot_graph`` is a multigraph.

    Example:
        ```python
        from ariel.body_phenotypes.robogen_lite.prebuilt_robots.spider import spider_graph
        from ariel.utils.morphological_descriptor import MorphologicalMeasures

        measures = MorphologicalMeasures(spider_graph())
        print(measures.num_modules, measures.B, measures.S)  # modules, branching, symmetry
        ```
    """

    def __init__(self, robot_graph: nx.DiGraph) -> None:
        if not isinstance(robot_graph, nx.DiGraph) or robot_graph.number_of_nodes() == 0:
            raise ValueError("Cannot analyze an empty robot graph (or one that is not a DiGraph)")
        self.graph = robot_graph
        self.tree = validate_robot_graph(robot_graph)
        self.descriptors = morphology_descriptors(self.tree)
        types, children = self.tree.types, self.tree.children
        self.core_node = IDX_OF_CORE
        self.modules: list[Any] = list(robot_graph.nodes)
        self.bricks = [n for n in self.modules if types[n] is ModuleType.BRICK]
        self.active_hinges = [n for n in self.modules if types[n] is ModuleType.HINGE]
        self.is_2d = all(r in _PLANAR_ROTATIONS for r in self.tree.rotations.values())

        def filled(node: int) -> bool:
            return len(children[node]) == len(ALLOWED_FACES[types[node]])

        self.core_is_filled = filled(IDX_OF_CORE)
        self.filled_bricks = [n for n in self.bricks if filled(n)]
        self.filled_active_hinges = [n for n in self.active_hinges if filled(n)]
        self.single_neighbour_bricks = [n for n in self.bricks if not children[n]]
        self.single_neighbour_modules = [
            n for n in self.modules if n != IDX_OF_CORE and not children[n]
        ]
        self.double_neighbour_bricks = [n for n in self.bricks if len(children[n]) == 1]
        self.double_neighbour_active_hinges = [
            n for n in self.active_hinges if len(children[n]) == 1
        ]

        # Lattice positions, breadth-first from the core; a cell two modules would share keeps
        # the first (the lattice is an abstraction of the body, as upstream's).
        self.positions: dict[int, tuple[int, int, int]] = {IDX_OF_CORE: (0, 0, 0)}
        for node in self.tree.order[1:]:
            parent, face = self.tree.parent[node]
            px, py, pz = self.positions[parent]
            dx, dy, dz = _FACE_STEP[face]
            self.positions[node] = (px + dx, py + dy, pz + dz)
        points = np.array(list(self.positions.values()))
        low = points.min(axis=0)
        shape = tuple(int(s) for s in points.max(axis=0) - low + 1)
        self.grid = np.full(shape, None, dtype=object)
        for node in self.tree.order[::-1]:  # earlier modules overwrite later ones
            self.grid[tuple(np.array(self.positions[node]) - low)] = node
        self.core_grid_position = -low
        self.xy_symmetry = self._plane_symmetry(2)
        self.xz_symmetry = self._plane_symmetry(1)
        self.yz_symmetry = self._plane_symmetry(0)

    def _plane_symmetry(self, axis: int) -> float:
        """Share of off-plane modules whose mirror cell (through the core, across ``axis``)
        holds a module of the same type."""
        cells = {}
        for node in self.tree.order:
            cells.setdefault(self.positions[node], self.tree.types[node])
        off_plane = [p for p in cells if p[axis] != 0]
        if not off_plane:
            return 0.0
        matched = 0
        for p in off_plane:
            mirror = tuple(-v if k == axis else v for k, v in enumerate(p))
            matched += cells.get(mirror) is cells[p]
        return matched / len(off_plane)

    # ---- sizes -----------------------------------------------------------------------------

    @property
    def bounding_box_depth(self) -> int:
        """Cells along the core's forward/backward axis."""
        return int(self.grid.shape[0])

    @property
    def bounding_box_width(self) -> int:
        """Cells along the core's right/left axis."""
        return int(self.grid.shape[1])

    @property
    def bounding_box_height(self) -> int:
        """Cells along the core's up/down axis."""
        return int(self.grid.shape[2])

    @property
    def bounding_box_volume(self) -> int:
        return self.bounding_box_width * self.bounding_box_height * self.bounding_box_depth

    @property
    def num_modules(self) -> int:
        return int(self.descriptors["num_modules"])

    @property
    def num_bricks(self) -> int:
        return int(self.descriptors["num_bricks"])

    @property
    def num_active_hinges(self) -> int:
        return int(self.descriptors["num_hinges"])

    @property
    def num_joints(self) -> int:
        return self.num_active_hinges

    @property
    def num_filled_bricks(self) -> int:
        return len(self.filled_bricks)

    @property
    def num_filled_active_hinges(self) -> int:
        return len(self.filled_active_hinges)

    @property
    def num_filled_modules(self) -> int:
        """Modules with every usable face taken, the core included."""
        return self.num_filled_bricks + self.num_filled_active_hinges + int(self.core_is_filled)

    @property
    def num_single_neighbour_modules(self) -> int:
        """Leaf modules (one neighbour, their parent); the core excluded."""
        return int(self.descriptors["num_limbs"])

    @property
    def num_double_neighbour_bricks(self) -> int:
        return len(self.double_neighbour_bricks)

    @property
    def num_double_neighbour_active_hinges(self) -> int:
        return len(self.double_neighbour_active_hinges)

    # ---- the paper's maxima and proportions ------------------------------------------------

    @property
    def max_potentionally_filled_core_and_bricks(self) -> int:
        """``b_max``: core and bricks that could be filled if the modules were rearranged."""
        return min(max(0, (self.num_modules - 2) // 3), 1 + self.num_bricks)

    @property
    def filled_core_and_bricks_proportion(self) -> float:
        if self.max_potentionally_filled_core_and_bricks == 0:
            return 0.0
        filled = self.num_filled_bricks + int(self.core_is_filled)
        return filled / self.max_potentionally_filled_core_and_bricks

    @property
    def max_potential_single_neighbour_modules(self) -> int:
        """``l_max``: leaves possible with this many modules."""
        return self.num_modules - 1 - max(0, (self.num_modules - 3) // 3)

    @property
    def potential_double_neighbour_bricks_and_active_hinges(self) -> int:
        """``e_max``: bricks and hinges that could have exactly two neighbours."""
        return max(0, self.num_bricks + self.num_active_hinges - 1)

    @property
    def double_neighbour_brick_and_active_hinge_proportion(self) -> float:
        if self.potential_double_neighbour_bricks_and_active_hinges == 0:
            return 0.0
        doubles = self.num_double_neighbour_bricks + self.num_double_neighbour_active_hinges
        return doubles / self.potential_double_neighbour_bricks_and_active_hinges

    @property
    def bounding_box_volume_coverage(self) -> float:
        return self.num_modules / self.bounding_box_volume

    @property
    def max_potential_joints(self) -> int:
        return max(0, self.num_modules - 1)

    # ---- the paper's measures --------------------------------------------------------------

    @property
    def branching(self) -> float:
        """B: filled core and bricks / ``b_max``."""
        return self.filled_core_and_bricks_proportion

    @property
    def limbs(self) -> float:
        """L: leaf modules / ``l_max``."""
        if self.max_potential_single_neighbour_modules == 0:
            return 0.0
        return self.num_single_neighbour_modules / self.max_potential_single_neighbour_modules

    @property
    def length_of_limbs(self) -> float:
        """E (extensiveness): modules with exactly two neighbours / ``e_max``."""
        return self.double_neighbour_brick_and_active_hinge_proportion

    @property
    def coverage(self) -> float:
        """C: modules / bounding-box cells."""
        return self.bounding_box_volume_coverage

    @property
    def size(self) -> float:
        """Modules / bounding-box cells (upstream's name for the same ratio as coverage)."""
        return self.bounding_box_volume_coverage

    @property
    def joints(self) -> float:
        """J: hinges / (modules - 1)."""
        if self.max_potential_joints == 0:
            return 0.0
        return self.num_joints / self.max_potential_joints

    @property
    def symmetry(self) -> float:
        """S: the best of the three mirror-plane symmetries through the core."""
        return max(self.xy_symmetry, self.xz_symmetry, self.yz_symmetry)

    @property
    def proportion_2d(self) -> float:
        """P: shorter / longer side of the footprint (planar bodies only)."""
        if not self.is_2d:
            raise ValueError("proportion is defined for planar bodies only (rotations 0 and 90)")
        return min(self.bounding_box_depth, self.bounding_box_width) / max(
            self.bounding_box_depth, self.bounding_box_width
        )

    @property
    def proportion(self) -> float:
        return self.proportion_2d

    @property
    def module_diversity(self) -> float:
        """Share of links between two non-core modules that join different types (ours:
        upstream's examples use this name, its class lacks it); 0.0 without such links."""
        links = [(u, v) for v, (u, _face) in self.tree.parent.items() if u != IDX_OF_CORE]
        if not links:
            return 0.0
        return sum(self.tree.types[u] is not self.tree.types[v] for u, v in links) / len(links)

    @cached_property
    def B(self) -> float:
        return self.branching

    @cached_property
    def L(self) -> float:
        return self.limbs

    @cached_property
    def E(self) -> float:
        return self.length_of_limbs

    @cached_property
    def C(self) -> float:
        return self.coverage

    @cached_property
    def J(self) -> float:
        return self.joints

    @cached_property
    def S(self) -> float:
        return self.symmetry

    @property
    def P(self) -> float:
        """Proportion for planar bodies, 0.0 otherwise."""
        return self.proportion_2d if self.is_2d else 0.0
