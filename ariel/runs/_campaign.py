"""`run_campaign`, `resume_campaign`, `campaign_status`: conditions x seeds on ONE executor.

Every run is a normal run folder (its own lock, run.json, checkpoints) at
``runs/condition=<name>/seed=<n>/`` of the campaign folder, driven by its own `RunDriver`;
the drivers' generations are the groups of one `Scheduler`, so evaluations of all runs
interleave on the same pool or Dask cluster and every worker stays busy. A run's records
depend only on its config and seed, never on what ran beside it: each run's tables equal a
lone run's, bit for bit. Everything is checked before anything is written.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ariel.errors import DamagedRunError, ExecutorStartError
from ariel.evaluation.executors import planned_workers, reach as reach_executor
from ariel.evolution import ConfigError, ExecutorConfig, ExperimentConfig, shows_progress
from ariel.recording import rerun  # its modules load at call time: `_write_recording`
from ariel.recording.store import (
    CAMPAIGN_JSON,
    CAMPAIGN_RRD,
    LOCK_NAME,
    Campaign,
    NotARunError,
    RunFolder,
    RunInUseError,
    RunLock,
    check_new_id,
    check_path_names,
    ensure_open_files,
    load_campaign,
    load_run,
    now,
    one_line,
    read_campaign_info,
    run_path,
    storage_errors,
    terminal_text,
    write_campaign_info,
    written_path,
)
from ariel.runs._campaign_file import load_campaign_file
from ariel.runs._campaign_folder import (
    DEFAULT_CAMPAIGN_ROOT,
    check_new_folder,
    new_campaign_id,
)
from ariel.runs._campaign_info import campaign_info
from ariel.runs._campaign_progress import CampaignProgress, RunProgress
from ariel.runs._experiment import new_progress, noted_on_interrupt, raised_from
from ariel.runs._prepare import PreparedRun, executor_settings, prepare_run, resume_settings
from ariel.runs._result import RunResult
from ariel.runs._session import RunSession, drive
from ariel.utils import (
    accept_aliases,
    flag_argument,
    gone_if_empty,
    new_folder,
    path_argument,
    strings_argument,
)
from ariel.utils.interrupts import stop_on_signals

__all__ = ["CampaignResult", "campaign_status", "resume_campaign", "run_campaign"]


@dataclass
class CampaignResult:
    """What `run_campaign` and `resume_campaign` return.

    Attributes:
        path: The campaign folder.
        campaign_id: The campaign's id (the folder's name).
        status: How the call ended: ``"finished"``.
        runs: The runs driven by this call, one `RunResult` each (finished ones skipped on
            resume are not among them).
        skipped: Runs that had finished before this call (always 0 for `run_campaign`).
        wall_seconds: Wall-clock seconds this call spent driving the runs.
        busy_share: The workers' time spent in evaluations / (wall time x workers), over
            this call: 1.0 means every worker was busy throughout.
        workers: The executor's worker count (its capacity).
        damaged: One line per run a resume left alone because it cannot go on (a damaged run
            folder, a config that does not validate), each naming the run.
    """

    path: Path
    campaign_id: str
    status: str
    runs: list[RunResult]
    skipped: int
    wall_seconds: float
    busy_share: float
    workers: int
    damaged: list[str] = field(default_factory=list)

    def load(self) -> Campaign:
        """The campaign's records (`ariel.recording.load_campaign`)."""
        return load_campaign(self.path)

    def __repr__(self) -> str:  # one line, as Run's (a notebook cell's last value)
        damaged = f", {len(self.damaged)} damaged" if self.damaged else ""
        return (
            f"<CampaignResult {self.campaign_id}: {self.status}, {len(self.runs)} runs driven, "
            f"{self.skipped} finished before{damaged}, {self.wall_seconds:.1f} s>"
        )


@dataclass
class _Run:
    """A run of the campaign: its condition, seed, id and prepared config; its session once
    its folder is open."""

    condition: str
    seed: int
    run_id: str
    prepared: PreparedRun
    session: RunSession | None = None
    first_generation: int = 0

    @property
    def config(self) -> ExperimentConfig:
        return self.prepared.config

    @property
    def label(self) -> str:
        return f"{self.condition} seed {self.seed}"

    @property
    def started(self) -> RunSession:
        assert self.session is not None  # every run's session opens before the drive
        return self.session


