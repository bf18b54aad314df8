"""`ariel compare`: conditions of a campaign (or of several folders of one campaign file run
on different seeds, pooled; or plain run folders grouped by how their configs differ) compared
with statistics; writes ``compare/`` and returns a `Comparison`.

Every run is compared at one budget of evaluations (the smallest any run made, or
``at_evaluations``), on two measures: its best fitness after that many evaluations (``final
best``) and the mean of its best-so-far fitness over evaluations 1..N (``AUC``, the area under
the best-so-far curve / N, in the fitness's unit: an anytime measure). The tests follow the
design (`_compare_stats`); runs measured differently are refused (`_compare_design`).

``compare/`` holds ``best_so_far.png``, ``final_best.png``, ``morphology.png`` (co-evolution
runs), ``stats.csv`` (one row per measure and pair of conditions), ``summary.csv`` (one row per
condition), ``omnibus.csv`` (more than two conditions), ``runs.csv`` (each run's values),
``stats.md`` (the tables), ``README.md`` (what was compared, the warnings, the tables) and
``compare.html``, one self-contained page with the figures embedded. The fitness direction
comes from the runs' records.

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
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ariel.recording._campaign import fitness_maximise, is_campaign, load_campaign
from ariel.recording._compare_design import (
    MEASURES,
    QD_COLUMNS,
    CompareError,
    Source,
    check_comparable,
    common_budget,
    condition_settings,
    describe,
    first_evaluations,
    shared_settings,
)
from ariel.recording._compare_stats import (
    Design,
    Sample,
    location,
    median_band,
    omnibus_test,
    pairing_notes,
    pairwise_table,
    small_n_warning,
)
from ariel.recording._curves import best_so_far, on_grid
from ariel.recording._escape import csv_safe
from ariel.recording._files import UnsafePathError, written_path
from ariel.recording._load import Run, load_run

__all__ = [
    "MEASURES",
    "QD_COLUMNS",
    "CompareError",
    "Comparison",
    "RunCurve",
    "compare",
    "compare_runs",
]

GRID_POINTS = 200
MORPHOLOGY_BINS = 20
#: Every file a comparison may write into its folder.
FILES = (
    "best_so_far.png",
    "final_best.png",
    "morphology.png",
    "stats.csv",
    "summary.csv",
    "omnibus.csv",
    "runs.csv",
    "stats.md",
    "README.md",
    "compare.html",
)


@dataclass
class RunCurve:
    """One run's part of a comparison: its condition, seed, and evaluations table (``fitness``,
    ``status``, ``generation``, ``eval_id``, descriptor columns); ``info``: its run.json (for
    software and commit); ``generations``: its per-generation QD columns (``generation`` and
    any of `QD_COLUMNS`), or None."""

    condition: str
    seed: int
    evaluations: Any
    path: str = ""
    info: dict[str, Any] = field(default_factory=dict)
    generations: Any = None


@dataclass
class Comparison:
    """What `compare` found (and wrote, unless ``write=False``).

    ``stats``: one row per measure and pair of conditions (`_compare_stats.pairwise_table`);
    ``summary``: one row per condition (runs, median / mean / sd of each measure, QD medians);
    ``omnibus``: one row per measure for more than two conditions; ``runs``: one row per run.
    ``budget``: the evaluations every run was compared at; ``tests``: which tests and why;
    ``notes``: warnings the reader must see (small n, unequal budgets, missing pairs);
    ``about``: what was compared, (label, text) lines; ``settings``: the config values every
    run shares; ``replaced``: ``out`` held an earlier comparison, which this one replaced.
    `table`, `summary_table` and `omnibus_table` give the tables as printed.
    """

    out: Path | None
    title: str
    maximise: bool
    fitness_fn: str
    conditions: list[str]
    runs: Any
    stats: Any
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

    def table(self) -> Any:
        """The pairwise statistics as `ariel compare` prints them (a DataFrame of text)."""
        from ariel.recording._compare_html import stats_frame

        return stats_frame(self)

    def summary_table(self) -> Any:
        """Per condition (columns): runs, median and mean ± sd of each measure, QD medians."""
        from ariel.recording._compare_html import summary_frame

        return summary_frame(self)

    def omnibus_table(self) -> Any:
        """The omnibus test per measure (more than two conditions; else no rows)."""
        from ariel.recording._compare_html import omnibus_frame

        return omnibus_frame(self)


# --------------------------------------------------------------------------------------------
# Finding the runs and their conditions
# --------------------------------------------------------------------------------------------


def _qd_generations(run: Run) -> Any:
    """The run's per-generation QD columns (MAP-Elites runs), or None."""
    if not len(run.archive):
        return None
    generations = run.generations
    columns = [c for c in QD_COLUMNS if c in generations.columns]
    return generations[["generation", *columns]] if columns else None


