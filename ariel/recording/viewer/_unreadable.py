"""A watched run's generation that cannot be read (`Unreadable`): being written, or damaged.

A generation is read once its manifest is there (written after its tables). While the run
runs, one whose tables do not match it yet is being written, or read over a file system that
lags: a later poll finds it whole, and a note says so only when it stays unreadable. Once the
run has ended nothing will change it: it is damage, said in one line (as ``ariel report``
and ``ariel view`` say it), and the watch ends instead of waiting for ever.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ariel.errors import ArielError, DamagedRunError, NotARunError, ViewError
from ariel.recording.store import terminal_text

__all__ = ["NOTE_AFTER_S", "UNREADABLE", "Unreadable", "check_still_there", "missing_manifest"]

#: What reading a generation's tables raises when they are not (yet) what its manifest lists.
UNREADABLE = (NotARunError, OSError)
#: Seconds a running run's generation stays unreadable before a note says so.
NOTE_AFTER_S = 10.0


def _damage(path: Path, generation: int, exc: BaseException) -> ArielError:
    """The one-line error of generation ``generation`` of the ended run in ``path``."""
    if isinstance(exc, ArielError):  # DamagedRunError: the file, and what to do
        return exc
    reason = getattr(exc, "strerror", None) or str(exc).splitlines()[0]
    name = getattr(exc, "filename", None)
    where = f" ({name})" if name else ""
    return DamagedRunError(
        f"run folder {str(path)!r}: generation {generation} cannot be read: {reason}{where}"
    )


def check_still_there(path: Path) -> None:
    """`ViewError` where the watched folder ``path`` is gone: it was polled for ever, without a
    word, once removed or moved."""
    if not path.is_dir():
        raise ViewError(f"{terminal_text(path)} is gone (moved or removed); stopped watching")


def missing_manifest(path: Path, generation: int, done: int) -> DamagedRunError:
    """The one-line error of an ended run whose run.json counts ``done`` generations but
    whose manifest of ``generation`` (below that) is missing."""
    return DamagedRunError(
        f"run folder {str(path)!r} is damaged: manifests/gen-{generation:06d}.json is missing "
        f"(run.json counts {done} generations done); restore the folder from a copy"
    )


class Unreadable:
    """The generations of the run in ``path`` found unreadable, and since when."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._since: dict[int, float] = {}
        self._noted: set[int] = set()

    def meet(self, generation: int, exc: BaseException, *, ended: bool) -> None:
        """Generation ``generation`` could not be read (``exc``): raise its one-line error
        when the run has ended (``ended``), else wait, with a note once it stays so."""
        if ended:
            raise _damage(self.path, generation, exc) from None
        since = self._since.setdefault(generation, time.monotonic())
        if time.monotonic() - since >= NOTE_AFTER_S and generation not in self._noted:
            self._noted.add(generation)
            reason = (str(exc).splitlines() or [type(exc).__name__])[0]
            note = f"ariel: generation {generation} of {self.path} cannot be read yet ({reason})"
            print(terminal_text(f"{note}; waiting for it"), file=sys.stderr, flush=True)
