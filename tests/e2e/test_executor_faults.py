"""Executor faults that must end in one line, or in nothing at all (issue: a hostile probe).

- The local pool's fork server killed: its workers look dead to ``multiprocessing`` but live on;
  the pool stops them and runs their calls again (no death counted), and nothing prints a
  traceback (workers whose pipe closed exit quietly).
- A worker process that cannot be started: the pool breaks with one line on every future, the
  driver thread prints no traceback; a start that fails once (the fork server just died) is
  tried again.
- SIGTERM to a campaign on the local pool (its process group: driver, fork server, workers):
  ``interrupted (SIGTERM); continue it with: ...`` and no traceback.
- A Dask cluster with no worker left: the run stops (``interrupted: no Dask worker for ...``),
  resumable, instead of waiting for ever; on a scheduler you run it first says that it waits.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import importlib.util
import json
import logging
import multiprocessing
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from _helpers import REPO, repo_env

from ariel.evaluation import _selftest
from ariel.evaluation.executors import LocalPool, make_executor

TINY_RUN = REPO / "tests" / "data" / "run_tiny.toml"
TINY_CAMPAIGN = REPO / "tests" / "data" / "campaign_tiny.toml"

needs_dask = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="dask.distributed is not installed (pip install 'ariel[distributed]')",
)
posix_only = pytest.mark.skipif(
    not Path("/proc/self/task").is_dir() or not hasattr(os, "killpg"),
    reason="needs Linux /proc and process groups",
)


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _children(pid: int) -> list[int]:
    found: list[int] = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            found += [int(p) for p in (task / "children").read_text().split()]
    return found


def _fork_server(pid: int) -> int | None:
    """The fork server among ``pid``'s children, or None."""
    for child in _children(pid):
        try:
            cmdline = Path(f"/proc/{child}/cmdline").read_bytes()
        except OSError:
            continue
        if b"multiprocessing.forkserver" in cmdline:
            return child
    return None


def _running(pids: list[int]) -> bool:
    """Whether one of ``pids`` is running (or waiting for a CPU): a worker mid-evaluation."""
    for pid in pids:
        with contextlib.suppress(OSError, IndexError):
            if Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "R":
                return True
    return False


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    try:  # a zombie still answers
        return Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"
    except OSError:
        return True


def _wait_for(condition: Any, seconds: float, what: str, process: Any = None) -> None:
    """Poll ``condition`` until it holds; fail after ``seconds``, or once ``process`` ended."""
    deadline = time.monotonic() + seconds
    while not condition():
        if process is not None and process.poll() is not None:
            raise AssertionError(f"the process ended (code {process.returncode}) before {what}")
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {seconds} s waiting for {what}")
        time.sleep(0.05)


def _generations_done(folder: Path) -> int:
    try:
        return int(json.loads((folder / "run.json").read_text()).get("generations_done", 0))
    except (OSError, ValueError):
        return 0


def _runs_running(folder: Path) -> int:
    running = 0
    for info in folder.rglob("run.json"):
        with contextlib.suppress(OSError, ValueError):
            running += json.loads(info.read_text()).get("status") == "running"
    return running


# --------------------------------------------------------------------------------------------
# the local pool: its fork server killed, a worker that cannot start, SIGTERM
# --------------------------------------------------------------------------------------------


@pytest.mark.soak  # ~15 s: a run whose fork server is killed midway
@posix_only
def test_a_run_whose_fork_server_is_killed_goes_on_without_a_word(tmp_path: Path) -> None:
    out, err = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    run_dir = tmp_path / "run"
    command = [sys.executable, "-m", "ariel.cli", "run", str(TINY_RUN), "--executor", "local"]
    # Generations enough that the run is still under way at the second kill on a fast machine.
    command += ["--workers", "2", "--out", str(run_dir), "--quiet", "--set", "generations=20"]
    with out.open("wb") as stdout, err.open("wb") as stderr:
        process = subprocess.Popen(
            command, stdout=stdout, stderr=stderr, env=repo_env(), start_new_session=True
        )
        try:
            killed: list[int] = []
            for generation in (1, 2):  # twice: the second time a fork server the pool restarted
                _wait_for(
                    lambda g=generation: _generations_done(run_dir) >= g,
                    120,
                    "a generation",
                    process,
                )
                _wait_for(
                    lambda: _fork_server(process.pid) not in (None, *killed),
                    60,
                    "a fork server",
                    process,
                )
                server = _fork_server(process.pid)
                assert server is not None
                _wait_for(lambda s=server: _running(_children(s)), 60, "a busy worker", process)
                os.kill(server, signal.SIGKILL)  # mid-evaluation: its workers live on
                killed.append(server)
            code = process.wait(timeout=180)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
    errors = err.read_text()
    assert "Traceback" not in errors and "Error" not in errors, errors[-3000:]
    assert code == 0, errors[-3000:]
    assert errors.strip() == ""  # --quiet: a run that went on says nothing
    info = json.loads((run_dir / "run.json").read_text())
    assert info["status"] == "finished" and info["generations_done"] == 20


