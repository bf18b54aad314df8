"""Executors: same results on every kind and worker count, errors travel back, BLAS limits."""

from __future__ import annotations

import concurrent.futures as cf
import functools
import importlib.abc
import importlib.util
import os
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest

from ariel.evaluation import _selftest
from ariel.evaluation.executors import (
    EVAL_THREADS_VARIABLE,
    THREAD_LIMIT_VARIABLES,
    DaskExecutor,
    ExecutorKind,
    SerialExecutor,
    check_settings,
    evaluation_threads,
    executor_kinds,
    make_executor,
    map_ordered,
)

HAS_DASK = importlib.util.find_spec("distributed") is not None
needs_dask = pytest.mark.skipif(
    not HAS_DASK, reason="dask.distributed is not installed (pip install 'ariel[distributed]')"
)

SEEDS = list(range(12))
N_DRAWS = 5000

EXECUTORS = [
    pytest.param(("serial", None), id="serial"),
    pytest.param(("local", 1), id="local-1"),
    pytest.param(("local", 2), id="local-2"),
    pytest.param(("dask", 1), id="dask-1", marks=needs_dask),
]


@pytest.fixture(scope="module", params=EXECUTORS)
def executor(request: pytest.FixtureRequest) -> Iterator[cf.Executor]:
    kind, workers = request.param
    with make_executor(kind, workers=workers) as ex:
        yield ex


def expected_bits() -> list[str]:
    return [_selftest.seeded_sum(seed, N_DRAWS).hex() for seed in SEEDS]


def test_same_bits_on_every_executor(executor: cf.Executor) -> None:
    task = functools.partial(_selftest.seeded_sum, n=N_DRAWS)
    results = list(map_ordered(executor, task, SEEDS))
    assert [r.hex() for r in results] == expected_bits()
    # Plain submit/map agree too (and map keeps the order).
    assert executor.submit(_selftest.seeded_sum, 3, N_DRAWS).result().hex() == expected_bits()[3]
    mapped = list(executor.map(_selftest.seeded_sum, SEEDS, [N_DRAWS] * len(SEEDS)))
    assert [r.hex() for r in mapped] == expected_bits()


def test_exceptions_propagate(executor: cf.Executor) -> None:
    future = executor.submit(_selftest.fail, "boom in a worker")
    with pytest.raises(ValueError, match="boom in a worker"):
        future.result()
    # map_ordered raises at the failing item, after yielding the earlier ones in order.
    results = map_ordered(executor, _selftest.fail, ["first failure", "second failure"])
    with pytest.raises(ValueError, match="first failure"):
        next(results)
    # The executor still works afterwards.
    assert executor.submit(_selftest.seeded_sum, 0, 10).result() == _selftest.seeded_sum(0, 10)


def test_workers_run_with_one_blas_thread(executor: cf.Executor) -> None:
    parent_before = {name: os.environ.get(name) for name in THREAD_LIMIT_VARIABLES}
    env = executor.submit(_selftest.thread_environment).result()
    if isinstance(executor, SerialExecutor):  # runs here and leaves the environment alone
        assert env == {**parent_before, "pid": str(os.getpid())}
        return
    assert env["pid"] != str(os.getpid())
    assert {name: env[name] for name in THREAD_LIMIT_VARIABLES} == dict.fromkeys(
        THREAD_LIMIT_VARIABLES, "1"
    )
    # Starting workers must not leave the variables changed in this process.
    assert {name: os.environ.get(name) for name in THREAD_LIMIT_VARIABLES} == parent_before