def _curve(condition: str, seed: int, run: Run) -> RunCurve:
    return RunCurve(condition, seed, run.evaluations, str(run.path), run.info, _qd_generations(run))


def _overrides(changes: dict[str, Any]) -> str:
    import json

    return ", ".join(f"{k} = {json.dumps(v)}" for k, v in changes.items())


def _campaign_runs(
    path: Path, campaign: Any = None
) -> tuple[str, Source, bool, list[tuple[RunCurve, Run]]]:
    """(title, source, whether the conditions share seeds, the runs) of a campaign folder
    (``campaign``: its records where already loaded)."""
    campaign = campaign if campaign is not None else load_campaign(path)
    info = campaign.info
    seeding = campaign.seeding
    found = [(_curve(c, seed, run), run) for (c, seed), run in campaign.runs.items()]
    base = info.get("base")
    source = Source(
        what=f"campaign {info.get('campaign_id', path.name)} ({path}), "
        f"{len(found)} runs, seeding = {seeding!r}",
        overrides={c["name"]: _overrides(c.get("set", {})) for c in info.get("conditions", [])},
        base=f"{base} (from the campaign file {info.get('file', '?')})"
        if base
        else f"the base of the campaign file {info.get('file', '?')}",
    )
    return str(info.get("campaign_id", path.name)), source, seeding == "shared", found


def _campaign_key(campaign: Any) -> tuple[Any, ...]:
    """What campaign folders must share to be pooled: the campaign file's name, seeding and
    conditions (each with its settings)."""
    import json

    info = campaign.info
    conditions = [
        (c["name"], json.dumps(c.get("set", {}), sort_keys=True))
        for c in info.get("conditions", [])
    ]
    return (info.get("name"), campaign.seeding, tuple(conditions))


def _pooled_campaign_runs(
    paths: Sequence[Path],
) -> tuple[str, Source, bool, list[tuple[RunCurve, Run]]]:
    """Several folders of one campaign file run on different seeds (a campaign extended with
    more seeds), pooled as one campaign: the same conditions and seeding, no seed twice."""
    campaigns = [load_campaign(p) for p in paths]
    first = _campaign_key(campaigns[0])
    for path, campaign in zip(paths[1:], campaigns[1:]):
        if _campaign_key(campaign) != first:
            raise CompareError(
                f"{str(path)!r} is not the same campaign as {str(paths[0])!r} (name, seeding "
                "and conditions must match): compare several campaign folders only to pool "
                "one campaign's seeds"
            )
    found: list[tuple[RunCurve, Run]] = []
    seen: dict[tuple[str, int], Path] = {}
    for path, campaign in zip(paths, campaigns):
        for (condition, seed), run in campaign.runs.items():
            if (condition, seed) in seen:
                raise CompareError(
                    f"condition {condition!r} seed {seed} is in both "
                    f"{str(seen[condition, seed])!r} and {str(path)!r}: pooled campaign folders "
                    "must have different seeds"
                )
            seen[condition, seed] = path
            found.append((_curve(condition, seed, run), run))
    _, source, paired, _ = _campaign_runs(paths[0], campaigns[0])
    ids = [str(c.info.get("campaign_id", p.name)) for p, c in zip(paths, campaigns)]
    source.what = (
        f"campaign {campaigns[0].info.get('name', '?')} pooled from {len(paths)} folders "
        f"({', '.join(f'{i} ({p})' for i, p in zip(ids, paths))}), {len(found)} runs, "
        f"seeding = {campaigns[0].seeding!r}"
    )
    return " + ".join(ids), source, paired, found