@accept_aliases(scheduler="address")
def run_campaign(
    file: str | Path,
    *,
    out: str | Path | None = None,
    executor: str | None = None,
    workers: int | None = None,
    address: str | None = None,
    progress: bool | None = None,
    overrides: Sequence[str] = (),
) -> CampaignResult:
    """Run every condition x seed of the campaign ``file`` into a new campaign folder.

    Everything is validated before anything is written. Ctrl-C (or SIGTERM or SIGHUP, as in
    `run_experiment`) raises `KeyboardInterrupt` with ``campaign_dir`` set to the folder to
    pass to `resume_campaign`.

    Args:
        file: The campaign TOML file (its base experiment, seeds and conditions;
            docs/campaigns.md).
        out: The campaign folder; None (the default): ``data/campaigns/<name>-<time>``. It
            must not exist (or be empty); its name becomes the campaign id.
        executor: The executor kind every run shares (``"serial"``, ``"local"``, ``"dask"``,
            ``"gpu"``); None: the base experiment's ``executor.kind``.
        workers: Worker processes; None: the base experiment's ``executor.workers``.
        address: A running Dask scheduler's address; None: the base experiment's
            (``executor.address``). ``scheduler=`` is its old name, still accepted.
        progress: One line per run and generation; True, False or None (the default: where
            someone watches, a terminal or a Jupyter notebook; see `run_experiment`).
        overrides: ``key=value`` strings with dotted keys, applied to every run after the
            file's campaign-wide ``set`` and before each condition's own ``set``.

    Returns:
        The campaign's summary; ``CampaignResult.load()`` reads its records.

    Raises:
        ConfigError: For a bad campaign file, override, config or executor setting.
        TypeError: For an argument of the wrong type (``progress="no"``: True, False or None).
        FileExistsError: When ``out`` exists and is not an empty folder.
        RunStorageError: When the campaign folder cannot be written.

    Example:
        A tiny campaign on the serial executor, from the repository's root:

        ```python
        from ariel.runs import campaign_status, run_campaign

        if __name__ == "__main__":  # needed: the local executor's workers import this script
            result = run_campaign(
                "experiments/campaigns/inheritance.toml",
                executor="serial",
                progress=False,
                overrides=[
                    "generations=2",
                    "body.population=2",
                    "body.offspring=2",
                    "brain.iterations=1",
                ],
            )
            for row in campaign_status(result.path):
                print(row["condition"], row["seed"], row["status"], row["best_fitness"])
        ```
    """
    file = path_argument("file", file, function="run_campaign")
    out = path_argument("out", out, function="run_campaign") if out is not None else None
    flag_argument("progress", progress, none=True, function="run_campaign")
    overrides = strings_argument("overrides", overrides, "generations=3", function="run_campaign")
    spec = load_campaign_file(file, overrides)
    first = next(iter(spec.configs.values()))
    settings = executor_settings(first, kind=executor, workers=workers, address=address)
    _check_open_files(len(spec.configs), settings)
    campaign_id = new_campaign_id(spec.name)
    path = Path(out) if out is not None else DEFAULT_CAMPAIGN_ROOT / campaign_id
    campaign_id = check_new_id(path.name or campaign_id, campaign=True)
    runs = []
    for (condition, seed), config in spec.configs.items():
        run_id = check_new_id(f"{campaign_id}-{condition}-s{seed}")
        runs.append(_Run(condition, seed, run_id, prepare_run(config, settings)))
    if out is not None:  # the default one is claimed new below
        check_new_folder(path)
    reach_executor(settings)  # a scheduler that never answers: no folder
    if out is None:  # claimed now: two campaigns started in one second named one folder
        path = new_folder(DEFAULT_CAMPAIGN_ROOT, campaign_id)
        if path.name != campaign_id:  # taken meanwhile: the next number, in its runs' ids too
            campaign_id = path.name
            runs = [replace(r, run_id=f"{campaign_id}-{r.condition}-s{r.seed}") for r in runs]
    info = campaign_info(spec, runs, settings, campaign_id, Path(file).name)
    try:
        with (
            gone_if_empty(path if out is None else None),  # refused before campaign.json
            storage_errors(path, campaign=True),
            RunLock(path, create=True),
            contextlib.ExitStack() as locks,
        ):
            check_new_folder(path, locked=True)  # again: another campaign run may have begun
            write_campaign_info(path, info)
            locks.enter_context(stop_on_signals())  # SIGTERM, SIGHUP: as Ctrl-C (if not handled)
            locks.enter_context(noted_on_interrupt("campaign_dir", path))
            for run in runs:
                folder = path / run_path(run.condition, run.seed)
                run.session = RunSession.create(run.prepared, folder, run.run_id, locks)
            return _drive_campaign(path, runs, settings, progress, skipped=0)
    except Exception as exc:
        if raised_from(exc, ExecutorStartError):  # nothing ran: the new folder goes
            shutil.rmtree(path, ignore_errors=True)
        raise


