"""Workers that die or hang: the local pool retries or stops just that call; Dask's faults map
to the same outcomes; a local Dask cluster listens on the loopback interface only."""

from __future__ import annotations

import concurrent.futures as cf
import importlib.util
import os
import time
from pathlib import Path

import pytest

from ariel.evaluation import _selftest
from ariel.evaluation.executors import (
    CallTimeoutError,
    LocalPool,
    WorkerLostError,
    make_executor,
    submit_with_timeout,
    worker_fault,
)

needs_dask = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="dask.distributed is not installed (pip install 'ariel[distributed]')",
)


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    # A zombie still answers: ask /proc where there is one.
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"
    except OSError:
        return True


def test_a_call_whose_worker_is_killed_runs_again_on_a_fresh_worker(tmp_path: Path) -> None:
    marker = tmp_path / "died"
    with make_executor("local", workers=2) as ex:
        assert isinstance(ex, LocalPool) and ex.max_retries == 2
        others = [ex.submit(_selftest.seeded_sum, seed) for seed in range(6)]
        dying = ex.submit(_selftest.die_once, str(marker))
        pid = dying.result(timeout=60)
        assert marker.exists()  # so the first attempt really died (SIGKILL) mid-call
        assert pid != os.getpid()
        assert [f.result() for f in others] == [_selftest.seeded_sum(s) for s in range(6)]
        # The pool goes on as before.
        assert ex.submit(_selftest.seeded_sum, 7).result() == _selftest.seeded_sum(7)


def test_a_call_that_always_kills_its_worker_fails_after_max_retries() -> None:
    with make_executor("local", workers=2, max_retries=1) as ex:
        doomed = ex.submit(_selftest.die)
        innocent = [ex.submit(_selftest.seeded_sum, seed) for seed in range(4)]
        with pytest.raises(WorkerLostError) as info:
            doomed.result(timeout=60)
        assert (
            str(info.value)
            == "worker process died 2 times running this call (last: killed by SIGKILL)"
        )
        assert worker_fault(info.value) == f"worker lost: {info.value}"
        assert [f.result() for f in innocent] == [_selftest.seeded_sum(s) for s in range(4)]
    with (
        make_executor("local", workers=1, max_retries=0) as ex,
        pytest.raises(WorkerLostError, match="died once"),
    ):
        ex.submit(_selftest.die).result(timeout=60)


def test_a_call_past_its_timeout_is_stopped_and_the_pool_goes_on() -> None:
    with make_executor("local", workers=2) as ex:
        start = time.monotonic()
        hung = submit_with_timeout(ex, 0.5, _selftest.sleep, 120)
        quick = submit_with_timeout(ex, 30, _selftest.seeded_sum, 3)
        with pytest.raises(CallTimeoutError) as info:
            hung.result(timeout=60)
        assert time.monotonic() - start < 60  # not the 120 s the call asked for
        assert str(info.value) == "no result after 0.5 s; the worker was stopped"
        assert worker_fault(info.value) == f"timeout: {info.value}"
        assert quick.result() == _selftest.seeded_sum(3)
        assert ex.submit(_selftest.seeded_sum, 4).result() == _selftest.seeded_sum(4)


def test_the_hung_worker_process_is_gone() -> None:
    with make_executor("local", workers=1) as ex:
        first = ex.submit(_selftest.pid).result()
        with pytest.raises(CallTimeoutError):
            submit_with_timeout(ex, 0.5, _selftest.sleep, 120).result(timeout=60)
        second = ex.submit(_selftest.pid).result()
    assert first != second  # one worker: the one that slept was replaced
    assert _gone(first)


def test_other_exceptions_are_the_calls_own_and_never_retried(tmp_path: Path) -> None:
    with make_executor("local", workers=1, max_tasks_per_child=1) as ex:
        with pytest.raises(ValueError, match="plain error") as info:
            ex.submit(_selftest.fail, "plain error").result()
        assert worker_fault(info.value) is None
        # max_tasks_per_child: each call on a new process, and that is not a fault.
        pids = [ex.submit(_selftest.pid).result() for _ in range(3)]
        assert len(set(pids)) == 3


