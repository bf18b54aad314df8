"""The run driver: one run's generations, as a group of work for the `Scheduler`.

Per generation: the body optimizer asks for genotypes, each becomes a compiled body
(`BodyFactory`), each buildable body gets a brain run (`BrainWork`: its learner, CMA-ES by
default, ``brain.optimizer``), the scheduler runs all brain runs side by side, the optimizer
is told the bodies, and the records writer writes the generation; then the checkpoint. A
body's fitness is its best brain's fitness.

An encoder that cannot vary its genotypes (``evolvable = False``, e.g. ``prebuilt``), or a
fixed ``body.genotype`` under any encoder, gives a brain-only run: one fixed body whose brain
run goes on across generations, each generation adding ``brain.iterations`` iterations.

The driver writes nothing itself and owns the run's counts: it tells its observers what
happened (`ariel.evolution._events`: the records writer, the Rerun recorder, run.json and the
progress display in a run, wired by `ariel.runs`).
"""

from __future__ import annotations

import json
import math
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ariel.body_phenotypes.robogen_lite.graph_io import graph_key
from ariel.evaluation import FAILED_STATUSES, EvaluationResult, EvaluationTask
from ariel.evolution._bodies import BodyFactory, BrainJob
from ariel.evolution._brain import fitness_rank
from ariel.evolution._config import ExperimentConfig, config_hash
from ariel.evolution._events import (
    BatchEvaluated,
    BodyFailed,
    CheckpointDue,
    FlushDue,
    GenerationEnded,
    GenerationStarted,
    RunEnded,
    RunEvent,
    RunObserver,
    RunStarted,
)
from ariel.evolution._optimizer import Proposal
from ariel.evolution._seeds import derive_rng
from ariel.evolution._state import BodiesSeen, Body, LoopState, state_to_plain
from ariel.evolution._tasks import body_spec

__all__ = ["Plugins", "RunDriver", "budget", "distinct_bodies", "fixed_genotype"]


@dataclass
class Plugins:
    """A run's plugins, made once from the config (`ariel.runs`)."""

    encoder: Any
    controller: Any
    fitness: Any
    optimizer_factory: Any  # (**keywords) -> BodyOptimizer; None in a brain-only run

    @property
    def maximise(self) -> bool:
        return bool(self.fitness.maximise)

    @property
    def worst(self) -> float:
        """The fitness of an evaluation that failed (as the engine gives it)."""
        # lazy: loads mujoco; `ariel watch` imports this module before choosing a GL backend
        from ariel.evaluation import worst_fitness

        return worst_fitness(self.maximise)


def is_brain_only(config: ExperimentConfig, encoder: Any) -> bool:
    """A fixed ``body.genotype``, or an encoder that cannot vary bodies."""
    return config.body.genotype is not None or not bool(getattr(encoder, "evolvable", False))


def fixed_genotype(config: ExperimentConfig, encoder: Any) -> Any:
    """The body of a brain-only run: ``body.genotype``, else the encoder's random one."""
    if config.body.genotype is not None:
        return config.body.genotype
    return encoder.random_genotype(derive_rng(config.seed, "body-init", 0))


def per_body(config: ExperimentConfig) -> int:
    """Evaluations of one body's brain run in a generation: ``popsize x iterations``."""
    return config.brain.popsize * config.brain.iterations


def budget(config: ExperimentConfig, brain_only: bool) -> int:
    """Evaluations the run will make (bodies without parameters count as a full brain run)."""
    each = per_body(config)
    if brain_only:
        return config.generations * each
    return (config.body.population + (config.generations - 1) * config.body.offspring) * each


