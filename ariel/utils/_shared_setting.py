"""A process-wide setting that code changes for a while, from any number of threads at once.

Saving and restoring around each use loses the setting when two threads overlap (thread A
saves X and sets Y; B saves Y; A puts X back; B puts Y back: Y stays for good). Here the first
thread to enter saves and sets it, and the last to leave puts it back.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

__all__ = ["SharedSetting"]

T = TypeVar("T")


class SharedSetting(Generic[T]):
    """``get``/``put`` a process-wide value; `held` sets it to ``value`` while any thread is
    inside (re-entrant too: a nested `held` leaves it set)."""

    def __init__(self, get: Callable[[], T], put: Callable[[T], object], value: T) -> None:
        self._get, self._put, self._value = get, put, value
        self._lock = threading.Lock()
        self._inside = 0
        self._saved: T | None = None

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        with self._lock:
            if self._inside == 0:
                self._saved = self._get()
                self._put(self._value)
            self._inside += 1
        try:
            yield
        finally:
            with self._lock:
                self._inside -= 1
                if self._inside == 0:
                    saved, self._saved = self._saved, None
                    self._put(saved)  # type: ignore[arg-type]  # what _get returned
