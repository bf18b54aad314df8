"""Progress of a run: a live rich display on a terminal, one line per generation otherwise.

On a terminal two bars update as batches finish: this generation's evaluations done / total
with evaluations/s and its ETA, and the whole run's. Elsewhere (a pipe, a log file) one line is
printed per finished generation. The generation's line also says, in a co-evolution run, how
many distinct bodies the population after selection holds (``morphs 5/8``: distinct robot
graphs / bodies), and in a MAP-Elites run the archive's coverage, QD-score and normalised
QD-score (``ariel.evolution._map_elites``), the numbers ``load_run(...).generations`` has (a
novelty search run: those of its result archive, and its novelty archive's size and the
population's mean novelty, ``ariel.evolution._novelty``).
Its ``mean`` is the population's mean fitness after selection; in a brain-only run, whose
population is the one fixed body, it is the mean of the generation's CMA-ES candidates
(``mean of candidates``, the finite fitnesses of the generation's evaluations), as `ariel
report` draws it.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Mapping
from typing import Any, TextIO

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress as RichProgress,
    TaskID,
    TextColumn,
)
from rich.table import Column

from ariel.evolution._events import (
    BatchEvaluated,
    BodyFailed,
    CheckpointDue,
    GenerationStarted,
    RunEvent,
)
from ariel.utils import in_notebook_kernel, is_terminal

__all__ = [
    "Progress",
    "auto_progress",
    "eta_text",
    "fmt_value",
    "live_bars",
    "shows_progress",
]


def shows_progress(progress: bool | None) -> bool:
    """Whether a run shows its progress: ``progress`` as given, or for None (the default of
    `run_experiment` and its kin) `auto_progress`."""
    return auto_progress() if progress is None else bool(progress)


def auto_progress() -> bool:
    """Whether someone is watching: stdout or stderr is a terminal, or this is a Jupyter
    (IPython) kernel, whose streams are none. Not in a pipe, a batch job's log or pytest."""
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None and stream.isatty():
                return True
        except (AttributeError, ValueError):  # a stand-in stream without isatty, or closed
            continue
    return in_notebook_kernel()


def live_bars(stream: TextIO, label: str, *texts: str) -> RichProgress:
    """A started rich display of bars on ``stream``: each row ``label``, its bar, done /
    total, then ``texts`` and the task's ``info`` field."""
    console = Console(file=stream)
    # Narrower than the whole line (80 columns), rich shrank every column alike and the bar and
    # the counts vanished: they keep their width, the bar narrows first, the info is cut at
    # its end.
    width = console.width
    bar = max(10, min(40, width - 110))
    display = RichProgress(
        TextColumn(label, table_column=Column(no_wrap=True)),
        BarColumn(bar_width=bar, table_column=Column(no_wrap=True)),
        MofNCompleteColumn(table_column=Column(no_wrap=True)),
        *(TextColumn(text, table_column=Column(no_wrap=True)) for text in texts),
        TextColumn(
            "{task.fields[info]}",
            table_column=Column(
                no_wrap=True, overflow="ellipsis", max_width=max(12, width - 52 - bar)
            ),
        ),
        console=console,
        transient=False,
    )
    display.__enter__()
    return display


def fmt_value(value: float) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.4g}"


