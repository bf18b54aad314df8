"""The scheduler on its own: work of several groups side by side, batches cut into chunks,
results back in task order whatever order they arrive in, lost chunks retried one by one."""

from __future__ import annotations

import concurrent.futures as cf
import gc
import os
import random
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from ariel.evaluation.executors import WorkerLostError
from ariel.evolution._scheduler import Scheduler
from ariel.utils.interrupts import Interrupted, raise_pending, stop_on_signals


class FakeExecutor:
    """Squares numbers in threads, after a random delay: results arrive in any order."""

    def __init__(self, capacity: int, seed: int = 0, lose: set[int] | None = None) -> None:
        self.capacity = capacity
        self.pool = cf.ThreadPoolExecutor(max_workers=capacity)
        self.rng = random.Random(seed)
        self.lose = lose or set()  # tasks whose chunk is lost while it holds more than one
        self.chunks: list[list[int]] = []
        self.in_flight: set[str] = set()
        self.groups_together = 0  # chunks sent while another group's chunk was in flight
        self.lock = threading.Lock()

    def submit_batch(self, tasks: list[Any], *, timeout: float | None = None) -> cf.Future:
        self.chunks.append([task for _, task in tasks])
        groups = {group for group, _ in tasks}
        with self.lock:
            if self.in_flight - groups:
                self.groups_together += 1
            self.in_flight |= groups
        delay = self.rng.random() * 0.01

        def run() -> list[int]:
            time.sleep(delay)
            with self.lock:
                self.in_flight -= groups
            if len(tasks) > 1 and self.lose & {task for _, task in tasks}:
                raise WorkerLostError("the worker died")
            if len(tasks) == 1 and tasks[0][1] in self.lose:
                raise WorkerLostError("the worker died again")
            return [task * task for _, task in tasks]

        return self.pool.submit(run)


class Counting:
    """Work of ``batches`` batches of ``size`` numbers; keeps what came back."""

    def __init__(self, group: str, start: int, batches: int, size: int) -> None:
        self.group, self.start, self.left, self.size = group, start, batches, size
        self.sent: list[list[int]] = []
        self.received: list[list[Any]] = []
        self.flushed = 0

    def next_batch(self) -> list[Any] | None:
        if not self.left:
            return None
        self.left -= 1
        first = self.start + len(self.sent) * self.size
        self.sent.append(list(range(first, first + self.size)))
        return [(self.group, n) for n in self.sent[-1]]

    def batch_done(self, results: list[Any]) -> None:
        self.received.append(results)

    def failed_result(self, task: Any, reason: str) -> Any:
        return f"error: {reason}"

    def flush(self) -> None:
        self.flushed += 1


def group(name: str, lists: list[list[Counting]], log: list[str]):
    for index, works in enumerate(lists):
        log.append(f"{name} starts {index}")
        yield works
        log.append(f"{name} ends {index}")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_group_runs_to_its_end_with_results_in_task_order(seed: int) -> None:
    executor = FakeExecutor(capacity=3, seed=seed)
    a = [[Counting("a", 0, 3, 4), Counting("a", 100, 2, 5)], [Counting("a", 200, 1, 3)]]
    b = [[Counting("b", 1000, 4, 2)], [], [Counting("b", 2000, 2, 2)]]
    log: list[str] = []
    Scheduler(executor, timeout=None).run([group("a", a, log), group("b", b, log)])
    for work in [w for lists in a + b for w in lists]:
        assert work.left == 0
        assert work.received == [[n * n for n in sent] for sent in work.sent]
        assert work.flushed == len(work.sent)
    # each group's lists one after the other, the empty one skipped at once
    assert [line for line in log if line.startswith("b")] == [
        "b starts 0",
        "b ends 0",
        "b starts 1",
        "b ends 1",
        "b starts 2",
        "b ends 2",
    ]
    assert executor.groups_together > 0  # the two runs' work shared the executor


def test_a_batch_is_cut_into_chunks_for_idle_workers() -> None:
    executor = FakeExecutor(capacity=4)
    work = Counting("a", 0, 1, 8)
    Scheduler(executor, timeout=None).run([group("a", [[work]], [])])
    assert sorted(len(chunk) for chunk in executor.chunks) == [2, 2, 2, 2]
    assert work.received == [[n * n for n in range(8)]]


