"""Runs whose evaluations kill or hang their worker: a worker killed once changes nothing, an
evaluation that always kills its worker or hangs becomes one ``error`` row, and the run
finishes with every other evaluation as in a serial run.

The faults come from a fitness plugin (an entry point of a throwaway distribution, so worker
processes find it too) that computes ``xy_displacement`` and, as told by its options, SIGKILLs
its process the first time any evaluation reaches it (``mode="once"``), or every time the one
evaluation whose fitness is ``target`` reaches it (``"kill"``), or sleeps for an hour there
(``"hang"``).
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Any

import pytest
from _helpers import plain_rows

from ariel.evolution import run_experiment
from ariel.recording import load_run

# 2 + 1 bodies with 3-4 joints, 4 x 2 brain evaluations each: generation 0 learns two brains
# side by side (a call of 4 evaluations each), generation 1 one brain in two calls of 2.
CONFIG: dict[str, Any] = {
    "name": "faults",
    "seed": 11,
    "generations": 2,
    "body": {"options": {"number_of_modules": 10}, "population": 2, "offspring": 1},
    "brain": {"popsize": 4, "iterations": 2},
    "task": {"duration": 0.5},
    "record": {"rerun": False},
}
COLUMNS = ["eval_id", "generation", "body_id", "controller_params", "fitness", "status", "error"]
BODY_COLUMNS = ["generation", "body_id", "fitness", "best_eval_id", "evaluations", "selected"]

PLUGIN = """
    import multiprocessing
    import os
    import signal
    import time

    from ariel.evaluation.builtin_plugins import xy_displacement


    def faulty_displacement(record, mode="once", marker="", target=""):
        value = xy_displacement(record)
        if multiprocessing.parent_process() is None:
            return value  # the run's plugin check, in the driver: only workers are hit
        if mode == "once":
            try:
                os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            except FileExistsError:
                return value
            os.kill(os.getpid(), signal.SIGKILL)
        if value.hex() == target:
            if mode == "kill":
                os.kill(os.getpid(), signal.SIGKILL)
            if mode == "hang":
                time.sleep(3600)
        return value


    faulty_displacement.maximise = True
"""

needs_dask = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="dask/distributed is not installed (optional extra ariel[distributed])",
)


def _table(frame: Any, columns: list[str], order: list[str]) -> dict[tuple, tuple]:
    return {row[: len(order)]: row for row in plain_rows(frame, columns, order)}


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> Any:
    out = tmp_path_factory.mktemp("serial") / "run"
    return load_run(run_experiment(CONFIG, out=out, executor="serial").run_dir)


@pytest.fixture
def faulty(fake_distribution) -> None:
    fake_distribution(
        "ariel_fault_plugin",
        "0.1",
        source=PLUGIN,
        entry_points={
            "ariel.fitness": {"faulty_displacement": "ariel_fault_plugin:faulty_displacement"}
        },
    )


def _with_fitness(options: dict[str, str], **executor: Any) -> dict[str, Any]:
    task = {**CONFIG["task"], "fitness": "faulty_displacement", "options": options}
    return {**CONFIG, "task": task, "executor": executor}


def _chosen(serial: Any) -> Any:
    """An evaluation of generation 1's last CMA-ES iteration that is not its body's best:
    failing it changes no later ask, no body fitness and no selection."""
    evals, bodies = serial.evaluations, serial.bodies
    best = set(bodies["best_eval_id"])
    late = evals[(evals["generation"] == 1) & (evals["iteration"] == 1)]
    row = late[~late["eval_id"].isin(best)].iloc[0]
    assert (evals["fitness"] == row["fitness"]).sum() == 1  # the target names one evaluation
    return row


def _compare(run: Any, serial: Any, *, except_eval: str | None = None) -> None:
    mine = _table(run.evaluations, COLUMNS, ["eval_id"])
    theirs = _table(serial.evaluations, COLUMNS, ["eval_id"])
    assert mine.keys() == theirs.keys()
    for key, row in theirs.items():
        if key[0] != except_eval:
            assert mine[key] == row, key
    bodies = _table(run.bodies, BODY_COLUMNS, ["generation", "body_id"])
    assert bodies == _table(serial.bodies, BODY_COLUMNS, ["generation", "body_id"])


@pytest.mark.slow
def test_a_worker_killed_mid_evaluation_changes_nothing(serial, faulty, tmp_path: Path) -> None:
    marker = tmp_path / "killed"
    config = _with_fitness({"mode": "once", "marker": str(marker)}, kind="local", workers=2)
    result = run_experiment(config, out=tmp_path / "run")
    assert marker.exists()  # a worker was killed (SIGKILL) during an evaluation ...
    assert result.status == "finished"
    _compare(load_run(result.run_dir), serial)  # ... which ran again: the same records


@pytest.mark.slow
def test_an_evaluation_that_always_kills_its_worker_is_an_error_row(
    serial, faulty, tmp_path: Path
) -> None:
    chosen = _chosen(serial)
    options = {"mode": "kill", "target": float(chosen["fitness"]).hex()}
    config = _with_fitness(options, kind="local", workers=2, max_retries=1)
    result = run_experiment(config, out=tmp_path / "run")
    assert result.status == "finished"
    run = load_run(result.run_dir)
    row = run.evaluations.set_index("eval_id").loc[chosen["eval_id"]]
    assert row["status"] == "error"
    assert row["fitness"] == -math.inf
    assert row["error"] == (
        "worker lost: worker process died 2 times running this call (last: killed by SIGKILL)"
    )
    _compare(run, serial, except_eval=chosen["eval_id"])
    assert list(run.generations["errors"]) == [0, 1]


@pytest.mark.slow
def test_an_evaluation_that_hangs_times_out_as_an_error_row(serial, faulty, tmp_path: Path) -> None:
    chosen = _chosen(serial)
    options = {"mode": "hang", "target": float(chosen["fitness"]).hex()}
    config = _with_fitness(options, kind="local", workers=2, timeout=2.0)
    result = run_experiment(config, out=tmp_path / "run")  # would take an hour without it
    assert result.status == "finished"
    run = load_run(result.run_dir)
    row = run.evaluations.set_index("eval_id").loc[chosen["eval_id"]]
    assert row["status"] == "error" and row["fitness"] == -math.inf
    assert row["error"] == "timeout: no result after 2 s; the worker was stopped"
    _compare(run, serial, except_eval=chosen["eval_id"])


@pytest.mark.slow
@needs_dask
def test_a_dask_worker_lost_mid_generation_changes_nothing(serial, faulty, tmp_path: Path) -> None:
    marker = tmp_path / "killed"
    config = _with_fitness({"mode": "once", "marker": str(marker)}, kind="dask", workers=2)
    result = run_experiment(config, out=tmp_path / "run")
    assert marker.exists()  # a Dask worker process was killed mid-evaluation; its nanny
    assert result.status == "finished"  # restarted it and the scheduler ran the task again
    _compare(load_run(result.run_dir), serial)
