"""`run_experiment` and `resume_experiment`: one run, from its config to its finished folder.

Everything is checked before anything is written: the config, the executor settings, every
plugin the config names (with its options), a fixed body. Then the run folder is created
under its lock, and the evolution driver runs on the executor, writing through the
records writer of `ariel.recording`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ariel.evolution._config import ConfigError, ExperimentConfig, config_hash, load_config
from ariel.evolution._driver import Plugins, RunDriver, budget, drive, fixed_genotype
from ariel.evolution._genotype import check_genotype, describe, is_genotype_file
from ariel.evolution._progress import Progress
from ariel.evolution._state import LoopState, state_from_plain

__all__ = ["RunResult", "resolve_plugins", "resume_experiment", "run_experiment"]


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


def _make(key: str, registry: Any, name: str, options: dict[str, Any]) -> Any:
    try:
        registry.get(name)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"{key}: {exc}") from None
    try:
        return registry.make(name, **options)
    except (TypeError, ValueError) as exc:
        options_key = key.rsplit(".", 1)[0] + ".options"
        raise ConfigError(f"{options_key}: {registry.label} '{name}': {exc}") from None


def _check_fitness_options(config: ExperimentConfig, fitness: Any) -> None:
    import inspect

    try:
        signature = inspect.signature(fitness)
    except (TypeError, ValueError):  # a callable without a readable signature: not checked
        return
    try:
        signature.bind(None, **config.task.options)
    except TypeError as exc:
        raise ConfigError(
            f"task.options: fitness function '{config.task.fitness}': {exc}"
        ) from None


def _optimizer_factory(config: ExperimentConfig, encoder: Any, maximise: bool) -> Any:
    """``(**keywords) -> BodyOptimizer`` for ``body.optimizer``, made once here to check it."""
    from ariel.plugins import body_optimizers

    body = config.body
    try:
        cls = body_optimizers.get(body.optimizer)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"body.optimizer: {exc}") from None

    def make(**keywords: Any) -> Any:
        return cls(**keywords, **body.optimizer_options)

    try:
        make(encoder=encoder, seed=config.seed, maximise=maximise, settings=body)
    except (TypeError, ValueError) as exc:
        first = (str(exc).splitlines() or [""])[0]
        raise ConfigError(f"body.optimizer_options: {body.optimizer!r}: {first}") from None
    return make


def resolve_plugins(config: ExperimentConfig) -> Plugins:
    """Make every plugin the config names; a bad name or option is a `ConfigError`."""
    from ariel.plugins import body_encoders, controllers, fitness_functions, worlds

    encoder = _make("body.encoder", body_encoders, config.body.encoder, config.body.options)
    controller = _make(
        "brain.controller", controllers, config.brain.controller, config.brain.options
    )
    _make("world.name", worlds, config.world.name, config.world.options)
    try:
        fitness = fitness_functions.get(config.task.fitness)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"task.fitness: {exc}") from None
    _check_fitness_options(config, fitness)
    if config.body.genotype is not None and not is_genotype_file(config.body.genotype):
        check_genotype(config.body.genotype, encoder)  # a file is checked as it is read
    if config.body.survivors == "generational" and config.body.offspring < config.body.population:
        raise ConfigError(
            f"body.offspring: generational survival needs offspring >= population "
            f"({config.body.population}), got {config.body.offspring}"
        )
    maximise = bool(fitness.maximise)
    optimizer = _optimizer_factory(config, encoder, maximise)
    return Plugins(encoder, controller, fitness, optimizer)


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


def _check_fixed_body(config: ExperimentConfig, plugins: Plugins) -> None:
    """A brain-only run's body must build: a bad ``body.genotype`` is a config error."""
    from ariel.evolution._bodies import BodyFactory

    factory = BodyFactory(config, plugins.encoder, plugins.controller, plugins.maximise)
    body = factory.new_body(0, fixed_genotype(config, plugins.encoder), [], 0)
    if body.status == "error":
        shown = describe(config.body.genotype)
        raise ConfigError(f"body.genotype: {shown} gives no body: {body.error}")


def _executor_settings(config: ExperimentConfig, **given: Any) -> Any:
    """The config's ``[executor]`` with the caller's overrides, checked: `ConfigError`."""
    from ariel.evaluation.executors import ExecutorSettingsError, check_settings

    changes = {key: value for key, value in given.items() if value is not None}
    settings = config.executor.model_copy(update=changes)
    try:
        check_settings(settings)
    except ExecutorSettingsError as exc:
        raise ConfigError(str(exc)) from None
    return settings


# --------------------------------------------------------------------------------------------
# Driving a run in its folder
# --------------------------------------------------------------------------------------------


