"""The statistics of `ariel compare`, as evolutionary-computation papers report them, with the
guard rails those papers ask for (Arcuri & Briand 2011; Bartz-Beielstein et al. 2020).

- Median of the seeds with a 95 % percentile-bootstrap confidence band (`scipy.stats.bootstrap`).
- The test follows the design (`Design`): conditions that share seeds (a campaign's
  default, common random numbers) are paired by seed: the Wilcoxon signed-rank test per pair
  of conditions on the seeds both have, and the Friedman test across all conditions when
  there are more than two (on the seeds every condition has). Independent samples (a
  campaign with ``seeding = "independent"``, or plain run folders): the Mann-Whitney U test
  per pair, Kruskal-Wallis across all. All two-sided. p-values of the pairs are
  Holm-corrected over all pairs of a measure (Holm 1979).
- Per pair: the difference of the medians with its bootstrap CI (paired designs resample
  seeds, not runs), and the Vargha-Delaney A12 effect size (Vargha & Delaney 2000): the chance
  that a run of the first condition beats one of the second, ties counting half, "beats"
  meaning better in the fitness's direction (so a minimised fitness compares correctly).
  Paired designs add the share of seeds on which the first condition is better.
- Small samples are said, not hidden: `min_p_value` is the smallest p a test can give with the
  samples' sizes (`holm_floor`: after Holm), and an effect gets no size label ("large", ...)
  where that smallest p is not below `ALPHA`: no test could have detected it.

Random resampling uses a fixed seed: the same runs give the same table.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "ALPHA",
    "FEW_RUNS",
    "NOT_DETECTABLE",
    "Design",
    "Sample",
    "a12",
    "effect_label",
    "holm",
    "holm_floor",
    "location",
    "max_kruskal_h",
    "median_band",
    "median_difference_ci",
    "min_p_friedman",
    "min_p_kruskal",
    "min_p_mann_whitney",
    "min_p_wilcoxon",
    "omnibus_test",
    "pair_p_value",
    "pairing_notes",
    "pairwise_table",
    "small_n_warning",
]

ALPHA = 0.05
CONFIDENCE = 0.95
RESAMPLES = 2000
#: Below this many runs per condition, `small_n_warning` says what the tests can reach.
FEW_RUNS = 5
#: The effect label where no test could reach p < `ALPHA` with the samples' sizes.
NOT_DETECTABLE = "— (n too small)"
_SEED = 20240514


def _rng() -> np.random.Generator:
    return np.random.default_rng(_SEED)


# --------------------------------------------------------------------------------------------
# Samples and the design
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Sample:
    """One condition's values (finite), each from the run of a seed (``seeds``, in step)."""

    values: np.ndarray
    seeds: tuple[int, ...] = field(default=())

    @classmethod
    def of(cls, values: Any, seeds: Sequence[int] | None = None) -> Sample:
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


def as_sample(value: Sample | Any) -> Sample:
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


# --------------------------------------------------------------------------------------------
# Bands, intervals, effect sizes
# --------------------------------------------------------------------------------------------