def test_bad_pool_arguments_and_shutdown() -> None:
    with pytest.raises(ValueError, match="max_retries must be an integer >= 0"):
        make_executor("local", max_retries=-1)
    with pytest.raises(TypeError, match="max_retries"):
        make_executor("serial", max_retries=1)
    with pytest.raises(ValueError, match="timeout must be > 0"):
        submit_with_timeout(make_executor("serial"), 0, _selftest.pid)
    ex = make_executor("local", workers=1)
    slow = ex.submit(_selftest.sleep, 0.3)
    waiting = [ex.submit(_selftest.pid) for _ in range(3)]
    while not slow.running():  # handed to the worker (the others wait for it)
        time.sleep(0.01)
    ex.shutdown(wait=True, cancel_futures=True)
    assert slow.result() == 0.3  # running calls finish; waiting ones are cancelled
    assert all(f.cancelled() for f in waiting)
    with pytest.raises(RuntimeError, match="after shutdown"):
        ex.submit(_selftest.pid)


def test_serial_has_no_timeout() -> None:
    with make_executor("serial") as ex:
        assert submit_with_timeout(ex, 0.01, _selftest.sleep, 0.05).result() == 0.05


def _raise_in_initializer() -> None:
    raise OSError("no scratch disk")


def test_an_initializer_that_fails_breaks_the_pool() -> None:
    with make_executor("local", workers=1, initializer=_raise_in_initializer) as ex:
        with pytest.raises(cf.BrokenExecutor, match="initializer failed: OSError: no scratch"):
            ex.submit(_selftest.pid).result(timeout=60)
        with pytest.raises(cf.BrokenExecutor):
            ex.submit(_selftest.pid)


@needs_dask
def test_dask_killed_worker_maps_to_a_worker_fault() -> None:
    from distributed import KilledWorker

    exc = KilledWorker("evaluate_batch-1234", object(), 2)  # type: ignore[arg-type]
    assert worker_fault(exc) == (
        "worker lost: Dask workers died 3 times running this call (KilledWorker)"
    )
    # The real thing: max_retries=0 is the scheduler's allowed_failures, so one death is enough.
    with make_executor("dask", workers=1, max_retries=0) as ex:
        with pytest.raises(KilledWorker) as info:
            ex.submit(_selftest.die).result(timeout=120)
        assert worker_fault(info.value) == (
            "worker lost: Dask workers died once running this call (KilledWorker)"
        )


@needs_dask
def test_dask_local_cluster_listens_on_loopback_only_and_times_out_softly() -> None:
    psutil = pytest.importorskip("psutil")
    me = psutil.Process()
    before = {c.laddr for c in me.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
    with make_executor("dask", workers=2, max_retries=1) as ex:
        assert (
            ex.client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.allowed_failures) == 1
        )
        assert ex.submit(_selftest.seeded_sum, 1).result() == _selftest.seeded_sum(1)
        listening = []
        for process in [me, *me.children(recursive=True)]:
            for c in process.net_connections(kind="inet"):
                if c.status == psutil.CONN_LISTEN and (process != me or c.laddr not in before):
                    listening.append((process.pid, c.laddr.ip, c.laddr.port))
        workers = {p for p, _, _ in listening if p != me.pid}
        assert len(workers) >= 2  # both worker processes listen (and were looked at)
        assert listening and {ip for _, ip, _ in listening} == {"127.0.0.1"}, listening
        # A soft timeout: the future fails, the call's thread is left to finish in its worker.
        with pytest.raises(CallTimeoutError, match=r"no result after 0\.5 s; the call was left"):
            submit_with_timeout(ex, 0.5, _selftest.sleep, 3).result(timeout=60)
        assert submit_with_timeout(ex, 30, _selftest.seeded_sum, 2).result() == (
            _selftest.seeded_sum(2)
        )
