"""Brain CMA-ES runs: own generator, picklable, independent of other runs' timing."""

from __future__ import annotations

import pickle

import numpy as np

from ariel.evolution import BrainRun


def sphere(x: np.ndarray) -> np.ndarray:
    return -np.sum((x - 1.0) ** 2, axis=1)


def make(seed: int = 1) -> BrainRun:
    return BrainRun(n_params=5, popsize=6, maximise=True, x0=np.zeros(5), sigma0=0.5, seed=seed)


def test_cma_es_improves_and_tracks_its_best() -> None:
    run = make()
    first = None
    for _ in range(30):
        x = run.ask()
        assert x.shape == (6, 5) and x.dtype == np.float64
        f = sphere(x)
        first = f.max() if first is None else first
        run.tell(x, f)
    assert run.iteration == 30
    assert run.best_fitness > first and run.best_fitness > -0.05
    np.testing.assert_allclose(run.best_params, 1.0, atol=0.3)


def test_interleaved_runs_ask_what_sequential_runs_ask_and_leave_numpy_global_rng_alone() -> None:
    np.random.seed(123)
    state = np.random.get_state()[1].copy()
    a, b = make(1), make(2)
    interleaved = []
    for _ in range(5):
        for run in (a, b):
            x = run.ask()
            interleaved.append((id(run), x))
            run.tell(x, sphere(x))
    assert np.array_equal(np.random.get_state()[1], state)
    solo = make(1)
    for _ in range(5):
        x = solo.ask()
        expected = next(xs for key, xs in interleaved if key == id(a))
        interleaved.remove((id(a), expected))
        np.testing.assert_array_equal(x, expected)
        solo.tell(x, sphere(x))


def test_a_pickled_run_continues_exactly_like_the_original() -> None:
    run = make()
    for _ in range(3):
        x = run.ask()
        run.tell(x, sphere(x))
    copy = pickle.loads(pickle.dumps(run))
    np.testing.assert_array_equal(run.ask(), copy.ask())


def test_failed_candidates_rank_last_and_minimising_fitness_is_supported() -> None:
    run = BrainRun(n_params=3, popsize=4, maximise=False, x0=np.zeros(3), sigma0=1.0, seed=3)
    x = run.ask()
    f = np.array([2.0, np.inf, 1.0, np.nan])
    assert run.tell(x, f) == 2
    assert run.best_fitness == 1.0
    np.testing.assert_array_equal(run.best_params, x[2])


def test_a_body_without_parameters_gets_one_empty_candidate() -> None:
    run = BrainRun(n_params=0, popsize=8, maximise=True, x0=np.zeros(0), sigma0=1.0, seed=0)
    assert run.batch_size == 1 and run.ask().shape == (1, 0)
    assert run.tell(np.zeros((1, 0)), np.array([0.1])) == 0
    assert run.best_fitness == 0.1
