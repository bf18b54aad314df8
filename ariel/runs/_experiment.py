"""`run_experiment` and `resume_experiment`: one run, from its config to its finished folder.

Everything is checked before anything is written: the config, the executor settings, every
plugin the config names (with its options), a fixed body. Then the run folder is created
under its lock, and the evolution driver runs on the executor, writing through the
records writer of `ariel.recording`.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import shutil
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from ariel.errors import ConfigError, ExecutorStartError
from ariel.evaluation import WorkerCannotStartError
from ariel.evaluation.executors import reach as reach_executor
from ariel.evolution import (
    ExperimentConfig,
    LoopState,
    Progress,
    load_config,
    no_main_guard_line,
    refuse_in_spawned_child,
    shows_progress,
)
from ariel.plugins import REGISTRIES, script_plugins
from ariel.recording.store import (
    RunFolder,
    check_new_id,
    check_path_names,
    storage_errors,
    terminal_text,
)
from ariel.runs._prepare import (  # noqa: F401 - resolve_plugins and _read_genotype_file: tests
    PreparedRun,
    _read_genotype_file,
    executor_settings,
    prepare_run,
    resolve_plugins,
    resume_settings,
)
from ariel.runs._result import RunResult
from ariel.runs._session import RunSession, drive, resumable
from ariel.utils import (
    accept_aliases,
    flag_argument,
    free_path,
    gone_if_empty,
    new_folder,
    path_argument,
)
from ariel.utils.interrupts import stop_on_signals

__all__ = [
    "RunResult",
    "executor_settings",
    "new_progress",
    "noted_on_interrupt",
    "prepare_run",
    "raised_from",
    "resolve_plugins",
    "resume_experiment",
    "run_experiment",
]


# --------------------------------------------------------------------------------------------
# Driving a run in its folder
# --------------------------------------------------------------------------------------------


def new_progress(
    prepared: PreparedRun,
    state: LoopState | None,
    show_progress: bool | None,
    kind: type[Progress] = Progress,
    **extra: Any,
) -> Progress:
    """The run's progress display (``kind``: a `Progress` class; ``extra``: its keywords);
    ``show_progress``: see `shows_progress` (None: only where someone watches)."""
    return kind(
        total=prepared.budget,
        done=state.budget_done if state else 0,
        enabled=shows_progress(show_progress),
        **extra,
    )


def _drive(session: RunSession, show_progress: bool | None) -> RunResult:
    """A lone run: a campaign of one, driven as a campaign's runs are (`drive`)."""
    progress = new_progress(session.prepared, session.state, show_progress)
    session.start(progress)
    if progress.enabled:
        shown = f"{session.run_id}: {session.folder.path} ({progress.total} evaluations)"
        print(terminal_text(f"run {shown}"), flush=True)  # a folder's name: any characters
    drive([session], session.prepared.settings, progress)
    return session.result()


#: Where a run without ``out`` goes (relative to the current directory).
DEFAULT_RUN_ROOT = Path("data") / "runs"