@posix_only
@pytest.mark.parametrize(
    ("whole_group", "delay"),
    # ~10-15 s each: the driver alone in `make test`, the whole group with the soak tests
    [
        pytest.param(True, 0.3, marks=pytest.mark.soak),
        (False, 1.0),
        pytest.param(True, 2.0, marks=pytest.mark.soak),
    ],
    ids=["group", "driver", "group-later"],
)
def test_sigterm_to_a_local_campaign_ends_in_one_line(
    tmp_path: Path, whole_group: bool, delay: float
) -> None:
    # SIGTERM to the process group (a batch system, a closed terminal: the driver, the fork
    # server and the workers all get it), or to the driver alone, while the workers are busy.
    folder, err = tmp_path / "campaign", tmp_path / "stderr.txt"
    command = [sys.executable, "-m", "ariel.cli", "campaign", "run", str(TINY_CAMPAIGN)]
    command += ["--executor", "local", "--workers", "2", "--out", str(folder), "--quiet"]
    command += ["--set", "generations=30"]  # still under way 2 s after its runs start
    with err.open("wb") as stderr:
        process = subprocess.Popen(
            command,
            stdout=subprocess.DEVNULL,
            stderr=stderr,
            env=repo_env(),
            start_new_session=True,
        )
        try:
            _wait_for(lambda: _runs_running(folder) == 4, 120, "the 4 runs to start", process)
            time.sleep(delay)  # generation 0's evaluations are under way
            assert process.poll() is None
            if whole_group:
                os.killpg(process.pid, signal.SIGTERM)
            else:
                os.kill(process.pid, signal.SIGTERM)
            code = process.wait(timeout=120)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
    errors = err.read_text()
    assert "Traceback" not in errors and "Exception" not in errors, errors[-3000:]
    assert code == 128 + signal.SIGTERM, (code, errors[-3000:])
    lines = errors.strip().splitlines()
    assert len(lines) == 1, errors
    assert re.fullmatch(
        r"interrupted \(SIGTERM\); continue it with: \S*ariel campaign resume \S+", lines[0]
    ), lines


class _FailingStarts:
    """A multiprocessing context whose first ``failures`` process starts fail as a start does
    when the fork server died just then."""

    def __init__(self, failures: int) -> None:
        self.real = multiprocessing.get_context("spawn")
        self.failures = failures
        self.lock = threading.Lock()

    def get_start_method(self) -> str:
        return self.real.get_start_method()

    def Pipe(self, duplex: bool = True) -> Any:  # multiprocessing's name
        return self.real.Pipe(duplex)

    def Process(self, **options: Any) -> Any:
        process = self.real.Process(**options)
        with self.lock:
            fail, self.failures = self.failures > 0, self.failures - 1
        if fail:

            def start() -> None:
                raise ConnectionRefusedError(111, "Connection refused")

            process.start = start
        return process


def test_a_worker_that_cannot_start_breaks_the_pool_in_one_line(monkeypatch) -> None:
    hooked: list[Any] = []
    monkeypatch.setattr(threading, "excepthook", hooked.append)
    monkeypatch.setattr("ariel.evaluation._pool._START_RETRY_SECONDS", (0.01, 0.01), raising=False)
    with LocalPool(1, mp_context=_FailingStarts(100)) as pool:  # type: ignore[arg-type]
        future = pool.submit(_selftest.pid)
        with pytest.raises(cf.BrokenExecutor) as info:
            future.result(timeout=60)
        pool._driver.thread.join(timeout=60)
    assert str(info.value) == (
        "a worker process could not be started: ConnectionRefusedError: [Errno 111] Connection "
        "refused"
    )
    assert isinstance(info.value.__cause__, ConnectionRefusedError)  # for whoever debugs it
    assert hooked == []  # the driver thread printed no traceback