class BrainWork:
    """A `BrainJob` as the scheduler's `Work`: ask the learner, evaluate, tell, say so.
    ``skipped``: evaluations its first batch counts beyond its own (a body without joints is
    evaluated once, for a whole brain run)."""

    def __init__(self, driver: RunDriver, job: BrainJob, generation: int, skipped: int = 0) -> None:
        self.driver, self.job, self.generation = driver, job, generation
        self._skipped = skipped
        self._params: np.ndarray | None = None
        self._tasks: list[EvaluationTask] = []

    def next_batch(self) -> list[EvaluationTask] | None:
        run = self.job.run
        if run.iteration >= self.job.target:
            return None
        try:
            self._params = run.ask()
        except Exception as exc:
            raise self._learner_failed(exc) from exc
        driver = self.driver
        self._tasks = driver.factory.batch_tasks(self.job, self._params, driver.record_bodies)
        return self._tasks

    def batch_done(self, results: list[EvaluationResult]) -> None:
        job, driver = self.job, self.driver
        iteration = job.run.iteration
        assert self._params is not None  # the scheduler tells a batch that next_batch gave
        try:
            improved = job.run.tell(self._params, np.array([r.fitness for r in results]))
        except Exception as exc:
            raise self._learner_failed(exc) from exc
        body = job.body
        body.evaluations += len(results)
        if improved is not None:
            body.fitness = job.run.best_fitness
            body.best_params = job.run.best_params.tolist()  # type: ignore[union-attr]
            body.best_eval_id = self._tasks[improved].eval_id
        driver.candidates.extend(float(r.fitness) for r in results if math.isfinite(r.fitness))
        counted, self._skipped = len(results) + self._skipped, 0
        driver.count([r.status for r in results], counted)
        driver.emit(
            BatchEvaluated(
                body=body,
                model=driver.factory.model(body),
                tasks=self._tasks,
                results=results,
                generation=self.generation,
                iteration=iteration,
                improved=improved,
                counted=counted,
                best=driver.best_so_far(),
            )
        )

    def _learner_failed(self, exc: Exception) -> BaseException:
        """What stops the run when the brain optimizer raised asking for or told the batch of
        this iteration: the driver's `plugin_error` for the batch's first evaluation, ``exc``
        noted as raised by the brain optimizer (so the one line names it)."""
        exc.add_note(f"raised by brain optimizer {self.driver.config.brain.optimizer!r}")
        job = self.job
        first = np.zeros((1, job.run.n_params))  # the batch's first task, as it is named
        task = self.driver.factory.batch_tasks(job, first, record_bodies=False)[0]
        return self.driver.plugin_error(task, exc)

    def failed_result(self, task: EvaluationTask, reason: str) -> EvaluationResult:
        worst = self.driver.plugins.worst
        return EvaluationResult(eval_id=task.eval_id, fitness=worst, status="error", error=reason)

    def task_error(self, task: EvaluationTask, exc: BaseException) -> BaseException:
        return self.driver.plugin_error(task, exc)

    def flush(self) -> None:
        self.driver.emit(FlushDue())


def _unchanged(task: EvaluationTask | None, exc: BaseException) -> BaseException:
    return exc


