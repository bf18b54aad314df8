"""The scheduler: moves evaluation tasks to an executor and results back, nothing else.

Work comes in groups (one per run: a generation's brain runs); every piece of work hands out
one batch of tasks at a time and gets that batch's results back, and all pieces of all groups
progress side by side, so every worker stays busy: a piece asks for its next batch as soon as
its previous one returned. A batch is cut into chunks, about one per free worker, so a few
big batches still fill a large pool. A chunk lost to its worker (it died too often, or timed
out, or raised) is tried again one task at a time, so only the task that keeps failing fails:
lost to its worker, it gets an ``error`` result with the worst fitness and the reason; raising
(a plugin's fault), it stops the run with the error its work makes of it.

An executor that can tell that it will never give results (a Dask cluster with no worker left,
`BatchExecutor.stalled`) is asked every ``watch_seconds`` while results are awaited; on its
reason the run stops (`ariel.utils.interrupts.Stopped`: as an interrupt, resumable; the line
names the generation that the pieces of work in flight give as ``generation``, if any). A pool
that broke as a whole (``BrokenExecutor``: its workers cannot be started) stops the run with
the error its work makes of it, without trying its tasks one by one.

A group is a generator: it yields a list of work, the scheduler runs that work to the end,
and the generator goes on (writes the generation, makes the next one) and yields the next
list, until it returns. Nothing here knows what a body, a brain or a generation is; the order
in which results arrive changes nothing, since each piece changes only through its own results.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from threadpoolctl import threadpool_limits

from ariel import evaluation
from ariel.evaluation.executors import worker_fault
from ariel.utils.interrupts import Stopped, raise_pending

if TYPE_CHECKING:
    from ariel.evaluation import EvaluationResult, EvaluationTask
    from ariel.evaluation.executors import BatchExecutor
    from ariel.evolution._config import ExecutorConfig

__all__ = ["Scheduler", "Work", "run_groups"]


class Work(Protocol):
    """A piece of work: batches of evaluation tasks, one at a time."""

    def next_batch(self) -> list[EvaluationTask] | None:
        """The next batch of tasks, or None when the work is done."""
        ...

    def batch_done(self, results: list[EvaluationResult]) -> None:
        """The results of the last batch, in task order."""
        ...

    def failed_result(self, task: EvaluationTask, reason: str) -> EvaluationResult:
        """The result of a task lost to its worker (``error``, the worst fitness)."""
        ...

    def task_error(self, task: EvaluationTask, exc: BaseException) -> BaseException:
        """The error to stop the run with: ``task``'s evaluation raised ``exc`` (a plugin)."""
        ...

    def flush(self) -> None:
        """Called once the work's next batch is on its way (a time to write records)."""
        ...


@dataclass
class _Batch:
    work: Work
    group: int
    tasks: list[EvaluationTask]
    # Any: each task's `EvaluationResult`, None until it came back (all are in when left == 0)
    results: list[Any] = field(default_factory=list)
    left: int = 0


