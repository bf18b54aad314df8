"""Random genotype generators (and, re-exported, the mutators), as upstream ARIEL names them.

Every function takes ``seed=`` (a numpy Generator, an int, or ``None`` for NumPy's global RNG;
see `ariel.ec._rng`) instead of upstream's shared module-level generator, and returns plain
Python lists ready to store as a genotype.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

from ariel.ec._arguments import bounds, finite, integer_genes, whole
from ariel.ec._mutators import FloatMutator, IntegerMutator
from ariel.ec._rng import SEED, SeedLike, resolve_rng, set_seed

__all__ = [
    "SEED",
    "FloatMutator",
    "Floats",
    "FloatsGenerator",
    "IntegerMutator",
    "Integers",
    "IntegersGenerator",
    "set_seed",
]

Integers = Sequence[int]
Floats = Sequence[float]
Size = int | Sequence[int] | None


class IntegersGenerator:
    """Namespace of integer genotype generators."""

    @staticmethod
    def integers(
        low: int,
        high: int,
        size: Size = 1,
        *,
        endpoint: bool = True,
        seed: SeedLike = None,
    ) -> Any:
        """Uniform integers in ``[low, high]`` (``[low, high)`` with ``endpoint=False``)."""
        bounds(low, high, whole=True)  # numpy says only "low > high", and cut 1.5 to 1
        return resolve_rng(seed).integers(low, high, size=size, endpoint=endpoint).tolist()

    @staticmethod
    def choice(
        value_set: int | Integers,
        size: Size = 1,
        probabilities: Sequence[float] | None = None,
        axis: int = 0,
        *,
        replace: bool = True,
        shuffle: bool = False,
        seed: SeedLike = None,
    ) -> Any:
        """Draws from ``value_set`` (an int ``n`` means ``range(n)``), as ``Generator.choice``."""
        if np.ndim(value_set) == 0 and (  # True (NumPy's too) was range(1), 3.0 range(3)
            not isinstance(value_set, numbers.Integral) or isinstance(value_set, bool | np.bool_)
        ):
            raise ValueError(
                f"value_set must be an int n (range(n)) or integers, not {value_set!r}"
            )
        if not isinstance(value_set, int):
            value_set = integer_genes(value_set, "value_set").tolist()
        drawn = resolve_rng(seed).choice(
            value_set, size=size, replace=replace, p=probabilities, axis=axis, shuffle=shuffle
        )
        return np.asarray(drawn).astype(int).tolist()

    @staticmethod
    def permutation(n: int, *, seed: SeedLike = None) -> list[int]:
        """A random ordering of ``0 .. n - 1``."""
        return resolve_rng(seed).permutation(whole("n", n)).tolist()


class FloatsGenerator:
    """Namespace of real-valued genotype generators."""

    @staticmethod
    def uniform(low: float, high: float, size: Size = 1, *, seed: SeedLike = None) -> Any:
        """Uniform floats in ``[low, high)``."""
        bounds(low, high)
        return resolve_rng(seed).uniform(low, high, size=size).tolist()

    @staticmethod
    def normal(
        mean: float = 0.0, std: float = 1.0, size: Size = 1, *, seed: SeedLike = None
    ) -> Any:
        """Gaussian floats with the given mean and standard deviation."""
        finite("mean", mean)
        finite("std", std, at_least=0.0)
        return resolve_rng(seed).normal(mean, std, size=size).tolist()

    @staticmethod
    def lognormal(
        mean: float = 0.0, sigma: float = 1.0, size: Size = 1, *, seed: SeedLike = None
    ) -> Any:
        """Log-normal floats (``mean`` and ``sigma`` of the underlying normal)."""
        finite("mean", mean)
        finite("sigma", sigma, at_least=0.0)
        return resolve_rng(seed).lognormal(mean, sigma, size=size).tolist()

    @staticmethod
    def choice(
        value_set: Floats,
        size: Size = 1,
        probabilities: Sequence[float] | None = None,
        *,
        replace: bool = True,
        seed: SeedLike = None,
    ) -> Any:
        """Draws from the floats in ``value_set``."""
        drawn = resolve_rng(seed).choice(
            np.asarray(value_set, dtype=float), size=size, replace=replace, p=probabilities
        )
        return np.asarray(drawn, dtype=float).tolist()

    @staticmethod
    def linspace(start: float, stop: float, num: int) -> list[float]:
        """``num`` evenly spaced floats from ``start`` to ``stop`` (both included)."""
        finite("start", start)
        finite("stop", stop)
        if not math.isfinite(float(stop) - float(start)):  # -1e308 to 1e308: NaN and inf
            raise ValueError(f"stop - start must be finite, got start={start!r}, stop={stop!r}")
        return np.linspace(start, stop, whole("num", num)).tolist()
