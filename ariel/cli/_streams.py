"""The command's standard output, made safe for the command: what it prints is not its data.

- A closed stdout or stderr (``ariel run >&-``) reads as ``os.devnull``, not as None (which
  crashed the progress display before the run began).
- A character stdout's encoding cannot hold (a folder named ``é`` under ``LC_ALL=C``) is
  written escaped (``\\xe9``), as Python writes stderr, rather than ending the command.
- A stdout that fails (a full device, an I/O error) does not stop the command: a run goes on
  to its end, its records whole; what was printed is lost, and the command ends with one line
  that says so (`Output.lost`), never blaming the run folder for stdout's disk.
- A reader that went away (``ariel runs | head``, ``ariel run | head -1``) stops the command
  as SIGPIPE would, as an interrupt (`Interrupted`): a listing ends quietly (exit 141), a run
  or campaign ends ``interrupted``, resumable, saying so on stderr (it ended ``failed``).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

from ariel.utils import MIN_OPEN_FILES, open_files_short
from ariel.utils.interrupts import Interrupted, stop_soon

__all__ = ["Output", "cwd_problem", "lost_output_line", "open_files_problem", "standard_output"]


class Output:
    """``sys.stdout`` while a command runs: writes pass through until one fails, then go
    nowhere; the first failure is kept in ``lost``."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self.lost: OSError | None = None
        self._reader_gone = False

    def write(self, text: str) -> int:
        self._guarded(self._stream.write, text)
        return len(text)

    def flush(self) -> None:
        self._guarded(self._stream.flush)

    def _guarded(self, call: Any, *args: object) -> None:
        if self.lost is not None or self._reader_gone:
            return
        try:
            call(*args)
        except BrokenPipeError:
            self._reader_gone = True
            self._to_nowhere()
            stop_soon(signal.SIGPIPE)  # met in a display's thread: the run stops at its next
            if threading.current_thread() is threading.main_thread():
                raise Interrupted(signal.SIGPIPE) from None
        except OSError as exc:
            self.lost = exc
            self._to_nowhere()

    def _to_nowhere(self) -> None:
        """What stays in the stream's buffer would fail again at exit ("Exception ignored ...
        OSError"): from now on the descriptor writes to nowhere."""
        with contextlib.suppress(OSError, ValueError, AttributeError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)

    def __getattr__(self, name: str) -> Any:  # isatty, fileno, encoding, buffer, ...
        return getattr(self._stream, name)


@contextlib.contextmanager
def standard_output() -> Iterator[Output]:
    """``sys.stdout`` as an `Output` for the ``with`` block (closed streams as ``os.devnull``,
    characters its encoding lacks escaped), the stream before it restored after."""
    for name in ("stdout", "stderr"):
        if getattr(sys, name) is None:
            setattr(sys, name, open(os.devnull, "w"))  # noqa: SIM115 - kept for the process
    before = sys.stdout
    with contextlib.suppress(AttributeError, ValueError, OSError):
        before.reconfigure(errors="backslashreplace")  # pyright: ignore[reportAttributeAccessIssue]
    output = Output(before)
    sys.stdout = output  # pyright: ignore[reportAttributeAccessIssue]
    try:
        yield output
        output.flush()
    finally:
        sys.stdout = before


def lost_output_line(exc: OSError) -> str:
    """The one line for a stdout that failed: what the command printed is lost (its files are
    not: they are written elsewhere)."""
    why = exc.strerror or type(exc).__name__
    return (
        f"cannot write to standard output: {why}; what the command printed there is lost "
        "(send it to a file with room, or pass --quiet where the command takes it)"
    )


def cwd_problem() -> str | None:
    """The line for a current folder that no longer exists (deleted while a shell stood in it),
    where relative paths, and libraries that make paths absolute, fail; None when it exists."""
    try:
        os.getcwd()
    except OSError as exc:
        return (
            f"the current folder cannot be used ({exc.strerror}: deleted, or not readable): "
            "cd to another folder and run the command again"
        )
    return None


def open_files_problem() -> str | None:
    """The line for a process that may open fewer files than any command needs (``ulimit -n``
    below `MIN_OPEN_FILES`, its hard limit too: Rerun's import alone aborted the process
    with a 170-line panic); None where it may (the soft limit raised where it was lower)."""
    most = open_files_short(MIN_OPEN_FILES)
    if most is None:
        return None
    return (
        f"this process may open only {most} files at once (ulimit -n); ariel needs at least "
        f"{MIN_OPEN_FILES}: raise the limit (ulimit -n {MIN_OPEN_FILES * 4}) and run again"
    )