class Scheduler:
    """Runs groups of `Work` side by side on one executor (``capacity``, ``submit_batch``)."""

    def __init__(self, executor: BatchExecutor, *, timeout: float | None) -> None:
        self.executor = executor
        self.timeout = timeout
        self._in_flight: dict[cf.Future, tuple[_Batch, np.ndarray]] = {}
        self._working: dict[int, int] = {}  # group -> pieces of work not done yet

    def run(self, groups: Sequence[Iterator[Sequence[Work]]]) -> None:
        """Run every group to its end (see the module docstring)."""
        groups = list(groups)
        watch = getattr(self.executor, "watch_seconds", None)
        checked = time.monotonic()
        try:
            for index in range(len(groups)):
                self._advance(groups, index)
            while self._in_flight:
                raise_pending()  # a Ctrl-C whose KeyboardInterrupt got lost: ariel.utils.interrupts
                self._dispatch()
                done, _ = cf.wait(
                    list(self._in_flight), timeout=watch, return_when=cf.FIRST_COMPLETED
                )
                raise_pending()
                if watch is not None and time.monotonic() - checked >= watch:
                    self._check_stalled()
                    checked = time.monotonic()
                finished = []
                for future in done:
                    batch, part = self._in_flight.pop(future)
                    if self._collect(batch, part, future):
                        finished.append(batch)
                self._finish(groups, finished)
        except BaseException:
            for future in self._in_flight:
                future.cancel()
            self._in_flight.clear()
            raise

    def _check_stalled(self) -> None:
        """Stop the run (`Stopped`) when the executor says it will give no more results."""
        reason = self.executor.stalled()
        if reason:
            self._stop(reason)

    def _stop(self, reason: str) -> None:
        """Stop the run (`Stopped`): ``reason`` and the generations it stopped at."""
        generations = sorted(
            {
                generation
                for batch, _ in self._in_flight.values()
                if isinstance(generation := getattr(batch.work, "generation", None), int)
            }
        )
        if len(generations) == 1:
            reason += f"; the run stopped at generation {generations[0]}"
        elif generations:
            reason += f"; the runs stopped at generations {generations[0]} to {generations[-1]}"
        raise Stopped(reason)

    # -- groups and work -----------------------------------------------------------------------

    def _advance(self, groups: list[Iterator[Sequence[Work]]], index: int) -> None:
        """Take the group's next list of work and start it (again while a list is empty)."""
        while True:
            try:
                works = next(groups[index])
            except StopIteration:
                self._working.pop(index, None)
                return
            self._working[index] = len(works)
            for work in works:
                if not self._launch(work, index):
                    self._working[index] -= 1
            if self._working[index]:
                return

    def _launch(self, work: Work, group: int) -> bool:
        """Send the work's next batch; False when it has none (it is done)."""
        tasks = work.next_batch()
        if tasks is None:
            return False
        batch = _Batch(work, group, list(tasks), [None] * len(tasks))
        busy = sum(self._working.values()) or 1
        chunks = max(1, min(len(tasks), math.ceil(self.executor.capacity / busy)))
        batch.left = chunks
        for part in np.array_split(np.arange(len(tasks)), chunks):
            self._send(batch, part)
        return True

    def _finish(self, groups: list[Iterator[Sequence[Work]]], finished: list[_Batch]) -> None:
        """Hand each finished batch to its work and send the work's next batch; only then
        write their records (`Work.flush`), so the executor steps the next batches meanwhile.
        """
        relaunched = []
        for batch in finished:
            batch.work.batch_done(batch.results)
            relaunched.append(self._launch(batch.work, batch.group))
        if any(relaunched):
            self._dispatch()
        for batch, again in zip(finished, relaunched):
            if not again:
                self._working[batch.group] -= 1
            batch.work.flush()
            if self._working.get(batch.group) == 0:
                self._advance(groups, batch.group)

    def _dispatch(self) -> None:
        dispatch = getattr(self.executor, "dispatch", None)
        if dispatch is not None:  # an executor that gathers batches starts them now
            dispatch()

    # -- chunks --------------------------------------------------------------------------------

    def _send(self, batch: _Batch, part: np.ndarray) -> None:
        chunk = [batch.tasks[i] for i in part]
        # A call of k evaluations may take k times one evaluation's timeout.
        timeout = None if self.timeout is None else self.timeout * len(chunk)
        try:
            future = self.executor.submit_batch(chunk, timeout=timeout)
        except cf.BrokenExecutor as exc:  # the pool broke (e.g. no worker can start)
            raise batch.work.task_error(chunk[0], exc) from exc
        self._in_flight[future] = (batch, part)

    def _collect(self, batch: _Batch, part: np.ndarray, future: cf.Future) -> bool:
        """Store a chunk's results; True when the batch is complete."""
        try:
            results = future.result()
        except cf.BrokenExecutor as exc:  # the pool, not this chunk: one at a time cannot help
            raise batch.work.task_error(batch.tasks[part[0]], exc) from exc
        except cf.CancelledError:  # not by this scheduler: its executor went (a Dask client
            # closed once its scheduler was gone), which no plugin did
            stalled = getattr(self.executor, "stalled", lambda: None)()
            self._stop(
                stalled or "the executor cancelled the run's evaluations (its cluster is gone)"
            )
        except Exception as exc:
            if len(part) > 1:  # one at a time: the bad one fails, the rest finish
                batch.left += len(part) - 1
                for i in part:
                    self._send(batch, np.array([i]))
                return False
            reason = worker_fault(exc)  # its worker died too often, or a timeout
            if reason is None:  # the evaluation itself raised: a plugin failed
                raise batch.work.task_error(batch.tasks[part[0]], exc) from exc
            results = [batch.work.failed_result(batch.tasks[part[0]], reason)]
        for i, result in zip(part, results):
            batch.results[i] = result
        batch.left -= 1
        return batch.left == 0


def run_groups(
    groups: Sequence[Iterator[Sequence[Work]]], executor_settings: ExecutorConfig
) -> int:
    """Run ``groups`` to their ends on the executor ``executor_settings`` (a config's
    ``[executor]``) describes; returns its capacity (workers) as the run ended."""
    # BLAS in this process (pycma's eigendecompositions) stays on one thread. The executor's
    # maker is looked up when called (`evaluation.make_executor`: a test may replace it).
    with threadpool_limits(limits=1), evaluation.make_executor(executor_settings) as executor:
        Scheduler(executor, timeout=executor_settings.timeout).run(groups)
        return int(executor.capacity)
