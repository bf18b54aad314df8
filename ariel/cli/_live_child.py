"""The live view's child process (`ariel.cli._live`): ``python -m ariel.cli._live_child FOLDER
MARKER SINCE COMMAND...`` waits until ``FOLDER/MARKER`` was written at ``SINCE`` (a time) or
later, then becomes ``COMMAND`` (``exec``), the watcher.

A module of its own, which nothing imports: ``python -m`` runs it after importing `ariel.cli`,
which imports `ariel.cli._live` (runpy warns about a module run that was imported first).
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

_WAIT_S = 0.1  # how often the waiting child looks for the folder


def _wait_then_watch(argv: Sequence[str]) -> int:
    """The child: ``FOLDER MARKER SINCE COMMAND...``; wait until ``FOLDER/MARKER`` was
    written at ``SINCE`` (a time) or later, then become ``COMMAND``."""
    folder, marker, since, *command = argv
    path = Path(folder) / marker
    try:
        while True:
            with contextlib.suppress(OSError):
                if path.stat().st_mtime >= float(since):
                    break
            time.sleep(_WAIT_S)
    except KeyboardInterrupt:  # Ctrl-C before the folder was made: nothing to show
        return 130
    sys.stdout.flush()
    os.execv(command[0], command)
    return 0  # pragma: no cover - execv does not return


if __name__ == "__main__":
    sys.exit(_wait_then_watch(sys.argv[1:]))