class RunDriver:
    """One run's generations (`generations`, a group for the `Scheduler`); see the module
    docstring.

    Args:
        config: The run's config.
        plugins: Its plugins.
        observers: Who hears the run's events, in this order (`RunObserver`).
        state: The checkpoint to continue from, or None for a new run.
        record_bodies: Whether evaluations return the bodies' poses (for recordings).
        plugin_error: ``(task, exc) -> the exception that stops the run`` when a plugin
            raised in an evaluation (the records writer logs it; task None: the body
            optimizer raised, or a learner's state is not plain data); None: ``exc`` itself.
    """

    def __init__(
        self,
        config: ExperimentConfig,
        plugins: Plugins,
        observers: Sequence[RunObserver] = (),
        state: LoopState | None = None,
        *,
        record_bodies: bool = False,
        plugin_error: Callable[[EvaluationTask | None, BaseException], BaseException] | None = None,
    ) -> None:
        self.config, self.plugins, self.observers = config, plugins, list(observers)
        self.record_bodies = record_bodies
        self.plugin_error = plugin_error or _unchanged
        self.brain_only = is_brain_only(config, plugins.encoder)
        self.factory = BodyFactory(config, plugins.encoder, plugins.controller, plugins.maximise)
        self.state = state
        self.optimizer = None
        if not self.brain_only:
            self.optimizer = plugins.optimizer_factory(
                encoder=plugins.encoder,
                seed=config.seed,
                maximise=plugins.maximise,
                settings=config.body,
            )
            if state is not None:
                self.optimizer.restore(state.optimizer, state.population)
        self._jobs: list[BrainJob] = []
        # this generation's parents, children
        self._bodies: tuple[list[Body], list[Body]] = ([], [])
        # The finite fitnesses of this generation's evaluations (a brain-only run's progress
        # line shows their mean: the population is one body, whose mean is its best).
        self.candidates: list[float] = []
        # The run's counts, the checkpoint's: evaluations run or skipped (failed bodies) so
        # far; this generation's evaluation rows, and those by failed status.
        self.budget_done = state.budget_done if state is not None else 0
        self._rows = 0
        self._failures: Counter[str] = Counter()
        self._started = time.perf_counter()
        self._wall_before = state.wall_seconds if state is not None else 0.0

    def emit(self, event: RunEvent) -> None:
        """Tell every observer ``event``, in order."""
        for observer in self.observers:
            observer.notify(event)

    def start(self) -> None:
        """Say `RunStarted` (with a QD optimizer's archive description: readers and run.rrd
        draw from it before its first rows)."""
        describe = getattr(self.optimizer, "archive_description", None)
        self.emit(RunStarted(self.first_generation, describe() if describe else None))

    def count(self, statuses: Sequence[str], evaluations: int) -> None:
        """Count rows of the evaluations table with ``statuses`` (one each), by failed status,
        and ``evaluations`` as done (run, or skipped for a failed body)."""
        self._rows += len(statuses)
        self._failures.update(s for s in statuses if s in FAILED_STATUSES)
        self.budget_done += evaluations

    @property
    def first_generation(self) -> int:
        return 0 if self.state is None else self.state.generation + 1

    def best_so_far(self) -> float:
        """The best fitness of the kept population and this generation's brains so far: the
        progress line's ``best`` (of this generation's alone, it fell at each generation's
        start, and after a resume forgot what the generations before had found)."""
        kept = [b.fitness for b in self.state.population] if self.state is not None else []
        found = [j.run.best_fitness for j in self._jobs]
        values = [v for v in (*kept, *found) if not math.isnan(v)]
        if not values:
            return math.nan
        return max(values) if self.plugins.maximise else min(values)

    def generations(self) -> Iterator[list[BrainWork]]:
        for generation in range(self.first_generation, self.config.generations):
            self.emit(GenerationStarted(generation, self._generation_budget()))
            self.candidates, self._rows, self._failures = [], 0, Counter()
            works = (
                self._brain_only_works(generation)
                if self.brain_only
                else self._works_of(generation)
            )
            self._jobs = [work.job for work in works]
            yield works
            self._end(generation)
        self.emit(RunEnded())

    def _generation_budget(self) -> int:
        """Evaluations the next generation makes (as `budget` counts them)."""
        each = per_body(self.config)
        if self.optimizer is None:
            return each
        parents = self.optimizer.population
        return (self.config.body.offspring if parents else self.config.body.population) * each

    # -- a generation's brain jobs -------------------------------------------------------------

    def _brain_only_works(self, generation: int) -> list[BrainWork]:
        config, factory = self.config, self.factory
        if self.state is None:
            body = factory.new_body(0, fixed_genotype(config, self.plugins.encoder), [], 0)
            if body.status == "error":  # checked before the run started
                raise RuntimeError(f"the fixed body cannot be built: {body.error}")
            brain = factory.new_brain(body, {})
            self.state = LoopState(config_hash(config), -1, 1, [body], brain)
        body = self.state.population[0]
        assert self.state.brain is not None
        self._bodies = ([], [body])
        target = (generation + 1) * config.brain.iterations
        return [BrainWork(self, factory.job(body, self.state.brain, target), generation)]

    def _works_of(self, generation: int) -> list[BrainWork]:
        config, factory, optimizer = self.config, self.factory, self.optimizer
        assert optimizer is not None
        if self.state is None:
            self.state = LoopState(config_hash(config), -1, 0, [])
        state = self.state
        parents = optimizer.population
        count = config.body.offspring if parents else config.body.population
        children, seen = [], BodiesSeen(parents)
        try:
            proposals = list(optimizer.ask(count))
            seen.unchanged("ask")
            _check_proposals(proposals, count, {body.body_id for body in parents}, config)
        except Exception as exc:  # any: the optimizer's own code
            raise self._optimizer_failed(exc) from exc
        for proposal in proposals:
            body = factory.new_body(
                state.next_body, proposal.genotype, proposal.parent_ids, generation
            )
            children.append(body)
            state.next_body += 1
        self._bodies = (parents, children)
        by_id = {b.body_id: b for b in parents}
        each = per_body(config)
        works = []
        for child in children:
            if child.status == "error":
                child.fitness = self.plugins.worst
                self.count(["error"], each)  # its one row, with the error; a whole brain run
                self.emit(BodyFailed(child, generation, self.plugins.worst, each))
                continue
            job = factory.job(child, factory.new_brain(child, by_id), config.brain.iterations)
            # A body without joints is evaluated once: its batch counts the rest as done.
            works.append(BrainWork(self, job, generation, each - 1 if child.n_params == 0 else 0))
        return works

    # -- the end of a generation ---------------------------------------------------------------

    def _end(self, generation: int) -> None:
        state, (parents, children) = self.state, self._bodies
        assert state is not None
        if self.optimizer is None:
            rows = [(children[0], generation == 0, True)]
        else:
            seen = BodiesSeen(parents + children)
            try:
                self.optimizer.tell(children)
                state.population = self.optimizer.population
                state.optimizer = self.optimizer.state()
                seen.unchanged("tell")  # the rows below: the loop's values
            except Exception as exc:  # any: the optimizer's own code
                raise self._optimizer_failed(exc) from exc
            kept = {b.body_id for b in state.population}
            new = {b.body_id for b in children}
            rows = [(b, b.body_id in new, b.body_id in kept) for b in parents + children]
            self.factory.forget_models(state.population)
        state.generation = generation
        archive = getattr(self.optimizer, "archive_rows", None)  # a quality-diversity archive
        novelty = getattr(self.optimizer, "novelty_rows", None)  # novelty search's own
        self.emit(
            GenerationEnded(
                generation, rows, archive() if archive else None, novelty() if novelty else None
            )
        )
        state.evaluations_done += self._rows
        state.budget_done = self.budget_done
        state.wall_seconds = self.wall_seconds
        self.emit(self._checkpoint(generation, state, archive is not None))

    def _checkpoint(self, generation: int, state: LoopState, qd: bool) -> CheckpointDue:
        """The end of ``generation``: its checkpoint, counts and population summary."""
        best, mean = summary(state.population, self.plugins.maximise)
        label = "mean"
        if self.brain_only:  # as `ariel report` draws it: the mean of the brain candidates
            label = "mean of candidates"
            mean = float(np.mean(self.candidates)) if self.candidates else math.nan
        stats = getattr(self.optimizer, "stats", None) if qd else None
        # What readers need to compute the QD-score as the run did (`load_run`, `report`).
        offset = getattr(self.optimizer, "qd_offset", None) if qd else None
        try:  # the learner's or optimizer's state must be plain data, as the checkpoint is
            plain = state_to_plain(state)
            json.dumps(plain, allow_nan=False)
        except Exception as exc:  # any: a brain-only run's learner gives its state here
            raise self._optimizer_failed(exc, "its state() is not plain data (JSON)") from exc
        return CheckpointDue(
            generation=generation,
            state=plain,
            evaluations_done=state.evaluations_done,
            best=best,
            mean=mean,
            mean_label=label,
            failures={s: self._failures[s] for s in FAILED_STATUSES if self._failures[s]},
            morphs=None if self.optimizer is None else distinct_bodies(state.population),
            archive_stats=stats() if stats else None,
            qd_offset=None if offset is None else float(offset),
        )

    def _optimizer_failed(self, exc: Exception, what: str = "") -> BaseException:
        """What stops the run when the body optimizer (a brain-only run's brain optimizer, for
        its state) raised: the driver's `plugin_error` with no evaluation, ``exc`` noted as
        raised by that optimizer (so the one line names it)."""
        config = self.config
        if self.brain_only:
            label = f"brain optimizer {config.brain.optimizer!r}"
        else:
            label = f"body optimizer {config.body.optimizer!r}"
        exc.add_note(f"raised by {label}{': ' + what if what else ''}")
        return self.plugin_error(None, exc)

    @property
    def wall_seconds(self) -> float:
        return self._wall_before + time.perf_counter() - self._started

    def best_body(self) -> Body:
        assert self.state is not None
        return min(
            self.state.population,
            key=lambda b: (fitness_rank(b.fitness, self.plugins.maximise), b.number),
        )


