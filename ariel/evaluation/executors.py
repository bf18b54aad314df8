"""Executors: where evaluations run.

Everything that runs evaluations talks to a `concurrent.futures.Executor` made here:

- ``serial``: in this process, one call after another (debugging, tests, profiling).
- ``local`` (default): a process pool on this machine, one worker per CPU, started with
  ``forkserver`` (``spawn`` where that is missing), BLAS/OpenMP limited to one thread per worker;
  a call whose worker dies is retried on a fresh one, a call past its timeout is stopped
  (`ariel.evaluation._pool.LocalPool`).
- ``dask``: Dask distributed, on a ``LocalCluster`` or on an existing scheduler (e.g. one run by
  dask-jobqueue on SLURM); needs ``pip install 'ariel[distributed]'``.
- ``gpu``: in this process, each batch of one body's brains as parallel worlds on MuJoCo Warp
  (`ariel.evaluation._warp.WarpExecutor`, docs/gpu.md); needs ``pip install 'ariel[gpu]'``.

Functions shipped to workers must be plain top-level functions taking plain data: workers
import them by name and rebuild plugins from registry names (see ``docs/executors.md``).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import functools
import logging
import math
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING, Any, TypeVar

from ariel.evaluation._pool import CallTimeoutError, LocalPool, WorkerLostError, call_with_timeout
from ariel.evaluation._threads import (
    EVAL_THREADS_VARIABLE,
    THREAD_LIMIT_VARIABLES,
    default_workers,
    evaluation_threads,
)
from ariel.plugins import Registry
from ariel.utils import accept_aliases

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "DEFAULT_MAX_RETRIES",
    "EVAL_THREADS_VARIABLE",
    "EXECUTOR_KINDS",
    "NO_WORKER_TIMEOUT_VARIABLE",
    "THREAD_LIMIT_VARIABLES",
    "BatchExecutor",
    "CallTimeoutError",
    "DaskExecutor",
    "DaskKind",
    "EvaluationExecutor",
    "ExecutorKind",
    "ExecutorSettingsError",
    "GpuKind",
    "LocalExecutor",
    "LocalKind",
    "LocalPool",
    "SerialExecutor",
    "SerialKind",
    "WorkerLostError",
    "check_settings",
    "default_workers",
    "evaluation_threads",
    "executor_kind",
    "executor_kinds",
    "known_kinds",
    "make_executor",
    "map_ordered",
    "planned_workers",
    "settings_options",
    "submit_with_timeout",
    "worker_environment",
    "worker_fault",
]

R = TypeVar("R")

#: The built-in executor kinds (`executor_kinds` has these and any registered ones).
EXECUTOR_KINDS: tuple[str, ...] = ("serial", "local", "dask", "gpu")
_BUILTIN_KINDS = dict(zip(EXECUTOR_KINDS, ("SerialKind", "LocalKind", "DaskKind", "GpuKind")))

#: Times a call is tried again after its worker died (``local``; a Dask ``LocalCluster``).
DEFAULT_MAX_RETRIES = 2

_DASK_MISSING = "Dask executor needs the optional extra: pip install 'ariel[distributed]'"

#: Seconds a Dask run waits with no worker at all before it stops (resumable): on a
#: ``LocalCluster`` (its workers were killed, or could not start again) and on a scheduler you
#: run (its workers may wait in a batch queue). The variable `NO_WORKER_TIMEOUT_VARIABLE`
#: overrides both; ``no_worker_timeout=`` of `make_executor` overrides that.
NO_WORKER_TIMEOUT_LOCAL = 60.0
NO_WORKER_TIMEOUT_SCHEDULER = 3600.0
NO_WORKER_TIMEOUT_VARIABLE = "ARIEL_NO_WORKER_TIMEOUT"
#: While it waits for a worker, a Dask run says so on stderr this often (seconds).
NO_WORKER_NOTE_SECONDS = 120.0


def _is_count(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def worker_environment(threads: int = 1, *, workers: int | None = None) -> dict[str, str]:
    """The variables set in every worker process.

    The BLAS/OpenMP/numexpr thread limits (BLAS is 3-57x slower oversubscribed) and, given the
    number of workers sharing this machine, `EVAL_THREADS_VARIABLE`: each one's share of this
    process's CPUs, which `evaluation_threads` reads.

    Args:
        threads: The thread limit of BLAS, OpenMP and numexpr in each worker, >= 1.
        workers: How many workers share this machine, >= 1; None (the default): leave
            `EVAL_THREADS_VARIABLE` out.

    Returns:
        Variable name to value: every name of `THREAD_LIMIT_VARIABLES`, and with ``workers``
        `EVAL_THREADS_VARIABLE` (this process's CPUs divided by ``workers``, at least 1).

    Raises:
        ValueError: ``threads`` or ``workers`` is not an integer >= 1.
    """
    if not _is_count(threads):
        raise ValueError(f"blas_threads must be an integer >= 1, got {threads!r}")
    env = dict.fromkeys(THREAD_LIMIT_VARIABLES, str(threads))
    if workers is not None:
        if not _is_count(workers):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        env[EVAL_THREADS_VARIABLE] = str(max(1, default_workers() // workers))
    return env


# --------------------------------------------------------------------------------------------
# what the loop needs of every executor: its capacity, and how it evaluates a batch
# --------------------------------------------------------------------------------------------


class BatchExecutor:
    """What the scheduler uses: ``capacity`` (calls worth keeping in flight at once: one per
    worker) and ``submit_batch(tasks, timeout=)`` (a future of `evaluate_batch`'s results).

    Every executor `make_executor` returns has both; an executor kind says here how it
    evaluates a batch, so nothing outside this module branches on kind names.
    """

    kind: str = ""

    @property
    def capacity(self) -> int:
        return 1

    @property
    def watch_seconds(self) -> float | None:
        """How often the scheduler asks `stalled` while it waits for results (None: never)."""
        return None

    def stalled(self) -> str | None:
        """Why this executor cannot go on, in one line (e.g. no Dask worker for a minute), or
        None. The scheduler asks every `watch_seconds` while it waits, and stops the run
        (`ariel.utils.interrupts.Stopped`, resumable) on a reason. May print a note meanwhile."""
        return None

    def dispatch(self) -> None:
        """Start what `submit_batch` queued: the scheduler calls it before it waits for
        results. Executors that start each batch when it is submitted do nothing here."""

    def submit_batch(self, tasks: list[Any], *, timeout: float | None = None) -> cf.Future[Any]:
        """Evaluate ``tasks`` (`ariel.evaluation.evaluate_batch`) within ``timeout`` seconds
        where the executor can stop a call (`submit_with_timeout`)."""
        import ariel.evaluation  # looked up when called (a test may wrap it in this process)

        batch = ariel.evaluation.evaluate_batch
        return submit_with_timeout(self, timeout, batch, tasks)  # type: ignore[arg-type]


class EvaluationExecutor(BatchExecutor, cf.Executor):
    """A `concurrent.futures.Executor` that is also a `BatchExecutor`: what `make_executor`
    returns (typing has no intersection of two classes). The built-in executors subclass it;
    an executor kind's own executor may too, or subclass the two itself."""


# --------------------------------------------------------------------------------------------
# serial
# --------------------------------------------------------------------------------------------


class SerialExecutor(EvaluationExecutor):
    """Runs each submitted call at once, in this process; returns completed futures.

    An exception raised by the call is stored in its future (as in a process pool), not raised
    by ``submit``.
    """

    kind = "serial"

    def __init__(self) -> None:
        self._shutdown, self._lock = False, threading.Lock()

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> cf.Future[R]:
        with self._lock:
            if self._shutdown:
                raise RuntimeError("cannot schedule new futures after shutdown")
        future: cf.Future[R] = cf.Future()
        future.set_running_or_notify_cancel()
        try:
            result = fn(*args, **kwargs)
        except Exception as exc:  # KeyboardInterrupt and friends still stop the caller
            future.set_exception(exc)
        else:
            future.set_result(result)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            self._shutdown = True

    def __repr__(self) -> str:
        return "SerialExecutor()"


class _QueuedFuture(cf.Future):  # type: ignore[type-arg]
    """A future whose batch waits in a queue: asking for its result dispatches the queue."""

    def __init__(self, dispatch: Callable[[], None]) -> None:
        super().__init__()
        self._dispatch = dispatch

    def result(self, timeout: float | None = None) -> Any:
        self._dispatch()
        return super().result(timeout)

    def exception(self, timeout: float | None = None) -> BaseException | None:
        self._dispatch()
        return super().exception(timeout)


class WarpExecutor(SerialExecutor):
    """The ``gpu`` executor: batches run on a device, from a thread of this process.

    `submit_batch` queues a batch; `dispatch` (the scheduler calls it before it waits) hands
    everything queued to the device thread, which evaluates it as ONE call of its
    `WarpEvaluator`: the brain batches of several bodies or runs go to the device together
    (batches of one body, world and timing become one set of worlds), and the driver's work
    on earlier results overlaps the device's stepping. Results are the same kind as
    `ariel.evaluation.evaluate_batch`'s. A call that raises is retried batch by batch, so only
    the faulty batch's future holds the error. Any other call runs as in `SerialExecutor`.
    """

    kind = "gpu"

    def __init__(self, device: str = "cuda", *, max_worlds: int | None = None) -> None:
        from ariel.evaluation._warp import WarpEvaluator  # imports no Warp until it is made

        super().__init__()
        self.evaluator = WarpEvaluator(device, max_worlds=max_worlds)
        self._queued: list[tuple[list[Any], cf.Future[Any]]] = []
        self._ready: list[tuple[list[Any], cf.Future[Any]]] = []
        self._wake = threading.Condition()
        self._thread: threading.Thread | None = None

    @property
    def device(self) -> str:
        return self.evaluator.device

    def submit_batch(self, tasks: list[Any], *, timeout: float | None = None) -> Any:
        """Queue the batch for the device (no timeout: the device runs it to its end)."""
        future = _QueuedFuture(self.dispatch)
        with self._lock:
            if self._shutdown:
                raise RuntimeError("cannot schedule new futures after shutdown")
        self._queued.append((list(tasks), future))
        return future

    def dispatch(self) -> None:
        """Hand the queued batches to the device thread (started on first use)."""
        if not self._queued:
            return
        with self._wake:
            self._ready.extend(self._queued)
            self._queued.clear()
            self._wake.notify()
        if self._thread is None:
            self._thread = threading.Thread(target=self._serve, name="ariel-gpu", daemon=True)
            self._thread.start()

    def _serve(self) -> None:
        while True:
            with self._wake:
                while not self._ready and not self._shutdown:
                    self._wake.wait()
                if not self._ready:
                    return
                taken, self._ready = self._ready, []
            self._run(taken)

    def _run(self, taken: list[tuple[list[Any], cf.Future[Any]]]) -> None:
        live = [(tasks, f) for tasks, f in taken if f.set_running_or_notify_cancel()]
        try:
            results = self.evaluator.evaluate_batch([t for tasks, _ in live for t in tasks])
        except BaseException as exc:
            if len(live) == 1 or not isinstance(exc, Exception):
                for _, future in live:
                    future.set_exception(exc)
                return
            for tasks, future in live:  # batch by batch: only the faulty one fails
                try:
                    future.set_result(self.evaluator.evaluate_batch(tasks))
                except Exception as one:
                    future.set_exception(one)
            return
        start = 0
        for tasks, future in live:
            future.set_result(results[start : start + len(tasks)])
            start += len(tasks)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        super().shutdown(wait, cancel_futures=cancel_futures)
        for _, future in self._queued:
            future.cancel()
        self._queued.clear()
        with self._wake:
            if cancel_futures:
                for _, future in self._ready:
                    future.cancel()
            self._wake.notify()
        if wait and self._thread is not None:
            self._thread.join()

    def __repr__(self) -> str:
        return f"WarpExecutor(device={self.device!r})"


# --------------------------------------------------------------------------------------------
# local process pool
# --------------------------------------------------------------------------------------------


def _limit_loaded_thread_pools(threads: int) -> None:
    """Cap thread pools of libraries imported before the initializer ran (e.g. by __main__)."""
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(threads)
    if "numpy" in sys.modules:
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:  # optional: without it, only the environment limits BLAS
            return
        threadpool_limits(limits=threads)


def _initialize_worker(
    env: dict[str, str],
    threads: int,
    initializer: Callable[..., object] | None,
    initargs: tuple[Any, ...],
) -> None:
    """Process-pool initializer: thread limits first, then the caller's own initializer.

    Workers ignore SIGINT: Ctrl-C reaches the whole process group, and the parent, which
    catches it, shuts the pool down; workers dying mid-task would only add tracebacks.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.update(env)
    _limit_loaded_thread_pools(threads)
    if initializer is not None:
        initializer(*initargs)


def _default_mp_context() -> multiprocessing.context.BaseContext:
    # Never fork: forking a process that holds threads (MuJoCo, Dask, torch) can deadlock.
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


class LocalExecutor(EvaluationExecutor, LocalPool):
    """The ``local`` executor: a `LocalPool` whose capacity is its worker count."""

    kind = "local"

    @property
    def capacity(self) -> int:
        return self.max_workers


def _make_local(
    workers: int | None,
    *,
    max_retries: int | None = None,
    blas_threads: int = 1,
    mp_context: str | multiprocessing.context.BaseContext | None = None,
    initializer: Callable[..., object] | None = None,
    initargs: tuple[Any, ...] = (),
    max_tasks_per_child: int | None = None,
) -> LocalExecutor:
    workers = workers or default_workers()
    env = worker_environment(blas_threads, workers=workers)
    context = _default_mp_context() if mp_context is None else mp_context
    if isinstance(context, str):
        context = multiprocessing.get_context(context)
    return LocalExecutor(
        workers,
        mp_context=context,
        worker_env=env,
        initializer=_initialize_worker,
        initargs=(env, blas_threads, initializer, tuple(initargs)),
        max_tasks_per_child=max_tasks_per_child,
        max_retries=DEFAULT_MAX_RETRIES if max_retries is None else max_retries,
    )


# --------------------------------------------------------------------------------------------
# dask
# --------------------------------------------------------------------------------------------


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
        cluster: Any = None,
        close_client: bool = True,
        no_worker_timeout: float | None = None,
    ) -> None:
        default = NO_WORKER_TIMEOUT_LOCAL if cluster is not None else NO_WORKER_TIMEOUT_SCHEDULER
        #: Seconds with no worker at all before `stalled` gives a reason (see
        #: `NO_WORKER_TIMEOUT_LOCAL`); ``math.inf``: wait for ever, with notes.
        self.no_worker_timeout = _no_worker_timeout(no_worker_timeout, default)
        #: Seconds between the notes on stderr while no worker is there.
        self.note_every = NO_WORKER_NOTE_SECONDS
        self.client = client
        self.cluster = cluster
        self._close_client = close_client
        self._executor = client.get_executor(pure=False)
        self._closed = False
        self._none_since: float | None = None  # when `stalled` first saw no worker
        self._notes = 0

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
        trouble = ""
        try:
            count = len(self.client.nthreads())
        except Exception as exc:  # the scheduler is gone or does not answer: no worker either
            count, trouble = 0, f"the Dask scheduler does not answer ({type(exc).__name__})"
        now = time.monotonic()
        if count:
            self._none_since, self._notes = None, 0
            return None
        if self._none_since is None:
            self._none_since = now
        waited = now - self._none_since
        if waited >= self.no_worker_timeout:
            if not trouble:
                address = getattr(self.client.scheduler, "address", None)
                trouble = (
                    "the local Dask cluster has lost all its workers (killed, or they could "
                    "not start again)"
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

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> cf.Future[R]:
        return self._executor.submit(fn, *args, **kwargs)

    def submit_with_timeout(
        self, timeout: float | None, fn: Callable[..., R], /, *args: Any, **kwargs: Any
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
        finally:
            try:
                if self._close_client:
                    self.client.close()
            finally:
                if self.cluster is not None:
                    self.cluster.close()

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> bool | None:
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


def _no_worker_timeout(given: float | None, default: float) -> float:
    """`DaskExecutor.no_worker_timeout`: ``given``, else `NO_WORKER_TIMEOUT_VARIABLE`, else
    ``default``; a number of seconds > 0 (``inf``: wait for ever)."""
    from ariel.errors import ConfigError

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


@contextlib.contextmanager
def _workers_ignore_sigint() -> Iterator[None]:
    """Processes started inside ignore Ctrl-C: it reaches the whole process group, and the
    driver, which catches it, closes the cluster; Dask's workers would each print a traceback.

    A process started with SIGINT ignored keeps it ignored (Python installs its KeyboardInterrupt
    handler only over the default one), and so do the processes it starts.
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # signal dispositions can only be changed from the main thread
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _make_dask(
    workers: int | None,
    address: Any,
    *,
    max_retries: int | None = None,
    blas_threads: int = 1,
    no_worker_timeout: float | None = None,
    **cluster_options: Any,
) -> DaskExecutor:
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise ImportError(_DASK_MISSING) from exc
    if address is None:
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
        limit = _no_worker_timeout(no_worker_timeout, NO_WORKER_TIMEOUT_LOCAL)  # before starting
        with _workers_ignore_sigint():
            cluster = LocalCluster(**settings)
        try:
            client = Client(cluster)
        except BaseException:
            cluster.close()
            raise
        return DaskExecutor(client, cluster=cluster, no_worker_timeout=limit)
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
    limit = _no_worker_timeout(no_worker_timeout, NO_WORKER_TIMEOUT_SCHEDULER)
    if isinstance(address, Client):  # the caller owns it
        return DaskExecutor(address, close_client=False, no_worker_timeout=limit)
    # An address such as "tcp://host:8786", or a cluster object (e.g. a SLURMCluster).
    return DaskExecutor(Client(address), no_worker_timeout=limit)


# --------------------------------------------------------------------------------------------
# entry points
# --------------------------------------------------------------------------------------------


def _check_retries(max_retries: object) -> None:
    if not isinstance(max_retries, int) or isinstance(max_retries, bool) or max_retries < 0:
        raise ValueError(f"max_retries must be an integer >= 0, got {max_retries!r}")


class ExecutorSettingsError(ValueError):
    """Bad executor settings; the message starts with the config key (``executor.workers: ...``)."""


class ExecutorKind:
    """One executor kind: how its ``[executor]`` settings are checked, how many batches it runs
    at once, and how it is built. Register a subclass under its name (the entry-point group
    ``ariel.executors``, or ``executor_kinds.register``) to add an executor: ``executor.kind``
    and ``--executor`` then accept the name (docs/executors.md).
    """

    #: Why ``executor.workers`` must be 1 (the kind runs batches in this process), or None.
    one_worker: str | None = None
    #: Whether the kind connects to a running Dask scheduler (``executor.address``).
    takes_address: bool = False

    def check(self, settings: Any) -> None:
        """Checks of this kind's own settings, before anything runs (`ExecutorSettingsError`)."""

    def planned_workers(self, settings: Any) -> tuple[int, bool]:
        """Batches run at once, and whether they run on this machine."""
        if self.one_worker is not None:
            return 1, True
        return settings.workers or default_workers(), True

    def options(self, settings: Any) -> dict[str, Any]:
        """`make`'s keyword arguments for a checked ``[executor]`` section."""
        return {"workers": settings.workers}

    def make(
        self,
        *,
        workers: int | None = None,
        address: Any = None,
        max_retries: int | None = None,
        **options: Any,
    ) -> EvaluationExecutor:
        """The executor, from `make_executor`'s checked arguments."""
        raise NotImplementedError


class SerialKind(ExecutorKind):
    """``serial``: in this process, one call after another."""

    one_worker = "the serial executor has 1 worker"

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        if workers not in (None, 1):
            raise ValueError(
                f"the serial executor runs in this process; workers must be 1, got {workers}"
            )
        if options or max_retries is not None:
            given = sorted(options) + (["max_retries"] if max_retries is not None else [])
            raise TypeError(f"the serial executor takes no options, got {given}")
        return SerialExecutor()


class LocalKind(ExecutorKind):
    """``local``: a process pool on this machine."""

    def options(self, settings: Any) -> dict[str, Any]:
        return {"workers": settings.workers, "max_retries": settings.max_retries}

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        return _make_local(workers, max_retries=max_retries, **options)


class DaskKind(ExecutorKind):
    """``dask``: a Dask ``LocalCluster``, or a scheduler you run (at ``executor.address``)."""

    takes_address = True

    def check(self, settings: Any) -> None:
        if settings.address is not None and settings.workers is not None:
            raise ExecutorSettingsError(
                "executor.workers: sizes a local cluster; with executor.address the "
                "cluster's own workers are used (scale the cluster instead)"
            )

    def planned_workers(self, settings: Any) -> tuple[int, bool]:
        return settings.workers or default_workers(), settings.address is None

    def options(self, settings: Any) -> dict[str, Any]:
        options = {"workers": settings.workers, "address": settings.address}
        if settings.address is None:
            options["max_retries"] = settings.max_retries
        return options

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        return _make_dask(workers, address, max_retries=max_retries, **options)


class GpuKind(ExecutorKind):
    """``gpu``: MuJoCo Warp on one device, in this process (docs/gpu.md)."""

    one_worker = "the gpu executor runs on one device"

    def check(self, settings: Any) -> None:
        """MuJoCo Warp must be installed and its device (``executor.device``) present."""
        from ariel.evaluation._warp import WarpUnavailableError, check_device, warp_modules

        try:
            warp_modules()
        except WarpUnavailableError as exc:
            raise ExecutorSettingsError(f"executor.kind: {exc}") from None
        try:
            check_device(settings.device)
        except WarpUnavailableError as exc:
            raise ExecutorSettingsError(
                f"executor.device: {exc}; or the CPU engine: --executor local"
            ) from None

    def options(self, settings: Any) -> dict[str, Any]:
        return {"workers": settings.workers, "device": settings.device}

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        if workers not in (None, 1):
            raise ValueError(
                f"the gpu executor runs in this process on one device; no workers (got {workers})"
            )
        return WarpExecutor(**options)


def _check_kind(obj: Any) -> str | None:
    if isinstance(obj, type) and issubclass(obj, ExecutorKind):
        return None
    return "an executor kind must be a subclass of ariel.evaluation.executors.ExecutorKind"


#: Executor kinds by name: the built-in ones and those of the entry-point group
#: ``ariel.executors`` (each an `ExecutorKind` subclass).
executor_kinds: Registry[type[ExecutorKind]] = Registry(
    "executor",
    group="ariel.executors",
    builtins={name: f"{__name__}:{kind}" for name, kind in _BUILTIN_KINDS.items()},
    label="executor kind",
    check=_check_kind,
)


def known_kinds() -> str:
    """The executor kinds' names, for messages: the built-in ones first, in their order.

    Returns:
        The names joined by ``", "``: `EXECUTOR_KINDS`, then the registered ones sorted.
    """
    extra = sorted(set(executor_kinds.names()) - set(EXECUTOR_KINDS))
    return ", ".join([*EXECUTOR_KINDS, *extra])


def executor_kind(name: str) -> ExecutorKind:
    """The `ExecutorKind` called ``name``.

    Args:
        name: An executor kind's name, built-in (`EXECUTOR_KINDS`) or registered.

    Returns:
        A new instance of that kind's class.

    Raises:
        ValueError: No kind is called ``name``; the message names the known kinds.
    """
    if not isinstance(name, str) or name not in executor_kinds:
        raise ValueError(f"unknown executor kind {name!r}; known: {known_kinds()}")
    return executor_kinds.get(name)()


def check_settings(settings: Any) -> None:
    """Check an ``[executor]`` section once, before anything runs: `ExecutorSettingsError`.

    The settings every kind shares, then the kind's own (`ExecutorKind.check`; ``gpu`` also
    needs MuJoCo Warp and its device, ``executor.device``).

    Args:
        settings: An experiment config's ``[executor]`` section
            (`ariel.evolution.ExecutorConfig`), or any object with its attributes.

    Raises:
        ExecutorSettingsError: The first bad setting; the message starts with its key
            (``executor.workers: ...``).
    """
    kind_name, workers, address = settings.kind, settings.workers, settings.address
    try:
        kind = executor_kind(kind_name)
    except ValueError:
        raise ExecutorSettingsError(
            f"executor.kind: unknown executor {kind_name!r}; known: {known_kinds()}"
        ) from None
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ExecutorSettingsError(f"executor.workers: must be an integer >= 1 (got {workers!r})")
    if kind.one_worker is not None and workers not in (None, 1):
        raise ExecutorSettingsError(f"executor.workers: {kind.one_worker} (got {workers})")
    if address is not None and not kind.takes_address:
        raise ExecutorSettingsError(
            f"executor.address: only for the dask executor, not {kind_name!r}"
        )
    kind.check(settings)


def planned_workers(settings: Any) -> tuple[int, bool]:
    """Batches an ``[executor]`` section will run at once, and whether they run on this
    machine (for a memory estimate before anything starts).

    Args:
        settings: An experiment config's ``[executor]`` section
            (`ariel.evolution.ExecutorConfig`), or any object with its attributes.

    Returns:
        ``(batches, local)``: how many batches run at once (of the built-in kinds: 1 for
        ``serial`` and ``gpu``, ``workers`` or else one per usable CPU for ``local`` and
        ``dask``), and whether they run on this machine (False for ``dask`` with an
        ``address``).

    Raises:
        ValueError: ``settings.kind`` names no executor kind.
    """
    return executor_kind(settings.kind).planned_workers(settings)


def settings_options(settings: Any) -> dict[str, Any]:
    """`make_executor`'s keyword arguments for an ``[executor]`` section (checked first).

    Args:
        settings: An experiment config's ``[executor]`` section
            (`ariel.evolution.ExecutorConfig`), or any object with its attributes.

    Returns:
        The keyword arguments, ``kind`` not included (`ExecutorKind.options` of the kind):
        ``workers`` always, and per kind ``max_retries``, ``address`` or ``device``.

    Raises:
        ExecutorSettingsError: A bad setting (`check_settings`).
    """
    check_settings(settings)
    return executor_kind(settings.kind).options(settings)


@accept_aliases(scheduler="address")
def make_executor(
    kind: Any = "local",
    *,
    workers: int | None = None,
    address: Any = None,
    max_retries: int | None = None,
    **options: Any,
) -> EvaluationExecutor:
    """A `concurrent.futures.Executor` of ``kind`` (use it as a context manager), which is
    also a `BatchExecutor` (``capacity``, ``submit_batch``): an `EvaluationExecutor`.

    Args:
        kind: ``"serial"``, ``"local"``, ``"dask"`` or ``"gpu"`` (options ``device``:
            ``"cuda"`` or ``"cpu"``, and ``max_worlds``; see `WarpExecutor`), or a kind
            registered in `executor_kinds`; or an experiment config's ``[executor]`` section
            (``kind``, ``workers``, ``address``, ``device``, ``max_retries``; checked with
            `check_settings`).
        workers: processes for ``local`` and for a Dask ``LocalCluster`` (default: one per
            usable CPU); ``serial`` accepts only 1.
        address: ``dask`` only: a running Dask scheduler's address like
            ``"tcp://host:8786"``, a cluster object (e.g. dask-jobqueue's ``SLURMCluster``)
            or a ``distributed.Client``. Without it a ``LocalCluster`` is started, and closed
            again on shutdown. ``scheduler=`` is its old name, still accepted.
        max_retries: ``local`` and a Dask ``LocalCluster``: how many times a call is tried
            again after the worker process running it died (default `DEFAULT_MAX_RETRIES`
            for ``local``, Dask's ``allowed-failures`` setting for Dask); then its future
            fails (`WorkerLostError`, Dask's ``KilledWorker``). Not for ``serial`` (it runs here).
        **options: ``blas_threads`` (default 1, for ``local`` and ``dask``); for ``local`` also
            ``mp_context``, ``initializer``, ``initargs``, ``max_tasks_per_child``; for
            ``dask`` ``no_worker_timeout`` (seconds with no worker before a run stops, see
            `NO_WORKER_TIMEOUT_LOCAL`), and for a Dask ``LocalCluster`` any of its keyword
            arguments.

    Returns:
        The executor (``local`` starts its workers on demand, ``dask`` its ``LocalCluster``
        at once); shut it down, or leave its ``with`` block, to stop what it started.

    Raises:
        ValueError: An unknown ``kind``, ``workers`` that is not an integer >= 1 (or not 1
            for ``serial`` and ``gpu``), or ``address`` for a kind other than ``dask``.
        TypeError: Options the kind does not take, or both ``address`` and ``scheduler``.
        ExecutorSettingsError: A bad setting in a config's ``[executor]`` section.
        ImportError: ``dask`` without the ``distributed`` extra installed.

    Example:
        ```python
        import numpy as np

        from ariel.evaluation import BodySpec, EvaluationTask, make_executor

        if __name__ == "__main__":  # workers import this script: run only in the main process
            body = BodySpec("prebuilt", "gecko")
            brains = np.random.default_rng(0).uniform(-1.0, 1.0, (4, 40))  # na_cpg, 8 joints
            tasks = [EvaluationTask(body=body, params=p, duration=2.0) for p in brains]
            with make_executor("local", workers=2) as executor:
                results = executor.submit_batch(tasks).result()
            print([round(r.fitness, 3) for r in results])
        ```
    """
    if not isinstance(kind, str):  # a config's [executor] section
        return make_executor(kind.kind, **settings_options(kind))
    executor = executor_kind(kind)
    if workers is not None and not _is_count(workers):
        raise ValueError(f"workers must be an integer >= 1 or None, got {workers!r}")
    if address is not None and not executor.takes_address:
        raise ValueError(f"address= is only for the dask executor, not {kind!r}")
    return executor.make(workers=workers, address=address, max_retries=max_retries, **options)


def submit_with_timeout(
    executor: cf.Executor, timeout: float | None, fn: Callable[..., R], /, *args: Any
) -> cf.Future[R]:
    """``executor.submit(fn, *args)`` with a wall-clock limit where the executor has one.

    ``local``: past ``timeout`` seconds (from the call's start in a worker) the worker is killed
    and replaced, and the future fails with `CallTimeoutError`. ``dask``: the same exception, but
    the call goes on in its worker's thread until it ends. ``serial`` (and any other executor):
    no limit, the call runs as it would.

    Args:
        executor: Any `concurrent.futures.Executor`; the limit applies where it has a
            ``submit_with_timeout`` method (``local``, ``dask``).
        timeout: The limit in seconds, > 0; None: no limit.
        fn: The function to call (for a process pool or Dask, a top-level function).
        *args: Positional arguments ``fn`` is called with.

    Returns:
        The call's future: its result, its exception, or `CallTimeoutError`.

    Raises:
        ValueError: ``timeout`` is not None and not > 0.
    """
    if timeout is not None and not timeout > 0:
        raise ValueError(f"timeout must be > 0 seconds or None, got {timeout!r}")
    method = getattr(executor, "submit_with_timeout", None)
    if method is None:
        return executor.submit(fn, *args)
    return method(timeout, fn, *args)


def worker_fault(exc: BaseException) -> str | None:
    """One line on how a call was lost to its worker (died too often, or timed out), or None.

    Knows `WorkerLostError` and `CallTimeoutError` (``local``, and the soft timeout on Dask) and
    Dask's ``KilledWorker``; any other exception is the call's own and gives None.

    Args:
        exc: The exception a call's future raised.

    Returns:
        ``"timeout: ..."`` or ``"worker lost: ..."``; None for an exception raised by the
        call itself.
    """
    if isinstance(exc, CallTimeoutError):
        return f"timeout: {exc}"
    if isinstance(exc, WorkerLostError):
        return f"worker lost: {exc}"
    if type(exc).__name__ == "KilledWorker" and type(exc).__module__.startswith("distributed"):
        # Dask's own text names a task key and a worker address: not the same in two runs.
        tries = getattr(exc, "allowed_failures", None)
        if not isinstance(tries, int):
            times = "too often"
        else:
            times = "once" if tries == 0 else f"{tries + 1} times"
        return f"worker lost: Dask workers died {times} running this call (KilledWorker)"
    return None


def _check_shippable(fn: Callable[..., Any]) -> None:
    target = fn.func if isinstance(fn, functools.partial) else fn
    qualname = getattr(target, "__qualname__", "")
    if "<lambda>" in qualname or "<locals>" in qualname:
        raise TypeError(
            f"{qualname} cannot be sent to workers: pass a top-level function (workers import "
            "it by name) that takes plain data"
        )


def map_ordered(
    executor: cf.Executor,
    fn: Callable[[Any], R],
    items: Iterable[Any],
    *,
    progress: bool = False,
    desc: str | None = None,
) -> Iterator[R]:
    """Submit ``fn(item)`` for every item now; iterate over the results in input order.

    A failed call raises its exception when its turn comes; the calls not yet started are
    then cancelled (also when the iteration is abandoned).

    Args:
        executor: Where the calls run, e.g. one from `make_executor`.
        fn: A top-level function of one argument (workers import it by name).
        items: The arguments, one call each; all are submitted at once.
        progress: Show a tqdm bar that counts finished calls, in any order.
        desc: The bar's label; None: no label.

    Returns:
        An iterator over the results, in the order of ``items``.

    Raises:
        TypeError: ``fn`` is a lambda or a function defined inside another (workers cannot
            import it).

    Example:
        ```python
        import math

        from ariel.evaluation import make_executor, map_ordered

        with make_executor("serial") as executor:
            print(list(map_ordered(executor, math.sqrt, [1, 4, 9])))  # [1.0, 2.0, 3.0]
        ```
    """
    _check_shippable(fn)
    futures = [executor.submit(fn, item) for item in items]
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(futures), desc=desc, unit="task")
        for future in futures:
            future.add_done_callback(lambda _future: bar.update(1))

    def results() -> Iterator[R]:
        try:
            for future in futures:
                yield future.result()
        finally:
            for future in futures:
                future.cancel()
            if bar is not None:
                bar.close()

    return results()