def _check_open_files(runs: int, settings: ExecutorConfig) -> None:
    """Each run the campaign drives holds its lock (an open file) throughout: the process's
    limit on open files must allow them all (`ensure_open_files`), checked before anything is
    written or locked."""
    ensure_open_files(runs, planned_workers(settings)[0])


@accept_aliases(scheduler="address")
def resume_campaign(
    campaign_dir: str | Path,
    *,
    executor: str | None = None,
    workers: int | None = None,
    address: str | None = None,
    progress: bool | None = None,
) -> CampaignResult:
    """Continue every unfinished run of a campaign (finished runs are skipped) on one
    executor.

    A run that cannot go on (a damaged run folder, an unreadable checkpoint or config) does
    not hold up the others: they go on, and the result's ``damaged`` names it in one line.
    A campaign stopped after its last run had finished gets its own records written
    (campaign.rrd, then its ``finished`` status), and nothing runs. An interrupt: as
    `run_campaign`.

    Args:
        campaign_dir: The campaign folder to continue.
        executor: The executor kind; None (the default): the kind the campaign ran on.
        workers: Worker processes; None: as in `resume_experiment`.
        address: A running Dask scheduler's address; never taken from campaign.json (see
            `resume_experiment`). ``scheduler=`` is its old name, still accepted.
        progress: Whether to show progress, as in `run_campaign` (None: where someone
            watches).

    Returns:
        The summary of this call: the runs it drove, how many had finished before
        (``skipped``), and the runs it could not resume (``damaged``).

    Raises:
        NotACampaignError: When ``campaign_dir`` is not a campaign folder.
        ValueError: When the campaign has finished already (its runs and its own records).
        DamagedRunError: When no run can go on; the first run's line is the message.
        RunInUseError: When another process runs the campaign, or one of its runs.
        ConfigError: When the campaign's stored config cannot be read, or for a bad executor
            setting.
    """
    path = path_argument("campaign_dir", campaign_dir, function="resume_campaign")
    flag_argument("progress", progress, none=True, function="resume_campaign")
    check_path_names(path)  # before any run's status is touched
    info = read_campaign_info(path)
    try:
        first = ExperimentConfig.from_plain(info["runs"][0]["config"])
    except ConfigError as exc:
        raise ConfigError(f"{path / CAMPAIGN_JSON}: runs[0]: its config: {exc}") from None
    # As a run's resume: the kind it ran on, never a Dask scheduler address from the folder.
    settings = resume_settings(
        first,
        info.get("executor"),
        kind=executor,
        workers=workers,
        address=address,
        command=("campaign", "resume", campaign_dir),
    )
    reach_executor(settings)  # before any run.json is touched
    with storage_errors(path, campaign=True), RunLock(path), contextlib.ExitStack() as locks:
        info = read_campaign_info(path)  # again under the lock
        _remove_own_temporaries(path)
        locks.enter_context(stop_on_signals())  # SIGTERM, SIGHUP: as Ctrl-C (if not handled)
        locks.enter_context(noted_on_interrupt("campaign_dir", path))
        runs, skipped, damaged = _unfinished_runs(path, info, locks, settings)
        if not runs and damaged:
            more = f" ({len(damaged) - 1} more cannot either)" if len(damaged) > 1 else ""
            raise DamagedRunError(f"campaign {str(path)!r}: no run resumed: {damaged[0]}{more}")
        if not runs and info.get("status") != "finished":  # stopped after its last run
            return _records_finished(path, info, skipped)
        if not runs:
            raise ValueError(f"campaign {str(path)!r} is already finished; nothing to resume")
        result = _drive_campaign(path, runs, settings, progress, skipped=skipped)
        result.damaged = damaged
        return result