def test_each_worker_gets_its_share_of_the_cpus(executor: cf.Executor) -> None:
    before = os.environ.get(EVAL_THREADS_VARIABLE)
    shares = [executor.submit(_selftest.thread_share).result() for _ in range(4)]
    if isinstance(executor, SerialExecutor):
        workers = 1
    elif isinstance(executor, DaskExecutor):
        workers = len(executor.cluster.workers)
    else:
        workers = executor._max_workers
    for threads, affinity in shares:
        assert 1 <= threads <= affinity
        assert threads == max(1, affinity // workers)
    assert os.environ.get(EVAL_THREADS_VARIABLE) == before  # this process is left alone


def test_two_local_workers_on_this_machine_get_one_thread_each() -> None:
    affinity = len(os.sched_getaffinity(0))
    with make_executor("local", workers=2) as ex:
        shares = {ex.submit(_selftest.thread_share).result() for _ in range(4)}
    assert shares == {(max(1, affinity // 2), affinity)}
    if affinity == 2:  # this project's machine
        assert shares == {(1, 2)}


def test_evaluation_threads_never_exceed_the_affinity_mask(monkeypatch: pytest.MonkeyPatch) -> None:
    affinity = len(os.sched_getaffinity(0))
    monkeypatch.delenv(EVAL_THREADS_VARIABLE, raising=False)
    assert evaluation_threads() == affinity  # the main process: the whole mask
    for value, expected in (("1", 1), ("0", 1), (str(affinity + 64), affinity), (" 1 ", 1)):
        monkeypatch.setenv(EVAL_THREADS_VARIABLE, value)
        assert evaluation_threads() == expected
    monkeypatch.setenv(EVAL_THREADS_VARIABLE, "many")
    with pytest.raises(ValueError, match=EVAL_THREADS_VARIABLE):
        evaluation_threads()


@pytest.mark.skipif(not os.path.exists("/proc/self/environ"), reason="needs Linux /proc")
def test_local_workers_start_with_the_limits_in_their_environment() -> None:
    # Set before Python starts, so numpy imported by the main module (spawn and forkserver
    # import it before any initializer runs) already sees them.
    with make_executor("local", workers=1, mp_context="spawn") as ex:
        initial = ex.submit(_selftest.initial_environment).result()
    assert {name: initial.get(name) for name in THREAD_LIMIT_VARIABLES} == dict.fromkeys(
        THREAD_LIMIT_VARIABLES, "1"
    )


def test_local_pool_size_and_blas_option() -> None:
    with make_executor("local", workers=2, blas_threads=2) as ex:
        assert ex._max_workers == 2
        env = ex.submit(_selftest.thread_environment).result()
    assert env["OPENBLAS_NUM_THREADS"] == "2" and env["OMP_NUM_THREADS"] == "2"
    with make_executor("local") as ex:
        # Processes start lazily, so this costs nothing; default = CPUs this process may use.
        usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
        assert ex._max_workers == (usable or os.cpu_count())


def test_serial_executor_captures_exceptions_in_the_future() -> None:
    ex = make_executor("serial")
    assert isinstance(ex, SerialExecutor)
    future = ex.submit(_selftest.fail, "kept in the future")  # submit itself does not raise
    assert future.done() and isinstance(future.exception(), ValueError)
    ex.shutdown()
    with pytest.raises(RuntimeError, match="after shutdown"):
        ex.submit(_selftest.seeded_sum, 0)


def test_unknown_kind_lists_the_kinds() -> None:
    with pytest.raises(ValueError) as info:
        make_executor("threads")
    assert str(info.value) == "unknown executor kind 'threads'; known: serial, local, dask, gpu"


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"kind": "local", "workers": 0}, ValueError, "workers must be an integer >= 1"),
        ({"kind": "local", "workers": 1.5}, ValueError, "workers must be an integer >= 1"),
        ({"kind": "serial", "workers": 2}, ValueError, "workers must be 1"),
        ({"kind": "serial", "blas_threads": 1}, TypeError, "takes no options"),
        ({"kind": "local", "address": "tcp://x:8786"}, ValueError, "address= is only for the dask"),
        # scheduler= is the old name of address=: still accepted, but not beside it
        ({"kind": "local", "scheduler": "tcp://x:8786"}, ValueError, "address= is only for"),
        ({"kind": "dask", "address": "a", "scheduler": "a"}, TypeError, "both 'address' and"),
        ({"kind": "local", "blas_threads": 0}, ValueError, "blas_threads must be"),
    ],
)
def test_bad_arguments(kwargs: dict, error: type[Exception], message: str) -> None:
    with pytest.raises(error, match=message):
        make_executor(**kwargs)


