"""Seeding for the upstream-style EA engine: explicit generators, no module-level RNG.

Upstream ARIEL shares one module-level ``default_rng(42)`` between all its operators. Here every
stochastic call takes ``seed=``: a ``numpy.random.Generator`` (used as is, so a script can
thread one generator through a whole run), an integer (a fresh generator), or ``None``. With
``None`` the call draws its seed from NumPy's global RNG, so ``set_seed(42)`` (or
``np.random.seed(42)``) at the top of a script makes the whole script repeat, as upstream users
expect, while importing the package seeds nothing.
"""

from __future__ import annotations

import numbers
import random
import sys

import numpy as np

from ariel.utils import global_generator

__all__ = ["SEED", "SeedLike", "resolve_rng", "set_seed"]

#: Upstream's default seed, kept for scripts that import it (``from ariel.ec import SEED``).
SEED: int = 42

SeedLike = int | np.random.Generator | None


def resolve_rng(seed: SeedLike) -> np.random.Generator:
    """The generator a stochastic call should draw from (see the module docstring)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None:  # reproducible after np.random.seed()
        return global_generator()
    if isinstance(seed, numbers.Integral) and not isinstance(seed, bool) and seed >= 0:
        return np.random.default_rng(int(seed))
    raise ValueError(
        f"seed must be a non-negative integer, a numpy.random.Generator or None, not {seed!r}"
    )


def set_seed(seed: int) -> None:
    """Seed every global RNG an upstream-style script draws from.

    Python's ``random`` (used by ``Population.sample`` / ``shuffle`` without ``seed=``), NumPy's
    global RNG (used by the operators without ``seed=``) and, only if the script already
    imported it, torch's. Call it again whenever the seed changes.

    Args:
        seed: a non-negative integer (NumPy receives it modulo ``2**32``).

    Raises:
        ValueError: ``seed`` is not a non-negative integer (``bool`` included).
    """
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, not {seed!r}")
    random.seed(int(seed))
    np.random.seed(int(seed) % 2**32)
    torch = sys.modules.get("torch")  # never import torch just to seed it
    if torch is not None:
        torch.manual_seed(int(seed))
