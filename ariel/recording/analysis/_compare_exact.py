"""The exact rank tests of `ariel compare`'s pairs, ties included: Mann-Whitney U and Wilcoxon
signed-rank with their p from the exact permutation distribution of the rank statistic given
the data's ties (midranks), not from the normal approximation scipy switches to as soon as
two values tie. The distribution is counted, not sampled: the number of n-subsets of the
doubled midranks (integers) with each rank sum (Mann-Whitney), or of sign patterns with each
sum of positive ranks (Wilcoxon), by dynamic programming.

The two-sided p is twice the smaller one-sided p (capped at 1), as scipy's exact tests and
`scipy.stats.permutation_test` compute it. Each one-sided tail holds the observed split, so the
p is never below 2 / C(n_a + n_b, n_a) (Mann-Whitney) or 2 / 2^n for n non-zero differences
(Wilcoxon), ties or not: the floors `ariel compare` states. The direction (which side is
higher) is the tail the p comes from, so "better" follows the test.

Above `EXACT_LIMIT` values the tests fall back on scipy's normal approximation (with its tie
correction), which is good at such sizes.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.stats import mannwhitneyu, rankdata, wilcoxon

__all__ = ["EXACT_LIMIT", "exact_mann_whitney", "exact_wilcoxon", "signed_rank_share"]

#: Up to this many runs (Mann-Whitney: both samples together) or non-zero differences
#: (Wilcoxon), the p is exact.
EXACT_LIMIT = 120


def _doubled_midranks(values: np.ndarray) -> np.ndarray:
    """Twice the midranks of ``values`` (integers: a tie over ranks i..j has midrank (i+j)/2)."""
    return np.rint(2.0 * rankdata(values)).astype(np.int64)


def _two_sided(counts: np.ndarray, observed: int) -> tuple[float, int]:
    """(two-sided p, direction) of ``observed`` under the null counts of each statistic value:
    direction +1 where the upper tail is the smaller one (the statistic is high), -1 where the
    lower one is, 0 where they are equal."""
    total = counts.sum()
    upper = counts[observed:].sum() / total
    lower = counts[: observed + 1].sum() / total
    direction = 0 if math.isclose(upper, lower) else (1 if upper < lower else -1)
    return float(min(1.0, 2.0 * min(upper, lower))), direction


def _subset_sum_counts(scores: np.ndarray, size: int) -> np.ndarray:
    """counts[s]: how many ``size``-subsets of ``scores`` (non-negative integers) sum to s."""
    top = int(np.sort(scores)[::-1][:size].sum())
    table = np.zeros((size + 1, top + 1))
    table[0, 0] = 1.0
    for score in scores.tolist():
        if score <= top:
            table[1:, score:] += table[:-1, : top + 1 - score].copy()
    return table[size]


def _sign_sum_counts(scores: np.ndarray) -> np.ndarray:
    """counts[s]: how many of the 2^n sign patterns of ``scores`` have positive part s."""
    top = int(scores.sum())
    table = np.zeros(top + 1)
    table[0] = 1.0
    for score in scores.tolist():
        table[score:] += table[: top + 1 - score].copy()
    return table


def exact_mann_whitney(a: np.ndarray, b: np.ndarray) -> tuple[float, int]:
    """(two-sided p, direction) of the Mann-Whitney U test of ``a`` against ``b``; direction
    +1 where ``a`` tends to be higher, -1 lower, 0 neither. (NaN, 0) without data; p 1 where
    every value ties."""
    if len(a) == 0 or len(b) == 0:
        return math.nan, 0
    values = np.concatenate([a, b]).astype(np.float64)
    if np.all(values == values[0]):
        return 1.0, 0
    if len(values) > EXACT_LIMIT:
        result = mannwhitneyu(a, b, alternative="two-sided", method="asymptotic")
        u = float(result.statistic)
        centre = len(a) * len(b) / 2.0
        return float(result.pvalue), int(np.sign(u - centre))
    scores = _doubled_midranks(values)
    return _two_sided(_subset_sum_counts(scores, len(a)), int(scores[: len(a)].sum()))


def exact_wilcoxon(differences: np.ndarray) -> tuple[float, int, int]:
    """(two-sided p, direction, non-zero differences) of the Wilcoxon signed-rank test of the
    paired ``differences``: zero differences dropped (scipy's default, Wilcoxon's own), the
    rest ranked by size (midranks for ties). Direction +1 where the differences lean
    positive (the positive ranks outweigh the negative), -1 negative, 0 neither. (NaN, 0, 0)
    without differences; p 1 where every difference is 0."""
    differences = np.asarray(differences, dtype=np.float64)
    if len(differences) == 0:
        return math.nan, 0, 0
    nonzero = differences[differences != 0]
    if len(nonzero) == 0:
        return 1.0, 0, 0
    if len(nonzero) > EXACT_LIMIT:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            result = wilcoxon(nonzero, alternative="two-sided", method="asymptotic")
        scores = rankdata(np.abs(nonzero))
        lean = float(scores[nonzero > 0].sum() - scores[nonzero < 0].sum())
        return float(result.pvalue), int(np.sign(lean)), len(nonzero)  # pyright: ignore[reportAttributeAccessIssue]  # scipy makes the result class at run time
    scores = _doubled_midranks(np.abs(nonzero))
    p, direction = _two_sided(_sign_sum_counts(scores), int(scores[nonzero > 0].sum()))
    return p, direction, len(nonzero)


def signed_rank_share(differences: np.ndarray) -> float:
    """W+ / (W+ + W-): the positive differences' share of the signed-rank sum (zeros dropped,
    midranks), the matched-pairs rank-biserial correlation r on A12's scale, (1 + r) / 2
    (Kerby 2014). 0.5: no lean; NaN where every difference is 0 or there is none."""
    differences = np.asarray(differences, dtype=np.float64)
    nonzero = differences[differences != 0]
    if len(nonzero) == 0:
        return math.nan
    ranks = rankdata(np.abs(nonzero))
    return float(ranks[nonzero > 0].sum() / ranks.sum())