def _folder_runs(paths: Sequence[Path]) -> tuple[str, Source, list[tuple[RunCurve, Run]]]:
    """Plain run folders, each condition named by the config values that tell it apart."""
    runs = [load_run(p) for p in paths]
    flats = [condition_settings(run.config) for run in runs]
    keys = sorted({k for f in flats for k in f})
    differing = [k for k in keys if len({f.get(k) for f in flats}) > 1]
    found = []
    for run, flat in zip(runs, flats):
        name = ",".join(f"{k}={flat.get(k, '-')}" for k in differing) or str(
            run.config.get("name", "runs")
        )
        seed = int(run.info.get("seed", run.config.get("seed", 0)))
        found.append((_curve(name, seed, run), run))
    source = Source(
        what=f"{len(runs)} run folders: {', '.join(str(p) for p in paths)}",
        base="none: plain run folders, each condition named by the config values that differ",
    )
    return f"{len(runs)} runs", source, found


def _direction(runs: Sequence[Run]) -> tuple[bool, str]:
    """(whether the fitness is maximised, its name), of runs `check_comparable` let through."""
    directions = {fitness_maximise(r.info) for r in runs}
    if len(directions) > 1:
        raise CompareError("the runs disagree on the fitness direction (maximise in run.json)")
    return directions.pop(), str(runs[0].config.get("task", {}).get("fitness", "?"))


# --------------------------------------------------------------------------------------------
# Computing
# --------------------------------------------------------------------------------------------


def _by_condition(curves: Sequence[RunCurve]) -> dict[str, list[RunCurve]]:
    grouped: dict[str, list[RunCurve]] = {}
    for curve in curves:
        grouped.setdefault(curve.condition, []).append(curve)
    return grouped


def _best_curves(grouped: dict[str, list[RunCurve]], maximise: bool, budget: int) -> dict:
    """Per condition: (grid, median, low, high) of best so far over evaluations 1..budget."""
    grid = np.unique(np.linspace(1, max(budget, 1), GRID_POINTS).round().astype(np.int64))
    curves = {}
    for name, runs in grouped.items():
        values = np.array([on_grid(*best_so_far(r.evaluations, maximise), grid) for r in runs])
        curves[name] = (grid, *median_band(values))
    return curves


def _measures(curve: RunCurve, maximise: bool, budget: int) -> dict[str, float]:
    """A run's best so far after ``budget`` evaluations and the mean of its best so far over
    evaluations 1..budget (from its first finished evaluation on); NaN without one."""
    _, best = best_so_far(curve.evaluations, maximise)
    best = best[:budget]
    final = float(best[-1]) if len(best) == budget else math.nan
    finite = best[np.isfinite(best)]
    return {"final_best": final, "auc": float(finite.mean()) if len(finite) else math.nan}


def _qd_at_budget(curve: RunCurve, budget: int) -> dict[str, float]:
    """The run's QD columns at its last generation wholly within its first ``budget``
    evaluations (empty without QD columns or such a generation)."""
    if curve.generations is None or not len(curve.generations):
        return {}
    counts = curve.evaluations["generation"].value_counts()
    within = first_evaluations(curve.evaluations, budget)["generation"].value_counts()
    whole = [g for g, n in within.items() if counts.get(g) == n]
    rows = curve.generations[curve.generations["generation"].isin(whole)]
    if not len(rows):
        return {}
    last = rows.sort_values("generation").iloc[-1]
    return {c: float(last[c]) for c in QD_COLUMNS if c in rows.columns}