def test_a_lost_chunk_is_retried_one_task_at_a_time() -> None:
    executor = FakeExecutor(capacity=2, lose={5})
    work = Counting("a", 0, 1, 8)
    Scheduler(executor, timeout=None).run([group("a", [[work]], [])])
    (results,) = work.received
    assert results[5] == "error: worker lost: the worker died again"
    assert [r for i, r in enumerate(results) if i != 5] == [n * n for n in range(8) if n != 5]


def test_an_error_of_the_work_itself_stops_the_run() -> None:
    class Broken(Counting):
        def batch_done(self, results: list[Any]) -> None:
            raise RuntimeError("broken bookkeeping")

    with pytest.raises(RuntimeError, match="broken bookkeeping"):
        Scheduler(FakeExecutor(2), timeout=None).run([group("a", [[Broken("a", 0, 2, 2)]], [])])


def _lose_a_ctrl_c() -> bool:
    """Ctrl-C while a garbage-collection callback runs (Dask registers one): Python prints
    "Exception ignored" and goes on. True when it went on, as it does."""

    def callback(phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            os.kill(os.getpid(), signal.SIGINT)
            sum(range(1000))  # Python code: the handler runs here, its exception is ignored

    gc.callbacks.append(callback)
    try:
        gc.collect()
    finally:
        gc.callbacks.remove(callback)
    return True


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # the lost one
def test_a_ctrl_c_whose_keyboard_interrupt_got_lost_still_stops_the_run() -> None:
    class Interrupting(Counting):
        def batch_done(self, results: list[Any]) -> None:
            super().batch_done(results)
            if len(self.received) == 1:
                self.went_on = _lose_a_ctrl_c()

    work = Interrupting("a", 0, 5, 2)
    with stop_on_signals(), pytest.raises(Interrupted) as stopped:
        Scheduler(FakeExecutor(1), timeout=None).run([group("a", [[work]], [])])
    assert work.went_on  # the KeyboardInterrupt itself never reached the scheduler
    assert stopped.value.signum == signal.SIGINT
    assert len(work.received) == 1 and work.left == 3  # stopped at the next result
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # put back
    raise_pending()  # leaving the block forgot the signal: nothing to raise now


def test_a_signal_taken_inside_rerun_s_writer_is_an_interrupt(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """SIGTERM during run.rrd's write came out of Rerun as "RuntimeError: Interrupted: 15": a
    traceback and a run marked failed, not the one line saying how to resume it (probe G3)."""
    from ariel.recording.rerun import _rerun
    from ariel.utils import interrupts

    class Stream:
        @staticmethod
        def from_iter(chunks: Any) -> Any:
            return Stream()

        def write_rrd(self, *args: Any, **kwargs: Any) -> None:
            interrupts._pending = signal.SIGTERM  # the handler ran inside the writer
            raise RuntimeError("Interrupted: 15")

    rr = type("rr", (), {"chunk": type("chunk", (), {"LazyChunkStream": Stream})})
    monkeypatch.setattr(_rerun, "rerun_module", lambda: rr)
    monkeypatch.setattr(interrupts, "_pending", None)
    with pytest.raises(Interrupted) as stopped:
        _rerun._write_chunks(tmp_path / "run.rrd", "r", [], fsync=False)
    assert stopped.value.signum == signal.SIGTERM
    assert not (tmp_path / "run.rrd").exists()


def test_evaluations_its_executor_cancelled_stop_the_run_not_a_plugin() -> None:
    """A Dask client closed once its scheduler was gone cancels every future: each read as a
    plugin's CancelledError ("fix the plugin", status failed) (probe R9)."""
    from ariel.utils.interrupts import Stopped

    class Cancelling(FakeExecutor):
        def submit_batch(self, tasks: list[Any], *, timeout: float | None = None) -> cf.Future:
            future: cf.Future = cf.Future()
            future.cancel()
            future.set_running_or_notify_cancel()  # as an executor does for those it cancels
            return future

        def stalled(self) -> str:
            return "the Dask scheduler tcp://h:1 is gone (its client stopped reconnecting)"

    work = Counting("a", 0, 2, 2)
    with pytest.raises(Stopped) as stopped:
        Scheduler(Cancelling(1), timeout=None).run([group("a", [[work]], [])])
    assert stopped.value.reason.startswith("the Dask scheduler tcp://h:1 is gone")
