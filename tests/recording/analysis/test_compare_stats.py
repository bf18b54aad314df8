"""`ariel compare`'s tests on synthetic numbers (no run, no simulation): the paired test finds
a paired difference an unpaired one misses; identical conditions rarely differ; the smallest
reachable p is what scipy gives at the extreme; effects are labelled only where a test could
detect them; the omnibus test follows the design."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from ariel.recording.analysis._compare_stats import (
    NOT_DETECTABLE,
    Design,
    Sample,
    effect_label,
    holm,
    holm_floor,
    max_kruskal_h,
    min_p_friedman,
    min_p_kruskal,
    min_p_mann_whitney,
    min_p_wilcoxon,
    omnibus_test,
    pair_p_value,
    pairing_notes,
    pairwise_table,
    small_n_warning,
    tied_pairs_note,
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
    # Kruskal-Wallis, groups of 1, 3 and 2: every split of the ranks 1..6 (no ties) stays at
    # or above chi-square at `max_kruskal_h`; with ties (every value 0, 1 or 2) scipy's tie
    # correction takes H up to N - 1 = 5, the floor stated
    sizes, smallest = (1, 3, 2), 1.0
    for order in itertools.permutations(range(6)):
        groups = np.split(np.array(order, dtype=float), np.cumsum(sizes)[:-1])
        smallest = min(smallest, stats.kruskal(*groups).pvalue)
    assert stats.chi2.sf(max_kruskal_h(sizes), 2) == pytest.approx(smallest)
    tied = 1.0
    for values in itertools.product(range(3), repeat=6):
        if len(set(values)) > 1:
            groups = np.split(np.array(values, dtype=float), np.cumsum(sizes)[:-1])
            tied = min(tied, stats.kruskal(*groups).pvalue)
    assert min_p_kruskal(sizes) == pytest.approx(tied) and tied < smallest


def test_holm_floor_is_m_times_the_smallest_or_a_test_s_own() -> None:
    floor = holm_floor([0.01, 0.2, math.nan])
    assert floor[:2].tolist() == pytest.approx([0.02, 0.2]) and math.isnan(floor[2])
    assert holm_floor([0.5, 0.5]).tolist() == [1.0, 1.0]


def test_holm_floor_is_the_least_holm_p_any_values_give() -> None:
    """A 6-pair Wilcoxon test beside a 7-pair one: said to reach 0.047 (labelled 'large'),
    where Holm's running maximum keeps it at 0.0625 or more."""
    assert holm_floor([2 / 64, 2 / 64, 2 / 128]).tolist() == pytest.approx([0.0625] * 2 + [3 / 64])
    rng = np.random.default_rng(3)
    for _ in range(60):  # every p each test can give, at or above its own floor
        floors = rng.choice([2 / 8, 2 / 32, 2 / 64, 2 / 128, 0.5], rng.integers(1, 5))
        values = sorted({*floors.tolist(), 1.0})
        least = np.full(len(floors), np.inf)
        for p in itertools.product(values, repeat=len(floors)):
            if all(np.asarray(p) >= floors):
                least = np.minimum(least, holm(np.asarray(p)))
        assert holm_floor(floors).tolist() == pytest.approx(least.tolist())


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


def test_five_paired_seeds_are_warned_of_though_not_fewer_than_5() -> None:
    """The shipped inheritance campaign (5 shared seeds) could never be significant, and no
    warning said so: it came only below 5 runs per condition."""
    samples = {c: Sample.of(np.arange(5) + 10.0 * i, SEEDS[:5]) for i, c in enumerate("ab")}
    rows = pairwise_table(samples, maximise=True, paired=True)
    line = small_n_warning(rows, {"a": 5, "b": 5}, Design(True))
    assert line is not None and line.startswith(
        "too few runs per condition for these tests (fewest: 5): Wilcoxon signed-rank cannot "
        "give p below 0.0625 (5 pairs"
    )
    assert line.endswith("no difference can reach p < 0.05, effect sizes are not labelled")
    six = {c: Sample.of(np.arange(6) + 10.0 * i, SEEDS[:6]) for i, c in enumerate("ab")}
    rows = pairwise_table(six, maximise=True, paired=True)
    assert small_n_warning(rows, {"a": 6, "b": 6}, Design(True)) is None


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
    # 25 conditions of 2 tied seeds: scipy says statistic inf, p = 0 (below the floor stated)
    for k, n in ((25, 2), (6, 10)):
        same = {f"c{i}": Sample.of(np.arange(n, dtype=float), SEEDS[:n]) for i in range(k)}
        found = omnibus_test(same, paired=True)
        assert (found["statistic"], found["p_value"]) == (0.0, 1.0)


