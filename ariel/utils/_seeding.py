"""`global_generator`: a fresh NumPy generator seeded from NumPy's global RNG, the rule of every
stochastic component given ``seed=None`` (docs/decisions.md): ``np.random.seed(n)`` before
makes it repeat, and importing ariel seeds nothing."""

from __future__ import annotations

import numpy as np

__all__ = ["global_generator"]


def global_generator() -> np.random.Generator:
    """A generator seeded with four 32-bit words drawn from NumPy's global state.

    Returns:
        A new ``numpy.random.Generator``; the global state moves on by the four words.
    """
    return np.random.default_rng(np.random.randint(0, 2**32, size=4, dtype=np.uint64))
