"""What the report's figures share: a figure (`_figure`, matplotlib's Agg canvas, no pyplot),
its title wrapped to fit (`_title`), the run's id as one line (`_run_title`) and its status
(`run_status`), and writing it
whole into ``RUN_DIR/report/`` (`_save`; a write that fails is one line, `_cannot_write`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ariel.errors import ArielError, RunStorageError
from ariel.recording.store import (
    STOPPED,
    Run,
    RunFolder,
    atomic_write,
    cannot_write,
    figure_label,
    fitted,
    holder_gone,
    one_line,
)
from ariel.utils import ariel_line

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ariel.recording.analysis._report import Report

_DPI = 110


def _figure(width: float, height: float) -> Figure:
    from matplotlib.figure import Figure  # lazy: heavy optional library

    return Figure(figsize=(width, height), dpi=_DPI, layout="constrained")


def _cannot_write(exc: OSError, path: Path, report: Report) -> RunStorageError:
    """A failed write (disk full, read-only, no permission) of the report: one line naming the
    file and why. `atomic_write` leaves no part of the file; the figures written before it
    are whole."""
    elsewhere = (
        f", or write it elsewhere: {ariel_line('report', report.run.path, '--out', 'DIR')}"
        if report.out is None
        else ""
    )
    return RunStorageError(
        f"{cannot_write(exc, path)}; the report is not finished (the run is unchanged): make "
        f"room (or fix the folder), then run {ariel_line(*_report_words(report))} again"
        f"{elsewhere}"
    )


def _report_words(report: Report) -> tuple[object, ...]:
    """The ``ariel`` words that make ``report`` again."""
    out = () if report.out is None else ("--out", report.out)
    return ("report", report.run.path, *out)


#: What matplotlib raises when it lays out or draws values no run writes but a crafted table
#: can hold (a time of 1e308: "arange: cannot compute length"; a position of 1e308: "Axis
#: limits cannot be NaN or Inf").
UNDRAWABLE = (ValueError, OverflowError)


def cannot_draw(name: str, exc: BaseException) -> str:
    """The report's note for figure ``name`` left out because drawing it raised ``exc``."""
    return f"{name}: left out (its values cannot be drawn: {one_line(exc)})"


def _save(figure: Figure, path: Path, report: Report) -> None:
    """Write ``figure`` to ``path``; one that cannot be drawn (`UNDRAWABLE`) is left out with a
    note: matplotlib finds out only when it draws, in ``savefig``."""
    # Never through a link planted in a copied run folder (``report/fitness.png -> ~/x``).
    try:
        atomic_write(
            path,
            lambda temporary: figure.savefig(temporary, dpi=_DPI, format="png"),
            root=report.root,
        )
    except OSError as exc:
        raise _cannot_write(exc, path, report) from exc
    except UNDRAWABLE as exc:
        report.notes.append(cannot_draw(path.name, exc))
        return
    report.figures[path.name] = figure
    report.wrote(path)


def _run_title(run: Run) -> str:
    """The run's id (from run.json: any text) as one line, no control character in it."""
    return one_line(run.info.get("run_id") or run.path.name)


def figure_lines(text: str) -> str:
    """``text`` for a matplotlib title: each of its lines escaped (`figure_label`), the line
    breaks kept."""
    return "\n".join(figure_label(line) for line in text.split("\n"))


def _title(on: Any, text: str, *, fontsize: float = 12, suptitle: bool = False) -> None:
    """A title (of axes ``on``, or ``suptitle`` of figure ``on``) wrapped to fit the width it
    has (`fitted`), so it is never clipped at the figure's edge. Each of its lines is
    escaped (`figure_label`: text from a run folder is any text): a control or bidi character
    is drawn as its escape (``\\x1b``), a ``$`` as a dollar sign, not mathtext, which could
    fail to draw. A name that may hold a line break of its own goes through `one_line`
    first."""
    text = figure_lines(text)
    if suptitle:
        on.suptitle(fitted(text, on.get_figwidth(), fontsize), fontsize=fontsize)
        return
    spec = on.get_subplotspec()  # the axes' share of the figure's width
    share = len(spec.colspan) / spec.get_gridspec().ncols
    on.set_title(fitted(text, on.figure.get_figwidth() * share, fontsize), fontsize=fontsize)


def run_status(run: Run) -> str:
    """run.json's status, `STOPPED` for a "running" run whose process is gone (SIGKILL, out
    of memory), as `ariel runs` says (`holder_gone`); a run that ended while the report was
    drawn (run.json read again: no longer "running") is said so, not called killed."""
    status = str(run.info.get("status", "?"))
    if status != "running" or not holder_gone(run.path):
        return status
    try:
        now = RunFolder(run.path).read_info().get("status")
    except (ArielError, OSError):
        now = None
    ended = now in ("finished", "interrupted", "failed")
    return f"running when read, {now} since" if ended else STOPPED
