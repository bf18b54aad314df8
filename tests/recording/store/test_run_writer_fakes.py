"""`RunWriter` with a fake Rerun recorder behind it, told what a run driver tells it.

The evaluations are made up (no physics): a few frames each. The fake recorder keeps its
calls, so these tests say what the writer hands the recorder, when, and what it writes
itself (the tables and manifests), without a Rerun file in sight.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from ariel.evaluation import EvaluationResult, EvaluationTask
from ariel.evolution import load_config
from ariel.evolution._state import Body
from ariel.recording.store._row_types import RowError
from ariel.recording.store._rows import RunWriter


class FakeRecorder:
    """A Rerun recorder that keeps its calls."""

    record_bodies = True

    def __init__(self) -> None:
        self.evaluations: list[dict[str, Any]] = []
        self.generations: list[tuple[int, list[str], Any]] = []

    def evaluation(self, **evaluation: Any) -> None:
        self.evaluations.append(evaluation)

    def generation(self, generation: int, body_rows: Any, archive: Any = None) -> None:
        self.generations.append((generation, [row["body_id"] for row in body_rows], archive))


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


@pytest.fixture
def written(tmp_path: Path) -> tuple[Path, FakeRecorder, list[Body]]:
    config = load_config(overrides=["record.trajectories=true"])
    recorder = FakeRecorder()
    writer = RunWriter(SimpleNamespace(path=str(tmp_path)), config, "run", recorder=recorder)
    assert writer.record_bodies  # asked of the recorder
    bodies = [_body(0), _body(1)]
    for body in bodies:
        tasks = [
            EvaluationTask(body=None, params=(0.1 * k,), eval_id=f"{body.body_id}-c{k}")  # type: ignore[arg-type]
            for k in range(2)
        ]
        results = [_result(t, body.fitness - k) for k, t in enumerate(tasks)]
        writer.evaluated(body, None, tasks, results, generation=0, iteration=0, improved=0)
        assert all(r.body_pos is not None for r in results)  # kept until flushed
    assert recorder.evaluations == []  # nothing recorded before the flush
    writer.flush()
    assert all(e["result"].body_pos is None for e in recorder.evaluations)  # then let go
    writer.write_generation(0, [(b, True, True) for b in bodies])
    return tmp_path, recorder, bodies


def test_the_recorder_gets_each_evaluation_once_with_its_new_best(written) -> None:
    _, recorder, _ = written
    ids = [e["task"].eval_id for e in recorder.evaluations]
    assert ids == ["b000000-c0", "b000000-c1", "b000001-c0", "b000001-c1"]
    assert [e["new_best"] for e in recorder.evaluations] == [True, False, True, False]
    assert [e["row"].eval_id for e in recorder.evaluations] == ids  # its table row with it


def test_the_generation_goes_to_the_tables_then_the_recorder(written) -> None:
    path, recorder, _ = written
    assert recorder.generations == [(0, ["b000000", "b000001"], None)]
    for table in ("evaluations", "bodies", "trajectories"):
        assert (path / table / "gen-000000.parquet").is_file()
    assert (path / "manifests" / "gen-000000.json").is_file()
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
