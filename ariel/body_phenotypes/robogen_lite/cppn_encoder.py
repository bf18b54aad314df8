"""The ``cppn`` body encoder: a CPPN-NEAT `Genome` (its plain dict) decoded best-first.

Genotype: ``Genome.to_dict()`` of a CPPN with 6 inputs (parent and child lattice positions)
and 8 outputs (connection score, 4 type scores, 3 rotation scores), decoded by
`MorphologyDecoderBestFirst` into a body of ``max_modules`` modules at most.

Innovation and node ids come from the structure itself, not from a run-wide counter: a link
``a -> b`` always has the same innovation number and splitting it always gives the same node
id (a stable hash). Two genomes that make the same structural change get the same genes (what
NEAT's innovation numbers are for), and genotypes need no shared state: any worker, run or
resumed run agrees. Registered as ``"cppn"`` in `ariel.evaluation.builtin_plugins`.
"""

from __future__ import annotations

import hashlib
from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.cppn_neat.connection import Connection
from ariel.body_phenotypes.robogen_lite.cppn_neat.genome import Genome
from ariel.body_phenotypes.robogen_lite.cppn_neat.node import Node
from ariel.body_phenotypes.robogen_lite.decoders.cppn_best_first import (
    CPPN_INPUTS,
    CPPN_OUTPUTS,
    MorphologyDecoderBestFirst,
)
from ariel.utils import whole_numbers

__all__ = ["CPPNEncoder", "structural_id"]

# Ids of the fixed layout (inputs, outputs, their first links) stay below this; hashed ids
# lie in [_HASHED_BASE, _HASHED_BASE + 2**40), far below 2**53 so JSON readers keep them exact.
_HASHED_BASE = 1 << 20
_MAX_TRIES = 10  # draws before forcing a weight change (a no-op mutation is never returned)


def structural_id(kind: str, a: int, b: int) -> int:
    """A stable id for a structural gene: ``kind`` "link" (a -> b) or "split" (of link a).

    The id is a hash of the three arguments, so the same structural change always gets the
    same id, in any genome, worker or run.

    Args:
        kind: "link" for a connection ``a -> b``, "split" for the node that splits link ``a``
            (any other string is hashed the same way).
        a: For "link", the source node id; for "split", the innovation id of the split link.
        b: For "link", the target node id; for "split", 0 (as the encoder calls it).

    Returns:
        The id, in ``[2**20, 2**20 + 2**40)``: above the ids of the fixed layout and exact
        in JSON.
    """
    digest = hashlib.blake2b(f"{kind}:{a}:{b}".encode(), digest_size=8).digest()
    return _HASHED_BASE + int.from_bytes(digest, "little") % (1 << 40)


