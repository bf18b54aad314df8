"""The statistics of `ariel compare`, as evolutionary-computation papers report them, with the
guard rails those papers ask for (Arcuri & Briand 2011; Bartz-Beielstein et al. 2020).

- Median of the seeds with a 95 % percentile-bootstrap confidence band (`scipy.stats.bootstrap`).
- The test follows the design (`Design`): conditions that share seeds (a campaign's
  default, common random numbers) are paired by seed: the Wilcoxon signed-rank test per pair
  of conditions on the seeds both have, and the Friedman test across all conditions when
  there are more than two (on the seeds every condition has). Independent samples (a
  campaign with ``seeding = "independent"``, or plain run folders): the Mann-Whitney U test
  per pair, Kruskal-Wallis across all. All two-sided; the pairs' tests exact, ties
  included (`_compare_exact`). p-values of the pairs are Holm-corrected over all pairs of a
  measure (Holm 1979).
- Per pair: the difference of the medians with its bootstrap CI, both on the sample the test
  uses (paired designs: the seeds both conditions have, resampled as seeds), and the
  Vargha-Delaney A12 effect size (Vargha & Delaney 2000): the chance that a run of the first
  condition beats one of the second, ties counting half, "beats" meaning better in the
  fitness's direction (so a minimised fitness compares correctly). Paired designs add the
  share of seeds on which the first condition is better, and their effect (``effect_size``,
  labelled) is the Wilcoxon test's own: the better side's share of the signed ranks.
- ``better`` follows the test: the side its p comes from.
- Small samples are said, not hidden: `min_p_value` is the smallest p a test can give with the
  samples' sizes (`holm_floor`: after Holm), and an effect gets no size label ("large", ...)
  where that smallest p is not below `ALPHA`: no test could have detected it.

Random resampling uses a fixed seed: the same runs give the same table.

Here: the bands, intervals and effect sizes, the table and what the reader must be told; the
samples and the design are `_compare_samples`'s, the tests and what they can reach
`_compare_tests`'s (all importable from here).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike
from scipy.stats import bootstrap, mannwhitneyu

from ariel.recording.analysis._compare_exact import signed_rank_share
from ariel.recording.analysis._compare_samples import (
    Design as Design,
    Sample as Sample,
    as_sample,
    paired_values,
)
from ariel.recording.analysis._compare_tests import (
    PairTest,
    holm,
    holm_floor,
    max_kruskal_h as max_kruskal_h,
    min_p_friedman as min_p_friedman,
    min_p_kruskal as min_p_kruskal,
    min_p_mann_whitney,
    min_p_wilcoxon,
    omnibus_test as omnibus_test,
    pair_p_value as pair_p_value,
    pair_test,
)

__all__ = [
    "ALPHA",
    "FEW_RUNS",
    "NOT_DETECTABLE",
    "Design",
    "Row",
    "RowDict",
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
    "tied_pairs_note",
]

#: One row of a table of `ariel compare` (column -> value), as its CSV holds it; `RowDict`: one
#: being made.
Row: TypeAlias = Mapping[str, Any]
RowDict: TypeAlias = dict[str, Any]

ALPHA = 0.05
CONFIDENCE = 0.95
RESAMPLES = 2000
#: Below this many runs per condition, `small_n_warning` says what the tests can reach.
FEW_RUNS = 5
#: The effect label where no test could reach p < `ALPHA` with the samples' sizes.
NOT_DETECTABLE = "— (n too small)"
#: Vargha and Delaney's limits of A12's distance from 0.5: below 0.06 negligible, below 0.14
#: small, below 0.21 medium (A12 0.56, 0.64, 0.71, and symmetrically 0.44, 0.36, 0.29).
EFFECT_LIMITS = ((0.06, "negligible"), (0.14, "small"), (0.21, "medium"))
#: Floating-point slack at a limit: A12 = 0.71 (0.71 - 0.5 = 0.20999999999999996) is large,
#: as 0.29 is.
_SLACK = 1e-9
_SEED = 20240514


def _rng() -> np.random.Generator:
    return np.random.default_rng(_SEED)


# --------------------------------------------------------------------------------------------
# Bands, intervals, effect sizes
# --------------------------------------------------------------------------------------------


def median_band(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Median over the rows (seeds) of ``values`` (seeds x points) and its 95 % bootstrap
    band, per column; the band is NaN where fewer than 2 seeds have a value."""
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
    """Vargha and Delaney's magnitude of A12 (0.5: no effect; symmetric around it): below
    0.56 negligible, below 0.64 small, below 0.71 medium, else large (`EFFECT_LIMITS`; a value
    at a limit, up to float error, takes the larger label on either side of 0.5)."""
    if math.isnan(value):
        return "-"
    distance = abs(value - 0.5)
    for limit, label in EFFECT_LIMITS:
        if distance < limit - _SLACK:
            return label
    return "large"


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


