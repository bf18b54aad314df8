"""Best-first decoding of a CPPN genome into a robot graph (upstream's
``MorphologyDecoderBestFirst``).

Modules sit on an integer lattice (the core at the origin). Every free allowed face of every
placed module is a candidate; the CPPN, given ``(parent position, child position)``, scores it
(output 0), picks the child's type (outputs 1-4: the best of BRICK and HINGE) and rotation
(outputs 5-7). The best-scoring candidate is placed, until ``max_modules`` modules (core
included) are placed or no candidate is left. Ties go to the earlier module, then the earlier
face (FRONT, BACK, RIGHT, LEFT, TOP, BOTTOM). Each candidate is scored once (its inputs never
change), in batches: each covers the unscored lattice points near a newly placed module. Fixed
from upstream (docs/decisions.md): a face that is not allowed or occupied no longer stops the
scan of the module's later faces, and the child's own faces do not restrict where it may attach.
"""

from __future__ import annotations

import heapq
import itertools

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
from ariel.body_phenotypes.robogen_lite.cppn_neat.genome import Evaluator, Genome

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
# Output columns of the child types, BRICK then HINGE: consecutive, so a view (no gather).
_CHILD_TYPE_COLUMNS = slice(1 + ModuleType.BRICK.value, 1 + ModuleType.HINGE.value + 1)
if ModuleType.HINGE.value != ModuleType.BRICK.value + 1:  # pragma: no cover - config guard
    raise ImportError("cppn_best_first expects HINGE's value right after BRICK's")
_ROTS = list(ModuleRotationsIdx)
_FACES = list(ModuleFaces)
_DELTAS = [FACE_DELTAS[f] for f in _FACES]
_LOOKAHEAD = 2  # lattice steps scored ahead of a new module (one CPPN batch per ~3 modules)


def _ball(radius: int) -> list[tuple[int, int, int]]:
    """Lattice offsets within ``radius`` face steps of the origin, sorted."""
    ring, points = {(0, 0, 0)}, {(0, 0, 0)}
    for _ in range(radius):
        ring = {(p[0] + d[0], p[1] + d[1], p[2] + d[2]) for p in ring for d in _DELTAS}
        ring -= points
        points |= ring
    return sorted(points)


# The CPPN batch of a prefetch is built from constants: shifting a sorted set of points keeps
# its order, so the rows of the points still to score are rows of this table (offset, offset +
# face step, per offset and face) plus the module's position, and exactly the rows (same
# values, same order) that listing and sorting the shifted points would give. Same batches,
# so the same CPPN outputs bit for bit (a matrix product's last bits may depend on its shape).
_BALL = _ball(_LOOKAHEAD)
_BALL_ROWS = np.array(
    [(*o, o[0] + d[0], o[1] + d[1], o[2] + d[2]) for o in _BALL for d in _DELTAS],
    dtype=np.float64,
).reshape(len(_BALL), len(_DELTAS), 2 * 3)
# Per module type, its allowed faces as (index, name, step), in the scan order of candidates;
# names are looked up once here (an Enum's ``.name`` and hash are slow Python calls).
_ALLOWED_STEPS = {
    t: [(i, f.name, FACE_DELTAS[f]) for i, f in enumerate(_FACES) if f in ALLOWED_FACES[t]]
    for t in (ModuleType.CORE, *_CHILD_TYPES)
}
_CORE_STEPS = _ALLOWED_STEPS[ModuleType.CORE]
_CHILD_STEPS = [_ALLOWED_STEPS[t] for t in _CHILD_TYPES]  # by the type's output index
_CHILD_NAMES = [t.name for t in _CHILD_TYPES]
_ROT_NAMES = [r.name for r in _ROTS]


#: CPPN outputs per lattice point: (a batch's scores, types, rotations, the point's first row
#: in them), by position.
_Scored = dict[tuple[int, int, int], tuple[list, list, list, int]]


def _check_cppn(genome: Genome) -> None:
    """`ValueError` unless ``genome`` has the CPPN's inputs and outputs (`CPPN_INPUTS`,
    at least `CPPN_OUTPUTS`)."""
    n_in = sum(node.typ == "input" for node in genome.nodes.values())
    n_out = sum(node.typ == "output" for node in genome.nodes.values())
    if n_in != CPPN_INPUTS or n_out < CPPN_OUTPUTS:
        raise ValueError(
            f"the best-first decoder needs a CPPN with {CPPN_INPUTS} inputs and at least "
            f"{CPPN_OUTPUTS} outputs; this one has {n_in} and {n_out}"
        )


