"""`run_experiment` and `resume_experiment`: one run, from its config to its finished folder.

Everything is checked before anything is written: the config, the executor settings, every
plugin the config names (with its options), a fixed body. Then the run folder is created
under its lock, and the evolution driver runs on the executor, writing through the
records writer of `ariel.recording`.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import shutil
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

from ariel import evolution
from ariel.evaluation import WorkerCannotStartError
from ariel.evaluation.executors import planned_workers
from ariel.evolution import (
    ConfigError,
    ExecutorConfig,
    ExperimentConfig,
    LoopState,
    Plugins,
    Progress,
    RunDriver,
    budget,
    check_resources,
    config_hash,
    is_brain_only,
    load_config,
    no_main_guard_line,
    refuse_in_spawned_child,
    run_groups,
    shows_progress,
    state_from_plain,
)
from ariel.plugins import plugin_provenance
from ariel.recording import Run, load_run, rerun
from ariel.recording.store import (
    MANIFEST_FORMAT,
    NotARunError,
    RunFolder,
    RunLock,
    RunWriter,
    adopt_manifests,
    git_commit,
    now,
    software_versions,
    storage_errors,
)
from ariel.runs._prepare import (  # noqa: F401 - resolve_plugins and _read_genotype_file: tests
    _read_genotype_file,
    executor_settings,
    prepare_run,
    resolve_plugins,
    resume_settings,
)
from ariel.utils import accept_aliases

__all__ = [
    "RunResult",
    "end_run",
    "executor_settings",
    "new_progress",
    "noted_on_interrupt",
    "prepare_run",
    "resolve_plugins",
    "resumable",
    "resume_experiment",
    "run_experiment",
    "run_info",
    "run_result",
    "start_driver",
]


@dataclass
class RunResult:
    """What `run_experiment` returns.

    Attributes:
        run_dir: The run folder.
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


# --------------------------------------------------------------------------------------------
# Driving a run in its folder
# --------------------------------------------------------------------------------------------


def new_progress(
    config: ExperimentConfig,
    plugins: Plugins,
    state: LoopState | None,
    show_progress: bool | None,
    kind: type[Progress] = Progress,
    **extra: Any,
) -> Progress:
    """The run's progress display (``kind``: a `Progress` class; ``extra``: its keywords);
    ``show_progress``: see `shows_progress` (None: only where someone watches)."""
    return kind(
        total=budget(config, is_brain_only(config, plugins.encoder)),
        done=state.budget_done if state else 0,
        enabled=shows_progress(show_progress),
        **extra,
    )


def start_driver(
    config: ExperimentConfig,
    plugins: Plugins,
    folder: RunFolder,
    run_id: str,
    state: LoopState | None,
    settings: ExecutorConfig,
    progress: Progress,
) -> RunDriver:
    """The run's driver, writing into ``folder`` (locked by the caller), marked running."""
    recorder = None
    if config.record.rerun:  # only then are the recorder's modules (and Rerun) loaded
        recorder = rerun.RerunRecorder(
            folder.path,
            run_id=run_id,
            bodies=config.record.bodies,
            maximise=plugins.maximise,
            config=config,
        )
    writer = RunWriter(folder, config, run_id, recorder=recorder)
    driver = RunDriver(config, plugins, writer, progress, state)
    folder.update_info(
        status="running",
        executor={
            "kind": settings.kind,
            "workers": settings.workers,
            "address": settings.address,
        },
        # What the checkpoint holds: run.json may lag behind it when a kill came between them.
        generations_done=driver.first_generation,
    )
    return driver


def end_run(folder: RunFolder, driver: RunDriver, status: str) -> None:
    """Record how the run ended (``finished``, ``interrupted``, ``failed``) in run.json."""
    # On a full disk this write fails too: then the first error is the one to tell.
    with contextlib.suppress(OSError) if status != "finished" else contextlib.nullcontext():
        folder.update_info(status=status, ended=now(), wall_seconds=driver.wall_seconds)


def run_result(driver: RunDriver, folder: RunFolder, run_id: str, status: str) -> RunResult:
    best = driver.best_body()
    return RunResult(
        run_dir=folder.path,
        run_id=run_id,
        status=status,
        generations=driver.config.generations,
        evaluations=driver.state.evaluations_done if driver.state else 0,
        best_fitness=best.fitness,
        best_body_id=best.body_id,
        best_eval_id=best.best_eval_id,
        wall_seconds=driver.wall_seconds,
    )


