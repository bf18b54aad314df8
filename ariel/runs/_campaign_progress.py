"""A campaign's progress: one campaign-wide line, each run's generations as detail under it.

The runs of a campaign interleave on one executor, so a run's own evaluations/s and ETA say
little (each run gets a changing share of the workers). What a researcher watches is the
campaign: evaluations done / total, evaluations/s and the ETA of the whole campaign, and runs
finished. On a terminal that is a live bar, with each run's finished generation printed above
it; elsewhere (a pipe, a batch job's log) the campaign line is printed at the start, then
whenever ``interval`` seconds have passed since the last one (even while no generation ends,
as in the long first generation when every run's bodies are being evaluated side by side), and
at the end, each run's generation lines indented under it.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

from ariel.evolution import Progress, RunEnded, RunEvent, eta_text, fmt_value, live_bars
from ariel.utils import is_terminal

__all__ = ["CampaignProgress", "RunProgress"]


class CampaignProgress:
    """Evaluations done / total over every run of a campaign; see the module docstring.
    ``enabled=False`` prints nothing; ``live=None`` picks the live bar on a terminal."""

    def __init__(
        self,
        *,
        runs: int,
        total: int,
        done: int = 0,
        enabled: bool = True,
        live: bool | None = None,
        stream: TextIO | None = None,
        interval: float = 30.0,
    ) -> None:
        self.runs, self.total, self.done, self.finished = runs, total, done, 0
        self.enabled, self.interval = enabled, interval
        self.stream = stream if stream is not None else sys.stdout
        self.live = enabled and (is_terminal(self.stream) if live is None else live)
        self._start, self._start_done = time.perf_counter(), done
        self._last_line = -float("inf")
        self._rich: Any = None
        self._task: Any = None

    def __enter__(self) -> CampaignProgress:
        if self.live:
            self._rich = live_bars(self.stream, "campaign")
            self._task = self._rich.add_task("campaign", total=self.total, info=self._info())
        elif self.enabled:
            self._print_line()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._rich is not None:
            self._rich.__exit__(*exc)
            self._rich = None
        elif self.enabled and exc[0] is None:
            self._print_line()

    def restart(self) -> None:
        """Count from here: what is done now (an earlier call's evaluations, on resume) is not
        part of this call's evaluations/s."""
        self._start, self._start_done = time.perf_counter(), self.done

    def rate(self) -> float:
        """Evaluations per second over the whole campaign since this process started it."""
        elapsed = time.perf_counter() - self._start
        return (self.done - self._start_done) / elapsed if elapsed > 0 else 0.0

    def _info(self) -> str:
        rate = self.rate()
        return (
            f"runs finished {self.finished}/{self.runs}, {rate:.1f} eval/s, "
            f"ETA {eta_text(self.total - self.done, rate)}"
        )

    def line(self) -> str:
        """``campaign: evaluations 1200/115200 (1%), runs finished 0/30, 9.1 eval/s, ETA 3h29m``."""
        share = self.done / self.total if self.total else 1.0
        return f"campaign: evaluations {self.done}/{self.total} ({share:.0%}), {self._info()}"

    def _print_line(self) -> None:
        self._last_line = time.perf_counter()
        print(self.line(), file=self.stream, flush=True)

    def _due(self) -> bool:
        return self.enabled and time.perf_counter() - self._last_line >= self.interval

    def advance(self, evaluations: int) -> None:
        """A run made ``evaluations`` more."""
        self.done += evaluations
        if self._rich is not None:
            self._rich.update(self._task, completed=self.done, info=self._info())
        elif self._due():
            self._print_line()

    def run_finished(self) -> None:
        self.finished += 1
        if self._rich is not None:
            self._rich.update(self._task, info=self._info())

    def detail(self, text: str) -> None:
        """A run's line (a finished generation), under the campaign line."""
        if self._rich is not None:
            self._rich.console.print(f"  {text}", markup=False, highlight=False)
        elif self.enabled:
            if self._due():
                self._print_line()
            print(f"  {text}", file=self.stream, flush=True)


class RunProgress(Progress):
    """A run of a campaign: counts its evaluations as a lone run's `Progress` does and reports
    them to the campaign, and its end (`RunEnded`); its generation lines, prefixed by
    the run's condition and seed, go to the campaign's display without an evaluations/s or
    ETA of their own (never a live display of its own: one per run would fight over the
    terminal)."""

    def __init__(self, *, label: str, campaign: CampaignProgress, **options: Any) -> None:
        super().__init__(**options)
        self.label, self.campaign = label, campaign
        self.live = False
        self.enabled = False  # the base prints nothing; the campaign shows the lines

    def notify(self, event: RunEvent) -> None:
        super().notify(event)
        if isinstance(event, RunEnded):
            self.campaign.run_finished()

    def advance(self, evaluations: int, best: float | None = None) -> None:
        super().advance(evaluations, best)
        self.campaign.advance(evaluations)

    def end_generation(self, generation: int, best: float, mean: float, *args, **kwargs) -> None:
        super().end_generation(generation, best, mean, *args, **kwargs)
        self.campaign.detail(self._line(generation, args[0] if args else kwargs.get("extra", "")))

    def _line(self, generation: int, extra: str) -> str:
        return (
            f"{self.label}: gen {generation}: evaluations {self.done}/{self.total}, "
            f"best {fmt_value(self._best)}, {self._mean_label} {fmt_value(self._mean)}"
            f"{self._population}{extra}"
        )