def _prefetch(evaluate: Evaluator, scored: _Scored, pos: tuple[int, int, int]) -> None:
    """Score, in one CPPN batch, every lattice point within `_LOOKAHEAD` steps of ``pos``
    that ``scored`` lacks, and add them to it."""
    points = [(pos[0] + o[0], pos[1] + o[1], pos[2] + o[2]) for o in _BALL]
    fresh = [i for i, point in enumerate(points) if point not in scored]
    rows = _BALL_ROWS.take(fresh, axis=0).reshape(-1, 2 * 3)
    rows += pos + pos
    out = evaluate(rows)[:, :CPPN_OUTPUTS]
    if not np.isfinite(out).all():
        out = np.nan_to_num(out, nan=-np.inf)  # a NaN never wins
    batch = (
        out[:, 0].tolist(),
        out[:, _CHILD_TYPE_COLUMNS].argmax(axis=1).tolist(),
        out[:, 1 + NUM_OF_TYPES_OF_MODULES :].argmax(axis=1).tolist(),
    )
    for i, k in enumerate(fresh):
        scored[points[k]] = (*batch, i * len(_DELTAS))


def softmax(raw_scores: np.ndarray) -> np.ndarray:
    """Softmax along the last axis (shifted by the maximum, so it never overflows).

    Args:
        raw_scores: Scores of any shape; each slice along the last axis is normalised.

    Returns:
        Probabilities of the same shape, each last-axis slice summing to 1.
    """
    shifted = np.exp(raw_scores - np.max(raw_scores, axis=-1, keepdims=True))
    return shifted / shifted.sum(axis=-1, keepdims=True)


class MorphologyDecoderBestFirst:
    """Decodes a CPPN genome best-first into a robot graph (see the module docstring).

    Args:
        cppn_genome: The CPPN: 6 inputs and at least 8 outputs (`CPPN_INPUTS`,
            `CPPN_OUTPUTS`), checked by `decode`.
        max_modules: Most modules in the graph, the core included (an int >= 1).

    Raises:
        ValueError: If ``max_modules`` is a bool or less than 1.

    Example:
        ```python
        from ariel.body_phenotypes.robogen_lite.cppn_neat.genome import Genome
        from ariel.body_phenotypes.robogen_lite.decoders.cppn_best_first import (
            CPPN_INPUTS,
            CPPN_OUTPUTS,
            MorphologyDecoderBestFirst,
        )

        genome = Genome.random(CPPN_INPUTS, CPPN_OUTPUTS, rng=0)
        graph = MorphologyDecoderBestFirst(genome, max_modules=10).decode()
        print(graph.number_of_nodes())  # 10 at most, the core (node 0) included
        ```
    """

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
        _check_cppn(genome)
        evaluate = genome.compile()
        nodes = [(IDX_OF_CORE, {"type": ModuleType.CORE.name, "rotation": _ROT_NAMES[0]})]
        edges: list[tuple[int, int, dict[str, str]]] = []
        occupied = {(0, 0, 0): IDX_OF_CORE}
        # Candidates as a heap of (-score, arrival, parent, face, child position, type,
        # rotation): its top is the best score, ties to the earliest arrival, i.e. the earlier
        # module, then face. A candidate whose position got occupied is dropped when popped.
        candidates: list[tuple] = []
        arrivals = itertools.count()

        # CPPN outputs per (position, face): its inputs depend on nothing else, so they are
        # computed once, ahead, for every lattice point within _LOOKAHEAD steps of a newly
        # placed module: one batch then serves that module's children and grandchildren too.
        # position -> (the batch's scores, types, rotations, the point's first row in them);
        # the rows are read only for the faces that become candidates.
        scored: _Scored = {}

        def score_faces(module: int, steps: list, pos: tuple[int, int, int]) -> None:
            if pos not in scored:
                _prefetch(evaluate, scored, pos)
            scores, kinds, rotations, first = scored[pos]
            for index, face, (dx, dy, dz) in steps:
                child = (pos[0] + dx, pos[1] + dy, pos[2] + dz)
                if child not in occupied:
                    row = first + index
                    candidate = (-scores[row], next(arrivals), module, face, child)
                    heapq.heappush(candidates, (*candidate, kinds[row], rotations[row]))

        score_faces(IDX_OF_CORE, _CORE_STEPS, (0, 0, 0))
        while len(nodes) < self.max_modules and candidates:
            *_, parent, face, pos, kind, rotation = heapq.heappop(candidates)
            if pos in occupied:
                continue
            child = len(nodes)
            nodes.append((child, {"type": _CHILD_NAMES[kind], "rotation": _ROT_NAMES[rotation]}))
            edges.append((parent, child, {"face": face}))
            occupied[pos] = child
            score_faces(child, _CHILD_STEPS[kind], pos)
        # The same graph as adding each node, then its edge, in turn (same orders, same data).
        graph = nx.DiGraph()
        graph.add_nodes_from(nodes)
        graph.add_edges_from(edges)
        return graph