def test_a_worker_start_that_fails_once_is_tried_again(monkeypatch) -> None:
    hooked: list[Any] = []
    monkeypatch.setattr(threading, "excepthook", hooked.append)
    with LocalPool(1, mp_context=_FailingStarts(1)) as pool:  # type: ignore[arg-type]
        assert pool.submit(_selftest.seeded_sum, 3).result(timeout=120) == (_selftest.seeded_sum(3))
    assert hooked == []


@posix_only
@pytest.mark.skipif(not hasattr(os, "pidfd_open"), reason="needs pidfd_open (Linux 5.3)")
def test_a_killed_fork_server_is_no_worker_death_and_leaves_no_orphan() -> None:
    # max_retries=0: were the fork server's death taken for the worker's, the call would fail.
    pool = make_executor("local", workers=1, max_retries=0, mp_context="forkserver")
    try:
        worker = pool.submit(_selftest.pid).result(timeout=120)
        future = pool.submit(_selftest.sleep, 60)
        _wait_for(future.running, 60, "the call to start")
        time.sleep(0.5)  # it is in the worker
        server = _fork_server(os.getpid())
        assert server is not None and worker in _children(server)
        os.kill(server, signal.SIGKILL)
        _wait_for(lambda: _gone(worker), 20, "the orphaned worker to be stopped")
        time.sleep(0.5)
        assert not future.done()  # running again, on a fresh worker (a new fork server)
        _wait_for(lambda: _fork_server(os.getpid()) not in (None, server), 60, "a new forkserver")
    finally:  # as Ctrl-C does: kill the worker, do not wait a minute
        pool.__exit__(KeyboardInterrupt, KeyboardInterrupt(), None)
    with pytest.raises(cf.BrokenExecutor, match="the pool was closed during the call"):
        future.result(timeout=60)


def test_a_killed_pool_does_not_retry_its_calls(monkeypatch) -> None:
    """A call waiting for a fresh worker (its worker died) when the pool is killed fails at once
    rather than starting a worker while the driver stops (the SIGTERM race)."""
    pool = make_executor("local", workers=1, max_retries=5, mp_context="spawn")
    driver = pool._driver
    started: list[int] = []
    real = driver._start_worker

    def start_worker() -> Any:
        started.append(1)
        if len(started) == 2:  # the retry's worker: the pool is killed meanwhile
            pool.__exit__(KeyboardInterrupt, KeyboardInterrupt(), None)
        return real()

    monkeypatch.setattr(driver, "_start_worker", start_worker)
    future = pool.submit(_selftest.die)
    with pytest.raises(cf.BrokenExecutor, match="the pool was closed during the call"):
        future.result(timeout=60)
    _wait_for(lambda: not driver.thread.is_alive(), 60, "the driver thread to end")
    assert driver.workers == [] and len(started) <= 2


# --------------------------------------------------------------------------------------------
# Dask: no worker left
# --------------------------------------------------------------------------------------------


class _Waiting:
    """Work of one batch of two tasks, in generation 4."""

    generation = 4

    def __init__(self) -> None:
        self.sent = False

    def next_batch(self) -> list[Any] | None:
        if self.sent:
            return None
        self.sent = True
        return [1, 2]

    def batch_done(self, results: list[Any]) -> None:
        raise AssertionError("no worker: no results")

    def failed_result(self, task: Any, reason: str) -> Any:
        raise AssertionError(reason)

    def task_error(self, task: Any, exc: BaseException) -> BaseException:
        return exc

    def flush(self) -> None:
        pass


@needs_dask
def test_waiting_for_the_workers_of_your_scheduler_says_so_then_stops(capsys) -> None:
    from distributed import LocalCluster

    from ariel.evolution._scheduler import Scheduler
    from ariel.utils.interrupts import STOPPED_EXIT, Stopped, exit_status

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        with make_executor("dask", address=address, no_worker_timeout=3) as executor:
            executor.note_every = 1.0
            assert executor.watch_seconds == pytest.approx(0.1)
            started = time.monotonic()
            with pytest.raises(Stopped) as info:
                Scheduler(executor, timeout=None).run([iter([[_Waiting()]])])
            waited = time.monotonic() - started
    assert 3 <= waited < 30
    assert info.value.reason == (
        f"no Dask worker for 3 s: none is connected to the Dask scheduler {address}; "
        "the run stopped at generation 4"
    )
    assert exit_status(info.value) == (STOPPED_EXIT, f": {info.value.reason}")
    notes = capsys.readouterr().err.strip().splitlines()
    assert len(notes) >= 2, notes
    for note in notes:  # one line every note_every seconds, and nothing else
        assert re.fullmatch(
            r"waiting for Dask workers: 0 connected for \d s; the run stops after 3 s", note
        ), notes