def _check_proposals(
    proposals: Sequence[Proposal], count: int, population: set[str], config: ExperimentConfig
) -> None:
    """What the body optimizer asked for can be made and stored (`ValueError`, one line): as
    many genotypes as asked, each plain data (JSON: the bodies table stores it), each child's
    parents in the population it was bred from (a parent id of no body made a "finished" run
    that `verify` then called damaged). `check_body_optimizer` checks the same before a run."""
    if len(proposals) != count:
        raise ValueError(f"ask({count}) gave {len(proposals)} genotypes")
    for proposal in proposals:
        unknown = sorted(set(proposal.parent_ids) - population)
        if unknown:
            raise ValueError(f"a child's parents {unknown[:3]} are not in its population")
        try:  # as its body's spec stores it (numpy arrays as lists), then hashes it as JSON
            _ = body_spec(config, proposal.genotype).key
        except (TypeError, ValueError) as exc:
            raise ValueError(f"a genotype is not plain data (JSON): {exc}") from None


def distinct_bodies(population: Sequence[Body]) -> tuple[int, int]:
    """(distinct robot graphs, bodies) among the bodies of ``population`` with a finite
    fitness (the population after selection, as `ariel.recording.Run.generations` counts it).
    Graphs are compared by structure (`graph_key`); a body without a graph counts as its own."""

    alive = [b for b in population if math.isfinite(b.fitness)]
    return len({graph_key(b.graph) if b.graph else b.body_id for b in alive}), len(alive)


def summary(population: Sequence[Body], maximise: bool) -> tuple[float, float]:
    """Best and mean finite fitness of ``population`` (NaN when none is finite)."""
    values = np.array([b.fitness for b in population if math.isfinite(b.fitness)])
    if values.size == 0:
        return math.nan, math.nan
    return float(values.max() if maximise else values.min()), float(values.mean())