def _remove_own_temporaries(path: Path) -> None:
    """A killed campaign's half-written campaign.json, .rrd or .rbl (its runs clean their own);
    a user's ``.notes.tmp`` beside them is theirs."""
    own = (CAMPAIGN_JSON, CAMPAIGN_RRD, rerun.CAMPAIGN_BLUEPRINT)
    for entry in path.iterdir():
        written = written_path(entry)
        if written is not None and written.name in own and not entry.is_symlink():
            with contextlib.suppress(OSError):
                entry.unlink()


def _unfinished_runs(
    path: Path, info: dict[str, Any], locks: contextlib.ExitStack, settings: ExecutorConfig
) -> tuple[list[_Run], int, list[str]]:
    """The campaign's runs left to do, each locked (by ``locks``) and made ready to go on;
    how many finished before; and one line per run that cannot go on (left alone, unlocked).
    First, that the limit on open files allows a lock for each (`_check_open_files`)."""
    _check_open_files(_left_to_do(path, info), settings)
    runs, skipped, damaged = [], 0, []
    for entry in info["runs"]:
        try:
            with contextlib.ExitStack() as own:
                run = _unfinished_run(path, entry, own, settings)
                locks.enter_context(own.pop_all())
        except (NotARunError, ValueError) as exc:  # damaged, or a config that does not validate
            first = one_line((str(exc).splitlines() or [type(exc).__name__])[0])
            name = f"condition {entry['condition']} seed {entry['seed']}"
            damaged.append(f"{name} not resumed: {first}")
            continue
        if run is None:
            skipped += 1
        else:
            runs.append(run)
    return runs, skipped, damaged


def _left_to_do(path: Path, info: dict[str, Any]) -> int:
    """How many of the campaign's runs are not finished (reads each run.json only)."""
    left = 0
    for entry in info["runs"]:
        try:
            finished = RunFolder(path / entry["path"]).read_info().get("status") == "finished"
        except (NotARunError, ValueError, OSError):
            finished = False
        left += not finished
    return left


def _unfinished_run(
    path: Path, entry: dict[str, Any], locks: contextlib.ExitStack, settings: ExecutorConfig
) -> _Run | None:
    """campaign.json's run ``entry`` locked (by ``locks``) and made ready to go on; None when it
    is finished."""
    folder = RunFolder(path / entry["path"])
    condition, seed = entry["condition"], int(entry["seed"])
    if not folder.run_json.is_file():  # killed while the campaign was being made
        prepared = prepare_run(ExperimentConfig.from_plain(entry["config"]), settings)
        run = _Run(condition, seed, entry["run_id"], prepared)
        run.session = RunSession.create(prepared, folder.path, run.run_id, locks, overwrite=True)
        return run
    if folder.read_info().get("status") == "finished":
        if os.path.lexists(folder.path / LOCK_NAME):  # the campaign was killed after it ended
            with contextlib.suppress(RunInUseError), RunLock(folder.path):
                pass  # taken and released at once: the stale .lock goes
        return None
    session = RunSession.reopen(folder, locks, settings)
    return _Run(condition, seed, session.run_id, session.prepared, session)


