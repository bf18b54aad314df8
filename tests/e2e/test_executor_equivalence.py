"""One config gives the same run on every executor: serial, local processes, Dask.

Same eval ids, bit-identical fitness and controller parameters, the same bodies, lineage and
selection, whatever runs the evaluations and in which order their results come back.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from _helpers import plain_rows

from ariel.evolution import run_experiment
from ariel.recording import load_run

# 2 + 2 x 1 bodies with 3-4 joints, 4 x 2 brain evaluations each. Generation 0 learns two
# brains side by side (a batch per worker); later generations one brain, whose batches are
# split over both workers and put back together.
CONFIG = {
    "name": "executors",
    "seed": 11,
    "generations": 3,
    "body": {"options": {"number_of_modules": 10}, "population": 2, "offspring": 1},
    "brain": {"popsize": 4, "iterations": 2, "inherit": True},
    "task": {"duration": 0.5},
}

EVALUATION_COLUMNS = [
    "eval_id",
    "generation",
    "body_id",
    "parent_ids",
    "body_genotype",
    "controller_params",
    "fitness",
    "status",
    "seed",
]
BODY_COLUMNS = [
    "generation",
    "body_id",
    "parent_ids",
    "body_genotype",
    "fitness",
    "best_eval_id",
    "evaluations",
    "is_new",
    "selected",
]

needs_dask = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="dask/distributed is not installed (optional extra ariel[distributed])",
)


def _records(run_dir: Path) -> dict[str, list[tuple]]:
    run = load_run(run_dir)
    return {
        "evaluations": plain_rows(run.evaluations, EVALUATION_COLUMNS, ["eval_id"]),
        "bodies": plain_rows(run.bodies, BODY_COLUMNS, ["generation", "body_id"]),
        "trajectories": plain_rows(
            run.trajectories, list(run.trajectories.columns), ["eval_id", "t"]
        ),
    }


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple]]:
    out = tmp_path_factory.mktemp("serial") / "run"
    result = run_experiment(CONFIG, out=out, executor="serial")
    records = _records(result.run_dir)
    assert len(records["evaluations"]) == (2 + 2 * 1) * 4 * 2
    assert len({row[0] for row in records["evaluations"]}) == len(records["evaluations"])
    return records


@pytest.mark.parametrize(
    "kind",
    [
        pytest.param("local", marks=pytest.mark.slow),
        pytest.param("dask", marks=[pytest.mark.slow, needs_dask]),
    ],
)
def test_every_executor_gives_the_serial_run(serial, kind: str, tmp_path: Path) -> None:
    result = run_experiment(CONFIG, out=tmp_path / kind, executor=kind, workers=2)
    assert result.status == "finished"
    assert load_run(result.run_dir).info["executor"] == {
        "kind": kind,
        "workers": 2,
        "address": None,
    }
    records = _records(result.run_dir)
    for table, rows in serial.items():
        assert len(records[table]) == len(rows), table
        for mine, expected in zip(records[table], rows):
            assert mine == expected, f"{kind}, {table}: {mine[:3]} differs from the serial run"