# --------------------------------------------------------------------------------------------
# Regressions of the numbers audit (each failed on the code before it)
# --------------------------------------------------------------------------------------------


def _brute_mann_whitney(a: np.ndarray, b: np.ndarray) -> float:
    """Two-sided exact p by enumerating every split of the midranks: twice the smaller tail."""
    ranks = stats.rankdata(np.concatenate([a, b]))
    sums = np.array(
        [ranks[list(c)].sum() for c in itertools.combinations(range(len(ranks)), len(a))]
    )
    observed = ranks[: len(a)].sum()
    tails = (sums >= observed - 1e-9).mean(), (sums <= observed + 1e-9).mean()
    return min(1.0, 2 * min(tails))


def _brute_wilcoxon(differences: np.ndarray) -> float:
    """Two-sided exact p by enumerating every sign pattern of the non-zero differences."""
    d = differences[differences != 0]
    ranks = stats.rankdata(np.abs(d))
    signs = (np.arange(2 ** len(d))[:, None] >> np.arange(len(d))) & 1
    sums = (signs * ranks).sum(axis=1)
    observed = ranks[d > 0].sum()
    tails = (sums >= observed - 1e-9).mean(), (sums <= observed + 1e-9).mean()
    return min(1.0, 2 * min(tails))


def test_tied_values_get_the_exact_p_never_below_the_floor_stated() -> None:
    """F1: scipy's Mann-Whitney U goes asymptotic with ties (3 vs 3: p 0.047 under a floor of
    0.1, and "better" named); the exact p counts every split of the midranks."""
    (row,) = pairwise_table(
        {"A": Sample.of([2, 2, 2]), "B": Sample.of([4, 4, 4])}, maximise=True, paired=False
    )
    assert row["p_value"] == pytest.approx(0.1) and row["min_p"] == pytest.approx(0.1)
    assert row["better"] == "-" and row["effect"] == NOT_DETECTABLE
    exact = stats.permutation_test(
        ([2.0, 2, 2], [4.0, 4, 4]),
        lambda x, y, axis: np.mean(x, axis=axis) - np.mean(y, axis=axis),
        permutation_type="independent",
        n_resamples=9999,  # more than the 20 splits: scipy enumerates them all
        vectorized=True,
    )
    assert row["p_value"] == pytest.approx(exact.pvalue)
    big, small = np.array([2.0, 2, 1, 2, 2, 2]), np.array([4.0, 4])  # the audit's 6 vs 2
    (row,) = pairwise_table({"big": big, "small": small}, maximise=True, paired=False)
    assert row["p_value"] == pytest.approx(2 / 28) and row["min_p"] == pytest.approx(2 / 28)
    assert row["better"] == "-"
    rng = np.random.default_rng(7)
    for _ in range(60):  # small samples with many ties, against brute force
        n_a, n_b = rng.integers(1, 6, 2)
        a, b = rng.integers(0, 3, n_a).astype(float), rng.integers(0, 3, n_b).astype(float)
        p = pair_p_value(a, b, paired=False)
        assert p >= min_p_mann_whitney(n_a, n_b)
        if len(set(np.concatenate([a, b]))) > 1:
            assert p == pytest.approx(_brute_mann_whitney(a, b))
        d = rng.integers(-2, 3, int(n_a) + 3).astype(float)
        p = pair_p_value(d, np.zeros(len(d)), paired=True)
        if d.any():
            assert p == pytest.approx(_brute_wilcoxon(d))
            assert p >= min_p_wilcoxon(int((d != 0).sum()))
    # the omnibus test stays at or above its floor when ties push H to its largest
    for groups in ([[1, 1, 1], [2, 2, 2], [3, 3, 3]], [[2, 2, 1, 2, 2, 2], [4, 4], [2]]):
        found = omnibus_test({str(i): g for i, g in enumerate(groups)}, paired=False)
        assert found is not None and found["p_value"] >= found["min_p"]


