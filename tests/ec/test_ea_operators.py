"""Upstream ARIEL's variation operators and generators (`ariel.ec`): shapes, types, seeds."""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
import pytest

from ariel.ec import (
    Crossover,
    FloatMutator,
    FloatsGenerator,
    IntegerMutator,
    IntegersGenerator,
    set_seed,
)

PARENT_A = [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]
PARENT_B = [[10.0, 11.0, 12.0], [13.0, 14.0, 15.0]]


def _flat(x: Any) -> np.ndarray:
    return np.asarray(x).ravel()


@pytest.mark.parametrize(
    ("name", "extra"), [("one_point", {}), ("n_point", {"n": 2}), ("uniform", {})]
)
def test_crossovers_keep_shape_and_exchange_genes_position_wise(name: str, extra: dict) -> None:
    op = getattr(Crossover, name)
    c1, c2 = op(PARENT_A, PARENT_B, **extra, seed=5)
    assert np.asarray(c1).shape == (2, 3) and isinstance(c1, list) and isinstance(c1[0], list)
    a, b, x, y = _flat(PARENT_A), _flat(PARENT_B), _flat(c1), _flat(c2)
    # every position holds the two parents' genes, one in each child
    assert np.all(((x == a) & (y == b)) | ((x == b) & (y == a)))
    assert (c1, c2) == op(PARENT_A, PARENT_B, **extra, seed=5)  # same seed, same children


def test_one_point_cuts_once_inside_the_genome() -> None:
    cuts = Counter()
    rng = np.random.default_rng(0)  # one generator threaded through many calls
    for _ in range(300):
        c1, _ = Crossover.one_point(list(range(5)), list(range(10, 15)), seed=rng)
        from_b = [g >= 10 for g in c1]
        assert from_b == sorted(from_b)  # one cut: a's genes then b's
        cuts[from_b.index(True)] += 1
    assert set(cuts) == {1, 2, 3, 4}  # cut in [1, L-1]: children always mix both parents


def test_n_point_alternates_segments() -> None:
    c1, _ = Crossover.n_point([0] * 8, [1] * 8, n=3, seed=2)
    changes = sum(c1[i] != c1[i + 1] for i in range(7))
    assert changes == 3 and c1[0] == 0


def test_integer_genes_stay_integers() -> None:
    c1, c2 = Crossover.uniform([1, 2, 3, 4], [5, 6, 7, 8], seed=1)
    assert all(isinstance(g, int) for g in c1 + c2)


def test_uniform_swap_probability_extremes() -> None:
    assert Crossover.uniform([1, 2], [3, 4], swap_probability=0.0, seed=0) == ([1, 2], [3, 4])
    assert Crossover.uniform([1, 2], [3, 4], swap_probability=1.0, seed=0) == ([3, 4], [1, 2])


