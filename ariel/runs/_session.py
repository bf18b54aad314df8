"""A run's life, the same for a lone run and for each run of a campaign: `RunSession`.

Prepared (`PreparedRun`) → its folder made, or reopened to go on, under its lock
(`RunSession.create`, `RunSession.reopen`) → driven (`RunSession.start`, then `drive`: the
sessions' generations are the groups of one scheduler) → closed with how it ended (run.json's
``status``). A lone run is a campaign of one: `run_experiment` and `run_campaign` drive their
sessions with the same `drive`.

A session wires its driver's observers (`ariel.evolution.RunObserver`), in this order: the
records writer (tables, manifests, checkpoint), the Rerun recorder (when ``record.rerun``),
run.json (`RunInfo`) and the progress display. The writer and the recorder write a
generation's records before the writer saves its checkpoint, and run.json follows it.
"""

from __future__ import annotations

import contextlib
import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ariel.evolution import (
    RESULTS_VERSION,
    CheckpointDue,
    ConfigError,
    ExecutorConfig,
    ExperimentConfig,
    LoopState,
    Progress,
    RunDriver,
    RunEvent,
    RunObserver,
    RunStarted,
    config_hash,
    results_version,
    run_groups,
    state_from_plain,
)
from ariel.plugins import REGISTRIES, plugin_provenance
from ariel.recording import rerun
from ariel.recording.store import (
    MANIFEST_FORMAT,
    NotARunError,
    RunFolder,
    RunLock,
    RunWriter,
    adopt_manifests,
    finished_generations,
    git_commit,
    now,
    short_ascii,
    software_versions,
)
from ariel.runs._prepare import PreparedRun, prepare_run
from ariel.runs._result import RunResult
from ariel.utils import ariel_line

__all__ = ["RunInfo", "RunSession", "drive", "resumable", "run_info"]


class RunInfo:
    """run.json, an observer of the run's driver: ``running`` (with the executor) when it
    starts, the counts after each checkpoint. How it ended: `RunSession.close`."""

    def __init__(self, folder: RunFolder, settings: ExecutorConfig) -> None:
        self.folder, self.settings = folder, settings

    def notify(self, event: RunEvent) -> None:
        if isinstance(event, RunStarted):
            settings = self.settings
            self.folder.update_info(
                # A QD archive's description: readers and run.rrd draw from it.
                **({} if event.archive is None else {"archive": dict(event.archive)}),
                status="running",
                executor={
                    "kind": settings.kind,
                    "workers": settings.workers,
                    "address": settings.address,
                },
                # What the checkpoint holds: run.json may lag behind it when a kill came
                # between them.
                generations_done=event.first_generation,
            )
        elif isinstance(event, CheckpointDue):
            offset = event.qd_offset  # readers compute the QD-score as the run did
            self.folder.update_info(
                generations_done=event.generation + 1,
                evaluations_done=event.evaluations_done,
                best_fitness=event.best,
                **({} if offset is None else {"qd_offset": offset}),
            )