def test_in_a_paired_design_better_and_the_effect_follow_the_wilcoxon_test() -> None:
    """F2: A beats B by 0.1 on 19 of 20 seeds and loses one badly: Wilcoxon finds A better,
    the pooled A12 leans to B (0.475); better and the effect must be the test's."""
    y = np.arange(1.0, 21.0)
    x = y + 0.1
    x[-1] = -100.0
    (row,) = pairwise_table({"A": Sample.of(x), "B": Sample.of(y)}, maximise=True, paired=True)
    assert row["better"] == "A" and row["a12"] == pytest.approx(0.475)
    assert row["p_value"] == pytest.approx(_brute_wilcoxon(x - y))  # 0.00059: exact, ties
    assert row["paired_wins"] == pytest.approx(0.95)
    assert row["effect_size"] == pytest.approx(190 / 210)  # W+ / (W+ + W-)
    assert row["effect"] == "large"
    (row,) = pairwise_table({"A": Sample.of(x), "B": Sample.of(y)}, maximise=False, paired=True)
    assert row["better"] == "B" and row["effect_size"] == pytest.approx(20 / 210)


def test_seeds_that_tie_do_not_count_towards_the_wilcoxon_floor() -> None:
    """F3: 3 of 6 differences are 0; scipy's Wilcoxon drops them, so its p cannot go below
    2 / 2^3 = 0.25 and no effect may be labelled; a note says so."""
    x = np.array([1.0, 2, 3, 4, 5, 6])
    y = x.copy()
    y[:3] -= 0.5
    (row,) = pairwise_table({"A": Sample.of(x), "B": Sample.of(y)}, maximise=True, paired=True)
    assert (row["n_pairs"], row["n_tested"]) == (6, 3)
    assert row["min_p"] == pytest.approx(0.25) and row["p_value"] == pytest.approx(0.25)
    assert row["effect"] == NOT_DETECTABLE
    note = tied_pairs_note([row])
    assert note is not None and "final best A vs B (3 of 6 seeds differ)" in note


def test_a_paired_estimate_and_its_ci_rest_on_the_same_seeds() -> None:
    """F4: B's seeds 3-5 failed; the difference of the medians is of the 2 seeds both have,
    the sample its CI resamples, so it lies inside it."""
    a = Sample.of([0.0, 1, 10, 10, 10], seeds=[1, 2, 3, 4, 5])
    b = Sample.of([5.0, 5], seeds=[1, 2])
    (row,) = pairwise_table({"A": a, "B": b}, maximise=True, paired=True)
    assert row["difference"] == pytest.approx(-4.5)
    assert row["ci_low"] <= row["difference"] <= row["ci_high"]
    assert row["effect_size"] == 0.0 and row["paired_wins"] == 0.0  # A lost on both pairs


def test_effect_labels_are_symmetric_at_vargha_delaney_s_limits() -> None:
    """F5: A12 = 0.71 is large, as 0.29 is, in either order and fitness direction."""
    a = np.arange(10.0)
    b = np.array([-1, -1, -1, -1, -1, -1, 1.5, 6.5, 10, 10])  # U = 71 of 100
    for first, second, maximise in ((a, b, True), (b, a, True), (a, b, False), (b, a, False)):
        samples = {"A": Sample.of(first), "B": Sample.of(second)}
        (row,) = pairwise_table(samples, maximise=maximise)
        assert row["a12"] == pytest.approx(0.71) or row["a12"] == pytest.approx(0.29)
        assert row["effect"] == "large"
    for value, label in ((0.56, "small"), (0.44, "small"), (0.64, "medium"), (0.36, "medium")):
        assert effect_label(value) == label
    assert effect_label(0.5599) == "negligible" and effect_label(0.7099) == "medium"


def test_the_warning_does_not_deny_an_omnibus_p_below_alpha() -> None:
    """F6: 3 conditions x 3 shared seeds: no pair can reach 0.05, but Friedman can (0.0498,
    reached when every seed ranks the conditions alike); the warning must not say that no
    difference can."""
    samples = {c: Sample.of(np.arange(3) * 10.0 + i, SEEDS[:3]) for i, c in enumerate("abc")}
    rows = pairwise_table(samples, maximise=True, paired=True)
    omnibus = omnibus_test(samples, paired=True)
    assert omnibus is not None and omnibus["p_value"] == pytest.approx(0.0498, abs=1e-4)
    line = small_n_warning(rows, {c: 3 for c in "abc"}, Design(True), [omnibus])
    assert line is not None and "no difference can reach" not in line
    assert "no pair of conditions can reach p < 0.05 (only the Friedman test" in line
    assert all(r["effect"] == NOT_DETECTABLE for r in rows)
    # and the judgement covers every measure's pairs, not the first measure's alone: 3 vs 3
    # runs cannot reach 0.05 (0.1), 4 vs 4 can (2 / 70)
    weak = pairwise_table({"a": [1, 2, 3], "b": [4, 5, 6]}, maximise=True, measure="one")
    strong = pairwise_table({"a": [1, 2, 3, 4], "b": [5, 6, 7, 8]}, maximise=True)
    line = small_n_warning(weak + strong, {"a": 4, "b": 4}, Design(False))
    assert line is not None and "cannot give p below 0.1 (3 vs 3 runs" in line
    assert "no difference can reach" not in line and line.endswith("get no effect size label")
    assert strong[0]["better"] == "b" and strong[0]["effect"] == "large"


