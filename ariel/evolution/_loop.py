"""The co-evolution loop: a body GA outside, a CMA-ES brain run per new body inside.

Generation 0 is a random population; every later generation breeds ``body.offspring``
children (tournament selection, crossover, mutation), learns a brain for each (CMA-ES,
``brain.popsize`` x ``brain.iterations`` evaluations), and keeps ``body.population`` survivors
(mu+lambda, or generational). A body's fitness is its best brain's fitness.

The brain runs of a generation progress side by side: each run asks for its next batch as
soon as its previous batch returns, so every worker stays busy. Nothing depends on the order
in which results arrive: each run changes only through its own results, every random draw
comes from a stream derived from the run seed (`ariel.evolution._seeds`), and rows are written
in id order.

An encoder that cannot vary its genotypes (``evolvable = False``, e.g. ``prebuilt``), or a
fixed ``body.genotype`` under any encoder, gives a brain-only experiment: one fixed body whose
CMA-ES run goes on across generations, each generation adding ``brain.iterations`` iterations.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import inspect
import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ariel.evolution._brain import BrainRun, fitness_rank
from ariel.evolution._config import ConfigError, ExperimentConfig, config_hash, load_config
from ariel.evolution._genotype import check_genotype, describe, is_genotype_file
from ariel.evolution._progress import Progress
from ariel.evolution._seeds import derive_rng, derive_seed
from ariel.evolution._tasks import body_spec, evaluation_task, record_steps, shipped_body

__all__ = ["Body", "LoopState", "RunResult", "resume_experiment", "run_experiment"]


# --------------------------------------------------------------------------------------------
# State (what a checkpoint holds)
# --------------------------------------------------------------------------------------------


@dataclass
class Body:
    """One body of the GA: identity, genotype (plain data), lineage and its learned brain."""

    number: int
    genotype: Any
    parent_ids: list[str]
    born: int
    status: str = "ok"  # "error": the genotype gives no buildable body
    error: str = ""
    n_params: int = 0
    n_joints: int = 0
    joint_names: list[str] = field(default_factory=list)
    descriptors: dict[str, float] = field(default_factory=dict)
    graph: str = ""
    fitness: float = math.nan
    best_params: list[float] | None = None
    best_eval_id: str = ""
    evaluations: int = 0

    @property
    def body_id(self) -> str:
        return f"b{self.number:06d}"


@dataclass
class LoopState:
    """Everything resume needs. RNG states are not stored: each draw's stream is derived."""

    config_hash: str
    generation: int  # the last finished generation
    next_body: int
    population: list[Body]
    brain: BrainRun | None = None  # brain-only: the run that goes on across generations
    evaluations_done: int = 0  # rows in the evaluations table
    budget_done: int = 0  # progress: evaluations run or skipped (failed bodies)
    wall_seconds: float = 0.0


@dataclass
class RunResult:
    """What `run_experiment` returns."""

    run_dir: Path
    run_id: str
    status: str
    generations: int
    evaluations: int
    best_fitness: float
    best_body_id: str
    best_eval_id: str
    wall_seconds: float

    def load(self) -> Any:
        """The run's records as pandas DataFrames (`ariel.recording.load_run`)."""
        from ariel.recording import load_run

        return load_run(self.run_dir)


# --------------------------------------------------------------------------------------------
# Plugins resolved once, with config errors naming the key
# --------------------------------------------------------------------------------------------


@dataclass
class _Plugins:
    encoder: Any
    controller: Any
    fitness: Any

    @property
    def maximise(self) -> bool:
        return bool(self.fitness.maximise)

    @property
    def worst(self) -> float:
        """The fitness of an evaluation that failed (as the engine gives it)."""
        return -math.inf if self.maximise else math.inf


