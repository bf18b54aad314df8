"""The tests of `ariel compare` and what they can reach: the two-sided p of a pair of conditions
(Wilcoxon signed-rank on the seeds both have where the design is paired, else Mann-Whitney U),
the omnibus test across more than two (Friedman, else Kruskal-Wallis), the smallest p each test
can give with the samples' sizes, and Holm's correction over the pairs of a measure (with the
smallest Holm p a family could reach, `holm_floor`).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.stats import chi2, friedmanchisquare, kruskal, mannwhitneyu, wilcoxon

from ariel.recording.analysis._compare_samples import Sample, as_sample, paired_values

__all__ = [
    "holm",
    "holm_floor",
    "max_kruskal_h",
    "min_p_friedman",
    "min_p_kruskal",
    "min_p_mann_whitney",
    "min_p_wilcoxon",
    "omnibus_test",
    "pair_p_value",
]


def _no_evidence(p: float) -> float:
    return 1.0 if math.isnan(p) else p  # every value tied: no evidence of a difference


def _mann_whitney_p(a: np.ndarray, b: np.ndarray) -> float:
    if len(a) == 0 or len(b) == 0:
        return math.nan
    return _no_evidence(float(mannwhitneyu(a, b, alternative="two-sided").pvalue))


def _wilcoxon_p(x: np.ndarray, y: np.ndarray) -> float:
    differences = x - y
    if len(differences) == 0:
        return math.nan
    if not differences.any():
        return 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return _no_evidence(float(wilcoxon(differences, alternative="two-sided").pvalue))  # pyright: ignore[reportAttributeAccessIssue]  # scipy makes the result class at run time


def pair_p_value(a: Sample | ArrayLike, b: Sample | ArrayLike, *, paired: bool) -> float:
    """Two-sided p of a pair of conditions: Wilcoxon signed-rank on the seeds both have
    (``paired``), else Mann-Whitney U on all their runs. NaN without data."""
    a, b = as_sample(a), as_sample(b)
    if paired:
        return _wilcoxon_p(*paired_values(a, b))
    return _mann_whitney_p(a.values, b.values)


def min_p_mann_whitney(n_a: int, n_b: int) -> float:
    """The smallest two-sided p of the exact Mann-Whitney U test (no ties): the two most
    extreme of the C(n_a + n_b, n_a) equally likely rank splits, 2 / C(n_a + n_b, n_a)."""
    if n_a < 1 or n_b < 1:
        return math.nan
    return min(1.0, 2.0 / math.comb(n_a + n_b, n_a))


def min_p_wilcoxon(pairs: int) -> float:
    """The smallest two-sided p of the exact Wilcoxon signed-rank test on ``pairs`` non-zero
    differences: all of one sign, 2 of the 2^n equally likely sign patterns, 2 / 2^n."""
    if pairs < 1:
        return math.nan
    return min(1.0, 2.0 / 2.0**pairs)


def min_p_friedman(conditions: int, blocks: int) -> float:
    """The smallest p of the Friedman test as scipy computes it (chi-square with k - 1
    degrees of freedom): at its largest statistic, n (k - 1), every seed ranking the
    conditions the same way. (The exact permutation test's smallest p, 1 / (k!)^(n - 1),
    differs: above it for k = 3, n = 2, below it for larger k or n.)"""
    if conditions < 3 or blocks < 1:
        return math.nan
    return float(chi2.sf(blocks * (conditions - 1), conditions - 1))


def max_kruskal_h(sizes: Sequence[int]) -> float:
    """The largest Kruskal-Wallis H for groups of ``sizes`` without ties: each group holding a
    block of consecutive ranks, in the order of blocks that gives the largest H."""
    total = sum(sizes)
    if total < 2:
        return math.nan
    orders = itertools.permutations(sizes) if len(sizes) <= 7 else [sorted(sizes)]
    best = -math.inf
    for order in orders:
        start, spread = 0, 0.0
        for n in order:
            rank_sum = n * start + n * (n + 1) / 2
            spread += rank_sum**2 / n
            start += n
        best = max(best, spread)
    return 12.0 / (total * (total + 1)) * best - 3.0 * (total + 1)


def min_p_kruskal(sizes: Sequence[int]) -> float:
    """The smallest p of the Kruskal-Wallis test as scipy computes it (chi-square with k - 1
    degrees of freedom) at `max_kruskal_h`."""
    sizes = [n for n in sizes if n > 0]
    if len(sizes) < 2:
        return math.nan
    return float(chi2.sf(max_kruskal_h(sizes), len(sizes) - 1))


def holm_floor(min_p: Sequence[float]) -> np.ndarray:
    """The smallest Holm-corrected p each of ``min_p`` (each test's smallest p, one family)
    could become: at least its own, and at least m times the smallest of them all."""
    p = np.asarray(min_p, dtype=np.float64)
    known = np.isfinite(p)
    if not known.any():
        return p.copy()
    floor = np.maximum(p, known.sum() * p[known].min())
    return np.where(known, np.minimum(floor, 1.0), np.nan)


def holm(p_values: np.ndarray) -> np.ndarray:
    """Holm's step-down correction of ``p_values`` (NaN stays NaN, counted out of m)."""
    p = np.asarray(p_values, dtype=np.float64)
    adjusted = np.full(p.shape, np.nan)
    known = np.flatnonzero(np.isfinite(p))
    m = len(known)
    running = 0.0
    for rank, index in enumerate(known[np.argsort(p[known], kind="stable")]):
        running = max(running, min(1.0, (m - rank) * p[index]))
        adjusted[index] = running
    return adjusted


def omnibus_test(
    samples: Mapping[str, Sample | ArrayLike], *, paired: bool, measure: str = "final best"
) -> dict[str, Any] | None:
    """For more than two conditions: Friedman on the seeds every condition has (``paired``),
    else Kruskal-Wallis on all runs; None for two or fewer. ``n``: seeds (blocks) or runs."""
    found = {name: as_sample(s) for name, s in samples.items()}
    if len(found) < 3:
        return None
    statistic, p = math.nan, math.nan
    if paired:
        by_seed = [s.by_seed() for s in found.values()]
        seeds = [seed for seed in by_seed[0] if all(seed in other for other in by_seed[1:])]
        n, floor = len(seeds), min_p_friedman(len(found), len(seeds))
        if seeds:
            columns = [[values[s] for s in seeds] for values in by_seed]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                statistic, p = friedmanchisquare(*columns)
    else:
        groups = [s.values for s in found.values() if len(s)]
        n, floor = sum(len(g) for g in groups), min_p_kruskal([len(g) for g in groups])
        if len(groups) >= 2:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                statistic, p = kruskal(*groups)
    return {
        "measure": measure,
        "test": "Friedman" if paired else "Kruskal-Wallis",
        "k": len(found),
        "n": n,
        "statistic": float(statistic),
        "p_value": _no_evidence(float(p)) if n else math.nan,
        "min_p": floor,
    }