@dataclass
class RunSession:
    """One run from its prepared config to its closed folder (see the module docstring).
    ``state``: the checkpoint it goes on from (None: a new run)."""

    prepared: PreparedRun
    folder: RunFolder
    run_id: str
    state: LoopState | None = None
    driver: RunDriver | None = None
    status: str = "failed"

    @classmethod
    def create(
        cls,
        prepared: PreparedRun,
        path: Path,
        run_id: str,
        locks: contextlib.ExitStack,
        *,
        overwrite: bool = False,
    ) -> RunSession:
        """A new run folder at ``path``, locked until ``locks`` closes (`RunFolder.create`
        checks the folder again under the lock)."""
        locks.enter_context(RunLock(path, create=True))
        info = run_info(prepared, run_id)
        folder = RunFolder.create(path, info, overwrite=overwrite, locked=True)
        locks.enter_context(_interrupted_while_locked(folder))
        folder.start_segment("run")
        return cls(prepared, folder, run_id)

    @classmethod
    def reopen(
        cls, folder: RunFolder, locks: contextlib.ExitStack, settings: ExecutorConfig
    ) -> RunSession:
        """The unfinished run in ``folder`` made ready to go on on ``settings``, locked until
        ``locks`` closes: checked (`resumable`, `prepare_run`) before anything is written,
        then its manifests adopted, later generations' files removed, this resume noted."""
        locks.enter_context(RunLock(folder.path))
        locks.enter_context(_interrupted_while_locked(folder))
        info, config, state = resumable(folder)
        prepared = prepare_run(config, settings)
        _check_same_plugins(folder.path, info, prepared)
        adopt_manifests(folder, state.generation + 1 if state is not None else 0)
        folder.discard_after(state.generation if state is not None else -1)
        folder.start_segment("resume")
        return cls(prepared, folder, str(info["run_id"]), state)

    def start(self, progress: Progress) -> RunDriver:
        """The run's driver with its observers (``progress`` the last), marked running."""
        prepared, folder = self.prepared, self.folder
        config, plugins = prepared.config, prepared.plugins
        writer = RunWriter(folder, config, self.run_id)
        observers: list[RunObserver] = [writer]
        recorder = None
        if config.record.rerun:  # only then are the recorder's modules (and Rerun) loaded
            recorder = rerun.RerunRecorder(
                folder.path,
                run_id=self.run_id,
                bodies=config.record.bodies,
                maximise=plugins.maximise,
                config=config,
                brain_only=prepared.brain_only,
            )
            observers.append(recorder)
        observers += [RunInfo(folder, prepared.settings), progress]
        self.driver = RunDriver(
            config,
            plugins,
            observers,
            self.state,
            record_bodies=recorder is not None and recorder.record_bodies,
            plugin_error=writer.plugin_failed,
        )
        # a resumed run's best so far, by the driver's own rule, before its first new batch
        # (the progress line showed "-" until then)
        best = self.driver.best_so_far()
        if not math.isnan(best):  # (a new run has none)
            progress.advance(0, best)
        self.driver.start()
        return self.driver

    def generations(self) -> Iterator[Sequence[Any]]:
        """The driver's generations, for the scheduler; closed as finished the moment its
        last generation is saved."""
        assert self.driver is not None, "start() the session first"
        yield from self.driver.generations()
        self.close("finished")

    def close(self, status: str) -> None:
        """Record how the run ended (``finished``, ``interrupted``, ``failed``) in run.json."""
        assert self.driver is not None
        self.status = status
        # On a full disk this write fails too: then the first error is the one to tell.
        with contextlib.suppress(OSError) if status != "finished" else contextlib.nullcontext():
            self.folder.update_info(
                status=status, ended=now(), wall_seconds=self.driver.wall_seconds
            )

    def result(self) -> RunResult:
        driver = self.driver
        assert driver is not None
        best = driver.best_body()
        return RunResult(
            # absolute: `RunResult.load` after a notebook changes directory reads the same run
            run_dir=self.folder.path.absolute(),
            run_id=self.run_id,
            status=self.status,
            generations=driver.config.generations,
            evaluations=driver.state.evaluations_done if driver.state else 0,
            best_fitness=best.fitness,
            best_body_id=best.body_id,
            best_eval_id=best.best_eval_id,
            wall_seconds=driver.wall_seconds,
        )


@contextlib.contextmanager
def _interrupted_while_locked(folder: RunFolder) -> Iterator[None]:
    """An interrupt (Ctrl-C, SIGTERM) while this process holds the run's lock but before its
    driver runs (its plugins checked, its recorder loaded) leaves run.json's status
    ``interrupted``, as one later does (`drive`): not ``created`` or ``running`` (a killed
    run's) with nothing running it. Entered on ``locks`` after the lock: left first."""
    try:
        yield
    except KeyboardInterrupt:
        with contextlib.suppress(Exception):  # a damaged run.json: the interrupt is the news
            if folder.read_info().get("status") in ("created", "running"):
                folder.update_info(status="interrupted", ended=now())
        raise


def drive(
    sessions: Sequence[RunSession],
    settings: ExecutorConfig,
    display: AbstractContextManager[object],
    ended: Callable[[str], None] | None = None,
) -> int:
    """Drive the started ``sessions`` side by side on one executor (``settings``) while
    ``display`` (their progress) is open; returns the executor's capacity. However it ends,
    every unfinished session is closed with how (``interrupted`` for Ctrl-C or SIGTERM,
    else ``failed``), then ``ended(status)`` is called (a campaign's own records)."""
    status = "failed"
    try:
        with display:
            capacity = run_groups([session.generations() for session in sessions], settings)
        status = "finished"
    except KeyboardInterrupt:
        status = "interrupted"
        raise
    finally:
        for session in sessions:
            if session.status != "finished" and session.driver is not None:
                session.close(status)
        if ended is not None:
            ended(status)
    return capacity


def run_info(prepared: PreparedRun, run_id: str) -> dict[str, Any]:
    """A new run's run.json: config, hash, software, plugin provenance, and what readers need
    without the run's plugins (fitness direction, brain-only)."""
    config = prepared.config
    named = {
        "body_encoder": config.body.encoder,
        "controller": config.brain.controller,
        "world": config.world.name,
        "fitness": config.task.fitness,
        "body_optimizer": config.body.optimizer,
        "brain_optimizer": config.brain.optimizer,
    }
    if prepared.brain_only:  # it asks no body optimizer: its name is not looked up
        del named["body_optimizer"]
    provenance = plugin_provenance(named)
    return {
        "run_id": run_id,
        "name": config.name,
        "status": "created",
        "seed": config.seed,
        "config": config.to_plain(),
        "config_hash": config_hash(config),
        "results_version": RESULTS_VERSION,
        "versions": software_versions(),
        "git_commit": git_commit(),
        "plugins": provenance,
        "created": now(),
        "generations_done": 0,
        "evaluations_done": 0,
        "maximise": prepared.plugins.maximise,
        "brain_only": prepared.brain_only,
        "manifests": MANIFEST_FORMAT,
    }


