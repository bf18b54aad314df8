"""Tiny pure functions for checking executors (importable by spawned and Dask workers)."""

from __future__ import annotations

import os
import signal
import time

import numpy as np

from ariel.evaluation.executors import THREAD_LIMIT_VARIABLES, evaluation_threads


def seeded_sum(seed: int, n: int = 1000) -> float:
    """Sum of ``n`` standard normal draws from ``default_rng(seed)``: same seed, same bits."""
    return float(np.random.default_rng(seed).standard_normal(n).sum())


def thread_environment() -> dict[str, str | None]:
    """The worker's thread-limit variables and its process id (under ``"pid"``)."""
    env: dict[str, str | None] = {name: os.environ.get(name) for name in THREAD_LIMIT_VARIABLES}
    env["pid"] = str(os.getpid())
    return env


def thread_share() -> tuple[int, int]:
    """``(evaluation_threads(), CPUs in this process's affinity mask)`` as the worker sees them."""
    return evaluation_threads(), len(os.sched_getaffinity(0))


def fail(message: str) -> None:
    """Raise ``ValueError(message)`` (to check that errors travel back from workers)."""
    raise ValueError(message)


def initial_environment() -> dict[str, str]:
    """The environment this process was started with (Linux ``/proc/self/environ``).

    Unlike ``os.environ`` it does not show variables set later, e.g. by an initializer.
    """
    with open("/proc/self/environ", "rb") as file:
        entries = file.read().split(b"\0")
    pairs = (entry.decode(errors="replace").partition("=") for entry in entries if entry)
    return {name: value for name, _, value in pairs}


def pid() -> int:
    """This process's id (which worker ran the call)."""
    return os.getpid()


def die_once(marker: str) -> int:
    """SIGKILL this process the first time ``marker`` (a file path) is seen missing, else pid.

    The marker is created atomically first, so exactly one call dies, wherever it runs.
    """
    try:
        os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return os.getpid()
    os.kill(os.getpid(), signal.SIGKILL)
    raise AssertionError("unreachable: SIGKILL cannot be caught")


def die() -> None:
    """SIGKILL this process, every time (a call that always takes its worker down)."""
    os.kill(os.getpid(), signal.SIGKILL)


def sleep(seconds: float) -> float:
    """Sleep ``seconds`` (a call that hangs, as far as a short timeout can tell); return them."""
    time.sleep(seconds)
    return seconds
