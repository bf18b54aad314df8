"""The ``gpu`` executor: brain batches queued, then evaluated together on MuJoCo Warp.

`WarpExecutor` runs in this process: a thread of its own hands everything the scheduler
queued to one `ariel.evaluation._warp.WarpEvaluator` call (docs/gpu.md). Re-exported by
`ariel.evaluation.executors`.
"""

from __future__ import annotations

import concurrent.futures as cf
import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar, cast

from ariel import evaluation
from ariel.evaluation._executor_base import SerialExecutor

if TYPE_CHECKING:
    from ariel.evaluation._task import EvaluationResult, EvaluationTask

    # A queued batch: its tasks and the future of their results.
    _Batch = tuple[list[EvaluationTask], cf.Future[list[EvaluationResult]]]

__all__ = ["WarpExecutor"]

R = TypeVar("R")
P = ParamSpec("P")

#: Seconds `WarpExecutor.shutdown` waits for the device thread before it says it is waiting (a
#: Ctrl-C during a kernel compilation or a batch waited up to a minute without a word).
WAIT_NOTE_S = 1.0


class _QueuedFuture(cf.Future):  # type: ignore[type-arg]
    """A future whose batch waits in a queue: asking for its result dispatches the queue."""

    def __init__(self, dispatch: Callable[[], None]) -> None:
        super().__init__()
        self._dispatch = dispatch

    def result(self, timeout: float | None = None) -> list[EvaluationResult]:
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
        # The evaluator imports no Warp until it is made, but MuJoCo (the engine) at once: it is
        # reached here, at call time (executors stay MuJoCo-free: the CLI imports them before
        # choosing a GL backend).
        super().__init__()
        self.evaluator = evaluation.WarpEvaluator(device, max_worlds=max_worlds)
        self._queued: list[_Batch] = []
        self._ready: list[_Batch] = []
        self._wake = threading.Condition()
        self._thread: threading.Thread | None = None

    @property
    def device(self) -> str:
        return self.evaluator.device

    def submit(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> cf.Future[R]:
        """``submit(evaluate_batch, tasks)`` runs on the device, as `submit_batch` (it ran on
        the CPU engine, while docs/gpu.md's example said Warp); any other call runs here, as in
        `SerialExecutor`."""
        given: list[Any] = [*args, *kwargs.values()]  # (a copy: len(args) narrows P.args)
        if fn is evaluation.evaluate_batch and len(given) == 1 and set(kwargs) <= {"tasks"}:
            return cast("cf.Future[R]", self.submit_batch(list(given[0])))
        return super().submit(fn, *args, **kwargs)

    def submit_batch(
        self, tasks: list[EvaluationTask], *, timeout: float | None = None
    ) -> cf.Future[list[EvaluationResult]]:
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

    def _run(self, taken: list[_Batch]) -> None:
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
            self._thread.join(timeout=WAIT_NOTE_S)
            if self._thread.is_alive():  # a device call cannot be stopped midway: say so
                print(
                    "waiting for the device to finish its current call (a kernel compilation "
                    "or a batch cannot be stopped midway)",
                    file=sys.stderr,
                    flush=True,
                )
                self._thread.join()

    def __repr__(self) -> str:
        return f"WarpExecutor(device={self.device!r})"