def _run_rows(
    curves: Sequence[RunCurve], truncated: Sequence[RunCurve], maximise: bool, budget: int
) -> list[dict[str, Any]]:
    return [
        {
            "condition": whole.condition,
            "seed": whole.seed,
            "evaluations": len(whole.evaluations),
            "compared_at": budget,
            **_measures(cut, maximise, budget),
            **_qd_at_budget(whole, budget),
            "path": whole.path,
        }
        for whole, cut in zip(curves, truncated)
    ]


def _samples(runs: Any, column: str) -> dict[str, Sample]:
    return {
        name: Sample.of(group[column].to_numpy(dtype=np.float64), group["seed"].tolist())
        for name, group in runs.groupby("condition", sort=False)
    }


def _summary(runs: Any) -> Any:
    """One row per condition: runs, then median / mean / sd of each measure, QD medians."""
    import pandas as pd

    rows = []
    for name, group in runs.groupby("condition", sort=False):
        row: dict[str, Any] = {"condition": name, "runs": len(group)}
        for column in MEASURES.values():
            for key, value in location(group[column].to_numpy(dtype=np.float64)).items():
                row[f"{column}_{key}"] = value
        for column in QD_COLUMNS:
            if column in group:
                row[f"{column}_median"] = float(group[column].median())
        rows.append(row)
    return pd.DataFrame(rows)


def _statistics(
    runs: Any, maximise: bool, choice: Design
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[str]]:
    """(pairwise rows of every measure, omnibus rows, notes on small n and missing pairs)."""
    rows, omnibus = [], []
    for measure, column in MEASURES.items():
        samples = _samples(runs, column)
        rows += pairwise_table(samples, maximise=maximise, paired=choice.paired, measure=measure)
        found = omnibus_test(samples, paired=choice.paired, measure=measure)
        if found is not None:
            omnibus.append(found)
    first = [r for r in rows if r["measure"] == "final best"]
    sizes = runs.groupby("condition", sort=False).size().to_dict()
    notes = [
        small_n_warning(first, sizes, choice, omnibus[0] if omnibus else None),
        *pairing_notes(first),
    ]
    return rows, omnibus, [n for n in notes if n]


def _morphology(grouped: dict[str, list[RunCurve]]) -> dict[str, dict[str, tuple]]:
    """descriptor -> condition -> (bin centres, median, 25 %, 75 %) of per-run bin means."""
    from ariel.recording._compare_plots import MORPHOLOGY

    series: dict[str, dict[str, tuple]] = {}
    for descriptor in MORPHOLOGY:
        per_condition = {}
        for name, runs in grouped.items():
            if not all(descriptor in r.evaluations.columns for r in runs):
                continue
            longest = max(len(r.evaluations) for r in runs)
            edges = np.linspace(0, longest, max(1, min(MORPHOLOGY_BINS, longest)) + 1)
            means = np.array([_bin_means(r.evaluations, descriptor, edges) for r in runs])
            if not np.isfinite(means).any():
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN bin: NaN
                low, median, high = np.nanpercentile(means, [25, 50, 75], axis=0)
            per_condition[name] = ((edges[:-1] + edges[1:]) / 2, median, low, high)
        if per_condition:
            series[descriptor] = per_condition
    return series


def _bin_means(evaluations: Any, descriptor: str, edges: np.ndarray) -> np.ndarray:
    ordered = evaluations.sort_values(["generation", "eval_id"], kind="stable")
    values = ordered[descriptor].to_numpy(dtype=np.float64, na_value=np.nan)
    position = np.arange(len(values))
    bins = np.digitize(position, edges[1:-1])
    means = np.full(len(edges) - 1, np.nan)
    for b in range(len(means)):
        inside = values[bins == b]
        if np.isfinite(inside).any():
            means[b] = np.nanmean(inside)
    return means


# --------------------------------------------------------------------------------------------
# The comparison
# --------------------------------------------------------------------------------------------


def _is_ours(path: Path) -> bool:
    """A file a comparison writes (or the temporary of one a killed comparison left)."""
    name = written_path(path)
    return path.name in FILES or (name is not None and name.name in FILES)


