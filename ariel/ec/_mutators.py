"""`IntegerMutator` and `FloatMutator`: upstream ARIEL's per-gene mutation operators, seeded.

Each takes a genotype (a list, nested list or array) and returns a new one as plain lists; the
input is never changed. ``mutation_probability`` is per gene for the element-wise operators and
per call for inversion / scramble, as upstream documents.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ariel.ec._arguments import bounds, finite, integer_genes, probability, whole
from ariel.ec._rng import SeedLike, resolve_rng

__all__ = ["FloatMutator", "IntegerMutator"]


def _swap(individual: Any, mutation_probability: float, seed: SeedLike) -> list[Any]:
    """Each gene, with the probability, trades places with a uniformly chosen gene."""
    probability("mutation_probability", mutation_probability)
    genes, rng = list(individual), resolve_rng(seed)
    for i in range(len(genes)):
        if rng.random() < mutation_probability:
            j = int(rng.integers(0, len(genes)))
            genes[i], genes[j] = genes[j], genes[i]
    return genes


def _segment(n: int, rng: np.random.Generator) -> tuple[int, int]:
    lo, hi = sorted(int(x) for x in rng.choice(n + 1, size=2, replace=False))
    return lo, hi


def _inversion(individual: Any, mutation_probability: float, seed: SeedLike) -> list[Any]:
    """With the probability, reverse a random slice."""
    probability("mutation_probability", mutation_probability)
    genes, rng = list(individual), resolve_rng(seed)
    if len(genes) < 2 or rng.random() >= mutation_probability:
        return genes
    lo, hi = _segment(len(genes), rng)
    genes[lo:hi] = genes[lo:hi][::-1]
    return genes


class IntegerMutator:
    """Namespace of mutations for integer genotypes."""

    @staticmethod
    def random_reset(
        individual: Any, low: int, high: int, mutation_probability: float, *, seed: SeedLike = None
    ) -> Any:
        """Each gene, with the probability, becomes a uniform integer in ``[low, high]``."""
        probability("mutation_probability", mutation_probability)
        bounds(low, high, whole=True)
        genes, rng = integer_genes(individual), resolve_rng(seed)
        mask = rng.random(genes.shape) < mutation_probability
        fresh = rng.integers(low, high, size=genes.shape, endpoint=True)
        return np.where(mask, fresh, genes).tolist()

    @staticmethod
    def integer_creep(
        individual: Any, span: int, mutation_probability: float, *, seed: SeedLike = None
    ) -> Any:
        """Each gene, with the probability, moves up or down by 1 to ``span``."""
        probability("mutation_probability", mutation_probability)
        span = whole("span", span, 1)
        genes, rng = integer_genes(individual), resolve_rng(seed)
        mask = rng.random(genes.shape) < mutation_probability
        step = rng.integers(1, span, size=genes.shape, endpoint=True)
        sign = rng.choice(np.array([-1, 1]), size=genes.shape)
        return (genes + mask * sign * step).tolist()

    @staticmethod
    def swap(individual: Any, mutation_probability: float, *, seed: SeedLike = None) -> list[int]:
        """Each gene, with the probability, trades places with a random gene."""
        return _swap(individual, mutation_probability, seed)

    @staticmethod
    def inversion(
        individual: Any, mutation_probability: float, *, seed: SeedLike = None
    ) -> list[int]:
        """With the probability, reverse a random slice."""
        return _inversion(individual, mutation_probability, seed)

    @staticmethod
    def scramble(
        individual: Any, mutation_probability: float, *, seed: SeedLike = None
    ) -> list[int]:
        """With the probability, shuffle a random slice."""
        probability("mutation_probability", mutation_probability)
        genes, rng = list(individual), resolve_rng(seed)
        if len(genes) < 2 or rng.random() >= mutation_probability:
            return genes
        lo, hi = _segment(len(genes), rng)
        genes[lo:hi] = [genes[lo + int(k)] for k in rng.permutation(hi - lo)]
        return genes


class FloatMutator:
    """Namespace of mutations for real-valued genotypes."""

    @staticmethod
    def gaussian(
        individual: Any,
        std: float,
        mutation_probability: float,
        *,
        lower_bound: float | None = None,
        upper_bound: float | None = None,
        seed: SeedLike = None,
    ) -> Any:
        """Each gene, with the probability, gets N(0, std²) added; then optionally clipped."""
        probability("mutation_probability", mutation_probability)
        finite("std", std, at_least=0.0)
        if lower_bound is not None and upper_bound is not None:
            bounds(lower_bound, upper_bound)  # reversed, np.clip set every gene to the upper
        else:
            for name, bound in (("lower_bound", lower_bound), ("upper_bound", upper_bound)):
                if bound is not None:
                    finite(name, bound)
        genes, rng = np.asarray(individual, dtype=np.float64), resolve_rng(seed)
        mask = rng.random(genes.shape) < mutation_probability
        out = genes + mask * rng.normal(0.0, std, size=genes.shape)
        if lower_bound is not None or upper_bound is not None:
            out = np.clip(out, lower_bound, upper_bound)
        return out.tolist()

    @staticmethod
    def uniform_reset(
        individual: Any,
        low: float,
        high: float,
        mutation_probability: float,
        *,
        seed: SeedLike = None,
    ) -> Any:
        """Each gene, with the probability, becomes uniform in ``[low, high)``."""
        probability("mutation_probability", mutation_probability)
        bounds(low, high)
        genes, rng = np.asarray(individual, dtype=np.float64), resolve_rng(seed)
        mask = rng.random(genes.shape) < mutation_probability
        return np.where(mask, rng.uniform(low, high, size=genes.shape), genes).tolist()

    @staticmethod
    def boundary(
        individual: Any,
        low: float,
        high: float,
        mutation_probability: float,
        *,
        seed: SeedLike = None,
    ) -> Any:
        """Each gene, with the probability, becomes ``low`` or ``high`` (even odds)."""
        probability("mutation_probability", mutation_probability)
        bounds(low, high)
        genes, rng = np.asarray(individual, dtype=np.float64), resolve_rng(seed)
        mask = rng.random(genes.shape) < mutation_probability
        edge = np.where(rng.random(genes.shape) < 0.5, float(low), float(high))
        return np.where(mask, edge, genes).tolist()

    @staticmethod
    def polynomial(
        individual: Any,
        low: float,
        high: float,
        mutation_probability: float,
        distribution_index: float = 20.0,
        *,
        seed: SeedLike = None,
    ) -> Any:
        """Polynomial mutation (Deb & Goyal 1996) within ``[low, high]``.

        Larger ``distribution_index`` keeps children closer to the parent gene.
        """
        probability("mutation_probability", mutation_probability)
        bounds(low, high, strict=True)
        finite("distribution_index", distribution_index, at_least=0.0)
        x = np.clip(np.asarray(individual, dtype=np.float64), low, high)
        rng = resolve_rng(seed)
        mask = rng.random(x.shape) < mutation_probability
        u = rng.random(x.shape)
        span, power = high - low, distribution_index + 1.0
        below = 1.0 - (x - low) / span  # 1 - distance to the lower bound, normalised
        above = 1.0 - (high - x) / span
        down = (2.0 * u + (1.0 - 2.0 * u) * below**power) ** (1.0 / power) - 1.0
        up = 1.0 - (2.0 * (1.0 - u) + 2.0 * (u - 0.5) * above**power) ** (1.0 / power)
        delta = np.where(u < 0.5, down, up)
        return np.clip(np.where(mask, x + delta * span, x), low, high).tolist()

    @staticmethod
    def swap(individual: Any, mutation_probability: float, *, seed: SeedLike = None) -> list[float]:
        """Each gene, with the probability, trades places with a random gene."""
        return _swap(individual, mutation_probability, seed)

    @staticmethod
    def inversion(
        individual: Any, mutation_probability: float, *, seed: SeedLike = None
    ) -> list[float]:
        """With the probability, reverse a random slice."""
        return _inversion(individual, mutation_probability, seed)
