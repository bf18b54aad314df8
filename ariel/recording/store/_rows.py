"""Rows of a run's tables, built as their declarations say (`_row_types`), and the writer that
collects one generation's rows and writes them when the generation ends.

The writer is one of the run driver's observers (`ariel.evolution.RunObserver`): the driver
says what happened (a batch of evaluations of a body, a body that could not be built, the end
of a generation, a checkpoint due); the writer decides what the tables look like. Rows are
written in id order, so the order in which results arrived never shows in a table.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from ariel.evolution import (
    BatchEvaluated,
    Body,
    BodyFailed,
    CheckpointDue,
    ExperimentConfig,
    GenerationEnded,
    RunEvent,
)
from ariel.recording.store._manifest import write_manifest
from ariel.recording.store._row_types import (
    ArchiveRow,
    BodyRow,
    EvaluationRow,
    NoveltyRow,
    table_columns,
)
from ariel.recording.store._tables import trajectory_columns, write_table

if TYPE_CHECKING:
    from ariel.evaluation import EvaluationResult, EvaluationTask

__all__ = ["RunWriter", "body_row", "body_rows_of", "error_row", "evaluation_row"]


class RunFiles(Protocol):
    """Where the writer writes: a run folder (`RunFolder`)."""

    @property
    def path(self) -> str | os.PathLike[str]: ...
    def save_checkpoint(self, state: Mapping[str, object]) -> None: ...


def _common(
    run_id: str, config: ExperimentConfig, body: Body, generation: int
) -> dict[str, object]:
    return {
        "run_id": run_id,
        "generation": generation,
        "body_id": body.body_id,
        "parent_ids": list(body.parent_ids),
        "body_encoder": config.body.encoder,
        "body_genotype": json.dumps(body.genotype),
    }


def evaluation_row(
    run_id: str,
    config: ExperimentConfig,
    body: Body,
    task: EvaluationTask,
    result: EvaluationResult,
    generation: int,
    iteration: int,
    k: int,
) -> EvaluationRow:
    """Candidate ``k`` of iteration ``iteration`` of ``body``'s brain run."""
    return EvaluationRow.of(
        {
            **_common(run_id, config, body, generation),
            "eval_id": task.eval_id,
            "iteration": iteration,
            "candidate": k,
            "controller": config.brain.controller,
            "controller_params": list(task.params),
            "world": config.world.name,
            "fitness_fn": config.task.fitness,
            "settle_seconds": float(config.task.settle),
            "fitness": float(result.fitness),
            "status": result.status,
            "error": result.error,
            "descriptors": body.descriptors,
            "n_joints": body.n_joints,
            "joint_names": list(body.joint_names),
            "seed": task.seed,
            "sim_seconds": float(result.sim_time),
            "wall_seconds": float(result.wall_time),
            "backend": result.backend,
        }
    )


def error_row(
    run_id: str, config: ExperimentConfig, body: Body, generation: int, worst: float
) -> EvaluationRow:
    """An unbuildable body still appears in the evaluations table, with its error."""
    return EvaluationRow.of(
        {
            **_common(run_id, config, body, generation),
            "eval_id": f"{body.body_id}-build",
            "iteration": 0,
            "candidate": 0,
            "controller": config.brain.controller,
            "controller_params": [],
            "world": config.world.name,
            "fitness_fn": config.task.fitness,
            "settle_seconds": float(config.task.settle),
            "fitness": worst,
            "status": "error",
            "error": body.error,
            "descriptors": {},  # no body: nulls
            "n_joints": 0,
            "joint_names": [],
            "seed": 0,
            "sim_seconds": 0.0,
            "wall_seconds": 0.0,
            "backend": None,  # no physics ran
        }
    )


def body_row(
    run_id: str,
    config: ExperimentConfig,
    body: Body,
    generation: int,
    is_new: bool,
    selected: bool,
) -> BodyRow:
    """``body`` in generation ``generation``: new in it, kept after it (``selected``)."""
    return BodyRow.of(
        {
            **_common(run_id, config, body, generation),
            "born_generation": body.born,
            "graph": body.graph,
            "descriptors": body.descriptors,
            "n_joints": body.n_joints,
            "status": body.status,
            "error": body.error,
            "fitness": body.fitness,
            "best_eval_id": body.best_eval_id,
            "evaluations": body.evaluations,
            "is_new": is_new,
            "selected": selected,
        }
    )


