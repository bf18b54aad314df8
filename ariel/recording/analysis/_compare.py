"""`ariel compare`: conditions of a campaign (or of several folders of one campaign file run
on different seeds, pooled; or plain run folders grouped by how their configs differ, or by
``labels``) compared with statistics; writes ``compare/`` and returns a `Comparison`. Each run
counts once: a folder given twice, or a copy of a run folder, is one run (a note says so).
Automatic names of plain run folders' conditions are at most `NAME_LIMIT` characters
(`condition_names`); what was compared lists each condition's whole settings.

Every run is compared at one budget of evaluations (the smallest any run made, or
``at_evaluations``), on two measures: its best fitness after that many evaluations (``final
best``) and the mean of its best-so-far fitness over evaluations 1..N (``AUC``, the area under
the best-so-far curve / N, in the fitness's unit: an anytime measure); co-evolution runs also on
their lineage (``surviving lineages``, ``best depth``: `_compare_lineage`). The tests follow the
design (`_compare_stats`); runs measured differently are refused (`_compare_design`).

``compare/`` holds ``best_so_far.png``, ``final_best.png``, ``morphology.png`` and
``lineages.png`` (co-evolution runs), ``stats.csv`` (one row per measure and pair of
conditions), ``summary.csv`` (one row per condition), ``omnibus.csv`` (more than two
conditions), ``runs.csv`` (each run's values), ``stats.md`` (the tables), ``README.md`` (what
was compared, the warnings, the tables) and ``compare.html``, one self-contained page with the
figures embedded. The fitness direction comes from the runs' records.

Where it writes: ``out``, or by default ``CAMPAIGN_DIR/compare`` for one campaign and a new
folder ``compare-<date>-<time>`` in the current directory for pooled campaigns and plain run
folders (never a
folder the user did not name beside the runs). An output folder that is a symbolic link is
refused (`UnsafePathError`); one holding files a comparison did not write is refused
(`CompareError`); an earlier comparison there is replaced (`Comparison.replaced` says so).
Every file is written whole under a temporary name and renamed (`_files.atomic_write`), so a
file in it that is a link is replaced, never followed. Names from the folders are escaped for
each medium (`_escape`): CSV text cells that a spreadsheet would read as a formula start
with ``'``.

Here: `Comparison`, `compare_runs` and `compare`. Finding the runs and naming their conditions
is `_compare_runs`'s job, the numbers `_compare_measures`'s, the output folder and writing its
files `_compare_output`'s.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import pandas as pd

from ariel.recording.analysis import _compare_lineage as lineages
from ariel.recording.analysis._compare_design import (
    MEASURES,
    QD_COLUMNS,
    CompareError,
    Source,
    common_budget,
    describe,
    first_evaluations,
    run_state_notes,
    shared_settings,
)
from ariel.recording.analysis._compare_html import omnibus_frame, stats_frame, summary_frame
from ariel.recording.analysis._compare_measures import (
    _by_condition,
    _run_rows,
    _statistics,
    _summary,
)
from ariel.recording.analysis._compare_output import (
    _write,
    new_folder,
    prepare_folder,
    shown_path as shown_path,
)
from ariel.recording.analysis._compare_runs import (
    NAME_LIMIT as NAME_LIMIT,
    RunCurve as RunCurve,
    _campaign_runs,
    _checked_labels,
    _comparable_runs,
    _folder_runs,
    _pooled_campaign_runs,
    condition_names as condition_names,
    unique_folders,
)
from ariel.recording.analysis._compare_stats import Design
from ariel.recording.store import is_campaign
from ariel.utils import flag_argument, gone_if_empty, path_argument, paths_argument

__all__ = [
    "MEASURES",
    "QD_COLUMNS",
    "CompareError",
    "Comparison",
    "RunCurve",
    "compare",
    "compare_runs",
]

#: Above this many conditions, `compare_runs` says how many pairs it tests before it starts
#: (each pair of each measure takes a bootstrap: the time grows with the square of them).
MANY_CONDITIONS = 20


@dataclass
class Comparison:
    """What `compare` found (and wrote, unless ``write=False``).

    `table`, `summary_table` and `omnibus_table` give the tables as printed.

    Attributes:
        out: The folder the comparison was written to (or would be); None when there is
            none (``write=False`` without ``out``).
        title: What was compared: the campaign id, the pooled campaigns' ids joined by
            ``" + "``, or ``"<n> runs"`` for plain run folders.
        maximise: Whether higher fitness is better (from the runs' records).
        fitness_fn: The name of the runs' fitness function.
        conditions: The conditions' names, in the order their first run came.
        runs: One row per run (a DataFrame): ``condition``, ``seed``, ``evaluations``,
            ``compared_at``, the measures ``final_best`` and ``auc``, the QD columns where the
            runs have them, ``surviving_lineages``, ``best_depth`` and ``distinct_made``
            (distinct bodies made so far) where a run has a lineage (co-evolution; NaN for a
            brain-only run), and ``path``.
        stats: One row per measure and pair of conditions (a DataFrame;
            `_compare_stats.pairwise_table`).
        figures: Figure name (``best_so_far``, ``final_best``, ``morphology``,
            ``lineages``) -> its PNG file; empty when nothing was written.
        html: The path of ``compare.html``; None when nothing was written.
        summary: One row per condition (a DataFrame): runs, median / mean / sd of each
            measure, QD medians, median / mean / sd of each lineage measure.
        omnibus: One row per measure for more than two conditions (a DataFrame; no rows
            otherwise).
        budget: The evaluations every run was compared at.
        tests: Which tests were used (paired or not) and why.
        notes: Warnings the reader must see (small n, unequal budgets, missing pairs, a folder
            given twice).
        about: What was compared, as (label, text) lines.
        settings: The config values every run shares (dotted key -> value as text).
        readme: The path of ``README.md``; None when nothing was written.
        replaced: Whether ``out`` held an earlier comparison, which this one replaced.
    """

    out: Path | None
    title: str
    maximise: bool
    fitness_fn: str
    conditions: list[str]
    runs: pd.DataFrame
    stats: pd.DataFrame
    figures: dict[str, Path] = field(default_factory=dict)
    html: Path | None = None
    summary: Any = None
    omnibus: Any = None
    budget: int = 0
    tests: Design = field(default_factory=lambda: Design(False))
    notes: list[str] = field(default_factory=list)
    about: list[tuple[str, str]] = field(default_factory=list)
    settings: dict[str, str] = field(default_factory=dict)
    readme: Path | None = None
    replaced: bool = False  # ``out`` held an earlier comparison, now replaced

    def __repr__(self) -> str:  # one line, as Run's (a notebook cell's last value)
        where = f", written to {self.out}" if self.readme is not None else ""
        notes = f", {len(self.notes)} notes" if self.notes else ""
        return (
            f"<Comparison {self.title}: {len(self.conditions)} conditions, {len(self.runs)} "
            f"runs, at {self.budget:,} evaluations{where}{notes}>"
        )

    def table(self) -> pd.DataFrame:
        """The pairwise statistics as `ariel compare` prints them (a DataFrame of text)."""
        return stats_frame(self)

    def summary_table(self) -> pd.DataFrame:
        """Per condition (columns): runs, median and mean ± sd of each measure, QD medians."""
        return summary_frame(self)

    def omnibus_table(self) -> pd.DataFrame:
        """The omnibus test per measure (more than two conditions; else no rows)."""
        return omnibus_frame(self)


def compare_runs(
    curves: Sequence[RunCurve],
    out: str | Path | None,
    *,
    maximise: bool,
    fitness_fn: str = "fitness",
    title: str = "comparison",
    paired: bool = False,
    reason: str = "",
    at_evaluations: int | None = None,
    source: Source | None = None,
    write: bool = True,
    notes: Sequence[str] = (),
    announce: Callable[[str], None] | None = None,
) -> Comparison:
    """Compare ``curves`` (runs with their conditions) and write ``out`` (see the module
    docstring; nothing is written where ``write`` is false); the core of `compare`, usable
    on any evaluations tables. ``paired``: the conditions share seeds (paired tests; why:
    ``reason``); ``at_evaluations``: the budget (default: the smallest run's); ``notes``:
    warnings to put first (`Comparison.notes`); ``announce``: given one line before the
    statistics are computed where there are more than `MANY_CONDITIONS` conditions."""
    if not curves:
        raise CompareError("no run with a finished generation to compare")
    count = len({c.condition for c in curves})
    if announce is not None and count > MANY_CONDITIONS:
        announce(many_conditions(count, any(c.lineage is not None for c in curves)))
    totals = {f"{c.condition} seed {c.seed}": len(c.evaluations) for c in curves}
    budget, budget_note = common_budget(totals, at_evaluations)
    truncated = [replace(c, evaluations=first_evaluations(c.evaluations, budget)) for c in curves]
    runs = pd.DataFrame(_run_rows(curves, truncated, maximise, budget))
    choice = Design(paired, reason or ("the conditions share seeds" if paired else ""))
    rows, omnibus, found_notes = _statistics(runs, maximise, choice)
    grouped = _by_condition(truncated)
    # runs not finished, runs of no success, runs whose lineage measures are missing
    states = [*run_state_notes(curves), lineages.no_generation_note(curves, budget)]
    comparison = Comparison(
        out=Path(out) if out is not None else None,
        title=title,
        maximise=maximise,
        fitness_fn=fitness_fn,
        conditions=list(grouped),
        runs=runs,
        stats=pd.DataFrame(rows),
        summary=_summary(runs),
        omnibus=pd.DataFrame(omnibus),
        budget=budget,
        tests=choice,
        notes=[n for n in (*notes, *states, budget_note, *found_notes, _alone(grouped)) if n],
        about=describe(
            source or Source(),
            seeds={name: [c.seed for c in group] for name, group in grouped.items()},
            totals={
                name: [len(c.evaluations) for c in curves if c.condition == name]
                for name in grouped
            },
            budget=budget,
            tests=choice.describe(),
            paired=paired,
            infos=[c.info for c in curves],
        ),
        settings=shared_settings([c.info.get("config", {}) for c in curves]),
    )
    if write and comparison.out is not None:
        _write(comparison, grouped, comparison.out)
    return comparison


def many_conditions(count: int, lineage: bool = False) -> str:
    """The line `compare_runs` announces before comparing ``count`` conditions (``lineage``:
    on the lineage measures too)."""
    pairs = count * (count - 1) // 2
    measures = len(MEASURES) + lineage * len(lineages.LINEAGE_MEASURES)
    return (
        f"{count} conditions: testing {pairs:,} pairs of conditions for each of "
        f"{measures} measures, each with a bootstrap CI (the time grows with the square "
        "of the number of conditions)"
    )


_REASONS = {
    "shared": "the conditions share seeds (seeding = 'shared': common random numbers, "
    "generation 0 is the same in every condition), so their runs are paired by seed",
    "independent": "each condition has its own seeds (seeding = 'independent'): "
    "independent samples",
    "folders": "plain run folders have no campaign design: independent samples",
}


def _alone(grouped: Mapping[str, object]) -> str:
    """The note for a comparison of one condition (``ariel compare RUN``, or runs of one
    config): an empty table of pairs, said in words."""
    if len(grouped) != 1:
        return ""
    return f"one condition ({next(iter(grouped))}): no pair of conditions to test, only its summary"


def _checked_out(out: str | Path | None, write: bool) -> Path | None:
    """``out`` as a path (``~`` the home folder), refused before the runs are read where it
    cannot take compare's files (again when they are written); `TypeError` for a ``write``
    that is not True or False."""
    out = path_argument("out", out, function="compare") if out is not None else None
    if flag_argument("write", write, function="compare") and out is not None:
        prepare_folder(out)
    return out


def compare(
    paths: Sequence[str | Path],
    *,
    out: str | Path | None = None,
    at_evaluations: int | None = None,
    write: bool = True,
    labels: Mapping[str | Path, str] | None = None,
    announce: Callable[[str], None] | None = None,
) -> Comparison:
    """Compare a campaign's conditions (one campaign folder, or several folders of one
    campaign file run on different seeds, pooled) or plain run folders (grouped by their
    config difference, or by ``labels``).

    A folder given twice (``R R``, ``R sub/../R``) counts once, and so does a copy of a run
    folder (the same run id, created at the same time, seed and config); a note says so.

    Args:
        paths: One campaign folder, several folders of one campaign file (pooled), or run
            folders; campaign and run folders cannot be mixed.
        out: Where to write ``compare/``'s files. None (the default): ``CAMPAIGN_DIR/compare``
            for one campaign (an earlier comparison there is replaced), else a new folder
            ``compare-<date>-<time>`` in the current directory (`new_folder`).
        at_evaluations: Compare every run after its first N evaluations; None (the default):
            as many as the shortest run made.
        write: False computes only (a notebook's table) and writes nothing.
        labels: Run folder -> condition name (`LABEL`: 1 to 64 letters, digits, ``_ . -``),
            for plain run folders only; runs with one label form one condition; every folder
            given must have one. None: conditions are named by their config difference.
        announce: Told one line before a long computation (more than `MANY_CONDITIONS`
            conditions, `compare_runs`), e.g. ``print``; None says nothing.

    Returns:
        The comparison: its tables, notes and (when written) the paths of its files.

    Raises:
        CompareError: For no paths, campaign and run folders mixed, labels that do not name
            every run folder once, runs that cannot be compared (no finished generation,
            different fitness functions or directions, ...), ``at_evaluations`` below 1 or
            beyond a run's total, or an ``out`` that is a file or holds other files.
        UnsafePathError: When ``out`` is a symbolic link.
        NotARunError: When a path is neither a campaign nor a run folder (or is damaged).
        TypeError: For an argument of the wrong type (``write="no"``: True or False).

    Example:
        Compare the conditions of a campaign folder (here the last by name under
        ``data/campaigns``) without writing anything:

        ```python
        from pathlib import Path

        from ariel.recording import compare

        campaign = max(Path("data/campaigns").iterdir())
        comparison = compare([campaign], write=False)
        print(comparison.table())  # the pairwise statistics, as `ariel compare` prints them
        print(comparison.notes)
        ```
    """
    paths = paths_argument("paths", paths, function="compare")
    if not paths:
        raise CompareError("give a campaign folder or run folders to compare")
    out = _checked_out(out, write)
    campaigns = [p for p in paths if is_campaign(p)]
    paths, notes = unique_folders(paths, "campaign folder" if campaigns else "run")
    if labels and campaigns:
        raise CompareError(
            "--label names plain run folders; a campaign's conditions have the names its "
            "campaign file gives them"
        )
    if len(paths) == 1 and is_campaign(paths[0]):
        title, source, paired, found = _campaign_runs(paths[0])
        reason = _REASONS["shared" if paired else "independent"]
        default = paths[0] / "compare"
        names = [f"condition {c.condition} seed {c.seed}" for c, _ in found]
    elif all(is_campaign(p) for p in paths):
        title, source, paired, found = _pooled_campaign_runs(paths)
        reason = _REASONS["shared" if paired else "independent"]
        default = None  # not inside one of them: a new folder here, as for run folders
        names = [f"condition {c.condition} seed {c.seed}" for c, _ in found]
    else:
        if campaigns:
            raise CompareError(
                f"{str(campaigns[0])!r} is a campaign: compare campaign folders (one, or "
                "several of one campaign file to pool their seeds), or run folders, not both"
            )
        checked = _checked_labels(labels, paths) if labels else None
        title, source, found, copies = _folder_runs(paths, checked)
        notes += copies
        paired, reason = False, _REASONS["folders"]
        default = None  # a new folder here, named when it is written (below)
        names = [c.path for c, _ in found]
    found, maximise, fitness_fn = _comparable_runs(found, names, notes)
    out = default if out is None and write else out
    claimed = new_folder(Path("."), "compare") if out is None and write else None
    with gone_if_empty(claimed):  # a comparison that stops before writing leaves no folder
        return compare_runs(
            [c for c, _ in found],
            out if claimed is None else claimed,
            maximise=maximise,
            fitness_fn=fitness_fn,
            title=title,
            paired=paired,
            reason=reason,
            at_evaluations=at_evaluations,
            source=source,
            write=write,
            notes=notes,
            announce=announce,
        )