def _drive_campaign(
    path: Path,
    runs: list[_Run],
    settings: ExecutorConfig,
    show_progress: bool | None,
    *,
    skipped: int,
) -> CampaignResult:
    """Drive ``runs`` (locked, ready) side by side on one executor; campaign.json and every
    run.json say how it ended, however it ends."""
    show_progress = shows_progress(show_progress)
    campaign = CampaignProgress(runs=len(runs), total=0, enabled=show_progress)
    for run in runs:
        session = run.started
        shown = new_progress(
            session.prepared, session.state, True, RunProgress, label=run.label, campaign=campaign
        )
        campaign.total, campaign.done = campaign.total + shown.total, campaign.done + shown.done
        run.first_generation = session.start(shown).first_generation
    campaign.restart()  # counts what earlier calls did as done, not as this call's rate
    info = read_campaign_info(path)
    write_campaign_info(path, {**info, "status": "running"})
    if show_progress:
        shown = terminal_text(f"campaign {info['campaign_id']}: {path}")  # names from the folder
        print(f"{shown} ({len(runs)} runs to go)", flush=True)
    started = time.perf_counter()

    capacity = drive(
        [run.started for run in runs], settings, campaign, lambda how: _ended(path, info, how)
    )
    wall = time.perf_counter() - started
    return CampaignResult(
        path=path,
        campaign_id=str(info["campaign_id"]),
        status="finished",
        runs=[run.started.result() for run in runs],
        skipped=skipped,
        wall_seconds=wall,
        busy_share=_busy_share(runs, wall, capacity),
        workers=capacity,
    )


def _ended(path: Path, info: Mapping[str, object], status: str) -> None:
    """The campaign's own records once its runs stopped (``status``): campaign.rrd, then
    campaign.json's status, so that ``finished`` there means the recording is written too;
    interrupted while writing them, ``interrupted`` (a resume writes them)."""
    try:
        with contextlib.suppress(OSError) if status != "finished" else contextlib.nullcontext():
            _write_recording(path, quiet=status != "finished")
            write_campaign_info(path, {**info, "status": status, "ended": now()})
    except KeyboardInterrupt:
        with contextlib.suppress(OSError):
            write_campaign_info(path, {**info, "status": "interrupted", "ended": now()})
        raise


def _records_finished(path: Path, info: Mapping[str, object], skipped: int) -> CampaignResult:
    """A campaign stopped after its last run had finished (its recording or campaign.json's
    status not written yet): writes them, as the end of `_drive_campaign` does."""
    _ended(path, info, "finished")
    return CampaignResult(
        path=path,
        campaign_id=str(info["campaign_id"]),
        status="finished",
        runs=[],
        skipped=skipped,
        wall_seconds=0.0,
        busy_share=0.0,
        workers=0,
    )


def _write_recording(path: Path, *, quiet: bool) -> None:
    """campaign.rrd; after an interruption, a failure to write it is not the error to tell."""
    try:
        rerun.write_campaign_recording(path)
    except Exception:
        if not quiet:
            raise


def _busy_share(runs: list[_Run], wall: float, workers: int) -> float:
    """The workers' time in evaluations (the evaluations' ``wall_seconds``: each a share of
    its batch's time on its worker) over ``wall`` x ``workers``, for this call's generations."""
    busy = 0.0
    for run in runs:
        evaluations = load_run(run.started.folder.path).evaluations
        done_now = evaluations[evaluations["generation"] >= run.first_generation]
        busy += float(done_now["wall_seconds"].sum())
    return busy / (wall * workers) if wall > 0 and workers > 0 else 0.0


def campaign_status(campaign_dir: str | Path) -> list[dict[str, Any]]:
    """One row per run: condition, seed, path, status, generations done / total, evaluations,
    best fitness (`ariel.recording.Campaign.status`).

    Args:
        campaign_dir: The campaign folder.

    Returns:
        One dict per run of campaign.json, in its order, with keys ``condition``, ``seed``,
        ``path``, ``status`` (run.json's; ``"stopped (killed?)"`` for a killed run, ``"not
        started"``, or ``"damaged"`` for a folder that does not load), ``generations_done``,
        ``generations``, ``evaluations`` and ``best_fitness`` (NaN when none yet).

    Raises:
        NotACampaignError: When ``campaign_dir`` is not a campaign folder.
        TypeError: When ``campaign_dir`` is not a path.
    """
    path = path_argument("campaign_dir", campaign_dir, function="campaign_status")
    return load_campaign(path).status()
