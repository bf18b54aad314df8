"""`RunResult`: what a finished (or interrupted) run's call returns."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ariel.recording import Run, load_run

__all__ = ["RunResult"]


@dataclass
class RunResult:
    """What `run_experiment` returns.

    Attributes:
        run_dir: The run folder, as an absolute path.
        run_id: The run's id (the folder's name when ``out`` was given, else
            ``<name>-<YYYYmmdd-HHMMSS>-s<seed>``).
        status: How the run ended: ``"finished"``.
        generations: The generations of the run (the config's ``generations``).
        evaluations: Rows in the evaluations table.
        best_fitness: The fitness of the run's best body.
        best_body_id: The id of the run's best body, e.g. ``"b000012"``.
        best_eval_id: The id of that body's best evaluation, e.g. ``"b000012-i003-c005"``.
        wall_seconds: Wall-clock seconds the run took (over all its sessions).
    """

    run_dir: Path
    run_id: str
    status: str
    generations: int
    evaluations: int
    best_fitness: float
    best_body_id: str
    best_eval_id: str
    wall_seconds: float

    def load(self) -> Run:
        """The run's records as pandas DataFrames (`ariel.recording.load_run`)."""
        return load_run(self.run_dir)
