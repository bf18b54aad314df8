"""What a run's driver says happened: its events, and the observers that hear them.

The driver (`RunDriver`) owns the run's counts and writes nothing. It tells each of its
observers every event, in the order it was given them: in a run (`ariel.runs`) the records
writer (the tables, the manifests and the checkpoint), the Rerun recorder, run.json and the
progress display. An observer takes the events it needs and ignores the rest.

One generation's events, in order:

* `GenerationStarted`;
* per body that cannot be built, `BodyFailed`;
* per batch of a brain run that came back, `BatchEvaluated`, and, once the scheduler has sent
  the next batches (so slow writing overlaps the workers' physics), `FlushDue`;
* `GenerationEnded`: the generation's bodies, for the tables and recordings;
* `CheckpointDue`: the state to save, and the counts and summary run.json and the progress
  line show. Saved only after every observer has written the generation's records.

A run also says `RunStarted` before its first generation, and `RunEnded` after its last.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import mujoco

    from ariel.evaluation import EvaluationResult, EvaluationTask
    from ariel.evolution._state import Body

__all__ = [
    "BatchEvaluated",
    "BodyFailed",
    "CheckpointDue",
    "FlushDue",
    "GenerationEnded",
    "GenerationStarted",
    "RunEnded",
    "RunEvent",
    "RunObserver",
    "RunStarted",
]


@dataclass(frozen=True)
class RunStarted:
    """The driver is ready; ``first_generation``: the one it goes on with (0 for a new run);
    ``archive``: a quality-diversity optimizer's description of its archive
    (``archive_description``), None for others."""

    first_generation: int
    archive: Mapping[str, object] | None = None


@dataclass(frozen=True)
class GenerationStarted:
    """Generation ``generation`` starts, to make ``evaluations`` evaluations (as `budget`
    counts them)."""

    generation: int
    evaluations: int


@dataclass(frozen=True)
class BatchEvaluated:
    """A batch of ``body``'s brain run came back: ``results[k]`` of ``tasks[k]``, iteration
    ``iteration``; ``improved``: the candidate that became the body's best, if any;
    ``counted``: evaluations this adds to the run's count; ``best``: the generation's best
    fitness so far."""

    body: Body
    model: mujoco.MjModel | None
    tasks: Sequence[EvaluationTask]
    results: Sequence[EvaluationResult]
    generation: int
    iteration: int
    improved: int | None
    counted: int
    best: float


@dataclass(frozen=True)
class BodyFailed:
    """``body`` could not be built (its error is ``body.error``); it has the fitness
    ``worst`` and counts as ``counted`` evaluations (a whole brain run)."""

    body: Body
    generation: int
    worst: float
    counted: int


@dataclass(frozen=True)
class FlushDue:
    """The scheduler has sent the next batches: what the batches so far left to write can be
    written now, while the workers step."""


@dataclass(frozen=True)
class GenerationEnded:
    """Generation ``generation`` ended; its records: ``bodies`` as (body, is_new, selected),
    parents then children; ``archive``: a quality-diversity archive's rows; ``novelty``:
    novelty search's rows (None for optimizers without them)."""

    generation: int
    bodies: Sequence[tuple[Body, bool, bool]]
    archive: Sequence[Mapping[str, object]] | None
    novelty: Sequence[Mapping[str, object]] | None


@dataclass(frozen=True)
class CheckpointDue:
    """Generation ``generation``'s records are written: ``state`` is the checkpoint to save
    (`state_to_plain`). The run's counts after it and the summary of its population, for
    run.json and the progress line: ``best`` / ``mean`` finite fitness (``mean_label`` says
    what the mean is of), ``failures`` (evaluations per failed status this generation),
    ``morphs`` (distinct graphs, bodies), ``archive_stats`` and ``qd_offset`` (a
    quality-diversity archive's)."""

    generation: int
    state: Mapping[str, object]
    evaluations_done: int
    best: float
    mean: float
    mean_label: str
    failures: Mapping[str, int]
    morphs: tuple[int, int] | None = None
    archive_stats: Mapping[str, float] | None = None
    qd_offset: float | None = None


@dataclass(frozen=True)
class RunEnded:
    """The run's last generation is saved."""


RunEvent = (
    RunStarted
    | GenerationStarted
    | BatchEvaluated
    | BodyFailed
    | FlushDue
    | GenerationEnded
    | CheckpointDue
    | RunEnded
)


class RunObserver(Protocol):
    """Hears a run's events (`RunEvent`), in the order the driver says them."""

    def notify(self, event: RunEvent) -> None: ...