def _drive(
    config: ExperimentConfig,
    plugins: Plugins,
    folder: Any,
    run_id: str,
    state: LoopState | None,
    settings: Any,
    show_progress: bool | None,
) -> RunResult:
    from ariel.evolution._driver import is_brain_only
    from ariel.recording._rows import RunWriter
    from ariel.recording._run_folder import now

    writer = RunWriter(folder, config, run_id, maximise=plugins.maximise)
    total = budget(config, is_brain_only(config, plugins.encoder))
    progress = Progress(
        total=total,
        done=state.budget_done if state else 0,
        enabled=show_progress is not False,
        live=None if show_progress is None else show_progress,
    )
    driver = RunDriver(config, plugins, writer, progress, state)
    folder.update_info(
        status="running",
        executor={
            "kind": settings.kind,
            "workers": settings.workers,
            "scheduler": settings.scheduler,
        },
        # What the checkpoint holds: run.json may lag behind it when a kill came between them.
        generations_done=driver.first_generation,
    )
    if driver.progress.enabled:
        print(f"run {run_id}: {folder.path} ({total} evaluations)", flush=True)
    status = "failed"
    try:
        drive(driver, settings)
        status = "finished"
    except KeyboardInterrupt:
        status = "interrupted"
        raise
    finally:
        # On a full disk this write fails too: then the first error is the one to tell.
        with contextlib.suppress(OSError) if status != "finished" else contextlib.nullcontext():
            folder.update_info(status=status, ended=now(), wall_seconds=driver.wall_seconds)
    best = driver.best_body()
    return RunResult(
        run_dir=folder.path,
        run_id=run_id,
        status=status,
        generations=config.generations,
        evaluations=driver.state.evaluations_done if driver.state else 0,
        best_fitness=best.fitness,
        best_body_id=best.body_id,
        best_eval_id=best.best_eval_id,
        wall_seconds=driver.wall_seconds,
    )


def _new_run_id(config: ExperimentConfig) -> str:
    import datetime as _dt

    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return f"{config.name}-{stamp}-s{config.seed}"


def _run_info(
    config: ExperimentConfig, run_id: str, *, maximise: bool, brain_only: bool
) -> dict[str, Any]:
    from ariel.plugins import plugin_provenance
    from ariel.recording._manifest import MANIFEST_FORMAT
    from ariel.recording._run_folder import git_commit, now, software_versions

    provenance = plugin_provenance(
        {
            "body_encoder": config.body.encoder,
            "controller": config.brain.controller,
            "world": config.world.name,
            "fitness": config.task.fitness,
            "body_optimizer": config.body.optimizer,
        }
    )
    return {
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
        "maximise": maximise,
        "brain_only": brain_only,
        "manifests": MANIFEST_FORMAT,
    }


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
    from ariel.evaluation.executors import planned_workers
    from ariel.evolution._checks import check_plugins, check_resources, refuse_in_spawned_child
    from ariel.evolution._driver import is_brain_only
    from ariel.recording._lock import RunLock
    from ariel.recording._run_folder import RunFolder, storage_errors

    refuse_in_spawned_child()  # a script without a __main__ guard, re-run by a pool worker
    config = load_config(config, overrides)
    settings = _executor_settings(config, kind=executor, workers=workers, scheduler=scheduler)
    plugins = resolve_plugins(config)
    config = _read_genotype_file(config, plugins.encoder)
    run_id = _new_run_id(config)
    path = Path(out) if out is not None else Path("data") / "runs" / run_id
    if out is not None:
        run_id = path.name or run_id
    RunFolder.check_new(path, overwrite=overwrite)
    brain_only = is_brain_only(config, plugins.encoder)
    if brain_only:
        _check_fixed_body(config, plugins)
    check_plugins(config)
    capacity, local_workers = planned_workers(settings)
    check_resources(
        config,
        plugins.encoder,
        brain_only=brain_only,
        capacity=capacity,
        local_workers=local_workers,
    )
    info = _run_info(config, run_id, maximise=plugins.maximise, brain_only=brain_only)
    # The lock is held for the whole run; create() checks the folder again under it.
    with storage_errors(path), RunLock(path, create=True):
        folder = RunFolder.create(path, info, overwrite=overwrite, locked=True)
        folder.start_segment("run")
        return _drive(config, plugins, folder, run_id, None, settings, progress)


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
    info, config, _ = _resumable(folder)
    # Unless told otherwise, continue where the run last ran (results do not depend on it).
    last = info.get("executor") or {}
    kind = executor or last.get("kind") or config.executor.kind
    if executor is None or executor == last.get("kind"):
        workers = workers if workers is not None else last.get("workers")
        scheduler = scheduler if scheduler is not None else last.get("scheduler")
    settings = _executor_settings(config, kind=kind, workers=workers, scheduler=scheduler)
    plugins = resolve_plugins(config)
    check_plugins(config)
    with storage_errors(folder.path), RunLock(folder.path):
        # Again under the lock: another resume may have run (or finished) the run meanwhile.
        info, config, state = _resumable(folder)
        adopt_manifests(folder, state.generation + 1 if state is not None else 0)
        folder.discard_after(state.generation if state is not None else -1)
        folder.start_segment("resume")
        return _drive(config, plugins, folder, info["run_id"], state, settings, progress)


def _resumable(folder: Any) -> tuple[dict[str, Any], ExperimentConfig, LoopState | None]:
    """run.json, config and checkpoint of a run that may be resumed; `ValueError` else."""
    from ariel.recording._run_folder import NotARunError

    info = folder.read_info()
    if info.get("status") == "finished":
        raise ValueError(f"run {str(folder.path)!r} is already finished; nothing to resume")
    try:
        config = ExperimentConfig.from_plain(info["config"])
    except (KeyError, ConfigError) as exc:
        raise ValueError(f"run {str(folder.path)!r}: its config cannot be read ({exc})") from None
    digest = config_hash(config)
    plain = folder.load_checkpoint()
    try:
        state = None if plain is None else state_from_plain(plain)
    except ValueError as exc:
        raise NotARunError(f"{folder.checkpoint}: unreadable checkpoint ({exc})") from None
    if digest != info.get("config_hash") or (state is not None and state.config_hash != digest):
        raise ValueError(
            f"run {str(folder.path)!r}: its config was edited after the run started (hash "
            "mismatch); start a new run with the new config instead"
        )
    return info, config, state
