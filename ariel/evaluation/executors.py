"""Executors: where evaluations run.

Everything that runs evaluations talks to a `concurrent.futures.Executor` made here:

- ``serial``: in this process, one call after another (debugging, tests, profiling).
- ``local`` (default): a process pool on this machine, one worker per CPU, started with
  ``forkserver`` (``spawn`` where that is missing), BLAS/OpenMP limited to one thread per worker;
  a call whose worker dies is retried on a fresh one, a call past its timeout is stopped
  (`LocalPool`).
- ``dask``: Dask distributed, on a ``LocalCluster`` or on an existing scheduler (e.g. one run by
  dask-jobqueue on SLURM); needs ``pip install 'ariel[distributed]'``.
- ``gpu``: in this process, each batch of one body's brains as parallel worlds on MuJoCo Warp
  (`ariel.evaluation._executor_gpu.WarpExecutor`, docs/gpu.md); needs ``pip install 'ariel[gpu]'``.

Functions shipped to workers must be plain top-level functions taking plain data: workers
import them by name and rebuild plugins from registry names (see ``docs/executors.md``).

This module holds the executor kinds (`ExecutorKind`, `executor_kinds`), `make_executor` and the
checks of an ``[executor]`` section, and the helpers that work with any executor; the executors
themselves are in private siblings (``_executor_base``: the base classes and ``serial``;
``_executor_local``, ``_executor_dask``, ``_executor_gpu``), every public name re-exported here.
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
from collections.abc import Callable, Iterable, Iterator
from typing import Any, Protocol, TypeVar

from ariel.errors import CallTimeoutError, WarpUnavailableError, WorkerLostError
from ariel.evaluation import _kind_make as kinds
from ariel.evaluation._dask_connect import address_problem, check_scheduler, distributed_module
from ariel.evaluation._dask_local import open_files_problem
from ariel.evaluation._executor_base import (
    BatchExecutor as BatchExecutor,
    EvaluationExecutor as EvaluationExecutor,
    SerialExecutor as SerialExecutor,
    _is_count,
    submit_with_timeout as submit_with_timeout,
    worker_environment as worker_environment,
)
from ariel.evaluation._executor_dask import (
    NO_WORKER_NOTE_SECONDS as NO_WORKER_NOTE_SECONDS,
    NO_WORKER_TIMEOUT_LOCAL as NO_WORKER_TIMEOUT_LOCAL,
    NO_WORKER_TIMEOUT_SCHEDULER as NO_WORKER_TIMEOUT_SCHEDULER,
    NO_WORKER_TIMEOUT_VARIABLE as NO_WORKER_TIMEOUT_VARIABLE,
    DaskExecutor as DaskExecutor,
    _make_dask,
    worker_wait_seconds,
)
from ariel.evaluation._executor_gpu import WarpExecutor as WarpExecutor
from ariel.evaluation._executor_local import (
    DEFAULT_MAX_RETRIES as DEFAULT_MAX_RETRIES,
    LocalExecutor as LocalExecutor,
    LocalPool as LocalPool,
    _make_local,
)
from ariel.evaluation._threads import (
    EVAL_THREADS_VARIABLE as EVAL_THREADS_VARIABLE,
    THREAD_LIMIT_VARIABLES as THREAD_LIMIT_VARIABLES,
    default_workers,
    evaluation_threads as evaluation_threads,
)
from ariel.evaluation._warp_runtime import check_device, warp_modules
from ariel.plugins import Registry
from ariel.utils import MIN_OPEN_FILES, accept_aliases, open_files_short

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
    "reach",
    "settings_options",
    "submit_with_timeout",
    "worker_environment",
    "worker_fault",
]

R = TypeVar("R")
T = TypeVar("T")

#: The built-in executor kinds (`executor_kinds` has these and any registered ones).
EXECUTOR_KINDS: tuple[str, ...] = ("serial", "local", "dask", "gpu")
_BUILTIN_KINDS = dict(zip(EXECUTOR_KINDS, ("SerialKind", "LocalKind", "DaskKind", "GpuKind")))


# --------------------------------------------------------------------------------------------
# executor kinds
# --------------------------------------------------------------------------------------------


class ExecutorSettings(Protocol):
    """What the executor kinds read of an experiment config's ``[executor]`` section: an
    `ariel.evolution.ExecutorConfig`, or any object with its attributes."""

    @property
    def kind(self) -> str: ...
    @property
    def workers(self) -> int | None: ...
    @property
    def address(self) -> str | None: ...
    @property
    def device(self) -> str: ...
    @property
    def timeout(self) -> float: ...
    @property
    def max_retries(self) -> int: ...


class ExecutorSettingsError(ValueError):
    """Bad executor settings; the message starts with the config key (``executor.workers: ...``)."""


#: Open files the driver holds for each worker of the local pool (pipes, the fork server's
#: and the result queue's): about 3 measured; with room to spare.
OPEN_FILES_PER_LOCAL_WORKER = 8


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

    def check(self, settings: ExecutorSettings) -> None:
        """Checks of this kind's own settings, before anything runs (`ExecutorSettingsError`)."""

    def reach(self, settings: ExecutorSettings) -> None:
        """Whatever the kind connects to answers: called before a new run or campaign folder
        is made (the `dask` kind asks the scheduler at ``executor.address`` who it is); one
        line why not, as the error its executor would raise connecting."""

    def planned_workers(self, settings: ExecutorSettings) -> tuple[int, bool]:
        """Batches run at once, and whether they run on this machine."""
        if self.one_worker is not None:
            return 1, True
        return settings.workers or default_workers(), True

    def options(self, settings: ExecutorSettings) -> dict[str, Any]:
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

    def check(self, settings: ExecutorSettings) -> None:
        # Before anything is written: a pool too big for ``ulimit -n`` failed in the fork
        # server with its traceback, before the one line.
        workers = settings.workers or default_workers()
        most = open_files_short(MIN_OPEN_FILES + OPEN_FILES_PER_LOCAL_WORKER * workers)
        if most is not None:
            fits = max(1, (most - MIN_OPEN_FILES) // OPEN_FILES_PER_LOCAL_WORKER)
            raise ExecutorSettingsError(
                f"executor.workers: a local pool of {workers} workers needs about "
                f"{MIN_OPEN_FILES + OPEN_FILES_PER_LOCAL_WORKER * workers} open files; the "
                f"limit is {most} (ulimit -n): use at most {fits} workers, or raise the limit"
            )

    def options(self, settings: ExecutorSettings) -> dict[str, Any]:
        return {"workers": settings.workers, "max_retries": settings.max_retries}

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        return _make_local(workers, max_retries=max_retries, **options)


class DaskKind(ExecutorKind):
    """``dask``: a Dask ``LocalCluster``, or a scheduler you run (at ``executor.address``)."""

    takes_address = True

    def check(self, settings: ExecutorSettings) -> None:
        if settings.address is not None and settings.workers is not None:
            raise ExecutorSettingsError(
                "executor.workers: sizes a local cluster; with executor.address the "
                "cluster's own workers are used (scale the cluster instead)"
            )
        # Before anything is written: Dask itself, the address's form (connecting is
        # `reach`'s), and the open files a local cluster of that many workers needs.
        try:
            distributed_module()
        except ImportError as exc:
            raise ExecutorSettingsError(f"executor.kind: {exc}") from None
        if settings.address is not None:
            problem = address_problem(settings.address)
            if problem is not None:
                raise ExecutorSettingsError(f"executor.address: {problem}")
        else:
            problem = open_files_problem(settings.workers or default_workers())
            if problem is not None:
                raise ExecutorSettingsError(f"executor.workers: {problem}")
        # ARIEL_NO_WORKER_TIMEOUT read when the executor is made: a bad one left a folder
        worker_wait_seconds(None, NO_WORKER_TIMEOUT_LOCAL)

    def reach(self, settings: ExecutorSettings) -> None:
        if settings.address is not None:
            check_scheduler(settings.address)

    def planned_workers(self, settings: ExecutorSettings) -> tuple[int, bool]:
        return settings.workers or default_workers(), settings.address is None

    def options(self, settings: ExecutorSettings) -> dict[str, Any]:
        options = {"workers": settings.workers, "address": settings.address}
        if settings.address is None:
            options["max_retries"] = settings.max_retries
        return options

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        return _make_dask(workers, address, max_retries=max_retries, **options)


class GpuKind(ExecutorKind):
    """``gpu``: MuJoCo Warp on one device, in this process (docs/gpu.md)."""

    one_worker = "the gpu executor runs on one device"

    def check(self, settings: ExecutorSettings) -> None:
        """MuJoCo Warp must be installed and its device (``executor.device``) present."""
        try:
            warp_modules()
        except WarpUnavailableError as exc:
            raise ExecutorSettingsError(f"executor.kind: {exc}") from None
        try:
            check_device(settings.device)
        except WarpUnavailableError as exc:
            raise ExecutorSettingsError(f"executor.device: {exc}") from None

    def options(self, settings: ExecutorSettings) -> dict[str, Any]:
        return {"workers": settings.workers, "device": settings.device}

    def make(self, *, workers=None, address=None, max_retries=None, **options):  # type: ignore[no-untyped-def]
        if workers not in (None, 1):
            raise ValueError(
                f"the gpu executor runs in this process on one device; no workers (got {workers})"
            )
        return WarpExecutor(**options)


def _check_kind(obj: object) -> str | None:
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


def check_settings(settings: ExecutorSettings) -> None:
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
    if workers is not None and (
        not isinstance(workers, int) or isinstance(workers, bool) or workers < 1
    ):
        raise ExecutorSettingsError(f"executor.workers: must be an integer >= 1 (got {workers!r})")
    if kind.one_worker is not None and workers not in (None, 1):
        raise ExecutorSettingsError(f"executor.workers: {kind.one_worker} (got {workers})")
    if address is not None and not kinds.takes_address(kind):
        raise ExecutorSettingsError(
            f"executor.address: only for the dask executor, not {kind_name!r}"
        )
    kinds.kind_call(kind_name in _BUILTIN_KINDS, kind_name, "check", kind.check, settings)


def reach(settings: ExecutorSettings) -> None:
    """`ExecutorKind.reach` of the settings' kind (a Dask scheduler that never answers: one
    line, before any folder is made); a registered kind's own failure in one line.

    Args:
        settings: An ``[executor]`` section (`ariel.evolution.ExecutorConfig`), checked.
    """
    name = settings.kind
    kinds.kind_call(name in _BUILTIN_KINDS, name, "reach", executor_kind(name).reach, settings)


def planned_workers(settings: ExecutorSettings) -> tuple[int, bool]:
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


def settings_options(settings: ExecutorSettings) -> dict[str, Any]:
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
    kind: str | ExecutorSettings = "local",
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
        ExecutorStartError: A registered kind's ``make`` raised, or gave no executor (one
            line naming the kind); a Dask ``LocalCluster`` that could not start its workers.

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
    if address is not None and not kinds.takes_address(executor):
        raise ValueError(f"address= is only for the dask executor, not {kind!r}")
    where = {kinds.address_keyword(executor.make): address}
    if kind in _BUILTIN_KINDS:
        return executor.make(workers=workers, max_retries=max_retries, **where, **options)
    return kinds.made_by_plugin(
        kind, executor, workers=workers, max_retries=max_retries, **where, **options
    )


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


def _check_shippable(fn: Callable[..., object]) -> None:
    target = fn.func if isinstance(fn, functools.partial) else fn
    qualname = getattr(target, "__qualname__", "")
    if "<lambda>" in qualname or "<locals>" in qualname:
        raise TypeError(
            f"{qualname} cannot be sent to workers: pass a top-level function (workers import "
            "it by name) that takes plain data"
        )


def map_ordered(
    executor: cf.Executor,
    fn: Callable[[T], R],
    items: Iterable[T],
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
        from tqdm.auto import tqdm  # lazy: slow to import (as slow as this module); a bar only

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