class RunWriter:
    """Collects a generation's rows (and recorded frames) and writes its tables when it ends,
    then, at the checkpoint, its manifest and the checkpoint (see the module docstring)."""

    def __init__(self, folder: RunFiles, config: ExperimentConfig, run_id: str) -> None:
        self.folder = folder
        self.config = config
        self.run_id = run_id
        self._rows: dict[tuple[int, int, int], EvaluationRow] = {}
        self._frames: dict[tuple[int, int, int], tuple[str, EvaluationResult]] = {}

    @property
    def path(self) -> Path:
        return Path(self.folder.path)

    def notify(self, event: RunEvent) -> None:
        """The driver's events: rows as batches come back, tables when the generation ends."""
        if isinstance(event, BatchEvaluated):
            self.evaluated(
                event.body,
                event.tasks,
                event.results,
                generation=event.generation,
                iteration=event.iteration,
            )
        elif isinstance(event, BodyFailed):
            self.body_failed(event.body, event.generation, event.worst)
        elif isinstance(event, GenerationEnded):
            self.write_generation(event.generation, event.bodies, event.archive, event.novelty)
        elif isinstance(event, CheckpointDue):
            # The tables' sizes and hashes, then the checkpoint: a generation counts as done
            # only once its records are whole.
            write_manifest(self.path, event.generation)
            self.folder.save_checkpoint(dict(event.state))

    def evaluated(
        self,
        body: Body,
        tasks: Sequence[EvaluationTask],
        results: Sequence[EvaluationResult],
        *,
        generation: int,
        iteration: int,
    ) -> None:
        """A batch of ``body``'s brain run came back: its rows (and frames, when recorded)."""
        for k, (task, result) in enumerate(zip(tasks, results)):
            key = (body.number, iteration, k)
            self._rows[key] = evaluation_row(
                self.run_id, self.config, body, task, result, generation, iteration, k
            )
            if self.config.record.trajectories and result.time.size:
                self._frames[key] = (task.eval_id, result)

    def body_failed(self, body: Body, generation: int, worst: float) -> None:
        """``body`` could not be built: its one row, with the error."""
        self._rows[(body.number, 0, 0)] = error_row(
            self.run_id, self.config, body, generation, worst
        )

    def write_generation(
        self,
        generation: int,
        bodies: Sequence[tuple[Body, bool, bool]],
        archive: Sequence[Mapping[str, object]] | None = None,
        novelty: Sequence[Mapping[str, object]] | None = None,
    ) -> None:
        """Write the generation's tables (``bodies``: (body, is_new, selected); ``archive``:
        a MAP-Elites archive's rows, see `ArchiveRow`; ``novelty``: novelty search's rows, see
        `NoveltyRow`)."""
        rows = [self._rows[key] for key in sorted(self._rows)]
        write_table(self.path, "evaluations", generation, table_columns(EvaluationRow, rows))
        if self.config.record.trajectories:
            frames = [self._frames[key] for key in sorted(self._frames)]
            write_table(
                self.path, "trajectories", generation, trajectory_columns(generation, frames)
            )
        body_rows = body_rows_of(self.run_id, self.config, generation, bodies)
        write_table(self.path, "bodies", generation, table_columns(BodyRow, body_rows))
        if archive is not None:
            cells = [ArchiveRow.of({"generation": generation, **row}) for row in archive]
            write_table(self.path, "archive", generation, table_columns(ArchiveRow, cells))
        if novelty is not None:
            rows_n = [NoveltyRow.of({"generation": generation, **row}) for row in novelty]
            write_table(self.path, "novelty", generation, table_columns(NoveltyRow, rows_n))
        self._rows.clear()
        self._frames.clear()

    def plugin_failed(self, task: EvaluationTask | None, exc: BaseException) -> BaseException:
        """The one-line error that stops the run (the traceback goes to RUN/error.log)."""
        # lazy: loads the evaluation engine, needed only when a plugin has failed
        from ariel.recording.store._failures import plugin_failure

        return plugin_failure(self.path, self.config, task, exc)


def body_rows_of(
    run_id: str,
    config: ExperimentConfig,
    generation: int,
    bodies: Sequence[tuple[Body, bool, bool]],
) -> list[BodyRow]:
    """The generation's rows of the bodies table, in id order (``bodies``: (body, is_new,
    selected))."""
    rows = [
        body_row(run_id, config, body, generation, is_new, selected)
        for body, is_new, selected in bodies
    ]
    rows.sort(key=lambda row: row.body_id)
    return rows