class CPPNEncoder:
    """A body as a CPPN-NEAT genome dict, decoded best-first on a lattice.

    Args:
        max_modules: Most modules in a decoded body, the core included (>= 1).
        initial_mutations: Structural mutation rounds applied to a fresh random genome (as
            upstream's example; >= 0). Each round adds a link and splits a link, each with
            its rate.
        add_node_rate: Chance, per structural round, of splitting a link into two through a
            new hidden node (NEAT's add-node), in [0, 1].
        add_connection_rate: Chance, per structural round, of linking two unlinked nodes, in
            [0, 1].
        weight_rate: Chance that each weight and bias is perturbed by a mutation, in [0, 1].
        weight_std: Standard deviation of the Gaussian noise added to a perturbed weight or
            bias (> 0).

    Raises:
        TypeError: If ``max_modules`` or ``initial_mutations`` is not an int (a float or a
            string is never truncated).
        ValueError: If an option is out of the range given above.
    """

    name = "cppn"
    evolvable = True

    def __init__(
        self,
        *,
        max_modules: int = 20,
        initial_mutations: int = 3,
        add_node_rate: float = 0.2,
        add_connection_rate: float = 0.3,
        weight_rate: float = 0.5,
        weight_std: float = 0.5,
    ) -> None:
        whole_numbers(max_modules=max_modules, initial_mutations=initial_mutations)
        if int(max_modules) < 1:
            raise ValueError(f"max_modules must be an int >= 1, not {max_modules!r}")
        if int(initial_mutations) < 0:
            raise ValueError(f"initial_mutations must be >= 0, not {initial_mutations!r}")
        for what, rate in (
            ("add_node_rate", add_node_rate),
            ("add_connection_rate", add_connection_rate),
            ("weight_rate", weight_rate),
        ):
            if not 0.0 <= float(rate) <= 1.0:
                raise ValueError(f"{what} must be in [0, 1], not {rate!r}")
        if not float(weight_std) > 0.0:
            raise ValueError(f"weight_std must be > 0, not {weight_std!r}")
        self.max_modules = int(max_modules)
        self.initial_mutations = int(initial_mutations)
        self.add_node_rate = float(add_node_rate)
        self.add_connection_rate = float(add_connection_rate)
        self.weight_rate = float(weight_rate)
        self.weight_std = float(weight_std)

    @staticmethod
    def _genome(genotype: Any) -> Genome:
        if isinstance(genotype, Genome):
            return genotype.copy()
        if not isinstance(genotype, dict):
            raise ValueError(
                f"a 'cppn' genotype is a dict (Genome.to_dict()), not {type(genotype).__name__}"
            )
        return Genome.from_dict(genotype)

    @staticmethod
    def _add_link(genome: Genome, rng: np.random.Generator) -> bool:
        """Link two unlinked nodes (never into an input, never closing a cycle)."""
        ids = sorted(genome.nodes)
        targets = [n for n in ids if genome.nodes[n].typ != "input"]
        out_id = targets[int(rng.integers(len(targets)))]
        sources = [n for n in ids if n != out_id]
        in_id = sources[int(rng.integers(len(sources)))]
        innov = structural_id("link", in_id, out_id)
        linked = any(c.in_id == in_id and c.out_id == out_id for c in genome.connections.values())
        if linked or innov in genome.connections or genome._creates_cycle(in_id, out_id):
            return False
        weight = Genome._get_random_weight(rng)
        genome.add_connection(Connection(in_id, out_id, weight, True, innov))
        return True

    @staticmethod
    def _split_link(genome: Genome, rng: np.random.Generator) -> bool:
        """Split a random enabled link ``a -> b`` into ``a -> new -> b`` (NEAT's add-node)."""
        enabled = [c for _, c in sorted(genome.connections.items()) if c.enabled]
        if not enabled:
            return False
        split = enabled[int(rng.integers(len(enabled)))]
        node_id = structural_id("split", split.innov_id, 0)
        first = structural_id("link", split.in_id, node_id)
        second = structural_id("link", node_id, split.out_id)
        if node_id in genome.nodes or {first, second} & set(genome.connections):
            return False
        split.enabled = False
        activation = Genome._get_random_activation(rng)
        genome.add_node(Node(node_id, "hidden", activation, Genome._get_random_bias(rng)))
        genome.add_connection(Connection(split.in_id, node_id, 1.0, True, first))
        genome.add_connection(Connection(node_id, split.out_id, split.weight, True, second))
        return True

    def _structural(self, genome: Genome, rng: np.random.Generator) -> None:
        """Add a link, then split one, each with its rate (upstream's ``Genome.mutate`` order)."""
        if rng.random() < self.add_connection_rate:
            self._add_link(genome, rng)
        if rng.random() < self.add_node_rate:
            self._split_link(genome, rng)

    def random_genotype(self, rng: np.random.Generator) -> dict[str, Any]:
        genome = Genome.random(CPPN_INPUTS, CPPN_OUTPUTS, rng=rng)
        for _ in range(self.initial_mutations):
            self._structural(genome, rng)
        return genome.to_dict()

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> dict[str, Any]:
        """Weight/bias noise and structural mutation; never returns its input unchanged."""
        parent = self._genome(genotype)
        for _ in range(_MAX_TRIES):
            child = parent.copy()
            child.mutate_weights(self.weight_rate, self.weight_std, rng=rng)
            self._structural(child, rng)
            if child.to_dict() != parent.to_dict():
                return child.to_dict()
        child = parent.copy()
        child.mutate_weights(1.0, self.weight_std, rng=rng)
        return child.to_dict()

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> dict[str, Any]:
        """NEAT crossover (genotypes carry no fitness, so both parents count as equally fit)."""
        return self._genome(a).crossover(self._genome(b), rng=rng).to_dict()

    def decode(self, genotype: Any) -> nx.DiGraph:
        return MorphologyDecoderBestFirst(self._genome(genotype), self.max_modules).decode()