def eta_text(left: int, rate: float) -> str:
    if left <= 0:
        return "0s"
    if rate <= 0:
        return "-"
    seconds = round(left / rate)
    minutes, seconds = divmod(seconds, 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"{hours}h{minutes:02d}m"
    return f"{minutes}m{seconds:02d}s" if minutes else f"{seconds}s"


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
        self.live = enabled and (is_terminal(self.stream) if live is None else live)
        self._start = time.perf_counter()
        self._start_done = done
        self._generation = 0
        self._generation_total: int | None = None
        self._generation_start = self._start
        self._generation_start_done = done
        self._steady_start: float | None = None  # when the first batch came back
        self._steady_done = done
        self._best = math.nan
        self._mean = math.nan
        self._mean_label = "mean"
        self._population = ""  # morphs and archive of the last generation's line
        # Any: a `RichProgress` (or None) whose add_task / update take this module's fields as
        # **mappings, which rich's signatures (refresh: bool, ...) cannot be checked against
        self._rich: Any = None
        self._run_task: TaskID | None = None
        self._generation_task: TaskID | None = None

    def __enter__(self) -> Progress:
        if self.live:
            self._rich = live_bars(
                self.stream,
                "{task.description:>10}",
                "{task.fields[rate]:>7} eval/s  ETA {task.fields[eta]:>7}",
            )
            self._generation_task = self._rich.add_task("gen -", total=None, **self._gen_fields())
            self._run_task = self._rich.add_task(
                "run", total=self.total, completed=self.done, **self._run_fields()
            )
        return self

    def __exit__(self, *exc: object) -> None:
        if self._rich is not None:
            self._rich.__exit__(*exc)
            self._rich = None

    # -- rates -----------------------------------------------------------------------------

    def rate(self) -> float:
        """Evaluations per second since this process started the run (or resumed it)."""
        elapsed = time.perf_counter() - self._start
        return (self.done - self._start_done) / elapsed if elapsed > 0 else 0.0

    @property
    def generation_done(self) -> int:
        """Evaluations done (or skipped, for failed bodies) in the current generation."""
        return self.done - self._generation_start_done

    def steady_rate(self) -> float:
        """Evaluations per second since the first batch came back (0 before a second one):
        what the ETAs use. Counted from the start, the workers' start-up and the first
        compilations made the first minutes' ETA several times too long (1h19m for 12 min)."""
        if self._steady_start is None or self.done == self._steady_done:
            return 0.0
        elapsed = time.perf_counter() - self._steady_start
        return (self.done - self._steady_done) / elapsed if elapsed > 0 else 0.0

    def generation_rate(self) -> float:
        elapsed = time.perf_counter() - self._generation_start
        return self.generation_done / elapsed if elapsed > 0 else 0.0

    def _gen_fields(self) -> dict[str, str]:
        rate, steady = self.generation_rate(), self.steady_rate()
        total = self._generation_total
        return {
            "rate": f"{rate:.1f}",
            "eta": eta_text(total - self.generation_done, steady) if total is not None else "-",
            "info": "",
        }

    def _run_fields(self) -> dict[str, str]:
        rate = self.rate()
        return {
            "rate": f"{rate:.1f}",
            "eta": eta_text(self.total - self.done, self.steady_rate()),
            "info": f"best {fmt_value(self._best)}  {self._mean_label} {fmt_value(self._mean)}"
            + self._population.replace(", ", "  "),
        }

    def _refresh(self) -> None:
        if self._rich is None:
            return
        self._rich.update(
            self._generation_task,
            description=f"gen {self._generation}",
            total=self._generation_total,
            completed=self.generation_done,
            **self._gen_fields(),
        )
        self._rich.update(self._run_task, completed=self.done, **self._run_fields())

    # -- what the driver says (a `RunObserver`) ----------------------------------------------

    def notify(self, event: RunEvent) -> None:
        """Draw the run's events as they come; the end of a generation is its line."""
        if isinstance(event, GenerationStarted):
            self.start_generation(event.generation, event.evaluations)
        elif isinstance(event, BatchEvaluated):
            self.advance(event.counted, event.best)
        elif isinstance(event, BodyFailed):
            self.advance(event.counted)
        elif isinstance(event, CheckpointDue):
            self.end_generation(
                event.generation,
                event.best,
                event.mean,
                "".join(f", {n} {status}" for status, n in event.failures.items()),
                morphs=event.morphs,
                archive=event.archive_stats,
                mean_label=event.mean_label,
            )

    def start_generation(self, generation: int, evaluations: int | None = None) -> None:
        """A generation starts; ``evaluations``: how many it will make (its bar's total)."""
        self._generation = generation
        self._generation_total = evaluations
        self._generation_start = time.perf_counter()
        self._generation_start_done = self.done
        self._refresh()

    def advance(self, evaluations: int, best: float | None = None) -> None:
        self.done += evaluations
        if self._steady_start is None and evaluations:
            self._steady_start, self._steady_done = time.perf_counter(), self.done
        if best is not None and not math.isnan(best):
            self._best = best
        self._refresh()

    def end_generation(
        self,
        generation: int,
        best: float,
        mean: float,
        extra: str = "",
        *,
        morphs: tuple[int, int] | None = None,
        archive: Mapping[str, float] | None = None,
        mean_label: str = "mean",
    ) -> None:
        """The generation's line. ``morphs``: (distinct bodies, bodies) of the population after
        selection; ``archive``: a MAP-Elites archive's ``coverage``, ``qd_score``,
        ``norm_qd_score`` (and ``filled`` / ``cells``); ``extra``: appended as it is;
        ``mean_label``: what ``mean`` is the mean of (``mean of candidates``)."""
        self._best, self._mean, self._mean_label = best, mean, mean_label
        self._population = population_text(morphs, archive)
        if self._rich is not None:
            self._refresh()
            self._rich.console.print(self._line(generation, extra))
        elif self.enabled:
            print(self._line(generation, extra), file=self.stream, flush=True)

    def _line(self, generation: int, extra: str) -> str:
        rate = self.rate()
        left, steady = self.total - self.done, self.steady_rate() or rate
        eta = f"{left / steady:.0f}s" if steady > 0 else "-"
        return (
            f"gen {generation}: evaluations {self.done}/{self.total}, "
            f"best {fmt_value(self._best)}, {self._mean_label} {fmt_value(self._mean)}"
            f"{self._population}, "
            f"{rate:.1f} eval/s, ETA {eta}{extra}"
        )


def population_text(morphs: tuple[int, int] | None, archive: Mapping[str, float] | None) -> str:
    """``, morphs 5/8, coverage 22% (14/64), qd_score 3.41, norm_qd_score 0.0533`` (the parts
    given; novelty search adds ``, novelty archive 37, mean novelty 0.214``)."""
    text = ""
    if morphs is not None:
        text += f", morphs {morphs[0]}/{morphs[1]}"
    if archive is not None:
        counted = {"filled", "cells"} <= archive.keys()
        cells = f" ({archive['filled']:.0f}/{archive['cells']:.0f})" if counted else ""
        coverage = float(archive.get("coverage", math.nan))
        share = f"{coverage:.0%}" if math.isfinite(coverage) else "-"
        text += (
            f", coverage {share}{cells}, "
            f"qd_score {fmt_value(archive.get('qd_score', math.nan))}, "
            f"norm_qd_score {fmt_value(archive.get('norm_qd_score', math.nan))}"
        )
        if "novelty_archive" in archive:  # novelty search: its novelty archive, too
            text += (
                f", novelty archive {archive['novelty_archive']:.0f}, "
                f"mean novelty {fmt_value(archive.get('mean_novelty', math.nan))}"
            )
    return text