def test_map_ordered_refuses_unshippable_functions() -> None:
    with make_executor("serial") as ex, pytest.raises(TypeError, match="top-level function"):
        map_ordered(ex, lambda seed: seed, [1])

    def local_function(seed: int) -> int:
        return seed

    with make_executor("serial") as ex, pytest.raises(TypeError, match="<locals>"):
        map_ordered(ex, functools.partial(local_function), [1])


def test_map_ordered_shows_progress(capsys: pytest.CaptureFixture[str]) -> None:
    with make_executor("serial") as ex:
        results = list(
            map_ordered(ex, _selftest.seeded_sum, [1, 2, 3], progress=True, desc="evals")
        )
    assert len(results) == 3
    err = capsys.readouterr().err
    assert "evals" in err and "3/3" in err


def test_map_ordered_cancels_pending_work_on_failure() -> None:
    class RecordingExecutor(SerialExecutor):
        """Hands out futures that have not run yet, so cancellation can be observed."""

        def __init__(self) -> None:
            super().__init__()
            self.futures: list[cf.Future] = []

        def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
            future: cf.Future = cf.Future()
            if args == ("fail",):
                future.set_exception(ValueError("fail"))
            self.futures.append(future)
            return future

    ex = RecordingExecutor()
    results = map_ordered(ex, _selftest.fail, ["fail", "later", "later"])
    assert len(ex.futures) == 3  # everything is submitted before iterating
    with pytest.raises(ValueError, match="fail"):
        next(results)
    assert [f.cancelled() for f in ex.futures] == [False, True, True]


def test_dask_missing_gives_install_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # makes `import distributed` fail
    with pytest.raises(ImportError) as info:
        make_executor("dask", workers=1)
    assert str(info.value) == (
        "Dask executor needs the optional extra: pip install 'ariel[distributed]'"
    )