def test_order_crossover_gives_permutations_keeping_a_slice() -> None:
    p, q = [0, 1, 2, 3, 4, 5, 6, 7], [7, 6, 5, 4, 3, 2, 1, 0]
    for s in range(20):
        c1, c2 = Crossover.order_crossover(p, q, seed=s)
        assert sorted(c1) == p and sorted(c2) == p


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: Crossover.one_point([1, 2], [1, 2, 3]), "same shape"),
        (lambda: Crossover.one_point([1], [2]), "at least 2 genes"),
        (lambda: Crossover.n_point([1, 2, 3], [4, 5, 6], n=3), r"n must be .* \[1, 2\]"),
        (lambda: Crossover.uniform([1], [2], swap_probability=1.5), r"in \[0, 1\]"),
        (lambda: Crossover.order_crossover([0, 1, 1], [1, 0, 1]), "permutations"),
        (lambda: Crossover.one_point(["a", "b"], ["c", "d"]), "must hold numbers"),
        (lambda: FloatMutator.gaussian([1.0], 0.1, 2.0), "mutation_probability"),
        (lambda: IntegerMutator.random_reset([1], 5, 1, 0.5), "low must be <= high"),
        (lambda: IntegerMutator.integer_creep([1], 0, 0.5), "span must be a whole number >= 1"),
        (lambda: FloatsGenerator.uniform(0, 1, seed=-1), "seed must be"),
        (lambda: set_seed(-3), "seed must be"),
    ],
)
def test_bad_operator_input_names_what_is_wrong(call: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()


def test_float_mutators_change_the_expected_genes() -> None:
    genes = np.zeros((4, 5)).tolist()
    assert FloatMutator.gaussian(genes, 1.0, 0.0, seed=0) == genes  # probability 0: unchanged
    out = np.asarray(FloatMutator.gaussian(genes, 1.0, 1.0, seed=0))
    assert out.shape == (4, 5) and np.all(out != 0.0)
    clipped = np.asarray(
        FloatMutator.gaussian(genes, 5.0, 1.0, lower_bound=-0.5, upper_bound=0.5, seed=0)
    )
    assert clipped.min() >= -0.5 and clipped.max() <= 0.5
    reset = np.asarray(FloatMutator.uniform_reset(genes, 2.0, 3.0, 1.0, seed=1))
    assert np.all((reset >= 2.0) & (reset < 3.0))
    edges = set(np.asarray(FloatMutator.boundary(genes, -1.0, 1.0, 1.0, seed=1)).ravel())
    assert edges == {-1.0, 1.0}
    poly = np.asarray(FloatMutator.polynomial([0.5] * 200, 0.0, 1.0, 1.0, seed=2))
    assert np.all((poly >= 0) & (poly <= 1)) and np.any(poly != 0.5)
    near = np.abs(np.asarray(FloatMutator.polynomial([0.5] * 200, 0, 1, 1.0, 100.0, seed=2)) - 0.5)
    assert near.mean() < np.abs(poly - 0.5).mean()  # a larger index keeps children closer


def test_reordering_mutators_keep_the_genes() -> None:
    genes = list(range(10))
    for op in (IntegerMutator.swap, IntegerMutator.inversion, IntegerMutator.scramble):
        out = op(genes, 1.0, seed=4)
        assert sorted(out) == genes and out != genes and genes == list(range(10))
    assert FloatMutator.inversion([1.0, 2.0], 0.0, seed=0) == [1.0, 2.0]
    assert sorted(FloatMutator.swap([1.0, 2.0, 3.0], 1.0, seed=0)) == [1.0, 2.0, 3.0]


def test_integer_mutators_stay_in_range() -> None:
    out = IntegerMutator.random_reset([0] * 50, 3, 5, 1.0, seed=0)
    assert set(out) == {3, 4, 5}  # both ends included
    creep = np.asarray(IntegerMutator.integer_creep([0] * 200, 2, 1.0, seed=0))
    assert set(np.abs(creep)) == {1, 2}


def test_generators_return_lists_and_repeat_with_a_seed() -> None:
    ints = IntegersGenerator.integers(0, 3, size=100, seed=1)
    assert isinstance(ints, list) and set(ints) == {0, 1, 2, 3}
    assert ints == IntegersGenerator.integers(0, 3, size=100, seed=1)
    assert sorted(IntegersGenerator.permutation(6, seed=2)) == list(range(6))
    assert set(IntegersGenerator.choice([4, 8], size=20, seed=3)) == {4, 8}
    assert np.asarray(FloatsGenerator.uniform(-1, 1, size=(3, 64), seed=0)).shape == (3, 64)
    normal = np.asarray(FloatsGenerator.normal(5.0, 0.1, size=500, seed=0))
    assert abs(normal.mean() - 5.0) < 0.05
    assert min(FloatsGenerator.lognormal(size=50, seed=0)) > 0
    assert FloatsGenerator.linspace(0, 1, 3) == [0.0, 0.5, 1.0]
    assert FloatsGenerator.choice([0.5], size=2, seed=0) == [0.5, 0.5]


def test_set_seed_makes_unseeded_calls_repeat() -> None:
    set_seed(11)
    first = (Crossover.one_point(list(range(9)), list(range(9, 18))), FloatsGenerator.normal())
    set_seed(11)
    assert (Crossover.one_point(list(range(9)), list(range(9, 18))), FloatsGenerator.normal()) == (
        first
    )


@pytest.mark.parametrize(
    ("call", "named"),
    [
        (lambda: FloatMutator.gaussian([1.0, 2.0], float("nan"), 1.0, seed=1), "std"),
        (lambda: FloatMutator.gaussian([1.0, 2.0], float("inf"), 1.0, seed=1), "std"),
        (lambda: FloatMutator.gaussian([1.0], 0.1, 1.0, lower_bound=5, upper_bound=0), "low"),
        (lambda: FloatMutator.polynomial([0.5], 0, 1, 1.0, distribution_index=np.nan), "index"),
        (lambda: FloatMutator.polynomial([0.5], 0, np.inf, 1.0), "high"),
        (lambda: FloatMutator.uniform_reset([0.5], -np.inf, 1, 1.0), "low"),
        (lambda: FloatsGenerator.normal(0, float("nan"), 3), "std"),
        (lambda: FloatsGenerator.lognormal(float("inf"), 1.0), "mean"),
        (lambda: FloatsGenerator.uniform(float("nan"), 1), "low"),
        (lambda: IntegersGenerator.integers(5, 1, 3), "low must be <= high"),
        (lambda: IntegersGenerator.permutation(-1), "n must be"),
        (lambda: IntegersGenerator.choice([1.7, 2.9]), "whole numbers"),
        (lambda: IntegerMutator.random_reset([1.7, 2.2], 0, 5, 0.0), "whole numbers"),
        (lambda: IntegerMutator.random_reset([1, 2], 1.5, 3.5, 1.0), "low must be a whole"),
        (lambda: IntegersGenerator.integers(1.5, 3), "low must be a whole"),
        (lambda: IntegersGenerator.choice(True, 3), "value_set must be"),
        (lambda: FloatMutator.polynomial([0.5], -1e308, 1e308, 1.0), "high - low must be finite"),
        (lambda: FloatsGenerator.linspace(0, float("nan"), 3), "stop"),
        (lambda: FloatsGenerator.linspace(-1e308, 1e308, 3), "stop - start must be finite"),
        (lambda: IntegersGenerator.choice(np.True_, 3), "value_set must be"),
        (lambda: IntegersGenerator.choice(3.0, 3), "value_set must be"),
    ],
)
def test_non_finite_and_reversed_settings_are_refused_not_turned_into_nan_genes(
    call: Any, named: str
) -> None:
    """A NaN or infinite step size or bound made NaN/inf genes that the EA stored; a reversed
    pair of clip bounds clipped every gene to the upper one; a float gene was cut to an int."""
    with pytest.raises(ValueError, match=named):
        call()


def test_numpy_integers_count_as_whole_numbers_and_bools_do_not() -> None:
    from ariel.ec import Individual, Population

    a, b = list(range(6)), list(range(6, 12))
    assert Crossover.n_point(a, b, np.int64(1), seed=0) == Crossover.n_point(a, b, 1, seed=0)
    with pytest.raises(ValueError, match=r"\[1, 5\], not True"):
        Crossover.n_point(a, b, True, seed=0)
    pop = Population(Individual() for _ in range(3))
    assert len(pop.best(n=np.int64(2))) == 2 and len(pop.sample(np.int64(2), seed=0)) == 2


def test_a_probability_that_is_not_a_number_is_named() -> None:
    """It said "'<=' not supported between instances", naming no argument."""
    with pytest.raises(TypeError, match="mutation_probability must be a number in"):
        FloatMutator.gaussian([1.0], 0.1, "x")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="swap_probability must be a number in"):
        Crossover.uniform([1.0, 2.0], [3.0, 4.0], "x")  # type: ignore[arg-type]