def prepare_folder(out: Path) -> bool:
    """Check that ``out`` can take a comparison; True where it holds an earlier one (to be
    replaced). A link is refused (`UnsafePathError`: nothing is written through it), and so
    are a file and a folder holding anything a comparison did not write (`CompareError`)."""
    if out.is_symlink():
        raise UnsafePathError(
            f"refusing to write the comparison into {str(out)!r}: it is a symbolic link (to "
            f"{os.readlink(out)!r}); remove the link or name another folder with --out DIR"
        )
    if not out.exists():
        return False
    if not out.is_dir():
        raise CompareError(f"{str(out)!r} is a file, not a folder: name a folder with --out DIR")
    entries = sorted(out.iterdir())
    foreign = [p.name for p in entries if not _is_ours(p) or (p.is_dir() and not p.is_symlink())]
    if foreign:
        raise CompareError(
            f"{str(out)!r} holds files a comparison does not write ({foreign[0]!r}"
            f"{f' and {len(foreign) - 1} more' if len(foreign) > 1 else ''}): name a new folder "
            "with --out DIR"
        )
    return bool(entries)


def _write(comparison: Comparison, grouped: dict[str, list[RunCurve]], out: Path) -> None:
    """The figures, tables and pages of ``comparison`` into ``out`` (`prepare_folder`); an
    earlier comparison's files that this one does not write are removed."""
    import pandas as pd

    from ariel.recording import _compare_plots as plots
    from ariel.recording._axes import fitness_label
    from ariel.recording._compare_html import write_html, write_markdown, write_readme
    from ariel.recording._files import atomic_write

    comparison.replaced = prepare_folder(out)
    out.mkdir(parents=True, exist_ok=True)

    def csv(frame: Any, name: str) -> None:
        atomic_write(out / name, lambda temporary: csv_safe(frame).to_csv(temporary, index=False))

    ylabel = fitness_label(comparison.fitness_fn, comparison.maximise, what="best fitness")
    finals = {name: s.values for name, s in _samples(comparison.runs, "final_best").items()}
    best = _best_curves(grouped, comparison.maximise, comparison.budget)
    comparison.figures = {
        "best_so_far": plots.best_so_far_figure(best, out / "best_so_far.png", ylabel=ylabel),
        "final_best": plots.final_best_figure(finals, out / "final_best.png", ylabel=ylabel),
    }
    morphology = _morphology(grouped)
    if morphology:
        comparison.figures["morphology"] = plots.morphology_figure(
            morphology, out / "morphology.png"
        )
    csv(comparison.stats, "stats.csv")
    csv(comparison.summary, "summary.csv")
    if len(comparison.omnibus):
        csv(pd.DataFrame(comparison.omnibus), "omnibus.csv")
    csv(comparison.runs, "runs.csv")
    write_markdown(comparison, out / "stats.md")
    comparison.readme = write_readme(comparison, out / "README.md")
    comparison.html = write_html(comparison, out / "compare.html")
    written = {p.name for p in comparison.figures.values()} | {
        "stats.csv",
        "summary.csv",
        "runs.csv",
        "stats.md",
        "README.md",
        "compare.html",
        *(["omnibus.csv"] if len(comparison.omnibus) else []),
    }
    for name in set(FILES) - written:  # an earlier comparison's, not this one's
        (out / name).unlink(missing_ok=True)  # a link is removed, not followed


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
) -> Comparison:
    """Compare ``curves`` (runs with their conditions) and write ``out`` (see the module
    docstring; nothing is written where ``write`` is false); the core of `compare`, usable
    on any evaluations tables. ``paired``: the conditions share seeds (paired tests; why:
    ``reason``); ``at_evaluations``: the budget (default: the smallest run's)."""
    import pandas as pd

    if not curves:
        raise CompareError("no run with a finished generation to compare")
    totals = {f"{c.condition} seed {c.seed}": len(c.evaluations) for c in curves}
    budget, budget_note = common_budget(totals, at_evaluations)
    truncated = [replace(c, evaluations=first_evaluations(c.evaluations, budget)) for c in curves]
    runs = pd.DataFrame(_run_rows(curves, truncated, maximise, budget))
    choice = Design(paired, reason or ("the conditions share seeds" if paired else ""))
    rows, omnibus, notes = _statistics(runs, maximise, choice)
    grouped = _by_condition(truncated)
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
        notes=[n for n in (budget_note, *notes) if n],
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