def test_auc_counts_failed_evaluations_before_the_first_finished_one() -> None:
    """F7: one AUC, the area under the best-so-far curve over evaluations 1..N divided by N;
    before a run's first finished evaluation the curve stands at the worst fitness any
    compared run finished with."""
    from ariel.recording.analysis._compare_measures import _measures, _run_rows
    from ariel.recording.analysis._compare_runs import RunCurve

    def curve(seed: int, fitness: list[float], status: list[str]) -> RunCurve:
        evaluations = pd.DataFrame(
            {
                "generation": 0,
                "eval_id": [f"b{i:06d}-i000-c000" for i in range(len(fitness))],
                "fitness": fitness,
                "status": status,
            }
        )
        return RunCurve("c", seed, evaluations)

    late = curve(1, [-np.inf] * 8 + [1.0, 1.0], ["error"] * 8 + ["ok", "ok"])
    steady = curve(2, [0.9, 0.2] + [0.9] * 8, ["ok"] * 10)
    rows = _run_rows([late, steady], [late, steady], True, 10)
    assert [r["final_best"] for r in rows] == [1.0, 0.9]
    assert rows[0]["auc"] == pytest.approx((8 * 0.2 + 2 * 1.0) / 10)  # worst finished: 0.2
    assert rows[1]["auc"] == pytest.approx(0.9)
    assert _measures(late, True, 10)["auc"] == pytest.approx(1.0)  # alone: its own worst
    assert _measures(late, False, 10, worst=3.0)["auc"] == pytest.approx((8 * 3 + 2) / 10)


def test_the_small_n_warning_counts_runs_with_a_value() -> None:
    """7 runs of 'a' of which 5 have no finished evaluation: said 'fewest: 7', and named a
    lineage measure's Friedman floor (7 seeds) for a fitness test of 2."""
    from ariel.recording.analysis._compare_measures import _statistics

    rng = np.random.default_rng(1)
    rows = []
    for condition in "abc":
        for seed in range(1, 8):
            lost = condition == "a" and seed > 2
            best = math.nan if lost else float(rng.normal())
            rows.append(
                {"condition": condition, "seed": seed, "final_best": best, "auc": best}
                | {"surviving_lineages": float(rng.integers(1, 4))}
            )
    _, _, notes = _statistics(pd.DataFrame(rows), True, Design(True))
    assert notes[0].startswith("fewer than 5 runs per condition (fewest: 2)"), notes
    assert "Friedman not below" in notes[0] and "2 seeds)" in notes[0], notes


def test_best_so_far_curves_follow_the_auc_s_rule_for_failed_evaluations() -> None:
    """One run of a condition without a finished evaluation took that condition's whole 95 %
    band away, and a run finishing late pulled its median up from its own floor."""
    from ariel.recording.analysis._compare_measures import _best_curves
    from ariel.recording.analysis._compare_runs import RunCurve

    def curve(seed: int, fitness: list[float], status: list[str]) -> RunCurve:
        ids = [f"b{i:06d}-i000-c000" for i in range(len(fitness))]
        frame = pd.DataFrame({"generation": 0, "eval_id": ids, "fitness": fitness})
        return RunCurve("a", seed, frame.assign(status=status))

    lost = curve(1, [-np.inf] * 10, ["error"] * 10)
    late = curve(2, [-np.inf] * 5 + [1.0] * 5, ["error"] * 5 + ["ok"] * 5)
    steady = [curve(s, [0.2] * 10, ["ok"] * 10) for s in (3, 4)]
    _, median, low, high = _best_curves({"a": [lost, late, *steady]}, True, 10)["a"]
    assert np.isfinite(low).all() and np.isfinite(high).all()  # three runs with a value
    assert median[0] == 0.2 and median[-1] == 0.2  # the late run at the worst (0.2) at first
    assert high[-1] == 1.0