def _resolve(config: ExperimentConfig) -> _Plugins:
    """Make every plugin the config names; a bad name or option is a `ConfigError`."""
    from ariel.plugins import body_encoders, controllers, fitness_functions, worlds

    def make(key: str, registry: Any, name: str, options: dict[str, Any]) -> Any:
        try:
            registry.get(name)
        except (KeyError, ValueError, ImportError) as exc:
            raise ConfigError(f"{key}: {exc}") from None
        try:
            return registry.make(name, **options)
        except (TypeError, ValueError) as exc:
            options_key = key.rsplit(".", 1)[0] + ".options"
            raise ConfigError(f"{options_key}: {registry.label} '{name}': {exc}") from None

    encoder = make("body.encoder", body_encoders, config.body.encoder, config.body.options)
    controller = make(
        "brain.controller", controllers, config.brain.controller, config.brain.options
    )
    make("world.name", worlds, config.world.name, config.world.options)
    try:
        fitness = fitness_functions.get(config.task.fitness)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"task.fitness: {exc}") from None
    try:
        signature = inspect.signature(fitness)
    except (TypeError, ValueError):  # a callable without a readable signature: not checked
        signature = None
    if signature is not None:
        try:
            signature.bind(None, **config.task.options)
        except TypeError as exc:
            raise ConfigError(
                f"task.options: fitness function '{config.task.fitness}': {exc}"
            ) from None
    if config.body.genotype is not None and not is_genotype_file(config.body.genotype):
        check_genotype(config.body.genotype, encoder)  # a file is checked as it is read
    if config.body.survivors == "generational" and config.body.offspring < config.body.population:
        raise ConfigError(
            f"body.offspring: generational survival needs offspring >= population "
            f"({config.body.population}), got {config.body.offspring}"
        )
    return _Plugins(encoder, controller, fitness)


# --------------------------------------------------------------------------------------------
# The experiment
# --------------------------------------------------------------------------------------------


@dataclass
class _Job:
    body: Body
    spec: Any
    run: BrainRun
    target: int  # iterations to reach in this generation
    eval_seed: int
    record_every: int


