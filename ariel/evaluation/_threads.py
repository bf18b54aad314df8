"""How many threads an evaluation may use here, and the thread limits workers start with.

Apart from the executors (`ariel.evaluation.executors`), which set them, because the engine
reads them too and must not import the executors.
"""

from __future__ import annotations

import os
import sys

from ariel.errors import ConfigError

__all__ = [
    "EVAL_THREADS_VARIABLE",
    "THREAD_LIMIT_VARIABLES",
    "default_workers",
    "evaluation_threads",
]

#: Environment variables that size the thread pools of BLAS, OpenMP and numexpr.
THREAD_LIMIT_VARIABLES: tuple[str, ...] = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)

#: Environment variable that tells `evaluation_threads` its share of the CPUs in a worker.
EVAL_THREADS_VARIABLE = "ARIEL_EVAL_THREADS"


def default_workers() -> int:
    """CPUs this process may use (its affinity mask where the OS has one, e.g. under SLURM).

    Returns:
        The number of CPUs in this process's affinity mask, or where the OS has none
        ``os.cpu_count()``; at least 1.
    """
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def _in_dask_worker() -> bool:
    distributed = sys.modules.get("distributed")  # never imported just to ask
    if distributed is None:
        return False
    try:
        distributed.get_worker()
    except ValueError:  # "No worker found": a client or plain process that imported Dask
        return False
    return True


def evaluation_threads() -> int:
    """Threads one call of `evaluate_batch` may use here: never more than the affinity mask.

    In the main process: every CPU this process may use. In a worker of the ``local`` executor
    or of a Dask ``LocalCluster`` from `make_executor`: its share of them (the
    `EVAL_THREADS_VARIABLE` they were started with), so N workers do not each start one thread
    per core. In a Dask worker without that variable (a remote cluster): 1, because the number
    of workers sharing its machine is not known there; set the variable on those workers (e.g.
    in dask-jobqueue's ``job_script_prologue``) to give them more.

    Returns:
        The number of threads, from 1 to `default_workers`: `EVAL_THREADS_VARIABLE`'s value
        where it is set (capped at the CPUs this process may use), else 1 in a Dask worker and
        every CPU this process may use elsewhere.

    Raises:
        ConfigError: `EVAL_THREADS_VARIABLE` is set to something that is not a whole number
            (a `ValueError`).
    """
    cpus = default_workers()
    value = os.environ.get(EVAL_THREADS_VARIABLE, "").strip()
    if value:
        try:
            return min(max(1, int(value)), cpus)
        except ValueError:
            raise ConfigError(  # the process's environment, not a plugin (a remote worker's)
                f"{EVAL_THREADS_VARIABLE} must be a whole number of threads, not {value!r}"
            ) from None
    return 1 if _in_dask_worker() else cpus