def _maker(info: Mapping[str, object]) -> str:
    """Which ariel made a run, for the line refusing it: run.json's commit, else its date."""
    commit, created = info.get("git_commit"), info.get("created")
    if isinstance(commit, str) and re.fullmatch(r"[0-9a-f]{7,64}(-dirty)?", commit):
        return f"commit {commit}, run.json's git_commit"
    day = created[:10] if isinstance(created, str) else ""
    made = f"made {day}" if re.fullmatch(r"\d{4}-\d{2}-\d{2}", day) else "date unknown"
    return f"{made}; run.json names no git commit"


def resumable(folder: RunFolder) -> tuple[dict[str, Any], ExperimentConfig, LoopState | None]:
    """run.json, config and checkpoint of a run that may be resumed; `ValueError` else."""
    info = folder.read_info()
    if info.get("status") == "finished":
        raise ValueError(f"run {str(folder.path)!r} is already finished; nothing to resume")
    made = results_version(info)
    if isinstance(made, int) and not isinstance(made, bool) and made > RESULTS_VERSION:
        raise ValueError(
            f"run {str(folder.path)!r} was made by a newer ariel (results version {made}; this "
            f"ariel's: {RESULTS_VERSION}): upgrade ariel to resume it"
        )
    if made != RESULTS_VERSION:
        raise ValueError(
            f"run {str(folder.path)!r} was made by an ariel whose results differ from this "
            f"one's (results version {str(made)[:20]}; this ariel's: {RESULTS_VERSION}): "
            "resuming it here would mix two algorithms in one run; finish it with the ariel "
            f"that made it ({_maker(info)}), or start a new run of its config: "
            f"{ariel_line('config', 'show', folder.path)} > config.toml prints it"
        )
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
    if state is not None:
        problem = _state_problem(state, config, finished_generations(folder.path, info))
        if problem:
            raise NotARunError(f"{folder.checkpoint}: unreadable checkpoint ({problem})")
    return info, config, state


def _check_same_plugins(run_dir: Path, info: Mapping[str, object], prepared: PreparedRun) -> None:
    """`ConfigError` when a plugin of the user's own (not ariel's) registered under the run's
    name is another object than the one run.json's ``plugins`` recorded, or the fitness now
    runs the other way: a resume would mix two plugins in one run (a notebook that registers
    an edited function again under the name with ``replace=True``)."""
    stored = info.get("plugins")
    for kind, entry in stored.items() if isinstance(stored, dict) else ():
        if kind not in REGISTRIES or not isinstance(entry, dict):
            continue
        was, name = entry.get("object"), entry.get("name")
        if not (isinstance(was, str) and isinstance(name, str)):
            continue
        now = str(plugin_provenance({kind: name})[kind].get("object"))
        if was.startswith("ariel.") and now.startswith("ariel."):
            continue  # ariel's own plugins may move between modules from version to version
        if "__main__" in (was.partition(":")[0], now.partition(":")[0]):  # a script, run
            was, now = was.partition(":")[2], now.partition(":")[2]  # as itself or imported
        if now != was:
            raise ConfigError(
                f"{REGISTRIES[kind].label} {short_ascii(name)} is {short_ascii(now, 200)} "
                f"here, but run {str(run_dir)!r} was made with {short_ascii(was, 200)}: resuming "
                "would mix two plugins in one run; register the one that made it, or start a "
                "new run"
            )
    maximise = prepared.plugins.maximise
    if isinstance(info.get("maximise"), bool) and info["maximise"] != maximise:
        raise ConfigError(
            f"fitness function {short_ascii(prepared.config.task.fitness)} is "
            f"{'maximised' if maximise else 'minimised'} here, but run {str(run_dir)!r} "
            f"{'maximised' if info['maximise'] else 'minimised'} it: resuming would mix two "
            "fitness directions in one run; register the one that made it"
        )


def _state_problem(state: LoopState, config: ExperimentConfig, done: int) -> str | None:
    """What no run's checkpoint holds, for a run of ``config`` with ``done`` finished
    generations: the counters and bodies resume goes on from (a crafted generation -5 made it
    write ``gen--00005`` tables and write generations 0 to 41 again over the run's own)."""
    if not (type(state.generation) is int and done - 1 <= state.generation <= done):
        return f"its generation {state.generation!r} is not the run's last finished one"
    most = 2 * max(config.body.population, config.body.offspring) * (state.generation + 1) + 2
    if not (type(state.next_body) is int and len(state.population) <= state.next_body <= most):
        return f"its next_body {state.next_body!r} is not a count of the bodies made so far"
    numbers = {body.number for body in state.population}
    for body in state.population:
        if not (type(body.born) is int and 0 <= body.born <= state.generation):
            return f"body {body.number!r} was born in generation {body.born!r}"
        if not (type(body.number) is int and 0 <= body.number < state.next_body):
            return f"body number {body.number!r} is not one of the bodies made so far"
    if len(numbers) != len(state.population):
        return "its population holds a body twice"
    return None
