"""Best-first decoding of a CPPN genome into a robot graph (upstream's
``MorphologyDecoderBestFirst``).

Modules sit on an integer lattice (the core at the origin). Every free allowed face of every
placed module is a candidate; the CPPN, given ``(parent position, child position)``, scores it
(output 0), picks the child's type (outputs 1-4: the best of BRICK and HINGE) and rotation
(outputs 5-7). The best-scoring candidate is placed, until ``max_modules`` modules (core
included) are placed or no candidate is left. Ties go to the earlier module, then the earlier
face (FRONT, BACK, RIGHT, LEFT, TOP, BOTTOM). Each candidate is scored once (its inputs never
change), in one batch per placed module. Fixed from upstream (docs/decisions.md): a face that
is not allowed or occupied no longer stops the scan of the module's later faces, and the child's
own faces do not restrict where it may attach.
"""

from __future__ import annotations

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    IDX_OF_CORE,
    NUM_OF_ROTATIONS,
    NUM_OF_TYPES_OF_MODULES,
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.cppn_neat.genome import Genome

__all__ = ["CPPN_INPUTS", "CPPN_OUTPUTS", "MorphologyDecoderBestFirst", "softmax"]

#: The CPPN's inputs: parent (x, y, z) and child (x, y, z) lattice positions.
CPPN_INPUTS = 6
#: The outputs it needs: connection score, 4 type scores, 3 rotation scores (more are ignored).
CPPN_OUTPUTS = 1 + NUM_OF_TYPES_OF_MODULES + NUM_OF_ROTATIONS

# Lattice step of each face, as upstream (a fixed frame: the lattice is the CPPN's coordinate
# space, not the body's geometry).
FACE_DELTAS: dict[ModuleFaces, tuple[int, int, int]] = {
    ModuleFaces.FRONT: (1, 0, 0),
    ModuleFaces.BACK: (-1, 0, 0),
    ModuleFaces.TOP: (0, 1, 0),
    ModuleFaces.BOTTOM: (0, -1, 0),
    ModuleFaces.RIGHT: (0, 0, 1),
    ModuleFaces.LEFT: (0, 0, -1),
}
_CHILD_TYPES = (ModuleType.BRICK, ModuleType.HINGE)
_CHILD_TYPE_VALUES = np.array([t.value for t in _CHILD_TYPES])
_ROTS = list(ModuleRotationsIdx)
_FACES = list(ModuleFaces)
_DELTAS = [FACE_DELTAS[f] for f in _FACES]
_FACE_STEPS = [(i, f, FACE_DELTAS[f]) for i, f in enumerate(_FACES)]
_LOOKAHEAD = 2  # lattice steps scored ahead of a new module (one CPPN batch per ~3 modules)


def softmax(raw_scores: np.ndarray) -> np.ndarray:
    """Softmax along the last axis (shifted by the maximum, so it never overflows)."""
    shifted = np.exp(raw_scores - np.max(raw_scores, axis=-1, keepdims=True))
    return shifted / shifted.sum(axis=-1, keepdims=True)


