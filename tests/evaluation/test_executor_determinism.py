"""Same evaluation tasks => bit-identical results on every executor and worker count."""

from __future__ import annotations

import numpy as np
import pytest

from ariel.evaluation import (
    BodySpec,
    EvaluationTask,
    build,
    evaluate,
    evaluate_batch,
    make_executor,
)
from ariel.evaluation.executors import map_ordered


def _tasks() -> list[EvaluationTask]:
    nde = BodySpec("nde", np.random.default_rng(2).random((3, 64)), {"number_of_modules": 10})
    gecko = BodySpec("prebuilt", "gecko")
    params = np.random.default_rng(3).uniform(-1, 1, (3, 40))
    tasks = [
        EvaluationTask(body=gecko, params=p, duration=0.5, seed=i) for i, p in enumerate(params)
    ]
    nu = build(EvaluationTask(body=nde)).model.nu
    nde_params = np.random.default_rng(4).uniform(-1, 1, 5 * nu)  # na_cpg: 5 per actuator
    tasks.append(EvaluationTask(body=nde, params=nde_params, duration=0.5))
    # A genotype that cannot be built is an "error" result wherever it runs.
    tasks.append(EvaluationTask(body=BodySpec("prebuilt", "dragon"), duration=0.5))
    return tasks


def _fingerprint(results) -> list[tuple]:
    return [(r.status, r.fitness, r.core_pos.tobytes(), r.joint_angle.tobytes()) for r in results]


@pytest.fixture(scope="module")
def reference() -> list[tuple]:
    results = [evaluate(t) for t in _tasks()]
    assert [r.status for r in results] == ["ok"] * 4 + ["error"]
    return _fingerprint(results)


@pytest.mark.parametrize(
    ("kind", "workers"), [("serial", 1), ("local", 1), ("local", 2), ("dask", 2)]
)
def test_results_do_not_depend_on_the_executor(kind: str, workers: int, reference) -> None:
    if kind == "dask":
        pytest.importorskip("dask.distributed", reason="Dask is the optional 'distributed' extra")
    with make_executor(kind, workers=workers) as executor:
        results = list(map_ordered(executor, evaluate, _tasks()))
    assert _fingerprint(results) == reference


def test_a_whole_batch_in_a_worker_equals_single_evaluations(reference) -> None:
    with make_executor("local", workers=2) as executor:
        (batch,) = list(map_ordered(executor, evaluate_batch, [_tasks()]))
    assert _fingerprint(batch) == reference