def test_a_dask_that_will_not_load_is_one_line_before_any_folder(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Dask reads its configuration files on import: a malformed one was a 40-line traceback
    from `ariel run --executor dask` (exit 1), and a campaign cut its message to one line
    without the YAML error."""
    from _helpers import exit_code, one_error_line

    malformed = (
        "A dask config file at 'bad.yaml' is malformed, original error message:\n\n"
        "while parsing a flow sequence\n  target: [1,2\n  ^"
    )

    class Malformed(importlib.abc.MetaPathFinder):
        def find_spec(self, name: str, *args: object) -> None:
            if name == "distributed":
                raise ValueError(malformed)

    monkeypatch.delitem(sys.modules, "distributed", raising=False)
    monkeypatch.setattr(sys, "meta_path", [Malformed(), *sys.meta_path])
    config = Path(__file__).parents[2] / "experiments" / "coevolve_flat.toml"
    argv = ["run", str(config), "--out", str(tmp_path / "run"), "--executor", "dask"]
    assert exit_code(argv) == 2
    assert one_error_line(capsys) == (
        "ariel: error: executor.kind: Dask could not load: A dask config file at 'bad.yaml' "
        "is malformed, original error message: while parsing a flow sequence target: [1,2 ^"
    )
    assert not (tmp_path / "run").exists()


@needs_dask
def test_dask_on_an_existing_scheduler() -> None:
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
    ) as cluster:
        with pytest.raises(ValueError, match="scale the cluster"):
            make_executor("dask", workers=2, address=cluster.scheduler_address)
        ex = make_executor("dask", address=cluster.scheduler_address)
        with ex:
            task = functools.partial(_selftest.seeded_sum, n=N_DRAWS)
            assert [r.hex() for r in map_ordered(ex, task, SEEDS)] == expected_bits()
            # A worker we did not start does not know how many share its machine: 1 thread.
            assert ex.submit(_selftest.thread_share).result()[0] == 1
        assert ex.client.status == "closed"  # the executor closes the client it made ...
        assert ex.cluster is None
        assert cluster.status.name == "running"  # ... but not a cluster it did not start


@needs_dask
def test_dask_local_cluster_is_closed_on_shutdown() -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ex = make_executor("dask", workers=1)
    # No "port 8787 is already in use" while another cluster (the fixture's) is running.
    assert [str(w.message) for w in caught if "already in use" in str(w.message)] == []
    cluster = ex.cluster
    assert cluster is not None and len(cluster.workers) == 1
    ex.shutdown()
    assert ex.client.status == "closed"
    assert cluster.status.name == "closed"
    ex.shutdown()  # idempotent


def test_a_third_party_executor_from_an_entry_point_runs_an_experiment(
    fake_distribution, tmp_path
) -> None:
    from ariel.evaluation.executors import executor_kinds
    from ariel.evolution import run_experiment
    from ariel.recording import load_run

    fake_distribution(
        "ariel_counting_executor",
        "0.3",
        source="""
            from ariel.evaluation.executors import ExecutorKind, SerialExecutor

            CALLS = []

            class Counting(SerialExecutor):
                def submit_batch(self, tasks, *, timeout=None):
                    CALLS.append(len(tasks))
                    return super().submit_batch(tasks, timeout=timeout)

            class CountingKind(ExecutorKind):
                one_worker = "the counting executor runs here"

                def make(self, *, workers=None, address=None, max_retries=None, **options):
                    return Counting()
        """,
        entry_points={"ariel.executors": {"counting": "ariel_counting_executor:CountingKind"}},
    )
    executor_kinds.refresh()
    try:
        config = {
            "name": "third_party_executor",
            "generations": 2,
            "body": {"encoder": "prebuilt", "genotype": "gecko"},
            "brain": {"popsize": 2, "iterations": 1},
            "task": {"duration": 0.2},
            "record": {"rerun": False},
            "executor": {"kind": "counting"},
        }
        run = load_run(run_experiment(config, out=tmp_path / "run").run_dir)
        import ariel_counting_executor

        assert ariel_counting_executor.CALLS == [2, 2]  # every brain batch went through it
        assert len(run.evaluations) == 4 and (run.evaluations.status == "ok").all()
        with pytest.raises(ValueError, match="counting executor runs here"):
            check_settings(type("S", (), {"kind": "counting", "workers": 3, "address": None})())
    finally:
        executor_kinds.refresh()


def test_a_kind_written_before_the_rename_gets_the_address_as_scheduler() -> None:
    """Third-party kinds from before ``scheduler`` became ``address`` keep working."""
    made = []

    class OldKind(ExecutorKind):
        takes_scheduler = True  # the old name of takes_address

        def make(self, *, workers=None, scheduler=None, max_retries=None, **options):
            made.append(scheduler)
            return SerialExecutor()

    executor_kinds.register("old_style", OldKind)
    try:
        with make_executor("old_style", address="tcp://host:8786"):
            pass
        settings = type("S", (), {"kind": "old_style", "workers": None, "address": "tcp://h:1"})
        check_settings(settings())  # executor.address is accepted for it
    finally:
        executor_kinds.unregister("old_style")
    assert made == ["tcp://host:8786"]
    assert "old_style" not in executor_kinds.names()


class _RaisingKind(ExecutorKind):
    one_worker = "it runs here"

    def make(self, *, workers=None, address=None, max_retries=None, **options):
        raise RuntimeError("my executor cannot start")


class _NoExecutorKind(_RaisingKind):
    def make(self, *, workers=None, address=None, max_retries=None, **options):
        return None


class _ArielErrorKind(_RaisingKind):
    def make(self, *, workers=None, address=None, max_retries=None, **options):
        from ariel.errors import RunStorageError

        raise RunStorageError("ariel-boom")  # one line, but not naming the kind


class _CheckRaisesKind(_RaisingKind):
    def check(self, settings):
        raise RuntimeError("my check's bug")


class _ReachRaisesKind(_RaisingKind):
    def reach(self, settings):
        raise RuntimeError("my reach's bug")


@pytest.mark.parametrize(
    ("kind", "said"),
    [
        (_RaisingKind, " could not make its executor: RuntimeError: my executor cannot start"),
        (_NoExecutorKind, ": make() gave NoneType, not an executor (one with submit_batch"),
        (_ArielErrorKind, " could not make its executor: RunStorageError: ariel-boom"),
        (_CheckRaisesKind, ": its check() raised RuntimeError: my check's bug"),
        (_ReachRaisesKind, ": its reach() raised RuntimeError: my reach's bug"),
    ],
)
def test_a_kind_that_makes_no_executor_is_one_line_and_leaves_no_folder(
    kind: type, said: str, tmp_path, capsys
) -> None:
    """A traceback (exit 1) before, and a `failed` folder holding run.json alone."""
    from _helpers import exit_code, one_error_line, tiny_run_toml

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("no_executor", 1))
    executor_kinds.register("test_no_executor", kind)
    try:
        argv = ["run", str(config), "--out", str(tmp_path / "run"), "--quiet"]
        assert exit_code([*argv, "--executor", "test_no_executor"]) == 2
    finally:
        executor_kinds.unregister("test_no_executor")
    line = one_error_line(capsys)
    assert "executor kind 'test_no_executor'" + said in line, line
    assert not (tmp_path / "run").exists()


def test_the_dask_cancel_race_s_log_record_is_dropped_and_no_other() -> None:
    import logging

    from ariel.evaluation._dask_logs import _CancelRace

    def record(exc: BaseException) -> logging.LogRecord:
        return logging.LogRecord(
            "tornado.application", logging.ERROR, "", 0, "x", None, (type(exc), exc, None)
        )

    race = NameError("cannot access free variable 'future' where it is not associated")
    assert _CancelRace().filter(record(race)) is False
    assert _CancelRace().filter(record(NameError("name 'x' is not defined"))) is True
    assert _CancelRace().filter(record(RuntimeError("'future'"))) is True


@needs_dask
def test_a_worker_running_other_ariel_code_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker with other ariel code gave other fitness values, recorded as the run's; one
    that could not import ariel dropped every task while the run waited (probe G6)."""
    from distributed import Client, LocalCluster

    from ariel.errors import ExecutorStartError
    from ariel.evaluation._dask_workers import check_workers, code_fingerprint

    with (
        LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster,
        Client(cluster) as client,
    ):
        check_workers(client)  # the same code: nothing said
        (worker,) = client.scheduler_info()["workers"]
        with pytest.raises(ExecutorStartError) as other:
            check_workers(client, expected="0" * 16)
        assert str(other.value).startswith(
            f"Dask worker {worker} runs other ariel code than this process (fingerprint "
            f"{code_fingerprint()}, here {'0' * 16}): "
        )
        failed = {worker: ImportError("this is not ariel")}
        monkeypatch.setattr(client, "run", lambda *args, **kwargs: failed)
        with pytest.raises(ExecutorStartError, match="could not say which ariel it runs \\(Imp"):
            check_workers(client)


@needs_dask
def test_a_worker_that_joins_with_other_ariel_code_stops_the_run(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Checked at the start only, a worker with edited code that joined mid-run had 88 of 240
    evaluations recorded from it (probe R9): each new worker is asked as the run looks at its
    workers (`stalled`), and one of other code stops the run, resumable; a closed client (its
    scheduler gone for good) is a reason at once."""
    from distributed import LocalCluster

    from ariel.evaluation import _dask_workers, _executor_dask

    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster:
        executor = make_executor("dask", address=cluster.scheduler_address)
        with executor:
            assert executor.stalled() is None  # the worker runs this ariel
            real = _dask_workers.workers_problem
            monkeypatch.setattr(
                _executor_dask,
                "workers_problem",
                lambda client, workers=None: real(client, "0" * 16, workers),
            )
            assert executor.stalled() is None  # asked once: not again
            cluster.scale(2)
            cluster.wait_for_workers(2, timeout=60)
            reason = executor.stalled()
            assert reason is not None and "runs other ariel code than this process" in reason
            assert reason.endswith("then resume the run")
            status = executor.client.status
            executor.client.status = "closed"
            assert executor.stalled().startswith("the Dask scheduler ")
            executor.client.status = status
