"""A run's lineage as a Rerun graph, as ``run.rrd`` and the live view (``ariel watch``) draw it.

Every body is a node (id: its body id; label: body id and fitness) at its birth generation
across and its place among that generation's new bodies down, coloured by fitness (viridis:
dark the worst, bright yellow the best so far) and larger while it is in the population; a
directed edge runs from each parent to its child. The graph is drawn whole at each
generation (a graph view shows an entity's latest row only), so following a body's edges
back leads to its founders.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.recording.rerun._archive import _VIRIDIS
from ariel.recording.rerun._chunks import rerun_module

if TYPE_CHECKING:
    from rerun import AsComponents
    from rerun.blueprint import GraphView

__all__ = ["LINEAGE_ENTITY", "LINEAGE_STEP", "Lineage", "fitness_colours", "lineage_view"]

#: Where the lineage graph is logged.
LINEAGE_ENTITY = "/lineage"
#: Scene units between generations (across) and between the bodies born in one (down).
LINEAGE_STEP = (40.0, 40.0)


def fitness_colours(fitness: np.ndarray, maximise: bool) -> np.ndarray:
    """RGB per fitness: viridis from the worst (dark) to the best (yellow); grey for NaN."""
    finite = np.isfinite(fitness)
    colours = np.full((len(fitness), 3), 160, dtype=np.uint8)
    if finite.any():
        low, high = float(fitness[finite].min()), float(fitness[finite].max())
        share = (fitness[finite] - low) / (high - low) if high > low else np.ones(finite.sum())
        share = share if maximise else 1.0 - share
        anchors = np.linspace(0.0, 1.0, len(_VIRIDIS))
        rgb = [np.interp(share, anchors, _VIRIDIS[:, c]) for c in range(3)]
        colours[finite] = np.stack(rgb, axis=1).round().astype(np.uint8)
    return colours


class Lineage:
    """The lineage so far (the module docstring says how it is drawn), grown one generation
    at a time from its rows of the bodies table (`grow`) and drawn by `archetypes`."""

    def __init__(self, *, maximise: bool) -> None:
        self.maximise = maximise
        self._nodes: dict[str, list[float]] = {}  # body id -> [x, y, fitness]
        self._edges: dict[tuple[str, str], None] = {}  # (parent, child), in order of birth
        self._born: dict[int, int] = {}  # generation -> bodies born in it so far
        self._alive: set[str] = set()

    def grow(self, bodies: Iterable[Mapping[str, Any]], generation: int) -> None:
        """Add generation ``generation``'s new bodies and their parent links, and update its
        bodies' fitness and who is in the population (``selected``)."""
        step_x, step_y = LINEAGE_STEP
        alive = set()
        for body in bodies:
            body_id = str(body["body_id"])
            node = self._nodes.get(body_id)
            if node is None:
                born = int(body.get("born_generation", generation))
                k = self._born.get(born, 0)
                self._born[born] = k + 1
                node = self._nodes[body_id] = [step_x * born, step_y * k, math.nan]
                parents = body.get("parent_ids")
                for parent in [] if parents is None else list(parents):
                    self._edges[(str(parent), body_id)] = None
            node[2] = float(body["fitness"])
            if body.get("selected"):
                alive.add(body_id)
        self._alive = alive

    def archetypes(self) -> list[AsComponents]:
        """`GraphNodes` and directed `GraphEdges` of the lineage so far."""
        rr = rerun_module()

        ids = list(self._nodes)
        nodes = np.array(list(self._nodes.values()), dtype=np.float64).reshape(-1, 3)
        return [
            rr.GraphNodes(
                ids,
                positions=nodes[:, :2],
                colors=fitness_colours(nodes[:, 2], self.maximise),
                labels=[f"{i}: {f:.4g}" for i, f in zip(ids, nodes[:, 2])],
                radii=[6.0 if i in self._alive else 3.0 for i in ids],
                show_labels=False,
            ),
            rr.GraphEdges([e for e in self._edges if e[0] in self._nodes], graph_type="directed"),
        ]


def lineage_view() -> GraphView:
    """The graph view of `LINEAGE_ENTITY`, as the run's and the live view's layouts show it."""
    rrb = rerun_module().blueprint

    return rrb.GraphView(name="lineage (bright: fitter)", origin=LINEAGE_ENTITY)
