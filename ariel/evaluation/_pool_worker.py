"""A worker process of the ``local`` executor's pool, and what the driver keeps of one.

The worker's side: `_worker_main`, its life (an initializer, then one call at a time), the
tagged messages it sends, and the watchdog that ends it when the driver process is gone. The
driver's side of one worker: its records (`_Call`, `_Worker`), the environment a worker starts
with (`temporary_environ`), a pidfd to stop it by, how it ended, and how its pickled outcome
becomes the call's future (`_settle`). The driver thread itself: `ariel.evaluation._pool`.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import pickle
import signal
import threading
import traceback
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess

__all__ = ["temporary_environ"]

_STOP = b""  # sent to an idle worker: exit
# Tags of a worker's messages (see `_worker_main`).
_STARTED, _DONE, _RETIRING, _BROKEN = b"S", b"D", b"R", b"B"
# Exit status of a worker whose driver died (no one reads it; for `ps` and tests).
_ORPHANED_EXIT = 3


class _RemoteTracebackError(Exception):
    """The worker's traceback, chained to an exception that came back (as CPython's pool does)."""

    def __init__(self, text: str) -> None:
        super().__init__(text)
        self.text = text

    def __str__(self) -> str:
        return self.text


def _watch_driver(lifeline: Connection) -> None:
    """Return when the driver process is gone (its end of ``lifeline`` closed), then exit."""
    with contextlib.suppress(EOFError, OSError):
        lifeline.recv_bytes()
    os._exit(_ORPHANED_EXIT)


def _start_watchdog(lifeline: Connection | None, inherited: Connection | None) -> None:
    if inherited is not None:  # fork: this copy of the driver's end would keep the pipe open
        inherited.close()
    if lifeline is not None:
        threading.Thread(
            target=_watch_driver, args=(lifeline,), name="ariel-driver-watchdog", daemon=True
        ).start()


def _worker_main(
    conn: Connection,
    initializer: Callable[..., object] | None,
    initargs: tuple[object, ...],
    max_tasks: int | None,
    lifeline: Connection | None = None,
    inherited: Connection | None = None,
) -> None:
    """A worker's life: initializer, then calls one at a time until told to stop.

    Messages to the driver start with a tag byte: `_STARTED` once a call is unpickled (its
    imports done), then `_DONE` (or `_RETIRING`, when this worker exits after it) followed by
    the pickled ``(ok, value, traceback_text)``. An initializer that raises sends `_BROKEN` and
    its traceback, and the worker exits. The tag lets the driver hand this worker its next call
    before it unpickles the result. ``lifeline``: see the module docstring.
    """
    _start_watchdog(lifeline, inherited)
    if initializer is not None:
        try:
            initializer(*initargs)
        except BaseException:
            with contextlib.suppress(OSError):  # the driver may be gone already
                conn.send_bytes(_BROKEN + traceback.format_exc().encode(errors="replace"))
            return
    calls = 0
    while True:
        try:
            payload = conn.recv_bytes()
        except (EOFError, OSError):  # the driver is gone
            return
        if payload == _STOP:
            return
        try:
            fn, args, kwargs = pickle.loads(payload)
            conn.send_bytes(_STARTED)
            value, ok, text = fn(*args, **kwargs), True, ""
        except BaseException as exc:
            value, ok, text = exc, False, traceback.format_exc()
        calls += 1
        retiring = max_tasks is not None and calls >= max_tasks
        try:
            message = pickle.dumps((ok, value, text))
        except Exception as exc:  # a result or exception that cannot be pickled
            error = RuntimeError(
                f"the call's {'result' if ok else 'exception'} cannot be sent back: {exc!r}"
            )
            message = pickle.dumps((False, error, traceback.format_exc()))
        del value
        try:
            conn.send_bytes((_RETIRING if retiring else _DONE) + message)
        except OSError:  # the driver closed this pipe (it took this worker for lost): quietly
            return
        if retiring:
            return


# Serialises temporary edits of os.environ (worker processes are created on the driver thread).
_ENVIRON_LOCK = threading.Lock()


@contextlib.contextmanager
def temporary_environ(env: Mapping[str, str]) -> Iterator[None]:
    """``os.environ`` updated with ``env`` for the duration (process creation inherits it)."""
    with _ENVIRON_LOCK:
        saved = {name: os.environ.get(name) for name in env}
        os.environ.update(env)
        try:
            yield
        finally:
            for name, value in saved.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value


@dataclass
class _Call:
    future: cf.Future
    payload: bytes
    timeout: float | None
    deaths: int = 0
    orphaned: int = 0  # times its worker's fork server died while it ran (not deaths)
    running: bool = False  # its future is marked running (it was handed to a worker once)


@dataclass
class _Worker:
    process: BaseProcess  # a Process of the pool's context
    conn: Connection
    call: _Call | None = None
    deadline: float | None = None
    retiring: bool = False
    killed: str = ""  # why the pool killed it ("timeout", "closed"): not the call's fault
    spoke: bool = False  # it sent a message: it started
    pidfd: int | None = None  # forkserver workers (not our children): a pidfd to stop it by


def _open_pidfd(pid: int | None) -> int | None:
    """A pidfd for process ``pid`` (Linux 5.3 and later), or None."""
    opener = getattr(os, "pidfd_open", None)
    if opener is None or pid is None:
        return None
    try:
        return int(opener(pid))
    except OSError:
        return None


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def _settle(call: _Call, data: bytes) -> None:
    """Set a finished call's future from the worker's pickled ``(ok, value, traceback)``."""
    try:
        ok, value, text = pickle.loads(data)
    except Exception as exc:  # e.g. an exception class that cannot be rebuilt from its args
        ok, value, text = (
            False,
            RuntimeError(f"the call's outcome cannot be unpickled: {exc!r}"),
            "",
        )
    if ok:
        call.future.set_result(value)
        return
    if text and isinstance(value, BaseException):
        value.__cause__ = _RemoteTracebackError(text)
    call.future.set_exception(value)


def _ended_how(exitcode: int | None) -> str:
    if exitcode is None:
        return "ended without an exit code"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"killed by {name}"
    return f"exit code {exitcode}"