def new_run_id(config: ExperimentConfig) -> str:
    """``<name>-<date>-<time>-s<seed>``, with ``-2``, ``-3``, ... where `DEFAULT_RUN_ROOT` has
    that folder already (named, not made: `run_experiment` claims its folder itself)."""
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return free_path(DEFAULT_RUN_ROOT, f"{config.name}-{stamp}-s{config.seed}").name


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

    Ctrl-C (or SIGTERM or SIGHUP, unless this process ignores or handles it itself, as
    ``nohup`` does SIGHUP) raises `KeyboardInterrupt` with ``run_dir`` set to the folder to pass
    to `resume_experiment`; the run's status is then ``interrupted``. Called from another thread
    than the main one, signals stay the main thread's (Python lets only it handle them): a
    SIGTERM then ends the process as it would without ariel, the run left ``running`` (listed
    as stopped, resumable). A script that calls this at its top level without ``if __name__ ==
    "__main__":``, on the local executor: its workers say so on stderr, and the script ends
    (`SystemExit`, code 2) leaving no run folder.

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
        TypeError: For an argument of the wrong type (``overwrite="no"``: True or False).
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
    out = path_argument("out", out, function="run_experiment") if out is not None else None
    flag_argument("overwrite", overwrite, function="run_experiment")
    flag_argument("progress", progress, none=True, function="run_experiment")
    config = load_config(config, overrides)
    settings = executor_settings(config, kind=executor, workers=workers, address=address)
    prepared = prepare_run(config, settings)
    run_id = new_run_id(prepared.config)
    path = Path(out) if out is not None else DEFAULT_RUN_ROOT / run_id
    if out is not None:
        run_id = path.name or run_id
    check_new_id(run_id)
    if out is not None:  # the default one is claimed new below
        RunFolder.check_new(path, overwrite=overwrite)
    reach_executor(settings)  # a scheduler that never answers: no folder
    if out is None:  # claimed now: two runs started in one second named one folder
        path = new_folder(DEFAULT_RUN_ROOT, run_id)
        run_id = path.name
    try:
        # The lock is held for the whole run. An interrupt once run.json is written (even
        # before the first generation) names the folder: it resumes from there.
        with (
            gone_if_empty(path if out is None else None),  # refused before run.json: none left
            storage_errors(path),
            contextlib.ExitStack() as locks,
            stop_on_signals(),
            noted_on_interrupt("run_dir", path, once="run.json"),
        ):
            session = RunSession.create(prepared, path, run_id, locks, overwrite=overwrite)
            return _drive(session, progress)
    except Exception as exc:
        if raised_from(exc, ExecutorStartError):  # nothing ran: the new folder goes
            shutil.rmtree(path, ignore_errors=True)
        if not raised_from(exc, WorkerCannotStartError):
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
def noted_on_interrupt(name: str, folder: Path, once: str | None = None) -> Iterator[None]:
    """A `KeyboardInterrupt` (Ctrl-C, SIGTERM) that leaves the block carries ``folder`` as its
    attribute ``name`` (``run_dir``, ``campaign_dir``): what to resume, for the ``ariel``
    command's hint and for a script or notebook; with ``once``, only once the folder holds
    that file (before it, there is nothing to resume)."""
    try:
        yield
    except KeyboardInterrupt as exc:
        if once is None or (folder / once).is_file():
            setattr(exc, name, folder)
            status_file = "campaign.json" if name == "campaign_dir" else "run.json"
            if _status(folder / status_file) == "finished":  # the signal came as it ended
                exc.finished = True  # type: ignore[attr-defined]  # no resume hint: refused
                exc.add_note("interrupted after it finished: its records are complete")
                raise
            # A script's or notebook's traceback shows it (the ariel command prints its own).
            call = "resume_campaign" if name == "campaign_dir" else "resume_experiment"
            exc.add_note(
                f"interrupted: its finished generations are kept; continue it with "
                f"{call}({str(folder)!r})"
            )
        raise


def _status(info: Path) -> object:
    """The ``status`` a run.json or campaign.json says, or None where it cannot be read."""
    try:
        return json.loads(info.read_text(encoding="utf-8")).get("status")
    except (OSError, ValueError, AttributeError):
        return None


def raised_from(exc: BaseException | None, kind: type[BaseException]) -> bool:
    """Whether ``exc``, or one it was raised from or during, is a ``kind``: the local pool's
    `WorkerCannotStartError` (a script without a ``__main__`` guard), a Dask cluster's
    `ExecutorStartError`."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, kind):
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
        ConfigError: For a bad executor setting, or a plugin the run's script registered
            that is not registered here.
    """
    folder = RunFolder(path_argument("run_dir", run_dir, function="resume_experiment"))
    flag_argument("progress", progress, none=True, function="resume_experiment")
    check_path_names(folder.path)  # before its status is touched
    info, config, _ = resumable(folder)
    _check_script_plugins_known(folder.path, info)
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
    reach_executor(settings)  # before run.json is touched
    with storage_errors(folder.path), contextlib.ExitStack() as locks:
        # Checked again under the lock: another resume may have run (or finished) the run.
        session = RunSession.reopen(folder, locks, settings)
        with stop_on_signals(), noted_on_interrupt("run_dir", folder.path):
            return _drive(session, progress)


def _check_script_plugins_known(run_dir: Path, info: Mapping[str, object]) -> None:
    """A plugin the run's script (or notebook) registered, unknown here (``ariel resume``, or
    a script that no longer registers it): `ConfigError` saying where to resume from, rather
    than only that the name is unknown."""
    for kind, name in script_plugins(info.get("plugins")):
        if name not in REGISTRIES[kind]:
            raise ConfigError(
                f"{REGISTRIES[kind].label} {name[:60]!r} of run {str(run_dir)!r} was registered "
                "by the script (or notebook) that made the run, and is not registered here: "
                f"resume the run from that script, resume_experiment({str(run_dir)!r}), after "
                "it registers the plugin"
            )