@needs_dask
def test_dask_stalled_counts_from_the_last_time_a_worker_was_there(monkeypatch) -> None:
    from ariel.errors import ConfigError
    from ariel.evaluation.executors import DaskExecutor

    class Client:
        scheduler = None

        def __init__(self) -> None:
            self.workers: dict[str, int] = {}

        def get_executor(self, **options: Any) -> Any:
            return None

        def nthreads(self) -> dict[str, int]:
            return dict(self.workers)

        def scheduler_info(self, n_workers: int) -> dict[str, Any]:
            heard = time.time() - self.silent_for
            return {"workers": {name: {"last_seen": heard} for name in self.workers}}

    client = Client()
    client.silent_for = 0.0
    executor = DaskExecutor(client, cluster=object(), no_worker_timeout=0.3)  # type: ignore[arg-type]
    assert executor.stalled() is None  # no worker: the clock starts
    client.workers = {"w": 1}
    time.sleep(0.4)
    assert executor.stalled() is None  # a worker came: the clock stops
    client.workers = {}
    assert executor.stalled() is None
    time.sleep(0.4)
    lost = (
        "no Dask worker for 0 s: the local Dask cluster has lost all its workers (killed, "
        "frozen for 30 s, or they could not start again)"
    )
    assert executor.stalled() == lost
    # A frozen worker (SIGSTOP) keeps its connection, not its heartbeat: it counts as gone.
    client.workers, client.silent_for = {"w": 1}, 31.0
    executor = DaskExecutor(client, cluster=object(), no_worker_timeout=0.3)  # type: ignore[arg-type]
    assert executor.stalled() is None
    time.sleep(0.4)
    assert executor.stalled() == lost
    client.silent_for = 1.0
    assert executor.stalled() is None
    monkeypatch.setenv("ARIEL_NO_WORKER_TIMEOUT", "soon")
    with pytest.raises(ConfigError, match=r"ARIEL_NO_WORKER_TIMEOUT: .* > 0 or inf .*'soon'"):
        DaskExecutor(client)  # type: ignore[arg-type]
    monkeypatch.setenv("ARIEL_NO_WORKER_TIMEOUT", "inf")
    assert DaskExecutor(client).no_worker_timeout == float("inf")  # type: ignore[arg-type]
    monkeypatch.delenv("ARIEL_NO_WORKER_TIMEOUT")
    assert DaskExecutor(client).no_worker_timeout == 3600  # type: ignore[arg-type]
    assert DaskExecutor(client, cluster=object()).no_worker_timeout == 60  # type: ignore[arg-type]


