"""The samples `ariel compare` tests and its design: each condition's values with the seeds of
their runs (`Sample`), which tests a comparison uses (`Design`: paired on shared seeds or not),
and the values two conditions have on the seeds both ran (`paired_values`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Design", "Sample", "as_sample", "common_seeds", "paired_values"]


@dataclass(frozen=True)
class Sample:
    """One condition's values (finite), each from the run of a seed (``seeds``, in step)."""

    values: np.ndarray
    seeds: tuple[int, ...] = field(default=())

    @classmethod
    def of(cls, values: ArrayLike, seeds: Sequence[int] | None = None) -> Sample:
        """``values`` (NaN and infinities dropped), with their ``seeds`` (default 0, 1, ...)."""
        values = np.asarray(values, dtype=np.float64).ravel()
        seeds = list(range(len(values))) if seeds is None else [int(s) for s in seeds]
        if len(seeds) != len(values):
            raise ValueError(f"{len(values)} values but {len(seeds)} seeds")
        keep = np.isfinite(values)
        return cls(values[keep], tuple(s for s, k in zip(seeds, keep) if k))

    def __len__(self) -> int:
        return len(self.values)

    def by_seed(self) -> dict[int, float]:
        """seed -> value (a seed's first value where one appears twice)."""
        found: dict[int, float] = {}
        for seed, value in zip(self.seeds, self.values):
            found.setdefault(seed, float(value))
        return found


def as_sample(value: Sample | ArrayLike) -> Sample:
    return value if isinstance(value, Sample) else Sample.of(value)


@dataclass(frozen=True)
class Design:
    """Which tests a comparison uses: paired (shared seeds) or not, and why."""

    paired: bool
    reason: str = ""

    @property
    def pairwise(self) -> str:
        return "Wilcoxon signed-rank" if self.paired else "Mann-Whitney U"

    @property
    def omnibus(self) -> str:
        return "Friedman" if self.paired else "Kruskal-Wallis"

    def describe(self) -> str:
        matched = " on seed-matched runs" if self.paired else ""
        why = f", because {self.reason}" if self.reason else ""
        return (
            f"{self.pairwise} per pair of conditions{matched}, two-sided, Holm-corrected over "
            f"the pairs; {self.omnibus} across all conditions when there are more than 2{why}"
        )


def common_seeds(a: Sample, b: Sample) -> list[int]:
    """The seeds both samples have, in ``a``'s order."""
    other = b.by_seed()
    return [seed for seed in a.by_seed() if seed in other]


def paired_values(a: Sample, b: Sample) -> tuple[np.ndarray, np.ndarray]:
    """``a``'s and ``b``'s values on the seeds both have (in step)."""
    seeds = common_seeds(a, b)
    first, second = a.by_seed(), b.by_seed()
    return (
        np.array([first[s] for s in seeds], dtype=np.float64),
        np.array([second[s] for s in seeds], dtype=np.float64),
    )
