"""`RunDriver` alone, with fake observers and fake evaluations.

No physics runs and nothing is written: each brain candidate's "fitness" is a function of its
parameters, and the fake observers keep the events the driver says. So these tests say what
the driver itself does (its counts, its events, its checkpoints), whatever the scheduler, the
engine and the records writer do.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest

from ariel.evaluation import EvaluationResult
from ariel.evolution import (
    BatchEvaluated,
    BodyFailed,
    CheckpointDue,
    GenerationEnded,
    GenerationStarted,
    RunEvent,
    RunStarted,
    load_config,
)
from ariel.evolution._driver import RunDriver, budget, per_body
from ariel.runs._prepare import resolve_plugins

SMALL = [
    "generations=3",
    "body.population=3",
    "body.offspring=2",
    "brain.popsize=2",
    "brain.iterations=2",
]


class FakeRecords:
    """An observer that keeps what a records writer and run.json would be told."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []
        self.checkpoints: list[dict[str, Any]] = []
        self.info: dict[str, Any] = {}
        self.events: list[str] = []

    def notify(self, event: RunEvent) -> None:
        self.events.append(type(event).__name__)
        if isinstance(event, BatchEvaluated):
            fitness = [r.fitness for r in event.results]
            self.calls.append(
                ("evaluated", event.generation, event.body.body_id, event.iteration, fitness)
            )
        elif isinstance(event, BodyFailed):
            self.calls.append(("failed", event.generation, event.body.body_id))
        elif isinstance(event, GenerationEnded):
            kept = sorted(b.body_id for b, _, selected in event.bodies if selected)
            self.calls.append(
                ("generation", event.generation, kept, event.archive is not None, event.novelty)
            )
        elif isinstance(event, CheckpointDue):
            self.checkpoints.append(json.loads(json.dumps(event.state)))  # plain JSON, as on disk
        elif isinstance(event, RunStarted) and event.archive is not None:
            self.info["archive"] = event.archive


class FakeProgress:
    """An observer that counts what a progress display is shown."""

    def __init__(self) -> None:
        self.done = 0
        self.generations: list[int] = []

    def notify(self, event: RunEvent) -> None:
        if isinstance(event, GenerationStarted):
            self.generations.append(event.generation)
        elif isinstance(event, BatchEvaluated | BodyFailed):
            self.done += event.counted


def _fitness(params: tuple[float, ...]) -> float:
    return -float(np.sum((np.asarray(params) - 0.3) ** 2))


def _drive(overrides: list[str]) -> tuple[RunDriver, FakeRecords, FakeProgress]:
    config = load_config(overrides=[*SMALL, *overrides])
    records, progress = FakeRecords(), FakeProgress()
    driver = RunDriver(config, resolve_plugins(config), [records, progress])
    driver.start()
    for works in driver.generations():
        for work in works:  # one after the other: the scheduler's order does not matter
            while (tasks := work.next_batch()) is not None:
                results = [
                    EvaluationResult(eval_id=t.eval_id, fitness=_fitness(t.params), status="ok")
                    for t in tasks
                ]
                work.batch_done(results)
    return driver, records, progress


@pytest.fixture(scope="module")
def ga() -> tuple[RunDriver, FakeRecords, FakeProgress]:
    return _drive([])


def test_the_driver_counts_every_evaluation_and_checkpoints_its_own_count(ga) -> None:
    driver, records, progress = ga
    config = driver.config
    assert progress.generations == [0, 1, 2]
    counted = [state["budget_done"] for state in records.checkpoints]
    runs = [call for call in records.calls if call[0] == "evaluated"]
    evaluated = sum(len(call[4]) for call in runs)
    # A body without joints is evaluated once, one that cannot be built never: each counts as
    # a whole brain run, so the count ends at the budget.
    still = {call[2] for call in runs if len(call[4]) == 1 and not call[3]}
    skipped = sum(call[0] == "failed" for call in records.calls) * per_body(config)
    assert evaluated + skipped + len(still) * (per_body(config) - 1) == budget(config, False)
    assert evaluated > 10 * len(still)  # most bodies learn (2 x 2 brains each)
    assert counted[-1] == budget(config, False)
    assert counted[-1] == driver.budget_done == progress.done
    assert counted == sorted(counted) and len(counted) == config.generations


def test_the_events_come_in_the_documented_order(ga) -> None:
    _, records, _ = ga
    said = records.events
    assert said[0] == "RunStarted" and said[-1] == "RunEnded"
    starts = [i for i, name in enumerate(said) if name == "GenerationStarted"]
    assert len(starts) == 3
    for first, end in zip(starts, [*starts[1:], len(said) - 1]):
        generation = said[first:end]
        # the batches (each followed by a flush only when a scheduler sends more: none here),
        # then the records, then the checkpoint
        assert generation[-2:] == ["GenerationEnded", "CheckpointDue"]
        assert set(generation[1:-2]) <= {"BatchEvaluated", "BodyFailed"}


def test_each_generation_is_written_once_in_order_with_its_survivors(ga) -> None:
    driver, records, _ = ga
    written = [call for call in records.calls if call[0] == "generation"]
    assert [call[1] for call in written] == [0, 1, 2]
    assert all(len(call[2]) == driver.config.body.population for call in written)
    assert not any(call[3] for call in written)  # a GA has no archive
    assert all(call[4] is None for call in written)  # nor novelty rows
    final = sorted(b.body_id for b in driver.state.population)  # type: ignore[union-attr]
    assert written[-1][2] == final


def test_a_body_s_fitness_is_its_best_evaluation_and_the_best_body_the_best(ga) -> None:
    driver, records, _ = ga
    best: dict[str, float] = {}
    for call in records.calls:
        if call[0] == "evaluated":
            best[call[2]] = max([best.get(call[2], -math.inf), *call[4]])
    for body in driver.state.population:  # type: ignore[union-attr]
        assert body.fitness == best[body.body_id]
    top = driver.best_body()
    assert top.fitness == max(b.fitness for b in driver.state.population)  # type: ignore[union-attr]


def test_the_same_config_drives_the_same_checkpoints(ga) -> None:
    _, records, _ = ga
    _, again, _ = _drive([])
    strip = [{**c, "wall_seconds": 0} for c in records.checkpoints]  # the one clock in them
    assert strip == [{**c, "wall_seconds": 0} for c in again.checkpoints]


def test_novelty_search_hands_its_archive_and_novelty_rows_to_the_records() -> None:
    options = '{ measures = ["num_limbs", "joints_ratio"], ranges = [[0, 8], [0, 1]], k = 2 }'
    _, records, _ = _drive(["body.optimizer=novelty", f"body.optimizer_options={options}"])
    written = [call for call in records.calls if call[0] == "generation"]
    assert len(written) == 3 and all(call[3] for call in written)
    rows = written[-1][4]
    assert rows and sum(row["rank"] >= 0 for row in rows) == 3  # the population, ranked
    assert records.info["archive"]["kind"] == "grid"
