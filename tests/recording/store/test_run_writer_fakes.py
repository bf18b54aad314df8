"""`RunWriter` and the Rerun recorder as observers, told the events a run driver says.

The evaluations are made up (no physics): a few frames each. The recorder's writing is
replaced by a fake that keeps its calls, so these tests say what the recorder records and
when, and what the writer writes (the tables, then the manifest and the checkpoint), without
a Rerun file in sight.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from ariel.evaluation import EvaluationResult, EvaluationTask
from ariel.evolution import (
    BatchEvaluated,
    CheckpointDue,
    FlushDue,
    GenerationEnded,
    load_config,
)
from ariel.evolution._state import Body
from ariel.recording.rerun import RerunRecorder
from ariel.recording.store._row_types import RowError
from ariel.recording.store._rows import RunWriter


class FakeRecorder(RerunRecorder):
    """The run's recorder, keeping what it would write instead of writing it."""

    def __init__(self, path: Path, config: Any) -> None:
        super().__init__(path, run_id="run", bodies="all", maximise=True, config=config)
        self.evaluations: list[dict[str, Any]] = []
        self.generations: list[tuple[int, list[str], Any]] = []

    def evaluation(self, **evaluation: Any) -> None:  # type: ignore[override]
        self.evaluations.append(evaluation)

    def generation(self, generation: int, body_rows: Any, archive: Any = None) -> None:  # type: ignore[override]
        self.generations.append((generation, [row["body_id"] for row in body_rows], archive))


class FakeFolder:
    def __init__(self, path: Path) -> None:
        self.path = str(path)
        self.checkpoints: list[dict[str, Any]] = []

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        self.checkpoints.append(state)


def _body(number: int) -> Body:
    body = Body(number, {"genes": [number]}, [], 0)
    body.status, body.fitness, body.evaluations = "ok", float(number), 2
    return body


def _result(task: EvaluationTask, fitness: float) -> EvaluationResult:
    frames = 3
    return EvaluationResult(
        eval_id=task.eval_id,
        fitness=fitness,
        status="ok",
        time=np.linspace(0.0, 0.2, frames),
        core_pos=np.zeros((frames, 3)),
        joint_target=np.zeros((frames, 2)),
        joint_angle=np.zeros((frames, 2)),
        body_pos=np.zeros((frames, 4, 3)),
        body_quat=np.ones((frames, 4, 4)),
    )


def _checkpoint() -> CheckpointDue:
    return CheckpointDue(0, {"generation": 0}, 4, 1.0, 0.5, "mean", {})


@pytest.fixture
def written(tmp_path: Path) -> tuple[Path, FakeRecorder, FakeFolder]:
    config = load_config(overrides=["record.trajectories=true"])
    folder = FakeFolder(tmp_path)
    writer, recorder = RunWriter(folder, config, "run"), FakeRecorder(tmp_path, config)
    bodies = [_body(0), _body(1)]
    for body in bodies:
        tasks = [
            EvaluationTask(body=None, params=(0.1 * k,), eval_id=f"{body.body_id}-c{k}")  # type: ignore[arg-type]
            for k in range(2)
        ]
        results = [_result(t, body.fitness - k) for k, t in enumerate(tasks)]
        event = BatchEvaluated(body, None, tasks, results, 0, 0, 0, 2, body.fitness)
        for observer in (writer, recorder):
            observer.notify(event)
        assert all(r.body_pos is not None for r in results)  # kept until flushed
    assert recorder.evaluations == []  # nothing recorded before the flush
    recorder.notify(FlushDue())
    assert all(e["result"].body_pos is None for e in recorder.evaluations)  # then let go
    ended = GenerationEnded(0, [(b, True, True) for b in bodies], None, None)
    for observer in (writer, recorder):
        observer.notify(ended)
    assert not (tmp_path / "manifests").exists() and not folder.checkpoints  # not yet
    writer.notify(_checkpoint())
    return tmp_path, recorder, folder


def test_the_recorder_gets_each_evaluation_once_with_its_new_best(written) -> None:
    _, recorder, _ = written
    ids = [e["task"].eval_id for e in recorder.evaluations]
    assert ids == ["b000000-c0", "b000000-c1", "b000001-c0", "b000001-c1"]
    assert [e["new_best"] for e in recorder.evaluations] == [True, False, True, False]
    assert [e["row"].eval_id for e in recorder.evaluations] == ids  # its table row with it


def test_the_tables_come_at_the_generation_s_end_then_manifest_and_checkpoint(written) -> None:
    path, recorder, folder = written
    assert recorder.generations == [(0, ["b000000", "b000001"], None)]
    for table in ("evaluations", "bodies", "trajectories"):
        assert (path / table / "gen-000000.parquet").is_file()
    assert (path / "manifests" / "gen-000000.json").is_file()
    assert folder.checkpoints == [{"generation": 0}]
    assert not (path / "archive").exists() and not (path / "novelty").exists()


def test_novelty_rows_with_a_misspelt_key_fail_naming_it(tmp_path: Path) -> None:
    config = load_config()
    writer = RunWriter(SimpleNamespace(path=str(tmp_path)), config, "run")
    row = {"body_id": "b000001", "place": [0.5], "novelty": 0.1, "local_competition": 1}
    with pytest.raises(RowError, match=r"novelty table lacks key 'rank'"):
        writer.write_generation(0, [], novelty=[row | {"in_archive": True}])
    with pytest.raises(RowError, match=r"novelty table has key 'in_achive'"):
        writer.write_generation(0, [], novelty=[row | {"rank": 0, "in_achive": True}])
    assert not (tmp_path / "novelty").exists()
