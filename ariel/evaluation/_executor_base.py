"""What every executor is, and what the built-in ones share.

`BatchExecutor` (the scheduler's view of an executor: its capacity and how it evaluates a batch),
`EvaluationExecutor` (that and a `concurrent.futures.Executor`), the ``serial`` executor
(`SerialExecutor`), `submit_with_timeout`, and `worker_environment`: the variables every worker
process of ``local`` and of a Dask ``LocalCluster`` starts with. Re-exported by
`ariel.evaluation.executors`.
"""

from __future__ import annotations

import concurrent.futures as cf
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, ParamSpec, TypeVar, TypeVarTuple

import ariel.evaluation
from ariel.evaluation._threads import EVAL_THREADS_VARIABLE, THREAD_LIMIT_VARIABLES, default_workers

if TYPE_CHECKING:
    from ariel.evaluation._task import EvaluationResult, EvaluationTask

__all__ = [
    "BatchExecutor",
    "EvaluationExecutor",
    "SerialExecutor",
    "submit_with_timeout",
    "worker_environment",
]

R = TypeVar("R")
P = ParamSpec("P")
Ts = TypeVarTuple("Ts")


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
    evaluates a batch, so nothing outside the executors branches on kind names.
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

    def submit_batch(
        self, tasks: list[EvaluationTask], *, timeout: float | None = None
    ) -> cf.Future[list[EvaluationResult]]:
        """Evaluate ``tasks`` (`ariel.evaluation.evaluate_batch`) within ``timeout`` seconds
        where the executor can stop a call (`submit_with_timeout`)."""
        batch = ariel.evaluation.evaluate_batch  # looked up when called (a test may wrap it)
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

    def submit(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> cf.Future[R]:
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


def submit_with_timeout(
    executor: cf.Executor, timeout: float | None, fn: Callable[[*Ts], R], /, *args: *Ts
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