def median_band(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Median over the rows (seeds) of ``values`` (seeds x points) and its 95 % bootstrap
    band, per column; the band is NaN where fewer than 2 seeds have a value."""
    from scipy.stats import bootstrap

    values = np.asarray(values, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: NaN, as meant
        median = np.nanmedian(values, axis=0) if values.size else np.full(values.shape[1:], np.nan)
    low = np.full(median.shape, np.nan)
    high = np.full(median.shape, np.nan)
    full = np.isfinite(values).all(axis=0)
    if values.shape[0] >= 2 and full.any():
        result = bootstrap(
            (values[:, full],),
            np.median,
            axis=0,
            vectorized=True,
            n_resamples=RESAMPLES,
            confidence_level=CONFIDENCE,
            method="percentile",
            rng=_rng(),
        )
        low[full], high[full] = result.confidence_interval
    return median, low, high


def _median_difference(x: np.ndarray, y: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.median(x, axis=axis) - np.median(y, axis=axis)


def median_difference_ci(
    a: np.ndarray, b: np.ndarray, *, paired: bool = False
) -> tuple[float, float]:
    """95 % bootstrap CI of median(a) - median(b): each sample resampled on its own, or, where
    ``paired`` (``a`` and ``b`` in step, seed by seed), the seeds resampled together. NaN when
    either has fewer than 2 values."""
    from scipy.stats import bootstrap

    if len(a) < 2 or len(b) < 2:
        return math.nan, math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a degenerate (all equal) resample
        result = bootstrap(
            (np.asarray(a, float), np.asarray(b, float)),
            _median_difference,
            vectorized=True,
            paired=paired,
            n_resamples=RESAMPLES,
            confidence_level=CONFIDENCE,
            method="percentile",
            rng=_rng(),
        )
    return float(result.confidence_interval.low), float(result.confidence_interval.high)


def a12(a: np.ndarray, b: np.ndarray, *, maximise: bool) -> float:
    """Vargha-Delaney A12: P(a run of ``a`` is better than one of ``b``) + P(tie) / 2.

    From the Mann-Whitney U of ``a`` (pairs with a > b, ties half): U / (n_a n_b) when higher
    is better, 1 minus it when lower is.
    """
    from scipy.stats import mannwhitneyu

    if len(a) == 0 or len(b) == 0:
        return math.nan
    u = float(mannwhitneyu(a, b, alternative="two-sided").statistic)
    share = u / (len(a) * len(b))
    return share if maximise else 1.0 - share


def paired_wins(x: np.ndarray, y: np.ndarray, *, maximise: bool) -> float:
    """The share of seeds on which ``x`` is better than ``y`` (in step), ties half: the paired
    counterpart of A12. NaN without a pair."""
    if len(x) == 0:
        return math.nan
    better = (x > y) if maximise else (x < y)
    return float((better.sum() + 0.5 * (x == y).sum()) / len(x))


def effect_label(value: float) -> str:
    """Vargha and Delaney's magnitude of A12 (0.5: no effect; symmetric around it)."""
    if math.isnan(value):
        return "-"
    distance = abs(value - 0.5)
    for limit, label in ((0.06, "negligible"), (0.14, "small"), (0.21, "medium")):
        if distance < limit:
            return label
    return "large"


# --------------------------------------------------------------------------------------------
# Tests and what they can reach
# --------------------------------------------------------------------------------------------


def _no_evidence(p: float) -> float:
    return 1.0 if math.isnan(p) else p  # every value tied: no evidence of a difference


def _mann_whitney_p(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.stats import mannwhitneyu

    if len(a) == 0 or len(b) == 0:
        return math.nan
    return _no_evidence(float(mannwhitneyu(a, b, alternative="two-sided").pvalue))


def _wilcoxon_p(x: np.ndarray, y: np.ndarray) -> float:
    from scipy.stats import wilcoxon

    differences = x - y
    if len(differences) == 0:
        return math.nan
    if not differences.any():
        return 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return _no_evidence(float(wilcoxon(differences, alternative="two-sided").pvalue))  # pyright: ignore[reportAttributeAccessIssue]  # scipy makes the result class at run time


def pair_p_value(a: Sample | Any, b: Sample | Any, *, paired: bool) -> float:
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
    from scipy.stats import chi2

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
    from scipy.stats import chi2

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
    samples: Mapping[str, Sample | Any], *, paired: bool, measure: str = "final best"
) -> dict[str, Any] | None:
    """For more than two conditions: Friedman on the seeds every condition has (``paired``),
    else Kruskal-Wallis on all runs; None for two or fewer. ``n``: seeds (blocks) or runs."""
    from scipy.stats import friedmanchisquare, kruskal

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


# --------------------------------------------------------------------------------------------
# The table
# --------------------------------------------------------------------------------------------


def location(values: np.ndarray) -> dict[str, float]:
    """``median``, ``mean`` and ``sd`` (the sample's, n - 1) of the finite ``values``; NaN
    where there are too few."""
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    n = len(values)
    return {
        "median": float(np.median(values)) if n else math.nan,
        "mean": float(np.mean(values)) if n else math.nan,
        "sd": float(np.std(values, ddof=1)) if n > 1 else math.nan,
    }


def _summary(values: np.ndarray, suffix: str) -> dict[str, float]:
    return {f"{key}_{suffix}": value for key, value in location(values).items()}


def _pair_row(
    names: tuple[str, str], a: Sample, b: Sample, *, maximise: bool, paired: bool
) -> dict[str, Any]:
    """One pair's numbers, before the Holm correction (see `pairwise_table`)."""
    x, y = paired_values(a, b) if paired else (a.values, b.values)
    low, high = median_difference_ci(x, y, paired=paired)
    pairs = len(x) if paired else None
    return {
        "a": names[0],
        "b": names[1],
        "n_a": len(a),
        "n_b": len(b),
        "n_pairs": pairs,
        **_summary(a.values, "a"),
        **_summary(b.values, "b"),
        "difference": float(np.median(a.values) - np.median(b.values))
        if len(a) and len(b)
        else math.nan,
        "ci_low": low,
        "ci_high": high,
        "p_value": _wilcoxon_p(x, y) if paired else _mann_whitney_p(x, y),
        "min_p": min_p_wilcoxon(len(x)) if paired else min_p_mann_whitney(len(a), len(b)),
        "a12": a12(a.values, b.values, maximise=maximise),
        "paired_wins": paired_wins(x, y, maximise=maximise) if paired else math.nan,
    }


def pairwise_table(
    samples: Mapping[str, Sample | Any],
    *,
    maximise: bool,
    paired: bool = False,
    measure: str = "final best",
) -> list[dict[str, Any]]:
    """One row per pair of conditions (in the given order) for one ``measure``.

    ``samples``: condition -> `Sample` (or plain values, seeds 0, 1, ...). Columns: ``n_a``,
    ``n_b`` (runs), ``n_pairs`` (seeds both have; paired only), median / mean / sd of each,
    difference of the medians (a - b) with its CI, the test and its p (raw, ``p_holm`` over
    the pairs), ``min_p`` / ``p_floor``: the smallest raw / Holm p reachable with these
    sizes, A12 (a beats b), ``paired_wins`` (share of seeds a is better on), ``effect`` (its
    size, or `NOT_DETECTABLE`), and ``better``: the better condition where p (Holm) <
    `ALPHA`, else ``-``.
    """
    found = {name: as_sample(s) for name, s in samples.items()}
    rows = [
        {
            "measure": measure,
            **_pair_row(
                (first, second), found[first], found[second], maximise=maximise, paired=paired
            ),
        }
        for first, second in itertools.combinations(found, 2)
    ]
    test = "Wilcoxon signed-rank" if paired else "Mann-Whitney U"
    adjusted = holm(np.array([row["p_value"] for row in rows]))
    floors = holm_floor([row["min_p"] for row in rows])
    for row, p, floor in zip(rows, adjusted, floors):
        row["test"] = test
        row["p_holm"] = float(p)
        row["p_floor"] = float(floor)
        detectable = math.isfinite(floor) and floor < ALPHA
        row["effect"] = effect_label(row["a12"]) if detectable else NOT_DETECTABLE
        significant = math.isfinite(p) and p < ALPHA
        row["better"] = (row["a"] if row["a12"] > 0.5 else row["b"]) if significant else "-"
    return rows


# --------------------------------------------------------------------------------------------
# What the reader must be told
# --------------------------------------------------------------------------------------------


def _sizes_text(row: Mapping[str, Any]) -> str:
    if row.get("n_pairs") is not None:
        return f"{row['n_pairs']} pair{'s' if row['n_pairs'] != 1 else ''}"
    return f"{row['n_a']} vs {row['n_b']} runs"


def small_n_warning(
    rows: Sequence[Mapping[str, Any]],
    runs_per_condition: Mapping[str, int],
    choice: Design,
    omnibus: Mapping[str, Any] | None = None,
) -> str | None:
    """One line where a condition has fewer than `FEW_RUNS` runs: the smallest p the chosen
    tests can give with these sizes (for the most limited pair; after Holm; the omnibus's)."""
    if not rows or min(runs_per_condition.values(), default=FEW_RUNS) >= FEW_RUNS:
        return None
    text = f"fewer than {FEW_RUNS} runs per condition (fewest: {min(runs_per_condition.values())})"
    testable = [r for r in rows if math.isfinite(r["min_p"])]
    if not testable:
        return f"{text}: no pair of conditions has runs on both sides to test"
    weakest = max(testable, key=lambda r: r["min_p"])
    text += (
        f": {choice.pairwise} cannot give p below {weakest['min_p']:.3g} "
        f"({_sizes_text(weakest)}, exact, two-sided), {weakest['p_floor']:.3g} after Holm over "
        f"{len(testable)} pair{'s' if len(testable) != 1 else ''}"
    )
    if omnibus is not None and math.isfinite(omnibus["min_p"]):
        unit = "seeds" if choice.paired else "runs"
        text += (
            f"; {omnibus['test']} not below {omnibus['min_p']:.3g} (chi-square, "
            f"{omnibus['k']} conditions, {omnibus['n']} {unit})"
        )
    if all(r["p_floor"] >= ALPHA for r in testable):
        text += f": no difference can reach p < {ALPHA:g}, effect sizes are not labelled"
    elif weakest["p_floor"] >= ALPHA:
        text += f": pairs that cannot reach p < {ALPHA:g} get no effect size label"
    return text


def pairing_notes(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """One line per pair that was paired on fewer seeds than it has runs (a failed run)."""
    notes = []
    for row in rows:
        pairs = row.get("n_pairs")
        if pairs is not None and pairs < max(row["n_a"], row["n_b"]):
            seeds = "seed" if pairs == 1 else "seeds"
            notes.append(
                f"{row['a']} vs {row['b']}: paired on the {pairs} {seeds} both have "
                f"({row['n_a']} and {row['n_b']} runs)"
            )
    return notes
