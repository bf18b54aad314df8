"""The tests of `ariel compare` and what they can reach: the two-sided p of a pair of conditions
(Wilcoxon signed-rank on the seeds both have where the design is paired, else Mann-Whitney U;
both exact, ties included: `_compare_exact`), the omnibus test across more than two (Friedman,
else Kruskal-Wallis), the smallest p each test can give with the samples' sizes, and Holm's
correction over the pairs of a measure (with the smallest Holm p a family could reach,
`holm_floor`).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.stats import chi2, friedmanchisquare, kruskal

from ariel.recording.analysis._compare_exact import exact_mann_whitney, exact_wilcoxon
from ariel.recording.analysis._compare_samples import Sample, as_sample, paired_values

__all__ = [
    "PairTest",
    "holm",
    "holm_floor",
    "max_kruskal_h",
    "min_p_friedman",
    "min_p_kruskal",
    "min_p_mann_whitney",
    "min_p_wilcoxon",
    "omnibus_test",
    "pair_p_value",
    "pair_test",
]


def _no_evidence(p: float) -> float:
    return 1.0 if math.isnan(p) else p  # every value tied: no evidence of a difference


def _at_least(p: float, floor: float) -> float:
    """``p``, or ``floor`` where ``p`` is below it by float rounding alone (the floors are
    proven bounds: a test's p reaches its floor, never passes it)."""
    if math.isfinite(p) and math.isfinite(floor) and floor * (1 - 1e-9) <= p < floor:
        return floor
    return p


class PairTest(NamedTuple):
    """A pair's test: its two-sided ``p``, its ``direction`` (+1: the first condition's
    values are higher, -1: lower, 0: neither), the values it rests on (``tested``: the
    non-zero differences of a paired test, else all runs) and the smallest p those allow."""

    p: float
    direction: int
    tested: int
    min_p: float


def pair_test(x: np.ndarray, y: np.ndarray, *, paired: bool) -> PairTest:
    """The exact test of ``x`` against ``y``: Wilcoxon signed-rank on ``x - y`` (``paired``:
    in step, seed by seed; zero differences dropped, so they do not count towards its smallest
    p either), else Mann-Whitney U."""
    if paired:
        p, direction, tested = exact_wilcoxon(x - y)
        floor = min_p_wilcoxon(tested) if tested else (1.0 if len(x) else math.nan)
        return PairTest(_at_least(p, floor), direction, tested, floor)
    p, direction = exact_mann_whitney(x, y)
    floor = min_p_mann_whitney(len(x), len(y))
    return PairTest(_at_least(p, floor), direction, len(x) + len(y), floor)


def pair_p_value(a: Sample | ArrayLike, b: Sample | ArrayLike, *, paired: bool) -> float:
    """Two-sided p of a pair of conditions: Wilcoxon signed-rank on the seeds both have
    (``paired``), else Mann-Whitney U on all their runs; exact, ties included. NaN without
    data."""
    a, b = as_sample(a), as_sample(b)
    return pair_test(*(paired_values(a, b) if paired else (a.values, b.values)), paired=paired).p


def min_p_mann_whitney(n_a: int, n_b: int) -> float:
    """The smallest two-sided p of the exact Mann-Whitney U test: the two most extreme of the
    C(n_a + n_b, n_a) equally likely rank splits, 2 / C(n_a + n_b, n_a). Ties cannot go below
    it: each one-sided tail holds the observed split, and the two-sided p is twice the
    smaller."""
    if n_a < 1 or n_b < 1:
        return math.nan
    return min(1.0, 2.0 / math.comb(n_a + n_b, n_a))


def min_p_wilcoxon(pairs: int) -> float:
    """The smallest two-sided p of the exact Wilcoxon signed-rank test on ``pairs`` non-zero
    differences (zero differences are dropped by the test): all of one sign, 2 of the 2^n
    equally likely sign patterns, 2 / 2^n; ties cannot go below it."""
    if pairs < 1:
        return math.nan
    return min(1.0, 2.0 / 2.0**pairs)


def min_p_friedman(conditions: int, blocks: int) -> float:
    """The smallest p of the Friedman test as scipy computes it (chi-square with k - 1
    degrees of freedom): at its largest statistic, n (k - 1), every seed ranking the
    conditions the same way; scipy's tie correction cannot take it higher. (The exact
    permutation test's smallest p, 1 / (k!)^(n - 1), differs: above it for k = 3, n = 2,
    below it for larger k or n.)"""
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
    degrees of freedom, ties corrected) at the largest H it can give: N - 1 for N runs, where
    every condition's runs tie among themselves and differ from the others'. (Without ties H
    cannot pass `max_kruskal_h`; the tie correction can take it up to N - 1.)"""
    sizes = [n for n in sizes if n > 0]
    if len(sizes) < 2 or sum(sizes) < 2:
        return math.nan
    return float(chi2.sf(sum(sizes) - 1, len(sizes) - 1))


def holm_floor(min_p: Sequence[float]) -> np.ndarray:
    """The smallest Holm-corrected p each of ``min_p`` (each test's smallest p, one family of
    m) could become, whatever p the others give (each at least its own smallest).

    Ranked r-th (from 0), a test's Holm p is the running maximum of (m - k) p_k over the
    tests ranked at or before it, so the r tests before it can help only with p at most its
    own: the least it can become is, over r, the larger of (m - r) max(its p, f_r) and
    max over k < r of (m - k) f_(k+1), with f the others' smallest p in ascending order.
    (m times the smallest of them all, at least its own, was not reachable where tests'
    sizes differ: a 6-pair test beside 7-pair ones was said to reach 0.047, not 0.0625.)"""
    p = np.asarray(min_p, dtype=np.float64)
    known = np.isfinite(p)
    floors = np.full(p.shape, np.nan)
    values = p[known]
    m = len(values)
    order = np.sort(values)
    ranks = np.arange(m)
    least = []
    for own in values:
        others = np.delete(order, np.searchsorted(order, own))  # one copy of its own left out
        before = np.concatenate([[0.0], np.maximum.accumulate((m - ranks[:-1]) * others)])
        at = (m - ranks) * np.maximum(own, np.concatenate([[0.0], others]))
        least.append(min(1.0, float(np.min(np.maximum(before, at)))))
    floors[known] = least
    return floors


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
        columns = [[values[s] for s in seeds] for values in by_seed]
        if seeds and all(len(set(block)) == 1 for block in zip(*columns)):
            # Every seed ties across the conditions: no evidence (scipy divides a rounding
            # residue by a tie correction of 0 and says inf, p = 0, or says NaN).
            statistic, p = 0.0, 1.0
        elif seeds:
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
        "p_value": _at_least(_no_evidence(float(p)), floor) if n else math.nan,
        "min_p": floor,
    }
