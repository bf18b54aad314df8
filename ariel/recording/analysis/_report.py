"""`ariel report`: a per-generation table and PNG figures of a run, from its run folder alone.

Figures go to ``RUN_DIR/report/``: ``fitness.png`` (best / mean / median of the population
after selection per generation, every evaluation as a dot; a brain-only run: the best so far
and the mean of each generation's CMA-ES candidates), ``morphology.png`` (the morphology
descriptors of the population after selection, `Run.population`, per generation; co-evolution
only), ``trajectory.png`` and ``joints.png`` (the best evaluation's core path and every joint's
target and angle, from the trajectories table; joints named by `joint_labels`) and
``best_body.png`` (the best body rendered in its world; skipped where OpenGL is missing;
these three are `_report_best`'s);
``archive.png`` for a MAP-Elites run (`_report_archive`); ``lineage.png``, the ancestry of the
final population as a tree over generations, the best body's ancestry highlighted
(co-evolution only, `_report_lineage`). Axes carry their units and counts
whole-number ticks (`_axes`); titles wrap to fit.
Only finished generations are reported, so a running or killed run reports what it has.

Every figure is made by `_report_figures` (what the figures share), imported only when it is
drawn, and drawn through the Agg canvas without pyplot, so making a report never changes the
caller's matplotlib backend.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.errors import RunStorageError
from ariel.recording import resim
from ariel.recording.analysis._gallery import add_report_gallery
from ariel.recording.analysis._report_best import _body_image, _trajectory_figures
from ariel.recording.analysis._report_figures import (
    _cannot_write,
    _figure,
    _run_title,
    _save,
    _title,
    run_status,
)
from ariel.recording.analysis._report_out import check_report_folder, refuse_if_replaced
from ariel.recording.store import (
    DESCRIPTORS,
    QD_COLUMNS,
    STALE_S,
    Run,
    evaluation_trajectory,
    figure_label,
    fitness_label,
    integer_ticks,
    load_run,
    one_line,
    population_after_selection,
    refuse_symlinks,
    remove_temporaries,
)
from ariel.utils import flag_argument, path_argument

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure
    from rich.text import TextType

__all__ = ["Report", "make_report", "print_report"]

#: The table's columns: ``Run.generations`` column -> heading.
TABLE_COLUMNS = {
    "generation": "generation",
    "evaluations": "evaluations",
    "best_fitness": "best",
    "mean_fitness": "mean",
    "median_fitness": "median",
    "errors": "errors",
    "unstable": "unstable",
    "invalid": "invalid",
}
#: The population `morphology.png` shows (the notebooks' morphology figure says the same).
MORPHOLOGY_TITLE = "morphology of the population after selection, per generation"
#: Most generations morphology.png draws a box for (evenly spread over longer runs).
MORPHOLOGY_BOXES = 40


@dataclass
class Report:
    """What `make_report` found and wrote.

    Attributes:
        run: the loaded run.
        table: one row per finished generation (``TABLE_COLUMNS``; a MAP-Elites run also
            ``coverage``, ``qd_score``, ``norm_qd_score``, printed as a second table).
        best: the best evaluation's row (a dict), or None before any finite fitness.
        written: the files written, in order: the PNG figures, and the final population's
            gallery (``gallery.png``, ``gallery.html``: `ariel gallery`).
        notes: one line per figure left out, and why.
        figures: file name (``fitness.png``) -> its matplotlib `Figure`, to show or restyle.
        announce: told a line as drawing starts and as each file is written (`make_report`'s),
            or None.
        out: the folder written to where it is not the run's own ``report/`` (`make_report`'s
            ``out``), or None.
    """

    run: Run
    table: pd.DataFrame
    best: dict[str, Any] | None
    written: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    figures: dict[str, Figure] = field(default_factory=dict, repr=False)
    announce: Callable[[str], None] | None = field(default=None, repr=False)
    out: Path | None = field(default=None, repr=False)

    def __repr__(self) -> str:  # one line, as Run's (a notebook cell's last value)
        notes = f", {len(self.notes)} notes" if self.notes else ""
        return (
            f"<Report of {self.run.path.name}: {len(self.table)} generations, "
            f"{len(self.written)} files written in {self.folder}{notes}>"
        )

    def wrote(self, path: Path) -> None:
        """Add ``path`` to the files written, and say so (``announce``)."""
        self.written.append(path)
        if self.announce is not None:
            self.announce(f"wrote {one_line(path)}")

    @property
    def folder(self) -> Path:
        return self.out if self.out is not None else self.run.path / "report"

    @property
    def root(self) -> Path:
        """The folder nothing is written outside of, or through a link below: the run's, or
        ``out``."""
        return self.out if self.out is not None else self.run.path


#: The heading of the archive's table, by optimizer, and what a line under it says: novelty
#: search keeps two archives, and the table is about the grid every body also goes to
#: (`ariel.evolution._novelty`), not the novelty archive that selection uses.
ARCHIVE_HEADINGS = {
    "map_elites": ("MAP-Elites archive after each generation", ""),
    "novelty": (
        "result archive after each generation",
        "result archive: the best body of each cell of the measures' grid, as MAP-Elites "
        "keeps it (the novelty archive, which selection uses, is another)",
    ),
}


def _best_row(run: Run, maximise: bool) -> dict[str, Any] | None:
    evals = run.evaluations
    ok = evals[evals["fitness"].map(math.isfinite)]
    if not len(ok):
        return None
    index = ok["fitness"].idxmax() if maximise else ok["fitness"].idxmin()
    return evals.loc[index].to_dict()


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------


def _fitness_figure(report: Report, maximise: bool) -> None:
    run, table = report.run, report.table
    fitness_fn = str(run.config.get("task", {}).get("fitness", "fitness"))
    figure = _figure(8, 4.8)
    axes = figure.add_subplot()
    evals = run.evaluations
    finite = evals[evals["fitness"].map(math.isfinite)]
    if len(finite):
        rng = np.random.default_rng(0)  # jitter only, for legibility
        x = finite["generation"].to_numpy() + rng.uniform(-0.15, 0.15, len(finite))
        axes.scatter(x, finite["fitness"], s=6, color="0.7", label="evaluations", zorder=1)
    gens = table["generation"].to_numpy()
    if run.brain_only:
        # One body: the population's best, mean and median are all its best brain so far. The
        # search is in the CMA-ES candidates: their mean per generation.
        candidates = finite.groupby("generation")["fitness"].mean().reindex(gens)
        lines = [
            (candidates.to_numpy(dtype=float), "mean of the generation's CMA-ES candidates", "-s"),
            (table["best_fitness"].to_numpy(dtype=float), "best so far", "-oC2"),
        ]
        title = "fitness of the fixed body's brains (CMA-ES)"
    else:
        lines = [
            (table["mean_fitness"].to_numpy(dtype=float), "mean", "-s"),
            (table["median_fitness"].to_numpy(dtype=float), "median", "--^"),
            # drawn last: on top where the lines meet
            (table["best_fitness"].to_numpy(dtype=float), "best", "-oC2"),
        ]
        title = "fitness of the population after selection"
        if run.body_optimizer == "map_elites":  # its population is the archive; novelty's is not
            title += " (the archive's elites)"
    for values, label, style in lines:
        axes.plot(gens, values, style, label=label, zorder=2)
    axes.set_xlabel("generation")
    integer_ticks(axes.xaxis)
    axes.set_ylabel(figure_label(fitness_label(fitness_fn, maximise)))  # the config's name
    _title(axes, f"{_run_title(run)}: {title}")
    axes.grid(alpha=0.3)
    axes.legend(loc="best")
    _save(figure, report.folder / "fitness.png", report)


def _morphology_figure(report: Report) -> None:

    run = report.run
    if run.brain_only:
        report.notes.append("morphology.png: left out (brain-only run: one fixed body)")
        return
    population = population_after_selection(run.bodies)
    names = [n for n in DESCRIPTOR_NAMES if n in population and population[n].notna().any()]
    if not len(population) or not names:
        report.notes.append("morphology.png: left out (no body with morphology descriptors)")
        return
    gens = sorted(population["generation"].unique())
    if len(gens) > MORPHOLOGY_BOXES:  # 300 boxes merged into black bars and took 90 s
        picked = np.unique(np.round(np.linspace(0, len(gens) - 1, MORPHOLOGY_BOXES)).astype(int))
        report.notes.append(f"morphology.png: {len(picked)} of {len(gens)} generations, spread")
        gens = [gens[i] for i in picked]
    step = (gens[-1] - gens[0]) / max(1, len(gens) - 1) if len(gens) > 1 else 1.0
    by_generation = dict(tuple(population.groupby("generation", sort=False)))
    cols, rows = 4, math.ceil(len(names) / 4)
    figure = _figure(4 * cols, 2.9 * rows)
    _title(figure, f"{_run_title(run)}: {MORPHOLOGY_TITLE}", suptitle=True)
    rng = np.random.default_rng(0)
    for i, name in enumerate(names):
        axes = figure.add_subplot(rows, cols, i + 1)
        values = [by_generation[g][name].dropna().to_numpy(dtype=float) for g in gens]
        axes.boxplot(
            values, positions=gens, widths=0.6 * step, showfliers=False, manage_ticks=False
        )
        jitter = [g + rng.uniform(-0.12, 0.12, v.size) * step for g, v in zip(gens, values)]
        axes.scatter(np.concatenate(jitter), np.concatenate(values), s=8, alpha=0.6, color="C0")
        unit, whole = DESCRIPTORS.get(name, ("", False))
        axes.set_title(name)
        axes.set_xlabel("generation")
        axes.set_ylabel(unit)
        axes.set_xlim(min(gens) - 0.6 * step, max(gens) + 0.6 * step)
        integer_ticks(axes.xaxis)
        if whole:
            integer_ticks(axes.yaxis)
        axes.grid(alpha=0.3)
    _save(figure, report.folder / "morphology.png", report)


# --------------------------------------------------------------------------------------------
# Entry points
# --------------------------------------------------------------------------------------------


def make_report(
    run_dir: str | Path,
    *,
    render: bool = True,
    announce: Callable[[str], None] | None = None,
    out: str | Path | None = None,
) -> Report:
    """Write the report figures of the run in ``run_dir`` to ``RUN_DIR/report/`` (or ``out``).

    A run without a finished generation gets no figures (a note says so); a figure that
    cannot be drawn (no trajectories recorded, no successful evaluation) is left out with a
    note.

    Args:
        run_dir: The run folder.
        render: False leaves out the rendered image of the best body (no OpenGL needed).
        announce: Told a line when drawing starts and one as each file is written (``ariel
            report`` prints them: a report of many generations is not silent), or None.
        out: Another folder for the figures (made where missing), e.g. for a run on a
            read-only disk: new, empty, or an earlier report's (its files are replaced),
            outside every run and campaign folder. None: ``RUN_DIR/report/``.

    Returns:
        What was found and written: the per-generation table, the best evaluation's row,
        the PNG files written, the figures themselves, and a note per figure left out.

    Raises:
        NotARunError: For a folder that is not a run (`DamagedRunError`: one whose tables
            were changed, whose config has a section that is no table, or, with ``render``,
            whose body encoder or world rejects the options its config records).
        UnsafePathError: When a folder on the way to ``report/`` is a symbolic link, or
            ``out`` is one.
        ReportFolderError: For an ``out`` inside a run or campaign folder, a file, or a
            folder holding files a report does not write.
        RunStorageError: When a figure cannot be written (disk full, read-only).
        TypeError: For an argument of the wrong type (``render="no"``: True or False).

    Example:
        ```python
        from ariel.recording import list_runs, make_report

        report = make_report(list_runs()[-1]["path"], render=False)  # a run under data/runs
        print(report.table)
        print([path.name for path in report.written], report.notes)
        ```
    """
    run_dir = path_argument("run_dir", run_dir, function="make_report")
    flag_argument("render", render, function="make_report")
    out = None if out is None else path_argument("out", out, function="make_report")
    folder = None if out is None else check_report_folder(out)
    run = load_run(run_dir)
    resim.check_config(run)  # a section that is no table: one line, before it is read
    missing = resim.missing_plugin(run) if render else None
    if render and missing is None:  # drawing a body makes its encoder and world
        resim.check_options(run, resim.BODY_PLUGINS)
    generations = run.generations
    quality = [c for c in QD_COLUMNS if c in generations.columns]  # a MAP-Elites run
    table = generations[[*TABLE_COLUMNS, *quality]]
    maximise = run.maximise if len(run.evaluations) else True
    best = _best_row(run, maximise)
    report = Report(run=run, table=table, best=best, announce=announce, out=folder)
    if missing is not None:  # the tables' figures need no plugin: drawn, the bodies left out
        report.notes.append(f"rendering off: {missing}, which draws the run's bodies")
        render = False
    if not len(table):
        report.notes.append("no finished generation yet: no figures")
        return report
    refuse_symlinks(report.folder / "fitness.png", report.root)
    made = not report.folder.exists()
    try:
        report.folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _cannot_write(exc, report.folder, report) from exc
    try:
        _fill(report, run, run_dir, maximise, render)
    except BaseException:  # Ctrl-C before the first figure left an empty report/ behind
        if made:
            with contextlib.suppress(OSError):
                report.folder.rmdir()  # only where nothing was written (it must be empty)
        raise
    return report


def _fill(report: Report, run: Run, run_dir: object, maximise: bool, render: bool) -> None:
    """`make_report`'s drawing into its folder (made): a killed one's temporaries removed,
    every figure drawn, and the run checked to be the one drawn."""
    # A killed report's temporaries (another report of the run may be writing its own now).
    list(remove_temporaries(report.folder, older_than_s=STALE_S, deep=False))
    if report.announce is not None:
        count = f"{len(report.table)} generation{'s' * (len(report.table) != 1)}"
        report.announce(f"drawing the report of {one_line(run_dir)} ({count})")
    try:
        _draw(report, maximise, render)
    except RunStorageError:  # e.g. report/ gone: the folder replaced by a new run meanwhile?
        refuse_if_replaced(run)
        raise
    refuse_if_replaced(run)
    report.announce = None  # told while drawing only: the report returned says nothing more


def _draw(report: Report, maximise: bool, render: bool) -> None:
    """Every figure of ``report`` (`make_report`'s), each written whole or left out with a
    note."""
    run = report.run
    # lazy: they import matplotlib, PIL and scipy at their tops (a report being drawn)
    from ariel.recording.analysis import _report_archive, _report_lineage

    _fitness_figure(report, maximise)
    _morphology_figure(report)
    _report_archive.archive_figure(report, maximise, render=render, figure=_figure, save=_save)
    _report_lineage.lineage_figure(report, maximise, figure=_figure, save=_save, render=render)
    add_report_gallery(report, render)
    if report.best is None:
        report.notes.append("trajectory.png, joints.png, best_body.png: no evaluation succeeded")
        return
    frames = evaluation_trajectory(run, report.best)
    if frames is None or not len(frames):
        report.notes.append(
            "trajectory.png, joints.png: left out (the run kept no trajectories: "
            "record.trajectories = false)"
        )
    else:
        _trajectory_figures(report, frames)
    if render:
        _body_image(report)
    else:
        report.notes.append("best_body.png: left out (rendering off)")


def _table(title: TextType) -> Table:
    return Table(
        title=title,
        box=box.SIMPLE_HEAD,
        show_edge=False,
        pad_edge=False,
        padding=(0, 1, 0, 0),  # fits 80 columns
    )


def _print_archive_table(report: Report, console: Console) -> None:
    """Per generation: the archive's coverage, QD-score and normalised QD-score."""
    offset = report.run.qd_offset
    heading, said = ARCHIVE_HEADINGS.get(
        report.run.body_optimizer, ("archive after each generation", "")
    )
    table = _table(heading)
    for column in ("generation", *QD_COLUMNS):
        table.add_column(column, justify="right", no_wrap=True, min_width=10)
    for row in report.table[["generation", *QD_COLUMNS]].itertuples(index=False):
        generation, coverage, score, norm = row
        table.add_row(
            str(int(generation)),
            f"{coverage:.1%}",
            *(f"{v:.6g}" if math.isfinite(v) else "-" for v in (score, norm)),
        )
    console.print(table)
    if said:
        console.print(said, highlight=False)
    if offset is None:
        console.print(
            "qd_score: none (a run of a minimised fitness made before run.json recorded its "
            "qd_offset)",
            highlight=False,
        )
    else:
        console.print(
            f"qd_score: the elites' fitness beyond qd_offset {offset:g} (each at least 0), "
            "summed; norm_qd_score: qd_score / cells",
            highlight=False,
        )


def print_report(report: Report, console: Console | None = None, *, written: bool = True) -> None:
    """The per-generation table, the best evaluation, the files written (unless ``written``
    is False: they were announced as they were written) and the notes."""
    if console is None:
        console = Console()
        if not console.is_terminal:  # a file or a pipe: no need to fit 80 columns
            console = Console(width=120)
    run = report.run
    status = run_status(run)
    done, total = run.generations_done, run.config.get("generations", "?")
    title = f"{_run_title(run)}: {one_line(status)}, {done}/{one_line(total)} generations"
    table = _table(Text(title))  # Text: a run id's [bold] is no markup
    for heading in TABLE_COLUMNS.values():
        wide = 10 if heading in ("best", "mean", "median") else len(heading)  # -0.0123456
        table.add_column(heading, justify="right", no_wrap=True, min_width=wide)
    for row in report.table[list(TABLE_COLUMNS)].itertuples(index=False):
        cells = []
        for column, value in zip(TABLE_COLUMNS, row):
            if column.endswith("_fitness"):
                cells.append(f"{value:.6g}" if math.isfinite(value) else "-")
            else:
                cells.append(str(int(value)))
        table.add_row(*cells)
    console.print(table)
    if run.brain_only:
        console.print(
            "best = mean = median: the fixed body's best so far (brain-only); fitness.png "
            "also draws the mean of each generation's CMA-ES candidates"
        )
    else:
        console.print("best, mean, median: fitness of the population after selection")
    if QD_COLUMNS[0] in report.table.columns:  # a MAP-Elites run: its archive, a second table
        _print_archive_table(report, console)
    if report.best is not None:
        best = report.best
        console.print(
            Text(
                f"best evaluation: {one_line(best['eval_id'])} (generation "
                f"{int(best['generation'])}, fitness {float(best['fitness'])!r})"
            ),
            highlight=False,
        )
    for path in report.written if written else []:  # Text: no markup in a name or a note
        console.print(Text(f"wrote {one_line(path)}"), highlight=False, soft_wrap=True)
    for note in report.notes:
        console.print(Text(one_line(note)), highlight=False, soft_wrap=True)