@needs_dask
def test_a_dask_run_whose_workers_are_all_gone_stops_and_resumes(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    from ariel import cli
    from ariel.evaluation.executors import DaskExecutor

    monkeypatch.setenv("ARIEL_NO_WORKER_TIMEOUT", "3")
    run_dir = tmp_path / "run"
    submit_batch = DaskExecutor.submit_batch
    closed: list[int] = []

    def submit_then_lose_the_workers(self: Any, tasks: list[Any], **options: Any) -> Any:
        if not closed and _generations_done(run_dir) >= 1:  # generation 1's first batch
            for nanny in list(self.cluster.workers.values()):  # as a nanny that could not
                self.cluster.sync(nanny.close)  # start its worker again: none left
            closed.append(len(self.client.nthreads()))
        return submit_batch(self, tasks, **options)

    monkeypatch.setattr(DaskExecutor, "submit_batch", submit_then_lose_the_workers)
    # Were the run to wait for ever, a Ctrl-C after 2 minutes ends it (exit 130, not 75).
    alarm = threading.Timer(120, os.kill, (os.getpid(), signal.SIGINT))
    alarm.start()
    try:
        code = cli.main(
            [
                *("run", str(TINY_RUN), "--executor", "dask", "--workers", "2"),
                *("--out", str(run_dir), "--quiet", "--set", "generations=3"),
            ]
        )
    finally:
        alarm.cancel()
    errors = capsys.readouterr().err
    assert closed == [0], errors  # the workers were all gone during generation 1
    assert code == 75, errors
    lines = errors.splitlines()
    assert len(lines) == 1, errors  # no empty line first: no ^C to end a line after
    assert re.fullmatch(
        r"interrupted: no Dask worker for 3 s: the local Dask cluster has lost all its workers "
        r"\(killed, frozen for 30 s, or they could not start again\); the run stopped at "
        r"generation 1; continue it with: \S*ariel resume \S+",
        lines[0],
    ), lines
    info = json.loads((run_dir / "run.json").read_text())
    assert info["status"] == "interrupted" and info["generations_done"] == 1
    # Resumable: it goes on from generation 1 (here on the serial executor) and finishes.
    monkeypatch.setattr(DaskExecutor, "submit_batch", submit_batch)
    code = cli.main(["resume", str(run_dir), "--executor", "serial", "--quiet"])
    assert code == 0, capsys.readouterr().err
    info = json.loads((run_dir / "run.json").read_text())
    assert info["status"] == "finished" and info["generations_done"] == 3


class _Shown(logging.Handler):
    """Collects the log records that reach it (as Dask's stderr handler would print them)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@pytest.fixture
def dask_log_shown() -> Any:
    """What Dask's logger shows, on a handler of its own (Dask installs one only where the
    root logger has none, which under pytest it has)."""
    import distributed  # noqa: F401  (configures the "distributed" logger)

    shown = _Shown()
    loggers = [logging.getLogger(name) for name in ("distributed", "tornado.application")]
    for logger in loggers:
        logger.addHandler(shown)
    yield shown
    for logger in loggers:
        logger.removeHandler(shown)


@needs_dask
def test_dask_s_error_logs_are_held_back_and_their_cause_kept(dask_log_shown: _Shown) -> None:
    from ariel.evaluation._dask_logs import DaskLogs

    nanny = logging.getLogger("distributed.nanny")
    logs = DaskLogs().hold()
    try:
        try:
            raise OSError(24, "Too many open files")
        except OSError:
            nanny.exception("Failed to start process")  # held back, its cause kept
        nanny.error("Nanny failed to start")  # a message without an exception: not the cause
        logging.getLogger("tornado.application").error("a cancelled future's callback")
        nanny.critical("shown")  # still shown
    finally:
        logs.release()
    assert [r.getMessage() for r in dask_log_shown.records] == ["shown"]
    assert logs.cause() == "; first error: OSError: [Errno 24] Too many open files"
    nanny.error("after")  # shown again once released
    assert [r.getMessage() for r in dask_log_shown.records] == ["shown", "after"]


@needs_dask
def test_a_local_dask_cluster_that_cannot_start_is_one_line(
    tmp_path: Path, monkeypatch, capsys, dask_log_shown: _Shown
) -> None:
    import distributed

    from ariel import cli

    class NoWorkers:  # as under `ulimit -n 32`: each nanny logs its failure, then it raises
        def __init__(self, **settings: Any) -> None:
            try:
                raise OSError(24, "Too many open files")
            except OSError:
                logging.getLogger("distributed.nanny").exception("Failed to start process")
            raise RuntimeError("Nanny failed to start.")

    monkeypatch.setattr(distributed, "LocalCluster", NoWorkers)
    argv = ["run", str(TINY_RUN), "--executor", "dask", "--workers", "2", "--quiet"]
    assert cli.main([*argv, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.splitlines() == [
        "ariel: error: the local Dask cluster could not start its 2 worker(s): RuntimeError: "
        "Nanny failed to start.; first error: OSError: [Errno 24] Too many open files"
    ], err
    assert dask_log_shown.records == []  # the nanny's error went into that line, not stderr


@needs_dask
def test_a_client_closed_by_a_lost_scheduler_stops_without_tracebacks(capfd) -> None:
    """Once the scheduler had gone for good the client closed itself; the run's stop then
    printed a ClosedClientError traceback per cancelled future, and shutdown raised one more,
    which replaced the one line saying why the run stopped (exit 1, status failed)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        executor = make_executor("dask", address=cluster.scheduler_address)
        futures = [executor.submit(abs, -1) for _ in range(3)]
        status, executor.client.status = executor.client.status, "closed"  # as after the loss
        try:
            for future in futures:
                future.cancel()  # what the scheduler does as the run stops
            executor.shutdown(wait=False, cancel_futures=True)
        finally:
            executor.client.status = status
            executor.client.close()
    err = capfd.readouterr().err
    assert "ClosedClientError" not in err and "Traceback" not in err, err[-2000:]
