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
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ariel.recording.analysis import _compare_lineage as lineages
from ariel.recording.analysis._compare_design import (
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
    whole_generations,
)
from ariel.recording.analysis._compare_stats import (
    Design,
    Sample,
    location,
    median_band,
    omnibus_test,
    pairing_notes,
    pairwise_table,
    small_n_warning,
)
from ariel.recording.store import (
    Run,
    UnsafePathError,
    best_so_far,
    csv_safe,
    fitness_maximise,
    is_campaign,
    load_campaign,
    load_run,
    on_grid,
    short_ascii,
    written_path,
)

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
#: The longest automatic condition name of plain run folders (`condition_names`).
NAME_LIMIT = 60
#: A ``--label``: 1 to 64 ASCII letters, digits, ``_``, ``.`` or ``-``.
LABEL = re.compile(r"[A-Za-z0-9_.-]{1,64}")
#: Above this many conditions, `compare_runs` says how many pairs it tests before it starts
#: (each pair of each measure takes a bootstrap: the time grows with the square of them).
MANY_CONDITIONS = 20
#: Every file a comparison may write into its folder.
FILES = (
    "best_so_far.png",
    "final_best.png",
    "morphology.png",
    "lineages.png",
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
    any of `QD_COLUMNS`), or None; ``lineage``: its per-generation lineage measures
    (`_compare_lineage.run_lineage`), or None (a brain-only run)."""

    condition: str
    seed: int
    evaluations: Any
    path: str = ""
    info: dict[str, Any] = field(default_factory=dict)
    generations: Any = None
    lineage: Any = None


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
            runs have them, ``surviving_lineages`` and ``best_depth`` where a run has a
            lineage (co-evolution; NaN for a brain-only run), and ``path``.
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
        from ariel.recording.analysis._compare_html import stats_frame

        return stats_frame(self)

    def summary_table(self) -> Any:
        """Per condition (columns): runs, median and mean ± sd of each measure, QD medians."""
        from ariel.recording.analysis._compare_html import summary_frame

        return summary_frame(self)

    def omnibus_table(self) -> Any:
        """The omnibus test per measure (more than two conditions; else no rows)."""
        from ariel.recording.analysis._compare_html import omnibus_frame

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
    found = (run.evaluations, str(run.path), run.info, _qd_generations(run))
    return RunCurve(condition, seed, *found, lineages.run_lineage(run))


def _overrides(changes: dict[str, Any]) -> str:
    import json

    return ", ".join(f"{k} = {json.dumps(v)}" for k, v in changes.items())


def _campaign_runs(path: Path) -> tuple[str, Source, bool, list[tuple[RunCurve, Run]]]:
    """(title, source, whether the conditions share seeds, the runs) of a campaign folder."""
    campaign = load_campaign(path)
    found = [(_curve(c, seed, run), run) for (c, seed), run in campaign.runs.items()]
    source = _campaign_source(path, campaign, len(found))
    title = str(campaign.info.get("campaign_id", path.name))
    return title, source, campaign.seeding == "shared", found


def _campaign_source(path: Path, campaign: Any, runs: int) -> Source:
    """What `compare` says it compared for the campaign in ``path`` (``runs`` of its runs)."""
    info = campaign.info
    base = info.get("base")
    return Source(
        what=f"campaign {info.get('campaign_id', path.name)} ({path}), "
        f"{runs} runs, seeding = {campaign.seeding!r}",
        overrides={c["name"]: _overrides(c.get("set", {})) for c in info.get("conditions", [])},
        base=f"{base} (from the campaign file {info.get('file', '?')})"
        if base
        else f"the base of the campaign file {info.get('file', '?')}",
    )


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
    source = _campaign_source(paths[0], campaigns[0], len(found))
    ids = [str(c.info.get("campaign_id", p.name)) for p, c in zip(paths, campaigns)]
    source.what = (
        f"campaign {campaigns[0].info.get('name', '?')} pooled from {len(paths)} folders "
        f"({', '.join(f'{i} ({p})' for i, p in zip(ids, paths))}), {len(found)} runs, "
        f"seeding = {campaigns[0].seeding!r}"
    )
    return " + ".join(ids), source, campaigns[0].seeding == "shared", found


def _times(n: int) -> str:
    return "twice" if n == 2 else f"{n} times"


def _once(items: Sequence[Any], key: Callable[[Any], Hashable | None]) -> list[list[Any]]:
    """``items`` grouped by ``key`` (None: an item of its own), in the order each group's
    first item comes: the first of each group is the one counted."""
    groups: dict[Any, list[Any]] = {}
    for i, item in enumerate(items):
        found = key(item)
        groups.setdefault(("own", i) if found is None else ("key", found), []).append(item)
    return list(groups.values())


def unique_folders(paths: Sequence[Path], what: str = "run") -> tuple[list[Path], list[str]]:
    """(``paths`` less those naming a folder given before: ``R R``, ``R sub/../R``, a link to
    ``R``, compared by their resolved paths; a note for each folder given more than once)."""
    groups = _once(paths, lambda p: os.path.realpath(p))
    notes = [
        f"the same {what} was given {_times(len(group))}: "
        f"{', '.join(repr(str(p)) for p in group)} (one folder); counted once"
        for group in groups
        if len(group) > 1
    ]
    return [group[0] for group in groups], notes


def _run_identity(run: Run) -> Hashable | None:
    """What makes two run folders one run (a copy of a folder): its run id, when run.json
    was created, its seed and its config. None without a run id. (A run id alone is not one
    run: ``ariel run --out a/seed1`` and ``--out b/seed1`` both have the run id ``seed1``.)"""
    run_id = run.info.get("run_id")
    if not run_id:
        return None
    config = json.dumps(run.info.get("config", run.config), sort_keys=True, default=str)
    return (str(run_id), str(run.info.get("created")), str(run.info.get("seed")), config)


def _short_keys(keys: Sequence[str]) -> dict[str, str]:
    """Each dotted key's shortest ending that no other of ``keys`` ends with
    (``body.population`` -> ``population``; ``body.options`` and ``brain.options`` stay)."""
    short = {}
    for key in keys:
        parts = key.split(".")
        for depth in range(1, len(parts) + 1):
            ending = ".".join(parts[-depth:])
            if not any(o != key and (o == ending or o.endswith(f".{ending}")) for o in keys):
                break
        short[key] = ending
    return short


def condition_names(keys: Sequence[str], flats: Sequence[Mapping[str, str]]) -> list[str]:
    """Each run's condition name from its values of the differing ``keys``
    (``brain.inherit=false``). Where one would be longer than `NAME_LIMIT`, every name uses
    the keys' last components (`_short_keys`), and one still too long is cut and ends in
    ``~`` and 8 hex digits of a hash of its whole name: the same settings, the same name.
    Never merges two conditions (the whole names then)."""
    whole = [",".join(f"{k}={f.get(k, '-')}" for k in keys) for f in flats]
    if max(map(len, whole), default=0) <= NAME_LIMIT:
        return whole
    short_keys = _short_keys(keys)
    names = []
    for name, flat in zip(whole, flats):
        short = ",".join(f"{short_keys[k]}={flat.get(k, '-')}" for k in keys)
        if len(short) > NAME_LIMIT:
            digest = hashlib.sha256(name.encode()).hexdigest()[:8]
            short = f"{short[: NAME_LIMIT - 9]}~{digest}"
        names.append(short)
    return names if len(set(names)) == len(set(whole)) else whole


def _settings_text(keys: Sequence[str], flats: Sequence[Mapping[str, str]]) -> str:
    """The values of ``keys`` in the runs of one condition (``a = 1 | 2`` where they differ)."""
    parts = []
    for key in keys:
        values = list(dict.fromkeys(f.get(key, "-") for f in flats))
        parts.append(f"{key} = {' | '.join(values)}")
    return ", ".join(parts)


def _checked_labels(labels: Mapping[str | Path, str], paths: Sequence[Path]) -> dict[str, str]:
    """``labels`` (run folder -> condition name) by resolved path, checked: every label a
    name (`LABEL`), every folder one of ``paths``, one label per folder, every folder
    labelled (`CompareError`, one line)."""
    given = {os.path.realpath(p): p for p in paths}
    found: dict[str, str] = {}
    for folder, name in labels.items():
        if not isinstance(name, str) or not LABEL.fullmatch(name):
            raise CompareError(
                f"--label {short_ascii(name)}: a label is 1 to 64 letters, digits, '_', '.' or '-'"
            )
        resolved = os.path.realpath(folder)
        if resolved not in given:
            raise CompareError(
                f"--label {name}={str(folder)!r}: that folder is not one of the run folders "
                "compared; give it as well"
            )
        if found.get(resolved, name) != name:
            raise CompareError(
                f"{str(given[resolved])!r} has two labels, {found[resolved]!r} and {name!r}"
            )
        found[resolved] = name
    missing = [p for r, p in given.items() if r not in found]
    if missing:
        raise CompareError(
            f"{str(missing[0])!r} has no --label: label every run folder or none"
            f"{f' ({len(missing)} unlabelled)' if len(missing) > 1 else ''}"
        )
    return found


def _folder_runs(
    paths: Sequence[Path], labels: Mapping[str, str] | None = None
) -> tuple[str, Source, list[tuple[RunCurve, Run]], list[str]]:
    """Plain run folders (each once: `unique_folders` first), each condition named by the
    config values that tell it apart (`condition_names`) or by ``labels`` (resolved run
    folder -> name, `_checked_labels`); with a note for each run given twice. A copy of a
    run folder (`_run_identity`) counts once."""
    loaded = [(p, load_run(p)) for p in paths]
    notes = []
    kept = []
    for group in _once(loaded, lambda item: _run_identity(item[1])):
        kept.append(group[0])
        if len(group) == 1:
            continue
        if labels is not None:
            named = {labels[os.path.realpath(p)] for p, _ in group}
            if len(named) > 1:
                raise CompareError(
                    f"{str(group[0][0])!r} and {str(group[1][0])!r} are the same run (run id "
                    f"{group[0][1].info.get('run_id')!r}) but have different labels"
                )
        notes.append(
            f"the same run was given {_times(len(group))}: "
            f"{', '.join(repr(str(p)) for p, _ in group)} (run id "
            f"{group[0][1].info.get('run_id')!r}: a copy); counted once"
        )
    runs = [run for _, run in kept]
    flats = [condition_settings(run.config) for run in runs]
    keys = sorted({k for f in flats for k in f})
    differing = [k for k in keys if len({f.get(k) for f in flats}) > 1]
    if labels is not None:
        names = [labels[os.path.realpath(p)] for p, _ in kept]
    elif differing:
        names = condition_names(differing, flats)
    else:
        names = [str(run.config.get("name", "runs")) for run in runs]
    found = []
    for name, run in zip(names, runs):
        seed = int(run.info.get("seed", run.config.get("seed", 0)))
        found.append((_curve(name, seed, run), run))
    overrides = {
        name: _settings_text(differing, [f for n, f in zip(names, flats) if n == name])
        for name in dict.fromkeys(names)
    }
    how = "by --label" if labels is not None else "by the config values that differ"
    source = Source(
        what=f"{len(runs)} run folders: {', '.join(str(p) for p, _ in kept)}",
        overrides=overrides if differing else {},
        base=f"none: plain run folders, each condition named {how}",
    )
    return f"{len(runs)} runs", source, found, notes


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
    whole = whole_generations(curve.evaluations, budget)
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
            **lineages.at_budget(whole, budget),
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
        row.update(lineages.summary(group))
        rows.append(row)
    return pd.DataFrame(rows)


def _statistics(
    runs: Any, maximise: bool, choice: Design
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[str]]:
    """(pairwise rows of every measure, omnibus rows, notes on small n and missing pairs)."""
    rows, omnibus = [], []
    for measure, column in {**MEASURES, **lineages.measures(runs)}.items():
        samples = _samples(runs, column)
        higher = maximise if measure in MEASURES else True  # a lineage measure: A12 = P(higher)
        rows += pairwise_table(samples, maximise=higher, paired=choice.paired, measure=measure)
        found = omnibus_test(samples, paired=choice.paired, measure=measure)
        if found is not None:
            omnibus.append(found)
    lineages.relabel(rows)
    first = [r for r in rows if r["measure"] == "final best"]
    sizes = runs.groupby("condition", sort=False).size().to_dict()
    notes = [
        small_n_warning(first, sizes, choice, omnibus[0] if omnibus else None),
        *pairing_notes(first),
    ]
    return rows, omnibus, [n for n in notes if n]


# --------------------------------------------------------------------------------------------
# The comparison
# --------------------------------------------------------------------------------------------


def _is_ours(path: Path) -> bool:
    """A file a comparison writes (or the temporary of one a killed comparison left)."""
    name = written_path(path)
    return path.name in FILES or (name is not None and name.name in FILES)


def _check_parents(out: Path) -> None:
    """Refuse (`CompareError`) an ``out`` that cannot be made because the nearest of its
    parents that is there is no folder: a file (``--out notes.txt/cmp``) or a link to
    nothing (``--out dangling/cmp``)."""
    for parent in out.parents:
        if not os.path.lexists(parent):
            continue
        if parent.is_dir():  # a link to a folder included: the path the user named
            return
        if parent.is_symlink():
            raise CompareError(
                f"cannot make {str(out)!r}: {str(parent)!r} is a symbolic link to "
                f"{os.readlink(parent)!r}, which does not exist; name a folder with --out DIR"
            )
        raise CompareError(
            f"cannot make {str(out)!r}: {str(parent)!r} is a file, not a folder; name a "
            "folder with --out DIR"
        )


def prepare_folder(out: Path) -> bool:
    """Check that ``out`` can take a comparison; True where it holds an earlier one (to be
    replaced). A link is refused (`UnsafePathError`: nothing is written through it), and so
    are a file, a folder holding anything a comparison did not write and a folder that
    cannot be made (a parent that is a file or a link to nothing) (`CompareError`)."""
    if out.is_symlink():
        missing = "" if out.exists() else ", which does not exist"
        raise UnsafePathError(
            f"refusing to write the comparison into {str(out)!r}: it is a symbolic link (to "
            f"{os.readlink(out)!r}{missing}); remove the link or name another folder with "
            "--out DIR"
        )
    if not out.exists():
        _check_parents(out)
        return False
    if not out.is_dir():
        what = "a file, not a folder" if out.is_file() else "not a folder"
        raise CompareError(f"{str(out)!r} is {what}: name a folder with --out DIR")
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

    from ariel.recording.analysis import _compare_plots as plots
    from ariel.recording.analysis._compare_html import write_html, write_markdown, write_readme
    from ariel.recording.store import atomic_write, fitness_label

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
    morphology = plots.morphology_series(grouped)
    if morphology:
        comparison.figures["morphology"] = plots.morphology_figure(
            morphology, out / "morphology.png"
        )
    comparison.figures.update(lineages.figure(grouped, comparison.budget, out))
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
    notes: Sequence[str] = (),
    announce: Callable[[str], None] | None = None,
) -> Comparison:
    """Compare ``curves`` (runs with their conditions) and write ``out`` (see the module
    docstring; nothing is written where ``write`` is false); the core of `compare`, usable
    on any evaluations tables. ``paired``: the conditions share seeds (paired tests; why:
    ``reason``); ``at_evaluations``: the budget (default: the smallest run's); ``notes``:
    warnings to put first (`Comparison.notes`); ``announce``: given one line before the
    statistics are computed where there are more than `MANY_CONDITIONS` conditions."""
    import pandas as pd

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
        notes=[n for n in (*notes, budget_note, *found_notes) if n],
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
    paths = [Path(p) for p in paths]
    if not paths:
        raise CompareError("give a campaign folder or run folders to compare")
    if write and out is not None:
        prepare_folder(Path(out))  # refused before the runs are read (again when written)
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
    done = [i for i, (_, run) in enumerate(found) if run.generations_done > 0]
    if not done:
        raise CompareError("no run with a finished generation to compare")
    found = [found[i] for i in done]
    check_comparable([(names[i], found[j][1].config) for j, i in enumerate(done)])
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
        notes=notes,
        announce=announce,
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
