"""Dask's own log lines while a ``LocalCluster`` of ours runs: held back, the last error kept.

When its workers are killed (or cannot start: too many open files, no memory), Dask's nannies
and scheduler log an ERROR with a traceback for every attempt: hundreds of lines on stderr
before the run's own one line says what happened and how to resume. The run already handles
a lost worker (its tasks run again, `DaskExecutor.stalled` stops a run left without workers),
so those lines say nothing the user can act on, except their cause: `DaskLogs` keeps the first
exception logged with an error (the follow-on ones hide the cause) for the one line that ends
the run. CRITICAL records still show. Tornado's callback errors (a cancelled future's, as the
cluster closes) are Dask's too while it runs.

`quiet_cancel_race` drops one more record, of an upstream race after Ctrl-C.
"""

from __future__ import annotations

import logging
import traceback
from pathlib import Path

__all__ = ["DaskLogs", "quiet_cancel_race"]

#: The loggers Dask writes to (each with its own stderr handler where Dask configured them).
_LOGGERS = ("distributed", "tornado")


def _one_line(text: str) -> str:
    return (text.strip().splitlines() or [""])[0][:200]


def _said(exc: BaseException) -> str:
    """``exc`` in one line: its type and message; one without a message (a MemoryError from
    a Dask configuration value a worker cannot use) names where it was raised instead."""
    if str(exc).strip():
        return _one_line(f"{type(exc).__name__}: {exc}")
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return type(exc).__name__
    file = "/".join(Path(frames[-1].filename).parts[-2:])  # distributed/worker_memory.py
    return f"{type(exc).__name__} (raised in {file} line {frames[-1].lineno})"


class DaskLogs(logging.Filter):
    """A filter on the handlers of Dask's loggers, from `hold` to `release`: drops records
    below CRITICAL and keeps the first exception Dask logged at ERROR for `cause`."""

    def __init__(self) -> None:
        super().__init__()
        self._exception: str | None = None  # the first exception logged at ERROR
        self._handlers: list[logging.Handler] = []

    def filter(self, record: logging.LogRecord) -> bool:
        ours = record.name.split(".")[0] in _LOGGERS
        if not ours or record.levelno >= logging.CRITICAL:
            return True
        if record.levelno >= logging.ERROR:
            exc = record.exc_info[1] if record.exc_info else None
            if exc is not None and self._exception is None and record.name.startswith("dist"):
                self._exception = _said(exc)
        return False

    def hold(self) -> DaskLogs:
        """Start holding the records back (idempotent): on the handlers of Dask's logger, and
        on the root logger's where Dask's records reach them (Dask configures its own handler
        only where the root logger has none)."""
        handlers: list[logging.Handler] = []
        for name in (*_LOGGERS, "tornado.application"):
            logger = logging.getLogger(name)
            handlers += logger.handlers
            if logger.propagate:
                handlers += logging.getLogger().handlers
        for handler in handlers:
            if self not in handler.filters:
                handler.addFilter(self)
                self._handlers.append(handler)
        return self

    def release(self) -> None:
        """Let Dask's records through again."""
        for handler in self._handlers:
            handler.removeFilter(self)
        self._handlers.clear()

    def cause(self) -> str:
        """``"; first error: ..."`` to add to a one-line message, or "" when none was seen."""
        return f"; first error: {self._exception}" if self._exception else ""


class _CancelRace(logging.Filter):
    """Drops one log record of an upstream race: when Ctrl-C lands inside distributed's
    ``sync`` before its future exists, the event loop's ``cancel`` callback raises NameError
    ("free variable 'future'"), which tornado logs with a traceback. After an interrupt that
    is noise: the run already says it was interrupted and how to resume it."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not (isinstance(exc, NameError) and "'future'" in str(exc))


class _ClosedClientCancel(logging.Filter):
    """Drops the traceback of a cancel sent to a closed client: once the scheduler is gone
    for good the client closes itself, and cancelling each of the run's futures as it stops
    makes distributed's callback raise ``ClosedClientError`` (logged by concurrent.futures,
    one traceback per future), although there is nothing left to cancel."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return type(exc).__name__ != "ClosedClientError"


def quiet_cancel_race() -> None:
    """Install `_CancelRace` on tornado's callback logger and `_ClosedClientCancel` on
    concurrent.futures', once per process."""
    for name, kind in (
        ("tornado.application", _CancelRace),
        ("concurrent.futures", _ClosedClientCancel),
    ):
        logger = logging.getLogger(name)
        if not any(isinstance(f, kind) for f in logger.filters):
            logger.addFilter(kind())