class _Experiment:
    def __init__(self, config: ExperimentConfig, plugins: _Plugins, folder: Any, run_id: str):
        self.config = config
        self.plugins = plugins
        self.folder = folder
        self.run_id = run_id
        # A fixed body (``body.genotype``) makes the run brain-only for any encoder.
        self.brain_only = config.body.genotype is not None or not bool(
            getattr(plugins.encoder, "evolvable", False)
        )
        self._rows: dict[tuple[int, int, int], dict[str, Any]] = {}
        self._frames: dict[tuple[int, int, int], Any] = {}
        self._models: dict[int, Any] = {}  # body number -> compiled model (this process only)
        self.rows_written = 0  # evaluations rows of the last generation written
        self.failed_written: dict[str, int] = {}  # of those: counts of each failed status
        self.recorder = None  # Rerun recordings (record.rerun), `_recorder.RerunRecorder`
        self._recordings: list[dict[str, Any]] = []  # evaluations waiting for their recording
        if config.record.rerun:
            from ariel.evolution._recorder import RerunRecorder

            self.recorder = RerunRecorder(
                folder.path,
                run_id=run_id,
                bodies=config.record.bodies,
                maximise=plugins.maximise,
                config=config,
            )

    # -- bodies --------------------------------------------------------------------------------

    def body_spec(self, genotype: Any) -> Any:
        return body_spec(self.config, genotype)

    def task(self, spec: Any, params: Any = (), **kwargs: Any) -> Any:
        # One place builds a run's tasks (`_tasks.evaluation_task`): replay rebuilds the same.
        return evaluation_task(self.config, spec, params, **kwargs)

    def new_body(self, number: int, genotype: Any, parents: list[str], generation: int) -> Body:
        """Decode and compile a body in this process (for its parameter count and records)."""
        from ariel.body_phenotypes.robogen_lite.graph_io import graph_to_plain
        from ariel.evaluation import BodyBuildError, build

        spec = self.body_spec(genotype)
        body = Body(number=number, genotype=spec.genotype, parent_ids=parents, born=generation)
        try:
            built = build(self.task(spec))
        except BodyBuildError as exc:
            body.status, body.error = "error", str(exc).splitlines()[0]
            return body
        import networkx as nx

        body.n_params = int(self.plugins.controller.num_parameters(built.model))
        body.n_joints = int(built.model.nu)
        body.joint_names = list(built.joint_names)
        body.descriptors = dict(built.descriptors)
        with contextlib.suppress(Exception):  # a body without a graph form (some prebuilts)
            graph = graph_to_plain(self.plugins.encoder.decode(spec.genotype))
            body.graph = json.dumps(nx.node_link_data(graph, edges="edges"), sort_keys=True)
        self._models[number] = built.model
        return body

    def new_brain(self, body: Body, population: dict[str, Body]) -> BrainRun:
        c, seed = self.config, self.config.seed
        if body.n_params == 0:
            x0 = np.zeros(0)
        else:
            rng = derive_rng(seed, "brain-x0", body.number)
            model = self.model(body)
            x0 = self.plugins.controller.random_parameters(model, rng, 1)[0]
            parent = population.get(body.parent_ids[0]) if body.parent_ids else None
            if (
                c.brain.inherit
                and parent is not None
                and parent.best_params is not None
                and len(parent.best_params) == body.n_params
            ):
                x0 = np.asarray(parent.best_params, dtype=np.float64)
        return BrainRun(
            n_params=body.n_params,
            popsize=c.brain.popsize,
            maximise=self.plugins.maximise,
            x0=x0,
            sigma0=c.brain.sigma0,
            seed=derive_seed(seed, "cma", body.number),
        )

    def job(self, body: Body, run: BrainRun, target: int) -> _Job:
        timestep = self.model(body).opt.timestep
        record_every = record_steps(self.config, timestep)
        return _Job(
            body=body,
            spec=shipped_body(self.config, self.body_spec(body.genotype)),
            run=run,
            target=target if body.n_params else 1,
            eval_seed=derive_seed(self.config.seed, "evaluation", body.number),
            record_every=record_every,
        )

    def model(self, body: Body) -> Any:
        """The body's compiled model (compiled again for a body restored from a checkpoint)."""
        if body.number not in self._models:
            self.new_body(body.number, body.genotype, body.parent_ids, body.born)
        return self._models[body.number]

    def forget_models(self, alive: Sequence[Body]) -> None:
        """Drop the compiled models of bodies not in ``alive`` (each holds ~0.3 MB: a run of
        days would keep every body it ever made)."""
        keep = {body.number for body in alive}
        for number in [n for n in self._models if n not in keep]:
            del self._models[number]

    # -- brain learning: all jobs side by side -------------------------------------------------

    def learn(
        self,
        jobs: Sequence[_Job],
        generation: int,
        executor: Any,
        capacity: int,
        progress: Progress,
    ) -> None:
        from ariel.evaluation import evaluate_batch
        from ariel.evaluation.executors import submit_with_timeout, worker_fault
        from ariel.evolution._checks import plugin_failure

        in_flight: dict[cf.Future, tuple[_Job, Any]] = {}
        batches: dict[int, dict[str, Any]] = {}
        timeout = self.config.executor.timeout

        def send(job: _Job, tasks: list[Any], part: Any) -> None:
            # A call of k evaluations may take k times one evaluation's timeout.
            chunk = [tasks[i] for i in part]
            future = submit_with_timeout(executor, timeout * len(chunk), evaluate_batch, chunk)
            in_flight[future] = (job, part)

        def launch(job: _Job) -> None:
            params = job.run.ask()
            iteration = job.run.iteration
            tasks = [
                self.task(
                    job.spec,
                    p,
                    seed=job.eval_seed,
                    record_every=job.record_every,
                    record_bodies=self.recorder is not None and self.recorder.record_bodies,
                    eval_id=f"{job.body.body_id}-i{iteration:03d}-c{k:03d}",
                )
                for k, p in enumerate(params)
            ]
            active = sum(1 for j in jobs if j.run.iteration < j.target)
            chunks = max(1, min(len(tasks), math.ceil(capacity / max(1, active))))
            batches[job.body.number] = {
                "params": params,
                "tasks": tasks,
                "results": [None] * len(tasks),
                "left": chunks,
            }
            for part in np.array_split(np.arange(len(tasks)), chunks):
                send(job, tasks, part)

        try:
            for job in jobs:
                if job.run.iteration < job.target:
                    launch(job)
            while in_flight:
                done, _ = cf.wait(list(in_flight), return_when=cf.FIRST_COMPLETED)
                for future in done:
                    job, part = in_flight.pop(future)
                    batch = batches[job.body.number]
                    try:
                        results = future.result()
                    except Exception as exc:
                        reason = worker_fault(exc)  # its worker died too often, or a timeout
                        if len(part) > 1:  # one at a time: the bad one fails, the rest finish
                            batch["left"] += len(part) - 1
                            for i in part:
                                send(job, batch["tasks"], [i])
                            continue
                        if reason is None:  # the evaluation raised: a plugin failed
                            task = batch["tasks"][part[0]]
                            raise plugin_failure(self.folder.path, self.config, task, exc) from exc
                        results = [self.failed_result(batch["tasks"][part[0]], reason)]
                    for i, result in zip(part, results):
                        batch["results"][i] = result
                    batch["left"] -= 1
                    if batch["left"]:
                        continue
                    self.finish_batch(job, batch, generation)
                    progress.advance(len(batch["tasks"]), self.best_so_far(jobs))
                    if job.run.iteration < job.target:
                        launch(job)
                    self.write_recordings()  # once the job's next batch is on its way
        except BaseException:
            for future in in_flight:
                future.cancel()
            raise

    def failed_result(self, task: Any, reason: str) -> Any:
        """The result of an evaluation lost to its worker: ``error``, the worst fitness."""
        from ariel.evaluation import EvaluationResult

        return EvaluationResult(
            eval_id=task.eval_id, fitness=self.plugins.worst, status="error", error=reason
        )

    def best_so_far(self, jobs: Sequence[_Job]) -> float:
        values = [j.run.best_fitness for j in jobs if not math.isnan(j.run.best_fitness)]
        if not values:
            return math.nan
        return max(values) if self.plugins.maximise else min(values)

    def finish_batch(self, job: _Job, batch: dict[str, Any], generation: int) -> None:
        results = batch["results"]
        iteration = job.run.iteration
        improved = job.run.tell(batch["params"], np.array([r.fitness for r in results]))
        body = job.body
        body.evaluations += len(results)
        for k, (task, result) in enumerate(zip(batch["tasks"], results)):
            key = (body.number, iteration, k)
            self._rows[key] = self.evaluation_row(body, task, result, generation, iteration, k)
            if self.recorder is not None and result.time.size:
                self._recordings.append(
                    dict(
                        model=self.model(body),
                        body=body,
                        task=task,
                        result=result,
                        generation=generation,
                        iteration=iteration,
                        candidate=k,
                        new_best=k == improved,
                    )
                )
            if self.config.record.trajectories and result.time.size:
                self._frames[key] = (task.eval_id, result)
        if improved is not None:
            body.fitness = job.run.best_fitness
            body.best_params = job.run.best_params.tolist()  # type: ignore[union-attr]
            body.best_eval_id = batch["tasks"][improved].eval_id

    def write_recordings(self) -> None:
        """Write the Rerun recordings of the evaluations finished since the last call."""
        while self._recordings:
            evaluation = self._recordings.pop(0)
            self.recorder.evaluation(**evaluation)  # type: ignore[union-attr]
            result = evaluation["result"]
            result.body_pos = result.body_quat = None  # recorded; not kept till the tables

    def evaluation_row(
        self, body: Body, task: Any, result: Any, generation: int, iteration: int, k: int
    ) -> dict[str, Any]:
        c = self.config
        return {
            "run_id": self.run_id,
            "generation": generation,
            "body_id": body.body_id,
            "eval_id": task.eval_id,
            "iteration": iteration,
            "candidate": k,
            "parent_ids": list(body.parent_ids),
            "body_encoder": c.body.encoder,
            "body_genotype": json.dumps(body.genotype),
            "controller": c.brain.controller,
            "controller_params": list(task.params),
            "world": c.world.name,
            "fitness_fn": c.task.fitness,
            "fitness": float(result.fitness),
            "status": result.status,
            "error": result.error,
            **body.descriptors,
            "n_joints": body.n_joints,
            "joint_names": list(body.joint_names),
            "seed": task.seed,
            "sim_seconds": float(result.sim_time),
            "wall_seconds": float(result.wall_time),
            "backend": result.backend,
        }

    def error_row(self, body: Body, generation: int) -> None:
        """An unbuildable body still appears in the evaluations table, with its error."""
        c = self.config
        worst = self.plugins.worst
        self._rows[(body.number, 0, 0)] = {
            "run_id": self.run_id,
            "generation": generation,
            "body_id": body.body_id,
            "eval_id": f"{body.body_id}-build",
            "iteration": 0,
            "candidate": 0,
            "parent_ids": list(body.parent_ids),
            "body_encoder": c.body.encoder,
            "body_genotype": json.dumps(body.genotype),
            "controller": c.brain.controller,
            "controller_params": [],
            "world": c.world.name,
            "fitness_fn": c.task.fitness,
            "fitness": worst,
            "status": "error",
            "error": body.error,
            "n_joints": 0,
            "joint_names": [],
            "seed": 0,
            "sim_seconds": 0.0,
            "wall_seconds": 0.0,
        }
        body.fitness = worst

    # -- records -------------------------------------------------------------------------------

    def write_generation(self, generation: int, bodies: list[tuple[Body, bool, bool]]) -> None:
        from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES
        from ariel.recording._load import FAILED_STATUSES
        from ariel.recording._tables import evaluation_schema, trajectory_columns, write_table

        def columns(rows: list[dict[str, Any]], schema: Any) -> dict[str, list[Any]]:
            return {f.name: [row.get(f.name) for row in rows] for f in schema}

        rows = [self._rows[key] for key in sorted(self._rows)]
        self.rows_written = len(rows)
        self.failed_written = {
            status: sum(row["status"] == status for row in rows) for status in FAILED_STATUSES
        }
        write_table(self.folder.path, "evaluations", generation, columns(rows, evaluation_schema()))
        if self.config.record.trajectories:
            frames = [self._frames[key] for key in sorted(self._frames)]
            trajectories = trajectory_columns(generation, frames)
            write_table(self.folder.path, "trajectories", generation, trajectories)
        body_rows = []
        for body, is_new, selected in bodies:
            body_rows.append(
                {
                    "run_id": self.run_id,
                    "generation": generation,
                    "body_id": body.body_id,
                    "parent_ids": list(body.parent_ids),
                    "born_generation": body.born,
                    "body_encoder": self.config.body.encoder,
                    "body_genotype": json.dumps(body.genotype),
                    "graph": body.graph,
                    **{name: body.descriptors.get(name) for name in DESCRIPTOR_NAMES},
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
        body_rows.sort(key=lambda row: row["body_id"])
        from ariel.recording._tables import body_schema

        write_table(self.folder.path, "bodies", generation, columns(body_rows, body_schema()))
        if self.recorder is not None:
            self.recorder.generation(generation, body_rows)
        self._rows.clear()
        self._frames.clear()

    # -- the GA --------------------------------------------------------------------------------

    def tournament(self, population: list[Body], rng: np.random.Generator) -> Body:
        size = min(self.config.body.tournament, len(population))
        picks = rng.choice(len(population), size=size, replace=False)
        return min(
            (population[i] for i in sorted(picks)),
            key=lambda b: (fitness_rank(b.fitness, self.plugins.maximise), b.number),
        )

    def offspring(self, state: LoopState, generation: int) -> list[Body]:
        c, encoder = self.config, self.plugins.encoder
        children = []
        for j in range(c.body.offspring):
            rng = derive_rng(c.seed, "variation", generation, j)
            first = self.tournament(state.population, rng)
            if len(state.population) > 1 and rng.random() < c.body.crossover_rate:
                second = self.tournament(state.population, rng)
                genotype = encoder.crossover(first.genotype, second.genotype, rng)
                parents = [first.body_id, second.body_id]
            else:
                genotype, parents = first.genotype, [first.body_id]
            genotype = encoder.mutate(genotype, rng)
            children.append(self.new_body(state.next_body, genotype, parents, generation))
            state.next_body += 1
        return children

    def survivors(self, parents: list[Body], children: list[Body]) -> list[Body]:
        pool = children if self.config.body.survivors == "generational" else parents + children
        ranked = sorted(
            pool, key=lambda b: (fitness_rank(b.fitness, self.plugins.maximise), b.number)
        )
        return ranked[: self.config.body.population]


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------


def _fixed_genotype(config: ExperimentConfig, plugins: _Plugins) -> Any:
    """The body of a brain-only run: ``body.genotype``, else the encoder's random one."""
    if config.body.genotype is not None:
        return config.body.genotype
    return plugins.encoder.random_genotype(derive_rng(config.seed, "body-init", 0))


def _check_fixed_body(experiment: _Experiment) -> None:
    """A brain-only run's body must build: a bad ``body.genotype`` is a config error."""
    config = experiment.config
    body = experiment.new_body(0, _fixed_genotype(config, experiment.plugins), [], 0)
    if body.status == "error":
        shown = describe(config.body.genotype)
        raise ConfigError(f"body.genotype: {shown} gives no body: {body.error}")


def _budget(config: ExperimentConfig, brain_only: bool) -> int:
    per_body = config.brain.popsize * config.brain.iterations
    if brain_only:
        return config.generations * per_body
    return (config.body.population + (config.generations - 1) * config.body.offspring) * per_body


def _executor_capacity(kind: str, executor: Any, workers: int | None) -> int:
    from ariel.evaluation.executors import default_workers

    if kind in ("serial", "gpu"):  # gpu: a body's whole batch as one set of worlds
        return 1
    if kind == "dask":
        with contextlib.suppress(Exception):
            return max(1, sum(executor.client.nthreads().values()))
    return workers or default_workers()


def _summary(population: list[Body], maximise: bool) -> tuple[float, float]:
    values = np.array([b.fitness for b in population if math.isfinite(b.fitness)])
    if values.size == 0:
        return math.nan, math.nan
    return float(values.max() if maximise else values.min()), float(values.mean())


def _drive(
    experiment: _Experiment,
    state: LoopState | None,
    executor_kind: str,
    workers: int | None,
    scheduler: str | None,
    show_progress: bool | None,
) -> RunResult:
    from threadpoolctl import threadpool_limits

    from ariel.evaluation import make_executor
    from ariel.recording._manifest import write_manifest
    from ariel.recording._run_folder import now

    config, folder = experiment.config, experiment.folder
    start = time.perf_counter()
    total = _budget(config, experiment.brain_only)
    done = state.budget_done if state else 0
    wall_before = state.wall_seconds if state else 0.0
    progress = Progress(
        total=total,
        done=done,
        enabled=show_progress is not False,
        live=None if show_progress is None else show_progress,
    )
    options: dict[str, Any] = {"workers": workers}
    if executor_kind == "gpu":
        options["device"] = config.executor.device
    if executor_kind == "dask":
        options["scheduler"] = scheduler
    if executor_kind == "local" or (executor_kind == "dask" and scheduler is None):
        options["max_retries"] = config.executor.max_retries
    folder.update_info(
        status="running",
        executor={"kind": executor_kind, "workers": workers, "scheduler": scheduler},
        # What the checkpoint holds: run.json may lag behind it when a kill came between them.
        generations_done=0 if state is None else state.generation + 1,
    )
    if progress.enabled:
        print(f"run {experiment.run_id}: {folder.path} ({total} evaluations)", flush=True)
    status = "failed"
    try:
        # BLAS in this process (pycma's eigendecompositions) stays on one thread.
        with (
            threadpool_limits(limits=1),
            make_executor(executor_kind, **options) as executor,
            progress,
        ):
            capacity = _executor_capacity(executor_kind, executor, workers)
            first = 0 if state is None else state.generation + 1
            for generation in range(first, config.generations):
                progress.start_generation(generation)
                state = _one_generation(experiment, state, generation, executor, capacity, progress)
                write_manifest(folder.path, generation)  # before the checkpoint: see _manifest
                state.evaluations_done += experiment.rows_written
                state.budget_done = progress.done
                state.wall_seconds = wall_before + time.perf_counter() - start
                folder.save_checkpoint(state)
                best, mean = _summary(state.population, experiment.plugins.maximise)
                folder.update_info(
                    generations_done=generation + 1,
                    evaluations_done=state.evaluations_done,
                    best_fitness=best,
                    updated=now(),
                )
                failed = experiment.failed_written
                extra = "".join(f", {n} {status}" for status, n in failed.items() if n)
                progress.end_generation(generation, best, mean, extra)
        status = "finished"
    except KeyboardInterrupt:
        status = "interrupted"
        raise
    finally:
        wall = wall_before + time.perf_counter() - start
        # On a full disk this write fails too: then the first error is the one to tell.
        with contextlib.suppress(OSError) if status != "finished" else contextlib.nullcontext():
            folder.update_info(status=status, ended=now(), wall_seconds=wall)
    assert state is not None
    best_body = min(
        state.population,
        key=lambda b: (fitness_rank(b.fitness, experiment.plugins.maximise), b.number),
    )
    return RunResult(
        run_dir=folder.path,
        run_id=experiment.run_id,
        status=status,
        generations=config.generations,
        evaluations=state.evaluations_done,
        best_fitness=best_body.fitness,
        best_body_id=best_body.body_id,
        best_eval_id=best_body.best_eval_id,
        wall_seconds=wall,
    )


def _one_generation(
    experiment: _Experiment,
    state: LoopState | None,
    generation: int,
    executor: Any,
    capacity: int,
    progress: Progress,
) -> LoopState:
    config = experiment.config
    if experiment.brain_only:
        if state is None:
            body = experiment.new_body(0, _fixed_genotype(config, experiment.plugins), [], 0)
            if body.status == "error":  # checked in run_experiment already
                raise RuntimeError(f"the fixed body cannot be built: {body.error}")
            state = LoopState(config_hash(config), -1, 1, [body], experiment.new_brain(body, {}))
        body = state.population[0]
        assert state.brain is not None
        target = (generation + 1) * config.brain.iterations
        experiment.learn(
            [experiment.job(body, state.brain, target)], generation, executor, capacity, progress
        )
        experiment.write_generation(generation, [(body, generation == 0, True)])
        state.generation = generation
        return state

    if state is None:
        state = LoopState(config_hash(config), -1, 0, [])
        parents: list[Body] = []
        children = []
        for i in range(config.body.population):
            rng = derive_rng(config.seed, "body-init", i)
            genotype = experiment.plugins.encoder.random_genotype(rng)
            children.append(experiment.new_body(state.next_body, genotype, [], generation))
            state.next_body += 1
    else:
        parents = state.population
        children = experiment.offspring(state, generation)
    by_id = {b.body_id: b for b in parents}
    jobs = []
    for child in children:
        if child.status == "error":
            experiment.error_row(child, generation)
            progress.advance(config.brain.popsize * config.brain.iterations)
            continue
        run = experiment.new_brain(child, by_id)
        jobs.append(experiment.job(child, run, config.brain.iterations))
        # Bodies without parameters get one evaluation: count the rest as done.
        if child.n_params == 0:
            progress.advance(config.brain.popsize * config.brain.iterations - 1)
    experiment.learn(jobs, generation, executor, capacity, progress)
    survivors = children if generation == 0 else experiment.survivors(parents, children)
    kept = {b.body_id for b in survivors}
    experiment.write_generation(
        generation, [(b, b in children, b.body_id in kept) for b in parents + children]
    )
    state.population = survivors
    experiment.forget_models(survivors)
    state.generation = generation
    return state


# --------------------------------------------------------------------------------------------
# Public entry points
# --------------------------------------------------------------------------------------------


def _new_run_id(config: ExperimentConfig) -> str:
    import datetime as _dt

    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return f"{config.name}-{stamp}-s{config.seed}"


def run_experiment(
    config: ExperimentConfig | str | Path | dict[str, Any] | None = None,
    *,
    out: str | Path | None = None,
    overwrite: bool = False,
    executor: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = False,
    overrides: Sequence[str] = (),
) -> RunResult:
    """Run one experiment into a new run folder and return its summary.

    ``config``: a config object, a TOML path, a dict, or None for the default experiment.
    ``out``: the run folder (default ``data/runs/<run-id>``); an existing one needs
    ``overwrite``. ``executor`` / ``workers`` / ``scheduler`` override the config's executor.
    ``progress``: None shows progress (live on a terminal), False prints nothing.
    Everything is validated before anything is written.
    """
    from ariel.evaluation.executors import default_workers
    from ariel.evolution._checks import check_plugins, check_resources, refuse_in_spawned_child
    from ariel.plugins import plugin_provenance
    from ariel.recording._lock import RunLock
    from ariel.recording._manifest import MANIFEST_FORMAT
    from ariel.recording._run_folder import (
        RunFolder,
        git_commit,
        now,
        software_versions,
        storage_errors,
    )

    refuse_in_spawned_child()
    config = load_config(config, overrides)
    kind = executor or config.executor.kind
    workers = workers if workers is not None else config.executor.workers
    scheduler = scheduler if scheduler is not None else config.executor.scheduler
    _check_executor(kind, workers, scheduler, config.executor.device)
    plugins = _resolve(config)
    config = _read_genotype_file(config, plugins.encoder)
    run_id = _new_run_id(config)
    path = Path(out) if out is not None else Path("data") / "runs" / run_id
    if out is not None:
        run_id = path.name or run_id
    RunFolder.check_new(path, overwrite=overwrite)
    experiment = _Experiment(config, plugins, RunFolder(path), run_id)
    if experiment.brain_only:
        _check_fixed_body(experiment)
    check_plugins(config)
    check_resources(
        config,
        plugins.encoder,
        brain_only=experiment.brain_only,
        capacity=1 if kind in ("serial", "gpu") else workers or default_workers(),
        local_workers=kind in ("local", "serial") or (kind == "dask" and scheduler is None),
    )
    provenance = plugin_provenance(
        {
            "body_encoder": config.body.encoder,
            "controller": config.brain.controller,
            "world": config.world.name,
            "fitness": config.task.fitness,
        }
    )
    info = {
        "run_id": run_id,
        "name": config.name,
        "status": "created",
        "seed": config.seed,
        "config": config.to_plain(),
        "config_hash": config_hash(config),
        "versions": software_versions(),
        "git_commit": git_commit(),
        "plugins": provenance,
        "created": now(),
        "generations_done": 0,
        "evaluations_done": 0,
        # What readers need without the run's plugins (report, load_run, runs, view).
        "maximise": plugins.maximise,
        "brain_only": experiment.brain_only,
        "manifests": MANIFEST_FORMAT,
    }
    # The lock is held for the whole run; create() checks the folder again under it.
    with storage_errors(path), RunLock(path, create=True):
        RunFolder.create(path, info, overwrite=overwrite, locked=True).start_segment("run")
        return _drive(experiment, None, kind, workers, scheduler, progress)


def _read_genotype_file(config: ExperimentConfig, encoder: Any) -> ExperimentConfig:
    """The config holding the genotype itself when ``body.genotype`` names a file (checked)."""
    from ariel.evolution._genotype import read_genotype_file

    if not is_genotype_file(config.body.genotype):
        return config
    path = config.body.genotype
    genotype = read_genotype_file(path)
    check_genotype(genotype, encoder, f"body.genotype: file {path!r}")
    body = config.body.model_copy(update={"genotype": genotype})
    return config.model_copy(update={"body": body})


def _check_executor(kind: str, workers: int | None, scheduler: str | None, device: str) -> None:
    """The executor's settings, and for ``gpu`` MuJoCo Warp and its device: `ConfigError`."""
    from ariel.evaluation.executors import EXECUTOR_KINDS

    if kind not in EXECUTOR_KINDS:
        raise ConfigError(
            f"executor.kind: unknown executor {kind!r}; known: {', '.join(EXECUTOR_KINDS)}"
        )
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ConfigError(f"executor.workers: must be an integer >= 1 (got {workers!r})")
    if kind == "serial" and workers not in (None, 1):
        raise ConfigError(f"executor.workers: the serial executor has 1 worker (got {workers})")
    if kind == "gpu" and workers not in (None, 1):
        raise ConfigError(f"executor.workers: the gpu executor runs on one device (got {workers})")
    if scheduler is not None and kind != "dask":
        raise ConfigError(f"executor.scheduler: only for the dask executor, not {kind!r}")
    if scheduler is not None and workers is not None:
        raise ConfigError(
            "executor.workers: sizes a local cluster; with executor.scheduler the cluster's own "
            "workers are used (scale the cluster instead)"
        )
    if kind == "gpu":
        from ariel.evaluation._warp import WarpUnavailableError, check_device, warp_modules

        try:
            warp_modules()
        except WarpUnavailableError as exc:
            raise ConfigError(f"executor.kind: {exc}") from None
        try:
            check_device(device)
        except WarpUnavailableError as exc:
            raise ConfigError(
                f"executor.device: {exc}; or the CPU engine: --executor local"
            ) from None


def resume_experiment(
    run_dir: str | Path,
    *,
    executor: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = False,
) -> RunResult:
    """Continue a killed or interrupted run from its last finished generation.

    Refuses a folder that is not a run, a finished run, a run whose config was edited, and a
    run that another process is running (`RunInUseError`), before writing anything.
    """
    from ariel.evolution._checks import check_plugins
    from ariel.recording._lock import RunLock
    from ariel.recording._manifest import adopt_manifests
    from ariel.recording._run_folder import RunFolder, storage_errors

    folder = RunFolder(run_dir)
    info, config, state = _resumable(folder)
    # Unless told otherwise, continue where the run last ran (results do not depend on it).
    last = info.get("executor") or {}
    kind = executor or last.get("kind") or config.executor.kind
    if executor is None or executor == last.get("kind"):
        workers = workers if workers is not None else last.get("workers")
        scheduler = scheduler if scheduler is not None else last.get("scheduler")
    _check_executor(kind, workers, scheduler, config.executor.device)
    plugins = _resolve(config)
    check_plugins(config)
    with storage_errors(folder.path), RunLock(folder.path):
        # Again under the lock: another resume may have run (or finished) the run meanwhile.
        info, config, state = _resumable(folder)
        adopt_manifests(folder, state.generation + 1 if state is not None else 0)
        folder.discard_after(state.generation if state is not None else -1)
        folder.start_segment("resume")
        experiment = _Experiment(config, plugins, folder, info["run_id"])
        return _drive(experiment, state, kind, workers, scheduler, progress)


def _resumable(folder: Any) -> tuple[dict[str, Any], ExperimentConfig, LoopState | None]:
    """run.json, config and checkpoint of a run that may be resumed; `ValueError` else."""
    info = folder.read_info()
    if info.get("status") == "finished":
        raise ValueError(f"run {str(folder.path)!r} is already finished; nothing to resume")
    try:
        config = ExperimentConfig.from_plain(info["config"])
    except (KeyError, ConfigError) as exc:
        raise ValueError(f"run {str(folder.path)!r}: its config cannot be read ({exc})") from None
    digest = config_hash(config)
    state = folder.load_checkpoint()
    if digest != info.get("config_hash") or (state is not None and state.config_hash != digest):
        raise ValueError(
            f"run {str(folder.path)!r}: its config was edited after the run started (hash "
            "mismatch); start a new run with the new config instead"
        )
    return info, config, state
