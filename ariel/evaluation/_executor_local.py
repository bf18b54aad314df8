"""The ``local`` executor: a process pool on this machine that survives workers dying or hanging.

`LocalPool` is the pool as a `concurrent.futures.Executor` (its driver thread:
`ariel.evaluation._pool`; a worker process: `ariel.evaluation._pool_worker`), `LocalExecutor`
the pool as an evaluation executor, made by `_make_local` with each worker's thread limits.
Re-exported by `ariel.evaluation.executors`.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import pickle
import signal
import sys
import weakref
from collections.abc import Callable, Mapping
from types import TracebackType
from typing import ParamSpec, TypeVar

from ariel.evaluation._executor_base import EvaluationExecutor, worker_environment
from ariel.evaluation._pool import _Driver
from ariel.evaluation._pool_worker import _Call
from ariel.evaluation._threads import default_workers

__all__ = ["DEFAULT_MAX_RETRIES", "LocalExecutor", "LocalPool"]

R = TypeVar("R")
P = ParamSpec("P")

#: Times a call is tried again after its worker died (``local``; a Dask ``LocalCluster``).
DEFAULT_MAX_RETRIES = 2


class LocalPool(cf.Executor):
    """A process pool that survives workers dying or hanging (see the module docstring).

    Args:
        max_workers: worker processes at most (started on demand).
        mp_context: the multiprocessing context that starts them (never use fork if the
            calling process runs threads).
        worker_env: variables every worker process is started with.
        initializer: run once in every worker before its first call, with ``initargs``; if it
            raises, the pool is broken (every future fails with ``BrokenProcessPool``). None:
            nothing is run.
        initargs: the positional arguments ``initializer`` is called with.
        max_tasks_per_child: a worker exits after this many calls (a fresh one replaces it).
        max_retries: how many times a call whose worker died is tried again.
    """

    def __init__(
        self,
        max_workers: int,
        *,
        mp_context: multiprocessing.context.BaseContext,
        worker_env: Mapping[str, str] | None = None,
        initializer: Callable[..., object] | None = None,
        initargs: tuple[object, ...] = (),
        max_tasks_per_child: int | None = None,
        max_retries: int = 2,
    ) -> None:
        if not isinstance(max_workers, int) or isinstance(max_workers, bool) or max_workers < 1:
            raise ValueError(f"max_workers must be an integer >= 1, got {max_workers!r}")
        if not isinstance(max_retries, int) or isinstance(max_retries, bool) or max_retries < 0:
            raise ValueError(f"max_retries must be an integer >= 0, got {max_retries!r}")
        if max_tasks_per_child is not None and (
            not isinstance(max_tasks_per_child, int) or max_tasks_per_child < 1
        ):
            raise ValueError(
                f"max_tasks_per_child must be an integer >= 1 or None, got {max_tasks_per_child!r}"
            )
        self._max_workers = max_workers
        self.max_retries = max_retries
        self._driver = _Driver(
            max_workers,
            mp_context,
            worker_env or {},
            initializer,
            tuple(initargs),
            max_tasks_per_child,
            max_retries,
        )
        self._started = False
        # Dropped without shutdown, or still open at exit: stop the workers, do not hang.
        self._finalizer = weakref.finalize(
            self, self._driver.stop, cancel=True, kill=True, wait=True
        )

    @property
    def max_workers(self) -> int:
        return self._max_workers

    def submit(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> cf.Future[R]:
        return self._submit(None, fn, args, kwargs)

    def submit_with_timeout(
        self, timeout: float | None, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs
    ) -> cf.Future[R]:
        """`submit` with a wall-clock limit in seconds, counted from the call's start in a worker
        (after its function and arguments are unpickled). Past it the worker is killed and
        replaced, and the future fails with `CallTimeoutError`. None: no limit."""
        if timeout is not None and not timeout > 0:
            raise ValueError(f"timeout must be > 0 seconds or None, got {timeout!r}")
        return self._submit(timeout, fn, args, kwargs)

    def _submit(
        self, timeout: float | None, fn: Callable[..., R], args: tuple, kwargs: dict
    ) -> cf.Future[R]:
        driver = self._driver
        future: cf.Future[R] = cf.Future()
        try:
            payload = pickle.dumps((fn, args, kwargs))
        except Exception as exc:  # as a pool does: the error is the future's, not submit's
            future.set_running_or_notify_cancel()
            future.set_exception(exc)
            return future
        with driver.lock:
            if driver.broken is not None:
                raise driver.broken_error(driver.broken)
            if driver.shutting_down:
                raise RuntimeError("cannot schedule new futures after shutdown")
            driver.pending.append(_Call(future, payload, timeout))
            if not self._started:
                self._started = True
                driver.thread.start()
        driver.wake()
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._stop(cancel=cancel_futures, kill=False, wait=wait)

    def _stop(self, *, cancel: bool, kill: bool, wait: bool) -> None:
        """No new calls from here on; the driver, if it ever started, stops (`_Driver.stop`)."""
        self._finalizer.detach()  # from here on the driver stops once its work is done
        with self._driver.lock:
            started = self._started
            self._driver.shutting_down = True
        if started:
            self._driver.stop(cancel=cancel, kill=kill, wait=wait)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> bool | None:
        if exc_type is not None and not issubclass(exc_type, Exception):
            # Ctrl-C, SIGTERM (`KeyboardInterrupt`), SystemExit: stop now, do not wait for the
            # running calls (minutes, up to their timeout).
            self._stop(cancel=True, kill=True, wait=True)
            return None
        return super().__exit__(exc_type, exc, tb)

    def __repr__(self) -> str:
        return f"LocalPool(max_workers={self._max_workers}, max_retries={self.max_retries})"


def _limit_loaded_thread_pools(threads: int) -> None:
    """Cap thread pools of libraries imported before the initializer ran (e.g. by __main__)."""
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(threads)
    if "numpy" in sys.modules:
        try:
            from threadpoolctl import threadpool_limits  # lazy: slow; only in workers, as needed
        except ImportError:  # optional: without it, only the environment limits BLAS
            return
        threadpool_limits(limits=threads)


def _initialize_worker(
    env: dict[str, str],
    threads: int,
    initializer: Callable[..., object] | None,
    initargs: tuple[object, ...],
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
    initargs: tuple[object, ...] = (),
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