def _drive(
    config: ExperimentConfig,
    plugins: Plugins,
    folder: RunFolder,
    run_id: str,
    state: LoopState | None,
    settings: ExecutorConfig,
    show_progress: bool | None,
) -> RunResult:
    progress = new_progress(config, plugins, state, show_progress)
    driver = start_driver(config, plugins, folder, run_id, state, settings, progress)
    if driver.progress.enabled:
        print(f"run {run_id}: {folder.path} ({progress.total} evaluations)", flush=True)
    status = "failed"
    try:
        with progress:
            run_groups([driver.generations()], settings)
        status = "finished"
    except KeyboardInterrupt:
        status = "interrupted"
        raise
    finally:
        end_run(folder, driver, status)
    return run_result(driver, folder, run_id, status)


def new_run_id(config: ExperimentConfig) -> str:
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return f"{config.name}-{stamp}-s{config.seed}"


def run_info(config: ExperimentConfig, run_id: str, plugins: Plugins) -> dict[str, Any]:
    """A new run's run.json: config, hash, software, plugin provenance, and what readers need
    without the run's plugins (fitness direction, brain-only)."""
    provenance = plugin_provenance(
        {
            "body_encoder": config.body.encoder,
            "controller": config.brain.controller,
            "world": config.world.name,
            "fitness": config.task.fitness,
            "body_optimizer": config.body.optimizer,
            "brain_optimizer": config.brain.optimizer,
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
        "maximise": plugins.maximise,
        "brain_only": is_brain_only(config, plugins.encoder),
        "manifests": MANIFEST_FORMAT,
    }


@accept_aliases(scheduler="address")
def run_experiment(
    config: ExperimentConfig | str | Path | dict[str, Any] | None = None,
    *,
    out: str | Path | None = None,
    overwrite: bool = False,
    executor: str | None = None,
    workers: int | None = None,
    address: str | None = None,
    progress: bool | None = None,
    overrides: Sequence[str] = (),
) -> RunResult:
    """Run one experiment into a new run folder and return its summary.

    Everything is validated before anything is written.

    Ctrl-C (or SIGTERM) raises `KeyboardInterrupt` with ``run_dir`` set to the folder to pass
    to `resume_experiment`. A script that calls this at its top level without
    ``if __name__ == "__main__":``, on the local executor: its workers say so on stderr, and the
    script ends (`SystemExit`, code 2) leaving no run folder.

    Args:
        config: A config object, a TOML path, a dict, or None for the default experiment (as
            `load_config` reads them).
        out: The run folder; None (the default): ``data/runs/<run-id>``. An existing,
            non-empty one needs ``overwrite``, and its name becomes the run id.
        overwrite: Whether an existing run folder at ``out`` may be replaced (a folder that is
            not a run folder never is).
        executor: The executor kind (``"serial"``, ``"local"``, ``"dask"``, ``"gpu"``),
            overriding ``executor.kind``; None: the config's.
        workers: Worker processes, overriding ``executor.workers``; None: the config's.
        address: A running Dask scheduler's address, overriding ``executor.address``;
            None: the config's. ``scheduler=`` is its old name, still accepted.
        progress: True shows it (live bars on a terminal, else a line per generation), False
            prints nothing, None (the default) shows it where someone watches: when stdout or
            stderr is a terminal, or in a Jupyter notebook.
        overrides: ``key=value`` strings with dotted keys (``--set``), applied to ``config``.

    Returns:
        The run's summary; ``RunResult.load()`` reads its records.

    Raises:
        ConfigError: For a bad config, override, executor setting or plugin option.
        FileExistsError: When ``out`` exists and is not a folder, or is a non-empty folder
            and ``overwrite`` is False or it is not a run folder.
        RunInUseError: When another process runs in ``out``.
        RunStorageError: When the run folder cannot be written (disk full, read-only); the
            finished generations are kept for `resume_experiment`.

    Example:
        A short brain-only run on the serial executor, from the repository's root:

        ```python
        import ariel

        if __name__ == "__main__":  # needed: the local executor's workers import this script
            result = ariel.run_experiment(
                "experiments/gecko_gait.toml",
                executor="serial",
                progress=False,
                overrides=["generations=2", "brain.popsize=4", "brain.iterations=1"],
            )
            print(result.status, result.best_fitness, result.run_dir)
            run = result.load()  # pandas: run.evaluations, run.bodies, run.generations, ...
        ```
    """
    refuse_in_spawned_child()  # a script without a __main__ guard, re-run by a pool worker
    config = load_config(config, overrides)
    settings = executor_settings(config, kind=executor, workers=workers, address=address)
    config, plugins = prepare_run(config)
    capacity, local_workers = planned_workers(settings)
    check_resources(
        config,
        plugins.encoder,
        brain_only=is_brain_only(config, plugins.encoder),
        capacity=capacity,
        local_workers=local_workers,
    )
    run_id = new_run_id(config)
    path = Path(out) if out is not None else Path("data") / "runs" / run_id
    if out is not None:
        run_id = path.name or run_id
    RunFolder.check_new(path, overwrite=overwrite)
    info = run_info(config, run_id, plugins)
    try:
        # The lock is held for the whole run; create() checks the folder again under it.
        with storage_errors(path), RunLock(path, create=True):
            folder = RunFolder.create(path, info, overwrite=overwrite, locked=True)
            with noted_on_interrupt("run_dir", folder.path):
                folder.start_segment("run")
                return _drive(config, plugins, folder, run_id, None, settings, progress)
    except Exception as exc:
        if not _worker_cannot_start(exc):
            raise
    _end_script_without_main_guard(path, progress)


def _end_script_without_main_guard(path: Path, progress: bool | None) -> NoReturn:
    """A worker re-imported this script, which has no ``__main__`` guard, and said so in one
    line on stderr (`refuse_in_spawned_child`); a traceback would bury it. Nothing ran: the
    new run folder goes, and the script ends (exit code 2). A live progress display on the
    terminal may have drawn over the workers' lines: then the line again, below it."""
    shutil.rmtree(path, ignore_errors=True)
    isatty = getattr(sys.stdout, "isatty", None)
    if shows_progress(progress) and callable(isatty) and isatty():
        print(no_main_guard_line(), file=sys.stderr, flush=True)
    raise SystemExit(2)


@contextlib.contextmanager
def noted_on_interrupt(name: str, folder: Path) -> Iterator[None]:
    """A `KeyboardInterrupt` (Ctrl-C, SIGTERM) that leaves the block carries ``folder`` as its
    attribute ``name`` (``run_dir``, ``campaign_dir``): what to resume, for the ``ariel``
    command's hint and for a script or notebook."""
    try:
        yield
    except KeyboardInterrupt as exc:
        setattr(exc, name, folder)
        raise


def _worker_cannot_start(exc: BaseException | None) -> bool:
    """Whether ``exc`` (or one it was raised from or during) is the local pool saying that a
    worker could not start (`WorkerCannotStartError`)."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, WorkerCannotStartError):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


@accept_aliases(scheduler="address")
def resume_experiment(
    run_dir: str | Path,
    *,
    executor: str | None = None,
    workers: int | None = None,
    address: str | None = None,
    progress: bool | None = None,
) -> RunResult:
    """Continue a killed or interrupted run from its last finished generation.

    Refuses a folder that is not a run, a finished run, a run whose config was edited, and a
    run that another process is running, before writing anything. An interrupt: as
    `run_experiment`.

    Args:
        run_dir: The run folder to continue.
        executor: The executor kind it goes on on; None (the default): the kind (and worker
            count) it last ran on.
        workers: Worker processes; None: the count it last ran with when it goes on on the
            same kind of worker pool and this machine has that many CPUs, else all CPUs.
        address: A running Dask scheduler's address. Never taken from the folder: a Dask
            run without ``address`` goes on on a local Dask cluster, and says so.
            ``scheduler=`` is its old name, still accepted.
        progress: Whether to show progress, as in `run_experiment` (None: where someone
            watches).

    Returns:
        The finished run's summary.

    Raises:
        NotARunError: When ``run_dir`` is not a run folder or its checkpoint cannot be read;
            `DamagedRunError` (a `NotARunError`) when its records differ from its manifests.
        ValueError: When the run is already finished, or its config cannot be read or was
            edited after the run started.
        RunInUseError: When another process runs (or resumes) the run.
        ConfigError: For a bad executor setting.
    """
    folder = RunFolder(run_dir)
    info, config, _ = resumable(folder)
    # Unless told otherwise, continue on the kind of executor the run last ran on (results do
    # not depend on it), but never on a Dask scheduler the folder names: only on one passed here.
    settings = resume_settings(
        config,
        info.get("executor"),
        kind=executor,
        workers=workers,
        address=address,
        command=("resume", run_dir),
    )
    plugins = resolve_plugins(config)
    evolution.check_plugins(config)  # from the face when called: tests replace it there
    with storage_errors(folder.path), RunLock(folder.path):
        # Again under the lock: another resume may have run (or finished) the run meanwhile.
        info, config, state = resumable(folder)
        reopen(folder, state)
        with noted_on_interrupt("run_dir", folder.path):
            return _drive(config, plugins, folder, info["run_id"], state, settings, progress)


def reopen(folder: RunFolder, state: LoopState | None) -> None:
    """Under the run's lock, before it goes on: manifests for the kept generations (a run
    made before manifests), later generations' files removed, this resume's software noted."""
    adopt_manifests(folder, state.generation + 1 if state is not None else 0)
    folder.discard_after(state.generation if state is not None else -1)
    folder.start_segment("resume")


def resumable(folder: RunFolder) -> tuple[dict[str, Any], ExperimentConfig, LoopState | None]:
    """run.json, config and checkpoint of a run that may be resumed; `ValueError` else."""
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