class MorphologyDecoderBestFirst:
    """``MorphologyDecoderBestFirst(cppn_genome, max_modules=20).decode()`` -> robot graph."""

    def __init__(self, cppn_genome: Genome, max_modules: int = 20) -> None:
        if isinstance(max_modules, bool) or int(max_modules) < 1:
            raise ValueError(
                f"max_modules must be an int >= 1 (the core counts), not {max_modules!r}"
            )
        self.cppn_genome = cppn_genome
        self.max_modules = int(max_modules)
        self.face_deltas = dict(FACE_DELTAS)

    def _get_child_coords(
        self, parent_pos: tuple[int, int, int], face: ModuleFaces
    ) -> tuple[int, int, int]:
        dx, dy, dz = self.face_deltas[face]
        return (parent_pos[0] + dx, parent_pos[1] + dy, parent_pos[2] + dz)

    def decode(self) -> nx.DiGraph:
        """The robot graph: node attributes ``type``/``rotation``, edge attribute ``face``."""
        genome = self.cppn_genome
        n_in = sum(node.typ == "input" for node in genome.nodes.values())
        n_out = sum(node.typ == "output" for node in genome.nodes.values())
        if n_in != CPPN_INPUTS or n_out < CPPN_OUTPUTS:
            raise ValueError(
                f"the best-first decoder needs a CPPN with {CPPN_INPUTS} inputs and at least "
                f"{CPPN_OUTPUTS} outputs; this one has {n_in} and {n_out}"
            )
        evaluate = genome.compile()
        graph = nx.DiGraph()
        graph.add_node(
            IDX_OF_CORE, type=ModuleType.CORE.name, rotation=ModuleRotationsIdx.DEG_0.name
        )
        occupied = {(0, 0, 0): IDX_OF_CORE}
        # Candidates in (module, face) order: score, parent, face, child position, type, rotation.
        candidates: list[tuple[float, int, ModuleFaces, tuple, ModuleType, ModuleRotationsIdx]] = []

        # CPPN outputs per (position, face): its inputs depend on nothing else, so they are
        # computed once, ahead, for every lattice point within _LOOKAHEAD steps of a newly
        # placed module: one batch then serves that module's children and grandchildren too.
        scored: dict[tuple[int, int, int], list[tuple]] = {}  # position -> per face index

        def prefetch(pos: tuple[int, int, int]) -> None:
            ring, points = {pos}, {pos}
            for _ in range(_LOOKAHEAD):
                ring = {(p[0] + d[0], p[1] + d[1], p[2] + d[2]) for p in ring for d in _DELTAS}
                ring -= points
                points |= ring
            new = sorted(points.difference(scored))
            parents = np.repeat(np.array(new, dtype=np.float64), len(_DELTAS), axis=0)
            children = parents + np.tile(np.array(_DELTAS, dtype=np.float64), (len(new), 1))
            out = evaluate(np.concatenate([parents, children], axis=1))[:, :CPPN_OUTPUTS]
            out = np.nan_to_num(out, nan=-np.inf)  # a NaN never wins
            scores = out[:, 0].tolist()
            kinds = np.argmax(out[:, 1 + _CHILD_TYPE_VALUES], axis=1).tolist()
            rotations = np.argmax(out[:, 1 + NUM_OF_TYPES_OF_MODULES :], axis=1).tolist()
            for i, point in enumerate(new):
                rows = range(i * len(_DELTAS), (i + 1) * len(_DELTAS))
                scored[point] = [
                    (scores[k], _CHILD_TYPES[kinds[k]], _ROTS[rotations[k]]) for k in rows
                ]

        def score_faces(module: int, module_type: ModuleType, pos: tuple[int, int, int]) -> None:
            if pos not in scored:
                prefetch(pos)
            for index, face, (dx, dy, dz) in _FACE_STEPS:
                child = (pos[0] + dx, pos[1] + dy, pos[2] + dz)
                if face not in ALLOWED_FACES[module_type] or child in occupied:
                    continue
                score, kind, rotation = scored[pos][index]
                candidates.append((score, module, face, child, kind, rotation))

        score_faces(IDX_OF_CORE, ModuleType.CORE, (0, 0, 0))
        while len(graph) < self.max_modules:
            candidates = [c for c in candidates if c[3] not in occupied]
            if not candidates:
                break
            best = max(range(len(candidates)), key=lambda i: candidates[i][0])  # first on ties
            _score, parent, face, pos, kind, rotation = candidates.pop(best)
            child = len(graph)
            graph.add_node(child, type=kind.name, rotation=rotation.name)
            graph.add_edge(parent, child, face=face.name)
            occupied[pos] = child
            score_faces(child, kind, pos)
        return graph