def _better(names: tuple[str, str], test: PairTest, maximise: bool) -> str:
    """The better of ``names`` by the test's direction (higher values where ``maximise``)."""
    lean = test.direction if maximise else -test.direction
    return names[0] if lean > 0 else names[1] if lean < 0 else "-"


def _pair_row(
    names: tuple[str, str], a: Sample, b: Sample, *, maximise: bool, paired: bool
) -> tuple[RowDict, str]:
    """One pair's numbers, before the Holm correction, and the better of the two should the
    test's p (Holm) be below `ALPHA` (see `pairwise_table`). The difference and its CI are of
    the sample the test uses: in a paired design the seeds both have."""
    x, y = paired_values(a, b) if paired else (a.values, b.values)
    low, high = median_difference_ci(x, y, paired=paired)
    test = pair_test(x, y, paired=paired)
    row = {
        "a": names[0],
        "b": names[1],
        "n_a": len(a),
        "n_b": len(b),
        "n_pairs": len(x) if paired else None,
        "n_tested": test.tested if paired else None,
        **_summary(a.values, "a"),
        **_summary(b.values, "b"),
        "difference": float(np.median(x) - np.median(y)) if len(x) and len(y) else math.nan,
        "ci_low": low,
        "ci_high": high,
        "p_value": test.p,
        "min_p": test.min_p,
        "a12": a12(a.values, b.values, maximise=maximise),
        "paired_wins": paired_wins(x, y, maximise=maximise) if paired else math.nan,
    }
    oriented = (x - y if maximise else y - x) if paired else None
    row["effect_size"] = row["a12"] if oriented is None else signed_rank_share(oriented)
    return row, _better(names, test, maximise)


def pairwise_table(
    samples: Mapping[str, Sample | ArrayLike],
    *,
    maximise: bool,
    paired: bool = False,
    measure: str = "final best",
) -> list[RowDict]:
    """One row per pair of conditions (in the given order) for one ``measure``.

    ``samples``: condition -> `Sample` (or plain values, seeds 0, 1, ...). Columns: ``n_a``,
    ``n_b`` (runs), ``n_pairs`` (seeds both have; paired only), ``n_tested`` (of those, the
    seeds whose values differ: what the Wilcoxon test rests on), median / mean / sd of each
    (all its runs), the difference of the medians (a - b; paired: on the seeds both have) with
    its CI, the test and its p (raw, ``p_holm`` over the pairs), ``min_p`` / ``p_floor``: the
    smallest raw / Holm p reachable with these sizes, A12 (a run of a beats one of b, all
    runs), ``paired_wins`` (share of seeds a is better on), ``effect_size`` (what ``effect``
    sizes: A12, or in a paired design a's share of the signed ranks, `signed_rank_share`),
    ``effect`` (its size, or `NOT_DETECTABLE`), and ``better``: the condition the test finds
    better where p (Holm) < `ALPHA`, else ``-``.
    """
    found = {name: as_sample(s) for name, s in samples.items()}
    pairs = [
        _pair_row((first, second), found[first], found[second], maximise=maximise, paired=paired)
        for first, second in itertools.combinations(found, 2)
    ]
    rows = [{"measure": measure, **row} for row, _ in pairs]
    test = "Wilcoxon signed-rank" if paired else "Mann-Whitney U"
    adjusted = holm(np.array([row["p_value"] for row in rows]))
    floors = holm_floor([row["min_p"] for row in rows])
    for row, (_, better), p, floor in zip(rows, pairs, adjusted, floors):
        row["test"] = test
        row["p_holm"] = float(p)
        row["p_floor"] = float(floor)
        detectable = math.isfinite(floor) and floor < ALPHA
        row["effect"] = effect_label(row["effect_size"]) if detectable else NOT_DETECTABLE
        row["better"] = better if math.isfinite(p) and p < ALPHA else "-"
    return rows


# --------------------------------------------------------------------------------------------
# What the reader must be told
# --------------------------------------------------------------------------------------------


def _sizes_text(row: Row) -> str:
    pairs = row.get("n_pairs")
    if pairs is not None:
        return f"{pairs} pair{'s' if pairs != 1 else ''}"
    return f"{row['n_a']} vs {row['n_b']} runs"


