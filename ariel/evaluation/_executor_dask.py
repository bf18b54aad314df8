"""The ``dask`` executor: Dask distributed, on a ``LocalCluster`` or on a scheduler you run.

`DaskExecutor` (a Dask client's executor that closes what it started, and notices a cluster
left without workers), `_make_dask` (which starts a ``LocalCluster`` on the loopback interface,
or connects to a scheduler), and `call_with_timeout`, the soft timeout of a call in a Dask
worker. Needs ``pip install 'ariel[distributed]'``; Dask is imported only when an executor is
made. Re-exported by `ariel.evaluation.executors`.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextvars
import logging
import math
import os
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from types import TracebackType
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

from ariel.errors import CallTimeoutError, ConfigError, ExecutorStartError
from ariel.evaluation._dask_connect import connect_scheduler, distributed_module
from ariel.evaluation._dask_local import (
    SILENT_WORKER_SECONDS,
    answering_workers,
    check_open_files,
    drop_gc_diagnosis,
    never_fork,
    quiet_nanny,
    stop_signals_left_to_driver,
)
from ariel.evaluation._dask_logs import DaskLogs, quiet_cancel_race
from ariel.evaluation._dask_workers import check_workers, workers_problem
from ariel.evaluation._executor_base import EvaluationExecutor, worker_environment
from ariel.evaluation._threads import default_workers

if TYPE_CHECKING:
    from distributed import Client
    from distributed.deploy.cluster import Cluster

__all__ = [
    "NO_WORKER_NOTE_SECONDS",
    "NO_WORKER_TIMEOUT_LOCAL",
    "NO_WORKER_TIMEOUT_SCHEDULER",
    "NO_WORKER_TIMEOUT_VARIABLE",
    "DaskExecutor",
    "call_with_timeout",
]

R = TypeVar("R")
P = ParamSpec("P")

#: Seconds a Dask run waits with no worker at all before it stops (resumable): on a
#: ``LocalCluster`` (its workers were killed, or could not start again) and on a scheduler you
#: run (its workers may wait in a batch queue). The variable `NO_WORKER_TIMEOUT_VARIABLE`
#: overrides both; ``no_worker_timeout=`` of `make_executor` overrides that.
NO_WORKER_TIMEOUT_LOCAL = 60.0
NO_WORKER_TIMEOUT_SCHEDULER = 3600.0
NO_WORKER_TIMEOUT_VARIABLE = "ARIEL_NO_WORKER_TIMEOUT"
#: While it waits for a worker, a Dask run says so on stderr this often (seconds).
NO_WORKER_NOTE_SECONDS = 120.0


class DaskExecutor(EvaluationExecutor):
    """``client.get_executor(pure=False)`` that also closes what it started on shutdown.

    ``pure=False``: Dask would otherwise run identical calls once and share the result.
    `make_executor` makes one; make it yourself only to wrap a client you set up.

    Args:
        client: The `distributed.Client` the calls are submitted through.
        cluster: The ``LocalCluster`` behind ``client`` that this executor is to close on
            shutdown, or None (a scheduler run elsewhere).
        close_client: Whether shutdown closes ``client`` too (False for a client the caller
            owns and closes).
        no_worker_timeout: Seconds the cluster may have no worker at all before `stalled`
            gives a reason to stop (``math.inf``: wait for ever, with notes on stderr). None
            (the default): `NO_WORKER_TIMEOUT_VARIABLE` if set, else `NO_WORKER_TIMEOUT_LOCAL`
            with a ``cluster`` and `NO_WORKER_TIMEOUT_SCHEDULER` without.
        logs: Dask's log lines held back while ``cluster`` runs (`DaskLogs`), released on
            shutdown; their first error goes into `stalled`'s reason. None: left as they are.

    Raises:
        ConfigError: ``no_worker_timeout`` (or the variable) is not a number of seconds > 0.

    Attributes:
        client: the `distributed.Client`.
        cluster: the ``LocalCluster`` this executor started, or None.
    """

    def __init__(
        self,
        client: Client,
        *,
        cluster: Cluster | None = None,
        close_client: bool = True,
        no_worker_timeout: float | None = None,
        logs: DaskLogs | None = None,
    ) -> None:
        quiet_cancel_race()
        default = NO_WORKER_TIMEOUT_LOCAL if cluster is not None else NO_WORKER_TIMEOUT_SCHEDULER
        #: Seconds with no worker at all before `stalled` gives a reason (see
        #: `NO_WORKER_TIMEOUT_LOCAL`); ``math.inf``: wait for ever, with notes.
        self.no_worker_timeout = worker_wait_seconds(no_worker_timeout, default)
        #: Seconds between the notes on stderr while no worker is there.
        self.note_every = NO_WORKER_NOTE_SECONDS
        self.client = client
        self.cluster = cluster
        self._close_client = close_client
        self._executor = client.get_executor(pure=False)
        self._closed = False
        self._none_since: float | None = None  # when `stalled` first saw no worker
        self._checked: set[str] = set()  # workers known to run this ariel (`check_workers`)
        self._notes = 0
        #: Dask's log lines, held back while our LocalCluster runs (None: a cluster of yours).
        self.logs = logs

    kind = "dask"

    @property
    def capacity(self) -> int:
        """The cluster's threads now (each may run a batch); 1 if the scheduler cannot say."""
        try:
            return max(1, sum(self.client.nthreads().values()))
        except Exception:  # a scheduler that is gone or slow: still send work, one call
            return 1

    @property
    def watch_seconds(self) -> float | None:
        return max(0.05, min(5.0, self.no_worker_timeout / 10, self.note_every / 10))

    def stalled(self) -> str | None:
        """A reason once the cluster has had no worker for `no_worker_timeout` seconds (its
        tasks would wait for ever); before that, every `note_every` seconds without one, a
        note on stderr (a batch queue may be slow to start workers). None while workers are
        there."""
        if self._client_closed:  # it gave up reconnecting: for good
            address = getattr(self.client.scheduler, "address", None) or "of the run"
            return f"the Dask scheduler {address} is gone (its client stopped reconnecting)"
        trouble = ""
        try:  # our own cluster's frozen workers count as none (`answering_workers`)
            count = (
                answering_workers(self.client)
                if self.cluster is not None
                else len(self.client.nthreads())
            )
        except Exception as exc:  # the scheduler is gone or does not answer: no worker either
            first = (str(exc).splitlines() or [""])[0][:200]
            why = f"{type(exc).__name__}: {first}" if first else type(exc).__name__
            count, trouble = 0, f"the Dask scheduler does not answer ({why})"
        now = time.monotonic()
        if count:
            self._none_since, self._notes = None, 0
            return self._new_workers_problem()
        if self._none_since is None:
            self._none_since = now
        waited = now - self._none_since
        if waited >= self.no_worker_timeout:
            if not trouble:
                address = getattr(self.client.scheduler, "address", None)
                trouble = (
                    "the local Dask cluster has lost all its workers (killed, frozen for "
                    f"{_duration(SILENT_WORKER_SECONDS)}, or they could not start again)"
                    f"{self.logs.cause() if self.logs is not None else ''}"
                    if self.cluster is not None
                    else f"none is connected to the Dask scheduler {address}"
                )
            return f"no Dask worker for {_duration(self.no_worker_timeout)}: {trouble}"
        if waited >= (self._notes + 1) * self.note_every:
            self._notes += 1
            limit = self.no_worker_timeout
            until = "" if math.isinf(limit) else f"; the run stops after {_duration(limit)}"
            why = f" ({trouble})" if trouble else ""
            print(
                f"waiting for Dask workers: 0 connected for {_duration(waited)}{why}{until}",
                file=sys.stderr,
                flush=True,
            )
        return None

    @property
    def _client_closed(self) -> bool:
        """Whether the client closed itself: its scheduler was gone and it gave up
        reconnecting (Dask's 30 s), so no result will come and nothing is left to cancel."""
        return getattr(self.client, "status", None) in ("closing", "closed")

    def _new_workers_problem(self) -> str | None:
        """A worker that joined a scheduler of the user's since the last look and runs other
        ariel code (`check_workers`; a local cluster's workers are this ariel): the reason to
        stop, or None. Looked for at each `stalled`, so its results reach no finished
        generation but one that ends within `watch_seconds` of its joining."""
        if self.cluster is not None:
            return None
        try:
            workers = set(self.client.nthreads())
        except Exception:  # the scheduler does not answer: said on the next look
            return None
        new = sorted(workers - self._checked)
        if not new:
            return None
        problem = workers_problem(self.client, workers=new)
        if problem is not None:
            return f"{problem}, then resume the run"
        self._checked.update(new)
        return None

    def submit(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> cf.Future[R]:
        return self._executor.submit(fn, *args, **kwargs)

    def submit_with_timeout(
        self, timeout: float | None, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs
    ) -> cf.Future[R]:
        """`submit` with a soft wall-clock limit: past ``timeout`` seconds the future fails with
        `CallTimeoutError`, but the call's thread keeps running in its Dask worker until it ends
        (Dask gives no way to stop one task)."""
        if timeout is None:
            return self.submit(fn, *args, **kwargs)
        return self._executor.submit(call_with_timeout, timeout, fn, *args, **kwargs)

    def map(
        self,
        fn: Callable[..., R],
        *iterables: Iterable[Any],
        timeout: float | None = None,
        chunksize: int = 1,
    ) -> Iterator[R]:
        return self._executor.map(fn, *iterables, timeout=timeout)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self._executor.shutdown(wait=wait and not cancel_futures)
        except Exception:
            if not self._client_closed:
                raise
            # The client closed itself (its scheduler gone): nothing is left to wait for or
            # to cancel, and its error would replace the one line saying why the run stopped.
        finally:
            try:
                if self._close_client:
                    self.client.close()
            finally:
                try:
                    if self.cluster is not None:
                        self.cluster.close()
                finally:
                    if self.logs is not None:
                        self.logs.release()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> bool | None:
        if exc_type is not None and not issubclass(exc_type, Exception):
            # Ctrl-C, SIGTERM, a stopped run (`KeyboardInterrupt`): cancel, do not wait for
            # tasks that may never run (no worker left).
            self.shutdown(wait=False, cancel_futures=True)
            return None
        return super().__exit__(exc_type, exc, tb)

    def __repr__(self) -> str:
        address = getattr(self.client.scheduler, "address", None)
        return f"DaskExecutor(address={address!r}, closed={self._closed})"


def _duration(seconds: float) -> str:
    """``45 s``, ``2 min``, ``1.5 h``: a wait as people say it."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def worker_wait_seconds(given: float | None, default: float) -> float:
    """`DaskExecutor.no_worker_timeout`: ``given``, else `NO_WORKER_TIMEOUT_VARIABLE`, else
    ``default``; a number of seconds > 0 (``inf``: wait for ever)."""
    where, value = "no_worker_timeout", given
    if value is None:
        text = os.environ.get(NO_WORKER_TIMEOUT_VARIABLE, "").strip()
        if not text:
            return default
        where = NO_WORKER_TIMEOUT_VARIABLE
        try:
            value = float(text)
        except ValueError:
            value = math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ConfigError(
            f"{where}: seconds to wait for a Dask worker must be a number > 0 or inf "
            f"(got {value if where != NO_WORKER_TIMEOUT_VARIABLE else text!r})"
        )
    return float(value)


def _make_dask(
    workers: int | None,
    address: str | Client | Cluster | None,
    *,
    max_retries: int | None = None,
    blas_threads: int = 1,
    no_worker_timeout: float | None = None,
    **cluster_options: Any,
) -> DaskExecutor:
    distributed = distributed_module()
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    if address is None:
        settings = _cluster_settings(workers, max_retries, blas_threads, cluster_options)
        settings.setdefault("worker_class", quiet_nanny(distributed))
        limit = worker_wait_seconds(no_worker_timeout, NO_WORKER_TIMEOUT_LOCAL)  # before starting
        check_open_files(settings["n_workers"])
        logs = DaskLogs().hold()  # its workers' deaths are the run's to report, in one line
        never_fork(distributed)
        try:
            with stop_signals_left_to_driver():
                cluster = LocalCluster(**settings)
        except Exception as exc:
            logs.release()
            raise ExecutorStartError(
                f"the local Dask cluster could not start its {settings['n_workers']} worker(s): "
                f"{type(exc).__name__}: {exc}{logs.cause()}"
            ) from exc
        except BaseException:
            logs.release()
            raise
        try:
            drop_gc_diagnosis(distributed)
            client = Client(cluster)
        except BaseException:
            cluster.close()
            logs.release()
            raise
        return DaskExecutor(client, cluster=cluster, no_worker_timeout=limit, logs=logs)
    if workers is not None:
        raise ValueError(
            "workers= sizes a LocalCluster; with address= the cluster's own workers are used "
            "(scale the cluster instead)"
        )
    if cluster_options or max_retries is not None:
        given = sorted(cluster_options) + (["max_retries"] if max_retries is not None else [])
        raise TypeError(
            f"options {given} are for a LocalCluster; they cannot be used with address= "
            "(a scheduler's retries are its distributed.scheduler.allowed-failures setting)"
        )
    limit = worker_wait_seconds(no_worker_timeout, NO_WORKER_TIMEOUT_SCHEDULER)
    if isinstance(address, Client):  # the caller owns it
        return DaskExecutor(address, close_client=False, no_worker_timeout=limit)
    if isinstance(address, str):  # "tcp://host:8786": checked, reached in bounded time
        return DaskExecutor(_checked_client(address), no_worker_timeout=limit)
    return DaskExecutor(Client(address), no_worker_timeout=limit)  # e.g. a SLURMCluster


def _checked_client(address: str) -> Client:
    """A client of the scheduler at ``address`` (`connect_scheduler`) whose workers connected
    now run this ariel (`check_workers`); closed again when they do not."""
    client = connect_scheduler(address)
    try:
        check_workers(client)
    except BaseException:
        client.close()
        raise
    return client


def _cluster_settings(
    workers: int | None,
    max_retries: int | None,
    blas_threads: int,
    cluster_options: dict[str, Any],
) -> dict[str, Any]:
    """A ``LocalCluster``'s keyword arguments: ours, then the caller's ``cluster_options``."""
    n_workers = cluster_options.pop("n_workers", None) or workers or default_workers()
    per_worker = cluster_options.pop("threads_per_worker", None) or 1
    # Every Dask thread may run an evaluation batch: they share the CPUs.
    env = worker_environment(blas_threads, workers=n_workers * per_worker)
    settings: dict[str, Any] = {
        "n_workers": n_workers,
        "threads_per_worker": per_worker,
        "processes": True,
        # Scheduler, nannies and workers (and their HTTP endpoints) listen on the loopback
        # interface only: nothing is reachable from other machines unless asked for.
        "host": "127.0.0.1",
        "dashboard_address": None,
        # Workers' own warnings (e.g. about the tasks a Ctrl-C cancelled) stay quiet; errors
        # still show.
        "silence_logs": logging.ERROR,
        # The nanny sets these before the worker process starts; the caller's env wins.
        "env": {**env, **(cluster_options.pop("env", None) or {})},
    }
    if "dashboard_address" not in cluster_options:
        # Without a dashboard the scheduler still serves HTTP (health, metrics) on 8787 and
        # warns when that is taken (a second cluster): a free loopback port instead.
        quiet_http = {"dashboard": False, "dashboard_address": "127.0.0.1:0"}
        cluster_options["scheduler_kwargs"] = {
            **quiet_http,
            **(cluster_options.get("scheduler_kwargs") or {}),
        }
    if max_retries is not None:
        # Dask reschedules the tasks of a lost worker itself; a task whose workers died
        # more than ``allowed_failures`` times fails with KilledWorker.
        _check_retries(max_retries)
        cluster_options["scheduler_kwargs"] = {
            "allowed_failures": max_retries,
            **(cluster_options.get("scheduler_kwargs") or {}),
        }
    settings.update(cluster_options)
    return settings


def _check_retries(max_retries: object) -> None:
    if not isinstance(max_retries, int) or isinstance(max_retries, bool) or max_retries < 0:
        raise ValueError(f"max_retries must be an integer >= 0, got {max_retries!r}")


def call_with_timeout(
    timeout: float, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs
) -> R:
    """``fn(*args, **kwargs)`` in a helper thread, waiting at most ``timeout`` seconds for it.

    Past the timeout `CallTimeoutError` is raised and the helper thread is left running (a thread
    cannot be stopped): the caller moves on, but the thread may keep a CPU busy until it ends.
    The thread runs in a copy of this thread's context (e.g. Dask's current worker).
    """
    outcome: dict[str, Any] = {}
    context = contextvars.copy_context()

    def target() -> None:
        try:
            outcome["value"] = context.run(fn, *args, **kwargs)
        except BaseException as exc:
            outcome["error"] = exc

    thread = threading.Thread(target=target, name="ariel-timed-call", daemon=True)
    thread.start()
    thread.join(timeout)
    if thread.is_alive():
        raise CallTimeoutError(f"no result after {timeout:g} s; the call was left running")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]