_REASONS = {
    "shared": "the conditions share seeds (seeding = 'shared': common random numbers, "
    "generation 0 is the same in every condition), so their runs are paired by seed",
    "independent": "each condition has its own seeds (seeding = 'independent'): "
    "independent samples",
    "folders": "plain run folders have no campaign design: independent samples",
}


def compare(
    paths: Sequence[str | Path],
    *,
    out: str | Path | None = None,
    at_evaluations: int | None = None,
    write: bool = True,
) -> Comparison:
    """Compare a campaign's conditions (one campaign folder, or several folders of one
    campaign file run on different seeds, pooled) or plain run folders (grouped by their
    config difference). ``out``: default ``CAMPAIGN_DIR/compare`` for one campaign (an earlier
    comparison there is replaced), else a new folder ``compare-<date>-<time>`` in the
    current directory (`new_folder`); ``at_evaluations``: compare every run after its first N
    evaluations (default: as many as the shortest run made); ``write=False``: compute only
    (a notebook's table), write nothing."""
    paths = [Path(p) for p in paths]
    if not paths:
        raise CompareError("give a campaign folder or run folders to compare")
    if write and out is not None:
        prepare_folder(Path(out))  # refused before the runs are read (again when written)
    if len(paths) == 1 and is_campaign(paths[0]):
        title, source, paired, found = _campaign_runs(paths[0])
        reason = _REASONS["shared" if paired else "independent"]
        default = paths[0] / "compare"
        labels = [f"condition {c.condition} seed {c.seed}" for c, _ in found]
    elif all(is_campaign(p) for p in paths):
        title, source, paired, found = _pooled_campaign_runs(paths)
        reason = _REASONS["shared" if paired else "independent"]
        default = None  # not inside one of them: a new folder here, as for run folders
        labels = [f"condition {c.condition} seed {c.seed}" for c, _ in found]
    else:
        campaigns = [p for p in paths if is_campaign(p)]
        if campaigns:
            raise CompareError(
                f"{str(campaigns[0])!r} is a campaign: compare campaign folders (one, or "
                "several of one campaign file to pool their seeds), or run folders, not both"
            )
        title, source, found = _folder_runs(paths)
        paired, reason = False, _REASONS["folders"]
        default = None  # a new folder here, named when it is written (below)
        labels = [c.path for c, _ in found]
    done = [i for i, (_, run) in enumerate(found) if run.generations_done > 0]
    if not done:
        raise CompareError("no run with a finished generation to compare")
    found = [found[i] for i in done]
    check_comparable([(labels[i], found[j][1].config) for j, i in enumerate(done)])
    maximise, fitness_fn = _direction([r for _, r in found])
    if out is None and write:
        out = default if default is not None else new_folder(Path("."), "compare")
    return compare_runs(
        [c for c, _ in found],
        out,
        maximise=maximise,
        fitness_fn=fitness_fn,
        title=title,
        paired=paired,
        reason=reason,
        at_evaluations=at_evaluations,
        source=source,
        write=write,
    )


def new_folder(parent: Path, prefix: str) -> Path:
    """``parent/<prefix>-<date>-<time>`` (``-2``, ``-3``, ... added where that exists): the
    name of a folder that is not there yet. ``parent`` ``.`` gives a relative path."""
    import datetime

    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    name = f"{prefix}-{stamp}"
    path, n = parent / name, 1
    while os.path.lexists(path):
        n += 1
        path = parent / f"{name}-{n}"
    return Path(os.path.normpath(path))


def shown_path(path: str | Path) -> str:
    """``path`` relative to the current directory where it lies in it, else as it is."""
    try:
        relative = Path(os.path.abspath(path)).relative_to(Path.cwd())
    except ValueError:
        return str(path)
    return str(relative) if str(relative) != "." else "."