def _size_floor(row: Row) -> float:
    """The smallest p a pair's test can give with its sizes alone, whatever the values (a
    paired test's own ``min_p`` also leaves out the seeds that tie)."""
    pairs = row.get("n_pairs")
    return min_p_wilcoxon(pairs) if pairs is not None else row["min_p"]


def _reach(rows: Sequence[Row], omnibus: Sequence[Row], test: str) -> str:
    """What no p shown can go below `ALPHA` means for the reader: over every measure's pairs
    and omnibus tests, not the quoted ones alone."""
    pairs_cannot = all(r["p_floor"] >= ALPHA for r in rows if math.isfinite(r["p_floor"]))
    omnibus_can = any(o["min_p"] < ALPHA for o in omnibus if math.isfinite(o["min_p"]))
    if pairs_cannot and not omnibus_can:
        return f": no difference can reach p < {ALPHA:g}, effect sizes are not labelled"
    if pairs_cannot:
        return (
            f": no pair of conditions can reach p < {ALPHA:g} (only the {test} test across "
            "all can), effect sizes are not labelled"
        )
    if any(r["p_floor"] >= ALPHA for r in rows):
        return f": pairs that cannot reach p < {ALPHA:g} get no effect size label"
    return ""


def small_n_warning(
    rows: Sequence[Row],
    runs_per_condition: Mapping[str, int],
    choice: Design,
    omnibus: Sequence[Row] = (),
) -> str | None:
    """One line where a condition has fewer than `FEW_RUNS` runs with a value
    (``runs_per_condition``), or where the sizes alone
    keep a pair from reaching p < `ALPHA` after Holm (5 paired seeds: the Wilcoxon test's
    floor is 2/2^5 = 0.0625): the smallest p the chosen tests can give with these sizes
    whatever the values (for the most limited pair of the first measure in ``rows``; after
    Holm; that measure's ``omnibus`` test), and what is possible, judged over every p of
    ``rows`` and ``omnibus`` (every measure's; a paired pair's seeds that tie count out,
    `tied_pairs_note`)."""
    fewest = min(runs_per_condition.values(), default=FEW_RUNS)
    testable = [r for r in rows if math.isfinite(r["min_p"])]
    first = [r for r in testable if r.get("measure") == testable[0].get("measure")]
    floors = [_size_floor(r) for r in first]
    short = any(p >= ALPHA for p in holm_floor(floors))
    if not rows or (fewest >= FEW_RUNS and not short):
        return None
    tests = [o for o in omnibus if math.isfinite(o["min_p"])]
    if fewest < FEW_RUNS:
        text = f"fewer than {FEW_RUNS} runs per condition (fewest: {fewest})"
    else:
        text = f"too few runs per condition for these tests (fewest: {fewest})"
    if not testable:
        return f"{text}: no pair of conditions has runs on both sides to test"
    weakest = int(np.argmax(floors))
    text += (
        f": {choice.pairwise} cannot give p below {floors[weakest]:.3g} "
        f"({_sizes_text(first[weakest])}, exact, two-sided), "
        f"{holm_floor(floors)[weakest]:.3g} after Holm over "
        f"{len(first)} pair{'s' if len(first) != 1 else ''}"
    )
    # The omnibus test of the first measure, as the pair named (a lineage measure's may
    # have more seeds with a value than the fitness has)
    own = [o for o in tests if o.get("measure") == first[0].get("measure")] or tests
    if own:
        lowest = min(own, key=lambda o: o["min_p"])
        unit = "seeds" if choice.paired else "runs"
        text += (
            f"; {lowest['test']} not below {lowest['min_p']:.3g} (chi-square, "
            f"{lowest['k']} conditions, {lowest['n']} {unit})"
        )
    return text + _reach(testable, tests, choice.omnibus)


def tied_pairs_note(rows: Sequence[Row]) -> str | None:
    """One line naming the paired comparisons that seeds with equal values (dropped by the
    Wilcoxon test) leave unable to reach p < `ALPHA`, though their number of pairs could
    have: they get no effect size label."""
    lost = [
        f"{r['measure']} {r['a']} vs {r['b']} ({r['n_tested']} of {r['n_pairs']} seeds differ)"
        for r in rows
        if r.get("n_tested") is not None
        and r["n_tested"] < r["n_pairs"]
        and r["p_floor"] >= ALPHA
        and min_p_wilcoxon(r["n_pairs"]) < ALPHA
    ]
    if not lost:
        return None
    return (
        f"seeds on which both conditions have the same value do not count in the Wilcoxon "
        f"test, so these cannot reach p < {ALPHA:g} and get no effect size label: "
        + "; ".join(lost)
    )


def pairing_notes(rows: Sequence[Row]) -> list[str]:
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
