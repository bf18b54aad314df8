"""Progress of a run: a live rich display on a terminal, one line per generation otherwise."""

from __future__ import annotations

import math
import sys
import time
from typing import Any, TextIO

__all__ = ["Progress"]


def _fmt(value: float) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.4g}"


class Progress:
    """Generation, evaluations done / total, best and mean fitness, evaluations/s, ETA.

    ``live=None`` picks the rich display when ``stream`` is a terminal; ``enabled=False``
    prints nothing (library use, tests).
    """

    def __init__(
        self,
        *,
        total: int,
        done: int = 0,
        enabled: bool = True,
        live: bool | None = None,
        stream: TextIO | None = None,
    ) -> None:
        self.total = total
        self.done = done
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stdout
        self.live = enabled and (self.stream.isatty() if live is None else live)
        self._start = time.perf_counter()
        self._start_done = done
        self._generation = 0
        self._best = math.nan
        self._mean = math.nan
        self._rich: Any = None
        self._task: Any = None

    def __enter__(self) -> Progress:
        if self.live:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.progress import Progress as RichProgress

            self._rich = RichProgress(
                TextColumn("gen {task.fields[generation]}"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("best {task.fields[best]}  mean {task.fields[mean]}"),
                TextColumn("{task.fields[rate]} eval/s"),
                TimeElapsedColumn(),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                console=Console(file=self.stream),
                transient=False,
            )
            self._rich.__enter__()
            self._task = self._rich.add_task(
                "run", total=self.total, completed=self.done, **self._fields()
            )
        return self

    def __exit__(self, *exc: object) -> None:
        if self._rich is not None:
            self._rich.__exit__(*exc)
            self._rich = None

    def rate(self) -> float:
        elapsed = time.perf_counter() - self._start
        return (self.done - self._start_done) / elapsed if elapsed > 0 else 0.0

    def _fields(self) -> dict[str, str]:
        return {
            "generation": str(self._generation),
            "best": _fmt(self._best),
            "mean": _fmt(self._mean),
            "rate": f"{self.rate():.1f}",
        }

    def start_generation(self, generation: int) -> None:
        self._generation = generation
        if self._rich is not None:
            self._rich.update(self._task, **self._fields())

    def advance(self, evaluations: int, best: float | None = None) -> None:
        self.done += evaluations
        if best is not None and not math.isnan(best):
            self._best = best
        if self._rich is not None:
            self._rich.update(self._task, completed=self.done, **self._fields())

    def end_generation(self, generation: int, best: float, mean: float, extra: str = "") -> None:
        self._best, self._mean = best, mean
        if self._rich is not None:
            self._rich.update(self._task, completed=self.done, **self._fields())
            self._rich.console.print(self._line(generation, extra))
        elif self.enabled:
            print(self._line(generation, extra), file=self.stream, flush=True)

    def _line(self, generation: int, extra: str) -> str:
        rate = self.rate()
        left = self.total - self.done
        eta = f"{left / rate:.0f}s" if rate > 0 else "-"
        return (
            f"gen {generation}: evaluations {self.done}/{self.total}, best {_fmt(self._best)}, "
            f"mean {_fmt(self._mean)}, {rate:.1f} eval/s, ETA {eta}{extra}"
        )
