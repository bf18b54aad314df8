"""`Crossover`: upstream ARIEL's two-parent recombination operators, seeded.

Genotypes are any JSON-like nested lists (or arrays) of equal shape; the operators cut the
flattened genes and hand back two children of the parents' shape as nested lists. Integer
genes stay integers (upstream turns every gene into a float).
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

from ariel.ec._arguments import probability
from ariel.ec._rng import SeedLike, resolve_rng

__all__ = ["Crossover"]


def _flat_pair(parent_i: Any, parent_j: Any) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
    """Shape and flat copies of two parents; ``ValueError`` if their shapes differ."""
    a, b = np.asarray(parent_i), np.asarray(parent_j)
    if a.shape != b.shape:
        raise ValueError(f"parents must have the same shape, got {a.shape} and {b.shape}")
    dtype = np.result_type(a, b)
    if dtype.kind not in "biuf":
        raise ValueError(f"parents must hold numbers (booleans, integers or floats), not {dtype}")
    return a.shape, a.astype(dtype).ravel(), b.astype(dtype).ravel()


class Crossover:
    """Namespace of crossover operators; each returns ``(child_i, child_j)``."""

    @staticmethod
    def one_point(parent_i: Any, parent_j: Any, *, seed: SeedLike = None) -> tuple[Any, Any]:
        """Swap the genes after one random cut in ``[1, genes - 1]``."""
        shape, a, b = _flat_pair(parent_i, parent_j)
        if a.size < 2:
            raise ValueError(f"one_point crossover needs at least 2 genes, got {a.size}")
        cut = int(resolve_rng(seed).integers(1, a.size))
        c1 = np.concatenate([a[:cut], b[cut:]])
        c2 = np.concatenate([b[:cut], a[cut:]])
        return c1.reshape(shape).tolist(), c2.reshape(shape).tolist()

    @staticmethod
    def n_point(parent_i: Any, parent_j: Any, n: int, *, seed: SeedLike = None) -> tuple[Any, Any]:
        """``n`` distinct cuts; every other segment (the 2nd, 4th, ...) is swapped."""
        shape, a, b = _flat_pair(parent_i, parent_j)
        if not isinstance(n, numbers.Integral) or isinstance(n, bool) or not 1 <= n < a.size:
            raise ValueError(
                f"n must be a whole number in [1, genes - 1] = [1, {a.size - 1}], not {n!r}"
            )
        n = int(n)
        cuts = np.sort(resolve_rng(seed).choice(np.arange(1, a.size), size=n, replace=False))
        # Segment index of each gene = number of cuts at or before it; odd segments swap.
        swap = (np.searchsorted(cuts, np.arange(a.size), side="right") % 2) == 1
        c1, c2 = np.where(swap, b, a), np.where(swap, a, b)
        return c1.reshape(shape).tolist(), c2.reshape(shape).tolist()

    @staticmethod
    def uniform(
        parent_i: Any, parent_j: Any, swap_probability: float = 0.5, *, seed: SeedLike = None
    ) -> tuple[Any, Any]:
        """Each gene is swapped between the parents with ``swap_probability``."""
        probability("swap_probability", swap_probability)
        shape, a, b = _flat_pair(parent_i, parent_j)
        swap = resolve_rng(seed).random(a.size) < swap_probability
        c1, c2 = np.where(swap, b, a), np.where(swap, a, b)
        return c1.reshape(shape).tolist(), c2.reshape(shape).tolist()

    @staticmethod
    def order_crossover(
        parent_i: Sequence[int], parent_j: Sequence[int], *, seed: SeedLike = None
    ) -> tuple[list[int], list[int]]:
        """Order crossover (OX, Davis 1985) for permutations.

        Each child keeps a random slice of one parent in place and fills the other positions,
        starting after the slice and wrapping round, with the other parent's remaining genes in
        the order they appear there from the same point.
        """
        p, q = list(parent_i), list(parent_j)
        if sorted(p) != sorted(q) or len(set(p)) != len(p):
            raise ValueError("order_crossover needs two permutations of the same genes")
        n = len(p)
        lo, hi = sorted(int(x) for x in resolve_rng(seed).choice(n + 1, size=2, replace=False))

        def child(keep: list[int], fill: list[int]) -> list[int]:
            kept = set(keep[lo:hi])
            rest = [g for g in fill[hi:] + fill[:hi] if g not in kept]
            out = list(keep)
            for k, gene in enumerate(rest):
                out[(hi + k) % n] = gene
            return out

        return child(p, q), child(q, p)
