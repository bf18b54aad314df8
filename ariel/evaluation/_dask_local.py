"""Starting a ``LocalCluster`` of ours: what its processes inherit, and whether it can fit.

`stop_signals_left_to_driver`: the cluster's processes ignore Ctrl-C and SIGHUP, which a
terminal sends to every process of the job; the driver catches them and closes the cluster.
`check_open_files`: a cluster too big for this process's open-file limit is refused in one
line before it starts (else Dask logs ``Too many open files`` for every worker, by the
hundred thousand lines, and the run waits). `quiet_nanny`: worker processes that log nothing
below CRITICAL on stderr. `never_fork`: worker processes are never forked.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import signal
import sys
import threading
import time
from collections.abc import Iterator
from multiprocessing import resource_tracker
from types import ModuleType
from typing import Any

from ariel.errors import ConfigError
from ariel.utils import open_files_short

__all__ = [
    "OPEN_FILES_BESIDE_DASK",
    "OPEN_FILES_PER_DASK_WORKER",
    "SILENT_WORKER_SECONDS",
    "answering_workers",
    "check_open_files",
    "drop_gc_diagnosis",
    "never_fork",
    "open_files_problem",
    "quiet_nanny",
    "stop_signals_left_to_driver",
]

#: A worker of our ``LocalCluster`` whose heartbeat the scheduler has not had for this long
#: counts as gone: a frozen process (SIGSTOP, or C code holding the GIL) keeps its connection
#: and its tasks, and Dask would wait for it for its worker-ttl (5 minutes) each time. Workers
#: beat every second or so.
SILENT_WORKER_SECONDS = 30.0

#: Open files the driver holds for each worker of its ``LocalCluster`` (its nanny's pipes and
#: sockets, the client's and scheduler's connections): measured 10 with 1, 2 and 4 workers.
OPEN_FILES_PER_DASK_WORKER = 12
#: Open files for the rest of a run beside the cluster (records, locks, the scheduler, imports).
OPEN_FILES_BESIDE_DASK = 128


def check_open_files(workers: int) -> None:
    """`open_files_problem` as an error: `ConfigError` in one line, starting ``workers:``."""
    problem = open_files_problem(workers)
    if problem is not None:
        raise ConfigError(f"workers: {problem}")


def open_files_problem(workers: int) -> str | None:
    """Whether this process may hold the open files a ``LocalCluster`` of ``workers`` needs:
    None when it may (the soft limit, ``ulimit -n``, raised towards the hard one where it is
    lower), else why not, naming the most workers that fit (one line, no key)."""
    needed = OPEN_FILES_BESIDE_DASK + OPEN_FILES_PER_DASK_WORKER * workers
    most = open_files_short(needed)
    if most is None:
        return None
    fits = max(0, (most - OPEN_FILES_BESIDE_DASK) // OPEN_FILES_PER_DASK_WORKER)
    return (
        f"a local Dask cluster of {workers} workers needs about {needed} open files; the "
        f"limit is {most} (ulimit -n): use at most {fits} workers, or raise the limit"
    )


@contextlib.contextmanager
def stop_signals_left_to_driver() -> Iterator[None]:
    """Processes started inside ignore Ctrl-C (SIGINT) and SIGHUP: a terminal sends them to
    the whole process group, and the driver, which catches them, closes the cluster; Dask's
    workers would each print a traceback, and multiprocessing's resource tracker, killed by
    SIGHUP, would be started again and print one for every name it no longer knows.

    A process started with a signal ignored keeps it ignored (Python installs its own
    handlers only over the default ones), and so do the processes it starts. The resource
    tracker is started here (if it is not running yet) so that it inherits this too. SIGTERM
    is left alone: Dask's nannies stop their workers with it.
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # signal dispositions can only be changed from the main thread
        return
    numbers = [signal.SIGINT, *([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])]
    previous = {number: signal.signal(number, signal.SIG_IGN) for number in numbers}
    try:
        with contextlib.suppress(Exception):  # no tracker (Windows): nothing to protect
            resource_tracker.ensure_running()
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def quiet_nanny(distributed: ModuleType) -> type:
    """Dask's ``Nanny`` (``distributed.Nanny``) whose worker processes log nothing below
    CRITICAL. A worker that could not start (a Dask configuration value it cannot use, no
    memory) printed its own traceback on stderr from its process, where `DaskLogs` in the
    driver never sees it; the nanny in the driver still logs the error, which `DaskLogs`
    keeps for the run's one line."""
    return _quiet_nanny(distributed.Nanny)


@functools.cache
def _quiet_nanny(nanny: type) -> type:
    class Nanny(nanny):  # type: ignore[misc,valid-type]  # its name in Dask's messages
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)  # its own log level in the driver: as asked
            self.silence_logs = logging.CRITICAL  # handed to each worker process it starts

    return Nanny


def never_fork(distributed: ModuleType) -> None:
    """A Dask configuration asking for ``fork`` (``distributed.worker.multiprocessing-method``,
    in ``~/.config/dask`` or ``DASK_*``) is overridden by ``spawn``, Dask's default, for this
    process from now on (workers are started again later): forked from a process that runs
    threads, the workers hung, the run printed nothing and ignored SIGTERM."""
    del distributed  # imported: it imported dask, whose config this is
    config = sys.modules["dask"].config
    key = "distributed.worker.multiprocessing-method"
    if config.get(key, "spawn") == "fork":
        config.set({key: "spawn"})


def drop_gc_diagnosis(distributed: ModuleType) -> None:
    """Stop the scheduler of our ``LocalCluster`` (it runs in this, the driver's, process)
    timing every garbage collection from a `gc` callback: a Ctrl-C, SIGTERM or SIGHUP that
    lands in that callback is printed by Python as "Exception ignored" with a traceback
    (`ariel.utils.interrupts`), around the run's one line. It only logs long pauses, which
    are held back while the cluster runs anyway. Closing the scheduler later is then a no-op."""
    with contextlib.suppress(AttributeError):  # a Dask without it: nothing to drop
        distributed.gc.disable_gc_diagnosis(force=True)


def answering_workers(client: Any, now: float | None = None) -> int:
    """The workers of ``client``'s cluster whose last heartbeat is under
    `SILENT_WORKER_SECONDS` old (``now``: the scheduler's clock, `time.time` on this machine;
    for our ``LocalCluster`` only: a scheduler elsewhere may keep another clock)."""
    workers = client.scheduler_info(n_workers=-1).get("workers", {})
    now = time.time() if now is None else now
    return sum(
        1
        for worker in workers.values()
        if now - float(worker.get("last_seen", now)) < SILENT_WORKER_SECONDS
    )
