"""Seeds: every random decision of a run derives from the run seed and a fixed key.

``numpy.random.SeedSequence(run_seed, spawn_key=(purpose, *indices))`` gives an independent
stream per decision (a body's initial genotype, the variation that makes child j of
generation g, body n's CMA-ES, body n's evaluations), so no result depends on the order in
which work is done, the executor or the number of workers, and a resumed run redraws exactly
what an uninterrupted one would.
"""

from __future__ import annotations

import zlib

import numpy as np

__all__ = ["derive_rng", "derive_seed"]


def _key(purpose: str, indices: tuple[int, ...]) -> tuple[int, ...]:
    # A stable integer per purpose name (crc32 does not change between runs, unlike hash()).
    return (zlib.crc32(purpose.encode()), *(int(i) for i in indices))


def derive_rng(run_seed: int, purpose: str, *indices: int) -> np.random.Generator:
    """An independent generator for one ``purpose`` (e.g. ``"variation"``) and its indices.

    The same arguments always give a generator that draws the same numbers; any other
    ``purpose`` or ``indices`` gives an independent stream.

    Args:
        run_seed: The run seed (``seed`` of the config), or a body's own seed.
        purpose: What the numbers decide, e.g. ``"variation"``; hashed to a stable integer
            (crc32), so any string works.
        *indices: Integers that pick one decision of that purpose, e.g. the generation and
            the child's index.

    Returns:
        A fresh numpy generator seeded from
        ``SeedSequence(run_seed, spawn_key=(crc32(purpose), *indices))``.

    Example:
        ```python
        from ariel.evolution import derive_rng

        a = derive_rng(42, "variation", 3, 0).random()
        b = derive_rng(42, "variation", 3, 0).random()
        assert a == b  # the same decision draws the same numbers, in any order of work
        assert derive_rng(42, "variation", 3, 1).random() != a
        ```
    """
    return np.random.default_rng(np.random.SeedSequence(run_seed, spawn_key=_key(purpose, indices)))


def derive_seed(run_seed: int, purpose: str, *indices: int) -> int:
    """An integer seed in ``[1, 2**31)`` for one purpose (for code that takes int seeds).

    Args:
        run_seed: The run seed (``seed`` of the config), or a body's own seed.
        purpose: What the seed is for, e.g. ``"evaluation"``; hashed to a stable integer (crc32).
        *indices: Integers that pick one decision of that purpose, e.g. a body's number.

    Returns:
        A seed ``1 <= seed < 2**31``, the same for the same arguments, drawn from
        ``SeedSequence(run_seed, spawn_key=(crc32(purpose), *indices))``.
    """
    sequence = np.random.SeedSequence(run_seed, spawn_key=_key(purpose, indices))
    return int(sequence.generate_state(1, np.uint32)[0] % (2**31 - 1)) + 1
