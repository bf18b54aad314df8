"""Stopping a run on Ctrl-C, SIGTERM or SIGHUP without losing the signal.

Python turns Ctrl-C into a `KeyboardInterrupt` at whatever line the main thread is running.
When that line belongs to a garbage-collection or weakref callback (Dask registers one), Python
prints "Exception ignored" and carries on: the run would go on to its end as if the key had
never been pressed. So `stop_on_signals` also notes the signal, and the scheduler calls
`raise_pending` between results, which raises it again while it is still noted. Whoever
catches the interrupt (the ``ariel`` command) leaves the ``with`` block, which clears it.

SIGTERM (a batch system, ``kill``) and SIGHUP (a closed terminal or SSH session) stop a run as
Ctrl-C does: status ``interrupted``, the lock released, resumable. Once: a second signal
meanwhile ends the process at once, as Python's own handling of a second Ctrl-C would. A
signal that is ignored or handled by someone else when the run starts is left to them: ``nohup``
ignores SIGHUP (the run must outlive the terminal), a Jupyter kernel handles Ctrl-C, a batch
framework may handle SIGTERM itself.

Some code must not be left midway: a C++ extension that is being imported (torch sets up its
distributed package in C++, and a Python exception raised inside that aborts the whole process
with a C++ dump). `signals_deferred` holds a signal back until such code is done.

`Stopped` is the same kind of stop without a signal: the run cannot go on for a reason outside
it (e.g. its Dask cluster has had no worker for a minute), so it ends as an interrupted one,
resumable, with the reason in its one line.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = [
    "STOPPED_EXIT",
    "Interrupted",
    "Stopped",
    "exit_status",
    "raise_pending",
    "signals_deferred",
    "stop_on_signals",
    "stop_soon",
]

#: Exit status of a run that `Stopped` (EX_TEMPFAIL: a temporary failure; resume it later).
STOPPED_EXIT = 75

_pending: int | None = None  # the signal number taken and not yet acted on
_deferring = 0  # how many `signals_deferred` blocks the main thread is in
_active = False  # whether a `stop_on_signals` block has its handlers installed


class Interrupted(KeyboardInterrupt):
    """The signal ``signum`` stopped the run: raised where Ctrl-C would be."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


class Stopped(KeyboardInterrupt):
    """The run stopped itself: ``reason`` (one line) says why, e.g. no Dask worker for 60 s.

    A `KeyboardInterrupt`, so that it ends a run as Ctrl-C does: status ``interrupted``, the
    lock released, the folder noted for the resume hint, the executor stopped without waiting.
    """

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def exit_status(exc: KeyboardInterrupt) -> tuple[int, str]:
    """The exit code of a stopped run and what to add to the word "interrupted".

    Args:
        exc: The interrupt that stopped the run: an `Interrupted`, a `Stopped`, or a plain
            `KeyboardInterrupt` (taken as Ctrl-C).

    Returns:
        ``(code, suffix)``: the code is 128 + the signal's number (130 for Ctrl-C) or
        `STOPPED_EXIT` for `Stopped`; the suffix is "" for Ctrl-C, e.g. " (SIGTERM)" for
        another signal, and ": <reason>" for `Stopped`.
    """
    if isinstance(exc, Stopped):
        return STOPPED_EXIT, f": {exc.reason}"
    signum = int(exc.signum) if isinstance(exc, Interrupted) else int(signal.SIGINT)
    how = "" if signum == signal.SIGINT else f" ({signal.Signals(signum).name})"
    return 128 + signum, how


def stop_soon(signum: int) -> None:
    """Note ``signum`` as taken, as its handler would, without raising here: where another
    thread than the main one met the stop (a broken pipe as a progress display wrote), the run
    stops at its next `raise_pending`. Outside `stop_on_signals`: nothing.

    Args:
        signum: The signal the stop is said as (``signal.SIGPIPE``: the output's reader went).
    """
    global _pending
    if _active and _pending is None:
        _pending = signum


def raise_pending() -> None:
    """Raise `Interrupted` if a signal was taken and its first raise got lost (or not yet
    acted on): call where stopping is safe, e.g. between results."""
    if _pending is not None:
        raise Interrupted(_pending)


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Within: a stop signal is noted, not raised; leaving the block raises it (`Interrupted`).

    For code that a Python exception must not enter midway, e.g. ``import torch``: a signal
    that arrives during its C++ initialisation would abort the process instead of stopping
    the run. Outside `stop_on_signals` it changes nothing.

    Yields:
        None.

    Raises:
        Interrupted: On leaving, when a signal arrived within (and nothing else was raised).
    """
    global _deferring
    _deferring += 1
    try:
        yield
    finally:
        _deferring -= 1
    if _deferring == 0:
        raise_pending()


def _signals() -> list[signal.Signals]:
    """The stop signals whose handling is still Python's default: Ctrl-C raising
    `KeyboardInterrupt`, SIGTERM and SIGHUP ending the process. Ignored (``nohup``'s SIGHUP) or
    handled by someone else (a Jupyter kernel's Ctrl-C), a signal is left as it is."""
    defaults = [
        (signal.SIGINT, signal.default_int_handler),
        (signal.SIGTERM, signal.SIG_DFL),
        (getattr(signal, "SIGHUP", None), signal.SIG_DFL),
    ]
    return [s for s, default in defaults if s is not None and signal.getsignal(s) == default]


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """Within: SIGINT, SIGTERM and SIGHUP raise `Interrupted` and stay noted until the block
    is left (see the module docstring). Outside the main thread, nothing changes; within
    another such block, neither (the outer one has them).

    Each signal is taken only where its handling is Python's default (`_signals`: not nohup's
    ignored SIGHUP, not a Jupyter kernel's Ctrl-C); SIGHUP only where the platform has it.
    The previous handlers are put back on leaving.

    Yields:
        None, once the handlers are installed.

    Raises:
        Interrupted: Inside the block, when one of the signals arrives.
    """
    global _pending, _active
    if _active or threading.current_thread() is not threading.main_thread():
        yield  # signal dispositions can only be changed from the main thread
        return
    wanted = _signals()

    def interrupt(signum: int, frame: object) -> None:
        global _pending
        _pending = signum
        for number in wanted:  # a second signal: what it would do without us
            default = signal.default_int_handler if number == signal.SIGINT else signal.SIG_DFL
            signal.signal(number, default)
        if _deferring == 0:
            raise Interrupted(signum)  # else `signals_deferred` raises it on leaving

    previous = {number: signal.signal(number, interrupt) for number in wanted}
    _active = True
    try:
        yield
    finally:
        _pending, _active = None, False
        for number, handler in previous.items():
            signal.signal(number, handler)
