"""Whether the workers of a Dask scheduler run this ariel: `check_workers`.

Every worker machine needs the same ariel as the driver (docs/executors.md), and nothing
checked it: a worker with other code (another checkout, an edited plugin) gave other fitness
values that the run recorded as its own, and a worker that could not import ariel dropped
every task without a word while the run waited. When a run starts on a scheduler, each worker
connected then is asked for a fingerprint of its ``ariel`` package (`code_fingerprint`: the
SHA-256 of every module's path and bytes), in bounded time; a worker that differs, or fails
to answer with one, is one line. A worker that joins later is asked when the run next looks
at its workers (`DaskExecutor.stalled`, every few seconds), and stops the run, resumable.
"""

from __future__ import annotations

import functools
import hashlib
import threading
from pathlib import Path
from typing import TYPE_CHECKING

from ariel.errors import ExecutorStartError

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["ASK_SECONDS", "check_workers", "code_fingerprint", "workers_problem"]

#: Seconds the workers have to answer; past it the run starts unchecked (a busy worker).
ASK_SECONDS = 30.0


@functools.cache
def code_fingerprint() -> str:
    """SHA-256 (hex, 16 characters) of this process's ``ariel`` package: every ``.py`` file's
    path relative to the package and its bytes, in path order.

    Returns:
        The fingerprint; equal in two processes that run the same ariel code.
    """
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def check_workers(
    client: Client, expected: str | None = None, workers: list[str] | None = None
) -> None:
    """Each worker connected to ``client``'s scheduler runs ``expected`` ariel code, as a
    run starts (`workers_problem`).

    Args:
        client: The run's client.
        expected: The fingerprint the workers must have; None: this process's
            (`code_fingerprint`).
        workers: The workers to ask (their addresses); None: every one connected now.

    Raises:
        ExecutorStartError: Naming the first worker whose ariel differs, or that could not
            say (it cannot import ariel, say), and what to do.
    """
    problem = workers_problem(client, expected, workers)
    if problem is not None:
        raise ExecutorStartError(f"{problem}, then run again")


def workers_problem(
    client: Client, expected: str | None = None, workers: list[str] | None = None
) -> str | None:
    """The first worker of ``workers`` (None: every one connected now) whose ariel is not
    ``expected`` (None: this process's, `code_fingerprint`), or that could not say, and what to
    do (the caller ends the line with how to go on); None where every one that answered within
    `ASK_SECONDS` runs it.

    Args:
        client: The run's client.
        expected: The fingerprint the workers must have.
        workers: The workers to ask (their addresses).

    Returns:
        The line, or None.
    """
    expected = code_fingerprint() if expected is None else expected
    answer: dict[str, object] = {}

    def ask() -> None:
        try:
            answer["found"] = client.run(code_fingerprint, workers=workers, on_error="return")
        except BaseException as exc:  # handed to the caller's thread
            answer["error"] = exc

    thread = threading.Thread(target=ask, name="ariel-dask-fingerprint", daemon=True)
    thread.start()
    thread.join(ASK_SECONDS)
    found = answer.get("found")
    if not isinstance(found, dict):  # no answer in time, or none at all: left unchecked
        return None
    for worker, value in sorted(found.items()):
        if value == expected:
            continue
        if isinstance(value, BaseException):
            why = f"could not say which ariel it runs ({type(value).__name__}: {value})"
        else:
            why = f"runs other ariel code than this process (fingerprint {value}, here {expected})"
        return (
            f"Dask worker {worker} {why}: its results would not be this ariel's; give every "
            "worker machine the same ariel (docs/executors.md)"
        )
    return None
