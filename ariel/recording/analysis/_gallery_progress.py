"""How far a gallery's drawing is: thumbnails drawn of those to draw.

Drawing a thumbnail takes ~25 ms a process, so a few hundred take a while. On a terminal (or
in a notebook) a rich bar counts them, with the time left, and is gone when they are drawn;
elsewhere (a pipe, a log) a line is printed at the start and at every tenth, and only for a
batch worth waiting for (`LINES_FROM`), so a small gallery's output stays as it was.
"""

from __future__ import annotations

import sys
from typing import TextIO

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeRemainingColumn,
)

from ariel.evolution import shows_progress
from ariel.utils import is_terminal

__all__ = ["LINES_FROM", "ThumbnailProgress"]

#: The fewest thumbnails to draw for which a pipe gets progress lines (~2 s of drawing).
LINES_FROM = 64


class ThumbnailProgress:
    """``with ThumbnailProgress(total, workers=N, show=...) as progress: progress.advance(n)``.

    ``show``: True shows it (on ``stream``, stdout by default), False prints nothing, None
    shows it only where someone watches (`ariel.evolution.shows_progress`).
    """

    def __init__(
        self, total: int, *, workers: int, show: bool | None, stream: TextIO | None = None
    ) -> None:
        self.total, self.workers, self.done = total, workers, 0
        self.stream = stream if stream is not None else sys.stdout
        self.show = shows_progress(show)
        self._bar: Progress | None = None  # started on a terminal
        self._next_line = 0  # the count at which a pipe gets its next line

    def _terminal(self) -> bool:
        return is_terminal(self.stream)

    def __enter__(self) -> ThumbnailProgress:
        if not self.show or not self.total:
            return self
        if self._terminal() or (self.stream is sys.stdout and shows_progress(None)):
            self._bar = Progress(
                TextColumn("drawing thumbnails"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeRemainingColumn(),
                console=Console(file=self.stream),
                transient=True,  # the command's own lines follow
            )
            self._bar.start()
            self._task = self._bar.add_task("thumbnails", total=self.total)
        elif self.total >= LINES_FROM:
            processes = f"{self.workers} process{'es' if self.workers > 1 else ''}"
            self._line(f"drawing {self.total} thumbnails ({processes})")
            self._next_line = max(1, self.total // 10)
        return self

    def advance(self, count: int) -> None:
        """``count`` more thumbnails drawn (or given up on)."""
        self.done += count
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done)
        elif self._next_line and self.done >= self._next_line and self.done < self.total:
            self._line(f"thumbnails: {self.done}/{self.total} drawn")
            step = max(1, self.total // 10)
            self._next_line = (self.done // step + 1) * step

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None

    def _line(self, text: str) -> None:
        print(text, file=self.stream, flush=True)
