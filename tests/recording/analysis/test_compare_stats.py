"""`ariel compare`'s tests on synthetic numbers (no run, no simulation): the paired test finds
a paired difference an unpaired one misses; identical conditions rarely differ; the smallest
reachable p is what scipy gives at the extreme; effects are labelled only where a test could
detect them; the omnibus test follows the design."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import stats

from ariel.recording.analysis._compare_stats import (
    NOT_DETECTABLE,
    Design,
    Sample,
    holm,
    holm_floor,
    min_p_friedman,
    min_p_kruskal,
    min_p_mann_whitney,
    min_p_wilcoxon,
    omnibus_test,
    pair_p_value,
    pairing_notes,
    pairwise_table,
    small_n_warning,
)

SEEDS = list(range(1, 11))


def paired_data(rng: np.random.Generator, shift: float, n: int = 10) -> dict[str, Sample]:
    """Two conditions on the same seeds: a large seed effect (sd 1), a small shift of
    condition "a" and little noise (sd 0.01): common random numbers."""
    seed_effect = rng.normal(0.0, 1.0, n)
    return {
        "a": Sample.of(seed_effect + shift + rng.normal(0, 0.01, n), SEEDS[:n]),
        "b": Sample.of(seed_effect + rng.normal(0, 0.01, n), SEEDS[:n]),
    }


def test_a_paired_difference_is_found_by_wilcoxon_and_missed_by_mann_whitney() -> None:
    samples = paired_data(np.random.default_rng(1), shift=0.1)
    paired = pair_p_value(samples["a"], samples["b"], paired=True)
    unpaired = pair_p_value(samples["a"], samples["b"], paired=False)
    assert paired == pytest.approx(2 / 2**10)  # a better on every seed: the exact minimum
    assert unpaired > 0.05  # the seed effect hides the shift from an unpaired test
    (row,) = pairwise_table(samples, maximise=True, paired=True)
    assert row["test"] == "Wilcoxon signed-rank" and row["n_pairs"] == 10
    assert row["p_holm"] < 0.05 and row["better"] == "a" and row["paired_wins"] == 1.0
    assert row["ci_low"] > 0  # the seeds resampled together: the CI excludes no difference
    (row,) = pairwise_table(samples, maximise=True, paired=False)
    assert row["test"] == "Mann-Whitney U" and row["n_pairs"] is None
    assert row["p_holm"] > 0.05 and row["better"] == "-"


@pytest.mark.parametrize("paired", [True, False])
def test_identical_conditions_differ_in_at_most_5_percent_of_200_repetitions(
    paired: bool,
) -> None:
    """3 conditions x 8 seeds from one distribution (paired: sharing a seed effect); a false
    difference is any pair with p (Holm) < 0.05. Over 3,000 repetitions the rate is 3.8 %
    for both designs (Holm over 3 pairs of exact tests keeps it below 5 %)."""
    rng = np.random.default_rng(2024)
    false = 0
    for _ in range(200):
        shared = rng.normal(0.0, 1.0, 8) if paired else np.zeros(8)
        samples = {c: Sample.of(shared + rng.normal(0, 1, 8), SEEDS[:8]) for c in "abc"}
        p = [
            pair_p_value(samples[x], samples[y], paired=paired)
            for x, y in itertools.combinations(samples, 2)
        ]
        false += bool((holm(np.array(p)) < 0.05).any())
    assert false <= 10, f"{false} of 200 repetitions found a difference that is not there"


def test_the_smallest_p_is_what_scipy_gives_at_the_extreme() -> None:
    assert min_p_mann_whitney(2, 2) == pytest.approx(1 / 3)
    assert min_p_mann_whitney(5, 5) == pytest.approx(2 / 252)
    assert min_p_mann_whitney(1, 1) == 1.0 and math.isnan(min_p_mann_whitney(0, 3))
    for n_a, n_b in ((2, 2), (3, 4), (5, 5)):
        separated = stats.mannwhitneyu(np.arange(n_a), n_a + np.arange(n_b)).pvalue
        assert min_p_mann_whitney(n_a, n_b) == pytest.approx(separated)
    assert min_p_wilcoxon(2) == 0.5 and min_p_wilcoxon(10) == pytest.approx(2 / 1024)
    for n in (1, 2, 4, 6):
        assert min_p_wilcoxon(n) == pytest.approx(stats.wilcoxon(np.arange(1, n + 1)).pvalue)
    concordant = [np.full(4, rank, dtype=float) + np.arange(4) * 10 for rank in range(3)]
    assert min_p_friedman(3, 4) == pytest.approx(stats.friedmanchisquare(*concordant).pvalue)
    # Kruskal-Wallis, groups of 1, 3 and 2: every split of the ranks 1..6, the smallest p
    sizes, smallest = (1, 3, 2), 1.0
    for order in itertools.permutations(range(6)):
        groups = np.split(np.array(order, dtype=float), np.cumsum(sizes)[:-1])
        smallest = min(smallest, stats.kruskal(*groups).pvalue)
    assert min_p_kruskal(sizes) == pytest.approx(smallest)


def test_holm_floor_is_m_times_the_smallest_or_a_test_s_own() -> None:
    floor = holm_floor([0.01, 0.2, math.nan])
    assert floor[:2].tolist() == pytest.approx([0.02, 0.2]) and math.isnan(floor[2])
    assert holm_floor([0.5, 0.5]).tolist() == [1.0, 1.0]


@pytest.mark.parametrize(
    ("pairs", "paired", "minimum"),
    [(2, True, 0.5), (4, True, 0.125), (2, False, 1 / 3), (3, False, 0.1)],
)
def test_below_5_runs_a_warning_says_the_smallest_p_and_effects_are_not_labelled(
    pairs: int, paired: bool, minimum: float
) -> None:
    samples = {
        "a": Sample.of(np.arange(pairs) + 10.0, SEEDS[:pairs]),
        "b": Sample.of(np.arange(pairs) + 0.0, SEEDS[:pairs]),
    }
    rows = pairwise_table(samples, maximise=True, paired=paired)
    choice = Design(paired)
    line = small_n_warning(rows, {"a": pairs, "b": pairs}, choice)
    assert line is not None and "\n" not in line
    assert f"{choice.pairwise} cannot give p below {minimum:.3g}" in line, line
    assert "no difference can reach p < 0.05" in line
    (row,) = rows
    assert row["a12"] == 1.0 and row["effect"] == NOT_DETECTABLE  # no "large" from 2 runs
    assert row["min_p"] == pytest.approx(minimum)


def test_effects_are_labelled_where_the_test_can_reach_significance() -> None:
    def effect(n: int, paired: bool, conditions: int = 2) -> str:
        samples = {
            c: Sample.of(np.arange(n) + 10.0 * i, SEEDS[:n])
            for i, c in enumerate("abc"[:conditions])
        }
        return pairwise_table(samples, maximise=True, paired=paired)[0]["effect"]

    assert effect(5, paired=False) == "large"  # 2 / C(10, 5) = 0.008
    assert effect(5, paired=True) == NOT_DETECTABLE  # 5 pairs: 2 / 2^5 = 0.0625
    assert effect(6, paired=True) == "large"  # 6 pairs: 0.031
    assert effect(6, paired=True, conditions=3) == NOT_DETECTABLE  # Holm over 3: 0.094
    rows = [{"n_a": 5, "n_b": 5, "min_p": 0.008, "p_floor": 0.008, "n_pairs": None}]
    assert small_n_warning(rows, {"a": 5, "b": 5}, Design(False)) is None


def test_pairs_use_the_seeds_both_conditions_have_and_say_so() -> None:
    samples = {
        "a": Sample.of([1.0, 2.0, 3.0, 4.0, 5.0], [1, 2, 3, 4, 5]),
        "b": Sample.of([0.5, 1.5, np.nan, 3.5, 4.5], [1, 2, 3, 4, 5]),  # seed 3 failed
    }
    (row,) = pairwise_table(samples, maximise=True, paired=True)
    assert (row["n_a"], row["n_b"], row["n_pairs"]) == (5, 4, 4)
    assert row["p_value"] == pytest.approx(2 / 2**4)
    assert pairing_notes([row]) == ["a vs b: paired on the 4 seeds both have (5 and 4 runs)"]


def test_the_omnibus_test_is_friedman_for_shared_seeds_and_kruskal_for_independent() -> None:
    rng = np.random.default_rng(5)
    samples = {c: Sample.of(rng.normal(i, 0.1, 6), SEEDS[:6]) for i, c in enumerate("abc")}
    friedman = omnibus_test(samples, paired=True)
    values = [s.values for s in samples.values()]
    assert friedman["test"] == "Friedman" and (friedman["k"], friedman["n"]) == (3, 6)
    assert friedman["p_value"] == pytest.approx(stats.friedmanchisquare(*values).pvalue)
    kruskal = omnibus_test(samples, paired=False)
    assert kruskal["test"] == "Kruskal-Wallis" and kruskal["n"] == 18
    assert kruskal["p_value"] == pytest.approx(stats.kruskal(*values).pvalue)
    assert omnibus_test(dict(list(samples.items())[:2]), paired=True) is None  # k = 2
    tied = {c: Sample.of(np.ones(3), SEEDS[:3]) for c in "abc"}
    assert omnibus_test(tied, paired=True)["p_value"] == 1.0
    assert omnibus_test(tied, paired=False)["p_value"] == 1.0
