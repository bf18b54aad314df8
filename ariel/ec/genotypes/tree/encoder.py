"""The ``tree`` body encoder: a `TreeGenome` (as its plain dict) is the body's graph.

Variation: upstream's GP operators (subtree crossover; point, subtree, shrink and hoist
mutation) plus our grow and rotation mutations, all drawn from the rng given, with bodies kept
at ``max_modules`` modules or fewer. Registered as ``"tree"`` in
`ariel.evaluation.builtin_plugins`.
"""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import IDX_OF_CORE
from ariel.ec.genotypes.tree import operators as ops
from ariel.ec.genotypes.tree.tree_genome import TreeGenome
from ariel.ec.genotypes.tree.validation import validate_genome_dict
from ariel.utils import whole_numbers

__all__ = ["TreeEncoder"]

#: Mutation operators and how often each is drawn (upstream's example favours point/subtree).
MUTATIONS: dict[str, float] = {
    "replace_node": 0.3,
    "subtree_replacement": 0.25,
    "shrink": 0.1,
    "hoist": 0.1,
    "add_node": 0.15,
    "rotation": 0.1,
}
_MAX_TRIES = 10  # draws before falling back to growing (a no-op mutation is never returned)


class TreeEncoder:
    """A body as a `TreeGenome` dict (``{"nodes": {...}, "edges": [...]}``).

    Args:
        max_modules: the most modules a body has, core included (>= 1); mutation and crossover
            trim their children to it.
        min_modules: the fewest modules a random body has, in [1, ``max_modules``]; random
            bodies have a size drawn uniformly in between.

    Raises:
        TypeError: ``max_modules`` or ``min_modules`` is not an int (a bool, a float or a
            string: never truncated).
        ValueError: ``max_modules`` < 1, or ``min_modules`` outside [1, ``max_modules``].
    """

    name = "tree"
    evolvable = True

    def __init__(self, *, max_modules: int = 20, min_modules: int = 2) -> None:
        whole_numbers(max_modules=max_modules, min_modules=min_modules)
        if int(max_modules) < 1:
            raise ValueError(f"max_modules must be an int >= 1, not {max_modules!r}")
        if not 1 <= int(min_modules) <= int(max_modules):
            raise ValueError(
                f"min_modules must be an int in [1, max_modules={max_modules}], not {min_modules!r}"
            )
        self.max_modules = int(max_modules)
        self.min_modules = int(min_modules)

    @staticmethod
    def _genome(genotype: Any) -> TreeGenome:
        if isinstance(genotype, TreeGenome):
            return genotype.copy()
        genome = TreeGenome.from_dict(genotype)
        validate_genome_dict(genome.to_dict())
        return genome

    def random_genotype(self, rng: np.random.Generator) -> dict[str, Any]:
        size = int(rng.integers(self.min_modules, self.max_modules + 1))
        return ops.random_tree(size, rng=rng).to_dict()

    def _trim(self, genome: TreeGenome, rng: np.random.Generator) -> None:
        """Remove random leaves until the body has at most ``max_modules`` modules."""
        while len(genome.nodes) > self.max_modules:
            parents = {e["parent"] for e in genome.edges}
            leaves = sorted(n for n in genome.nodes if n not in parents and n != IDX_OF_CORE)
            ops.remove_subtree(genome, leaves[int(rng.integers(len(leaves)))])

    def _mutate_once(self, genome: TreeGenome, operator: str, rng: np.random.Generator) -> None:
        if operator == "subtree_replacement":
            ops.mutate_subtree_replacement(genome, self.max_modules, rng=rng)
        elif operator == "add_node" and len(genome.nodes) >= self.max_modules:
            ops.mutate_rotation(genome, rng=rng)
        else:
            getattr(ops, f"mutate_{operator}")(genome, rng=rng)

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> dict[str, Any]:
        """One random operator (weights in `MUTATIONS`); never returns its input unchanged."""
        parent = self._genome(genotype)
        names = list(MUTATIONS)
        weights = np.array([MUTATIONS[n] for n in names])
        for _ in range(_MAX_TRIES):
            child = parent.copy()
            self._mutate_once(child, names[rng.choice(len(names), p=weights / weights.sum())], rng)
            self._trim(child, rng)
            if child != parent:
                return child.to_dict()
        child = parent.copy()  # e.g. a lone core: only growing changes it
        ops.mutate_add_node(child, rng=rng)
        if child == parent or len(child.nodes) > self.max_modules:
            raise ValueError("this tree genome cannot be mutated within max_modules")
        return child.to_dict()

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> dict[str, Any]:
        """Subtree crossover; one of the two children, trimmed to ``max_modules``."""
        children = ops.crossover_subtree(self._genome(a), self._genome(b), rng=rng)
        child = children[int(rng.integers(2))]
        self._trim(child, rng)
        return child.to_dict()

    def decode(self, genotype: Any) -> nx.DiGraph:
        return self._genome(genotype).to_networkx()
