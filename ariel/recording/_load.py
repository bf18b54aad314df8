"""Load a run folder into pandas: `load_run(path)` and `list_runs(folder)`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ariel.recording._run_folder import NotARunError, RunFolder
from ariel.recording._tables import read_table

__all__ = ["Run", "list_runs", "load_run"]


@dataclass
class Run:
    """A run's records. Tables load on first access and hold finished generations only.

    Attributes:
        path: the run folder.
        info: ``run.json`` (status, seed, versions, plugin provenance, times, ...).
        config: the resolved experiment config as a dict.
    """

    path: Path
    info: dict[str, Any]
    config: dict[str, Any] = field(init=False)

    def __post_init__(self) -> None:
        self.config = self.info.get("config", {})

    @property
    def generations_done(self) -> int:
        return int(self.info.get("generations_done", 0))

    def _table(self, name: str) -> Any:
        return read_table(self.path, name, up_to=self.generations_done - 1).to_pandas()

    @cached_property
    def evaluations(self) -> Any:
        """One row per evaluation (ids, genotype, controller params, fitness, status, ...)."""
        return self._table("evaluations")

    @cached_property
    def bodies(self) -> Any:
        """One row per body per generation (``selected``: it survived into the next one)."""
        return self._table("bodies")

    @cached_property
    def trajectories(self) -> Any:
        """One row per recorded frame: ``eval_id``, ``t``, core position, joint lists."""
        return self._table("trajectories")

    @cached_property
    def archive(self) -> Any:
        """MAP-Elites runs: one row per filled cell of the archive after each generation
        (``cell``, the elite's ``body_id``, ``fitness``, ``measures``, ``grid``); empty else."""
        return self._table("archive")

    @cached_property
    def generations(self) -> Any:
        """Per generation: evaluations, failures, and best / mean / median fitness of the
        population after selection (a MAP-Elites run: its elites), and for MAP-Elites runs
        ``coverage`` (filled cells / cells) and ``qd_score`` (the elites' summed objective)."""
        import pandas as pd

        evaluations, bodies = self.evaluations, self.bodies
        maximise = True
        if len(evaluations):
            from ariel.plugins import fitness_functions

            maximise = bool(fitness_functions.get(evaluations["fitness_fn"].iloc[0]).maximise)
        rows = []
        for generation, group in bodies.groupby("generation", sort=True):
            alive = group[group["selected"]]["fitness"]
            alive = alive[alive.map(math.isfinite)]
            evals = evaluations[evaluations["generation"] == generation]
            rows.append(
                {
                    "generation": int(generation),
                    "evaluations": len(evals),
                    "new_bodies": int(group["is_new"].sum()),
                    "errors": int((evals["status"] == "error").sum()),
                    "unstable": int((evals["status"] == "unstable").sum()),
                    "best_fitness": (alive.max() if maximise else alive.min())
                    if len(alive)
                    else math.nan,
                    "mean_fitness": alive.mean() if len(alive) else math.nan,
                    "median_fitness": alive.median() if len(alive) else math.nan,
                }
            )
        columns = [
            "generation",
            "evaluations",
            "new_bodies",
            "errors",
            "unstable",
            "best_fitness",
            "mean_fitness",
            "median_fitness",
        ]
        frame = pd.DataFrame(rows, columns=columns)  # the columns even before a generation ends
        archive = self.archive
        if len(archive):
            grouped = archive.groupby("generation")
            cells = grouped["grid"].first().map(lambda grid: int(np.prod(grid)))
            quality = pd.DataFrame(
                {"coverage": grouped.size() / cells, "qd_score": grouped["objective"].sum()}
            )
            frame = frame.join(quality, on="generation")
        return frame


def load_run(path: str | Path) -> Run:
    """The records of the run in ``path`` (a folder made by `ariel run`)."""
    folder = RunFolder(path)
    return Run(path=folder.path, info=folder.read_info())


#: `list_runs` status of a run whose run.json says "running" but whose lock is free: its
#: process ended without saying so (SIGKILL, power cut, out of memory); `ariel resume` it.
STOPPED = "stopped (killed?)"


def list_runs(root: str | Path = Path("data") / "runs") -> list[dict[str, Any]]:
    """One summary per run folder directly under ``root`` (folders that are not runs skipped).

    ``status`` is run.json's, except `STOPPED` for a "running" run that no process runs.
    """
    from ariel.recording._lock import lock_is_free

    root = Path(root)
    if not root.is_dir():
        return []
    found = []
    for child in sorted(root.iterdir()):
        if not child.is_dir():
            continue
        try:
            info = RunFolder(child).read_info()
        except NotARunError:
            continue
        config = info.get("config", {})
        status = info.get("status")
        if status == "running" and lock_is_free(child):
            status = STOPPED
        found.append(
            {
                "path": str(child),
                "run_id": info.get("run_id", child.name),
                "status": status,
                "generations_done": info.get("generations_done", 0),
                "generations": config.get("generations"),
                "evaluations": info.get("evaluations_done", 0),
                "best_fitness": info.get("best_fitness"),
                "created": info.get("created"),
            }
        )
    return found
